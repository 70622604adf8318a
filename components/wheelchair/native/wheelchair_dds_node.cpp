// wheelchair_dds_node: one of the wheelchair's three components (Salov et al. 2013, section 3)
// as a Cyclone DDS program of its own, the benchmark's "native B" configuration: no polyport,
// types generated from config/types/wheelchair.idl by idlc, the math of steering.hpp.
//
//   wheelchair_dds_node --role joystick|control|hw|stick [--period-ms 10] [--if vcan0]
//                       [--summary FILE] [--domain 0]
//
// Roles and topics (every reader and writer reliable, keep_last 1, volatile):
//   hw        raw CAN socket on --if, kernel filters for 0x101 (joystick) and 0x181 (encoders);
//             each period drains it, publishes wheelchair/joystick and wheelchair/wheel_speeds,
//             takes the newest wheelchair/voltages and, once one has come, sends 0x201 with
//             the latest every period.
//   stick     no CAN: plays the IO board's side alone for runs on a host without CAN; each
//             period publishes wheelchair/joystick from the scripted stick (steering.hpp's
//             default scenario, from the first period) and the wheels at rest on
//             wheelchair/wheel_speeds (no plant: the loop is open; for latency runs).
//   joystick  each period: newest wheelchair/joystick -> joystick_to_reference ->
//             wheelchair/reference.
//   control   a listener takes wheelchair/reference as samples arrive (logging now minus their
//             source timestamp, CLOCK_REALTIME as Cyclone stamps); each period:
//             SpeedRatioController::step(latest reference, newest wheelchair/wheel_speeds)
//             -> wheelchair/voltages; zero voltages once at exit.
// Before the first sample of an input a role uses the type's zero value (stick centred, wheels
// at rest), as the in-process components do.
// Cyclone's configuration comes from CYCLONEDDS_URI. On stderr: one line
// "wheelchair_dds_node ROLE: running" once the entities exist. At exit (SIGINT/SIGTERM),
// --summary FILE gets one JSON object: role, period_ms, periods, overruns, lateness_ns (the
// wake lateness of every period), cpu_s; control adds joystick_to_control_ns; hw adds
// frames_rx (frames read from the socket), bad_frames (of those, the ones of a wrong length,
// dropped), frames_tx, rx_errors and tx_errors (failed socket calls).
// Exit status: 0 stopped by a signal; 1 setup failed or the summary could not be written
// (a line on stderr says why); 2 bad command line.
//
// Threads: the main thread runs the periodic loop (PeriodicTimer on CLOCK_MONOTONIC) and owns
// every entity, the CAN socket and the loop's logs. Cyclone's own threads receive; in the
// control role its listener runs on one of them, takes the references into a stack buffer,
// adds to the latency log (only that thread adds to it; the main thread reads it after the
// participant, and with it the listener, is deleted) and stores the latest reference under a
// mutex that the loop takes once a period. SIGINT/SIGTERM only set an atomic flag, which the
// loop checks at every wake, so it ends within one period.
// Memory: the sample logs reserve their capacity at start; samples are taken into caller-owned
// stack buffers (the types are flat doubles), so the loop does not allocate.
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
#include <mutex>
#include <string>

#include "can_frames.hpp"
#include "dds/dds.h"
#include "loop_stats.hpp"
#include "steering.hpp"
#include "wheelchair.h"

