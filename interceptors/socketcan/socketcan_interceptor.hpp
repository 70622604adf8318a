// The native side of a SocketCAN proxy: one CAN_RAW socket on the component's interface,
// whose kernel filters pass exactly the ids of the component's `output` ports (and every
// error frame, CAN_RAW_ERR_FILTER), watched by the model's CanReactor; `input` ports write
// frames on it from their sinks. Input ports with a cycle time hand their frames to a
// CAN_BCM socket instead, whose kernel timer sends the last one every cycle.
//
// Threads and buffers (forwarding path):
//  - bus -> polyport: on the reactor thread. When it waits with io_uring, its ring receives
//    every frame itself (multishot recvmsg into the reactor's buffers, with the SO_TIMESTAMPNS
//    stamp and the drop count) and hands it to on_message, copied onto the stack: no system
//    call of the interceptor's. Otherwise on_readable runs when the socket is readable;
//    recvmmsg copies up to 16 frames with their stamps into the interceptor's receive batch
//    (made and set up once at construction, used by the reactor thread alone) in one system
//    call. Either way on_frame takes each frame:
//    SocketCanAdaptor::receive finds each frame's port by binary search in a sorted array
//    built at construction (no allocation, no lock of ours), checks the length against the
//    DBC message (a wrong one is counted and dropped) and writes the data bytes to the port.
//  - polyport -> bus: an `input` port's sink runs on the upstream writer's thread and builds a
//    can_frame / canfd_frame on its stack. On the reactor thread itself (CAN -> CAN, a frame
//    forwarded from this reactor's receive), when the reactor waits with io_uring, the frame
//    is handed to the reactor (FdReactor::send_with_next_wait: copied into one of its send
//    slots) and goes out with the io_uring_enter that ends the reactor's round, right after
//    the receive handler returns: one system call for the send and the next wait. Elsewhere
//    it is write()n at once. Neither blocks: EAGAIN/ENOBUFS are counted as send_failed (for a
//    handed frame when the kernel reports it, on_send_done; the connection has counted it
//    delivered by then). A periodic port's sink writes a TX_SETUP for its id on
//    the BCM socket instead: the first (and the first after a loss of the interface) with
//    SETTIMER|STARTTIMER|TX_ANNOUNCE at ival2 = the cycle, later ones without flags, which
//    replace the frame's data in place without touching the timer. The sink also keeps the
//    frame (atomics under a sequence lock), so that the tick can start the task again on a
//    re-created BCM socket.
//  - error frames: decoded on the reactor thread into atomics (bus state, counters per
//    kind and class) and written as a CanBusEvent to the optional event port.
//  - supervision: on_tick runs on the reactor thread every tick interval (500 ms) and at once on
//    a link notification of the kernel (CanReactor::watch_links). It
//    asks the kernel for the interface's index and flags; when the interface it was bound
//    to is gone (deleted, or re-added under a new index, or a read saw ENODEV) or was missing
//    at start, it re-creates both sockets with their options, binds / connects them and
//    dup2()s them over the old descriptors, so the descriptor numbers the sinks use never
//    change; it logs each loss, return, down / up and bus-state change and writes their
//    events. It allocates and logs; it is not the forwarding path.
// start/stop/describe run on the control thread. The sockets are created by the first
// start() (unbound while the interface is missing) and closed by the destructor, so a sink
// that races with stop() never writes to a descriptor number that was reused; stop() only
// detaches (atomics), deletes the BCM tasks and leaves the reactor.
#pragma once

#include <linux/can.h>
#include <sys/socket.h>

#include <atomic>
#include <cstdint>
#include <ctime>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "can_reactor.hpp"
#include "polyport/base/clock.hpp"
#include "polyport/runtime/model.hpp"
#include "polyport/runtime/port.hpp"
#include "socketcan_adaptor.hpp"

namespace polyport::socketcan {

class SocketCanInterceptor final : public Interceptor, private MessageHandler, private Supervised {
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
    std::atomic<std::uint64_t> echo_unrecorded{0};  // an echo the full echo table could not record
  };

