#include "polyport/runtime/histogram.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <mutex>
#include <random>
#include <thread>
#include <vector>

namespace {

using polyport::LatencyHistogram;

constexpr std::int64_t kMax = std::numeric_limits<std::int64_t>::max();
const int kLastIndex = LatencyHistogram::bucket_index(kMax);

// Nearest rank, computed in integers so the reference does not share the histogram's
// floating-point path: the value at position ceil(per_mille * n / 1000) (1-based).
std::int64_t exact_percentile(const std::vector<std::int64_t>& sorted, std::uint64_t per_mille) {
  const std::uint64_t n = sorted.size();
  std::uint64_t rank = (per_mille * n + 999) / 1000;
  rank = std::clamp<std::uint64_t>(rank, 1, n);
  return sorted[rank - 1];
}

// The histogram reports the top of the bucket holding the exact value (or the max), so it
// may only overstate, and by less than one bucket width: < 2^-kSubBits of the value.
void expect_close(std::int64_t exact, std::int64_t reported, const char* what) {
  EXPECT_GE(reported, exact) << what;
  const double bound = static_cast<double>(exact) / LatencyHistogram::kSubCount;
  EXPECT_LE(static_cast<double>(reported - exact), bound) << what << " exact " << exact;
}

TEST(LatencyHistogram, LinearRangeMapsOneToOne) {
  for (std::int64_t v = 0; v < LatencyHistogram::kSubCount; ++v) {
    EXPECT_EQ(LatencyHistogram::bucket_index(v), v);
    EXPECT_EQ(LatencyHistogram::bucket_upper(static_cast<int>(v)), v);
  }
  EXPECT_EQ(LatencyHistogram::bucket_index(-1), 0);
  EXPECT_EQ(LatencyHistogram::bucket_index(std::numeric_limits<std::int64_t>::min()), 0);
}

TEST(LatencyHistogram, BucketBoundariesAtOctaves) {
  // 32..63 are still one value per bucket; from 64 on, two values per bucket, and so on.
  EXPECT_EQ(LatencyHistogram::bucket_index(32), 32);
  EXPECT_EQ(LatencyHistogram::bucket_index(63), 63);
  EXPECT_EQ(LatencyHistogram::bucket_index(64), 64);
  EXPECT_EQ(LatencyHistogram::bucket_index(65), 64);
  EXPECT_EQ(LatencyHistogram::bucket_index(66), 65);
  EXPECT_EQ(LatencyHistogram::bucket_upper(64), 65);
  EXPECT_EQ(LatencyHistogram::bucket_index(127), 95);
  EXPECT_EQ(LatencyHistogram::bucket_index(128), 96);
  EXPECT_EQ(LatencyHistogram::bucket_upper(96), 131);
  EXPECT_LT(kLastIndex, LatencyHistogram::kBucketCount);
  EXPECT_EQ(LatencyHistogram::bucket_upper(kLastIndex), kMax);
  EXPECT_EQ(LatencyHistogram::bucket_index(kMax), kLastIndex);
}

TEST(LatencyHistogram, UpperBoundsAreMonotonicAndTight) {
  for (int i = 0; i < kLastIndex; ++i) {
    const std::int64_t upper = LatencyHistogram::bucket_upper(i);
    const std::int64_t next_upper = LatencyHistogram::bucket_upper(i + 1);
    ASSERT_LT(upper, next_upper) << i;
    ASSERT_EQ(LatencyHistogram::bucket_index(upper), i);
    ASSERT_EQ(LatencyHistogram::bucket_index(upper + 1), i + 1);  // no gaps between buckets
    if (i >= LatencyHistogram::kSubCount) {
      const std::int64_t lower = LatencyHistogram::bucket_upper(i - 1) + 1;
      // Width relative to the smallest value held: the percentile error bound.
      ASSERT_LE(static_cast<double>(upper - lower + 1) / static_cast<double>(lower),
                1.0 / LatencyHistogram::kSubCount)
          << i;
    }
  }
}

TEST(LatencyHistogram, EveryValueFallsInsideItsBucket) {
  auto check = [](std::int64_t v) {
    const int index = LatencyHistogram::bucket_index(v);
    ASSERT_LE(v, LatencyHistogram::bucket_upper(index)) << v;
    if (index > 0) {
      ASSERT_GT(v, LatencyHistogram::bucket_upper(index - 1)) << v;
    }
  };
  int previous_index = 0;
  for (std::int64_t v = 0; v < 100'000; ++v) {
    check(v);
    const int index = LatencyHistogram::bucket_index(v);
    ASSERT_GE(index, previous_index);  // the index never decreases with the value
    ASSERT_LE(index, previous_index + 1);  // nor skips a bucket
    previous_index = index;
  }
  std::mt19937_64 rng(7);
  for (int i = 0; i < 20000; ++i) {  // random magnitudes across the whole int64 range
    const int bits = 1 + static_cast<int>(rng() % 63);
    check(static_cast<std::int64_t>(rng() >> (64 - bits)));
  }
  check(kMax);
}

TEST(LatencyHistogram, EmptySummaryIsZero) {
  LatencyHistogram h;
  const auto s = h.summarize();
  EXPECT_EQ(s.count, 0u);
  EXPECT_EQ(s.min, 0);
  EXPECT_EQ(s.max, 0);
  EXPECT_EQ(s.mean, 0.0);
  EXPECT_EQ(s.p50, 0);
  EXPECT_EQ(s.p999, 0);
  EXPECT_EQ(h.percentile(50), 0);
  EXPECT_TRUE(h.buckets().empty());
}

TEST(LatencyHistogram, MinMaxMean) {
  LatencyHistogram h;
  for (std::int64_t v : {5, 100, 1000, 7}) h.record(v);
  h.record(-20);  // counts as 0
  const auto s = h.summarize();
  EXPECT_EQ(s.count, 5u);
  EXPECT_EQ(s.min, 0);
  EXPECT_EQ(s.max, 1000);
  EXPECT_DOUBLE_EQ(s.mean, 1112.0 / 5.0);
  EXPECT_EQ(h.percentile(0), 0);
  EXPECT_EQ(h.percentile(100), 1000);
}

TEST(LatencyHistogram, SingleValueReportsItselfEverywhere) {
  LatencyHistogram h;
  h.record(1'000'003);  // not a bucket top: clamping to the max must bring it back
  const auto s = h.summarize();
  EXPECT_EQ(s.p50, 1'000'003);
  EXPECT_EQ(s.p90, 1'000'003);
  EXPECT_EQ(s.p99, 1'000'003);
  EXPECT_EQ(s.p999, 1'000'003);
  EXPECT_EQ(h.percentile(37.5), 1'000'003);
}

TEST(LatencyHistogram, PercentilesMatchExactSortWithinRelativeError) {
  std::mt19937_64 rng(12345);
  // A latency-like mix: a log-normal body around 50 us with a heavy tail.
  std::lognormal_distribution<double> body(std::log(50'000.0), 0.6);
  std::exponential_distribution<double> tail(1.0 / 2'000'000.0);
  std::vector<std::int64_t> values;
  LatencyHistogram h;
  for (int i = 0; i < 100'000; ++i) {
    const double x = (rng() % 100 == 0) ? tail(rng) : body(rng);
    const auto v = static_cast<std::int64_t>(x);
    values.push_back(v);
    h.record(v);
  }
  std::sort(values.begin(), values.end());
  const auto s = h.summarize();
  EXPECT_EQ(s.count, values.size());
  EXPECT_EQ(s.min, values.front());
  EXPECT_EQ(s.max, values.back());
  expect_close(exact_percentile(values, 500), s.p50, "p50");
  expect_close(exact_percentile(values, 900), s.p90, "p90");
  expect_close(exact_percentile(values, 990), s.p99, "p99");
  expect_close(exact_percentile(values, 999), s.p999, "p99.9");
  for (std::uint64_t pm : {1u, 100u, 250u, 750u, 995u}) {
    expect_close(exact_percentile(values, pm), h.percentile(static_cast<double>(pm) / 10.0), "p");
  }
}

// The standard deviation comes from bucket midpoints: exact for values in the linear range,
// within the buckets' relative width above it.
TEST(LatencyHistogram, StandardDeviationFromTheBuckets) {
  LatencyHistogram small;
  for (std::int64_t v : {2, 4, 4, 4, 5, 5, 7, 9}) small.record(v);  // population sd 2
  EXPECT_DOUBLE_EQ(small.summarize().sd, 2.0);

  std::mt19937_64 rng(7);
  std::normal_distribution<double> normal(200'000.0, 20'000.0);
  LatencyHistogram h;
  std::vector<double> values;
  for (int i = 0; i < 50'000; ++i) {
    const auto v = static_cast<std::int64_t>(normal(rng));
    values.push_back(static_cast<double>(v));
    h.record(v);
  }
  double mean = 0.0;
  for (double v : values) mean += v;
  mean /= static_cast<double>(values.size());
  double squares = 0.0;
  for (double v : values) squares += (v - mean) * (v - mean);
  const double exact = std::sqrt(squares / static_cast<double>(values.size()));
  EXPECT_NEAR(h.summarize().sd, exact, exact * 0.05);
  LatencyHistogram one;
  one.record(123'456);
  EXPECT_EQ(one.summarize().sd, 0.0);
}

TEST(LatencyHistogram, BucketsListNonEmptyAscending) {
  LatencyHistogram h;
  for (std::int64_t v : {3, 3, 70, 1'000'000, 71}) h.record(v);
  const auto b = h.buckets();
  ASSERT_EQ(b.size(), 3u);  // 70 and 71 share the bucket [70, 71]
  EXPECT_EQ(b[0], (std::pair<std::int64_t, std::uint64_t>{3, 2}));
  EXPECT_EQ(b[1], (std::pair<std::int64_t, std::uint64_t>{71, 2}));
  EXPECT_EQ(b[2].second, 1u);
  EXPECT_GE(b[2].first, 1'000'000);
}

TEST(LatencyHistogram, ResetClearsEverything) {
  LatencyHistogram h;
  for (int i = 1; i <= 100; ++i) h.record(i * 1000);
  h.reset();
  const auto s = h.summarize();
  EXPECT_EQ(s.count, 0u);
  EXPECT_EQ(s.max, 0);
  EXPECT_TRUE(h.buckets().empty());
  h.record(42);  // min and max start afresh
  const auto after = h.summarize();
  EXPECT_EQ(after.count, 1u);
  EXPECT_EQ(after.min, 42);
  EXPECT_EQ(after.max, 42);
  EXPECT_DOUBLE_EQ(after.mean, 42.0);
}

// Two threads record `per_thread` values each, offset + i % 5000 with offsets 10 and
// 1 000 000, through `record`: the histogram must hold every one of them.
template <class Record>
void expect_two_threads_add_up(int per_thread, Record record) {
  LatencyHistogram h;
  auto work = [&](std::int64_t offset) {
    for (int i = 0; i < per_thread; ++i) record(h, offset + i % 5000);
  };
  std::thread a(work, 10);
  std::thread b(work, 1'000'000);
  a.join();
  b.join();
  const auto s = h.summarize();
  const auto total = 2u * static_cast<std::uint64_t>(per_thread);
  EXPECT_EQ(s.count, total);
  EXPECT_EQ(s.min, 10);
  EXPECT_EQ(s.max, 1'000'000 + 4999);
  std::uint64_t in_buckets = 0;
  for (const auto& bucket : h.buckets()) in_buckets += bucket.second;
  EXPECT_EQ(in_buckets, total);
  // Each thread's values average offset + 2499.5 (i % 5000 over whole cycles of 5000).
  EXPECT_DOUBLE_EQ(s.mean, (10 + 1'000'000 + 2 * 2499.5) / 2.0);
}

TEST(LatencyHistogram, ConcurrentRecordsAddUp) {
  expect_two_threads_add_up(300'000, [](LatencyHistogram& h, std::int64_t v) { h.record(v); });
}

// record_serial is record() for one thread at a time: the same buckets, count, sum and bounds.
TEST(LatencyHistogram, SerialRecordsMatchAtomicOnes) {
  LatencyHistogram atomic;
  LatencyHistogram serial;
  std::mt19937_64 rng(7);
  std::uniform_int_distribution<std::int64_t> value(-50, 5'000'000);
  for (int i = 0; i < 20'000; ++i) {
    const std::int64_t v = value(rng);
    atomic.record(v);
    serial.record_serial(v);
  }
  const auto a = atomic.summarize();
  const auto s = serial.summarize();
  EXPECT_EQ(s.count, a.count);
  EXPECT_EQ(s.min, a.min);
  EXPECT_EQ(s.max, a.max);
  EXPECT_DOUBLE_EQ(s.mean, a.mean);
  EXPECT_EQ(s.p50, a.p50);
  EXPECT_EQ(s.p999, a.p999);
  EXPECT_EQ(serial.buckets(), atomic.buckets());
}

// Threads taking turns through a mutex (as a port's writers and the timer thread take turns at
// a connection) lose no serial record.
TEST(LatencyHistogram, SerialRecordsHandedOverThroughALockAddUp) {
  std::mutex turn;
  expect_two_threads_add_up(100'000, [&turn](LatencyHistogram& h, std::int64_t v) {
    const std::lock_guard<std::mutex> lock(turn);
    h.record_serial(v);
  });
}

}  // namespace
