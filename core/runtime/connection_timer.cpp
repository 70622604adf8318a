// The connections' timer thread. See connection_timer.hpp.
#include "polyport/runtime/connection_timer.hpp"

#include <sys/prctl.h>

#include <algorithm>
#include <chrono>
#include <cstdio>

#include "polyport/runtime/component.hpp"
#include "polyport/runtime/connection.hpp"
#include "polyport/runtime/port.hpp"

namespace polyport {

namespace {

// How often a tripped or waiting watchdog is looked at for its recovery (the forwarding path
// does not wait for it: a fresh sample passes as soon as it comes).
constexpr Nanos kRecoveryPoll{5'000'000};
// When the writer had the connection: the next try.
constexpr Nanos kRetry{100'000};
// The longest sleep, also without any policy that could need this thread sooner.
constexpr Nanos kMaxSleep{100'000'000};

std::string milliseconds(Nanos d) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.1f ms", static_cast<double>(d.count) / 1e6);
  return text;
}

}  // namespace

void ConnectionTimer::start(Notify notify) {
  if (connections_.empty() || thread_.joinable()) return;
  notify_ = std::move(notify);
  stopping_ = false;
  thread_ = std::thread([this] { run(); });
}

void ConnectionTimer::stop() {
  if (!thread_.joinable()) return;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_all();
  thread_.join();
}

void ConnectionTimer::add(Connection& connection) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    connections_.push_back(&connection);
  }
  wake_.notify_one();
}

void ConnectionTimer::remove(const Connection& connection) {
  // The thread holds the mutex while it checks, and lets go of it only to sleep.
  std::lock_guard<std::mutex> lock(mutex_);
  connections_.erase(std::remove(connections_.begin(), connections_.end(), &connection), connections_.end());
}

MonoTime ConnectionTimer::check(MonoTime now) {
  MonoTime next = now + kMaxSleep;
  for (Connection* connection : connections_) {
    if (connection->watchdog()) next = std::min(next, check_watchdog(*connection, now));
    if (connection->rate_interval().count > 0) next = std::min(next, check_rate_limit(*connection, now));
  }
  return next;
}

MonoTime ConnectionTimer::check_watchdog(Connection& connection, MonoTime now) {
  ConnectionWatchdog& watchdog = *connection.watchdog();
  const WatchdogState state = watchdog.state();
  if (watchdog.fresh(now)) {
    watchdog.safe_written_ = false;
    if (state != WatchdogState::ok) {
      watchdog.state_.store(WatchdogState::ok, std::memory_order_relaxed);
      if (state == WatchdogState::tripped) {
        watchdog.counters_.recoveries.fetch_add(1, std::memory_order_relaxed);
        tell(watchdog, 1, 0, nullptr);
        if (notify_) notify_("watchdog " + connection.name() + ": recovered, samples pass again", false);
      } else if (notify_) {
        notify_("watchdog " + connection.name() + ": armed, deadline " + milliseconds(watchdog.deadline()), false);
      }
    }
    return watchdog.expiry() + Nanos{1};
  }
  if (state == WatchdogState::ok) {
    watchdog.state_.store(WatchdogState::tripped, std::memory_order_relaxed);
    watchdog.counters_.trips.fetch_add(1, std::memory_order_relaxed);
    const bool source_silent = now - ConnectionWatchdog::last_write(watchdog.source()) > watchdog.deadline();
    const DataOutPort& silent = source_silent || !watchdog.upstream() ? watchdog.source() : *watchdog.upstream();
    tell(watchdog, 0, (now - ConnectionWatchdog::last_write(silent)).count, &silent);
    if (notify_) {
      notify_("watchdog " + connection.name() + ": tripped, " + silent.full_name() + " silent for more than " +
                  milliseconds(watchdog.deadline()) + "; the target gets the safe value",
              true);
    }
  }
  // A push-mode target whose source is silent gets the safe value from here, once; one whose
  // source still writes gets it from the forwarding path (Connection::deliver), and a
  // pull-mode reader from Connection::take.
  if (!connection.push_mode()) return now + kRecoveryPoll;
  if (watchdog.safe_written_) return now + kRecoveryPoll;
  switch (connection.emit_safe_value(now)) {
    case Connection::SafeValueResult::sent:
      watchdog.safe_written_ = true;
      return now + kRecoveryPoll;
    case Connection::SafeValueResult::busy:
      return now + kRetry;  // the writer has the sink this moment
    case Connection::SafeValueResult::refused:
      return now + kRecoveryPoll;  // the target refused it (counted): again in a while
  }
  return now + kRecoveryPoll;
}

// The watchdog's event port, if it has one: a fixed-size sample, written on this thread.
void ConnectionTimer::tell(ConnectionWatchdog& watchdog, std::int32_t kind, std::int64_t silent_ns,
                           const DataOutPort* silent) {
  if (watchdog.events_ == nullptr) return;
  WatchdogEventSample& event = watchdog.event_;
  event.kind = kind;
  event.trips = watchdog.counters_.trips.load(std::memory_order_relaxed);
  event.recoveries = watchdog.counters_.recoveries.load(std::memory_order_relaxed);
  event.silent_ns = silent_ns;
  event.silent_port[0] = '\0';
  if (silent != nullptr) {
    const std::string& owner = silent->owner().name();
    const std::string& port = silent->name();
    std::snprintf(event.silent_port, sizeof event.silent_port, "%s.%s", owner.c_str(), port.c_str());
  }
  watchdog.events_->write(&event, sizeof event);
}

MonoTime ConnectionTimer::check_rate_limit(Connection& connection, MonoTime now) {
  if (connection.polled()) {
    // Fixed ticks from the first pass; ticks missed (a late wake) are skipped, not caught up.
    const std::int64_t period = connection.rate_interval().count;
    if (connection.next_poll == 0) connection.next_poll = now.ns + period;
    if (now.ns < connection.next_poll) return MonoTime{connection.next_poll};
    if (connection.held_due().ns != 0 && !connection.release_held(now)) return now + kRetry;
    connection.next_poll += ((now.ns - connection.next_poll) / period + 1) * period;
    return MonoTime{connection.next_poll};
  }
  const MonoTime due = connection.held_due();
  if (due.ns == 0) return now + std::max(Nanos{connection.rate_interval().count / 4}, kRetry);
  if (now < due) return due;
  if (!connection.release_held(now)) return now + kRetry;
  return now + connection.rate_interval();
}

void ConnectionTimer::run() {
  prctl(PR_SET_NAME, "pp-conn-timer", 0, 0, 0);
  prctl(PR_SET_TIMERSLACK, 1UL, 0, 0, 0);  // act at the deadline, not 50 us after it
  std::unique_lock<std::mutex> lock(mutex_);
  while (!stopping_) {
    const MonoTime next = check(mono_now());
    // steady_clock is CLOCK_MONOTONIC here, the clock of every stamp on the path.
    const auto until = std::chrono::steady_clock::time_point(std::chrono::nanoseconds(next.ns));
    wake_.wait_until(lock, until, [this] { return stopping_; });
  }
}

}  // namespace polyport
