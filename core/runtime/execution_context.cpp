// Periodic execution contexts. The thread sleeps to absolute CLOCK_MONOTONIC deadlines (with
// a spin tail: to that much before them, then spins to them); between cycles it applies at most one pending lifecycle command (handed over under a
// mutex: the control path, never the data path) and serves queued service calls.
#include "polyport/runtime/execution_context.hpp"

#include <linux/futex.h>
#include <pthread.h>
#include <sys/mman.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sched.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <algorithm>
#include <climits>

#include <cerrno>
#include <cstring>

#include "polyport/base/serial_counter.hpp"
#include "polyport/runtime/component_api.hpp"
#include "polyport/runtime/service.hpp"
#include "polyport/runtime/thread_scheduling.hpp"

namespace polyport {

MonoTime first_on_grid(MonoTime now, Nanos period, Nanos phase) noexcept {
  const std::int64_t since = now.ns - phase.count;
  std::int64_t k = since / period.count;
  if (k * period.count < since) ++k;  // round up; negative `since` truncates up already
  return MonoTime{k * period.count + phase.count};
}

ExecutionContext::ExecutionContext(ExecutionSettings settings) : settings_(std::move(settings)) {
  // Models refuse periods under kMinPeriod with a diagnostic; this guards the arithmetic.
  if (settings_.period < kMinPeriod) settings_.period = kMinPeriod;
  if (settings_.spin < Nanos{0}) settings_.spin = Nanos{0};
  if (settings_.spin > settings_.period) settings_.spin = settings_.period;
  if (settings_.phase && (settings_.phase->count < 0 || *settings_.phase >= settings_.period)) {
    settings_.phase = Nanos{((settings_.phase->count % settings_.period.count) + settings_.period.count) %
                            settings_.period.count};
  }
  period_ns_.store(settings_.period.count, std::memory_order_relaxed);
}

bool ExecutionContext::set_period(Nanos period) noexcept {
  if (period < kMinPeriod) return false;
  // A real-time thread that never sleeps starves every ordinary thread of its CPU: a run-time
  // change (which a peer may ask for, e.g. through a data port) keeps a sleep in each period.
  if (settings_.policy != SchedPolicy::other && period < kMinRealTimePeriod) return false;
  if (settings_.spin.count > 0 && period.count < 2 * settings_.spin.count) return false;
  period_ns_.store(period.count, std::memory_order_relaxed);
  period_changes_.fetch_add(1, std::memory_order_relaxed);
  return true;
}

ExecutionContext::~ExecutionContext() { stop(); }

void ExecutionContext::add(Lifecycle& lifecycle, std::vector<ProvidedServicePort*> served) {
  members_.push_back(&lifecycle);
  lifecycle.component().attach_execution_context(this);
  served_.insert(served_.end(), served.begin(), served.end());
}

void ExecutionContext::start(std::vector<std::string>& warnings) {
  if (running()) return;
  stop_requested_.store(false, std::memory_order_release);
  running_.store(true, std::memory_order_release);
  thread_ = std::thread([this] { run(); });

  const std::string name = settings_.name.substr(0, 15);  // the kernel's limit
  pthread_setname_np(thread_.native_handle(), name.c_str());
  const SchedulingOutcome outcome = apply_scheduling(
      thread_.native_handle(), ThreadScheduling{settings_.policy, settings_.priority, settings_.cpu},
      "execution context '" + settings_.name + "'");
  realtime_applied_ = outcome.realtime_applied;
  pinned_ = outcome.pinned;
  if (!outcome.problem.empty()) warnings.push_back(outcome.problem);
  // The command lock is the one lock a real-time cycle shares with the control thread; without
  // priority inheritance an ordinary thread holding it can delay the cycle unboundedly.
  if (realtime_applied_ && !command_mutex_.inherits_priority()) {
    warnings.push_back("execution context '" + settings_.name +
                       "': its command lock has no priority inheritance (PTHREAD_PRIO_INHERIT refused); "
                       "a lifecycle command may delay a cycle");
  }
}

void ExecutionContext::stop() {
  if (!thread_.joinable()) return;
  stop_requested_.store(true, std::memory_order_release);
  wake();
  thread_.join();
  running_.store(false, std::memory_order_release);
  for (ProvidedServicePort* port : served_) port->cancel_queued(Status::not_active);
}

ReturnCode ExecutionContext::command(Lifecycle& lifecycle, LifecycleCommand command) {
  return call([&] { return lifecycle.apply(command); });
}

ReturnCode ExecutionContext::call(const std::function<ReturnCode()>& task) {
  std::unique_lock<PiMutex> lock(command_mutex_);
  // One command at a time; commands are rare, so waiting callers simply queue on the mutex.
  command_done_.wait(lock, [&] { return !command_pending_.load(std::memory_order_acquire) || !running(); });
  if (!running()) return task();  // serialized by the mutex
  command_task_ = &task;
  command_finished_ = false;
  command_pending_.store(true, std::memory_order_release);
  command_to_run_.store(true, std::memory_order_release);
  wake();
  command_done_.wait(lock, [&] { return command_finished_ || !running(); });
  // If the thread ended before taking the command, run it here, still under the mutex.
  const ReturnCode result = command_finished_ ? command_result_ : task();
  command_to_run_.store(false, std::memory_order_release);
  command_pending_.store(false, std::memory_order_release);
  command_done_.notify_all();
  return result;
}

void ExecutionContext::apply_pending_command() {
  std::lock_guard<PiMutex> lock(command_mutex_);
  if (!command_to_run_.load(std::memory_order_acquire) || command_finished_) return;
  command_result_ = (*command_task_)();
  command_finished_ = true;
  // Done: the thread goes back to sleep. The caller clears command_pending_ once it has read
  // the result, which may take a while if it is an ordinary thread and this one is real-time;
  // checking command_pending_ meanwhile would spin this thread until then.
  command_to_run_.store(false, std::memory_order_release);
  command_done_.notify_all();
}

void ExecutionContext::wake() noexcept {
  wake_word_.fetch_add(1, std::memory_order_release);
  syscall(SYS_futex, reinterpret_cast<std::uint32_t*>(&wake_word_), FUTEX_WAKE_PRIVATE, INT_MAX, nullptr, nullptr, 0);
}

namespace {

inline void cpu_pause() noexcept {
#if defined(__x86_64__) || defined(__i386__)
  __builtin_ia32_pause();
#elif defined(__aarch64__)
  asm volatile("yield" ::: "memory");
#endif
}

}  // namespace

void ExecutionContext::sleep_until(MonoTime deadline, Nanos spin) {
  // A futex wait with an absolute CLOCK_MONOTONIC deadline (FUTEX_WAIT_BITSET) sleeps as
  // precisely as clock_nanosleep, but a command or stop() can wake it at once.
  const MonoTime sleep_end = deadline + Nanos{-spin.count};
  for (;;) {
    const std::uint32_t seen = wake_word_.load(std::memory_order_acquire);
    if (stop_requested_.load(std::memory_order_acquire)) return;
    if (command_to_run_.load(std::memory_order_acquire)) {
      apply_pending_command();
      continue;
    }
    if (mono_now() >= sleep_end) break;
    const timespec until = to_timespec(sleep_end);
    syscall(SYS_futex, reinterpret_cast<std::uint32_t*>(&wake_word_), FUTEX_WAIT_BITSET_PRIVATE, seen, &until,
            nullptr, FUTEX_BITSET_MATCH_ANY);
  }
  if (spin.count == 0) return;  // sleep_end was the deadline
  // The spin tail: the clock, a pause instruction, and commands and stop as above.
  while (mono_now() < deadline) {
    if (stop_requested_.load(std::memory_order_relaxed)) return;
    if (command_to_run_.load(std::memory_order_relaxed)) apply_pending_command();
    cpu_pause();
  }
}

// A real-time context touches the stack it may use once, before its first cycle, so that no
// cycle pays a page fault for it (with memory locked, the pages then stay).
void ExecutionContext::prefault_stack() noexcept {
  volatile std::uint8_t stack[kPrefaultedStack];
  for (std::size_t i = 0; i < sizeof stack; i += 4096) stack[i] = 0;
  stack[sizeof stack - 1] = 0;
}

void ExecutionContext::run() {
  // The kernel may defer a sleeping thread's wake-up by its timer slack (50 us by default) to
  // batch wake-ups; a periodic context wants its deadline, so it asks for the minimum.
  if (prctl(PR_SET_TIMERSLACK, 1UL, 0UL, 0UL, 0UL) == 0) {
    timer_slack_ns_.store(prctl(PR_GET_TIMERSLACK, 0UL, 0UL, 0UL, 0UL), std::memory_order_relaxed);
  }
  if (settings_.policy != SchedPolicy::other) prefault_stack();
  MonoTime deadline = mono_now();
  if (settings_.phase) {
    // On the grid from the first cycle on: wait for its first instant.
    deadline = first_on_grid(deadline, settings_.period, *settings_.phase);
    sleep_until(deadline, settings_.spin);
  }
  while (!stop_requested_.load(std::memory_order_acquire)) {
    if (command_to_run_.load(std::memory_order_acquire)) apply_pending_command();

    const MonoTime cycle_start = mono_now();
    for (ProvidedServicePort* port : served_) port->serve_queued();
    for (Lifecycle* member : members_) {
      // <notifications auto="true">: busy before, idle after each onExecute of an active member.
      ComponentBase& component = member->component();
      const bool notify = component.auto_notifications() && member->state() == LifecycleState::active;
      if (notify) component.notify_busy();
      member->execute();
      if (notify) component.notify_idle();
    }
    const MonoTime cycle_end = mono_now();
    // This thread alone counts and records its cycles (serial_counter.hpp).
    add_serial(cycles_);
    cycle_time_.record_serial((cycle_end - cycle_start).count);

    // Read once per cycle: a set_period() takes effect from this deadline on.
    const Nanos period = this->period();
    deadline = deadline + period;
    if (cycle_end > deadline) {
      // Overrun: skip the periods already missed instead of running them back-to-back.
      overruns_.fetch_add(1, std::memory_order_relaxed);
      const std::int64_t behind = (cycle_end - deadline).count / period.count + 1;
      missed_.fetch_add(static_cast<std::uint64_t>(behind), std::memory_order_relaxed);
      deadline = deadline + Nanos{behind * period.count};
    }
    sleep_until(deadline, settings_.spin < period ? settings_.spin : period);
    if (stop_requested_.load(std::memory_order_acquire)) break;
    jitter_.record_serial((mono_now() - deadline).count);
  }
  // Let a waiting command caller fall back to running inline.
  std::lock_guard<PiMutex> lock(command_mutex_);
  running_.store(false, std::memory_order_release);
  command_done_.notify_all();
}

ExecutionContext& ExecutionContextPool::shared(const ExecutionSettings& settings) {
  for (std::size_t i = 0; i < contexts_.size(); ++i) {
    const ExecutionSettings& s = contexts_[i]->settings();
    // A running context's members are fixed: a component added while the application runs
    // (a reload) gets a new context.
    if (!exclusive_[i] && !contexts_[i]->running() && !contexts_[i]->retired() && s.period == settings.period && s.policy == settings.policy &&
        s.priority == settings.priority && s.cpu == settings.cpu && s.spin == settings.spin &&
        s.phase == settings.phase) {
      return *contexts_[i];
    }
  }
  contexts_.push_back(std::make_unique<ExecutionContext>(settings));
  exclusive_.push_back(false);
  return *contexts_.back();
}

ExecutionContext& ExecutionContextPool::exclusive(const ExecutionSettings& settings) {
  contexts_.push_back(std::make_unique<ExecutionContext>(settings));
  exclusive_.push_back(true);
  return *contexts_.back();
}

void ExecutionContextPool::start_all(std::vector<std::string>& warnings) {
  const bool realtime = std::any_of(contexts_.begin(), contexts_.end(), [](const auto& c) {
    return c->settings().policy != SchedPolicy::other;
  });
  if (!lock_decided_) {
    lock_decided_ = true;
    if (realtime) lock_memory(warnings);
  } else if (!memory_locked_ && std::any_of(contexts_.begin(), contexts_.end(), [](const auto& c) {
               return !c->running() && !c->retired() && c->settings().policy != SchedPolicy::other;
             })) {
    warnings.push_back("memory not locked for a real-time context started while the application runs "
                       "(memory is locked at start only, when a real-time context is there then)");
  }
  for (auto& context : contexts_) {
    if (!context->retired()) context->start(warnings);
  }
}

// Locks the process's pages (now and later) in memory, so that a real-time context never
// waits for a page to come back. Only where the limit allows locking everything: with
// MCL_FUTURE under a finite RLIMIT_MEMLOCK, an allocation past the limit would fail instead.
void ExecutionContextPool::lock_memory(std::vector<std::string>& warnings) {
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
  // The sanitizers' shadow memory is terabytes of reserved address space: never locked.
  warnings.push_back("memory not locked: a sanitizer build");
  return;
#endif
  rlimit limit{};
  const bool unlimited = getrlimit(RLIMIT_MEMLOCK, &limit) == 0 && limit.rlim_cur == RLIM_INFINITY;
  if (!unlimited && geteuid() != 0) {
    warnings.push_back("memory not locked: RLIMIT_MEMLOCK is " + std::to_string(limit.rlim_cur) +
                       " bytes (a real-time context may wait for page faults; `ulimit -l unlimited` or "
                       "LimitMEMLOCK=infinity allows locking)");
    return;
  }
  if (mlockall(MCL_CURRENT | MCL_FUTURE) != 0) {
    warnings.push_back(std::string("memory not locked: mlockall: ") + std::strerror(errno) +
                       " (a real-time context may wait for page faults)");
    return;
  }
  memory_locked_ = true;
  memory_was_locked_ = true;
}

void ExecutionContextPool::stop_all() {
  for (auto& context : contexts_) context->stop();
  if (memory_locked_ && munlockall() == 0) memory_locked_ = false;
  lock_decided_ = false;
}

}  // namespace polyport
