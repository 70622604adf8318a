// The admin socket of a running polyportd (docs/CONTROL.md).
//
// Threads: the server has a control thread of its own that accepts connections, checks each
// peer's credentials (SO_PEERCRED: the daemon's uid, or root), reads request lines, parses
// them and writes replies, all with non-blocking I/O under one poll(). A parsed request is
// not executed there: it is queued for the engine's control thread (polyportd's main
// thread, which owns the Engine) and request_fd() becomes readable; that thread calls
// serve(), which runs the handler and queues the reply for the control thread. The queues'
// mutex is taken by these two threads only, never by the forwarding path.
//
// Buffers and bounds: a request line is at most admin::kMaxRequestLine bytes (a longer one
// gets an error reply and the client is cut off); a client has at most one request in
// flight (its socket is not read meanwhile); a client whose unsent replies exceed
// kMaxOutput (it does not read) is cut off; at most kMaxClients connections at once.
#pragma once

#include <atomic>
#include <cstdint>
#include <deque>
#include <functional>
#include <mutex>
#include <string>
#include <thread>

#include "admin_protocol.hpp"
#include "polyport/base/result.hpp"

namespace polyport::daemon {

class AdminServer {
 public:
  static constexpr std::size_t kMaxOutput = 1 << 20;
  static constexpr std::size_t kMaxClients = 64;

  // Returns the reply line for a request (admin::ok_reply / admin::error_reply).
  using Handler = std::function<std::string(const admin::Request&)>;

  AdminServer() = default;
  AdminServer(const AdminServer&) = delete;
  AdminServer& operator=(const AdminServer&) = delete;
  ~AdminServer();  // stops the thread, closes and removes the socket

  // Creates the listening socket at `path` (mode 0600; a stale socket left by a daemon that
  // died is replaced, a live one is an error) and starts the control thread.
  Result<void> start(const std::string& path);
  void stop();
  // Readable (an eventfd) when requests wait for serve(); -1 before start.
  int request_fd() const noexcept { return request_fd_; }
  // On the engine's control thread: answers every queued request.
  void serve(const Handler& handler);
  const std::string& path() const noexcept { return path_; }

 private:
  struct Pending {
    std::uint64_t client;
    admin::Request request;
  };
  void loop();

  std::string path_;
  int listen_fd_ = -1;
  int wake_fd_ = -1;     // eventfd: replies queued, or stop
  int request_fd_ = -1;  // eventfd: requests queued
  std::atomic<bool> stopping_{false};
  std::thread thread_;
  std::mutex mutex_;  // requests_ and replies_; the control thread and serve() only
  std::deque<Pending> requests_;
  std::deque<std::pair<std::uint64_t, std::string>> replies_;
};

// The default socket path: admin::default_socket_dir() + "/polyportd-<pid>.sock"; the
// folder is created (mode 0700) when missing.
Result<std::string> default_admin_socket();

}  // namespace polyport::daemon
