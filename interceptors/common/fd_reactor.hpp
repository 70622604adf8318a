// One thread that waits on many descriptors and calls their handlers: the receive thread a
// model shares between all its sockets (SocketCAN: every CAN socket of the daemon; LCM: every
// LCM instance's notify descriptor). The model hands it out; the interceptors hold it; it goes
// with the last of them.
//
// How it waits (ReactorIo): epoll_wait, or an io_uring. With the ring a descriptor is a one-shot
// poll armed again after its handler ran (level-triggered, as the epoll set is), or, for a
// datagram socket added with add_receiver(), a multishot recvmsg whose messages the reactor
// hands its MessageHandler; and a handler may hand the kernel a send with the thread's next wait
// (send_with_next_wait): the one io_uring_enter that ends a round both sends what the round's
// handlers forwarded and waits for the next message, where epoll_wait() + recvmmsg() + write()
// are three system calls. The SocketCAN model
// asks for the ring (polyportd --can-io); the thread falls back to epoll where the kernel gives
// none (io_uring_setup refused: an old kernel, a seccomp filter, kernel.io_uring_disabled).
//
// Threads: the reactor thread waits on the registered descriptors and a wake-up eventfd, and
// calls a descriptor's handler when it is readable, so handlers run on it. add() and remove()
// run on the control thread; after remove() returns, the handler is not running and is not
// called again, so its owner may close the descriptor and go away (with the ring, once its
// SendTracker has no send in flight either). With the ring only the reactor thread touches the
// submission queue: add() and remove() hand it the change (through the wake-up descriptor) and
// wait until it is made.
// The same thread can run a supervision tick: once something is watched, every tick interval
// (kTickInterval unless the subclass sets another, which must be positive: zero or less means
// kTickInterval; a timerfd in the same set) it calls on_tick() of each watched Supervised,
// which may re-create descriptors, log and report; the tick is not the forwarding path (it
// may allocate and log) and never runs concurrently with a handler (tick_now() runs it from
// one, on the same thread), so both may write the same ports. watch() and unwatch() run on the
// control thread; after unwatch() returns, on_tick is not running and is not called again.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <sys/socket.h>

#include <nlohmann/json_fwd.hpp>

#include "polyport/base/result.hpp"
#include "polyport/runtime/thread_scheduling.hpp"

namespace polyport {

// Reads what is queued on one descriptor, on the reactor thread. No allocation, no lock.
class ReadableHandler {
 public:
  virtual ~ReadableHandler() = default;
  virtual void on_readable() noexcept = 0;
};

// A datagram socket whose messages the reactor may receive itself. With the ring, a multishot
// recvmsg puts each message in one of the reactor's buffers and on_message() gets it where it
// lies: the handler makes no system call, so a frame forwarded on the reactor thread costs it one
// io_uring_enter in all (its send and the next wait). With epoll, or a kernel without multishot
// recvmsg (before 6.0), the reactor calls on_readable() as for any handler, which reads itself.
class MessageHandler : public ReadableHandler {
 public:
  // One message, reactor thread: its bytes (at most kMessageBytes: a CAN FD frame) and a msghdr
  // whose msg_control / msg_controllen hold its control messages (CMSG_FIRSTHDR and
  // CMSG_NXTHDR work on it) and whose msg_flags are the message's (MSG_DONTROUTE, MSG_TRUNC...).
  virtual void on_message(const std::byte* data, std::uint32_t size, const msghdr& header) noexcept = 0;
  // A receive failed with `error` (an errno, e.g. ENODEV: the interface went away); the
  // reactor receives again.
  virtual void on_receive_error(int error) noexcept = 0;
  // The room its control messages take (the CMSG_SPACE of each option set on the socket), at
  // most kControlBytes.
  virtual std::uint32_t control_bytes() const noexcept = 0;

