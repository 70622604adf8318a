// Periodic execution contexts: one thread that wakes at absolute deadlines
// (clock_nanosleep TIMER_ABSTIME on CLOCK_MONOTONIC, so the period does not drift) and runs
// its components in order. A context records how late each wake-up was (jitter), how long
// each cycle took, and overruns (a cycle that ended past the next deadline; missed periods
// are skipped, not run back-to-back).
//
// With a spin tail (ExecutionSettings::spin > 0) the thread sleeps only until that long before
// each deadline, then spins on CLOCK_MONOTONIC (with a pause instruction) until the deadline,
// still applying commands and seeing stop(): the wake-up no longer depends on how late the
// kernel wakes a sleeper, at the cost of a busy core for the tail of every period.
//
// The period can change while the context runs (set_period, from any thread: a component's
// request_period): the thread reads it once per cycle, so the next deadline is the last one
// plus the new period. A spin tail longer than the new period is cut to it.
//
// Lifecycle commands (and property changes) for a component that belongs to a running context
// are executed by the context's thread between cycles, so every hook of a component runs on
// one thread.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "polyport/base/clock.hpp"
#include "polyport/runtime/histogram.hpp"
#include "polyport/runtime/pi_mutex.hpp"
#include "polyport/runtime/lifecycle.hpp"
#include "polyport/profile/profile.hpp"

