// Connection watchdogs and the thread that watches them. See watchdog.hpp.
#include "polyport/runtime/watchdog.hpp"

#include <sys/prctl.h>

#include <algorithm>
#include <chrono>
#include <cstdio>

#include "polyport/runtime/connection.hpp"
#include "polyport/runtime/port.hpp"

namespace polyport {

namespace {

// How often a tripped or waiting watchdog is looked at for its recovery (the forwarding path
// does not wait for it: a fresh sample passes as soon as it comes).
constexpr Nanos kRecoveryPoll{5'000'000};
// The longest sleep, also without any watchdog that could expire sooner.
constexpr Nanos kMaxSleep{100'000'000};

std::string milliseconds(Nanos d) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.1f ms", static_cast<double>(d.count) / 1e6);
  return text;
}

}  // namespace

std::string_view to_string(WatchdogState state) noexcept {
  switch (state) {
    case WatchdogState::waiting: return "waiting";
    case WatchdogState::ok: return "ok";
    case WatchdogState::tripped: return "tripped";
  }
  return "unknown";
}

ConnectionWatchdog::ConnectionWatchdog(const DataOutPort& source, const DataOutPort* upstream, Nanos deadline,
                                       Nanos max_age, std::vector<std::byte> safe)
    : source_(source), upstream_(upstream), deadline_(deadline), max_age_(max_age), safe_(std::move(safe)) {}

MonoTime ConnectionWatchdog::last_write(const DataOutPort& port) noexcept { return port.last_write(); }

MonoTime ConnectionWatchdog::expiry() const noexcept {
  MonoTime oldest = last_write(source_);
  if (upstream_) oldest = std::min(oldest, last_write(*upstream_));
  return oldest + deadline_;
}

void ConnectionWatchdog::enter() noexcept {
  while (busy_.exchange(true, std::memory_order_acquire)) {
#if defined(__x86_64__) || defined(__i386__)
    __builtin_ia32_pause();
#endif
  }
}

void WatchdogMonitor::start(Notify notify) {
  if (connections_.empty() || thread_.joinable()) return;
  notify_ = std::move(notify);
  stopping_ = false;
  thread_ = std::thread([this] { run(); });
}

void WatchdogMonitor::stop() {
  if (!thread_.joinable()) return;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_all();
  thread_.join();
}

MonoTime WatchdogMonitor::check(MonoTime now) {
  MonoTime next = now + kMaxSleep;
  for (Connection* connection : connections_) {
    ConnectionWatchdog& watchdog = *connection->watchdog();
    const WatchdogState state = watchdog.state();
    if (watchdog.fresh(now)) {
      watchdog.safe_written_ = false;
      if (state != WatchdogState::ok) {
        watchdog.state_.store(WatchdogState::ok, std::memory_order_relaxed);
        if (state == WatchdogState::tripped) {
          watchdog.counters_.recoveries.fetch_add(1, std::memory_order_relaxed);
          if (notify_) notify_("watchdog " + connection->name() + ": recovered, samples pass again", false);
        } else if (notify_) {
          notify_("watchdog " + connection->name() + ": armed, deadline " + milliseconds(watchdog.deadline()), false);
        }
      }
      next = std::min(next, watchdog.expiry() + Nanos{1});
      continue;
    }
    if (state == WatchdogState::ok) {
      watchdog.state_.store(WatchdogState::tripped, std::memory_order_relaxed);
      watchdog.counters_.trips.fetch_add(1, std::memory_order_relaxed);
      if (notify_) {
        const bool source_silent = now - ConnectionWatchdog::last_write(watchdog.source()) > watchdog.deadline();
        const DataOutPort& silent = source_silent || !watchdog.upstream() ? watchdog.source() : *watchdog.upstream();
        notify_("watchdog " + connection->name() + ": tripped, " + silent.full_name() + " silent for more than " +
                    milliseconds(watchdog.deadline()) + "; the target gets the safe value",
                true);
      }
    }
    // A push-mode target whose source is silent gets the safe value from here, once; one whose
    // source still writes gets it from the forwarding path (Connection::deliver), and a
    // pull-mode reader from Connection::take.
    if (!watchdog.safe_written_ && connection->push_mode()) {
      watchdog.safe_written_ = connection->emit_safe_value(now);
    }
    next = std::min(next, now + (watchdog.safe_written_ ? kRecoveryPoll : Nanos{100'000}));
  }
  return next;
}

void WatchdogMonitor::run() {
  prctl(PR_SET_NAME, "pp-watchdog", 0, 0, 0);
  prctl(PR_SET_TIMERSLACK, 1UL, 0, 0, 0);  // trip at the deadline, not 50 us after it
  std::unique_lock<std::mutex> lock(mutex_);
  while (!stopping_) {
    const MonoTime next = check(mono_now());
    // steady_clock is CLOCK_MONOTONIC here, the clock of every stamp on the path.
    const auto until = std::chrono::steady_clock::time_point(std::chrono::nanoseconds(next.ns));
    wake_.wait_until(lock, until, [this] { return stopping_; });
  }
}

}  // namespace polyport