  // One `input` port: the port's sink sends each sample as a frame, or hands it to the
  // broadcast manager when the message is periodic.
  class FrameWriter final : public SampleSink, public SendTracker {
   public:
    FrameWriter(const SocketCanAdaptor::Message& message, const std::atomic<int>& fd, const std::atomic<int>& bcm_fd,
                Counters& counters, CanEchoes& echoes, bool reads_own_id, FdReactor& reactor)
        : message_(message), fd_(fd), bcm_fd_(bcm_fd), counters_(counters), echoes_(echoes),
          readers_(echoes.readers_of(message.can_id)), reads_own_id_(reads_own_id), reactor_(reactor) {}
    Status on_sample(const std::byte* data, const SampleMeta& meta) noexcept override;
    // A frame handed to the reactor went out (or not); `cookie`: its loop-prevention
    // fingerprint, 0 when none was recorded. Reactor thread.
    void on_send_done(int result, std::uint64_t cookie) noexcept override;
    // Deletes the BCM task (control thread, after `active` went false).
    void unschedule() noexcept;
    // Starts the BCM task again with the last frame sent, if there was one (the tick, after
    // the interface came back and the BCM socket was re-created).
    void reschedule() noexcept;

    std::atomic<bool> active{false};
    // Periodic: the BCM task exists with its timer running.
    std::atomic<bool> scheduled{false};

   private:
    std::atomic<int> in_sink_{0};  // sinks running now (unschedule waits for none)
    // Writes the BCM TX_SETUP of `frame`; true when the kernel took it.
    bool setup(const canfd_frame& frame, std::size_t frame_size, bool first) noexcept;

    // Periodic: the last frame handed to the broadcast manager, for reschedule(), as a
    // sequence lock (the sink writes, the tick reads; odd `sequence_`: being written; 0: none).
    static constexpr std::size_t kFrameWords = sizeof(canfd_frame) / sizeof(std::uint64_t);
    static_assert(sizeof(canfd_frame) % sizeof(std::uint64_t) == 0);
    std::atomic<std::uint32_t> sequence_{0};
    std::atomic<std::uint64_t> last_[kFrameWords]{};

    const SocketCanAdaptor::Message& message_;
    const std::atomic<int>& fd_;
    const std::atomic<int>& bcm_fd_;
    Counters& counters_;
    CanEchoes& echoes_;
    const std::atomic<std::uint32_t>& readers_;  // polyport's raw sockets reading the id
    bool reads_own_id_;  // this interceptor's own socket reads the id (it never gets its own raw frames)
    FdReactor& reactor_;
  };

  // What the interface is, as the last tick saw it.
  enum class Link : int { up, down, missing };

  // recvmmsg's arrays: set up once, so that a wake-up for one frame writes no more than the
  // kernel does (setting up 16 headers on the stack each time stored about 1.3 KiB).
  static constexpr unsigned kBatch = 16;
  static constexpr std::size_t kControl = CMSG_SPACE(sizeof(timespec)) + CMSG_SPACE(sizeof(std::uint32_t));
  struct ReceiveBatch {
    ReceiveBatch() noexcept;
    mmsghdr headers[kBatch];
    canfd_frame frames[kBatch];
    iovec data[kBatch];
    alignas(cmsghdr) char control[kBatch][kControl];
  };

  void on_readable() noexcept override;
  // A frame the reactor's ring received (multishot recvmsg into its buffer).
  void on_message(const std::byte* data, std::uint32_t size, const msghdr& header) noexcept override;
  void on_receive_error(int error) noexcept override;
  std::uint32_t control_bytes() const noexcept override { return kControl; }
  // One received frame (of on_readable's batch, or on_message's), `size` bytes as read, with
  // its timestamp and drop count in `header`'s control messages.
  void on_frame(const canfd_frame& frame, unsigned size, const msghdr& header) noexcept;
  void on_tick() noexcept override;
  void on_error_frame(const canfd_frame& frame, MonoTime t_source) noexcept;
  void emit(CanBusEventKind kind, CanBusState state, MonoTime t_source, std::uint32_t error_class = 0,
            const std::uint8_t* data = nullptr) noexcept;
  // Creates the sockets, unbound (first start).
  Result<void> create_sockets();
  // New sockets with every option, bound / connected to `ifindex`, dup2()ed over the old.
  Result<void> attach(int ifindex);
  bool interface_flags(int& ifindex, bool& up) const noexcept;
  void drain() noexcept;
  // Adds this interceptor's readers (per id) and senders to echoes_, or takes them out.
  void count_in(bool in) noexcept;
  std::string where() const;

