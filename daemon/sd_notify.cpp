#include "sd_notify.hpp"

#include <algorithm>
#include <cstdint>
#include <string>

#ifdef POLYPORT_WITH_SYSTEMD
#include <systemd/sd-daemon.h>
#endif

namespace polyport::daemon {

ServiceNotifier::ServiceNotifier() {
#ifdef POLYPORT_WITH_SYSTEMD
  std::uint64_t usec = 0;
  // unset_environment = 0: the variables stay for what the daemon starts (nothing today).
  if (sd_watchdog_enabled(0, &usec) > 0 && usec > 0) {
    // Half the interval, as sd_watchdog_enabled(3) recommends: one late wake-up of the main
    // loop does not get the daemon killed.
    ping_interval_ = std::chrono::duration_cast<Clock::duration>(std::chrono::microseconds(usec / 2));
    next_ping_ = Clock::now();
  }
#endif
}

void ServiceNotifier::send([[maybe_unused]] std::string_view message) {
#ifdef POLYPORT_WITH_SYSTEMD
  // Fails only when NOTIFY_SOCKET names nothing that listens; nothing to do about that here.
  sd_notify(0, std::string(message).c_str());
#endif
}

void ServiceNotifier::ready(std::string_view status) { send("READY=1\nSTATUS=" + std::string(status)); }

void ServiceNotifier::status(std::string_view status) { send("STATUS=" + std::string(status)); }

void ServiceNotifier::stopping(std::string_view status) { send("STOPPING=1\nSTATUS=" + std::string(status)); }

void ServiceNotifier::ping_if_due(Clock::time_point now) {
  if (!watchdog_enabled() || now < next_ping_) return;
  send("WATCHDOG=1");
  next_ping_ = now + ping_interval_;
}

std::chrono::milliseconds ServiceNotifier::wait_at_most(Clock::time_point now, std::chrono::milliseconds longest) const {
  if (!watchdog_enabled()) return longest;
  if (now >= next_ping_) return std::chrono::milliseconds(0);
  // Rounded up: waking a little after the due time is fine, spinning before it is not.
  const auto until = std::chrono::ceil<std::chrono::milliseconds>(next_ping_ - now);
  return std::min(longest, until);
}

}  // namespace polyport::daemon
