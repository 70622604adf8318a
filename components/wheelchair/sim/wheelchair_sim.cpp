// wheelchair_sim: the electric wheelchair's DSP and IO boards on a CAN bus, for the wheelchair
// benchmark suite. Every period (10 ms) it sends the joystick position (0x101) and the two
// encoder wheel speeds (0x181), applies the newest motor reference voltages received (0x201)
// to the simulated chair (the plant of components/wheelchair/steering.hpp) and logs its own
// view: commanded voltages, wheel speeds, heading and realised steering angle, stamped on its
// clock. The frames are those of config/types/wheelchair_can.dbc (can_frames.hpp).
//
// Time starts when the controller shows up: the boards send a centred stick and still wheels
// until the first motor-voltage frame arrives, then the scenario plays from t = 0 for
// --duration-s, so runs of different configurations line up sample for sample.
//
// Sensor to actuator, from kernel timestamps: the socket receives its own frames back
// (CAN_RAW_RECV_OWN_MSGS) with their SO_TIMESTAMPNS stamps. For every scenario step, the
// latency is from the first joystick frame carrying the new stick position to the first
// motor-voltage frame that differs from the last one before it by more than --response-v.
//
// Threads: one. Memory: the trace rows and stamps are reserved before the run; the loop does
// not allocate. Output files are written after the run.
#include <fcntl.h>
#include <linux/can.h>
#include <linux/can/raw.h>
#include <net/if.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <atomic>
#include <cerrno>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "can_frames.hpp"
#include "loop_stats.hpp"
#include "steering.hpp"

namespace wc = polyport::wheelchair;

namespace {

std::atomic<bool> g_stop{false};
void on_signal(int) { g_stop.store(true); }

struct Options {
  std::string interface = "vcan0";
  double period_ms = 10.0;
  std::optional<double> phase_ms;
  double duration_s = 12.0;
  std::string scenario = "0:0:0; 0.5:0:0.6; 2.0:20:0.6; 6.0:0:0.6";
  std::string trace_path;
  std::string summary_path;
  double start_timeout_s = 20.0;
  double response_v = 0.5;
};

struct TraceRow {
  double t_s;
  wc::JoystickPosition stick;
  wc::MotorVoltages applied;
  wc::WheelSpeeds speeds;
  int voltage_frames;  // received during the period before this step
};

// A frame the socket received, with its kernel stamp (CLOCK_REALTIME, ns).
struct Stamped {
  std::int64_t kernel_ns;
  bool own;  // our own transmission, looped back
  can_frame frame;
};

int open_socket(const std::string& name, std::string& error) {
  const int fd = ::socket(PF_CAN, SOCK_RAW | SOCK_CLOEXEC, CAN_RAW);
  if (fd < 0) {
    error = std::string("socket(PF_CAN): ") + std::strerror(errno) + " (does this kernel have CAN? see scripts/vcan-run)";
    return -1;
  }
  const can_filter filters[] = {{wc::can::kVoltagesId, CAN_SFF_MASK | CAN_EFF_FLAG | CAN_RTR_FLAG},
                                {wc::can::kJoystickId, CAN_SFF_MASK | CAN_EFF_FLAG | CAN_RTR_FLAG}};
  const int on = 1;
  ifreq ifr{};
  std::snprintf(ifr.ifr_name, IFNAMSIZ, "%s", name.c_str());
  if (::setsockopt(fd, SOL_CAN_RAW, CAN_RAW_FILTER, filters, sizeof filters) != 0 ||
      ::setsockopt(fd, SOL_CAN_RAW, CAN_RAW_RECV_OWN_MSGS, &on, sizeof on) != 0 ||
      ::setsockopt(fd, SOL_SOCKET, SO_TIMESTAMPNS, &on, sizeof on) != 0) {
    error = std::string("setsockopt: ") + std::strerror(errno);
  } else if (::ioctl(fd, SIOCGIFINDEX, &ifr) != 0) {
    error = "no CAN interface '" + name + "': " + std::strerror(errno);
  } else {
    sockaddr_can addr{};
    addr.can_family = AF_CAN;
    addr.can_ifindex = ifr.ifr_ifindex;
    if (::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) == 0) return fd;
    error = "bind to " + name + ": " + std::strerror(errno);
  }
  ::close(fd);
  return -1;
}

// One frame without blocking; false when the socket is empty.
bool receive(int fd, Stamped& out) {
  char control[CMSG_SPACE(sizeof(timespec))];
  iovec iov{&out.frame, sizeof out.frame};
  msghdr msg{};
  msg.msg_iov = &iov;
  msg.msg_iovlen = 1;
  msg.msg_control = control;
  msg.msg_controllen = sizeof control;
  const ssize_t n = ::recvmsg(fd, &msg, MSG_DONTWAIT);
  if (n != static_cast<ssize_t>(sizeof(can_frame))) return false;
  out.own = (msg.msg_flags & MSG_CONFIRM) != 0;
  out.kernel_ns = 0;
  for (cmsghdr* c = CMSG_FIRSTHDR(&msg); c != nullptr; c = CMSG_NXTHDR(&msg, c)) {
    if (c->cmsg_level == SOL_SOCKET && c->cmsg_type == SO_TIMESTAMPNS) {
      timespec t;
      std::memcpy(&t, CMSG_DATA(c), sizeof t);
      out.kernel_ns = wc::ns_of(t);
    }
  }
  return true;
}

