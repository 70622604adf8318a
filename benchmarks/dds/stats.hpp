// Percentiles of one run's samples, as JSON, for the ping-pong programs.
#pragma once

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

namespace bench {

inline std::string summary(std::vector<std::int64_t> v) {
  if (v.empty()) return "{}";
  std::sort(v.begin(), v.end());
  auto at = [&](double q) { return v[std::min(v.size() - 1, static_cast<std::size_t>(q * static_cast<double>(v.size())))]; };
  char text[256];
  std::snprintf(text, sizeof text, R"({"n":%zu,"min":%lld,"p50":%lld,"p90":%lld,"p99":%lld,"p999":%lld,"max":%lld})",
                v.size(), static_cast<long long>(v.front()), static_cast<long long>(at(0.5)),
                static_cast<long long>(at(0.9)), static_cast<long long>(at(0.99)), static_cast<long long>(at(0.999)),
                static_cast<long long>(v.back()));
  return text;
}

// One line on stdout: round trips and one-way (= round trip / 2), in nanoseconds.
inline void report(const char* vendor, int size, int warmup, const std::vector<std::int64_t>& rtt, int lost) {
  std::vector<std::int64_t> one_way;
  one_way.reserve(rtt.size());
  for (std::int64_t r : rtt) one_way.push_back(r / 2);
  std::printf(R"({"vendor":"%s","size":%d,"warmup":%d,"lost":%d,"rtt_ns":%s,"one_way_ns":%s})"
              "\n",
              vendor, size, warmup, lost, summary(rtt).c_str(), summary(one_way).c_str());
  std::fflush(stdout);
}

}  // namespace bench
