#include "polyport/base/clock.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <limits>
#include <memory>
#include <mutex>
#include <optional>
#include <system_error>
#include <thread>

#include "polyport/base/tsc_discipline.hpp"

#if defined(__x86_64__)
#include <cpuid.h>
#include <pthread.h>
#endif

namespace polyport {

namespace detail {
TscClock g_tsc_clock;
}  // namespace detail

namespace {

// The fastest of a few back-to-back CLOCK_MONOTONIC reads: what one read costs.
double system_read_ns() noexcept {
  std::int64_t best = std::numeric_limits<std::int64_t>::max();
  std::int64_t previous = detail::system_ns(CLOCK_MONOTONIC);
  for (int i = 0; i < 16; ++i) {
    const std::int64_t now = detail::system_ns(CLOCK_MONOTONIC);
    best = std::min(best, now - previous);
    previous = now;
  }
  return static_cast<double>(best);
}

#if defined(__x86_64__)

// An invariant TSC ticks at one rate in every power state and on every core: CPUID
// 0x80000007, EDX bit 8 (Intel SDM vol. 3, 18.17.1; AMD APM vol. 3, E.4.18).
bool has_invariant_tsc() noexcept {
  unsigned eax = 0, ebx = 0, ecx = 0, edx = 0;
  if (__get_cpuid(0x80000000U, &eax, &ebx, &ecx, &edx) == 0 || eax < 0x80000007U) return false;
  if (__get_cpuid(0x80000007U, &eax, &ebx, &ecx, &edx) == 0) return false;
  return (edx & (1U << 8)) != 0;
}

// One CLOCK_MONOTONIC read paired with the TSC: the tightest bracket of a few tries, its
// middle as the TSC at the read; and CLOCK_REALTIME's offset from it, from the tightest of a
// few CLOCK_MONOTONIC brackets around a CLOCK_REALTIME read (where each read is a system call,
// one bracket preempted midway put the offset tens of µs off).
detail::TscPoint sample() noexcept {
  detail::TscPoint best;
  best.bracket = std::numeric_limits<std::int64_t>::max();
  for (int i = 0; i < 5; ++i) {
    const std::int64_t before = detail::read_tsc();
    const std::int64_t mono = detail::system_ns(CLOCK_MONOTONIC);
    const std::int64_t after = detail::read_tsc();
    if (after - before < best.bracket) {
      best.bracket = after - before;
      best.tsc = before + (after - before) / 2;
      best.mono_ns = mono;
    }
  }
  std::int64_t tightest = std::numeric_limits<std::int64_t>::max();
  for (int i = 0; i < 5; ++i) {
    const std::int64_t mono_before = detail::system_ns(CLOCK_MONOTONIC);
    const std::int64_t wall = detail::system_ns(CLOCK_REALTIME);
    const std::int64_t mono_after = detail::system_ns(CLOCK_MONOTONIC);
    if (mono_after - mono_before < tightest) {
      tightest = mono_after - mono_before;
      best.wall_minus_mono_ns = wall - (mono_before + (mono_after - mono_before) / 2);
    }
  }
  return best;
}

// The one writer of g_tsc_clock (see TscClock): the copy readers are not using is changed
// first, then the other. The sequence moves before either copy changes (release: a reader
// that sees a copy's new fields sees the sequence that sends it elsewhere). Readers that
// read the TSC before the sequence sends them to the new line read the old one: the new
// line is joined to the old at a TSC read after that (TscDiscipline::rejoin), so no reader
// finds it below a value the old one gave. Returns the line written.
detail::TscLine publish(const detail::TscLine& published, const detail::TscLine& line) noexcept {
  detail::TscClock& clock = detail::g_tsc_clock;
  const auto write = [](detail::TscScale& copy, const detail::TscLine& value) {
    copy.base_tsc.store(value.base_tsc, std::memory_order_relaxed);
    copy.base_mono_ns.store(value.base_mono_ns, std::memory_order_relaxed);
    copy.wall_minus_mono_ns.store(value.wall_minus_mono_ns, std::memory_order_relaxed);
    copy.ns_per_tick_q32.store(value.per_tick_q32, std::memory_order_relaxed);
  };
  const std::uint32_t sequence = clock.sequence.load(std::memory_order_relaxed);
  clock.sequence.store(sequence + 1, std::memory_order_release);  // readers: the other copy
  std::atomic_thread_fence(std::memory_order_release);
  const detail::TscLine joined = detail::TscDiscipline::rejoin(published, line, detail::read_tsc());
  write(clock.copies[sequence & 1U], joined);
  clock.sequence.store(sequence + 2, std::memory_order_release);  // readers: the new copy
  std::atomic_thread_fence(std::memory_order_release);
  write(clock.copies[(sequence + 1) & 1U], joined);
  return joined;
}

// A child of fork() has no calibration thread: it goes back to clock_gettime.
void tsc_clock_off_in_child() noexcept { detail::g_tsc_clock.active.store(false, std::memory_order_release); }

// Runs TscDiscipline: a pair 50, 100 and 200 ms after the last, then every kInterval.
class Calibrator {
 public:
  static constexpr std::chrono::milliseconds kFirstBaseline{50};
  static constexpr std::chrono::milliseconds kInterval{250};

