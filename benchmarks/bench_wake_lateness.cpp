// Wake lateness of a periodic thread (wake - deadline, CLOCK_MONOTONIC), run by hand
// (scripts/bench_wake.sh), never a test. In one run, per period, it measures:
//   plain            a clock_nanosleep(TIMER_ABSTIME) loop with timer slack 1 ns, the floor
//                    any sleeping thread can reach on this kernel;
//   ec               a polyport ExecutionContext at its default settings (futex sleep);
//   ec-spin<N>us     an ExecutionContext with an N us spin tail;
//   cpu-gaps         no sleep: a thread that only reads the clock, recording per period the
//                    longest time between two reads: how long the thread lost its CPU (to the
//                    guest's scheduler, interrupts, or the host stopping the vCPU). A spin tail
//                    cannot wake more punctually than that.
// The cases take turns in chunks (plain, ec, ec-spin..., plain, ...), so a change of load on
// the shared machine falls on all of them alike. Each context lives for the whole run and is
// started and stopped once per chunk; its own wake-jitter histogram (the one polyportd reports)
// collects the samples. The plain loop records into the same kind of histogram, so every case
// is summarized the same way (percentiles within 1/32 relative, max exact).
//
//   bench_wake_lateness OUT.json [--periods N] [--chunks C] [--period-ms P[,P...]] [--spin-us S[,S...]]
//                                [--fifo PRIORITY]
//     N  measured periods per case and period (default 1000: 10 s per case at 10 ms)
//     C  chunks the N periods are split into (default 10)
//     P  periods in milliseconds (default 10)
//     S  spin tails in microseconds (default 100,300)
//     PRIORITY  run every case's thread under SCHED_FIFO at this priority (default: SCHED_OTHER);
//               refused (no CAP_SYS_NICE) is an error, not a silent fallback
//
// Threads: the main thread starts and stops each case and polls its cycle count; the plain
// loop and each context run on their own thread, one case at a time.
#include <pthread.h>
#include <sched.h>
#include <sys/prctl.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <fstream>
#include <memory>
#include <iostream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "polyport/base/clock.hpp"
#include "polyport/runtime/execution_context.hpp"
#include "polyport/runtime/histogram.hpp"
#include "runner.hpp"

namespace {

using polyport::ExecutionContext;
using polyport::ExecutionSettings;
using polyport::LatencyHistogram;
using polyport::MonoTime;
using polyport::Nanos;
using polyport::mono_now;

struct Case {
  std::string name;
  Nanos period{0};
  Nanos spin{0};
  bool plain = false;
  bool gaps = false;                          // the cpu-gaps case (plain is false too)
  std::unique_ptr<ExecutionContext> context;  // null for the plain loop and cpu-gaps
  LatencyHistogram plain_lateness;            // the plain loop's (or cpu-gaps') samples
  long timer_slack_ns = -1;
};

int fifo_priority = 0;  // 0: SCHED_OTHER
bool fifo_refused = false;

// Under --fifo, puts the calling thread under SCHED_FIFO; false (and fifo_refused) when refused.
bool take_fifo() {
  if (fifo_priority <= 0) return true;
  sched_param param{};
  param.sched_priority = fifo_priority;
  if (pthread_setschedparam(pthread_self(), SCHED_FIFO, &param) == 0) return true;
  fifo_refused = true;
  return false;
}

// `periods` wakes of a clock_nanosleep loop at `period`, after one unmeasured cycle.
void plain_loop(Case& c, std::uint64_t periods) {
  if (!take_fifo()) return;
  prctl(PR_SET_TIMERSLACK, 1UL, 0UL, 0UL, 0UL);
  c.timer_slack_ns = prctl(PR_GET_TIMERSLACK, 0UL, 0UL, 0UL, 0UL);
  MonoTime deadline = mono_now();
  for (std::uint64_t i = 0; i < periods; ++i) {
    deadline = deadline + c.period;
    const timespec until = polyport::to_timespec(deadline);
    while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &until, nullptr) != 0) {
    }
    c.plain_lateness.record((mono_now() - deadline).count);
  }
}

