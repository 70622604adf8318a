// FastddsDomain: dds::Domain over raw_type's Participant, RawWriter and RawReader (threads
// and ownership: fastdds_domain.hpp).
#include "fastdds_domain.hpp"

#include <atomic>
#include <map>

#include <fastrtps/xmlparser/XMLProfileManager.h>

#include "raw_type.hpp"

namespace polyport::fastdds {

namespace {

std::uint32_t max_size_of(const dds::EndpointSpec& spec) {
  return spec.max_size != 0 ? spec.max_size : kDefaultMaxPayload;
}

// Keyed by entity id in the topic's set of polyport's writers while it exists.
class FastddsWriter final : public dds::Writer {
 public:
  FastddsWriter(std::unique_ptr<RawWriter> writer, std::shared_ptr<dds::OwnWriters> own)
      : writer_(std::move(writer)), own_(std::move(own)), key_(writer_->own_key()) {
    if (!own_->add(key_)) key_ = 0;
  }
  ~FastddsWriter() override {
    writer_.reset();
    own_->remove(key_);
  }
  Status write(const std::byte* cdr, std::uint32_t size) noexcept override { return writer_->write(cdr, size); }
  std::int32_t matched_readers() const noexcept override { return writer_->matched_readers(); }
  dds::Guid guid() const noexcept override { return writer_->guid(); }

 private:
  std::unique_ptr<RawWriter> writer_;
  std::shared_ptr<dds::OwnWriters> own_;
  std::uint64_t key_;  // 0: not in the set (it was full)
};

// Loop prevention: a reader of the domain drops every sample of a writer of its own
// participant on its topic (own_writers.hpp: the publication handle is the writer's GUID, its
// entity id looked up among polyport's writers of the topic), counted as loop_dropped. Fast
// DDS 2.9 has no QoS that keeps a participant's own endpoints from matching (Cyclone's
// ignorelocal), so the samples do arrive; intra-process delivery is switched off
// (make_fastdds_domain) so that they arrive on Fast DDS's receive threads and never inside
// the writing thread's write(): there Fast DDS runs the reader's listener under the reader's
// mutex, and a bridge both ways across two domains deadlocks (a listener on each side
// writing into the other side's reader while that one's listener holds its mutex).
class FastddsDomain final : public dds::Domain {
 public:
  explicit FastddsDomain(std::unique_ptr<Participant> participant) : participant_(std::move(participant)) {}
  ~FastddsDomain() override = default;
  std::string_view vendor() const noexcept override { return "fastdds"; }
  std::uint32_t id() const noexcept override { return participant_->domain_id(); }

  Result<std::unique_ptr<dds::Writer>> create_writer(const dds::EndpointSpec& spec) override {
    auto writer =
        RawWriter::create(*participant_, spec.topic, spec.type_name, spec.qos, max_size_of(spec), spec.bounded);
    if (!writer) return writer.error();
    return std::unique_ptr<dds::Writer>(
        std::make_unique<FastddsWriter>(std::move(writer).value(), own_writers(spec.topic)));
  }

  Result<std::unique_ptr<dds::Reader>> create_reader(const dds::EndpointSpec& spec,
                                                     dds::ReceiveCallback callback) override {
    // The count lives in the wrapper, which exists before the first sample can arrive.
    auto counter = std::make_shared<std::atomic<std::uint64_t>>(0);
    auto reader = RawReader::create(
        *participant_, spec.topic, spec.type_name, spec.qos,
        [callback = std::move(callback), counter](const std::byte* cdr, std::uint32_t size, MonoTime source) {
          callback(cdr, size, source);
          counter->fetch_add(1, std::memory_order_relaxed);
        },
        max_size_of(spec), false, own_writers(spec.topic), spec.bounded);
    if (!reader) return reader.error();
    return std::unique_ptr<dds::Reader>(std::make_unique<CountedReader>(std::move(reader).value(), counter));
  }

 private:
  // Callbacks of one reader do not overlap: RawReader takes its samples through a DrainGate
  // (Fast DDS may call the listener from its receive thread and, for writers in this
  // process, from the writing thread).
  class CountedReader final : public dds::Reader {
   public:
    CountedReader(std::unique_ptr<RawReader> reader, std::shared_ptr<std::atomic<std::uint64_t>> counter)
        : reader_(std::move(reader)), counter_(std::move(counter)) {}
    std::int32_t matched_writers() const noexcept override { return reader_->matched_writers(); }
    std::uint64_t received() const noexcept override { return counter_->load(std::memory_order_relaxed); }
    std::uint64_t refused() const noexcept override { return reader_->refused(); }
    std::uint64_t loop_dropped() const noexcept override { return reader_->loop_dropped(); }

   private:
    std::unique_ptr<RawReader> reader_;
    std::shared_ptr<std::atomic<std::uint64_t>> counter_;
  };

  // Control thread. Entries stay while the domain does (one small set per topic name).
  std::shared_ptr<dds::OwnWriters> own_writers(const std::string& topic) {
    auto& own = own_[topic];
    if (!own) own = std::make_shared<dds::OwnWriters>();
    return own;
  }

  std::unique_ptr<Participant> participant_;
  std::map<std::string, std::shared_ptr<dds::OwnWriters>> own_;
};

}  // namespace

std::string default_config() { return POLYPORT_FASTDDS_DEFAULT_CONFIG; }

Result<std::unique_ptr<dds::Domain>> make_fastdds_domain(std::uint32_t domain_id, const std::string& config) {
  ParticipantOptions options;
  options.domain_id = domain_id;
  options.profiles_file = config;
  if (config.empty()) options.transport = Transport::fastdds_defaults;
  auto participant = Participant::create(options);
  if (!participant) return participant.error();
  // Loop prevention and deadlock freedom (see FastddsDomain): no intra-process delivery in
  // polyport's process. Process-wide, read when endpoints match, so set after the profiles
  // file (which may carry library settings) and before any endpoint exists.
  try {
    eprosima::fastrtps::LibrarySettingsAttributes library =
        eprosima::fastrtps::xmlparser::XMLProfileManager::library_settings();
    library.intraprocess_delivery = eprosima::fastrtps::INTRAPROCESS_OFF;
    eprosima::fastrtps::xmlparser::XMLProfileManager::library_settings(library);
  } catch (...) {
    return make_error("fastdds: cannot switch intra-process delivery off");
  }
  return std::unique_ptr<dds::Domain>(std::make_unique<FastddsDomain>(std::move(participant).value()));
}

}  // namespace polyport::fastdds