  SocketCanAdaptor& adaptor_;  // owned by the same Proxy; outlives start/stop
  std::shared_ptr<CanReactor> reactor_;
  CanEchoes& echoes_;  // the interface's, in the reactor
  bool counted_in_ = false;  // this interceptor's readers and senders are in echoes_ (control thread)
  std::atomic<std::uint64_t> loop_dropped_{0};  // echoes of polyport's own frames, dropped
  std::unique_ptr<Counters[]> counters_;                // per message
  std::vector<std::unique_ptr<FrameWriter>> writers_;  // per message; null for output ports
  std::atomic<int> fd_{-1};
  std::atomic<int> bcm_fd_{-1};  // -1 when no port is periodic
  bool periodic_ = false;
  std::atomic<bool> receiving_{false};
  // Supervision (written by the tick or by start before watch(); read by describe).
  int bound_ifindex_ = 0;           // 0: not bound (missing)
  bool was_up_ = true;
  bool had_interface_ = false;      // a return counts as a recovery only after a loss / a missing start
  std::string last_attach_error_;   // logged once until it changes
  std::int32_t logged_bus_state_ = 0;
  std::atomic<int> link_{static_cast<int>(Link::missing)};
  std::atomic<int> ifindex_{0};
  std::atomic<bool> lost_{false};   // a read saw ENODEV
  std::atomic<std::uint64_t> losses_{0};
  std::atomic<std::uint64_t> recoveries_{0};
  std::atomic<std::uint64_t> went_down_{0};
  std::atomic<std::uint64_t> came_up_{0};
  std::atomic<std::uint64_t> attach_failures_{0};
  // Error frames (reactor thread).
  std::atomic<std::int32_t> bus_state_{0};  // CanBusState
  std::atomic<std::uint64_t> error_frames_{0};
  std::atomic<std::uint64_t> error_kinds_[6]{};   // by CanBusEventKind error_frame .. error_active
  std::atomic<std::uint64_t> error_classes_[10]{};  // by class bit, CAN_ERR_TX_TIMEOUT .. CAN_ERR_CNT
  std::atomic<std::uint32_t> tx_errors_{0};
  std::atomic<std::uint32_t> rx_errors_{0};
  std::atomic<std::uint64_t> events_{0};
  // Frames that passed the kernel filter but match no port: stays 0 while the filters work.
  std::atomic<std::uint64_t> unknown_id_{0};
  std::atomic<std::uint64_t> read_errors_{0};
  // SO_RXQ_OVFL: frames the kernel dropped on a full receive buffer, on the current socket
  // (reactor thread) and on the sockets before it (added up by attach()).
  std::atomic<std::uint32_t> dropped_{0};
  std::atomic<std::uint64_t> dropped_before_{0};
  // CLOCK_MONOTONIC - CLOCK_REALTIME, measured at start: SO_TIMESTAMPNS stamps frames with
  // CLOCK_REALTIME, polyport's t_source is CLOCK_MONOTONIC. A wall-clock step after start
  // shifts the converted stamps by the step until the next start.
  Nanos realtime_to_mono_{};
  std::unique_ptr<ReceiveBatch> batch_ = std::make_unique<ReceiveBatch>();  // reactor thread
  bool registered_ = false;
  bool rewatch_ = false;  // attach() could not watch the new socket: the next attach() tries again
  bool active_ = false;
};

}  // namespace polyport::socketcan