  static constexpr std::uint32_t kMessageBytes = 72;
  static constexpr std::uint32_t kControlBytes = 128;
};

// How a reactor's thread waits. `automatic`: the ring where the kernel gives one, else epoll.
enum class ReactorIo { epoll, io_uring, automatic };
const char* to_string(ReactorIo io) noexcept;

// The owner of sends handed over with send_with_next_wait(). on_send_done() runs on the reactor
// thread once the kernel took the send (result: the bytes sent, or -errno); `in_flight` counts
// the sends not done yet. The owner must not go away, nor close the descriptor, before it is 0
// (wait_sends_done(), from any other thread: the reactor finishes them within its next round,
// and gives them up with -ECANCELED when its thread ends).
class SendTracker {
 public:
  virtual void on_send_done(int result, std::uint64_t cookie) noexcept = 0;
  void wait_sends_done() const noexcept {
    for (int turn = 0; in_flight.load(std::memory_order_acquire) != 0; ++turn) {
      if (turn < 100) {
        std::this_thread::yield();
      } else {
        std::this_thread::sleep_for(std::chrono::microseconds(100));  // a real-time reactor sharing our CPU
      }
    }
  }
  std::atomic<std::uint32_t> in_flight{0};

 protected:
  ~SendTracker() = default;
};

// Checks and repairs what a handler cannot (an interface that went away), on the reactor
// thread, every tick interval.
class Supervised {
 public:
  virtual ~Supervised() = default;
  virtual void on_tick() noexcept = 0;
};

class FdReactor {
 public:
  static constexpr std::chrono::milliseconds kTickInterval{500};
  // The most bytes one send_with_next_wait() takes (a CAN FD frame).
  static constexpr std::uint32_t kSendBytes = 72;

  // `thread_name` (at most 15 characters) names the thread in /proc; `what` names it in the
  // scheduling warning ("the LCM receive thread"). Nothing is opened before the first add()
  // or watch(), so a profile is checked on any host. `io`: how the thread is to wait; with
  // ReactorIo::io_uring the first add() or watch() fails where the kernel gives no ring.
  static std::shared_ptr<FdReactor> create(std::string thread_name, std::string what,
                                           ReactorIo io = ReactorIo::epoll);
  virtual ~FdReactor();
  FdReactor(const FdReactor&) = delete;
  FdReactor& operator=(const FdReactor&) = delete;

  // Watches `fd` for input (level-triggered); starts the thread on first use. Control thread.
  Result<void> add(int fd, ReadableHandler& handler);
  // Stops watching `fd` and waits until the thread is past any call of its handler.
  void remove(int fd) noexcept;
  // The same, on the reactor thread itself (a Supervised's on_tick, or a handler taking its own
  // descriptor out), so nothing to wait for.
  void remove_in_tick(int fd) noexcept;
  // Watches `fd` on a running thread (add() once the thread is started; a tick re-adding).
  Result<void> add_in_tick(int fd, ReadableHandler& handler);
  // add() / add_in_tick() of a socket whose messages the reactor receives for `handler`
  // (MessageHandler): with the ring, by multishot recvmsg; else as add().
  Result<void> add_receiver(int fd, MessageHandler& handler);
  Result<void> add_receiver_in_tick(int fd, MessageHandler& handler);

  // On the reactor thread (a handler, a tick): copies `size` (<= kSendBytes) bytes at `data`
  // and hands them to the kernel as a send on `fd` (MSG_DONTWAIT) with the thread's next wait,
  // which follows the round at once; `tracker` is told the result. False, having done nothing,
  // when the caller is another thread or the thread waits with epoll, or no send slot is free:
  // the caller then sends itself. No allocation, no lock, no system call.
  bool send_with_next_wait(int fd, const void* data, std::uint32_t size, SendTracker& tracker,
                           std::uint64_t cookie) noexcept;
  // How the thread waits: `io` as asked until the thread has started, then what it uses.
  ReactorIo io() const noexcept { return io_.load(std::memory_order_acquire); }
  // With the ring: whether it can receive for MessageHandlers (its buffers registered, 5.19+);
  // a receiver whose kernel lacks multishot recvmsg (before 6.0) is still polled.
  bool ring_receives() const noexcept { return ring_receives_.load(std::memory_order_acquire); }

