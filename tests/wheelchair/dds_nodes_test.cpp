// The wheelchair benchmark's native DDS nodes (components/wheelchair/native/
// wheelchair_dds_node) run as the benchmark runs them: the joystick and control roles as
// programs of their own on one Cyclone DDS domain (config/cyclonedds-loopback.xml), and this
// test in the place of the HW node, with the same idlc-generated types and QoS: it publishes
// the stick and the wheel speeds every 10 ms and reads what the nodes publish. Every wait
// polls with a deadline; the nodes' output stays in the test's folder when a case fails.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "../support/daemon_harness.hpp"
#include "dds/dds.h"
#include "watchdog_event.h"
#include "wheelchair.h"

namespace polyport::test {
namespace {

// Domains no other test uses, so that cases running beside these do not hear them.
constexpr dds_domainid_t kDomain = 170;
constexpr dds_domainid_t kMixedDomain = 171;
constexpr dds_domainid_t kFailSafeDomain = 172;
constexpr double kPi = 3.14159265358979323846;

// The nodes' QoS on every topic: reliable, keep_last 1, volatile.
dds_qos_t* node_qos() {
  dds_qos_t* qos = dds_create_qos();
  dds_qset_reliability(qos, DDS_RELIABILITY_RELIABLE, DDS_MSECS(100));
  dds_qset_history(qos, DDS_HISTORY_KEEP_LAST, 1);
  dds_qset_durability(qos, DDS_DURABILITY_VOLATILE);
  return qos;
}

// Every valid sample the reader holds, appended to `out`, with its source timestamp (the
// writer's CLOCK_REALTIME) appended to `stamps`.
template <class T>
void take_all(dds_entity_t reader, std::vector<T>& out, std::vector<dds_time_t>& stamps) {
  constexpr int kBatch = 8;
  T samples[kBatch];
  void* pointers[kBatch];
  dds_sample_info_t infos[kBatch];
  for (int i = 0; i < kBatch; ++i) pointers[i] = &samples[i];
  for (;;) {
    const dds_return_t n = dds_take(reader, pointers, infos, kBatch, kBatch);
    for (dds_return_t i = 0; i < n; ++i) {
      if (!infos[i].valid_data) continue;
      out.push_back(samples[i]);
      stamps.push_back(infos[i].source_timestamp);
    }
    if (n < kBatch) return;
  }
}

// polyport's watchdog events on the topic polyport/watchdog, read with idlc's types.
class AlarmReader {
 public:
  explicit AlarmReader(dds_domainid_t domain) {
    participant_ = dds_create_participant(domain, nullptr, nullptr);
    dds_qos_t* qos = dds_create_qos();
    dds_qset_reliability(qos, DDS_RELIABILITY_RELIABLE, DDS_MSECS(100));
    dds_qset_history(qos, DDS_HISTORY_KEEP_LAST, 16);
    const dds_entity_t topic =
        dds_create_topic(participant_, &polyport_WatchdogEvent_desc, "polyport/watchdog", nullptr, nullptr);
    reader_ = dds_create_reader(participant_, topic, qos, nullptr);
    dds_delete_qos(qos);
  }
  ~AlarmReader() {
    if (participant_ > 0) dds_delete(participant_);
  }
  AlarmReader(const AlarmReader&) = delete;
  AlarmReader& operator=(const AlarmReader&) = delete;
  bool ok() const { return participant_ > 0 && reader_ > 0; }
  // Every event that arrived so far.
  const std::vector<polyport_WatchdogEvent>& events() {
    std::vector<dds_time_t> stamps;
    take_all(reader_, events_, stamps);
    return events_;
  }

