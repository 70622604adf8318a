#include "cyclonedds_interceptor.hpp"

#include <nlohmann/json.hpp>

#include "polyport/component_api.hpp"

namespace polyport::cyclonedds {

Status CycloneInterceptor::TopicSink::on_sample(const std::byte* data, const SampleMeta& meta) noexcept {
  RawWriter* w = writer.load(std::memory_order_acquire);
  if (w == nullptr) return Status::not_active;
  return w->write(data, meta.size);
}

CycloneInterceptor::CycloneInterceptor(CycloneAdaptor& adaptor, std::shared_ptr<Participant> participant,
                                       std::string config)
    : adaptor_(adaptor), participant_(std::move(participant)), config_(std::move(config)) {
  for (const CycloneAdaptor::Topic& topic : adaptor_.topics()) {
    if (topic.in != nullptr) {
      sinks_.push_back(std::make_unique<TopicSink>());
      topic.in->set_sink(sinks_.back().get());  // before wiring: the connection is push mode
    } else {
      sinks_.push_back(nullptr);
    }
  }
}

CycloneInterceptor::~CycloneInterceptor() {
  stop();
  retired_.clear();
}

Result<void> CycloneInterceptor::start() {
  if (active_) return {};
  const auto& topics = adaptor_.topics();
  readers_.resize(topics.size());
  writers_.resize(topics.size());
  for (std::size_t i = 0; i < topics.size(); ++i) {
    const CycloneAdaptor::Topic& topic = topics[i];
    if (topic.out != nullptr) {
      DataOutPort* port = topic.out;
      auto reader = RawReader::create(
          *participant_, topic.topic, topic.type_name,
          [port](const std::byte* cdr, std::uint32_t size, MonoTime source_timestamp) {
            (void)port->write(cdr, size, source_timestamp);
          });
      if (!reader) {
        stop();
        return make_error(adaptor_.name() + "." + port->name() + ": " + reader.error().message);
      }
      readers_[i] = std::move(reader).value();
    } else {
      auto writer = RawWriter::create(*participant_, topic.topic, topic.type_name);
      if (!writer) {
        stop();
        return make_error(adaptor_.name() + "." + topic.in->name() + ": " + writer.error().message);
      }
      writers_[i] = std::move(writer).value();
      sinks_[i]->writer.store(writers_[i].get(), std::memory_order_release);
    }
  }
  active_ = true;
  return {};
}

void CycloneInterceptor::stop() noexcept {
  for (auto& reader : readers_) reader.reset();
  for (std::size_t i = 0; i < writers_.size(); ++i) {
    if (sinks_[i]) sinks_[i]->writer.store(nullptr, std::memory_order_release);
    if (writers_[i]) retired_.push_back(std::move(writers_[i]));
  }
  readers_.clear();
  writers_.clear();
  active_ = false;
}

ReturnCode CycloneInterceptor::command(LifecycleCommand command) {
  switch (command) {
    case LifecycleCommand::initialize:
    case LifecycleCommand::activate:
      return start() ? ReturnCode::ok : ReturnCode::error;
    case LifecycleCommand::deactivate:
    case LifecycleCommand::finalize:
      stop();
      return ReturnCode::ok;
    case LifecycleCommand::reset:
    case LifecycleCommand::recover:
      return ReturnCode::unsupported;
  }
  return ReturnCode::unsupported;
}

InterceptorStatus CycloneInterceptor::status() const {
  // Samples Cyclone refused are counted by the connections (dropped_sink_error).
  return InterceptorStatus{active_ ? "active" : "inactive", 0, 0};
}

void CycloneInterceptor::describe(nlohmann::json& out) const {
  nlohmann::json topics = nlohmann::json::array();
  const auto& list = adaptor_.topics();
  for (std::size_t i = 0; i < list.size(); ++i) {
    const CycloneAdaptor::Topic& topic = list[i];
    nlohmann::json t{{"port", topic.out ? topic.out->name() : topic.in->name()},
                     {"topic", topic.topic},
                     {"type", topic.type_name},
                     {"polyport", topic.out ? "reads" : "writes"}};
    if (i < readers_.size() && readers_[i]) {
      t["matched_writers"] = readers_[i]->matched_writers();
      t["received"] = readers_[i]->received();
    }
    if (i < writers_.size() && writers_[i]) t["matched_readers"] = writers_[i]->matched_readers();
    topics.push_back(std::move(t));
  }
  out["dds"] = {{"domain", participant_->domain_id()}, {"config", config_}, {"topics", std::move(topics)}};
}

}  // namespace polyport::cyclonedds
