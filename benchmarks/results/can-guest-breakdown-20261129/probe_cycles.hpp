// Probe only (not in the repository): cycle samples, medians printed at exit.
#pragma once
#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
struct ProbeCycles {
  const char* name;
  static constexpr std::size_t kMax = 1 << 17;
  std::uint32_t* v = new std::uint32_t[kMax];
  std::size_t n = 0;
  explicit ProbeCycles(const char* nm) : name(nm) {}
  void add(std::uint64_t c) { if (n < kMax) v[n++] = static_cast<std::uint32_t>(std::min<std::uint64_t>(c, 0xffffffffu)); }
  ~ProbeCycles() {
    if (n == 0) return;
    std::sort(v, v + n);
    auto at = [&](double q) { return v[std::min(n - 1, static_cast<std::size_t>(q * static_cast<double>(n)))]; };
    std::fprintf(stderr, "probe %-10s n=%zu p25=%u p50=%u p75=%u p90=%u cycles\n", name, n, at(.25), at(.5), at(.75), at(.9));
  }
};
inline bool probe_on() { static const bool on = std::getenv("POLYPORT_PROBE_CYCLES") != nullptr; return on; }
inline std::uint64_t probe_tsc() { return __builtin_ia32_rdtsc(); }
inline thread_local std::uint64_t g_probe_syscalls = 0;
