// One epoll thread for every CAN socket of the daemon, shared by the SocketCAN proxies (the
// model hands it out; the interceptors hold it; it goes with the last of them).
//
// Threads: the reactor thread waits in epoll_wait on the registered sockets and a wake-up
// eventfd, and calls a socket's handler when it is readable, so handlers run on it. add()
// and remove() run on the control thread; after remove() returns, the handler is not
// running and is not called again, so its owner may close the socket and go away.
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <thread>

#include "polyport/base/result.hpp"

namespace polyport::socketcan {

// Reads what is queued on one socket, on the reactor thread. No allocation, no lock.
class ReadableHandler {
 public:
  virtual ~ReadableHandler() = default;
  virtual void on_readable() noexcept = 0;
};

class CanReactor {
 public:
  // Nothing is opened before the first add(), so a profile is checked on any host.
  static std::shared_ptr<CanReactor> create();
  ~CanReactor();
  CanReactor(const CanReactor&) = delete;
  CanReactor& operator=(const CanReactor&) = delete;

  // Watches `fd` for input (level-triggered); starts the thread on first use. Control thread.
  Result<void> add(int fd, ReadableHandler& handler);
  // Stops watching `fd` and waits until the thread is past any call of its handler.
  void remove(int fd) noexcept;

 private:
  CanReactor() = default;
  Result<void> start();
  void run() noexcept;

  int epoll_fd_ = -1;
  int wake_fd_ = -1;
  std::atomic<bool> stopping_{false};
  // Rounds of epoll_wait + dispatch completed; remove() waits for the one in progress.
  std::atomic<std::uint64_t> rounds_{0};
  std::thread thread_;
};

}  // namespace polyport::socketcan
