// The Prometheus endpoint of a running polyportd: GET /metrics on a TCP port (docs/CONTROL.md),
// served by cpp-httplib.
//
// Threads: cpp-httplib's listening thread and its small pool of worker threads read requests
// and write responses; they never touch the Engine. A worker that got GET /metrics queues a
// promise and makes request_fd() readable; the engine's control thread (polyportd's main
// thread, which owns the Engine) calls serve(), which renders the metrics once for every
// queued scrape and fulfils their promises. The worker then writes the text at the client's
// pace: a slow client holds a worker, never the main thread. A scrape the main thread does not
// answer within kScrapeTimeout gets 503; a client that stalls is dropped after kReadTimeout
// (sending) or kScrapeTimeout (reading). The queue's mutex is taken by these threads only,
// never by the forwarding path.
#pragma once

#include <chrono>
#include <functional>
#include <future>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "polyport/base/result.hpp"

namespace httplib {
class Server;
}

namespace polyport::daemon {

class MetricsServer {
 public:
  static constexpr std::chrono::seconds kScrapeTimeout{5};
  // How long a client may keep a worker waiting for its request (also between requests of a
  // kept-alive connection); the daemon's shutdown waits at most about this long for them.
  static constexpr std::chrono::seconds kReadTimeout{2};
  static constexpr std::size_t kWorkers = 2;

  // Returns the Prometheus text of the metrics now.
  using Renderer = std::function<std::string()>;

  MetricsServer();
  MetricsServer(const MetricsServer&) = delete;
  MetricsServer& operator=(const MetricsServer&) = delete;
  ~MetricsServer();  // stops the server threads

  // Listens on address:port (port 0: one the kernel picks; port() tells which) and starts
  // the server's threads. An error when the port cannot be bound.
  Result<void> start(const std::string& address, int port);
  void stop();
  // Readable (an eventfd) when scrapes wait for serve(); -1 before start.
  int request_fd() const noexcept { return request_fd_; }
  // On the engine's control thread: answers every queued scrape with one rendering.
  void serve(const Renderer& render);
  int port() const noexcept { return port_; }
  const std::string& address() const noexcept { return address_; }
  // "http://ADDRESS:PORT/metrics"; empty before start.
  std::string url() const;

 private:
  std::unique_ptr<httplib::Server> server_;
  std::thread thread_;
  std::string address_;
  int port_ = 0;
  int request_fd_ = -1;
  std::mutex mutex_;  // pending_ and stopping_; the server's workers, serve() and stop() only
  bool stopping_ = false;
  std::vector<std::shared_ptr<std::promise<std::string>>> pending_;
};

}  // namespace polyport::daemon