  ~Calibrator() { stop(); }

  // Measures the first rate, publishes the first line, starts the thread, then switches
  // readers over; the TSC's rate in GHz.
  Result<double> start() {
    const detail::TscPoint anchor = sample();
    std::this_thread::sleep_for(kFirstBaseline);
    Result<detail::TscLine> first = discipline_.begin(anchor, sample());
    if (!first) return first.error();
    started_ = first.value().base_mono_ns;
    published_ = publish(first.value(), first.value());
    const double ghz = 1.0 / discipline_.ns_per_tick();
    ghz_.store(ghz, std::memory_order_relaxed);
    try {
      thread_ = std::thread([this] { run(); });
    } catch (const std::system_error& e) {
      return make_error(std::string("cannot start the TSC clock's calibration thread: ") + e.what());
    }
    detail::g_tsc_clock.active.store(true, std::memory_order_release);
    return ghz;
  }

  void stop() {
    {
      std::lock_guard lock(mutex_);
      stopping_ = true;
    }
    wake_.notify_all();
    if (thread_.joinable()) thread_.join();
  }

  ClockStats stats() const {
    ClockStats out;
    out.tsc = true;
    out.tsc_ghz = ghz_.load(std::memory_order_relaxed);
    out.calibrations = calibrations_.load(std::memory_order_relaxed);
    out.steps = steps_.load(std::memory_order_relaxed);
    out.skipped = skipped_.load(std::memory_order_relaxed);
    out.last_error_ns = last_error_.load(std::memory_order_relaxed);
    out.max_abs_error_ns = max_abs_error_.load(std::memory_order_relaxed);
    out.wall_checks = wall_checks_.load(std::memory_order_relaxed);
    if (out.wall_checks > 0)
      out.wall_error_mean_ns = static_cast<double>(wall_error_sum_.load(std::memory_order_relaxed)) /
                               static_cast<double>(out.wall_checks);
    out.wall_error_min_ns = wall_error_min_.load(std::memory_order_relaxed);
    out.wall_error_max_ns = wall_error_max_.load(std::memory_order_relaxed);
    std::lock_guard lock(mutex_);
    out.given_up = !why_given_up_.empty();
    out.why_given_up = why_given_up_;
    return out;
  }

 private:
  void run() {
    pthread_setname_np(pthread_self(), "pp-clock");
    const auto after = [](std::chrono::milliseconds interval) { return std::min(interval * 2, kInterval); };
    std::unique_lock lock(mutex_);
    for (std::chrono::milliseconds interval = kFirstBaseline;; interval = after(interval)) {
      const auto stop = [this] { return stopping_; };
      if (wake_.wait_for(lock, interval / 2, stop)) return;
      check_wall();
      if (wake_.wait_for(lock, interval - interval / 2, stop)) return;
      const std::chrono::milliseconds next = after(interval);
      const detail::TscPoint now = sample();
      Result<detail::TscDiscipline::Update> update =
          discipline_.update(now, detail::read_tsc(), std::chrono::nanoseconds(next).count());
      if (!update) {
        give_up(lock, update.error().message);
        return;
      }
      published_ = publish(published_, update.value().line);
      discipline_.adopt(published_);
      record(update.value(), now.mono_ns);
    }
  }