 private:
  dds_entity_t participant_ = 0;
  dds_entity_t reader_ = 0;
  std::vector<polyport_WatchdogEvent> events_;
};

// The HW node's side of the domain, played by the test.
class HwSide {
 public:
  explicit HwSide(dds_domainid_t domain) {
    participant_ = dds_create_participant(domain, nullptr, nullptr);
    dds_qos_t* qos = node_qos();
    const auto topic = [&](const dds_topic_descriptor_t& type, const char* name) {
      return dds_create_topic(participant_, &type, name, nullptr, nullptr);
    };
    joystick_ = dds_create_writer(participant_, topic(wheelchair_JoystickPosition_desc, "wheelchair/joystick"), qos,
                                  nullptr);
    speeds_ = dds_create_writer(participant_, topic(wheelchair_WheelSpeeds_desc, "wheelchair/wheel_speeds"), qos,
                                nullptr);
    reference_ = dds_create_reader(participant_, topic(wheelchair_Reference_desc, "wheelchair/reference"), qos,
                                   nullptr);
    voltages_ = dds_create_reader(participant_, topic(wheelchair_MotorVoltages_desc, "wheelchair/voltages"), qos,
                                  nullptr);
    dds_delete_qos(qos);
  }
  ~HwSide() {
    if (participant_ > 0) dds_delete(participant_);
  }
  HwSide(const HwSide&) = delete;
  HwSide& operator=(const HwSide&) = delete;

  bool ok() const { return participant_ > 0 && joystick_ > 0 && speeds_ > 0 && reference_ > 0 && voltages_ > 0; }

  // Publishes `stick` and `speeds` every 10 ms and collects what arrives until `done` holds
  // (true) or `limit` passes (false).
  bool drive_until(const wheelchair_JoystickPosition& stick, const wheelchair_WheelSpeeds& speeds,
                   const std::function<bool()>& done, std::chrono::milliseconds limit = 20s) {
    const auto deadline = std::chrono::steady_clock::now() + limit;
    for (;;) {
      dds_write(joystick_, &stick);
      dds_write(speeds_, &speeds);
      take_all(reference_, references, reference_stamps);
      take_all(voltages_, voltages, voltage_stamps);
      if (done()) return true;
      if (std::chrono::steady_clock::now() > deadline) return false;
      std::this_thread::sleep_for(10ms);
    }
  }

  // Forgets what arrived so far.
  void forget() {
    references.clear();
    reference_stamps.clear();
    voltages.clear();
    voltage_stamps.clear();
  }

  std::vector<wheelchair_Reference> references;
  std::vector<dds_time_t> reference_stamps;
  std::vector<wheelchair_MotorVoltages> voltages;
  std::vector<dds_time_t> voltage_stamps;

 private:
  dds_entity_t participant_ = 0;
  dds_entity_t joystick_ = 0;
  dds_entity_t speeds_ = 0;
  dds_entity_t reference_ = 0;
  dds_entity_t voltages_ = 0;
};

class WheelchairDdsNodes : public DaemonTest {
 public:
  WheelchairDdsNodes() : DaemonTest("polyport-wheelchair-dds") {}

  void SetUp() override {
    // The nodes and this test stay on loopback, with the configuration polyport ships.
    setenv("CYCLONEDDS_URI", "file://" POLYPORT_SOURCE_DIR "/config/cyclonedds-loopback.xml", 1);
    DaemonTest::SetUp();
  }

  fs::path summary_file(const std::string& role) const { return dir() / (role + ".json"); }

  // Starts a node of `role` and waits until it says it runs.
  std::unique_ptr<Child> node(const std::string& role, dds_domainid_t domain = kDomain) {
    auto child = peer(WHEELCHAIR_DDS_NODE, role,
                      {"--role", role, "--domain", std::to_string(domain), "--summary", summary_file(role).string()});
    const std::string line = "wheelchair_dds_node " + role + ": running";
    EXPECT_TRUE(eventually([&] { return child->errors().find(line) != std::string::npos || child->wait(0ms) != -1; }))
        << role << " neither ran nor ended:\n" << child->errors();
    EXPECT_NE(child->errors().find(line), std::string::npos) << role << " did not start:\n" << child->errors();
    return child;
  }

