// How the TSC clock (clock.hpp) is kept on CLOCK_MONOTONIC. Its calibration thread pairs a
// CLOCK_MONOTONIC read with the TSC every few hundred milliseconds and hands the pair to
// TscDiscipline, which returns the line readers use until the next one. A pure function of
// the pairs it is given, so that tests can drive it with made-up ones.
//
// - The rate is measured over a window of the last kWindow pairs (≈ 4 s; since the last
//   discontinuity): long enough that the uncertainty of a pair (a few microseconds where a
//   clock read is a system call) is about 1 ppm of it, short enough to follow the kernel's
//   clock when NTP changes its frequency.
// - Each new line starts where the published one stands at the moment it is published, and
//   is steered (at most kMaxSteer of the rate) to remove the error found over the next
//   interval: readers see a continuous clock that never goes back. The writer joins it once
//   more at a TSC read after readers were sent to the other copy (rejoin), so that a writer
//   held up between update and publish cannot leave a slower line below the old one.
// - An error of kStepNs or more is a discontinuity (a paused machine, a TSC that is not
//   what CPUID says). Behind: the clock steps ahead. Ahead: it slews back, running up to
//   kMaxSlew slower, since stepping back would make time go backwards. Either way the
//   window starts anew, and the rate is not measured across it.
// - A pair whose clock read was held up (its TSC bracket far wider than the tightest of the
//   window, the calibration thread was preempted) is skipped, unless that keeps happening;
//   the line then goes on at the measured rate, without a correction meant for one interval.
// - A TSC that goes back, or whose rate moves by more than kMaxRateChange, is not a clock:
//   the discipline fails and the process goes back to clock_gettime.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>

#include "polyport/base/clock.hpp"
#include "polyport/base/result.hpp"

namespace polyport::detail {

struct TscPoint {  // one CLOCK_MONOTONIC read paired with the TSC
  std::int64_t tsc = 0;       // the TSC at the read: the middle of the reads around it
  std::int64_t bracket = 0;   // TSC ticks between those reads
  std::int64_t mono_ns = 0;
  std::int64_t wall_minus_mono_ns = 0;  // CLOCK_REALTIME − CLOCK_MONOTONIC at about that time
};

struct TscLine {  // CLOCK_MONOTONIC at `tsc` = tsc_line_ns(base_mono_ns, tsc − base_tsc, per_tick_q32)
  std::int64_t base_tsc = 0;
  std::int64_t base_mono_ns = 0;
  std::int64_t wall_minus_mono_ns = 0;  // applied as it is measured: CLOCK_REALTIME steps too
  std::uint64_t per_tick_q32 = 0;       // nanoseconds per tick, 32.32 fixed point

  std::int64_t at(std::int64_t tsc) const noexcept { return tsc_line_ns(base_mono_ns, tsc - base_tsc, per_tick_q32); }
};

class TscDiscipline {
 public:
  static constexpr std::int64_t kStepNs = 1'000'000;
  static constexpr double kMaxSteer = 500e-6;       // of the rate
  static constexpr double kMaxSlew = 0.10;          // of the rate, while ≥ kStepNs ahead
  static constexpr double kMaxRateChange = 0.01;    // from the first rate measured
  static constexpr std::int64_t kWideBracket = 4;   // × the tightest bracket seen
  static constexpr int kMaxSkipsInARow = 8;
  static constexpr std::size_t kWindow = 16;

  enum class Outcome { steered, stepped, slewed, skipped };
  struct Update {
    Outcome outcome = Outcome::skipped;
    TscLine line;             // to publish (not for skipped)
    std::int64_t error_ns = 0;  // CLOCK_MONOTONIC − the published line, at the pair
    double ns_per_tick = 0;     // the measured rate
  };

  // The first line, from the anchor and a pair a baseline later (the same pair twice, or a
  // rate no CPU has, is an error).
  Result<TscLine> begin(const TscPoint& anchor, const TscPoint& now);

  // The line to publish after `now`, joined to the published line at `publish_tsc` (a TSC
  // read just before publishing) and steered to be right `interval_ns` later (the time until
  // the next update). An error when the TSC stopped being a clock.
  Result<Update> update(const TscPoint& now, std::int64_t publish_tsc, std::int64_t interval_ns);

  // `line` as the writer stores it once readers are off the copy, at `switch_tsc` read then:
  // joined again to `published` there if it would start below it. The discipline goes on
  // from the line actually published (adopt).
  static TscLine rejoin(const TscLine& published, const TscLine& line, std::int64_t switch_tsc) noexcept;
  void adopt(const TscLine& published) noexcept { line_ = published; }

  const TscLine& line() const noexcept { return line_; }
  double ns_per_tick() const noexcept { return rate_; }

 private:
  void remember(const TscPoint& pair) noexcept;

  TscLine line_;
  std::array<TscPoint, kWindow> window_{};  // the pairs the rate is measured over, a ring
  std::size_t window_start_ = 0;
  std::size_t window_size_ = 0;
  TscPoint last_;
  double first_rate_ = 0;
  double rate_ = 0;
  int skips_in_a_row_ = 0;
};

}  // namespace polyport::detail