  // The scheduling a component asks for the thread (<receive_thread>); the strongest request
  // of all its components is applied when the thread starts, or at once when it runs already
  // (one warning when refused). Control thread.
  void want(const ThreadScheduling& scheduling);
  // {"asked": "SCHED_FIFO 70", "realtime": true, "pinned": false}; null when nothing was asked.
  nlohmann::json scheduling() const;

  // Calls `supervised.on_tick()` every tick_interval() from now on; starts the thread and the
  // tick. Control thread.
  std::chrono::milliseconds tick_interval() const noexcept { return tick_interval_; }
  Result<void> watch(Supervised& supervised);
  // Stops the ticks for it, waiting for one in progress. Control thread.
  void unwatch(Supervised& supervised) noexcept;

 protected:
  FdReactor(std::string thread_name, std::string what, ReactorIo io = ReactorIo::epoll,
            std::chrono::milliseconds tick_interval = kTickInterval);
  // Runs the supervision tick now (every watched Supervised's on_tick), from a handler on the
  // reactor thread: a subclass's descriptor that announces a change the tick should act on at
  // once rather than at its next interval (CanReactor: the kernel's link notifications).
  // It takes a timer expiration that is due, so the periodic tick then skips that one.
  void tick_now() noexcept { tick(); }

 private:
  struct Ring;  // the io_uring and what the thread keeps for it (fd_reactor.cpp)
  // The wake-up descriptor's and the timer's handlers (both backends).
  struct Wake final : ReadableHandler {
    FdReactor* reactor;
    explicit Wake(FdReactor* r) : reactor(r) {}
    void on_readable() noexcept override;
  };
  struct Timer final : ReadableHandler {
    FdReactor* reactor;
    explicit Timer(FdReactor* r) : reactor(r) {}
    void on_readable() noexcept override { reactor->tick(); }
  };

  Result<void> start();
  void apply_scheduling();  // under start_mutex_
  void run() noexcept;
  void run_epoll() noexcept;
  void run_ring() noexcept;
  void end_round() noexcept;
  void tick() noexcept;
  bool on_thread() const noexcept;
  // Ring: runs `change` on the reactor thread (at once when called there) and waits for it;
  // false when the thread has left its loop and will not.
  bool on_reactor_thread(const std::function<void()>& change);
  void run_changes() noexcept;  // reactor thread, after a wake-up

  const std::string thread_name_;
  const std::string what_;
  const std::chrono::milliseconds tick_interval_;
  int epoll_fd_ = -1;
  int wake_fd_ = -1;
  int timer_fd_ = -1;
  mutable std::mutex start_mutex_;  // start() from add() and watch(); the tick's arming; the scheduling
  bool ticking_ = false;            // under start_mutex_
  // The watched ones; the tick holds the mutex while it calls them (not the forwarding path).
  std::mutex supervised_mutex_;
  std::vector<Supervised*> supervised_;
  std::atomic<bool> stopping_{false};
  // Rounds of epoll_wait + dispatch completed (wrapping); remove() waits for the one in
  // progress. 32 bits, the futex's own width: notify_all() after each round is then one load
  // while nobody waits, where a 64-bit atomic's goes through a word shared by every waiter in
  // the process and takes a second locked add each round.
  std::atomic<std::uint32_t> rounds_{0};
  std::atomic<ReactorIo> io_;
  std::atomic<bool> ring_receives_{false};
  Wake wake_{this};
  Timer timer_{this};
  std::unique_ptr<Ring> ring_;  // with ReactorIo::io_uring; made and used by the thread
  // The thread's pthread_self() once it runs (send_with_next_wait's test of the caller).
  std::atomic<unsigned long> thread_id_{0};
  // Ring: the changes add() and remove() hand the thread, and how many it has made.
  std::mutex changes_mutex_;
  std::condition_variable changes_made_;
  std::vector<std::function<void()>> changes_;  // under changes_mutex_
  std::uint64_t changes_posted_ = 0;            // under changes_mutex_
  std::uint64_t changes_done_ = 0;              // under changes_mutex_
  bool thread_gone_ = false;                    // under changes_mutex_
  std::thread thread_;
  std::optional<ThreadScheduling> scheduling_;  // under start_mutex_
  SchedulingOutcome applied_;
};

}  // namespace polyport