namespace {

namespace wc = polyport::wheelchair;

constexpr int kExitOk = 0;
constexpr int kExitFailed = 1;
constexpr int kExitUsage = 2;

constexpr const char* kJoystickTopic = "wheelchair/joystick";
constexpr const char* kReferenceTopic = "wheelchair/reference";
constexpr const char* kWheelSpeedsTopic = "wheelchair/wheel_speeds";
constexpr const char* kVoltagesTopic = "wheelchair/voltages";

// How many samples one take moves at most; with keep_last 1 a reader holds one at a time.
constexpr int kTakeBatch = 4;

std::atomic<bool> g_stop{false};
static_assert(std::atomic<bool>::is_always_lock_free);
extern "C" void on_stop_signal(int) { g_stop.store(true, std::memory_order_relaxed); }

void stop_on_signals() {
  struct sigaction action {};
  action.sa_handler = on_stop_signal;
  sigemptyset(&action.sa_mask);
  sigaction(SIGINT, &action, nullptr);
  sigaction(SIGTERM, &action, nullptr);
}

struct Options {
  std::string role;
  int period_ms = 10;
  std::string interface = "vcan0";
  std::string summary;
  std::uint32_t domain = 0;
};

// ---- DDS --------------------------------------------------------------------------------

// What polyport's DDS ports use by default for the wheelchair's topics: reliable (100 ms
// blocking, as polyport's writers), keep_last 1, volatile.
dds_qos_t* node_qos() {
  dds_qos_t* qos = dds_create_qos();
  dds_qset_reliability(qos, DDS_RELIABILITY_RELIABLE, DDS_MSECS(100));
  dds_qset_history(qos, DDS_HISTORY_KEEP_LAST, 1);
  dds_qset_durability(qos, DDS_DURABILITY_VOLATILE);
  return qos;
}

// The participant and what the roles create on it; a failure is printed once with the name
// of what could not be created and turns `ok` false.
class Dds {
 public:
  explicit Dds(std::uint32_t domain) : qos_(node_qos()) {
    participant_ = dds_create_participant(static_cast<dds_domainid_t>(domain), nullptr, nullptr);
    check(participant_, "participant");
  }
  ~Dds() {
    dds_delete_qos(qos_);
    if (participant_ > 0) dds_delete(participant_);
  }
  Dds(const Dds&) = delete;
  Dds& operator=(const Dds&) = delete;

  // Deletes the participant and every entity on it; a listener has returned when it returns.
  void close() {
    if (participant_ > 0) dds_delete(participant_);
    participant_ = 0;
  }

  dds_entity_t writer(const dds_topic_descriptor_t& type, const char* name) {
    if (!ok_) return 0;
    return check(dds_create_writer(participant_, topic(type, name), qos_, nullptr), name);
  }
  dds_entity_t reader(const dds_topic_descriptor_t& type, const char* name, const dds_listener_t* listener = nullptr) {
    if (!ok_) return 0;
    return check(dds_create_reader(participant_, topic(type, name), qos_, listener), name);
  }
  bool ok() const { return ok_; }

 private:
  dds_entity_t topic(const dds_topic_descriptor_t& type, const char* name) {
    return check(dds_create_topic(participant_, &type, name, nullptr, nullptr), name);
  }
  dds_entity_t check(dds_entity_t entity, const char* what) {
    if (entity < 0 && ok_) {
      std::fprintf(stderr, "wheelchair_dds_node: cannot create the DDS %s%s: %s\n",
                   participant_ > 0 ? "entities of topic " : "", what, dds_strretcode(entity));
      ok_ = false;
    }
    return entity;
  }

  dds_qos_t* qos_;
  dds_entity_t participant_ = 0;
  bool ok_ = true;
};

// Takes every sample the reader holds; `last` becomes the newest valid one. Returns whether
// there was one.
template <class T>
bool take_newest(dds_entity_t reader, T& last) noexcept {
  T samples[kTakeBatch];
  void* pointers[kTakeBatch];
  dds_sample_info_t infos[kTakeBatch];
  for (int i = 0; i < kTakeBatch; ++i) pointers[i] = &samples[i];
  bool got = false;
  for (;;) {
    const dds_return_t n = dds_take(reader, pointers, infos, kTakeBatch, kTakeBatch);
    if (n <= 0) break;
    for (dds_return_t i = 0; i < n; ++i) {
      if (infos[i].valid_data) {
        last = samples[i];
        got = true;
      }
    }
    if (n < kTakeBatch) break;
  }
  return got;
}

// ---- The periodic loop and the summary ---------------------------------------------------

struct LoopStats {
  wc::SampleLog lateness;
  std::uint64_t periods = 0;
  std::uint64_t overruns = 0;
};

// Runs `step` at every deadline until a stop signal; the signal is seen at the next wake.
template <class Step>
void run_periodic(int period_ms, LoopStats& stats, Step&& step) {
  wc::PeriodicTimer timer(static_cast<std::int64_t>(period_ms) * 1'000'000);
  while (!g_stop.load(std::memory_order_relaxed)) {
    stats.lateness.add(timer.wait());
    if (g_stop.load(std::memory_order_relaxed)) break;
    step();
    ++stats.periods;
  }
  stats.overruns = timer.overruns();
}

void announce(const Options& options) {
  std::fprintf(stderr, "wheelchair_dds_node %s: running\n", options.role.c_str());
  std::fflush(stderr);
}

// Writes {"role":..,"period_ms":..,"periods":..,"overruns":..,"lateness_ns":{..},"cpu_s":..
// plus `extra` (",\"key\":value..." or empty)}. No file named: nothing to do.
bool write_summary(const Options& options, const LoopStats& stats, const std::string& extra) {
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
    std::fprintf(stderr, "wheelchair_dds_node: cannot write the summary %s: %s\n", options.summary.c_str(),
                 std::strerror(errno));
    return false;
  }
  return true;
}

