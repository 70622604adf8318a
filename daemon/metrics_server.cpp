#include "metrics_server.hpp"

#include <errno.h>
#include <sys/eventfd.h>
#include <unistd.h>

#include <cstring>
#include <httplib.h>

namespace polyport::daemon {

MetricsServer::MetricsServer() = default;

MetricsServer::~MetricsServer() { stop(); }

std::string MetricsServer::url() const {
  if (port_ == 0) return {};
  const bool v6 = address_.find(':') != std::string::npos;
  return "http://" + (v6 ? "[" + address_ + "]" : address_) + ":" + std::to_string(port_) + "/metrics";
}

Result<void> MetricsServer::start(const std::string& address, int port) {
  stopping_ = false;
  request_fd_ = ::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
  if (request_fd_ < 0) return make_error(std::string("metrics: eventfd: ") + std::strerror(errno));
  server_ = std::make_unique<httplib::Server>();
  // A few workers are enough for scrapers. A client that stalls holds one until a timeout
  // drops it: short for reading (a scraper sends its request at once; stop() waits for the
  // workers), longer for writing the text.
  server_->new_task_queue = [] { return new httplib::ThreadPool(kWorkers); };
  server_->set_read_timeout(kReadTimeout);
  server_->set_keep_alive_timeout(kReadTimeout.count());
  server_->set_write_timeout(kScrapeTimeout);
  server_->set_keep_alive_max_count(100);
  server_->set_payload_max_length(1 << 16);
  server_->Get("/metrics", [this](const httplib::Request&, httplib::Response& response) {
    auto promise = std::make_shared<std::promise<std::string>>();
    std::future<std::string> text = promise->get_future();
    {
      std::lock_guard lock(mutex_);
      if (stopping_) {
        response.status = 503;
        return;
      }
      pending_.push_back(promise);
    }
    const std::uint64_t one = 1;
    [[maybe_unused]] ssize_t n = ::write(request_fd_, &one, sizeof one);
    if (text.wait_for(kScrapeTimeout) != std::future_status::ready) {
      response.status = 503;
      response.set_content("polyportd did not answer in time\n", "text/plain");
      return;
    }
    response.set_content(text.get(), "text/plain; version=0.0.4; charset=utf-8");
  });
  server_->Get("/", [](const httplib::Request&, httplib::Response& response) {
    response.set_content("polyportd: the metrics are at /metrics\n", "text/plain");
  });

  errno = 0;
  const int bound = port == 0 ? server_->bind_to_any_port(address) : (server_->bind_to_port(address, port) ? port : -1);
  if (bound <= 0) {
    const std::string why = errno != 0 ? std::string(": ") + std::strerror(errno) : std::string();
    stop();
    return make_error("cannot listen for metrics on " + address + " port " + std::to_string(port) + why);
  }
  address_ = address;
  port_ = bound;
  thread_ = std::thread([this] { server_->listen_after_bind(); });
  return {};
}

void MetricsServer::stop() {
  // Scrapes still waiting get an empty page at once rather than their timeout: the server's
  // workers are joined below.
  auto release = [this] {
    std::lock_guard lock(mutex_);
    stopping_ = true;
    for (auto& promise : pending_) promise->set_value({});
    pending_.clear();
  };
  release();
  if (server_) {
    server_->stop();
    if (thread_.joinable()) thread_.join();
    server_.reset();
  }
  release();
  if (request_fd_ >= 0) ::close(request_fd_);
  request_fd_ = -1;
  port_ = 0;
}

void MetricsServer::serve(const Renderer& render) {
  std::uint64_t value = 0;
  [[maybe_unused]] ssize_t n = ::read(request_fd_, &value, sizeof value);
  std::vector<std::shared_ptr<std::promise<std::string>>> work;
  {
    std::lock_guard lock(mutex_);
    work.swap(pending_);
  }
  if (work.empty()) return;
  const std::string text = render();
  for (auto& promise : work) promise->set_value(text);
}

}  // namespace polyport::daemon
