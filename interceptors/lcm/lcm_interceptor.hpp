// The native side of an LCM proxy: a subscription per `output` channel and a publisher per
// `input` channel of one component, and a service bridge per service port (core's
// polyport/runtime/service_bridge.hpp over the request and reply channels this interceptor
// subscribes and publishes for it), on the model's instance for the component's URL.
//
// Threads and buffers (forwarding path):
//  - application -> polyport: a subscription's handler runs on the instance's receive
//    thread with LCM's buffer (valid for the call), checks size and fingerprint (a wrong one
//    is counted and dropped) and calls DataOutPort::write. No allocation, no lock of ours.
//  - polyport -> application: an `input` port's sink runs on the upstream writer's thread
//    and hands the bytes to lcm_publish (LCM copies them into its datagrams).
//  - services: requests and replies go the same ways (a subscription's handler on the
//    receive thread, lcm_publish on the caller's or the completing provider's thread), into
//    and out of the bridges' preallocated slots.
// start/stop/describe run on the control thread. Handlers and sinks live as long as the
// interceptor; stop detaches them (atomics), so a late call finds nothing to forward to.
#pragma once

#include <atomic>
#include <memory>
#include <string>
#include <vector>

#include "lcm_adaptor.hpp"
#include "lcm_instance.hpp"
#include "polyport/runtime/model.hpp"
#include "polyport/runtime/port.hpp"
#include "polyport/runtime/service_bridge.hpp"

namespace polyport::lcm {

class LcmInterceptor final : public Interceptor {
 public:
  LcmInterceptor(LcmAdaptor& adaptor, std::shared_ptr<Instance> instance);
  ~LcmInterceptor() override;

  Result<void> start() override;
  void stop() noexcept override;
  ReturnCode command(LifecycleCommand command) override;
  InterceptorStatus status() const override;
  void describe(nlohmann::json& out) const override;

 private:
  // One `output` channel: what the application publishes, into the port.
  class ChannelReader final : public MessageHandler {
   public:
    ChannelReader(const LcmAdaptor::Channel& channel, ChannelEchoes& channel_echoes)
        : echoes(channel_echoes), channel_(channel) {}
    void on_message(const void* data, std::uint32_t size) noexcept override;

    ChannelEchoes& echoes;  // the channel's on the instance (loop prevention)

    std::atomic<bool> active{false};
    std::atomic<std::uint64_t> received{0};
    // Echoes of polyport's own publishes on the channel, dropped (loop prevention).
    std::atomic<std::uint64_t> loop_dropped{0};
    std::atomic<std::uint64_t> wrong_fingerprint{0};
    std::atomic<std::uint64_t> too_short{0};
    std::atomic<std::uint64_t> too_large{0};
    lcm_subscription_t* subscription = nullptr;  // control thread

   private:
    const LcmAdaptor::Channel& channel_;
  };

  // One `input` channel: the port's sink publishes each sample.
  class ChannelWriter final : public SampleSink {
   public:
    ChannelWriter(const LcmAdaptor::Channel& channel, Instance& instance)
        : echoes(instance.echoes(channel.channel)), channel_(channel), instance_(instance) {}
    Status on_sample(const std::byte* data, const SampleMeta& meta) noexcept override;

    ChannelEchoes& echoes;  // the channel's on the instance (loop prevention)

    std::atomic<bool> active{false};
    std::atomic<std::uint64_t> published{0};
    std::atomic<std::uint64_t> failed{0};
    // Publishes whose echo could not be recorded (every nearby slot held a live entry).
    std::atomic<std::uint64_t> echo_unrecorded{0};

   private:
    const LcmAdaptor::Channel& channel_;
    Instance& instance_;
  };

  LcmAdaptor& adaptor_;  // owned by the same Proxy; outlives start/stop
  std::shared_ptr<Instance> instance_;
  std::vector<std::unique_ptr<ChannelReader>> readers_;  // per channel; null for input channels
  std::vector<std::unique_ptr<ChannelWriter>> writers_;  // per channel; null for output channels
  std::unique_ptr<RpcTransport> service_channels_;       // the services' channels
  std::vector<std::unique_ptr<ServiceServer>> servers_;  // provided service ports
  std::vector<std::unique_ptr<ServiceClient>> clients_;  // required service ports
  bool active_ = false;
};

}  // namespace polyport::lcm