std::string counter(const char* name, std::uint64_t value) {
  return std::string(",\"") + name + "\":" + std::to_string(value);
}

// ---- Role: joystick ------------------------------------------------------------------------

int run_joystick(const Options& options) {
  Dds dds(options.domain);
  const dds_entity_t joystick_in = dds.reader(wheelchair_JoystickPosition_desc, kJoystickTopic);
  const dds_entity_t reference_out = dds.writer(wheelchair_Reference_desc, kReferenceTopic);
  if (!dds.ok()) return kExitFailed;
  announce(options);

  LoopStats stats;
  wheelchair_JoystickPosition stick{};  // centred until the first sample
  run_periodic(options.period_ms, stats, [&] {
    take_newest(joystick_in, stick);
    const wc::Reference reference = wc::joystick_to_reference(wc::JoystickPosition{stick.x, stick.y});
    const wheelchair_Reference sample{reference.direction_deg, reference.speed_mps};
    dds_write(reference_out, &sample);
  });
  dds.close();
  return write_summary(options, stats, "") ? kExitOk : kExitFailed;
}

// ---- Role: stick ---------------------------------------------------------------------------

int run_stick(const Options& options) {
  const wc::ScenarioParseResult scenario = wc::parse_scenario(wc::kDefaultScenario);
  Dds dds(options.domain);
  const dds_entity_t joystick_out = dds.writer(wheelchair_JoystickPosition_desc, kJoystickTopic);
  const dds_entity_t speeds_out = dds.writer(wheelchair_WheelSpeeds_desc, kWheelSpeedsTopic);
  if (!dds.ok() || !scenario.ok()) return kExitFailed;
  announce(options);

  LoopStats stats;
  run_periodic(options.period_ms, stats, [&] {
    const double t = static_cast<double>(stats.periods + 1) * options.period_ms / 1000.0;
    const wc::JoystickPosition p = scenario.scenario.position_at(t);
    const wheelchair_JoystickPosition stick{p.x, p.y};
    const wheelchair_WheelSpeeds still{0.0, 0.0, 0.0, 0.0, t};
    dds_write(joystick_out, &stick);
    dds_write(speeds_out, &still);
  });
  dds.close();
  return write_summary(options, stats, "") ? kExitOk : kExitFailed;
}

// ---- Role: control -------------------------------------------------------------------------

// Shared between the reference listener (Cyclone's thread) and the loop.
struct ControlInput {
  std::mutex mutex;
  wc::Reference latest;       // guarded by mutex
  wc::SampleLog latency_ns;   // the listener's only
};

void on_reference(dds_entity_t reader, void* arg) {
  auto* input = static_cast<ControlInput*>(arg);
  wheelchair_Reference samples[kTakeBatch];
  void* pointers[kTakeBatch];
  dds_sample_info_t infos[kTakeBatch];
  for (int i = 0; i < kTakeBatch; ++i) pointers[i] = &samples[i];
  for (;;) {
    const dds_return_t n = dds_take(reader, pointers, infos, kTakeBatch, kTakeBatch);
    if (n <= 0) return;
    const std::int64_t now = wc::now_ns(CLOCK_REALTIME);
    const wheelchair_Reference* newest = nullptr;
    for (dds_return_t i = 0; i < n; ++i) {
      if (!infos[i].valid_data) continue;
      input->latency_ns.add(now - infos[i].source_timestamp);
      newest = &samples[i];
    }
    if (newest != nullptr) {
      const std::lock_guard<std::mutex> lock(input->mutex);
      input->latest = wc::Reference{newest->direction_deg, newest->speed_mps};
    }
    if (n < kTakeBatch) return;
  }
}

