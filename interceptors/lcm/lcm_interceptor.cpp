#include "lcm_interceptor.hpp"

#include <cstring>
#include <random>

#include <nlohmann/json.hpp>

#include "polyport/base/serial_counter.hpp"
#include "polyport/runtime/component_api.hpp"

namespace polyport::lcm {

namespace {

// Service channels on the instance. The caller of every request a server bridge publishes is
// this interceptor's client id: random, so that two polyport processes (or a restarted one)
// on the same channels tell their replies apart.
class ServiceChannels final : public RpcTransport {
 public:
  explicit ServiceChannels(Instance& instance) : instance_(instance) {
    std::random_device random;
    std::int64_t id = 0;
    while (id == 0) id = static_cast<std::int64_t>((std::uint64_t{random()} << 32) | random());
    std::memcpy(client_id_, &id, sizeof id);
  }

  Result<std::unique_ptr<RpcSender>> sender(const RpcLayout& layout) override {
    return std::unique_ptr<RpcSender>(
        std::make_unique<ChannelSender>(instance_, layout.address, client_id_, layout.reply));
  }

  Result<std::unique_ptr<RpcReceiver>> receiver(const RpcLayout& layout, RpcReceive receive) override {
    auto handler = std::make_unique<ChannelReceiver>(instance_, std::move(receive), layout.reply);
    auto subscription = instance_.subscribe(layout.address, *handler);
    if (!subscription) return make_error(subscription.error().message);
    handler->subscription = subscription.value();
    return std::unique_ptr<RpcReceiver>(std::move(handler));
  }

 private:
  class ChannelSender final : public RpcSender {
   public:
    ChannelSender(Instance& instance, std::string channel, const std::uint8_t* client_id, bool reply)
        : instance_(instance), channel_(std::move(channel)), client_id_(client_id), reply_(reply) {}
    Status send(const std::byte* wire, std::uint32_t size) noexcept override {
      if (instance_.publish(channel_.c_str(), wire, size) != 0) {
        failed_.fetch_add(1, std::memory_order_relaxed);
        return Status::error;
      }
      published_.fetch_add(1, std::memory_order_relaxed);
      return Status::ok;
    }
    const std::uint8_t* caller() const noexcept override { return client_id_; }
    void describe(nlohmann::json& operation) const override {
      const std::string what = reply_ ? "replies" : "requests";
      operation[what + "_published"] = published_.load(std::memory_order_relaxed);
      operation[what + "_failed"] = failed_.load(std::memory_order_relaxed);
    }

   private:
    Instance& instance_;
    std::string channel_;
    const std::uint8_t* client_id_;
    bool reply_;
    std::atomic<std::uint64_t> published_{0};
    std::atomic<std::uint64_t> failed_{0};
  };

  class ChannelReceiver final : public RpcReceiver, public MessageHandler {
   public:
    ChannelReceiver(Instance& instance, RpcReceive receive, bool reply)
        : instance_(instance), receive_(std::move(receive)), reply_(reply) {}
    ~ChannelReceiver() override {
      if (subscription != nullptr) instance_.unsubscribe(subscription);  // waits for a handler in progress
    }
    void on_message(const void* data, std::uint32_t size) noexcept override {
      received_.fetch_add(1, std::memory_order_relaxed);
      receive_(static_cast<const std::byte*>(data), size);
    }
    void describe(nlohmann::json& operation) const override {
      operation[reply_ ? "replies_received" : "requests_received"] = received_.load(std::memory_order_relaxed);
    }
    lcm_subscription_t* subscription = nullptr;

   private:
    Instance& instance_;
    RpcReceive receive_;
    bool reply_;
    std::atomic<std::uint64_t> received_{0};
  };

