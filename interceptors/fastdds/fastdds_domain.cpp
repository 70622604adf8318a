// FastddsDomain: dds::Domain over raw_type's Participant, RawWriter and RawReader (threads
// and ownership: fastdds_domain.hpp).
#include "fastdds_domain.hpp"

#include <atomic>

#include "raw_type.hpp"

namespace polyport::fastdds {

namespace {

std::uint32_t max_size_of(const dds::EndpointSpec& spec) {
  return spec.max_size != 0 ? spec.max_size : kDefaultMaxPayload;
}

class FastddsWriter final : public dds::Writer {
 public:
  explicit FastddsWriter(std::unique_ptr<RawWriter> writer) : writer_(std::move(writer)) {}
  Status write(const std::byte* cdr, std::uint32_t size) noexcept override { return writer_->write(cdr, size); }
  std::int32_t matched_readers() const noexcept override { return writer_->matched_readers(); }
  dds::Guid guid() const noexcept override { return writer_->guid(); }

 private:
  std::unique_ptr<RawWriter> writer_;
};

class FastddsDomain final : public dds::Domain {
 public:
  explicit FastddsDomain(std::unique_ptr<Participant> participant) : participant_(std::move(participant)) {}
  ~FastddsDomain() override = default;
  std::string_view vendor() const noexcept override { return "fastdds"; }
  std::uint32_t id() const noexcept override { return participant_->domain_id(); }

  Result<std::unique_ptr<dds::Writer>> create_writer(const dds::EndpointSpec& spec) override {
    auto writer = RawWriter::create(*participant_, spec.topic, spec.type_name, spec.qos, max_size_of(spec));
    if (!writer) return writer.error();
    return std::unique_ptr<dds::Writer>(std::make_unique<FastddsWriter>(std::move(writer).value()));
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
        max_size_of(spec));
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

   private:
    std::unique_ptr<RawReader> reader_;
    std::shared_ptr<std::atomic<std::uint64_t>> counter_;
  };

  std::unique_ptr<Participant> participant_;
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
  return std::unique_ptr<dds::Domain>(std::make_unique<FastddsDomain>(std::move(participant).value()));
}

}  // namespace polyport::fastdds
