// What the wheelchair's stand-alone node programs share (wheelchair_dds_node with Cyclone DDS,
// wheelchair_fastdds_hw with Fast DDS): stopping on a signal, the periodic loop and its
// statistics, the summary file, and the HW side's raw CAN socket (open, drain the joystick
// and encoder frames, send the motor voltages). No DDS in here: each program brings its SDK.
//
// Threads: everything here runs on the program's main thread, but for the signal handler,
// which only sets an atomic flag that the loop checks at every wake.
// Memory: the loop's logs reserve their capacity at start; the CAN side works in stack
// frames, so a period does not allocate.
#pragma once

#include <errno.h>
#include <linux/can.h>
#include <linux/can/raw.h>
#include <net/if.h>
#include <signal.h>
#include <sys/socket.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <atomic>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <optional>
#include <string>

#include "can_frames.hpp"
#include "loop_stats.hpp"
#include "steering.hpp"

namespace polyport::wheelchair::node {

namespace wc = polyport::wheelchair;

inline constexpr int kExitOk = 0;
inline constexpr int kExitFailed = 1;
inline constexpr int kExitUsage = 2;

inline std::atomic<bool> g_stop{false};
static_assert(std::atomic<bool>::is_always_lock_free);
extern "C" inline void on_stop_signal(int) { g_stop.store(true, std::memory_order_relaxed); }

inline void stop_on_signals() {
  struct sigaction action {};
  action.sa_handler = on_stop_signal;
  sigemptyset(&action.sa_mask);
  sigaction(SIGINT, &action, nullptr);
  sigaction(SIGTERM, &action, nullptr);
}

// What the loop, the announcement and the summary need of a program's command line.
struct NodeOptions {
  const char* program = "";
  std::string role;
  int period_ms = 10;
  std::optional<double> phase_ms;  // the loop's place in the period; none: a period from start
  std::optional<std::int64_t> phase_ns;  // phase_ms as parse_node_options checked it
  std::string interface = "vcan0";
  std::string summary;
  int domain = 0;
};

// The command line every node takes, on top of what the program adds itself (with CLI11):
// --period-ms, --if, --summary, --domain. Returns the exit code when the program should end
// here (help shown: kExitOk; a bad command line: kExitUsage).
inline std::optional<int> parse_node_options(CLI::App& app, NodeOptions& options, int argc, char** argv) {
  app.footer("Exit codes:\n  0  stopped by SIGINT or SIGTERM\n  1  setup failed, or the summary could not be written\n"
             "  2  bad command line\n");
  app.add_option("--period-ms", options.period_ms, "the loop's period, milliseconds")
      ->capture_default_str()
      ->check(CLI::Range(1, 60000));
  app.add_option("--phase-ms", options.phase_ms,
                 "run the loop at k * period + phase on CLOCK_MONOTONIC (default: a period after start)");
  app.add_option("--if", options.interface, "hw: the CAN interface")->capture_default_str();
  app.add_option("--summary", options.summary, "write the run's summary (JSON) to this file at exit");
  app.add_option("--domain", options.domain, "the DDS domain id")->capture_default_str()->check(CLI::Range(0, 232));
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    return code == 0 ? kExitOk : kExitUsage;
  }
  if (!wc::timer_phase(options.program, options.phase_ms, options.period_ms, options.phase_ns)) return kExitUsage;
  return std::nullopt;
}

struct LoopStats {
  wc::SampleLog lateness;
  std::uint64_t periods = 0;
  std::uint64_t overruns = 0;
};

// Runs `step` at every deadline until a stop signal; the signal is seen at the next wake.
template <class Step>
inline void run_periodic(const NodeOptions& options, LoopStats& stats, Step&& step) {
  wc::PeriodicTimer timer(static_cast<std::int64_t>(options.period_ms) * 1'000'000, options.phase_ns);
  while (!g_stop.load(std::memory_order_relaxed)) {
    stats.lateness.add(timer.wait());
    if (g_stop.load(std::memory_order_relaxed)) break;
    step();
    ++stats.periods;
  }
  stats.overruns = timer.overruns();
}

inline void announce(const NodeOptions& options) {
  std::fprintf(stderr, "%s %s: running\n", options.program, options.role.c_str());
  std::fflush(stderr);
}

// Writes {"role":..,"period_ms":..,"periods":..,"overruns":..,"lateness_ns":{..},"cpu_s":..
// plus `extra` (",\"key\":value..." or empty)}. No file named: nothing to do.
inline bool write_summary(const NodeOptions& options, const LoopStats& stats, const std::string& extra) {
  if (options.summary.empty()) return true;
  char head[256];
  std::snprintf(head, sizeof head, R"({"role":"%s","period_ms":%d,"periods":%llu,"overruns":%llu,"lateness_ns":)",
                options.role.c_str(), options.period_ms, static_cast<unsigned long long>(stats.periods),
                static_cast<unsigned long long>(stats.overruns));
  char cpu[64];
  std::snprintf(cpu, sizeof cpu, R"(,"cpu_s":%.6f)", wc::process_cpu_s());
  const std::string text = head + stats.lateness.summary_json() + cpu + extra + "}\n";
  std::FILE* file = std::fopen(options.summary.c_str(), "w");
  const bool written = file != nullptr && std::fputs(text.c_str(), file) >= 0;
  const bool closed = file != nullptr && std::fclose(file) == 0;
  if (!written || !closed) {
    std::fprintf(stderr, "%s: cannot write the summary %s: %s\n", options.program, options.summary.c_str(),
                 std::strerror(errno));
    return false;
  }
  return true;
}