  Instance& instance_;
  std::uint8_t client_id_[8] = {};
};

}  // namespace

void LcmInterceptor::ChannelReader::on_message(const void* data, std::uint32_t size) noexcept {
  if (!active.load(std::memory_order_acquire)) return;
  add_serial(received);  // the instance's receive thread alone counts messages in
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
  // Loop prevention (lcm_instance.hpp, ChannelEchoes): only on a channel polyport also
  // publishes on this instance, and there, while an echo is pending, a hash of the bytes and a
  // few atomic loads.
  if (echoes.publishers.load(std::memory_order_relaxed) != 0 && !echoes.table.empty() &&
      echoes.table.consume(message_fingerprint(data, size), mono_now())) {
    loop_dropped.fetch_add(1, std::memory_order_relaxed);
    return;
  }
  // A message cut short after its fingerprint fails in the codec when a connection decodes
  // it, and is counted there; a passthrough hands it on as the application wrote it.
  (void)channel_.out->write(data, size);
}

Status LcmInterceptor::ChannelWriter::on_sample(const std::byte* data, const SampleMeta& meta) noexcept {
  if (!active.load(std::memory_order_acquire)) return Status::not_active;
  // Recorded before the send: the receive thread may see the echo before publish returns.
  const std::uint32_t subscribers = echoes.subscribers.load(std::memory_order_acquire);
  std::uint64_t fingerprint = 0;
  if (subscribers != 0) {
    fingerprint = message_fingerprint(data, meta.size);
    // Now, not the sample's entry time: a polled or rate-limited connection hands a sample on
    // up to its period later, and an entry stamped then could be expired before it is sent.
    if (!echoes.table.expect(fingerprint, subscribers, mono_now())) echo_unrecorded.fetch_add(1, std::memory_order_relaxed);
  }
  if (instance_.publish(channel_.channel.c_str(), data, meta.size) != 0) {
    if (subscribers != 0) echoes.table.forget(fingerprint);
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
      readers_.push_back(std::make_unique<ChannelReader>(channel, instance_->echoes(channel.channel)));
      writers_.push_back(nullptr);
    } else {
      readers_.push_back(nullptr);
      writers_.push_back(std::make_unique<ChannelWriter>(channel, *instance_));
      channel.in->set_sink(writers_.back().get());  // before wiring: the connection is push mode
    }
  }
  service_channels_ = std::make_unique<ServiceChannels>(*instance_);
  const LcmSettings& settings = adaptor_.settings();
  for (const RpcService& service : adaptor_.services()) {
    if (service.provided != nullptr) {
      servers_.push_back(std::make_unique<ServiceServer>(service, settings.max_calls_in_flight,
                                                         settings.call_timeout_ns, "channel"));
    } else {
      clients_.push_back(std::make_unique<ServiceClient>(service, settings.max_calls_in_flight, "channel"));
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
      reader->echoes.subscribers.fetch_add(1, std::memory_order_acq_rel);
      reader->active.store(true, std::memory_order_release);
    } else {
      writers_[i]->echoes.publishers.fetch_add(1, std::memory_order_acq_rel);
      writers_[i]->active.store(true, std::memory_order_release);
    }
  }
  for (auto& server : servers_) {
    if (auto started = server->start(*service_channels_); !started) {
      stop();
      return make_error(adaptor_.name() + ": " + started.error().message);
    }
  }
  for (auto& client : clients_) {
    if (auto started = client->start(*service_channels_); !started) {
      stop();
      return make_error(adaptor_.name() + ": " + started.error().message);
    }
  }
  if (auto receiving = instance_->receive(); !receiving) {
    stop();
    return make_error(adaptor_.name() + ": " + receiving.error().message);
  }
  active_ = true;
  return {};
}

void LcmInterceptor::stop() noexcept {
  for (auto& client : clients_) client->stop();
  for (auto& server : servers_) server->stop();
  for (auto& reader : readers_) {
    if (!reader) continue;
    reader->active.store(false, std::memory_order_release);
    if (reader->subscription != nullptr) {
      instance_->unsubscribe(reader->subscription);
      reader->subscription = nullptr;
      reader->echoes.subscribers.fetch_sub(1, std::memory_order_acq_rel);
    }
  }
  for (auto& writer : writers_) {
    if (writer && writer->active.exchange(false, std::memory_order_acq_rel)) {
      writer->echoes.publishers.fetch_sub(1, std::memory_order_acq_rel);
    }
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
      // Echoes of what polyport itself published on the channel, not forwarded again.
      c["loop_dropped"] = reader->loop_dropped.load(std::memory_order_relaxed);
    }
    if (const ChannelWriter* writer = writers_[i].get()) {
      c["published"] = writer->published.load(std::memory_order_relaxed);
      c["failed"] = writer->failed.load(std::memory_order_relaxed);
      if (const auto n = writer->echo_unrecorded.load(std::memory_order_relaxed); n != 0) c["echo_unrecorded"] = n;
    }
    channels.push_back(std::move(c));
  }
  nlohmann::json services = nlohmann::json::array();
  for (const auto& server : servers_) {
    nlohmann::json s;
    server->describe(s);
    services.push_back(std::move(s));
  }
  for (const auto& client : clients_) {
    nlohmann::json s;
    client->describe(s);
    services.push_back(std::move(s));
  }
  out["lcm"] = {{"url", instance_->url()}, {"channels", std::move(channels)}, {"services", std::move(services)}};
  if (instance_->log_ended()) out["lcm"]["log_ended"] = true;
  if (nlohmann::json scheduling = instance_->scheduling(); !scheduling.is_null()) {
    out["lcm"]["receive_thread"] = std::move(scheduling);
  }
}

}  // namespace polyport::lcm
