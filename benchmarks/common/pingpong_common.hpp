// What the ping-pong programs (benchmarks/dds, benchmarks/lcm, benchmarks/can) share: stopping
// on a signal, the command line, the clock, the ping loop and the percentiles of its one run,
// printed as one JSON line. Single-threaded: the ping loop runs on main; an SDK's own threads
// only deliver into the reader the loop waits on.
#pragma once

#include <algorithm>
#include <atomic>
#include <csignal>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <initializer_list>
#include <optional>
#include <string>
#include <vector>

#include <sys/types.h>

namespace bench {

inline std::atomic<bool> g_stop{false};
extern "C" inline void on_signal(int) { g_stop = true; }
inline void stop_on_signals() {
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
}

// The command line every program takes:
//   ping DOMAIN SIZE ROUNDS WARMUP [SAMPLES] | pong DOMAIN SIZE | relay DOMAIN_A DOMAIN_B SIZE
// with SIZE one of `sizes` (bytes of payload) and DOMAIN what keeps one path apart from the
// others (a DDS domain, an LCM provider, a vcan interface). nullopt (after printing the usage)
// when it is not one of those.
struct Command {
  std::string mode;  // "ping", "pong" or "relay"
  int size = 0;
  int domain = 0;    // ping, pong; relay: domain A
  int domain_b = 0;  // relay only
  int rounds = 0;    // ping only
  int warmup = 0;    // ping only
  const char* samples = nullptr;  // ping only, optional
};

inline std::optional<Command> parse_command(int argc, char** argv, std::initializer_list<int> sizes = {16, 1024}) {
  const auto int_at = [&](int i) { return argc > i ? std::atoi(argv[i]) : 0; };
  Command c;
  c.mode = argc > 1 ? argv[1] : "";
  c.domain = int_at(2);
  c.size = c.mode == "relay" ? int_at(4) : int_at(3);
  const bool known = (c.mode == "ping" && argc >= 6) || c.mode == "pong" || c.mode == "relay";
  if (!known || std::find(sizes.begin(), sizes.end(), c.size) == sizes.end()) {
    std::string allowed;
    for (int size : sizes) allowed += (allowed.empty() ? "" : " or ") + std::to_string(size);
    std::fprintf(stderr,
                 "usage: %s ping DOMAIN SIZE ROUNDS WARMUP [SAMPLES] | pong DOMAIN SIZE | relay DOMAIN_A DOMAIN_B SIZE\n"
                 "       SIZE: %s\n",
                 argv[0], allowed.c_str());
    return std::nullopt;
  }
  if (c.mode == "relay") c.domain_b = int_at(3);
  if (c.mode == "ping") {
    c.rounds = int_at(4);
    c.warmup = int_at(5);
    c.samples = argc >= 7 ? argv[6] : nullptr;
  }
  return c;
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

// CPU time spent during the measured round trips, by this process and by the processes whose
// ids POLYPORT_BENCH_CPU_PIDS lists ("pid,pid": the runner names the pong and, via a bridge,
// polyportd or the relay). Read from the processes' CPU-time clocks once before the first
// measured round trip and once after the last, never inside one. Where every process shares
// one core, their sum per round trip is what the round trip can at best cost: it tells
// which process a slower path spends its time in.
class CpuClocks {
 public:
  CpuClocks() {
    clocks_.push_back(CLOCK_PROCESS_CPUTIME_ID);
    const char* pids = std::getenv("POLYPORT_BENCH_CPU_PIDS");
    for (const char* at = pids; at != nullptr && *at != '\0';) {
      char* end = nullptr;
      const long pid = std::strtol(at, &end, 10);
      if (end == at) break;
      clockid_t clock{};
      clocks_.push_back(clock_getcpuclockid(static_cast<pid_t>(pid), &clock) == 0 ? clock : kNone);
      at = *end == ',' ? end + 1 : end;
    }
    start_.assign(clocks_.size(), -1);
    spent_.assign(clocks_.size(), -1);
  }
  void start() { read(start_); }
  void stop() {
    std::vector<std::int64_t> now(clocks_.size(), -1);
    read(now);
    for (std::size_t i = 0; i < now.size(); ++i) {
      spent_[i] = now[i] >= 0 && start_[i] >= 0 ? now[i] - start_[i] : -1;
    }
  }
  // "[self,pid...]" in nanoseconds; -1 where a clock could not be read.
  std::string json() const {
    std::string out = "[";
    for (std::size_t i = 0; i < spent_.size(); ++i) out += (i ? "," : "") + std::to_string(spent_[i]);
    return out + "]";
  }

 private:
  static constexpr clockid_t kNone = -1;
  void read(std::vector<std::int64_t>& into) const {
    for (std::size_t i = 0; i < clocks_.size(); ++i) {
      timespec ts{};
      into[i] = clocks_[i] != kNone && clock_gettime(clocks_[i], &ts) == 0
                    ? static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec
                    : -1;
    }
  }
  std::vector<clockid_t> clocks_;
  std::vector<std::int64_t> start_;
  std::vector<std::int64_t> spent_;
};

// One line on stdout: round trips, one-way (= round trip / 2) and the SDK's write call in the
// ping process, in nanoseconds, and the CPU time of the measured round trips (CpuClocks). The
// write is there to compare with polyport's sink time, the same SDK's write (of bytes already
// serialized) on polyport's side of a hop.
inline void report(const char* vendor, int size, int warmup, const std::vector<std::int64_t>& rtt,
                   const std::vector<std::int64_t>& write_ns, int lost, const CpuClocks& cpu) {
  std::vector<std::int64_t> one_way;
  one_way.reserve(rtt.size());
  for (std::int64_t r : rtt) one_way.push_back(r / 2);
  std::printf(R"({"vendor":"%s","size":%d,"warmup":%d,"lost":%d,"rtt_ns":%s,"one_way_ns":%s,"write_ns":%s,)"
              R"("cpu_ns":%s})"
              "\n",
              vendor, size, warmup, lost, summary(rtt).c_str(), summary(one_way).c_str(), summary(write_ns).c_str(),
              cpu.json().c_str());
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
  CpuClocks cpu;
  for (int i = 0; i < warmup + rounds && !g_stop; ++i) {
    if (i == warmup) cpu.start();
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
  cpu.stop();
  report(vendor, size, warmup, rtt, write_time, lost, cpu);
  if (samples_path != nullptr && !write_samples(samples_path, rtt, write_time)) return 1;
  return 0;
}

}  // namespace bench
