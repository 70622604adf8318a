#include "polyport/base/clock.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <limits>
#include <mutex>
#include <optional>
#include <thread>

#if defined(__x86_64__)
#include <cpuid.h>
#include <pthread.h>
#endif

namespace polyport {

namespace detail {
TscClock g_tsc_clock;
}  // namespace detail

namespace {

std::int64_t read_ns(clockid_t id) noexcept {
  timespec ts{};
  clock_gettime(id, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

// The fastest of a few back-to-back CLOCK_MONOTONIC reads: what one read costs.
double system_read_ns() noexcept {
  std::int64_t best = std::numeric_limits<std::int64_t>::max();
  std::int64_t previous = read_ns(CLOCK_MONOTONIC);
  for (int i = 0; i < 16; ++i) {
    const std::int64_t now = read_ns(CLOCK_MONOTONIC);
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
// middle as the TSC at the read; and CLOCK_REALTIME's offset from it.
struct Point {
  std::int64_t tsc = 0;
  std::int64_t mono_ns = 0;
  std::int64_t wall_minus_mono_ns = 0;
};

Point sample() noexcept {
  Point best;
  std::int64_t best_bracket = std::numeric_limits<std::int64_t>::max();
  for (int i = 0; i < 5; ++i) {
    const auto before = static_cast<std::int64_t>(__builtin_ia32_rdtsc());
    const std::int64_t mono = read_ns(CLOCK_MONOTONIC);
    const auto after = static_cast<std::int64_t>(__builtin_ia32_rdtsc());
    if (after - before < best_bracket) {
      best_bracket = after - before;
      best.tsc = before + (after - before) / 2;
      best.mono_ns = mono;
    }
  }
  const std::int64_t mono_before = read_ns(CLOCK_MONOTONIC);
  const std::int64_t wall = read_ns(CLOCK_REALTIME);
  const std::int64_t mono_after = read_ns(CLOCK_MONOTONIC);
  best.wall_minus_mono_ns = wall - (mono_before + (mono_after - mono_before) / 2);
  return best;
}

struct Scale {
  std::int64_t base_tsc = 0;
  std::int64_t base_mono_ns = 0;
  std::int64_t wall_minus_mono_ns = 0;
  double ns_per_tick = 0;
};

std::int64_t evaluate(const Scale& scale, std::int64_t tsc) noexcept {
  return scale.base_mono_ns + std::llround(static_cast<double>(tsc - scale.base_tsc) * scale.ns_per_tick);
}

// The one writer of g_tsc_clock (see TscClock): the copy readers are not using is changed
// first, then the other.
void publish(const Scale& scale) noexcept {
  detail::TscClock& clock = detail::g_tsc_clock;
  const auto q32 = static_cast<std::uint64_t>(std::llround(scale.ns_per_tick * 4294967296.0));
  const auto write = [&](detail::TscScale& copy) {
    copy.base_tsc.store(scale.base_tsc, std::memory_order_relaxed);
    copy.base_mono_ns.store(scale.base_mono_ns, std::memory_order_relaxed);
    copy.wall_minus_mono_ns.store(scale.wall_minus_mono_ns, std::memory_order_relaxed);
    copy.ns_per_tick_q32.store(q32, std::memory_order_relaxed);
  };
  const std::uint32_t sequence = clock.sequence.load(std::memory_order_relaxed);
  clock.sequence.store(sequence + 1, std::memory_order_relaxed);  // readers: the other copy
  std::atomic_thread_fence(std::memory_order_release);
  write(clock.copies[sequence & 1U]);
  clock.sequence.store(sequence + 2, std::memory_order_release);  // readers: the new copy
  std::atomic_thread_fence(std::memory_order_release);
  write(clock.copies[(sequence + 1) & 1U]);
}

// Keeps the TSC clock on CLOCK_MONOTONIC. The rate is measured over everything since the
// start (its error shrinks as the baseline grows), and each calibration steers out the error
// it finds over the next interval instead of stepping, so the clock stays continuous and
// monotonic; an error of a millisecond or more (a paused machine, a TSC that is not what
// CPUID says) resets it.
class Calibrator {
 public:
  static constexpr auto kInterval = std::chrono::milliseconds(250);
  static constexpr auto kFirstBaseline = std::chrono::milliseconds(50);
  static constexpr std::int64_t kStepNs = 1'000'000;
  static constexpr double kMaxSteer = 200e-6;  // of the rate, per interval

  double start() {
    anchor_ = sample();
    std::this_thread::sleep_for(kFirstBaseline);
    const Point now = sample();
    scale_ = Scale{now.tsc, now.mono_ns, now.wall_minus_mono_ns, rate_since_anchor(now)};
    started_ = now.mono_ns;
    publish(scale_);
    detail::g_tsc_clock.active.store(true, std::memory_order_release);
    thread_ = std::thread([this] { run(); });
    return 1.0 / scale_.ns_per_tick;
  }

  void stop() {
    {
      std::lock_guard lock(mutex_);
      stopping_ = true;
    }
    wake_.notify_all();
    if (thread_.joinable()) thread_.join();
  }

  ClockStats stats() const noexcept {
    ClockStats out;
    out.tsc = true;
    out.tsc_ghz = ghz_.load(std::memory_order_relaxed);
    out.calibrations = calibrations_.load(std::memory_order_relaxed);
    out.steps = steps_.load(std::memory_order_relaxed);
    out.last_error_ns = last_error_.load(std::memory_order_relaxed);
    out.max_abs_error_ns = max_abs_error_.load(std::memory_order_relaxed);
    return out;
  }

 private:
  double rate_since_anchor(const Point& now) const noexcept {
    return static_cast<double>(now.mono_ns - anchor_.mono_ns) / static_cast<double>(now.tsc - anchor_.tsc);
  }

  void run() {
    pthread_setname_np(pthread_self(), "pp-clock");
    std::unique_lock lock(mutex_);
    while (!wake_.wait_for(lock, kInterval, [this] { return stopping_; })) calibrate();
  }

  void calibrate() noexcept {
    const Point now = sample();
    const std::int64_t predicted = evaluate(scale_, now.tsc);
    const std::int64_t error = now.mono_ns - predicted;
    const double rate = rate_since_anchor(now);
    if (std::llabs(error) >= kStepNs) {
      scale_ = Scale{now.tsc, now.mono_ns, now.wall_minus_mono_ns, rate};
      steps_.fetch_add(1, std::memory_order_relaxed);
    } else {
      const double interval_ticks = std::chrono::duration<double, std::nano>(kInterval).count() / rate;
      const double steer = std::clamp(static_cast<double>(error) / interval_ticks, -kMaxSteer * rate, kMaxSteer * rate);
      scale_ = Scale{now.tsc, predicted, now.wall_minus_mono_ns, rate + steer};
    }
    publish(scale_);
    ghz_.store(1.0 / rate, std::memory_order_relaxed);
    calibrations_.fetch_add(1, std::memory_order_relaxed);
    last_error_.store(error, std::memory_order_relaxed);
    if (now.mono_ns - started_ >= 1'000'000'000 && std::llabs(error) > max_abs_error_.load(std::memory_order_relaxed))
      max_abs_error_.store(std::llabs(error), std::memory_order_relaxed);
  }

  Point anchor_;
  Scale scale_;
  std::int64_t started_ = 0;
  std::mutex mutex_;
  std::condition_variable wake_;
  bool stopping_ = false;
  std::thread thread_;
  std::atomic<double> ghz_{0};
  std::atomic<std::uint64_t> calibrations_{0};
  std::atomic<std::uint64_t> steps_{0};
  std::atomic<std::int64_t> last_error_{0};
  std::atomic<std::int64_t> max_abs_error_{0};
};

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
  auto* calibrator = new Calibrator();
  info.tsc = true;
  info.tsc_ghz = calibrator->start();
  g_calibrator = calibrator;
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

ClockStats clock_stats() noexcept {
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
    g_calibrator->stop();
    delete g_calibrator;
    g_calibrator = nullptr;
  }
#endif
  g_choice.reset();
}

}  // namespace polyport
