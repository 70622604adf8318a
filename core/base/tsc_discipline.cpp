#include "polyport/base/tsc_discipline.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>

namespace polyport::detail {

namespace {

std::uint64_t q32(double ns_per_tick) noexcept {
  return static_cast<std::uint64_t>(std::llround(ns_per_tick * 4294967296.0));
}

std::string percent(double fraction) {
  char text[32];
  std::snprintf(text, sizeof text, "%.3f %%", fraction * 100.0);
  return text;
}

}  // namespace

Result<TscLine> TscDiscipline::begin(const TscPoint& anchor, const TscPoint& now) {
  if (now.tsc <= anchor.tsc || now.mono_ns <= anchor.mono_ns)
    return make_error("the TSC or CLOCK_MONOTONIC did not advance over the first baseline");
  const double rate = static_cast<double>(now.mono_ns - anchor.mono_ns) / static_cast<double>(now.tsc - anchor.tsc);
  // 0.1 to 10 GHz: anything else is not a time-stamp counter.
  if (!std::isfinite(rate) || rate < 0.1 || rate > 10.0)
    return make_error("the TSC's rate measured " + std::to_string(1.0 / rate) + " GHz, which no CPU has");
  window_size_ = 0;
  remember(anchor);
  remember(now);
  last_ = now;
  first_rate_ = rate_ = rate;
  skips_in_a_row_ = 0;
  line_ = TscLine{now.tsc, now.mono_ns, now.wall_minus_mono_ns, q32(rate)};
  return line_;
}

void TscDiscipline::remember(const TscPoint& pair) noexcept {
  if (window_size_ == 0) window_start_ = 0;
  if (window_size_ < kWindow) {
    window_[(window_start_ + window_size_++) % kWindow] = pair;
  } else {
    window_[window_start_] = pair;
    window_start_ = (window_start_ + 1) % kWindow;
  }
}

Result<TscDiscipline::Update> TscDiscipline::update(const TscPoint& now, std::int64_t publish_tsc,
                                                    std::int64_t interval_ns) {
  if (now.tsc <= last_.tsc)
    return make_error("the TSC went back (" + std::to_string(now.tsc) + " after " + std::to_string(last_.tsc) + ")");
  // Read on another CPU a moment later, the publishing TSC may lag the pair's by a few ticks.
  publish_tsc = std::max(publish_tsc, now.tsc);
  Update out;
  out.error_ns = now.mono_ns - line_.at(now.tsc);
  out.ns_per_tick = rate_;
  const bool discontinuity = std::llabs(out.error_ns) >= kStepNs;

  // A pair read while the thread was held up says little; a run of them is the new normal.
  // The line goes on at the measured rate: a correction sized for one interval, or a slew,
  // must not run on for several.
  std::int64_t tightest = now.bracket;
  for (std::size_t i = 0; i < window_size_; ++i) tightest = std::min(tightest, window_[i].bracket);
  if (now.bracket > kWideBracket * tightest && skips_in_a_row_ < kMaxSkipsInARow) {
    ++skips_in_a_row_;
    line_ = TscLine{publish_tsc, line_.at(publish_tsc), line_.wall_minus_mono_ns, q32(rate_)};
    out.outcome = Outcome::skipped;
    out.line = line_;
    return out;
  }
  skips_in_a_row_ = 0;

  // The rate since the oldest pair of the window, unless a discontinuity lies between them:
  // measured across one, it is not the TSC's (the last rate is kept, and the window starts
  // anew here). A window that starts at the last pair's discontinuity holds a real pair, so
  // a TSC whose rate changed (a discontinuity every interval) is caught at the second one.
  if (!discontinuity || window_size_ == 1) {
    const TscPoint& oldest = window_[window_start_];
    const double rate = static_cast<double>(now.mono_ns - oldest.mono_ns) / static_cast<double>(now.tsc - oldest.tsc);
    if (!std::isfinite(rate) || rate <= 0 || std::fabs(rate / first_rate_ - 1.0) > kMaxRateChange)
      return make_error("the TSC's rate moved by " + percent(rate / first_rate_ - 1.0) + " from its first measurement");
    rate_ = rate;
  }
  if (discontinuity) window_size_ = 0;
  remember(now);
  last_ = now;
  out.ns_per_tick = rate_;

  // The published line's value when the new one takes over: where the new one starts.
  const std::int64_t joined_ns = line_.at(publish_tsc);
  const std::int64_t mono_at_publish =
      now.mono_ns + std::llround(static_cast<double>(publish_tsc - now.tsc) * rate_);
  const double interval_ticks = static_cast<double>(interval_ns) / rate_;
  if (out.error_ns >= kStepNs) {
    out.outcome = Outcome::stepped;
    line_ = TscLine{publish_tsc, std::max(joined_ns, mono_at_publish), now.wall_minus_mono_ns, q32(rate_)};
    out.line = line_;
    return out;
  }
  // Steer out the error at the join over the next interval, within kMaxSteer of the rate (or
  // kMaxSlew, running slower, while far ahead).
  const bool far_ahead = out.error_ns <= -kStepNs;
  const double behind_ns = static_cast<double>(mono_at_publish - joined_ns);
  const double slower = far_ahead ? kMaxSlew : kMaxSteer;
  const double steer = std::clamp(behind_ns / interval_ticks, -slower * rate_, kMaxSteer * rate_);
  out.outcome = far_ahead ? Outcome::slewed : Outcome::steered;
  line_ = TscLine{publish_tsc, joined_ns, now.wall_minus_mono_ns, q32(rate_ + steer)};
  out.line = line_;
  return out;
}

TscLine TscDiscipline::rejoin(const TscLine& published, const TscLine& line, std::int64_t switch_tsc) noexcept {
  const std::int64_t old_ns = published.at(switch_tsc);
  if (line.at(switch_tsc) >= old_ns) return line;
  return TscLine{switch_tsc, old_ns, line.wall_minus_mono_ns, line.per_tick_q32};
}

}  // namespace polyport::detail
