// The native side of a SocketCAN proxy: one CAN_RAW socket on the component's interface,
// whose kernel filters pass exactly the ids of the component's `output` ports, watched by the
// model's CanReactor; `input` ports write frames on it from their sinks.
//
// Threads and buffers (forwarding path):
//  - bus -> polyport: on_readable runs on the reactor thread; recvmsg copies each frame and
//    its SO_TIMESTAMPNS stamp into locals, the port is found by binary search in a sorted
//    array built at construction (no allocation, no lock of ours), the length is checked
//    against the DBC message (a wrong one is counted and dropped) and the data bytes go to
//    DataOutPort::write.
//  - polyport -> bus: an `input` port's sink runs on the upstream writer's thread, builds a
//    can_frame / canfd_frame on its stack and write()s it without blocking (EAGAIN/ENOBUFS
//    are counted as send_failed).
// start/stop/describe run on the control thread. The socket is opened by the first start()
// and closed by the destructor, so a sink that races with stop() never writes to a
// descriptor number that was reused; stop() only detaches (atomics) and leaves the reactor.
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <utility>
#include <vector>

#include "can_reactor.hpp"
#include "polyport/base/clock.hpp"
#include "polyport/runtime/model.hpp"
#include "polyport/runtime/port.hpp"
#include "socketcan_adaptor.hpp"

namespace polyport::socketcan {

class SocketCanInterceptor final : public Interceptor, private ReadableHandler {
 public:
  SocketCanInterceptor(SocketCanAdaptor& adaptor, std::shared_ptr<CanReactor> reactor);
  ~SocketCanInterceptor() override;

  Result<void> start() override;
  void stop() noexcept override;
  ReturnCode command(LifecycleCommand command) override;
  InterceptorStatus status() const override;
  void describe(nlohmann::json& out) const override;

 private:
  // Counters of one port; `received` and `bad_length` for output ports, the others for input.
  struct Counters {
    std::atomic<std::uint64_t> received{0};
    std::atomic<std::uint64_t> bad_length{0};
    std::atomic<std::uint64_t> sent{0};
    std::atomic<std::uint64_t> send_failed{0};
  };

  // One `input` port: the port's sink sends each sample as a frame.
  class FrameWriter final : public SampleSink {
   public:
    FrameWriter(const SocketCanAdaptor::Message& message, const std::atomic<int>& fd, Counters& counters)
        : message_(message), fd_(fd), counters_(counters) {}
    Status on_sample(const std::byte* data, const SampleMeta& meta) noexcept override;

    std::atomic<bool> active{false};

   private:
    const SocketCanAdaptor::Message& message_;
    const std::atomic<int>& fd_;
    Counters& counters_;
  };

  void on_readable() noexcept override;
  Result<void> open_socket();
  void drain() noexcept;

  SocketCanAdaptor& adaptor_;  // owned by the same Proxy; outlives start/stop
  std::shared_ptr<CanReactor> reactor_;
  std::unique_ptr<Counters[]> counters_;                // per message
  std::vector<std::unique_ptr<FrameWriter>> writers_;  // per message; null for output ports
  // (can_id, message index) of the output ports, sorted: the receive path's lookup.
  std::vector<std::pair<std::uint32_t, std::uint32_t>> by_can_id_;
  std::atomic<int> fd_{-1};
  std::atomic<bool> receiving_{false};
  // Frames that passed the kernel filter but match no port: stays 0 while the filters work.
  std::atomic<std::uint64_t> unknown_id_{0};
  std::atomic<std::uint64_t> read_errors_{0};
  // CLOCK_MONOTONIC - CLOCK_REALTIME, measured at start: SO_TIMESTAMPNS stamps frames with
  // CLOCK_REALTIME, polyport's t_source is CLOCK_MONOTONIC. A wall-clock step after start
  // shifts the converted stamps by the step until the next start.
  Nanos realtime_to_mono_{};
  bool registered_ = false;
  bool active_ = false;
};

}  // namespace polyport::socketcan