int run_control(const Options& options) {
  ControlInput input;
  Dds dds(options.domain);
  dds_listener_t* listener = dds_create_listener(&input);
  dds_lset_data_available(listener, on_reference);
  dds.reader(wheelchair_Reference_desc, kReferenceTopic, listener);
  dds_delete_listener(listener);  // the reader keeps its own copy
  const dds_entity_t speeds_in = dds.reader(wheelchair_WheelSpeeds_desc, kWheelSpeedsTopic);
  const dds_entity_t voltages_out = dds.writer(wheelchair_MotorVoltages_desc, kVoltagesTopic);
  if (!dds.ok()) return kExitFailed;
  announce(options);

  LoopStats stats;
  wc::SpeedRatioController controller;
  const double period_s = options.period_ms / 1000.0;
  wheelchair_WheelSpeeds speeds{};  // at rest until the first sample
  run_periodic(options.period_ms, stats, [&] {
    wc::Reference reference;
    {
      const std::lock_guard<std::mutex> lock(input.mutex);
      reference = input.latest;
    }
    take_newest(speeds_in, speeds);
    const wc::MotorVoltages voltages = controller.step(
        reference,
        wc::WheelSpeeds{speeds.left_rad_s, speeds.right_rad_s, speeds.heading_deg, speeds.steering_deg, speeds.time_s},
        period_s);
    const wheelchair_MotorVoltages sample{voltages.left_v, voltages.right_v};
    dds_write(voltages_out, &sample);
  });
  // The motors stop when the controller does: zero voltages once, given a moment to arrive.
  const wheelchair_MotorVoltages zero{0.0, 0.0};
  dds_write(voltages_out, &zero);
  dds_wait_for_acks(voltages_out, DDS_MSECS(200));
  dds.close();
  return write_summary(options, stats, R"(,"joystick_to_control_ns":)" + input.latency_ns.summary_json())
             ? kExitOk
             : kExitFailed;
}

// ---- Role: hw ------------------------------------------------------------------------------

