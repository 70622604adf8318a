// The fail-safe of a data connection (<watchdog> in a profile): a deadline on its source port
// and, optionally, on an upstream port (the input the source's samples derive from, e.g. the
// joystick behind a controller's motor command), and a bound on a sample's age.
//
// While the watched ports have written within the deadline, samples pass as usual. Once one
// has been silent longer, or a sample's source stamp is older than max_age, the target gets
// the safe value (encoded once, at build, in the target's wire format) instead:
//   - on the forwarding path, a sample that arrives while the upstream is silent, or that is
//     too old, is replaced by the safe value (Connection::deliver);
//   - a reader that pulls while the source is silent reads the safe value (Connection::take);
//   - a push-mode target (a foreign model's writer) whose source has gone silent gets the
//     safe value from the connection timer thread (connection_timer.hpp) at the moment the
//     deadline passes, since nothing else would write to it.
// The timer thread also keeps the state (waiting for a first sample, ok, tripped), counts
// trips and recoveries, and reports each change through the engine's notifier.
//
// Threads: fresh() and the counters are read on the forwarding thread, the reader's thread
// and the timer thread: relaxed atomics, no lock, no allocation. The connection keeps the
// timer thread's safe value and a forwarded sample from reaching a push-mode sink at once.
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "polyport/base/clock.hpp"
#include "polyport/runtime/sample_buffer.hpp"

namespace polyport {

class Connection;
class DataOutPort;

enum class WatchdogState : std::uint8_t {
  waiting,  // no sample from a watched port yet: the target has the safe value
  ok,       // the watched ports write within the deadline
  tripped,  // one went silent: the target has the safe value until it writes again
};
std::string_view to_string(WatchdogState state) noexcept;

struct WatchdogCounters {
  std::atomic<std::uint64_t> trips{0};        // ok -> tripped
  std::atomic<std::uint64_t> recoveries{0};   // tripped -> ok
  std::atomic<std::uint64_t> safe_values{0};  // safe values handed to the target
  std::atomic<std::uint64_t> stale{0};        // samples older than max_age, replaced
};

// polyport::WatchdogEvent's flat layout (config/types/watchdog_event.idl); the engine checks
// the registered type against it before it connects an event port.
struct WatchdogEventSample {
  std::int32_t kind = 0;  // 0 WATCHDOG_TRIPPED, 1 WATCHDOG_RECOVERED
  std::uint64_t trips = 0;
  std::uint64_t recoveries = 0;
  std::int64_t silent_ns = 0;
  char connection[128] = {};
  char silent_port[128] = {};
};

class ConnectionWatchdog {
 public:
  // `safe` is the safe value in the target port's wire format.
  ConnectionWatchdog(const DataOutPort& source, const DataOutPort* upstream, Nanos deadline, Nanos max_age,
                     std::vector<std::byte> safe);

  // Whether every watched port wrote within the deadline before `now`.
  bool fresh(MonoTime now) const noexcept {
    return now - last_write(source_) <= deadline_ && (upstream_ == nullptr || now - last_write(*upstream_) <= deadline_);
  }
  // Whether a sample's source stamp is older than max_age at `now` (false without either).
  bool too_old(const SampleMeta& meta, MonoTime now) const noexcept {
    return max_age_.count > 0 && meta.t_source.ns != 0 && now - meta.t_source > max_age_;
  }
  // The instant the watched ports go stale unless one of them writes again.
  MonoTime expiry() const noexcept;

  const std::byte* safe_bytes() const noexcept { return safe_.data(); }
  std::uint32_t safe_size() const noexcept { return static_cast<std::uint32_t>(safe_.size()); }

  // The port that tells of trips and recoveries (an engine-owned output port connected to
  // the profile's <event> port); written by the timer thread only.
  void set_events(DataOutPort* port, const std::string& connection_name);
  DataOutPort* events() const noexcept { return events_; }

  const DataOutPort& source() const noexcept { return source_; }
  const DataOutPort* upstream() const noexcept { return upstream_; }
  Nanos deadline() const noexcept { return deadline_; }
  Nanos max_age() const noexcept { return max_age_; }
  WatchdogState state() const noexcept { return state_.load(std::memory_order_relaxed); }
  WatchdogCounters& counters() noexcept { return counters_; }
  const WatchdogCounters& counters() const noexcept { return counters_; }

 private:
  friend class ConnectionTimer;
  static MonoTime last_write(const DataOutPort& port) noexcept;

  const DataOutPort& source_;
  const DataOutPort* upstream_;
  Nanos deadline_;
  Nanos max_age_;
  std::vector<std::byte> safe_;
  std::atomic<WatchdogState> state_{WatchdogState::waiting};
  bool safe_written_ = false;  // timer thread: the safe value went out since the last ok
  DataOutPort* events_ = nullptr;
  WatchdogEventSample event_;  // timer thread: the next event, its connection name filled in
  WatchdogCounters counters_;
};

}  // namespace polyport
