// One epoll thread for every CAN socket of the daemon, shared by the SocketCAN proxies (the
// model hands it out; the interceptors hold it; it goes with the last of them).
//
// Threads: the reactor thread waits in epoll_wait on the registered sockets and a wake-up
// eventfd, and calls a socket's handler when it is readable, so handlers run on it. add()
// and remove() run on the control thread; after remove() returns, the handler is not
// running and is not called again, so its owner may close the socket and go away.
// The same thread runs the supervision tick: every kTickInterval (a timerfd in the same
// epoll set) it calls on_tick() of each watched Supervised, which checks its interface,
// re-creates sockets, logs and reports; the tick is not the forwarding path (it may allocate
// and log) and never runs while a handler does, so both may write the same ports. watch()
// and unwatch() run on the control thread; after unwatch() returns, on_tick is not running
// and is not called again.
#pragma once

#include <atomic>
#include <cstdint>
#include <cstring>
#include <chrono>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "polyport/base/result.hpp"
#include "polyport/runtime/echo_table.hpp"
#include "polyport/runtime/thread_scheduling.hpp"
#include <nlohmann/json_fwd.hpp>
#include <optional>

namespace polyport::socketcan {

// Reads what is queued on one socket, on the reactor thread. No allocation, no lock.
class ReadableHandler {
 public:
  virtual ~ReadableHandler() = default;
  virtual void on_readable() noexcept = 0;
};

// Checks and repairs what a handler cannot (interfaces that went away), on the reactor
// thread, every kTickInterval.
class Supervised {
 public:
  virtual ~Supervised() = default;
  virtual void on_tick() noexcept = 0;
};

// Loop prevention on one CAN interface (polyport/runtime/echo_table.hpp). The kernel loops
// every frame a socket sends back to the host's other raw sockets on the interface (not to
// the sender's own: CAN_RAW_RECV_OWN_MSGS is off), marked MSG_DONTROUTE as locally sent, but
// says nothing of which socket sent it. So a raw frame polyport sends on an id that a raw
// socket of polyport's reads on the interface is recorded first (a fingerprint of id, length
// and data, with how many of those sockets will see it), and those sockets drop it. Shared by
// the interceptors of the interface; made and counted on the control thread.
struct CanEchoes {
  EchoTable table;
  std::atomic<std::uint32_t> senders{0};  // polyport's sending ports on the interface, started
  // Polyport's started raw sockets that receive each id; entries stay while the reactor does.
  std::atomic<std::uint32_t>& readers_of(std::uint32_t can_id) {
    auto& readers = readers_[can_id];
    if (!readers) readers = std::make_unique<std::atomic<std::uint32_t>>(0);
    return *readers;
  }

 private:
  std::map<std::uint32_t, std::unique_ptr<std::atomic<std::uint32_t>>> readers_;
};

// The fingerprint of a frame, for CanEchoes: id, length and data bytes.
inline std::uint64_t frame_fingerprint(std::uint32_t can_id, std::uint8_t len, const std::uint8_t* data) noexcept {
  std::uint8_t bytes[sizeof can_id + 1 + 64];
  std::memcpy(bytes, &can_id, sizeof can_id);
  bytes[sizeof can_id] = len;
  const std::size_t n = len <= 64 ? len : 64;
  std::memcpy(bytes + sizeof can_id + 1, data, n);
  return message_fingerprint(bytes, sizeof can_id + 1 + n);
}

class CanReactor {
 public:
  static constexpr std::chrono::milliseconds kTickInterval{500};

  // Nothing is opened before the first add(), so a profile is checked on any host.
  static std::shared_ptr<CanReactor> create();
  ~CanReactor();
  CanReactor(const CanReactor&) = delete;
  CanReactor& operator=(const CanReactor&) = delete;

  // Watches `fd` for input (level-triggered); starts the thread on first use. Control thread.
  Result<void> add(int fd, ReadableHandler& handler);
  // Stops watching `fd` and waits until the thread is past any call of its handler.
  void remove(int fd) noexcept;
  // The same, from a Supervised's on_tick (the reactor thread itself, so nothing to wait for).
  void remove_in_tick(int fd) noexcept;
  Result<void> add_in_tick(int fd, ReadableHandler& handler);

  // The scheduling a component asks for the thread (<socketcan><receive_thread>); the
  // strongest request of all the daemon's CAN components is applied when the thread starts,
  // or at once when it runs already (one warning when refused). Control thread.
  void want(const ThreadScheduling& scheduling);
  // {"asked": "SCHED_FIFO 70", "realtime": true, "pinned": false}; null when nothing was asked.
  nlohmann::json scheduling() const;

  // The loop-prevention state of `interface`; lives as long as the reactor. Control thread.
  CanEchoes& echoes(const std::string& interface);

  // Calls `supervised.on_tick()` every kTickInterval from now on; starts the thread. Control thread.
  Result<void> watch(Supervised& supervised);
  // Stops the ticks for it, waiting for one in progress. Control thread.
  void unwatch(Supervised& supervised) noexcept;

 private:
  CanReactor() = default;
  Result<void> start();
  void apply_scheduling();  // under start_mutex_
  void run() noexcept;
  void tick() noexcept;

  int epoll_fd_ = -1;
  int wake_fd_ = -1;
  int timer_fd_ = -1;
  mutable std::mutex start_mutex_;  // start() from add() and watch(); the scheduling
  // The watched ones; the tick holds the mutex while it calls them (not the forwarding path).
  std::mutex supervised_mutex_;
  std::vector<Supervised*> supervised_;
  std::atomic<bool> stopping_{false};
  // Rounds of epoll_wait + dispatch completed; remove() waits for the one in progress.
  std::atomic<std::uint64_t> rounds_{0};
  std::thread thread_;
  std::optional<ThreadScheduling> scheduling_;  // under start_mutex_
  SchedulingOutcome applied_;
  std::map<std::string, std::unique_ptr<CanEchoes>> echoes_;  // control thread
};

}  // namespace polyport::socketcan