// A raw CAN socket bound to `interface`, non-blocking, receiving only the joystick and encoder
// frames (standard ids, no remote frames). -1 after printing why it could not be opened.
int open_can(const std::string& interface) {
  if (interface.empty() || interface.size() >= IFNAMSIZ) {
    std::fprintf(stderr, "wheelchair_dds_node: bad CAN interface name '%s'\n", interface.c_str());
    return -1;
  }
  const int fd = socket(PF_CAN, SOCK_RAW | SOCK_NONBLOCK | SOCK_CLOEXEC, CAN_RAW);
  if (fd < 0) {
    std::fprintf(stderr, "wheelchair_dds_node: cannot open a raw CAN socket: %s\n", std::strerror(errno));
    return -1;
  }
  const can_filter filters[2] = {
      {wc::can::kJoystickId, CAN_SFF_MASK | CAN_EFF_FLAG | CAN_RTR_FLAG},
      {wc::can::kEncoderId, CAN_SFF_MASK | CAN_EFF_FLAG | CAN_RTR_FLAG},
  };
  if (setsockopt(fd, SOL_CAN_RAW, CAN_RAW_FILTER, filters, sizeof filters) != 0) {
    std::fprintf(stderr, "wheelchair_dds_node: cannot set the CAN filters: %s\n", std::strerror(errno));
    close(fd);
    return -1;
  }
  const unsigned index = if_nametoindex(interface.c_str());
  if (index == 0) {
    std::fprintf(stderr, "wheelchair_dds_node: no network interface '%s': %s\n", interface.c_str(),
                 std::strerror(errno));
    close(fd);
    return -1;
  }
  sockaddr_can address{};
  address.can_family = AF_CAN;
  address.can_ifindex = static_cast<int>(index);
  if (bind(fd, reinterpret_cast<const sockaddr*>(&address), sizeof address) != 0) {
    std::fprintf(stderr, "wheelchair_dds_node: cannot bind to CAN interface '%s': %s\n", interface.c_str(),
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

int run_hw(const Options& options) {
  const int fd = open_can(options.interface);
  if (fd < 0) return kExitFailed;
  Dds dds(options.domain);
  const dds_entity_t joystick_out = dds.writer(wheelchair_JoystickPosition_desc, kJoystickTopic);
  const dds_entity_t speeds_out = dds.writer(wheelchair_WheelSpeeds_desc, kWheelSpeedsTopic);
  const dds_entity_t voltages_in = dds.reader(wheelchair_MotorVoltages_desc, kVoltagesTopic);
  if (!dds.ok()) {
    close(fd);
    return kExitFailed;
  }
  announce(options);

  LoopStats stats;
  CanCounters can;
  const wc::ChairGeometry geometry{};
  const std::int64_t start_ns = wc::now_ns();
  wc::JoystickPosition stick;      // centred until the first 0x101
  wc::EncoderSpeeds encoders;      // at rest until the first 0x181
  wheelchair_MotorVoltages voltages{};
  bool have_voltages = false;
  run_periodic(options.period_ms, stats, [&] {
    for (;;) {  // drain: everything the kernel queued since the last period
      can_frame frame{};
      const ssize_t n = recv(fd, &frame, sizeof frame, MSG_DONTWAIT);
      if (n < 0) {
        if (errno == EINTR) continue;
        if (errno != EAGAIN && errno != EWOULDBLOCK) ++can.rx_errors;
        break;
      }
      ++can.frames_rx;
      if (n != static_cast<ssize_t>(sizeof frame) || frame.can_dlc != wc::can::kLength) {
        ++can.bad_frames;
        continue;
      }
      if ((frame.can_id & CAN_SFF_MASK) == wc::can::kJoystickId) {
        stick = wc::can::unpack_joystick(frame.data);
      } else {
        encoders = wc::can::unpack_encoders(frame.data);
      }
    }
    const wheelchair_JoystickPosition joystick{stick.x, stick.y};
    dds_write(joystick_out, &joystick);
    const wheelchair_WheelSpeeds speeds{
        encoders.left_rad_s, encoders.right_rad_s,
        0.0,  // the heading is unknown to the HW node
        wc::realised_steering_deg(encoders.left_rad_s, encoders.right_rad_s, geometry),
        static_cast<double>(wc::now_ns() - start_ns) / 1e9};
    dds_write(speeds_out, &speeds);

    if (take_newest(voltages_in, voltages)) have_voltages = true;
    if (!have_voltages) return;
    can_frame out{};
    out.can_id = wc::can::kVoltagesId;
    out.can_dlc = wc::can::kLength;
    const wc::can::Payload payload = wc::can::pack(wc::MotorVoltages{voltages.left_v, voltages.right_v});
    std::memcpy(out.data, payload.data(), payload.size());
    if (write(fd, &out, sizeof out) == static_cast<ssize_t>(sizeof out)) {
      ++can.frames_tx;
    } else {
      ++can.tx_errors;
    }
  });
  dds.close();
  close(fd);
  const std::string extra = counter("frames_rx", can.frames_rx) + counter("frames_tx", can.frames_tx) +
                            counter("bad_frames", can.bad_frames) + counter("rx_errors", can.rx_errors) +
                            counter("tx_errors", can.tx_errors);
  return write_summary(options, stats, extra) ? kExitOk : kExitFailed;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"wheelchair_dds_node: the wheelchair's joystick, control or hw component (or a stick player) as a Cyclone DDS program "
               "(configuration from CYCLONEDDS_URI)"};
  app.footer("Exit codes:\n  0  stopped by SIGINT or SIGTERM\n  1  setup failed, or the summary could not be written\n"
             "  2  bad command line\n");
  Options options;
  app.add_option("--role", options.role, "the component this process runs")
      ->required()
      ->check(CLI::IsMember({"joystick", "control", "hw", "stick"}));
  app.add_option("--period-ms", options.period_ms, "the loop's period, milliseconds")
      ->capture_default_str()
      ->check(CLI::Range(1, 60000));
  app.add_option("--if", options.interface, "hw: the CAN interface")->capture_default_str();
  app.add_option("--summary", options.summary, "write the run's summary (JSON) to this file at exit");
  app.add_option("--domain", options.domain, "the DDS domain id")->capture_default_str()->check(CLI::Range(0, 232));
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    return code == 0 ? kExitOk : kExitUsage;
  }
  stop_on_signals();
  if (options.role == "joystick") return run_joystick(options);
  if (options.role == "control") return run_control(options);
  if (options.role == "stick") return run_stick(options);
  return run_hw(options);
}
