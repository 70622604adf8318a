// The admin socket of a running polyportd (docs/CONTROL.md).
//
// Threads: the server has a control thread of its own that accepts connections, checks each
// peer's credentials (SO_PEERCRED: the daemon's uid, or root, or a member of the allowed
// group when there is one), reads request lines, parses
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
//
// Streamed replies (trace): a handler may answer "later, in several lines" (kStreaming); the
// request then stays in flight and the engine's control thread sends lines with send() until
// one is the last. A client that leaves meanwhile (or is cut off, also by the kMaxOutput rule:
// lines are never held back for a slow reader, so the daemon never waits for one) is reported
// to serve()'s `left` callback, so its stream is closed on the engine's control thread.
#pragma once

#include <sys/types.h>

#include <atomic>
#include <cstdint>
#include <deque>
#include <functional>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "admin_protocol.hpp"
#include "polyport/base/result.hpp"

namespace polyport::daemon {

class AdminServer {
 public:
  static constexpr std::size_t kMaxOutput = 1 << 20;
  static constexpr std::size_t kMaxClients = 64;

  // Returns the reply line for a request (admin::ok_reply / admin::error_reply), or
  // kStreaming: the reply comes later through send(..., `client`, ...).
  using Handler = std::function<std::string(const admin::Request&, std::uint64_t client)>;
  // Told the client of an open streamed reply that left (or was cut off).
  using Left = std::function<void(std::uint64_t client)>;
  static inline const std::string kStreaming{};

  AdminServer() = default;
  AdminServer(const AdminServer&) = delete;
  AdminServer& operator=(const AdminServer&) = delete;
  ~AdminServer();  // stops the thread, closes and removes the socket

  // Creates the listening socket at `path` (mode 0600; a stale socket left by a daemon that
  // died is replaced, a live one is an error) and starts the control thread. With `group`,
  // the socket is mode 0660 and belongs to that group, and peers whose groups include it are
  // admitted too.
  Result<void> start(const std::string& path, std::optional<gid_t> group = std::nullopt);
  void stop();
  // Readable (an eventfd) when requests wait for serve(); -1 before start.
  int request_fd() const noexcept { return request_fd_; }
  // On the engine's control thread: answers every queued request, and tells `left` of
  // streams whose client left.
  void serve(const Handler& handler, const Left& left = nullptr);
  // On the engine's control thread: lines (newline-terminated) of a streamed reply; `last`
  // ends it (the client's next request is read then). Lines for a client that left are dropped.
  void send(std::uint64_t client, std::string lines, bool last);
  const std::string& path() const noexcept { return path_; }

 private:
  struct Pending {
    std::uint64_t client;
    admin::Request request;
  };
  struct Reply {
    std::uint64_t client;
    std::string text;
    bool last;  // the request is answered: read the client's next line
  };
  void loop();

  std::string path_;
  int listen_fd_ = -1;
  int wake_fd_ = -1;     // eventfd: replies queued, or stop
  int request_fd_ = -1;  // eventfd: requests queued
  std::atomic<bool> stopping_{false};
  std::thread thread_;
  std::optional<gid_t> group_;
  std::mutex mutex_;  // what follows; the control thread and the engine's control thread only
  std::deque<Pending> requests_;
  std::deque<Reply> replies_;
  std::set<std::uint64_t> streams_;  // clients with a streamed reply open
  std::vector<std::uint64_t> left_;  // of those, the ones that left (for serve())
  // Clients that left while their request waited for serve(): a stream it would open for one
  // is closed at once.
  std::set<std::uint64_t> departed_;
};

// The group of --admin-group: a group name, or a numeric gid.
Result<gid_t> admin_group(const std::string& name);

// The default socket path: admin::default_socket_dir() + "/polyportd-<pid>.sock"; the
// folder is created (mode 0700) when missing.
Result<std::string> default_admin_socket();

}  // namespace polyport::daemon