namespace polyport {

class ProvidedServicePort;

struct ExecutionSettings {
  std::string name;
  Nanos period{10'000'000};
  SchedPolicy policy = SchedPolicy::other;
  int priority = 0;
  std::optional<int> cpu;
  Nanos spin{0};  // the spin tail before each deadline; 0: sleep all the way
  // Cycles at k * period + phase on CLOCK_MONOTONIC (0 <= phase < period); none: the first
  // cycle runs at start() and the others follow it.
  std::optional<Nanos> phase;
};

// The first instant at or after `now` of the grid k * period + phase (period > 0,
// 0 <= phase < period; times from CLOCK_MONOTONIC's zero).
MonoTime first_on_grid(MonoTime now, Nanos period, Nanos phase) noexcept;

class ExecutionContext {
 public:
  static constexpr Nanos kMinPeriod{1'000};  // 1 us
  // The shortest period a real-time context takes at run time (set_period): faster, it would
  // overrun into a thread that never sleeps at real-time priority.
  static constexpr Nanos kMinRealTimePeriod{100'000};  // 100 us
  explicit ExecutionContext(ExecutionSettings settings);
  ExecutionContext(const ExecutionContext&) = delete;
  ExecutionContext& operator=(const ExecutionContext&) = delete;
  ~ExecutionContext();

  // Control thread, before start(): a component and the provided ports whose queued calls
  // this context serves before running the component each cycle.
  void add(Lifecycle& lifecycle, std::vector<ProvidedServicePort*> served = {});

  // Starts the thread. Real-time priority and CPU pinning are applied when asked for; when
  // the system refuses them, `warnings` says so and the context runs without them.
  void start(std::vector<std::string>& warnings);
  void stop();  // joins the thread; queued calls are cancelled
  bool running() const noexcept { return running_.load(std::memory_order_acquire); }
  // Stopped for good: every component it ran left (a reload). Kept in memory (its members'
  // interceptors, kept too, still point at it), no longer listed, started or shared.
  void retire() {
    stop();
    retired_ = true;
  }
  bool retired() const noexcept { return retired_; }

  // Applies a lifecycle command on the context's thread (or inline when it is not running)
  // and waits for the result.
  ReturnCode command(Lifecycle& lifecycle, LifecycleCommand command);
  // Runs `task` the same way: on the context's thread between two cycles, or inline when the
  // context is not running; for what must happen on a component's own thread (a property
  // change). Control path.
  ReturnCode call(const std::function<ReturnCode()>& task);

  // settings().period stays what the profile asked for (shared contexts are keyed by it);
  // period() is the one the thread runs at now.
  const ExecutionSettings& settings() const noexcept { return settings_; }
  Nanos period() const noexcept { return Nanos{period_ns_.load(std::memory_order_relaxed)}; }
  // From the next cycle on; false (and nothing changed) below kMinPeriod, below
  // kMinRealTimePeriod for a real-time context, or under twice its spin tail (the thread must
  // still sleep in each period). Any thread.
  bool set_period(Nanos period) noexcept;
  std::uint64_t period_changes() const noexcept { return period_changes_.load(std::memory_order_relaxed); }
  const std::vector<Lifecycle*>& members() const noexcept { return members_; }
  std::uint64_t cycles() const noexcept { return cycles_.load(std::memory_order_relaxed); }
  std::uint64_t overruns() const noexcept { return overruns_.load(std::memory_order_relaxed); }
  std::uint64_t missed_periods() const noexcept { return missed_.load(std::memory_order_relaxed); }
  const LatencyHistogram& wake_jitter() const noexcept { return jitter_; }   // wake - deadline
  const LatencyHistogram& cycle_time() const noexcept { return cycle_time_; }
  bool realtime_applied() const noexcept { return realtime_applied_; }
  // The thread's timer slack once it runs (the context asks for 1 ns); -1 before, or when the
  // kernel refused.
  long timer_slack_ns() const noexcept { return timer_slack_ns_.load(std::memory_order_relaxed); }
  bool pinned() const noexcept { return pinned_; }

 private:
  static constexpr std::size_t kPrefaultedStack = 256 * 1024;
  void run();
  void prefault_stack() noexcept;
  void apply_pending_command();
  void wake() noexcept;
  void sleep_until(MonoTime deadline, Nanos spin);

  ExecutionSettings settings_;
  std::vector<Lifecycle*> members_;
  std::vector<ProvidedServicePort*> served_;
  std::thread thread_;
  std::atomic<bool> running_{false};
  std::atomic<bool> stop_requested_{false};
  std::atomic<std::uint32_t> wake_word_{0};  // a futex: bumped to wake the sleeping thread

  // One pending command at a time, handed over under the mutex (control path only). The mutex
  // inherits priority: a real-time context never waits behind an ordinary caller thread.
  PiMutex command_mutex_;
  PiCondition command_done_;
  std::atomic<bool> command_pending_{false};  // a caller's command is in (callers queue behind it)
  std::atomic<bool> command_to_run_{false};   // ... and this thread has not run it yet
  const std::function<ReturnCode()>* command_task_ = nullptr;
  ReturnCode command_result_{};
  bool command_finished_ = false;

  std::atomic<std::int64_t> period_ns_{0};
  std::atomic<std::uint64_t> period_changes_{0};
  std::atomic<std::uint64_t> cycles_{0};
  std::atomic<std::uint64_t> overruns_{0};
  std::atomic<std::uint64_t> missed_{0};
  LatencyHistogram jitter_;
  LatencyHistogram cycle_time_;
  bool realtime_applied_ = false;
  std::atomic<long> timer_slack_ns_{-1};
  bool pinned_ = false;
  bool retired_ = false;
};

// Owns every execution context of an application. Periodic components with the same period,
// scheduling policy, priority, CPU and spin tail share one context (as OPRoS executors do), in the order
// they were added; `periodic-exclusive` ones get their own.
class ExecutionContextPool {
 public:
  ExecutionContext& shared(const ExecutionSettings& settings);
  ExecutionContext& exclusive(const ExecutionSettings& settings);
  // Starts the contexts not running yet (retired ones aside). At the first call, when one asks
  // for a real-time policy, the process's memory is locked first (mlockall), where the limits
  // allow; otherwise one warning. Later calls (a reload) never lock: locking the whole address
  // space stalls every thread meanwhile; a real-time context they start gets a warning.
  void start_all(std::vector<std::string>& warnings);
  void stop_all();  // and unlocks the memory it locked
  bool memory_locked() const noexcept { return memory_locked_; }
  // Whether memory was locked at any time since the pool was made: what a run's final
  // statistics report, written after stop_all unlocked it.
  bool memory_was_locked() const noexcept { return memory_was_locked_; }
  const std::vector<std::unique_ptr<ExecutionContext>>& contexts() const noexcept { return contexts_; }

 private:
  void lock_memory(std::vector<std::string>& warnings);

  std::vector<std::unique_ptr<ExecutionContext>> contexts_;
  std::vector<bool> exclusive_;
  bool memory_locked_ = false;
  bool memory_was_locked_ = false;
  bool lock_decided_ = false;  // the first start_all decided
};

}  // namespace polyport
