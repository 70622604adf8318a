#include "lcm_interceptor.hpp"

#include <nlohmann/json.hpp>

#include "polyport/runtime/component_api.hpp"

namespace polyport::lcm {

void LcmInterceptor::ChannelReader::on_message(const void* data, std::uint32_t size) noexcept {
  if (!active.load(std::memory_order_acquire)) return;
  received.fetch_add(1, std::memory_order_relaxed);
  switch (check_message(channel_, data, size)) {
    case MessageCheck::ok:
      break;
    case MessageCheck::too_short:
      too_short.fetch_add(1, std::memory_order_relaxed);
      return;
    case MessageCheck::wrong_fingerprint:
      wrong_fingerprint.fetch_add(1, std::memory_order_relaxed);
      return;
    case MessageCheck::too_large:
      too_large.fetch_add(1, std::memory_order_relaxed);
      return;
  }
  // A message cut short after its fingerprint fails in the codec when a connection decodes
  // it, and is counted there; a passthrough hands it on as the application wrote it.
  (void)channel_.out->write(data, size);
}

Status LcmInterceptor::ChannelWriter::on_sample(const std::byte* data, const SampleMeta& meta) noexcept {
  if (!active.load(std::memory_order_acquire)) return Status::not_active;
  if (instance_.publish(channel_.channel.c_str(), data, meta.size) != 0) {
    failed.fetch_add(1, std::memory_order_relaxed);
    return Status::error;
  }
  published.fetch_add(1, std::memory_order_relaxed);
  return Status::ok;
}

LcmInterceptor::LcmInterceptor(LcmAdaptor& adaptor, std::shared_ptr<Instance> instance)
    : adaptor_(adaptor), instance_(std::move(instance)) {
  for (const LcmAdaptor::Channel& channel : adaptor_.channels()) {
    if (channel.out != nullptr) {
      readers_.push_back(std::make_unique<ChannelReader>(channel));
      writers_.push_back(nullptr);
    } else {
      readers_.push_back(nullptr);
      writers_.push_back(std::make_unique<ChannelWriter>(channel, *instance_));
      channel.in->set_sink(writers_.back().get());  // before wiring: the connection is push mode
    }
  }
}

LcmInterceptor::~LcmInterceptor() { stop(); }

Result<void> LcmInterceptor::start() {
  if (active_) return {};
  if (auto started = instance_->start(); !started) {
    return make_error(adaptor_.name() + ": " + started.error().message);
  }
  const auto& channels = adaptor_.channels();
  for (std::size_t i = 0; i < channels.size(); ++i) {
    if (ChannelReader* reader = readers_[i].get()) {
      auto subscription = instance_->subscribe(channels[i].channel, *reader);
      if (!subscription) {
        stop();
        return make_error(adaptor_.name() + "." + channels[i].out->name() + ": " + subscription.error().message);
      }
      reader->subscription = subscription.value();
      reader->active.store(true, std::memory_order_release);
    } else {
      writers_[i]->active.store(true, std::memory_order_release);
    }
  }
  active_ = true;
  return {};
}

void LcmInterceptor::stop() noexcept {
  for (auto& reader : readers_) {
    if (!reader) continue;
    reader->active.store(false, std::memory_order_release);
    if (reader->subscription != nullptr) {
      instance_->unsubscribe(reader->subscription);
      reader->subscription = nullptr;
    }
  }
  for (auto& writer : writers_) {
    if (writer) writer->active.store(false, std::memory_order_release);
  }
  active_ = false;
}

ReturnCode LcmInterceptor::command(LifecycleCommand command) { return start_stop_command(*this, command); }

InterceptorStatus LcmInterceptor::status() const { return InterceptorStatus{active_ ? "active" : "inactive", 0, 0}; }

void LcmInterceptor::describe(nlohmann::json& out) const {
  nlohmann::json channels = nlohmann::json::array();
  const auto& list = adaptor_.channels();
  for (std::size_t i = 0; i < list.size(); ++i) {
    const LcmAdaptor::Channel& channel = list[i];
    nlohmann::json c{{"port", channel.out ? channel.out->name() : channel.in->name()},
                     {"channel", channel.channel},
                     {"type", channel.type_name},
                     {"max_size", channel.max_size},
                     {"polyport", channel.out ? "subscribes" : "publishes"}};
    if (const ChannelReader* reader = readers_[i].get()) {
      c["received"] = reader->received.load(std::memory_order_relaxed);
      c["wrong_fingerprint"] = reader->wrong_fingerprint.load(std::memory_order_relaxed);
      c["too_short"] = reader->too_short.load(std::memory_order_relaxed);
      c["too_large"] = reader->too_large.load(std::memory_order_relaxed);
    }
    if (const ChannelWriter* writer = writers_[i].get()) {
      c["published"] = writer->published.load(std::memory_order_relaxed);
      c["failed"] = writer->failed.load(std::memory_order_relaxed);
    }
    channels.push_back(std::move(c));
  }
  out["lcm"] = {{"url", instance_->url()}, {"channels", std::move(channels)}};
}

}  // namespace polyport::lcm
