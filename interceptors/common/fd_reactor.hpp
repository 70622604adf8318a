// One thread that waits on many descriptors (epoll) and calls their handlers: the receive
// thread a model shares between all its sockets (SocketCAN: every CAN socket of the daemon;
// LCM: every LCM instance's notify descriptor). The model hands it out; the interceptors hold
// it; it goes with the last of them.
//
// Threads: the reactor thread waits in epoll_wait on the registered descriptors and a wake-up
// eventfd, and calls a descriptor's handler when it is readable, so handlers run on it. add()
// and remove() run on the control thread; after remove() returns, the handler is not running
// and is not called again, so its owner may close the descriptor and go away.
// The same thread can run a supervision tick: once something is watched, every kTickInterval
// (a timerfd in the same epoll set) it calls on_tick() of each watched Supervised, which may
// re-create descriptors, log and report; the tick is not the forwarding path (it may allocate
// and log) and never runs while a handler does, so both may write the same ports. watch() and
// unwatch() run on the control thread; after unwatch() returns, on_tick is not running and is
// not called again.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

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

// Checks and repairs what a handler cannot (an interface that went away), on the reactor
// thread, every kTickInterval.
class Supervised {
 public:
  virtual ~Supervised() = default;
  virtual void on_tick() noexcept = 0;
};

class FdReactor {
 public:
  static constexpr std::chrono::milliseconds kTickInterval{500};

  // `thread_name` (at most 15 characters) names the thread in /proc; `what` names it in the
  // scheduling warning ("the LCM receive thread"). Nothing is opened before the first add()
  // or watch(), so a profile is checked on any host.
  static std::shared_ptr<FdReactor> create(std::string thread_name, std::string what);
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

  // The scheduling a component asks for the thread (<receive_thread>); the strongest request
  // of all its components is applied when the thread starts, or at once when it runs already
  // (one warning when refused). Control thread.
  void want(const ThreadScheduling& scheduling);
  // {"asked": "SCHED_FIFO 70", "realtime": true, "pinned": false}; null when nothing was asked.
  nlohmann::json scheduling() const;

  // Calls `supervised.on_tick()` every kTickInterval from now on; starts the thread and the
  // tick. Control thread.
  Result<void> watch(Supervised& supervised);
  // Stops the ticks for it, waiting for one in progress. Control thread.
  void unwatch(Supervised& supervised) noexcept;

 protected:
  FdReactor(std::string thread_name, std::string what);

 private:
  Result<void> start();
  void apply_scheduling();  // under start_mutex_
  void run() noexcept;
  void tick() noexcept;

  const std::string thread_name_;
  const std::string what_;
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
  std::thread thread_;
  std::optional<ThreadScheduling> scheduling_;  // under start_mutex_
  SchedulingOutcome applied_;
};

}  // namespace polyport