bool send(int fd, std::uint32_t id, const wc::can::Payload& payload) {
  can_frame frame{};
  frame.can_id = id;
  frame.len = wc::can::kLength;
  std::memcpy(frame.data, payload.data(), payload.size());
  return ::write(fd, &frame, sizeof frame) == static_cast<ssize_t>(sizeof frame);
}

bool same(const wc::JoystickPosition& a, const wc::JoystickPosition& b) { return a.x == b.x && a.y == b.y; }

// Finds, for each change of the stick in the joystick frames, the first motor frame after it
// that moved by more than `threshold_v` from the last motor frame before it.
void step_responses(const std::vector<Stamped>& frames, double threshold_v, wc::SampleLog& out) {
  bool have_stick = false;
  wc::JoystickPosition stick;
  bool have_voltages = false;
  wc::MotorVoltages last_voltages;
  bool pending = false;
  std::int64_t changed_ns = 0;
  wc::MotorVoltages before;
  for (const Stamped& s : frames) {
    if (s.frame.can_id == wc::can::kJoystickId && s.own && s.frame.len == wc::can::kLength) {
      const wc::JoystickPosition next = wc::can::unpack_joystick(s.frame.data);
      if (have_stick && !same(next, stick) && have_voltages && !pending) {
        pending = true;
        changed_ns = s.kernel_ns;
        before = last_voltages;
      }
      stick = next;
      have_stick = true;
    } else if (s.frame.can_id == wc::can::kVoltagesId && !s.own && s.frame.len == wc::can::kLength) {
      last_voltages = wc::can::unpack_voltages(s.frame.data);
      have_voltages = true;
      if (pending && std::fabs(last_voltages.left_v - before.left_v) + std::fabs(last_voltages.right_v - before.right_v) >
                         threshold_v) {
        out.add(s.kernel_ns - changed_ns);
        pending = false;
      }
    }
  }
}

