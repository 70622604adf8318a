// The native side of a DDS proxy, for either vendor (the Domain hides which): a raw reader
// per `output` topic and a raw writer per `input` topic of one component, and a service
// bridge per service port (core's polyport/runtime/service_bridge.hpp, over the request and
// reply topics this interceptor opens for it), all on the model's participant for the
// component's domain.
//
// Threads and buffers (forwarding path):
//  - application -> polyport: a Reader's callback runs on the SDK's thread and calls
//    DataOutPort::write with the SDK's serialized bytes, valid for the call. No allocation,
//    no lock here; the connections copy or convert what they keep.
//  - polyport -> application: each `input` port's sink (TopicSink) runs on the upstream
//    writer's thread and hands the bytes, owned by the caller for the call, to
//    Writer::write (the SDK copies them).
// start/stop/describe run on the control thread. stop deletes the readers (the SDK waits for
// a callback in progress) and detaches the writers from their sinks; detached writers are
// deleted with the interceptor, so an upstream writer still inside on_sample never sees a
// freed writer.
#pragma once

#include <atomic>
#include <memory>
#include <string>
#include <vector>

#include "dds_adaptor.hpp"
#include "dds_endpoint.hpp"
#include "polyport/runtime/model.hpp"
#include "polyport/runtime/service_bridge.hpp"

namespace polyport::dds {

class DdsInterceptor final : public Interceptor {
 public:
  // `config`: the vendor configuration the domain was made with, for describe.
  DdsInterceptor(DdsAdaptor& adaptor, std::shared_ptr<Domain> domain, std::string config);
  ~DdsInterceptor() override;

  Result<void> start() override;
  void stop() noexcept override;
  ReturnCode command(LifecycleCommand command) override;
  InterceptorStatus status() const override;
  void describe(nlohmann::json& out) const override;

 private:
  // The sink of one `input` port: publishes each sample on the topic's writer, if any.
  class TopicSink final : public SampleSink {
   public:
    Status on_sample(const std::byte* data, const SampleMeta& meta) noexcept override;
    std::atomic<Writer*> writer{nullptr};
  };

  DdsAdaptor& adaptor_;  // owned by the same Proxy; outlives start/stop
  std::shared_ptr<Domain> domain_;
  std::string config_;
  std::vector<std::unique_ptr<TopicSink>> sinks_;  // one per topic (null for output topics)
  std::vector<std::unique_ptr<Reader>> readers_;   // one per topic while started
  std::vector<std::unique_ptr<Writer>> writers_;   // one per topic while started
  std::vector<std::unique_ptr<Writer>> retired_;   // detached by stop
  // Samples received / refused by the readers stop() has closed, per topic, so that the
  // counts survive a restart and the final statistics (taken after stop) still have them.
  struct ReaderTotals {
    std::uint64_t received = 0;
    std::uint64_t refused = 0;
    std::uint64_t loop_dropped = 0;
  };
  std::vector<ReaderTotals> closed_;
  std::vector<std::unique_ptr<RpcTransport>> service_topics_;  // per service port, in order
  std::vector<std::unique_ptr<ServiceServer>> servers_;       // provided service ports
  std::vector<std::unique_ptr<ServiceClient>> clients_;       // required service ports
  bool active_ = false;
};

}  // namespace polyport::dds
