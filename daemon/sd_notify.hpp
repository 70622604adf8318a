// systemd's service notifications (sd_notify(3)) for polyportd run under a Type=notify unit
// (config/polyportd.service): READY=1 once the application runs, WATCHDOG=1 pings from the
// main loop at half the unit's WatchdogSec, STATUS= lines, STOPPING=1. Outside systemd
// (no NOTIFY_SOCKET) every call does nothing; so does a build without libsystemd.
//
// Runs on the daemon's main thread only, never on the forwarding path: a ping proves that
// the main loop (signals, the admin socket, reloads) still turns.
#pragma once

#include <chrono>
#include <string_view>

namespace polyport::daemon {

class ServiceNotifier {
 public:
  using Clock = std::chrono::steady_clock;

  // Reads the watchdog's interval (WATCHDOG_USEC, for this process: WATCHDOG_PID).
  ServiceNotifier();

  void ready(std::string_view status);
  void status(std::string_view status);
  void stopping(std::string_view status);

  // Sends WATCHDOG=1 when half the watchdog's interval has passed since the last ping.
  void ping_if_due(Clock::time_point now);
  // How long the main loop may sleep before the next ping is due (`longest` when systemd
  // does not watch the daemon).
  std::chrono::milliseconds wait_at_most(Clock::time_point now, std::chrono::milliseconds longest) const;

  bool watchdog_enabled() const { return ping_interval_.count() > 0; }
  Clock::duration ping_interval() const { return ping_interval_; }

 private:
  void send(std::string_view message);

  Clock::duration ping_interval_{0};  // half of WatchdogSec; zero: no watchdog
  Clock::time_point next_ping_{};
};

}  // namespace polyport::daemon
