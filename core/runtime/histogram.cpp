// LatencyHistogram: log-linear buckets of relaxed atomic counters.
//
// Ownership: the histogram owns its fixed array of counters; nothing is allocated after
// construction except by buckets(), which returns a vector for reporting.
// Threads: record() runs on the forwarding threads (any number of them, concurrently) and
// is the hot path: a handful of relaxed atomic operations, no allocation, no lock.
// record_serial() runs on one thread at a time (the forwarding path's writer, or a thread that
// took over from it through a synchronising operation): plain loads and stores.
// summarize(), percentile() and buckets() run on a reporting thread and read the counters
// while they may still be changing; the result is a near snapshot, not an exact one.
// reset() is meant for a quiet moment; records racing with it may be partly kept.
#include "polyport/runtime/histogram.hpp"

#include "polyport/base/serial_counter.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>

namespace polyport {

namespace {

constexpr std::int64_t kInt64Max = std::numeric_limits<std::int64_t>::max();

// Nearest-rank position (1-based) of percentile p among count samples. The small
// subtraction keeps p * count / 100 from rounding up past an exact integer (99.9 is not
// exactly representable, so 99.9 * 1000 / 100 may come out as 999.0000000000001).
std::uint64_t rank_of(double p, std::uint64_t count) noexcept {
  const double exact = p / 100.0 * static_cast<double>(count);
  const double rank = std::ceil(exact - exact * 1e-12);
  if (rank < 1.0) return 1;
  if (rank >= static_cast<double>(count)) return count;
  return static_cast<std::uint64_t>(rank);
}

}  // namespace

LatencyHistogram::LatencyHistogram() noexcept : min_(kInt64Max) {
  // std::atomic's default constructor leaves the value to value-initialisation rules that
  // changed across standards; state the zero explicitly.
  for (auto& c : counts_) c.store(0, std::memory_order_relaxed);
}

int LatencyHistogram::bucket_index(std::int64_t value) noexcept {
  if (value < kSubCount) return value < 0 ? 0 : static_cast<int>(value);
  const auto v = static_cast<std::uint64_t>(value);
  const int msb = std::bit_width(v) - 1;  // >= kSubBits here
  const int shift = msb - kSubBits;
  // The kSubBits bits after the leading one pick the sub-bucket; octave shift + 1 follows
  // the linear range, so the index is continuous at 2^kSubBits.
  const auto sub = static_cast<int>((v >> shift) - static_cast<std::uint64_t>(kSubCount));
  return (shift + 1) * kSubCount + sub;
}

std::int64_t LatencyHistogram::bucket_upper(int index) noexcept {
  if (index <= 0) return 0;
  if (index < kSubCount) return index;
  if (index >= kBucketCount) return kInt64Max;
  const int shift = (index >> kSubBits) - 1;
  const int sub = index & (kSubCount - 1);
  const std::uint64_t lower = static_cast<std::uint64_t>(kSubCount + sub) << shift;
  const std::uint64_t upper = lower + ((std::uint64_t{1} << shift) - 1);
  // The last octave is only half reachable by int64 values; its buckets report the top.
  if (lower > static_cast<std::uint64_t>(kInt64Max)) return kInt64Max;
  return static_cast<std::int64_t>(std::min<std::uint64_t>(upper, kInt64Max));
}

void LatencyHistogram::record(std::int64_t value_ns) noexcept {
  const std::int64_t v = value_ns < 0 ? 0 : value_ns;
  counts_[static_cast<std::size_t>(bucket_index(v))].fetch_add(1, std::memory_order_relaxed);
  total_.fetch_add(1, std::memory_order_relaxed);
  sum_.fetch_add(v, std::memory_order_relaxed);  // atomic signed adds wrap; no UB
  // A CAS retry happens only when another thread moved the bound meanwhile, and every
  // retry makes the bound tighter, so the loops end after a few rounds at most.
  std::int64_t cur = min_.load(std::memory_order_relaxed);
  while (v < cur && !min_.compare_exchange_weak(cur, v, std::memory_order_relaxed)) {
  }
  cur = max_.load(std::memory_order_relaxed);
  while (v > cur && !max_.compare_exchange_weak(cur, v, std::memory_order_relaxed)) {
  }
}

void LatencyHistogram::record_serial(std::int64_t value_ns) noexcept {
  const std::int64_t v = value_ns < 0 ? 0 : value_ns;
  add_serial(counts_[static_cast<std::size_t>(bucket_index(v))]);
  add_serial(total_);
  // Unsigned, so that it wraps as the atomic add does instead of overflowing.
  const auto sum = static_cast<std::uint64_t>(sum_.load(std::memory_order_relaxed)) + static_cast<std::uint64_t>(v);
  sum_.store(static_cast<std::int64_t>(sum), std::memory_order_relaxed);
  if (v < min_.load(std::memory_order_relaxed)) min_.store(v, std::memory_order_relaxed);
  if (v > max_.load(std::memory_order_relaxed)) max_.store(v, std::memory_order_relaxed);
}

LatencyHistogram::Summary LatencyHistogram::summarize() const noexcept {
  // Copy the counters once so that the count and all four percentiles come from the same
  // numbers even while records go on.
  std::array<std::uint64_t, kBucketCount> snap{};
  std::uint64_t count = 0;
  for (std::size_t i = 0; i < snap.size(); ++i) {
    snap[i] = counts_[i].load(std::memory_order_relaxed);
    count += snap[i];
  }
  Summary s;
  if (count == 0) return s;
  s.count = count;
  s.min = min_.load(std::memory_order_relaxed);
  s.max = max_.load(std::memory_order_relaxed);
  const std::uint64_t total = total_.load(std::memory_order_relaxed);
  s.mean = static_cast<double>(sum_.load(std::memory_order_relaxed)) /
           static_cast<double>(total == 0 ? count : total);

  struct Want {
    double p;
    std::int64_t* out;
  };
  const std::array<Want, 4> wants{{{50.0, &s.p50}, {90.0, &s.p90}, {99.0, &s.p99}, {99.9, &s.p999}}};
  std::size_t next = 0;
  std::uint64_t seen = 0;
  for (int i = 0; i < kBucketCount && next < wants.size(); ++i) {
    seen += snap[static_cast<std::size_t>(i)];
    while (next < wants.size() && seen >= rank_of(wants[next].p, count)) {
      // The bucket's top overstates the value by < 2^-kSubBits; the observed max is a
      // tighter bound for the highest bucket.
      *wants[next].out = std::min(bucket_upper(i), s.max);
      ++next;
    }
  }
  double squares = 0.0;
  for (int i = 0; i < kBucketCount; ++i) {
    const std::uint64_t n = snap[static_cast<std::size_t>(i)];
    if (n == 0) continue;
    const double lower = i == 0 ? 0.0 : static_cast<double>(bucket_upper(i - 1)) + 1.0;
    const double mid = std::clamp(0.5 * (lower + static_cast<double>(bucket_upper(i))),
                                  static_cast<double>(s.min), static_cast<double>(s.max));
    squares += static_cast<double>(n) * (mid - s.mean) * (mid - s.mean);
  }
  s.sd = std::sqrt(squares / static_cast<double>(count));
  return s;
}

std::int64_t LatencyHistogram::percentile(double p) const noexcept {
  std::uint64_t count = 0;
  for (const auto& c : counts_) count += c.load(std::memory_order_relaxed);
  if (count == 0) return 0;
  const std::int64_t max = max_.load(std::memory_order_relaxed);
  if (!(p > 0.0)) return min_.load(std::memory_order_relaxed);  // also catches NaN
  if (p >= 100.0) return max;
  const std::uint64_t rank = rank_of(p, count);
  std::uint64_t seen = 0;
  for (int i = 0; i < kBucketCount; ++i) {
    seen += counts_[static_cast<std::size_t>(i)].load(std::memory_order_relaxed);
    if (seen >= rank) return std::min(bucket_upper(i), max);
  }
  return max;  // counters moved under us (reset racing); the max is the honest answer
}

std::vector<std::pair<std::int64_t, std::uint64_t>> LatencyHistogram::buckets() const {
  std::vector<std::pair<std::int64_t, std::uint64_t>> out;
  for (int i = 0; i < kBucketCount; ++i) {
    const std::uint64_t n = counts_[static_cast<std::size_t>(i)].load(std::memory_order_relaxed);
    if (n != 0) out.emplace_back(bucket_upper(i), n);
  }
  return out;
}

void LatencyHistogram::reset() noexcept {
  for (auto& c : counts_) c.store(0, std::memory_order_relaxed);
  total_.store(0, std::memory_order_relaxed);
  sum_.store(0, std::memory_order_relaxed);
  min_.store(kInt64Max, std::memory_order_relaxed);
  max_.store(0, std::memory_order_relaxed);
}

}  // namespace polyport
