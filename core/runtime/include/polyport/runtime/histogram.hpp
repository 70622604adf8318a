// A lock-free log-linear latency histogram (HdrHistogram-like): values in nanoseconds fall
// into buckets of 2^kSubBits linear sub-buckets per power of two, so the relative error of a
// reported percentile is below 2^-kSubBits. record() is wait-free (relaxed atomic adds) and
// may be called from any thread; record_serial() is the cheaper form for a histogram that one
// thread at a time records into (serial_counter.hpp says when that holds); summarize() reads
// a consistent-enough snapshot from another thread.
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <utility>
#include <vector>

namespace polyport {

class LatencyHistogram {
 public:
  static constexpr int kSubBits = 5;                        // 32 sub-buckets per octave
  static constexpr int kSubCount = 1 << kSubBits;
  static constexpr int kOctaves = 64 - kSubBits;            // covers every int64 value
  static constexpr int kBucketCount = (kOctaves + 1) * kSubCount;

  struct Summary {
    std::uint64_t count = 0;
    std::int64_t min = 0;
    std::int64_t max = 0;
    double mean = 0.0;
    // Standard deviation from the buckets (each counted at its midpoint, clamped to the
    // observed min and max), so within the buckets' resolution.
    double sd = 0.0;
    std::int64_t p50 = 0;
    std::int64_t p90 = 0;
    std::int64_t p99 = 0;
    std::int64_t p999 = 0;
  };

  LatencyHistogram() noexcept;

  [[gnu::hot]] void record(std::int64_t value_ns) noexcept;  // negative values count as 0
  // record() without locked instructions: for one recording thread at a time, each handing
  // over to the next through a synchronising operation (serial_counter.hpp).
  [[gnu::hot]] void record_serial(std::int64_t value_ns) noexcept;
  Summary summarize() const noexcept;
  std::int64_t percentile(double p) const noexcept;  // p in [0, 100]
  // Non-empty buckets as (highest value the bucket holds, count), ascending.
  std::vector<std::pair<std::int64_t, std::uint64_t>> buckets() const;
  void reset() noexcept;

  static int bucket_index(std::int64_t value) noexcept;
  static std::int64_t bucket_upper(int index) noexcept;  // highest value in bucket index

 private:
  // The totals first: record() touches their line and one bucket's, and the buckets of
  // values up to ~100 us lie within the first 4 KiB, so one page instead of two.
  std::atomic<std::uint64_t> total_{0};
  std::atomic<std::int64_t> sum_{0};
  std::atomic<std::int64_t> min_;
  std::atomic<std::int64_t> max_{0};
  std::array<std::atomic<std::uint64_t>, kBucketCount> counts_;
};

}  // namespace polyport
