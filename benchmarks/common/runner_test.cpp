// The runners' verdict from paired chunks (runner.hpp, paired_chunks): which chunks pair up,
// the sign test's interval and confidence, and the three verdicts. A test of the benchmark's
// arithmetic on made-up chunk medians, not a benchmark.
#include <gtest/gtest.h>

#include <cstdint>
#include <vector>

#include "runner.hpp"

namespace {

using bench::Json;
using bench::paired_chunks;

Json series(const std::vector<std::int64_t>& chunk_p50) { return {{"one_way_p50_per_chunk_ns", chunk_p50}}; }

// A relay series whose chunks drift upwards by 7 us each (as a machine's load may), and a via
// series `d[i]` above it chunk by chunk: only the differences may count.
Json paired(const std::vector<std::int64_t>& d) {
  std::vector<std::int64_t> via, relay;
  for (std::size_t i = 0; i < d.size(); ++i) {
    relay.push_back(50'000 + static_cast<std::int64_t>(i) * 7'000);  // the machine drifts between chunks
    via.push_back(relay.back() + d[i]);
  }
  return paired_chunks(series(via), series(relay), 2000);
}

TEST(PairedChunks, SixteenChunksGiveTheSignTestsInterval) {
  // Sorted differences 100, 200, ..., 1600 ns: k = 4 (2 P(Bin(16, 1/2) <= 3) = 2.1 %,
  // <= 4 would be 7.7 %), so the interval is the 4th and the 13th.
  std::vector<std::int64_t> d;
  for (int i = 16; i >= 1; --i) d.push_back(i * 100);
  const Json p = paired(d);
  ASSERT_TRUE(p.is_object());
  EXPECT_EQ(p["chunks"], 16);
  EXPECT_EQ(p["via_minus_relay_p50_ns"], 850);
  EXPECT_EQ(p["interval_ns"][0], 400);
  EXPECT_EQ(p["interval_ns"][1], 1300);
  EXPECT_NEAR(p["confidence"].get<double>(), 1 - 2 * 697.0 / 65536.0, 1e-9);
  EXPECT_EQ(p["verdict"], "holds");
}

TEST(PairedChunks, AnIntervalAboveTheAllowanceMissesAndAcrossItIsUndecided) {
  EXPECT_EQ(paired({2500, 3000, 2100, 4000, 2600, 3100})["verdict"], "misses");
  // 2 P(Bin(6, 1/2) = 0) = 3.1 %: k = 1, the whole range.
  const Json across = paired({-1000, 500, 2600, 1500, 900, 3000});
  EXPECT_EQ(across["interval_ns"][0], -1000);
  EXPECT_EQ(across["interval_ns"][1], 3000);
  EXPECT_EQ(across["verdict"], "undecided");
  // At the allowance exactly: the bar is "<=".
  EXPECT_EQ(paired({2000, 1000, 1500, 2000, 0, 1999})["verdict"], "holds");
}

TEST(PairedChunks, FewChunksSayHowLittleTheyDecide) {
  const Json p = paired({100, -300, 900, 400});
  EXPECT_EQ(p["interval_ns"][0], -300);
  EXPECT_EQ(p["interval_ns"][1], 900);
  EXPECT_DOUBLE_EQ(p["confidence"].get<double>(), 0.875);  // 1 - 2 / 2^4
  EXPECT_EQ(p["via_minus_relay_p50_ns"], 250);
  EXPECT_EQ(p["verdict"], "holds");
}

TEST(PairedChunks, SeriesWithoutMatchingChunksGiveNothing) {
  EXPECT_TRUE(paired_chunks(series({1, 2, 3}), series({1, 2}), 2000).is_null());
  EXPECT_TRUE(paired_chunks(Json::object(), series({1}), 2000).is_null());
}

}  // namespace