bool write_trace(const std::string& path, const std::vector<TraceRow>& rows) {
  FILE* f = std::fopen(path.c_str(), "w");
  if (f == nullptr) return false;
  std::fprintf(f, "t_s,joy_x,joy_y,left_v,right_v,left_rad_s,right_rad_s,heading_deg,steering_deg,voltage_frames\n");
  for (const TraceRow& r : rows) {
    std::fprintf(f, "%.3f,%.4f,%.4f,%.3f,%.3f,%.5f,%.5f,%.4f,%.4f,%d\n", r.t_s, r.stick.x, r.stick.y, r.applied.left_v,
                 r.applied.right_v, r.speeds.left_rad_s, r.speeds.right_rad_s, r.speeds.heading_deg,
                 r.speeds.steering_deg, r.voltage_frames);
  }
  return std::fclose(f) == 0;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  CLI::App app{"wheelchair_sim: the wheelchair's DSP and IO boards on a CAN bus (config/types/wheelchair_can.dbc)"};
  app.add_option("--if", o.interface, "CAN interface")->capture_default_str();
  app.add_option("--period-ms", o.period_ms, "period of the boards")->capture_default_str()->check(CLI::Range(1.0, 1000.0));
  app.add_option("--duration-s", o.duration_s, "how long the scenario runs once the controller is there")
      ->capture_default_str()
      ->check(CLI::Range(0.01, 86400.0));
  app.add_option("--scenario", o.scenario, "the stick: \"time_s:angle_deg:magnitude; ...\"")->capture_default_str();
  app.add_option("--phase-ms", o.phase_ms, "run at k * period + phase on CLOCK_MONOTONIC (default: a period after start)");
  app.add_option("--trace", o.trace_path, "write the per-period trace (CSV) here");
  app.add_option("--summary", o.summary_path, "write the run's figures (JSON) here");
  app.add_option("--start-timeout-s", o.start_timeout_s, "give up when no motor-voltage frame comes within this")
      ->capture_default_str();
  app.add_option("--response-v", o.response_v, "voltage change that counts as the motors' response to a step")
      ->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  std::optional<std::int64_t> phase_ns;
  if (!wc::timer_phase("wheelchair_sim", o.phase_ms, o.period_ms, phase_ns)) return 2;

  const wc::ScenarioParseResult scenario = wc::parse_scenario(o.scenario);
  if (!scenario.ok()) {
    std::fprintf(stderr, "wheelchair_sim: --scenario at character %zu: %.*s\n", scenario.error_offset,
                 static_cast<int>(scenario.error.size()), scenario.error.data());
    return 2;
  }
  std::string error;
  const int fd = open_socket(o.interface, error);
  if (fd < 0) {
    std::fprintf(stderr, "wheelchair_sim: %s\n", error.c_str());
    return 1;
  }
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);

  const double dt = o.period_ms / 1000.0;
  const auto periods = static_cast<std::size_t>(std::llround(o.duration_s / dt));
  std::vector<TraceRow> rows;
  rows.reserve(periods);
  std::vector<Stamped> frames;
  frames.reserve(periods * 4 + 1024);
  wc::SampleLog lateness(periods + 16);
  wc::WheelchairPlant plant;
  wc::MotorVoltages voltages;
  std::size_t frames_lost = 0;
  std::size_t send_failures = 0;
  std::size_t bad_frames = 0;
  bool started = false;
  int voltage_frames = 0;
  const std::int64_t start_deadline = wc::now_ns() + static_cast<std::int64_t>(o.start_timeout_s * 1e9);
  std::fprintf(stderr, "wheelchair_sim: on %s, waiting for the controller's first motor-voltage frame (0x%03x)\n",
               o.interface.c_str(), wc::can::kVoltagesId);

  wc::PeriodicTimer timer(static_cast<std::int64_t>(o.period_ms * 1e6), phase_ns);
  while (!g_stop.load(std::memory_order_relaxed)) {
    const std::int64_t late = timer.wait();
    Stamped s;
    while (receive(fd, s)) {
      if (s.frame.len != wc::can::kLength) {
        ++bad_frames;
        continue;
      }
      if (s.frame.can_id == wc::can::kVoltagesId && !s.own) {
        voltages = wc::can::unpack_voltages(s.frame.data);
        ++voltage_frames;
        if (!started) {
          started = true;
          std::fprintf(stderr, "wheelchair_sim: controller present, scenario starts (%zu periods)\n", periods);
        }
      }
      if (started) {
        if (frames.size() < frames.capacity()) {
          frames.push_back(s);
        } else {
          ++frames_lost;
        }
      }
    }
    if (!started) {
      if (wc::now_ns() > start_deadline) {
        std::fprintf(stderr, "wheelchair_sim: no motor-voltage frame (0x%03x) on %s within %.0f s\n",
                     wc::can::kVoltagesId, o.interface.c_str(), o.start_timeout_s);
        return 1;
      }
      if (!send(fd, wc::can::kEncoderId, wc::can::pack(wc::EncoderSpeeds{})) ||
          !send(fd, wc::can::kJoystickId, wc::can::pack(wc::JoystickPosition{}))) {
        ++send_failures;
      }
      continue;
    }
    if (rows.size() == periods) break;
    lateness.add(late);
    plant.step(voltages, dt);
    const wc::WheelSpeeds speeds = plant.output();
    const wc::JoystickPosition stick = scenario.scenario.position_at(speeds.time_s);
    if (!send(fd, wc::can::kEncoderId, wc::can::pack(wc::EncoderSpeeds{speeds.left_rad_s, speeds.right_rad_s})) ||
        !send(fd, wc::can::kJoystickId, wc::can::pack(stick))) {
      ++send_failures;
    }
    rows.push_back({speeds.time_s, stick, voltages, speeds, voltage_frames});
    voltage_frames = 0;
  }
  const double cpu_s = wc::process_cpu_s();
  ::close(fd);

  wc::SampleLog responses(64);
  step_responses(frames, o.response_v, responses);
  if (!o.trace_path.empty() && !write_trace(o.trace_path, rows)) {
    std::fprintf(stderr, "wheelchair_sim: cannot write %s: %s\n", o.trace_path.c_str(), std::strerror(errno));
    return 1;
  }
  if (!o.summary_path.empty()) {
    FILE* f = std::fopen(o.summary_path.c_str(), "w");
    if (f == nullptr) {
      std::fprintf(stderr, "wheelchair_sim: cannot write %s: %s\n", o.summary_path.c_str(), std::strerror(errno));
      return 1;
    }
    std::fprintf(f,
                 "{\"role\":\"sim\",\"period_ms\":%g,\"periods\":%zu,\"overruns\":%llu,\"lateness_ns\":%s,"
                 "\"cpu_s\":%.4f,\"step_to_motor_ns\":%s,\"frames_kept\":%zu,\"frames_lost\":%zu,"
                 "\"bad_frames\":%zu,\"send_failures\":%zu}\n",
                 o.period_ms, rows.size(), static_cast<unsigned long long>(timer.overruns()),
                 lateness.summary_json().c_str(), cpu_s, responses.summary_json().c_str(), frames.size(), frames_lost,
                 bad_frames, send_failures);
    std::fclose(f);
  }
  std::fprintf(stderr, "wheelchair_sim: %zu periods, %zu step responses\n", rows.size(), responses.count());
  return rows.size() == periods ? 0 : 1;
}