// `periods` periods of spinning on the clock; per period, the longest gap between two reads.
void gap_loop(Case& c, std::uint64_t periods) {
  if (!take_fifo()) return;
  MonoTime previous = mono_now();
  MonoTime end_of_period = previous + c.period;
  for (std::uint64_t i = 0; i < periods; ++i) {
    std::int64_t longest = 0;
    for (MonoTime now = mono_now(); now < end_of_period; now = mono_now()) {
      longest = std::max(longest, (now - previous).count);
      previous = now;
    }
    c.plain_lateness.record(longest);
    end_of_period = end_of_period + c.period;
  }
}

void run_chunk(Case& c, std::uint64_t periods) {
  if (c.gaps) {
    std::thread thread([&] { gap_loop(c, periods); });
    thread.join();
    return;
  }
  if (c.plain) {
    std::thread thread([&] { plain_loop(c, periods); });
    thread.join();
    return;
  }
  std::vector<std::string> warnings;
  // The context's first cycle runs at once, without a sleep: periods + 1 cycles give `periods`
  // wakes (one or two more, as the poll below notices the count late).
  const std::uint64_t target = c.context->cycles() + periods + 1;
  c.context->start(warnings);
  for (const auto& w : warnings) std::cerr << w << "\n";
  if (fifo_priority > 0 && !c.context->realtime_applied()) fifo_refused = true;
  // Polled at most every period (and every 20 ms), so a chunk overshoots by a cycle or two.
  const auto poll = std::chrono::nanoseconds(std::min<std::int64_t>(c.period.count, 20'000'000));
  while (c.context->cycles() < target) std::this_thread::sleep_for(poll);
  c.context->stop();
  c.timer_slack_ns = c.context->timer_slack_ns();
}

std::vector<double> parse_list(const std::string& text) {
  std::vector<double> out;
  std::stringstream in(text);
  std::string item;
  while (std::getline(in, item, ',')) out.push_back(std::stod(item));
  return out;
}

std::string number(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%g", value);
  return text;
}

