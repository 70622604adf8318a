// wheelchair_dds_node: one of the wheelchair's three components (Salov et al. 2013, section 3)
// as a Cyclone DDS program of its own, the benchmark's "native B" configuration: no polyport,
// types generated from config/types/wheelchair.idl by idlc, the math of steering.hpp.
//
//   wheelchair_dds_node --role joystick|control|hw|stick [--period-ms 10] [--phase-ms P]
//                       [--if vcan0] [--summary FILE] [--domain 0]
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
//             source timestamp, CLOCK_REALTIME as Cyclone stamps, read with polyport's clock as
//             polyportd reads it: from the TSC where clock_gettime is a system call, as in the
//             vcan guest, so that native B and polyportd measure the same hop alike); each period:
//             SpeedRatioController::step(latest reference, newest wheelchair/wheel_speeds)
//             -> wheelchair/voltages; zero voltages once at exit.
// Before the first sample of an input a role uses the type's zero value (stick centred, wheels
// at rest), as the in-process components do.
// Cyclone's configuration comes from CYCLONEDDS_URI. On stderr: one line
// "wheelchair_dds_node ROLE: running" once the entities exist. At exit (SIGINT/SIGTERM),
// --summary FILE gets one JSON object: role, period_ms, periods, overruns, lateness_ns (the
// wake lateness of every period), cpu_s; control adds joystick_to_control_ns and
// arrival_clock ("tsc" or "system": the clock of its arrival stamps) and with the TSC clock
// `clock` (wall_checks, wall_error_mean_ns / min / max: its wall time minus the kernel's over
// the run, polyport::ClockStats, as polyportd's statistics give its own); hw adds
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
#include <atomic>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <mutex>
#include <optional>
#include <string>

#include "dds/dds.h"
#include "node_common.hpp"
#include "polyport/base/clock.hpp"
#include "wheelchair.h"

namespace {

namespace wc = polyport::wheelchair;

using namespace polyport::wheelchair::node;

constexpr const char* kJoystickTopic = "wheelchair/joystick";
constexpr const char* kReferenceTopic = "wheelchair/reference";
constexpr const char* kWheelSpeedsTopic = "wheelchair/wheel_speeds";
constexpr const char* kVoltagesTopic = "wheelchair/voltages";

// How many samples one take moves at most; with keep_last 1 a reader holds one at a time.
constexpr int kTakeBatch = 4;

struct Options : NodeOptions {
  Options() { program = "wheelchair_dds_node"; }
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
  explicit Dds(int domain) : qos_(node_qos()) {
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

// ---- Role: joystick ------------------------------------------------------------------------

int run_joystick(const Options& options) {
  Dds dds(options.domain);
  const dds_entity_t joystick_in = dds.reader(wheelchair_JoystickPosition_desc, kJoystickTopic);
  const dds_entity_t reference_out = dds.writer(wheelchair_Reference_desc, kReferenceTopic);
  if (!dds.ok()) return kExitFailed;
  announce(options);

  LoopStats stats;
  wheelchair_JoystickPosition stick{};  // centred until the first sample
  run_periodic(options, stats, [&] {
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
  run_periodic(options, stats, [&] {
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
    const std::int64_t now = polyport::wall_now().ns;
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

// The arrival stamps' clock, and for the TSC clock how far its wall time was from the
// kernel's over the run (ClockStats::wall_checks), as polyportd's statistics give its own.
std::string arrival_clock_json(bool tsc) {
  std::string text = R"(,"arrival_clock":")" + std::string(tsc ? "tsc" : "system") + "\"";
  const polyport::ClockStats clock = polyport::clock_stats();
  if (!tsc || clock.wall_checks == 0) return text;
  char figures[192];
  std::snprintf(figures, sizeof figures,
                R"(,"clock":{"wall_checks":%llu,"wall_error_mean_ns":%.1f,"wall_error_min_ns":%lld,"wall_error_max_ns":%lld})",
                static_cast<unsigned long long>(clock.wall_checks), clock.wall_error_mean_ns,
                static_cast<long long>(clock.wall_error_min_ns), static_cast<long long>(clock.wall_error_max_ns));
  return text + figures;
}

int run_control(const Options& options) {
  // The arrival stamps' clock, chosen as polyportd chooses its own (--clock auto).
  const polyport::Result<polyport::ClockInfo> clock = polyport::use_clock(polyport::ClockChoice::automatic);
  const bool tsc = clock && clock.value().tsc;
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
  run_periodic(options, stats, [&] {
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
  return write_summary(options, stats,
                       R"(,"joystick_to_control_ns":)" + input.latency_ns.summary_json() +
                           arrival_clock_json(tsc))
             ? kExitOk
             : kExitFailed;
}

// ---- Role: hw ------------------------------------------------------------------------------

int run_hw(const Options& options) {
  HwBus bus(options);
  if (!bus.ok()) return kExitFailed;
  Dds dds(options.domain);
  const dds_entity_t joystick_out = dds.writer(wheelchair_JoystickPosition_desc, kJoystickTopic);
  const dds_entity_t speeds_out = dds.writer(wheelchair_WheelSpeeds_desc, kWheelSpeedsTopic);
  const dds_entity_t voltages_in = dds.reader(wheelchair_MotorVoltages_desc, kVoltagesTopic);
  if (!dds.ok()) return kExitFailed;
  announce(options);

  LoopStats stats;
  wheelchair_MotorVoltages voltages{};
  bool have_voltages = false;
  run_periodic(options, stats, [&] {
    bus.drain();
    const wheelchair_JoystickPosition joystick{bus.stick().x, bus.stick().y};
    dds_write(joystick_out, &joystick);
    const wc::WheelSpeeds s = bus.wheel_speeds();
    const wheelchair_WheelSpeeds speeds{s.left_rad_s, s.right_rad_s, s.heading_deg, s.steering_deg, s.time_s};
    dds_write(speeds_out, &speeds);
    if (take_newest(voltages_in, voltages)) have_voltages = true;
    if (have_voltages) bus.send(wc::MotorVoltages{voltages.left_v, voltages.right_v});
  });
  dds.close();
  return write_summary(options, stats, bus.summary_fields()) ? kExitOk : kExitFailed;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"wheelchair_dds_node: the wheelchair's joystick, control or hw component (or a stick player) as a Cyclone DDS program "
               "(configuration from CYCLONEDDS_URI)"};
  Options options;
  app.add_option("--role", options.role, "the component this process runs")
      ->required()
      ->check(CLI::IsMember({"joystick", "control", "hw", "stick"}));
  if (const std::optional<int> done = parse_node_options(app, options, argc, argv)) return *done;
  stop_on_signals();
  if (options.role == "joystick") return run_joystick(options);
  if (options.role == "control") return run_control(options);
  if (options.role == "stick") return run_stick(options);
  return run_hw(options);
}
