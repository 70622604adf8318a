// What the wheelchair's stand-alone programs (the bus simulator and the native DDS nodes)
// share to run at a fixed period and report about it: an absolute-deadline periodic timer on
// CLOCK_MONOTONIC that measures its wake lateness, a sample log of nanosecond figures that
// summarises itself (count, mean, SD, min, max, p50, p99), and the process's CPU time.
//
// Memory: a SampleLog reserves its capacity when constructed; add() never allocates and
// counts what does not fit. summary_json() allocates, after the run. One thread per object.
#pragma once

#include <sys/prctl.h>
#include <sys/resource.h>
#include <time.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <optional>
#include <string>
#include <vector>

namespace polyport::wheelchair {

inline std::int64_t ns_of(const timespec& t) noexcept {
  return static_cast<std::int64_t>(t.tv_sec) * 1'000'000'000 + t.tv_nsec;
}

inline std::int64_t now_ns(clockid_t clock = CLOCK_MONOTONIC) noexcept {
  timespec t{};
  clock_gettime(clock, &t);
  return ns_of(t);
}

class SampleLog {
 public:
  explicit SampleLog(std::size_t capacity = 1 << 20) { values_.reserve(capacity); }

  void add(std::int64_t value_ns) noexcept {
    if (values_.size() < values_.capacity()) {
      values_.push_back(value_ns);
    } else {
      ++lost_;
    }
  }
  std::size_t count() const noexcept { return values_.size(); }
  const std::vector<std::int64_t>& values() const noexcept { return values_; }

  // {"count":N,"mean":..,"sd":..,"min":..,"max":..,"p50":..,"p99":..} in ns (nearest-rank
  // percentiles; sd is the population standard deviation); "lost" when the log overflowed.
  std::string summary_json() const {
    std::vector<std::int64_t> sorted = values_;
    std::sort(sorted.begin(), sorted.end());
    const std::size_t n = sorted.size();
    double mean = 0.0;
    for (const std::int64_t v : sorted) mean += static_cast<double>(v);
    mean = n ? mean / static_cast<double>(n) : 0.0;
    double squares = 0.0;
    for (const std::int64_t v : sorted) squares += (static_cast<double>(v) - mean) * (static_cast<double>(v) - mean);
    const double sd = n ? std::sqrt(squares / static_cast<double>(n)) : 0.0;
    const auto rank = [&](double p) -> std::int64_t {
      if (n == 0) return 0;
      const auto index = static_cast<std::size_t>(std::ceil(p / 100.0 * static_cast<double>(n)));
      return sorted[std::min(n, std::max<std::size_t>(index, 1)) - 1];
    };
    char text[320];
    std::snprintf(text, sizeof text,
                  "{\"count\":%zu,\"mean\":%.1f,\"sd\":%.1f,\"min\":%lld,\"max\":%lld,\"p50\":%lld,\"p99\":%lld,"
                  "\"lost\":%zu}",
                  n, mean, sd, static_cast<long long>(n ? sorted.front() : 0),
                  static_cast<long long>(n ? sorted.back() : 0), static_cast<long long>(rank(50)),
                  static_cast<long long>(rank(99)), lost_);
    return text;
  }

 private:
  std::vector<std::int64_t> values_;
  std::size_t lost_ = 0;
};

// Sleeps to absolute deadlines start + k * period on CLOCK_MONOTONIC, with the calling
// thread's timer slack at its minimum (as polyport's execution contexts do), so that the
// native programs and polyport wake alike. A late wake does not
// shift later deadlines; deadlines already passed by a whole period are skipped (counted as
// overruns) so that a stall does not turn into a burst.
//
// With a phase (0 <= phase < period) the deadlines are k * period + phase on CLOCK_MONOTONIC,
// as polyport's execution contexts with a <phase>, so that loops in different processes keep
// their order in the period run after run; without, the first deadline is one period from now.
class PeriodicTimer {
 public:
  explicit PeriodicTimer(std::int64_t period_ns, std::optional<std::int64_t> phase_ns = std::nullopt) noexcept
      : period_ns_(period_ns), next_ns_(now_ns() + period_ns) {
    prctl(PR_SET_TIMERSLACK, 1UL, 0UL, 0UL, 0UL);
    if (phase_ns) {
      const std::int64_t since = next_ns_ - period_ns - *phase_ns;  // from now
      next_ns_ = (since / period_ns + 1) * period_ns + *phase_ns;   // the grid's next instant
    }
  }

  // Waits for the next deadline; returns how late the wake was (ns).
  std::int64_t wait() noexcept {
    timespec deadline{static_cast<time_t>(next_ns_ / 1'000'000'000), static_cast<long>(next_ns_ % 1'000'000'000)};
    while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &deadline, nullptr) != 0) {
    }
    const std::int64_t woke = now_ns();
    const std::int64_t late = woke - next_ns_;
    next_ns_ += period_ns_;
    while (next_ns_ <= woke) {
      next_ns_ += period_ns_;
      ++overruns_;
    }
    return late;
  }
  std::uint64_t overruns() const noexcept { return overruns_; }

 private:
  std::int64_t period_ns_;
  std::int64_t next_ns_;
  std::uint64_t overruns_ = 0;
};

// A --phase-ms as a PeriodicTimer's phase (none when not given). False, with the reason on
// stderr, when it is not from 0 to less than the period.
inline bool timer_phase(const char* program, const std::optional<double>& phase_ms, double period_ms,
                        std::optional<std::int64_t>& phase_ns) {
  if (!phase_ms) return true;
  if (!(*phase_ms >= 0.0 && *phase_ms < period_ms)) {
    std::fprintf(stderr, "%s: --phase-ms %g is not from 0 to less than the period (%g ms)\n", program, *phase_ms,
                 period_ms);
    return false;
  }
  phase_ns = std::llround(*phase_ms * 1e6);
  return true;
}

// User + system CPU time of this process so far, in seconds.
inline double process_cpu_s() noexcept {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return static_cast<double>(usage.ru_utime.tv_sec + usage.ru_stime.tv_sec) +
         static_cast<double>(usage.ru_utime.tv_usec + usage.ru_stime.tv_usec) / 1e6;
}

}  // namespace polyport::wheelchair
