// Connection watchdogs. See watchdog.hpp; the thread that watches them is
// connection_timer.cpp.
#include "polyport/runtime/watchdog.hpp"

#include <algorithm>
#include <cstdio>

#include "polyport/runtime/port.hpp"

namespace polyport {

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

void ConnectionWatchdog::set_events(DataOutPort* port, const std::string& connection_name) {
  events_ = port;
  std::snprintf(event_.connection, sizeof event_.connection, "%s", connection_name.c_str());
}

MonoTime ConnectionWatchdog::expiry() const noexcept {
  MonoTime oldest = last_write(source_);
  if (upstream_) oldest = std::min(oldest, last_write(*upstream_));
  return oldest + deadline_;
}

}  // namespace polyport