inline std::string counter(const char* name, std::uint64_t value) {
  return std::string(",\"") + name + "\":" + std::to_string(value);
}


// ---- The HW side's CAN socket -------------------------------------------------------------

// A raw CAN socket bound to `interface`, non-blocking, receiving only the joystick and encoder
// frames (standard ids, no remote frames). -1 after printing why it could not be opened.
inline int open_can(const char* program, const std::string& interface) {
  if (interface.empty() || interface.size() >= IFNAMSIZ) {
    std::fprintf(stderr, "%s: bad CAN interface name '%s'\n", program, interface.c_str());
    return -1;
  }
  const int fd = socket(PF_CAN, SOCK_RAW | SOCK_NONBLOCK | SOCK_CLOEXEC, CAN_RAW);
  if (fd < 0) {
    std::fprintf(stderr, "%s: cannot open a raw CAN socket: %s\n", program, std::strerror(errno));
    return -1;
  }
  const can_filter filters[2] = {
      {wc::can::kJoystickId, CAN_SFF_MASK | CAN_EFF_FLAG | CAN_RTR_FLAG},
      {wc::can::kEncoderId, CAN_SFF_MASK | CAN_EFF_FLAG | CAN_RTR_FLAG},
  };
  if (setsockopt(fd, SOL_CAN_RAW, CAN_RAW_FILTER, filters, sizeof filters) != 0) {
    std::fprintf(stderr, "%s: cannot set the CAN filters: %s\n", program, std::strerror(errno));
    close(fd);
    return -1;
  }
  const unsigned index = if_nametoindex(interface.c_str());
  if (index == 0) {
    std::fprintf(stderr, "%s: no network interface '%s': %s\n", program, interface.c_str(),
                 std::strerror(errno));
    close(fd);
    return -1;
  }
  sockaddr_can address{};
  address.can_family = AF_CAN;
  address.can_ifindex = static_cast<int>(index);
  if (bind(fd, reinterpret_cast<const sockaddr*>(&address), sizeof address) != 0) {
    std::fprintf(stderr, "%s: cannot bind to CAN interface '%s': %s\n", program, interface.c_str(),
                 std::strerror(errno));
    close(fd);
    return -1;
  }
  return fd;
}

struct CanCounters {
  std::uint64_t frames_rx = 0;
  std::uint64_t bad_frames = 0;
  std::uint64_t frames_tx = 0;
  std::uint64_t rx_errors = 0;
  std::uint64_t tx_errors = 0;
};


// The HW node's side of the bus: the CAN socket, what it last read, and its counters.
class HwBus {
 public:
  explicit HwBus(const NodeOptions& options) : fd_(open_can(options.program, options.interface)) {}
  ~HwBus() {
    if (fd_ >= 0) close(fd_);
  }
  HwBus(const HwBus&) = delete;
  HwBus& operator=(const HwBus&) = delete;
  bool ok() const { return fd_ >= 0; }

  // Everything the kernel queued since the last period: the newest stick and encoders win.
  void drain() {
    for (;;) {
      can_frame frame{};
      const ssize_t n = recv(fd_, &frame, sizeof frame, MSG_DONTWAIT);
      if (n < 0) {
        if (errno == EINTR) continue;
        if (errno != EAGAIN && errno != EWOULDBLOCK) ++counters_.rx_errors;
        break;
      }
      ++counters_.frames_rx;
      if (n != static_cast<ssize_t>(sizeof frame) || frame.can_dlc != wc::can::kLength) {
        ++counters_.bad_frames;
        continue;
      }
      if ((frame.can_id & CAN_SFF_MASK) == wc::can::kJoystickId) {
        stick_ = wc::can::unpack_joystick(frame.data);
      } else {
        encoders_ = wc::can::unpack_encoders(frame.data);
      }
    }
  }

  // The stick as last read (centred until the first 0x101).
  const wc::JoystickPosition& stick() const { return stick_; }
  // The wheel speeds as the HW node knows them (at rest until the first 0x181): the heading
  // is unknown to it; time from the node's start.
  wc::WheelSpeeds wheel_speeds() const {
    return wc::WheelSpeeds{encoders_.left_rad_s, encoders_.right_rad_s, 0.0,
                           wc::realised_steering_deg(encoders_.left_rad_s, encoders_.right_rad_s, geometry_),
                           static_cast<double>(wc::now_ns() - start_ns_) / 1e9};
  }

  void send(const wc::MotorVoltages& voltages) {
    can_frame out{};
    out.can_id = wc::can::kVoltagesId;
    out.can_dlc = wc::can::kLength;
    const wc::can::Payload payload = wc::can::pack(voltages);
    std::memcpy(out.data, payload.data(), payload.size());
    if (write(fd_, &out, sizeof out) == static_cast<ssize_t>(sizeof out)) {
      ++counters_.frames_tx;
    } else {
      ++counters_.tx_errors;
    }
  }

  // The summary's CAN fields.
  std::string summary_fields() const {
    return counter("frames_rx", counters_.frames_rx) + counter("frames_tx", counters_.frames_tx) +
           counter("bad_frames", counters_.bad_frames) + counter("rx_errors", counters_.rx_errors) +
           counter("tx_errors", counters_.tx_errors);
  }

 private:
  int fd_;
  CanCounters counters_;
  const wc::ChairGeometry geometry_{};
  const std::int64_t start_ns_ = wc::now_ns();
  wc::JoystickPosition stick_;
  wc::EncoderSpeeds encoders_;
};

}  // namespace polyport::wheelchair::node