bench::Json summarize(const LatencyHistogram& h) {
  const LatencyHistogram::Summary s = h.summarize();
  return {{"n", s.count}, {"min", s.min},   {"mean", s.mean}, {"p50", s.p50},
          {"p90", s.p90}, {"p99", s.p99},   {"p999", s.p999}, {"max", s.max}};
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::cerr << "usage: " << argv[0]
              << " OUT.json [--periods N] [--chunks C] [--period-ms P[,P...]] [--spin-us S[,S...]]\n";
    return 2;
  }
  const std::string out_path = argv[1];
  std::uint64_t periods = 1000;
  std::uint64_t chunks = 10;
  std::vector<double> period_ms{10};
  std::vector<double> spin_us{100, 300};
  for (int i = 2; i + 1 < argc; i += 2) {
    const std::string option = argv[i];
    const std::string value = argv[i + 1];
    if (option == "--periods") {
      periods = std::stoull(value);
    } else if (option == "--chunks") {
      chunks = std::stoull(value);
    } else if (option == "--period-ms") {
      period_ms = parse_list(value);
    } else if (option == "--spin-us") {
      spin_us = parse_list(value);
    } else if (option == "--fifo") {
      fifo_priority = std::stoi(value);
    } else {
      std::cerr << "unknown option " << option << "\n";
      return 2;
    }
  }
  if (chunks == 0 || periods < chunks) {
    std::cerr << "need --periods >= --chunks >= 1\n";
    return 2;
  }
  bench::forward_stop_signals();
  bench::Json result = bench::result_header("wake_lateness");

  std::vector<std::unique_ptr<Case>> cases;
  for (const double p : period_ms) {
    const Nanos period{static_cast<std::int64_t>(p * 1e6)};
    const std::string suffix = "@" + number(p) + "ms";
    auto plain = std::make_unique<Case>();
    plain->name = "plain" + suffix;
    plain->period = period;
    plain->plain = true;
    cases.push_back(std::move(plain));
    auto gaps = std::make_unique<Case>();
    gaps->name = "cpu-gaps" + suffix;
    gaps->period = period;
    gaps->gaps = true;
    cases.push_back(std::move(gaps));
    std::vector<double> spins{0};
    spins.insert(spins.end(), spin_us.begin(), spin_us.end());
    for (const double s : spins) {
      auto c = std::make_unique<Case>();
      c->spin = Nanos{static_cast<std::int64_t>(s * 1000)};
      c->name = (s > 0 ? "ec-spin" + number(s) + "us" : std::string("ec")) + suffix;
      c->period = period;
      ExecutionSettings settings;
      settings.name = "bench-ec";
      settings.period = period;
      settings.spin = c->spin;
      if (fifo_priority > 0) {
        settings.policy = polyport::SchedPolicy::fifo;
        settings.priority = fifo_priority;
      }
      c->context = std::make_unique<ExecutionContext>(settings);
      cases.push_back(std::move(c));
    }
  }

  const std::uint64_t per_chunk = periods / chunks;
  for (std::uint64_t chunk = 0; chunk < chunks && !bench::interrupted(); ++chunk) {
    for (auto& c : cases) {
      if (bench::interrupted()) break;
      run_chunk(*c, per_chunk);
      if (fifo_refused) {
        std::cerr << "SCHED_FIFO priority " << fifo_priority << " refused: no result written\n";
        return 1;
      }
    }
    std::cerr << "chunk " << chunk + 1 << "/" << chunks << " done\n";
  }
  if (bench::interrupted()) {
    std::cerr << "interrupted: no result written\n";
    return 130;
  }

  result["settings"] = {{"periods_per_case", per_chunk * chunks},
                        {"chunks", chunks},
                        {"periods_per_chunk", per_chunk},
                        {"period_ms", period_ms},
                        {"spin_us", spin_us},
                        {"lateness",
                         "wake - deadline on CLOCK_MONOTONIC, ns; the ExecutionContext's own wake-jitter "
                         "histogram (what polyportd reports), the plain loop recorded into the same kind "
                         "of histogram: percentiles within 1/32 relative, min and max exact"},
                        {"scheduling", (fifo_priority > 0 ? "SCHED_FIFO priority " + std::to_string(fifo_priority)
                                                          : std::string("SCHED_OTHER")) +
                                           ", unpinned, timer slack 1 ns in every case"}};
  double load[3] = {0, 0, 0};
  getloadavg(load, 3);
  result["host"]["loadavg_at_end"] = {load[0], load[1], load[2]};
  result["cases"] = bench::Json::array();
  std::printf("%-22s %10s %10s %10s %10s %10s\n", "case", "n", "p50 us", "p99 us", "p99.9 us", "max us");
  for (const auto& c : cases) {
    const LatencyHistogram& h = c->context ? c->context->wake_jitter() : c->plain_lateness;
    bench::Json j{{"name", c->name},
                  {"period_ns", c->period.count},
                  {"spin_us", c->spin.count / 1000},
                  {"kind", c->plain  ? "clock_nanosleep loop"
                           : c->gaps ? "spinning on the clock: longest gap between two reads per period"
                                     : "ExecutionContext"},
                  {"timer_slack_ns", c->timer_slack_ns},
                  {"lateness_ns", summarize(h)}};
    if (c->context) j["overruns"] = c->context->overruns();
    const LatencyHistogram::Summary s = h.summarize();
    std::printf("%-22s %10llu %10.1f %10.1f %10.1f %10.1f\n", c->name.c_str(),
                static_cast<unsigned long long>(s.count), static_cast<double>(s.p50) / 1e3,
                static_cast<double>(s.p99) / 1e3, static_cast<double>(s.p999) / 1e3,
                static_cast<double>(s.max) / 1e3);
    result["cases"].push_back(std::move(j));
  }
  std::ofstream out(out_path);
  out << result.dump(2) << "\n";
  if (!out) {
    std::cerr << out_path << ": could not write\n";
    return 1;
  }
  std::cerr << "wrote " << out_path << "\n";
  return 0;
}
