// The thread of the connections' timed policies: watchdogs (watchdog.hpp) and rate limits
// (Connection::set_rate_limit). It sleeps until the earliest instant one of them has
// something to do (timer slack 1 ns), then:
//  - watchdogs: updates their states, counts trips and recoveries, tells the notifier, and
//    hands the safe value to a push-mode target whose source went silent;
//  - rate limits: hands over a sample held for its turn when the turn comes (a rate-limited
//    connection without a held sample is looked at every quarter interval, at least every
//    100 us, since the writer does not wake this thread).
// Started by the engine when the application has such a policy; stop() joins it. It never
// waits for the forwarding path: when the writer has a connection at that moment, it tries
// again 100 us later.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <functional>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "polyport/base/clock.hpp"

namespace polyport {

class Connection;
class ConnectionWatchdog;
class DataOutPort;

class ConnectionTimer {
 public:
  using Notify = std::function<void(const std::string& message, bool problem)>;

  ConnectionTimer() = default;
  ConnectionTimer(const ConnectionTimer&) = delete;
  ConnectionTimer& operator=(const ConnectionTimer&) = delete;
  ~ConnectionTimer() { stop(); }

  // Control thread, also while the thread runs (Engine::apply); the thread looks at it from
  // its next pass, at once.
  void add(Connection& connection);
  // Control thread, also while the thread runs (Engine::remove_connection): the thread no
  // longer looks at `connection` once this returns.
  void remove(const Connection& connection);
  bool empty() const noexcept { return connections_.empty(); }
  void start(Notify notify);
  void stop();
  // One pass at `now` (what the thread does at each wake); returns when to look next.
  MonoTime check(MonoTime now);

 private:
  MonoTime check_watchdog(Connection& connection, MonoTime now);
  MonoTime check_rate_limit(Connection& connection, MonoTime now);
  void tell(ConnectionWatchdog& watchdog, std::int32_t kind, std::int64_t silent_ns, const DataOutPort* silent);
  void run();

  std::vector<Connection*> connections_;
  Notify notify_;
  std::mutex mutex_;
  std::condition_variable wake_;
  bool stopping_ = false;
  std::thread thread_;
};

}  // namespace polyport
