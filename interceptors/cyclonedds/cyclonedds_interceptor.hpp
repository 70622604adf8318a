// The native side of a Cyclone DDS proxy: a raw reader per `output` topic and a raw writer
// per `input` topic of one component, on the model's participant for its domain.
//
// Threads and buffers (forwarding path):
//  - application -> polyport: a RawReader's callback runs on Cyclone's thread (listener /
//    receive thread, or the writing thread for local data) and calls DataOutPort::write with
//    Cyclone's serialized bytes, which Cyclone owns for the duration of the call. No
//    allocation, no lock here; the connections copy or convert what they keep.
//  - polyport -> application: each `input` port's sink (TopicSink) runs on the upstream
//    writer's thread and hands the bytes, owned by the caller for the call, to
//    RawWriter::write (Cyclone copies them into its one sample buffer per write).
// start/stop/describe run on the control thread. stop deletes the readers (Cyclone waits for
// a callback in progress) and detaches the writers from their sinks; detached writers are
// deleted with the interceptor, so an upstream writer still inside on_sample never sees a
// freed writer.
#pragma once

#include <atomic>
#include <memory>
#include <string>
#include <vector>

#include "cyclonedds_adaptor.hpp"
#include "polyport/model.hpp"
#include "raw_topic.hpp"

namespace polyport::cyclonedds {

class CycloneInterceptor final : public Interceptor {
 public:
  CycloneInterceptor(CycloneAdaptor& adaptor, std::shared_ptr<Participant> participant, std::string config);
  ~CycloneInterceptor() override;

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
    std::atomic<RawWriter*> writer{nullptr};
  };

  CycloneAdaptor& adaptor_;  // owned by the same Proxy; outlives start/stop
  std::shared_ptr<Participant> participant_;
  std::string config_;  // for describe
  std::vector<std::unique_ptr<TopicSink>> sinks_;    // one per topic (null for output topics)
  std::vector<std::unique_ptr<RawReader>> readers_;  // one per topic while started
  std::vector<std::unique_ptr<RawWriter>> writers_;  // one per topic while started
  std::vector<std::unique_ptr<RawWriter>> retired_;  // detached by stop
  bool active_ = false;
};

}  // namespace polyport::cyclonedds
