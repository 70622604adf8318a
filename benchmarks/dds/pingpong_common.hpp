// What the two ping-pong programs share: stopping on a signal, the clock, the ping loop and
// the percentiles of its one run, printed as one JSON line. Single-threaded: the ping loop runs
// on main; the SDKs' own threads only deliver into the reader the loop waits on.
#pragma once

#include <algorithm>
#include <atomic>
#include <csignal>
#include <cstdint>
#include <cstdio>
#include <ctime>
#include <string>
#include <vector>

namespace bench {

inline std::atomic<bool> g_stop{false};
extern "C" inline void on_signal(int) { g_stop = true; }
inline void stop_on_signals() {
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
}

inline std::int64_t now_ns() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

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

// One line on stdout: round trips, one-way (= round trip / 2) and the SDK's write call in the
// ping process, in nanoseconds. The write is there to compare with polyport's sink time, the
// same SDK's write (of bytes already serialized) on polyport's side of a hop.
inline void report(const char* vendor, int size, int warmup, const std::vector<std::int64_t>& rtt,
                   const std::vector<std::int64_t>& write_ns, int lost) {
  std::vector<std::int64_t> one_way;
  one_way.reserve(rtt.size());
  for (std::int64_t r : rtt) one_way.push_back(r / 2);
  std::printf(R"({"vendor":"%s","size":%d,"warmup":%d,"lost":%d,"rtt_ns":%s,"one_way_ns":%s,"write_ns":%s})"
              "\n",
              vendor, size, warmup, lost, summary(rtt).c_str(), summary(one_way).c_str(), summary(write_ns).c_str());
  std::fflush(stdout);
}

// Every measured round trip and its write call in nanoseconds, one pair per line, so that a
// runner can pool the samples of several ping processes before taking percentiles (percentiles
// do not merge).
inline bool write_samples(const char* path, const std::vector<std::int64_t>& rtt,
                          const std::vector<std::int64_t>& write_ns) {
  std::FILE* out = std::fopen(path, "w");
  if (out == nullptr) return false;
  for (std::size_t i = 0; i < rtt.size(); ++i) {
    std::fprintf(out, "%lld %lld\n", static_cast<long long>(rtt[i]), static_cast<long long>(write_ns[i]));
  }
  return std::fclose(out) == 0;
}

// Warm-up then `rounds` round trips: write(seq) publishes a ping (false: give up), echoed(seq)
// waits (at most a second) for the pong with that sequence number. Prints the report and,
// when `samples_path` is given, writes every measured round trip there.
template <class Write, class Echoed>
int run_ping(const char* vendor, int size, int rounds, int warmup, const char* samples_path, Write write,
             Echoed echoed) {
  std::vector<std::int64_t> rtt;
  std::vector<std::int64_t> write_time;
  rtt.reserve(static_cast<std::size_t>(rounds));
  write_time.reserve(static_cast<std::size_t>(rounds));
  int lost = 0;
  for (int i = 0; i < warmup + rounds && !g_stop; ++i) {
    const auto seq = static_cast<std::uint64_t>(i);
    const std::int64_t t0 = now_ns();
    if (!write(seq)) return 1;
    const std::int64_t t_written = now_ns();
    const bool got = echoed(seq);
    const std::int64_t t1 = now_ns();
    if (!got) {
      ++lost;
      continue;
    }
    if (i >= warmup) {
      rtt.push_back(t1 - t0);
      write_time.push_back(t_written - t0);
    }
  }
  report(vendor, size, warmup, rtt, write_time, lost);
  if (samples_path != nullptr && !write_samples(samples_path, rtt, write_time)) return 1;
  return 0;
}

}  // namespace bench