  // The node's summary, checked for what every role writes.
  Json summary(const std::string& role) {
    std::ifstream in(summary_file(role));
    Json j = Json::parse(in, nullptr, false);
    EXPECT_FALSE(j.is_discarded()) << "no JSON summary from " << role;
    if (j.is_discarded()) return Json::object();
    EXPECT_EQ(j.value("role", ""), role);
    EXPECT_EQ(j.value("period_ms", 0), 10);
    EXPECT_GT(j.value("periods", 0), 0) << j.dump();
    EXPECT_TRUE(j.contains("overruns")) << j.dump();
    EXPECT_GT(j.value("lateness_ns", Json::object()).value("count", 0), 0) << j.dump();
    EXPECT_GE(j.value("cpu_s", -1.0), 0.0) << j.dump();
    return j;
  }
};

bool near(double a, double b) { return std::abs(a - b) < 1e-9; }

// The wheels at about the straight-driving speed, and the stick 20 deg to the right.
const wheelchair_WheelSpeeds kRolling{5.0, 5.0, 0.0, 0.0, 0.0};
const wheelchair_JoystickPosition kRightTurn{0.6 * std::sin(20.0 * kPi / 180.0), 0.6 * std::cos(20.0 * kPi / 180.0)};

// Drives the chair through whatever runs the joystick and control components: straight
// ahead, then a right turn.
void expect_steering(HwSide& hw, const std::function<std::string()>& logs) {
  // Straight ahead at 60 % stick with the wheels at rest: the reference is (0 deg, 0.6 * 1.5
  // m/s) and both wheels get the same positive voltage.
  const wheelchair_WheelSpeeds at_rest{};
  const wheelchair_JoystickPosition straight{0.0, 0.6};
  const auto straight_reference = [&] {
    for (const auto& r : hw.references) {
      if (near(r.direction_deg, 0.0) && near(r.speed_mps, 0.6 * 1.5)) return true;
    }
    return false;
  };
  const auto driving = [&] {
    for (const auto& v : hw.voltages) {
      if (v.left_v > 0.0) return true;
    }
    return false;
  };
  ASSERT_TRUE(hw.drive_until(straight, at_rest, [&] { return straight_reference() && driving(); }))
      << "references: " << hw.references.size() << ", voltages: " << hw.voltages.size() << "\n" << logs();
  for (const auto& v : hw.voltages) {
    if (v.left_v == 0.0 && v.right_v == 0.0) continue;  // before the straight reference came
    EXPECT_GT(v.left_v, 0.0);
    EXPECT_GT(v.right_v, 0.0);
    EXPECT_DOUBLE_EQ(v.left_v, v.right_v);
  }

  // 20 deg to the right at the same stick deflection: the left (outer) wheel is driven harder.
  // The wheels now turn at about the straight-driving speed (0.9 m/s on 0.17 m wheels is
  // 5.3 rad/s): at rest, both wheels' errors would saturate both outputs at the supply voltage.
  hw.forget();
  const auto turning_reference = [&] {
    for (const auto& r : hw.references) {
      if (near(r.direction_deg, 20.0) && near(r.speed_mps, 0.6 * 1.5)) return true;
    }
    return false;
  };
  const auto turning = [&] {
    for (const auto& v : hw.voltages) {
      if (v.left_v > v.right_v) return true;
    }
    return false;
  };
  ASSERT_TRUE(hw.drive_until(kRightTurn, kRolling, [&] { return turning_reference() && turning(); }))
      << "references: " << hw.references.size() << ", voltages: " << hw.voltages.size()
      << (hw.voltages.empty() ? std::string()
                              : ", last: " + std::to_string(hw.voltages.back().left_v) + " / " +
                                    std::to_string(hw.voltages.back().right_v))
      << "\n" << logs();
}

TEST_F(WheelchairDdsNodes, JoystickAndControlSteerTheChair) {
  HwSide hw(kDomain);
  ASSERT_TRUE(hw.ok()) << "the test's own DDS entities could not be created";
  auto joystick = node("joystick");
  auto control = node("control");
  ASSERT_FALSE(HasFailure());
  expect_steering(hw, [&] { return "joystick:\n" + joystick->errors() + "control:\n" + control->errors(); });
  ASSERT_FALSE(HasFailure());

  // Control stops the motors when it ends: its last sample is zero voltages.
  hw.forget();
  control->signal(SIGTERM);
  EXPECT_TRUE(hw.drive_until(kRightTurn, kRolling, [&] {
    return !hw.voltages.empty() && hw.voltages.back().left_v == 0.0 && hw.voltages.back().right_v == 0.0;
  })) << "no zero voltages after control was stopped";
  EXPECT_EQ(control->wait(10s), 0) << control->errors();
  joystick->signal(SIGTERM);
  EXPECT_EQ(joystick->wait(10s), 0) << joystick->errors();

  summary("joystick");
  const Json control_summary = summary("control");
  ASSERT_TRUE(control_summary.contains("joystick_to_control_ns")) << control_summary.dump();
  EXPECT_GT(control_summary["joystick_to_control_ns"].value("count", 0), 0) << control_summary.dump();
}

// The benchmark's mixed configuration: Control in-process in polyportd, bridged by its Cyclone
// DDS model to the joystick node and to the HW side. The nodes' topics, types and QoS must be
// what a polyport DDS component of the same topics reads and writes.
TEST_F(WheelchairDdsNodes, ControlInPolyportdBetweenTheNodes) {
  if (std::string(POLYPORT_MIXED_MISSING) != "") GTEST_SKIP() << POLYPORT_MIXED_MISSING;
  HwSide hw(kMixedDomain);
  ASSERT_TRUE(hw.ok()) << "the test's own DDS entities could not be created";
  const fs::path app = fill_templates(POLYPORT_TEST_DATA "/wheelchair",
                                      {{"@DOMAIN@", std::to_string(kMixedDomain)}, {"@SRC@", POLYPORT_SOURCE_DIR}},
                                      "control_app.xml");
  auto polyportd = daemon(app);
  auto joystick = node("joystick", kMixedDomain);
  ASSERT_FALSE(HasFailure());
  expect_steering(hw, [&] { return "joystick:\n" + joystick->errors() + "polyportd:\n" + polyportd->errors(); });
  ASSERT_FALSE(HasFailure());

  const Json stats = stop(*polyportd);
  joystick->signal(SIGTERM);
  EXPECT_EQ(joystick->wait(10s), 0) << joystick->errors();
  summary("joystick");
  // Every sample polyport took from the nodes reached Control, and Control's reached DDS.
  ASSERT_TRUE(stats.contains("connections")) << stats.dump(2);
  for (const Json& link : stats["connections"]) {
    EXPECT_GT(link.value("received", 0), 0) << link.dump();
    EXPECT_EQ(link.value("dropped", -1), 0) << link.dump();
  }
}

// The wheelchair fails safe: the joystick node is killed while the daemon runs, and the
// motor command polyport sends to HW becomes zero within two periods (20 ms) of the last
// reference's deadline (fail_safe_app.xml: a 20 ms watchdog on Control.voltages -> HW with
// the joystick's reference upstream). Times are the DDS source timestamps of the joystick's
// last reference and of polyport's first zero command (both CLOCK_REALTIME on this host), so
// the test's own polling does not blur them. A new joystick node resumes driving.
TEST_F(WheelchairDdsNodes, MotorsStopWhenTheJoystickIsKilledAndDriveWhenItReturns) {
  if (std::string(POLYPORT_MIXED_MISSING) != "") GTEST_SKIP() << POLYPORT_MIXED_MISSING;
  constexpr dds_duration_t kDeadline = DDS_MSECS(20);
  constexpr dds_duration_t kTwoPeriods = DDS_MSECS(20);
  HwSide hw(kFailSafeDomain);
  AlarmReader alarms(kFailSafeDomain);
  ASSERT_TRUE(hw.ok() && alarms.ok()) << "the test's own DDS entities could not be created";
  const fs::path app = fill_templates(POLYPORT_TEST_DATA "/wheelchair",
                                      {{"@DOMAIN@", std::to_string(kFailSafeDomain)}, {"@SRC@", POLYPORT_SOURCE_DIR}},
                                      "fail_safe_app.xml");
  auto polyportd = daemon(app);
  auto joystick = node("joystick", kFailSafeDomain);
  ASSERT_FALSE(HasFailure());
  const auto logs = [&] { return "joystick:\n" + joystick->errors() + "polyportd:\n" + polyportd->errors(); };
  const wheelchair_WheelSpeeds at_rest{};
  const wheelchair_JoystickPosition straight{0.0, 0.6};
  const auto driving = [&] { return !hw.voltages.empty() && hw.voltages.back().left_v > 0.0; };
  ASSERT_TRUE(hw.drive_until(straight, at_rest, driving)) << "the chair never drove\n" << logs();

  const dds_time_t killed = dds_time();
  joystick->signal(SIGKILL);
  EXPECT_NE(joystick->wait(10s), 0);
  const auto stopped = [&] {
    for (std::size_t i = 0; i < hw.voltages.size(); ++i) {
      if (hw.voltage_stamps[i] > killed && hw.voltages[i].left_v == 0.0 && hw.voltages[i].right_v == 0.0) return true;
    }
    return false;
  };
  ASSERT_TRUE(hw.drive_until(straight, at_rest, stopped, 5s)) << "no zero command after the kill\n" << logs();
  // The joystick's last reference: the newest one sent before it was killed.
  ASSERT_FALSE(hw.reference_stamps.empty()) << "no reference arrived between the drive and the kill";
  const dds_time_t last_reference = *std::max_element(hw.reference_stamps.begin(), hw.reference_stamps.end());
  EXPECT_LE(last_reference, killed);
  const dds_time_t deadline = last_reference + kDeadline;
  std::size_t first_zero = 0;
  while (!(hw.voltage_stamps[first_zero] > killed && hw.voltages[first_zero].left_v == 0.0)) ++first_zero;
  for (std::size_t i = 0; i < first_zero; ++i) {
    // Between the kill and then, Control's own command went through (driving straight on).
    if (hw.voltage_stamps[i] > killed) {
      EXPECT_GT(hw.voltages[i].left_v, 0.0) << "sample " << i;
    }
  }
  const dds_time_t zero_at = hw.voltage_stamps[first_zero];
  EXPECT_GE(zero_at, deadline - DDS_MSECS(1)) << "the motors stopped before the deadline passed";
  EXPECT_LE(zero_at - deadline, kTwoPeriods)
      << "zero command " << (zero_at - deadline) / 1e6 << " ms after the last reference's deadline";
  std::printf("fail-safe: zero command %.3f ms after the last reference's deadline (%.3f ms after it)\n",
              static_cast<double>(zero_at - deadline) / 1e6, static_cast<double>(zero_at - last_reference) / 1e6);

  // The trip, as a DDS application hears of it. A busy machine may have tripped it before (Control
  // itself late by a deadline, then recovered), and that event may be the only one in yet: wait
  // for the trip that names the joystick's reference.
  const auto reference_trip = [&]() -> std::optional<polyport_WatchdogEvent> {
    const auto events = alarms.events();
    for (auto it = events.rbegin(); it != events.rend(); ++it) {
      if (it->kind == polyport_WATCHDOG_TRIPPED && std::string_view(it->silent_port) == "Nodes.reference") return *it;
    }
    return std::nullopt;
  };
  ASSERT_TRUE(eventually([&] { return reference_trip().has_value(); }))
      << "no watchdog event naming Nodes.reference on polyport/watchdog; events: " << alarms.events().size();
  const polyport_WatchdogEvent tripped = *reference_trip();
  EXPECT_EQ(tripped.kind, polyport_WATCHDOG_TRIPPED);
  EXPECT_GE(tripped.trips, 1U);
  EXPECT_EQ(tripped.recoveries, tripped.trips - 1);
  EXPECT_STREQ(tripped.connection, "Control.voltages -> Nodes.voltages");
  EXPECT_STREQ(tripped.silent_port, "Nodes.reference");
  EXPECT_GT(tripped.silent_ns, kDeadline);

  // The joystick returns: driving resumes.
  hw.forget();
  auto joystick_again = node("joystick", kFailSafeDomain);
  ASSERT_FALSE(HasFailure());
  // Five driving commands in a row: the watchdog thread, which looks every 5 ms while tripped,
  // has seen the recovery by then.
  const auto driving_again = [&] {
    if (hw.voltages.size() < 5) return false;
    return std::all_of(hw.voltages.end() - 5, hw.voltages.end(), [](const auto& v) { return v.left_v > 0.0; });
  };
  EXPECT_TRUE(hw.drive_until(straight, at_rest, driving_again)) << "driving did not resume\n" << logs();

  ASSERT_TRUE(eventually([&] { return alarms.events().back().kind == polyport_WATCHDOG_RECOVERED; }))
      << "no recovery event on polyport/watchdog";
  EXPECT_EQ(alarms.events().back().recoveries, alarms.events().back().trips);
  EXPECT_GE(alarms.events().back().recoveries, tripped.trips);
  EXPECT_STREQ(alarms.events().back().silent_port, "");

  const Json stats = stop(*polyportd);
  joystick_again->signal(SIGTERM);
  EXPECT_EQ(joystick_again->wait(10s), 0) << joystick_again->errors();
  ASSERT_TRUE(stats.contains("connections")) << stats.dump(2);
  bool found = false;
  for (const Json& link : stats["connections"]) {
    if (link.value("source", "") == "watchdogs.Control.voltages -> Nodes.voltages") {
      EXPECT_EQ(link.value("target", ""), "Alarms.events") << link.dump();
      EXPECT_EQ(link.value("delivered", 0), alarms.events().size()) << link.dump();
    }
    if (!link.contains("watchdog")) continue;
    found = true;
    const Json& w = link["watchdog"];
    EXPECT_EQ(link.value("target", ""), "Nodes.voltages") << link.dump();
    EXPECT_EQ(w.value("upstream", ""), "Nodes.reference") << w.dump();
    EXPECT_EQ(w.value("deadline_ns", 0), 20'000'000) << w.dump();
    EXPECT_GE(w.value("trips", 0), 1) << w.dump();
    EXPECT_EQ(w.value("recoveries", -1), w.value("trips", 0)) << w.dump();  // it ended driving
    EXPECT_EQ(w.value("state", ""), "ok") << w.dump();
    EXPECT_GE(w.value("safe_values", 0), 1) << w.dump();
  }
  EXPECT_TRUE(found) << stats.dump(2);
  EXPECT_NE(polyportd->errors().find("watchdog Control.voltages -> Nodes.voltages: tripped, Nodes.reference silent"),
            std::string::npos)
      << polyportd->errors();
}

TEST_F(WheelchairDdsNodes, BadCommandLineIsRefused) {
  for (const std::vector<std::string>& args :
       {std::vector<std::string>{"--role", "steering"}, std::vector<std::string>{"--period-ms", "10"},
        std::vector<std::string>{"--role", "control", "--period-ms", "0"},
        std::vector<std::string>{"--role", "control", "--domain", "233"}}) {
    auto child = peer(WHEELCHAIR_DDS_NODE, "bad", args);
    EXPECT_EQ(child->wait(10s), 2) << "arguments: " << Json(args).dump() << "\n" << child->errors();
    EXPECT_FALSE(child->errors().empty()) << Json(args).dump();
  }
}

// Without its CAN interface the HW node does not start, and says why (here either the kernel
// has no CAN at all or there is no such interface).
TEST_F(WheelchairDdsNodes, HwWithoutItsInterfaceSaysWhy) {
  auto child = peer(WHEELCHAIR_DDS_NODE, "hw",
                    {"--role", "hw", "--if", "nosuchcan9", "--domain", std::to_string(kDomain)});
  EXPECT_EQ(child->wait(10s), 1) << child->errors();
  const std::string errors = child->errors();
  EXPECT_TRUE(errors.find("cannot open a raw CAN socket") != std::string::npos ||
              errors.find("no network interface 'nosuchcan9'") != std::string::npos)
      << errors;
  EXPECT_EQ(errors.find("running"), std::string::npos) << errors;
}

// The Fast DDS HW program (wheelchair_fastdds_hw) shares the nodes' command line and CAN side
// (node_common.hpp): the same refusals, in its own name.
TEST_F(WheelchairDdsNodes, FastddsHwRefusesABadCommandLineAndSaysWhyWithoutItsInterface) {
#ifndef WHEELCHAIR_FASTDDS_HW
  GTEST_SKIP() << "wheelchair_fastdds_hw is not built (no Fast DDS packages or fastddsgen)";
#else
  for (const std::vector<std::string>& args :
       {std::vector<std::string>{"--period-ms", "0"}, std::vector<std::string>{"--domain", "233"},
        std::vector<std::string>{"--role", "hw"}}) {
    auto child = peer(WHEELCHAIR_FASTDDS_HW, "bad", args);
    EXPECT_EQ(child->wait(10s), 2) << "arguments: " << Json(args).dump() << "\n" << child->errors();
    EXPECT_FALSE(child->errors().empty()) << Json(args).dump();
  }
  auto child = peer(WHEELCHAIR_FASTDDS_HW, "hw", {"--if", "nosuchcan9", "--domain", std::to_string(kDomain)});
  EXPECT_EQ(child->wait(10s), 1) << child->errors();
  const std::string errors = child->errors();
  EXPECT_TRUE(errors.find("wheelchair_fastdds_hw: cannot open a raw CAN socket") != std::string::npos ||
              errors.find("wheelchair_fastdds_hw: no network interface 'nosuchcan9'") != std::string::npos)
      << errors;
  EXPECT_EQ(errors.find("running"), std::string::npos) << errors;
#endif
}

}  // namespace
}  // namespace polyport::test