  // Back to clock_gettime, once it has caught up with the TSC clock (when that is ahead, as
  // while slewing back: readers must not see time go back at the switch).
  void give_up(std::unique_lock<std::mutex>& lock, const std::string& why) {
    const std::int64_t lead = published_.at(detail::read_tsc()) - detail::system_ns(CLOCK_MONOTONIC);
    if (lead > 0 && lead < 1'000'000'000)
      wake_.wait_for(lock, std::chrono::nanoseconds(lead), [this] { return stopping_; });
    detail::g_tsc_clock.active.store(false, std::memory_order_release);
    why_given_up_ = why;
  }

  // wall_now() against clock_gettime(CLOCK_REALTIME) at the middle of the tightest of five
  // TSC brackets around it (ClockStats::wall_checks), after the first second.
  void check_wall() noexcept {
    std::int64_t tightest = std::numeric_limits<std::int64_t>::max();
    std::int64_t error = 0;
    std::int64_t middle = 0;
    for (int i = 0; i < 5; ++i) {
      const std::int64_t before = detail::read_tsc();
      const std::int64_t wall = detail::system_ns(CLOCK_REALTIME);
      const std::int64_t after = detail::read_tsc();
      if (after - before < tightest) {
        tightest = after - before;
        middle = before + (after - before) / 2;
        error = published_.at(middle) + published_.wall_minus_mono_ns - wall;
      }
    }
    if (published_.at(middle) - started_ < 1'000'000'000) return;
    const std::uint64_t checks = wall_checks_.load(std::memory_order_relaxed);
    if (checks == 0 || error < wall_error_min_.load(std::memory_order_relaxed))
      wall_error_min_.store(error, std::memory_order_relaxed);
    if (checks == 0 || error > wall_error_max_.load(std::memory_order_relaxed))
      wall_error_max_.store(error, std::memory_order_relaxed);
    wall_error_sum_.fetch_add(error, std::memory_order_relaxed);
    wall_checks_.store(checks + 1, std::memory_order_release);
  }

  void record(const detail::TscDiscipline::Update& update, std::int64_t now_ns) noexcept {
    using Outcome = detail::TscDiscipline::Outcome;
    if (update.outcome == Outcome::skipped) {
      skipped_.fetch_add(1, std::memory_order_relaxed);
      return;
    }
    if (update.outcome != Outcome::steered) steps_.fetch_add(1, std::memory_order_relaxed);
    ghz_.store(1.0 / update.ns_per_tick, std::memory_order_relaxed);
    calibrations_.fetch_add(1, std::memory_order_relaxed);
    last_error_.store(update.error_ns, std::memory_order_relaxed);
    if (now_ns - started_ >= 1'000'000'000 && std::llabs(update.error_ns) > max_abs_error_.load(std::memory_order_relaxed))
      max_abs_error_.store(std::llabs(update.error_ns), std::memory_order_relaxed);
  }

  detail::TscDiscipline discipline_;  // the calibration thread's, after start()
  detail::TscLine published_;         // the line readers use; likewise
  std::int64_t started_ = 0;
  mutable std::mutex mutex_;
  std::condition_variable wake_;
  bool stopping_ = false;       // mutex_
  std::string why_given_up_;    // mutex_
  std::thread thread_;
  std::atomic<double> ghz_{0};
  std::atomic<std::uint64_t> calibrations_{0};
  std::atomic<std::uint64_t> steps_{0};
  std::atomic<std::uint64_t> skipped_{0};
  std::atomic<std::int64_t> last_error_{0};
  std::atomic<std::int64_t> max_abs_error_{0};
  std::atomic<std::uint64_t> wall_checks_{0};
  std::atomic<std::int64_t> wall_error_sum_{0};
  std::atomic<std::int64_t> wall_error_min_{0};
  std::atomic<std::int64_t> wall_error_max_{0};
};

// Whether the kernel keeps its own time with something other than the TSC: it found the TSC
// unstable (it then drops it from available_clocksource), or the administrator chose another
// source, or a hypervisor's is preferred; the TSC clock is not taken for `auto` then. The
// clock of user-mode Linux is the host's (its kernel lists only its `timer`): no opinion.
std::optional<std::string> kernel_keeps_time_without_tsc() {
  const auto read_text = [](const char* path, std::size_t lines) {
    std::string text;
    if (FILE* file = std::fopen(path, "r")) {
      char buffer[256];
      for (std::size_t i = 0; i < lines && std::fgets(buffer, sizeof buffer, file) != nullptr; ++i) text += buffer;
      std::fclose(file);
    }
    while (!text.empty() && (text.back() == '\n' || text.back() == ' ')) text.pop_back();
    return text;
  };
  if (read_text("/proc/cpuinfo", 8).find("User Mode Linux") != std::string::npos) return std::nullopt;
  const std::string current = read_text("/sys/devices/system/clocksource/clocksource0/current_clocksource", 1);
  if (current.empty() || current == "tsc") return std::nullopt;
  return current;
}

#endif  // __x86_64__

std::mutex g_choice_mutex;
std::optional<ClockInfo> g_choice;
#if defined(__x86_64__)
Calibrator* g_calibrator = nullptr;  // lives until the process exits (or a test stops it)
#endif

std::string microseconds(double ns) {
  char text[32];
  std::snprintf(text, sizeof text, "%.2f µs", ns / 1000.0);
  return text;
}

}  // namespace

Result<ClockInfo> use_clock(ClockChoice choice) {
  std::lock_guard lock(g_choice_mutex);
  if (g_choice) return *g_choice;
  ClockInfo info;
  info.system_read_ns = system_read_ns();
  const bool slow = info.system_read_ns >= kSlowSystemClockNs;
  const std::string cost = "a clock_gettime takes " + microseconds(info.system_read_ns) + " here";
  if (choice == ClockChoice::system || (choice == ClockChoice::automatic && !slow)) {
    info.why = cost + (choice == ClockChoice::system ? ", and the system clock was asked for" : " (a vDSO read)");
    g_choice = info;
    return info;
  }
#if defined(__x86_64__)
  if (!has_invariant_tsc()) {
    if (choice == ClockChoice::tsc) return make_error("the TSC clock was asked for, but this CPU has no invariant TSC");
    info.why = cost + ", but this CPU has no invariant TSC to stamp with instead";
    g_choice = info;
    return info;
  }
  if (choice == ClockChoice::automatic) {
    if (const std::optional<std::string> current = kernel_keeps_time_without_tsc()) {
      info.why = cost + ", but the kernel keeps its time with " + *current + ", not the TSC";
      g_choice = info;
      return info;
    }
  }
  auto calibrator = std::make_unique<Calibrator>();
  Result<double> ghz = calibrator->start();
  if (!ghz) {
    if (choice == ClockChoice::tsc) return make_error("the TSC clock was asked for, but " + ghz.error().message);
    info.why = cost + ", but the TSC is no clock here: " + ghz.error().message;
    g_choice = info;
    return info;
  }
  static const int at_fork = pthread_atfork(nullptr, nullptr, tsc_clock_off_in_child);
  (void)at_fork;
  g_calibrator = calibrator.release();
  info.tsc = true;
  info.tsc_ghz = ghz.value();
  info.why = cost + (choice == ClockChoice::tsc ? ", and the TSC clock was asked for" : " (a system call, no vDSO)");
  g_choice = info;
  return info;
#else
  if (choice == ClockChoice::tsc) return make_error("the TSC clock exists on x86-64 only");
  info.why = cost + ", but the TSC clock exists on x86-64 only";
  g_choice = info;
  return info;
#endif
}

ClockStats clock_stats() {
#if defined(__x86_64__)
  std::lock_guard lock(g_choice_mutex);
  if (g_calibrator != nullptr) return g_calibrator->stats();
#endif
  return {};
}

void stop_tsc_clock_for_tests() {
  std::lock_guard lock(g_choice_mutex);
#if defined(__x86_64__)
  if (g_calibrator != nullptr) {
    detail::g_tsc_clock.active.store(false, std::memory_order_release);
    delete g_calibrator;
    g_calibrator = nullptr;
  }
#endif
  g_choice.reset();
}

}  // namespace polyport
