// wheelchair_lcm_joystick: the wheelchair's Joystick component as an LCM program. It
// subscribes to the stick position (WHEELCHAIR_JOYSTICK, wheelchair_lcm.joystick_t) and every
// period publishes the driver's reference (WHEELCHAIR_REFERENCE, reference_t) computed by the
// wheelchair's joystick mapping (steering.hpp). At SIGINT / SIGTERM it writes its figures
// (--summary: periods, wake lateness, CPU time) and exits.
//
// Threads: one. The LCM file descriptor is drained without blocking at the start of every
// period (lcm_handle_timeout with 0 ms), then the loop sleeps to the next deadline.
#include <lcm/lcm.h>

#include <CLI/CLI.hpp>
#include <atomic>
#include <csignal>
#include <cstdio>
#include <string>

#include "loop_stats.hpp"
#include "steering.hpp"
#include "wheelchair_lcm_joystick_t.h"
#include "wheelchair_lcm_reference_t.h"

namespace wc = polyport::wheelchair;

namespace {

std::atomic<bool> g_stop{false};
void on_signal(int) { g_stop.store(true); }

void on_joystick(const lcm_recv_buf_t*, const char*, const wheelchair_lcm_joystick_t* msg, void* user) {
  auto* stick = static_cast<wc::JoystickPosition*>(user);
  stick->x = msg->x;
  stick->y = msg->y;
}

}  // namespace

int main(int argc, char** argv) {
  std::string url = "udpm://239.255.76.67:7667?ttl=0";
  double period_ms = 10.0;
  std::string summary_path;
  CLI::App app{"wheelchair_lcm_joystick: the wheelchair's Joystick as an LCM program"};
  app.add_option("--url", url, "LCM provider")->capture_default_str();
  app.add_option("--period-ms", period_ms, "period")->capture_default_str()->check(CLI::Range(1.0, 1000.0));
  std::optional<double> phase_ms;
  app.add_option("--phase-ms", phase_ms, "run at k * period + phase on CLOCK_MONOTONIC (default: a period after start)");
  app.add_option("--summary", summary_path, "write the run's figures (JSON) here at exit");
  CLI11_PARSE(app, argc, argv);
  std::optional<std::int64_t> phase_ns;
  if (!wc::timer_phase("wheelchair_lcm_joystick", phase_ms, period_ms, phase_ns)) return 2;

  lcm_t* lcm = lcm_create(url.c_str());
  if (lcm == nullptr) {
    std::fprintf(stderr, "wheelchair_lcm_joystick: cannot create LCM on %s (a multicast route? see lcm-udpm)\n", url.c_str());
    return 1;
  }
  wc::JoystickPosition stick;
  wheelchair_lcm_joystick_t_subscribe(lcm, "WHEELCHAIR_JOYSTICK", on_joystick, &stick);
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  std::fprintf(stderr, "wheelchair_lcm_joystick joystick: running on %s\n", url.c_str());

  wc::SampleLog lateness(1 << 20);
  wc::PeriodicTimer timer(static_cast<std::int64_t>(period_ms * 1e6), phase_ns);
  std::size_t periods = 0;
  while (!g_stop.load(std::memory_order_relaxed)) {
    lateness.add(timer.wait());
    while (lcm_handle_timeout(lcm, 0) > 0) {
    }
    const wc::Reference reference = wc::joystick_to_reference(stick);
    wheelchair_lcm_reference_t out{reference.direction_deg, reference.speed_mps};
    wheelchair_lcm_reference_t_publish(lcm, "WHEELCHAIR_REFERENCE", &out);
    ++periods;
  }
  const double cpu_s = wc::process_cpu_s();
  lcm_destroy(lcm);
  if (!summary_path.empty()) {
    FILE* f = std::fopen(summary_path.c_str(), "w");
    if (f == nullptr) return 1;
    std::fprintf(f, "{\"role\":\"joystick\",\"period_ms\":%g,\"periods\":%zu,\"overruns\":%llu,\"lateness_ns\":%s,\"cpu_s\":%.4f}\n",
                 period_ms, periods, static_cast<unsigned long long>(timer.overruns()), lateness.summary_json().c_str(),
                 cpu_s);
    std::fclose(f);
  }
  return 0;
}
