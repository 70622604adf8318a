#include "cyclonedds_domain.hpp"

#include "raw_topic.hpp"

namespace polyport::cyclonedds {

namespace {

class CycloneWriter final : public dds::Writer {
 public:
  explicit CycloneWriter(std::unique_ptr<RawWriter> writer) : writer_(std::move(writer)) {}
  Status write(const std::byte* cdr, std::uint32_t size) noexcept override { return writer_->write(cdr, size); }
  std::int32_t matched_readers() const noexcept override { return writer_->matched_readers(); }
  dds::Guid guid() const noexcept override { return writer_->guid(); }

 private:
  std::unique_ptr<RawWriter> writer_;
};

// Callbacks of one reader do not overlap: Cyclone calls a reader's data-available listener
// from one thread at a time (its delivery thread for remote data; for data written in this
// process, the writer's thread, under the reader's listener lock).
class CycloneReader final : public dds::Reader {
 public:
  explicit CycloneReader(std::unique_ptr<RawReader> reader) : reader_(std::move(reader)) {}
  std::int32_t matched_writers() const noexcept override { return reader_->matched_writers(); }
  std::uint64_t received() const noexcept override { return reader_->received(); }
  // A raw sertype takes any bytes: nothing is refused before the callback.
  std::uint64_t refused() const noexcept override { return 0; }
  // Cyclone never delivers polyport's own samples to it (ignorelocal, below): none to drop.
  std::uint64_t loop_dropped() const noexcept override { return 0; }

 private:
  std::unique_ptr<RawReader> reader_;
};

// Loop prevention: every endpoint of the domain ignores the participant's own (Cyclone's
// ignorelocal QoS), so a sample polyport wrote is never delivered to polyport's readers of
// the topic, neither read back nor forwarded again when a profile bridges the topic both
// ways. Cyclone decides it when endpoints match, so nothing is spent per sample; and no
// write of polyport's runs a reader's listener of polyport's on the writing thread, which
// is what would deadlock a bridge both ways across two domains or vendors (a reader's
// listener writing while another writer's delivery waits for that listener to finish).
class CycloneDomain final : public dds::Domain {
 public:
  explicit CycloneDomain(std::unique_ptr<Participant> participant) : participant_(std::move(participant)) {}
  std::string_view vendor() const noexcept override { return "cyclonedds"; }
  std::uint32_t id() const noexcept override { return participant_->domain_id(); }

  Result<std::unique_ptr<dds::Writer>> create_writer(const dds::EndpointSpec& spec) override {
    auto writer = RawWriter::create(*participant_, spec.topic, spec.type_name, spec.qos, true);
    if (!writer) return writer.error();
    return std::unique_ptr<dds::Writer>(std::make_unique<CycloneWriter>(std::move(writer).value()));
  }

  Result<std::unique_ptr<dds::Reader>> create_reader(const dds::EndpointSpec& spec,
                                                     dds::ReceiveCallback callback) override {
    auto reader = RawReader::create(*participant_, spec.topic, spec.type_name, std::move(callback), spec.qos, true);
    if (!reader) return reader.error();
    return std::unique_ptr<dds::Reader>(std::make_unique<CycloneReader>(std::move(reader).value()));
  }

 private:
  std::unique_ptr<Participant> participant_;
};

}  // namespace

std::string default_config() { return POLYPORT_CYCLONE_DEFAULT_CONFIG; }

std::string with_thread_scheduling(const std::string& config, const ThreadScheduling& scheduling) {
  if (!scheduling.realtime()) return config;
  std::string threads;
  for (const char* name : {"recv", "dq.user", "tev"}) {
    threads += std::string("<Thread name=\"") + name + "\"><Scheduling><Class>realtime</Class><Priority>" +
               std::to_string(scheduling.priority) + "</Priority></Scheduling></Thread>";
  }
  // Cyclone 0.10 configures threads by name and knows no "recvUC" / "recvMC" (the threads it
  // adds for multiple receive threads): one receive thread, "recv", then takes every packet.
  const std::string fragment = "<CycloneDDS><Domain><Threads>" + threads +
                               "</Threads><Internal><MultipleReceiveThreads>false</MultipleReceiveThreads></Internal>"
                               "</Domain></CycloneDDS>";
  if (config.empty()) return fragment;
  const auto first = config.find_first_not_of(" \t\r\n");
  const bool xml = first != std::string::npos && config[first] == '<';
  return (xml || config.rfind("file://", 0) == 0 ? config : "file://" + config) + "," + fragment;
}

Result<std::unique_ptr<dds::Domain>> make_cyclonedds_domain(std::uint32_t domain_id, const std::string& config) {
  auto participant = Participant::create(domain_id, config);
  if (!participant) return participant.error();
  return std::unique_ptr<dds::Domain>(std::make_unique<CycloneDomain>(std::move(participant).value()));
}

}  // namespace polyport::cyclonedds
