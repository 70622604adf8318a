#include "fd_reactor.hpp"

#include <sys/epoll.h>
#include <sys/eventfd.h>
#include <sys/timerfd.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <string>
#include <utility>

#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

namespace polyport {

namespace {
// epoll_event.data.ptr of the timer descriptor (the wake-up descriptor has null).
int timer_tag = 0;
}  // namespace

FdReactor::FdReactor(std::string thread_name, std::string what)
    : thread_name_(std::move(thread_name)), what_(std::move(what)) {}

std::shared_ptr<FdReactor> FdReactor::create(std::string thread_name, std::string what) {
  return std::shared_ptr<FdReactor>(new FdReactor(std::move(thread_name), std::move(what)));
}

FdReactor::~FdReactor() {
  if (thread_.joinable()) {
    stopping_.store(true, std::memory_order_release);
    const std::uint64_t one = 1;
    (void)::write(wake_fd_, &one, sizeof one);
    thread_.join();
  }
  if (timer_fd_ >= 0) ::close(timer_fd_);
  if (wake_fd_ >= 0) ::close(wake_fd_);
  if (epoll_fd_ >= 0) ::close(epoll_fd_);
}

Result<void> FdReactor::start() {
  const std::lock_guard lock(start_mutex_);
  if (thread_.joinable()) return {};
  // A failure closes what this call opened, so a later add() starts afresh and leaks nothing.
  auto fail = [this](const char* what) {
    const std::string message = std::string(what) + ": " + std::strerror(errno);
    for (int* fd : {&timer_fd_, &wake_fd_, &epoll_fd_}) {
      if (*fd >= 0) ::close(*fd);
      *fd = -1;
    }
    return make_error(message);
  };
  epoll_fd_ = ::epoll_create1(EPOLL_CLOEXEC);
  if (epoll_fd_ < 0) return fail("epoll_create1");
  wake_fd_ = ::eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
  if (wake_fd_ < 0) return fail("eventfd");
  epoll_event event{};
  event.events = EPOLLIN;
  event.data.ptr = nullptr;  // the wake-up descriptor
  if (::epoll_ctl(epoll_fd_, EPOLL_CTL_ADD, wake_fd_, &event) != 0) return fail("epoll_ctl");
  timer_fd_ = ::timerfd_create(CLOCK_MONOTONIC, TFD_CLOEXEC | TFD_NONBLOCK);
  if (timer_fd_ < 0) return fail("timerfd_create");
  event.data.ptr = &timer_tag;
  if (::epoll_ctl(epoll_fd_, EPOLL_CTL_ADD, timer_fd_, &event) != 0) return fail("epoll_ctl");
  thread_ = std::thread([this] { run(); });
  pthread_setname_np(thread_.native_handle(), thread_name_.c_str());
  apply_scheduling();
  return {};
}

void FdReactor::want(const ThreadScheduling& scheduling) {
  std::lock_guard<std::mutex> lock(start_mutex_);
  const ThreadScheduling wanted = scheduling_ ? stronger(*scheduling_, scheduling) : scheduling;
  if (scheduling_ && wanted == *scheduling_) return;
  scheduling_ = wanted;
  if (thread_.joinable()) apply_scheduling();
}

void FdReactor::apply_scheduling() {
  if (!scheduling_) return;
  applied_ = polyport::apply_scheduling(thread_.native_handle(), *scheduling_, what_);
  if (!applied_.problem.empty()) spdlog::warn("{}", applied_.problem);
}

nlohmann::json FdReactor::scheduling() const {
  std::lock_guard<std::mutex> lock(start_mutex_);
  if (!scheduling_) return nullptr;
  return {{"asked", to_string(*scheduling_)}, {"realtime", applied_.realtime_applied}, {"pinned", applied_.pinned}};
}

Result<void> FdReactor::add(int fd, ReadableHandler& handler) {
  if (auto started = start(); !started) return started;
  return add_in_tick(fd, handler);
}

void FdReactor::remove(int fd) noexcept {
  if (!thread_.joinable()) return;
  (void)::epoll_ctl(epoll_fd_, EPOLL_CTL_DEL, fd, nullptr);
  // The thread may have taken this socket's event from epoll_wait before the DEL and be
  // calling its handler now. Wake it and wait until it finishes a round begun after the DEL
  // had been read: by then it is past any call for this socket.
  const std::uint32_t round = rounds_.load(std::memory_order_acquire);
  const std::uint64_t one = 1;
  (void)::write(wake_fd_, &one, sizeof one);
  for (std::uint32_t seen = round; seen == round; seen = rounds_.load(std::memory_order_acquire)) {
    rounds_.wait(seen, std::memory_order_acquire);
  }
}

void FdReactor::remove_in_tick(int fd) noexcept { (void)::epoll_ctl(epoll_fd_, EPOLL_CTL_DEL, fd, nullptr); }

Result<void> FdReactor::add_in_tick(int fd, ReadableHandler& handler) {
  epoll_event event{};
  event.events = EPOLLIN;
  event.data.ptr = &handler;
  if (::epoll_ctl(epoll_fd_, EPOLL_CTL_ADD, fd, &event) != 0) {
    return make_error(std::string("epoll_ctl(EPOLL_CTL_ADD): ") + std::strerror(errno));
  }
  return {};
}

Result<void> FdReactor::watch(Supervised& supervised) {
  if (auto started = start(); !started) return started;
  {
    // The tick runs once something is watched (an idle timer would wake the thread for nothing).
    const std::lock_guard lock(start_mutex_);
    if (!ticking_) {
      itimerspec period{};
      period.it_interval.tv_nsec = std::chrono::nanoseconds(kTickInterval).count();
      period.it_value = period.it_interval;
      if (::timerfd_settime(timer_fd_, 0, &period, nullptr) != 0) {
        return make_error(std::string("timerfd_settime: ") + std::strerror(errno));
      }
      ticking_ = true;
    }
  }
  const std::lock_guard lock(supervised_mutex_);
  supervised_.push_back(&supervised);
  return {};
}

void FdReactor::unwatch(Supervised& supervised) noexcept {
  const std::lock_guard lock(supervised_mutex_);
  supervised_.erase(std::remove(supervised_.begin(), supervised_.end(), &supervised), supervised_.end());
}

void FdReactor::tick() noexcept {
  std::uint64_t expirations = 0;
  (void)::read(timer_fd_, &expirations, sizeof expirations);
  const std::lock_guard lock(supervised_mutex_);
  for (Supervised* supervised : supervised_) supervised->on_tick();
}

void FdReactor::run() noexcept {
  constexpr int kMaxEvents = 16;
  epoll_event events[kMaxEvents];
  while (!stopping_.load(std::memory_order_acquire)) {
    const int ready = ::epoll_wait(epoll_fd_, events, kMaxEvents, -1);
    for (int i = 0; i < ready; ++i) {
      if (events[i].data.ptr == &timer_tag) {
        tick();
      } else if (auto* handler = static_cast<ReadableHandler*>(events[i].data.ptr)) {
        handler->on_readable();
      } else {
        std::uint64_t count = 0;
        (void)::read(wake_fd_, &count, sizeof count);
      }
    }
    if (ready < 0 && errno != EINTR) break;
    // seq_cst, not a plain store: notify_all() then reads whether anyone waits, and that read
    // must not pass the new count (remove() registers as a waiter before it reads the count).
    rounds_.fetch_add(1, std::memory_order_seq_cst);
    rounds_.notify_all();
  }
  // A remove() must not wait for a thread that has left: count one more round for it.
  rounds_.fetch_add(1, std::memory_order_seq_cst);
  rounds_.notify_all();
}

}  // namespace polyport
