// The SocketCAN model when the bus misbehaves, in the engine, in one process, against
// can-utils and iproute2 on real kernel vcan interfaces (label vm: each case in a guest of
// its own with vcan0 and vcan1, which the case may delete and re-create):
//  - an interface missing at start, or deleted and re-added while the engine runs: reported
//    (describe() counters, a log line, an event on the bus event port) and picked up again,
//    also by the kernel's link notifications alone (the model's own check an hour apart);
//  - error frames (cansend with CAN_ERR_FLAG in the id): decoded, counted per kind and
//    class, logged, and delivered as polyport::CanBusEvent samples;
//  - periodic messages through the broadcast manager: the interval between the frames
//    candump sees, and the payload following new samples.
//
// Every wait polls a condition until a deadline; nothing sleeps a fixed time, nothing
// measures latency.
#include <gtest/gtest.h>
#include <spdlog/sinks/ringbuffer_sink.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "../support/eventually.hpp"
#include "socketcan_adaptor.hpp"
#include "socketcan_fixture.hpp"

namespace polyport {
namespace {

using socketcan::CanBusEventKind;
using socketcan::CanBusEventSample;
using socketcan::CanBusState;
using test::CanPeer;
using test::cansend;
using test::Clock;
using test::eventually;
using test::kDeadline;
using test::run_command;

// EngineData (0x100): see socketcan_test.cpp.
constexpr const char* kEngineFrame = "100#A00F78C8307D0100";

// The log lines of the model, kept in memory for the test to read.
class SocketCanRobustTest : public test::SocketCanFixture {
 protected:
  explicit SocketCanRobustTest(std::chrono::milliseconds check = socketcan::CanReactor::kTickInterval,
                               ReactorIo io = ReactorIo::automatic)
      : SocketCanFixture(io, check) {
    sink_ = std::make_shared<spdlog::sinks::ringbuffer_sink_mt>(256);
    previous_ = spdlog::default_logger();
    spdlog::set_default_logger(std::make_shared<spdlog::logger>("test", sink_));
  }
  ~SocketCanRobustTest() override {
    engine.stop();
    spdlog::set_default_logger(previous_);
  }

  std::string log() const {
    std::string text;
    for (const auto& line : sink_->last_formatted()) text += line;
    return text;
  }
  bool logged(const std::string& part) const { return log().find(part) != std::string::npos; }

  // The next bus event, waited for until the deadline.
  static bool next_event(DataInPort& probe, CanBusEventSample& event) {
    return eventually([&] { return probe.read(&event, sizeof event) == Status::ok; }, kDeadline);
  }
  // The next bus event past an interface_down: `ip link del` of an interface that is up first
  // sets it down, and the kernel announces that before the deletion, so the model may report
  // both (on the notification between them) or the loss alone.
  static bool next_event_past_down(DataInPort& probe, CanBusEventSample& event) {
    if (!next_event(probe, event)) return false;
    if (event.kind == static_cast<int>(CanBusEventKind::interface_down)) return next_event(probe, event);
    return true;
  }
  // After a command on bus0's interface (`failed`: its output, empty when it worked): the
  // model counts the change (bus0's `counter` reaches 1) and reports it on `events` as `kind`
  // (past an interface_down first, with `past_down`: see next_event_past_down).
  void expect_found(const std::string& failed, const char* counter, CanBusEventKind kind, DataInPort& events,
                    bool past_down = false) {
    ASSERT_EQ(failed, "");
    ASSERT_TRUE(eventually([&] { return socket_counters("bus0")[counter] == 1; }, kDeadline))
        << socket_counters("bus0").dump(2);
    CanBusEventSample event;
    ASSERT_TRUE(past_down ? next_event_past_down(events, event) : next_event(events, event))
        << "no event once " << counter << " was counted";
    EXPECT_EQ(event.kind, static_cast<int>(kind));
  }

  std::shared_ptr<spdlog::sinks::ringbuffer_sink_mt> sink_;
  std::shared_ptr<spdlog::logger> previous_;
};

std::string add_vcan(const std::string& name) {
  if (std::string failed = run_command({"ip", "link", "add", "dev", name, "type", "vcan"}); !failed.empty()) return failed;
  return run_command({"ip", "link", "set", name, "up"});
}

TEST_F(SocketCanRobustTest, AMissingInterfaceIsReportedAndPickedUpWhenItAppears) {
  ASSERT_TRUE(build("missing_interface_app.xml")) << problems();
  DataInPort* engine_probe = probe("lost.engine");
  DataInPort* events = probe("lost.bus");
  ASSERT_TRUE(engine_probe && events);
  start();  // the start succeeds without vcan7

  EXPECT_TRUE(logged("lost: CAN interface 'vcan7' does not exist; the component runs without it")) << log();
  EXPECT_EQ(socket_counters("lost")["link"], "missing");
  CanBusEventSample event;
  ASSERT_TRUE(next_event(*events, event)) << "no event for the missing interface";
  EXPECT_EQ(event.kind, static_cast<int>(CanBusEventKind::interface_missing));
  EXPECT_EQ(event.state, static_cast<int>(CanBusState::missing));

  ASSERT_EQ(add_vcan("vcan7"), "");
  ASSERT_TRUE(eventually([&] { return socket_counters("lost")["link"] == "up"; }, kDeadline))
      << socket_counters("lost").dump(2);
  ASSERT_TRUE(next_event(*events, event)) << "no event for the interface's arrival";
  EXPECT_EQ(event.kind, static_cast<int>(CanBusEventKind::interface_back));
  // add_vcan adds the interface, then sets it up: the kernel announces both, and the model
  // may look while it is still down (back, down; then up) or only once it is up.
  if (event.state == static_cast<int>(CanBusState::down)) {
    ASSERT_TRUE(next_event(*events, event)) << "no event for the interface going up";
    EXPECT_EQ(event.kind, static_cast<int>(CanBusEventKind::interface_up));
  }
  EXPECT_EQ(event.state, static_cast<int>(CanBusState::active));
  EXPECT_TRUE(logged("lost: CAN interface 'vcan7' is back")) << log();

  ASSERT_EQ(cansend("vcan7", kEngineFrame), "");
  std::vector<double> values(6);
  ASSERT_TRUE(next_sample(*engine_probe, values)) << "no EngineData from vcan7 within 5 s";
  EXPECT_DOUBLE_EQ(values[0], 1000.0);
}

// `ip link del` unbinds the socket (and the interface that comes back has a new index):
// the model re-creates the socket, binds it and sets its filters again.
TEST_F(SocketCanRobustTest, DeletingAndReAddingTheInterfaceIsSurvivedAndReported) {
  ASSERT_TRUE(build("events_app.xml")) << problems();
  DataInPort* engine_probe = probe("bus0.engine");
  DataInPort* events = probe("bus0.bus");
  ASSERT_TRUE(engine_probe && events);
  start();
  std::vector<double> values(6);
  ASSERT_EQ(cansend("vcan0", kEngineFrame), "");
  ASSERT_TRUE(next_sample(*engine_probe, values)) << "no EngineData within 5 s";
  const int first_index = socket_counters("bus0")["ifindex"];

  ASSERT_NO_FATAL_FAILURE(expect_found(run_command({"ip", "link", "del", "vcan0"}), "losses",
                                       CanBusEventKind::interface_missing, *events, true));
  EXPECT_EQ(socket_counters("bus0")["link"], "missing");
  EXPECT_TRUE(logged("bus0: CAN interface 'vcan0' went away")) << log();

  ASSERT_NO_FATAL_FAILURE(
      expect_found(add_vcan("vcan0"), "recoveries", CanBusEventKind::interface_back, *events));
  // Added, then set up: the model may have found it back while still down.
  ASSERT_TRUE(eventually([&] { return socket_counters("bus0")["link"] == "up"; }, kDeadline))
      << socket_counters("bus0").dump(2);
  EXPECT_NE(socket_counters("bus0")["ifindex"], first_index) << "the new vcan0 is another interface";
  EXPECT_TRUE(logged("bus0: CAN interface 'vcan0' is back")) << log();

  // Frames flow again, through the filters set again: an id the component does not take,
  // sent first, never arrives.
  ASSERT_EQ(cansend("vcan0", "123#1122334455667788"), "");
  ASSERT_EQ(cansend("vcan0", "100#A00F78C8307D0200"), "");
  ASSERT_TRUE(next_sample(*engine_probe, values)) << "no EngineData after vcan0 came back";
  EXPECT_DOUBLE_EQ(values[5], 0.0) << "EngineRunning of the frame sent after the return";
  EXPECT_EQ(socket_counters("bus0")["unknown_id"], 0);
  EXPECT_EQ(port_counters("bus0", "engine")["received"], 2);
}

TEST_F(SocketCanRobustTest, SettingTheInterfaceDownAndUpIsReported) {
  ASSERT_TRUE(build("events_app.xml")) << problems();
  DataInPort* events = probe("bus0.bus");
  ASSERT_TRUE(events);
  start();
  ASSERT_NO_FATAL_FAILURE(expect_found(run_command({"ip", "link", "set", "vcan0", "down"}), "went_down",
                                       CanBusEventKind::interface_down, *events));
  EXPECT_EQ(socket_counters("bus0")["link"], "down");
  ASSERT_NO_FATAL_FAILURE(expect_found(run_command({"ip", "link", "set", "vcan0", "up"}), "came_up",
                                       CanBusEventKind::interface_up, *events));
  EXPECT_TRUE(logged("bus0: CAN interface 'vcan0' is down")) << log();
}

// The model's own look-up of the interfaces an hour apart: within the test's deadline only the
// kernel's link notifications (CanReactor::watch_links) can run the supervision.
// Both ways of waiting (the notifications' socket is a plain descriptor on the epoll set or a
// one-shot poll on the ring).
class SocketCanLinkNotificationTest : public SocketCanRobustTest, public ::testing::WithParamInterface<ReactorIo> {
 protected:
  SocketCanLinkNotificationTest() : SocketCanRobustTest(std::chrono::hours(1), GetParam()) {}
};

TEST_P(SocketCanLinkNotificationTest, DownUpDeletedAndReAddedAreFoundByTheKernelsNotifications) {
  ASSERT_TRUE(build("events_app.xml")) << problems();
  DataInPort* engine_probe = probe("bus0.engine");
  DataInPort* events = probe("bus0.bus");
  ASSERT_TRUE(engine_probe && events);
  start();
  const nlohmann::json at_start = socket_counters("bus0");
  ASSERT_TRUE(at_start["link_notifications"].is_number())
      << "the kernel gives no link notifications here: " << at_start.dump(2) << "\n" << log();
  const auto notifications = [&] { return socket_counters("bus0")["link_notifications"].get<std::uint64_t>(); };
  const std::uint64_t before = notifications();

  ASSERT_NO_FATAL_FAILURE(expect_found(run_command({"ip", "link", "set", "vcan0", "down"}), "went_down",
                                       CanBusEventKind::interface_down, *events));
  ASSERT_NO_FATAL_FAILURE(expect_found(run_command({"ip", "link", "set", "vcan0", "up"}), "came_up",
                                       CanBusEventKind::interface_up, *events));
  ASSERT_NO_FATAL_FAILURE(expect_found(run_command({"ip", "link", "del", "vcan0"}), "losses",
                                       CanBusEventKind::interface_missing, *events, true));
  ASSERT_NO_FATAL_FAILURE(
      expect_found(add_vcan("vcan0"), "recoveries", CanBusEventKind::interface_back, *events));
  // Each of the four steps was found through at least one notification of its own (each
  // waited for before the next).
  EXPECT_GE(notifications(), before + 4);
  EXPECT_TRUE(logged("bus0: CAN interface 'vcan0' is back")) << log();

  ASSERT_TRUE(eventually([&] { return socket_counters("bus0")["link"] == "up"; }, kDeadline))
      << socket_counters("bus0").dump(2);
  EXPECT_EQ(socket_counters("bus0")["io"], to_string(GetParam())) << socket_counters("bus0").dump(2);

  ASSERT_EQ(cansend("vcan0", kEngineFrame), "");
  std::vector<double> values(6);
  ASSERT_TRUE(next_sample(*engine_probe, values)) << "no EngineData after vcan0 came back";
  EXPECT_DOUBLE_EQ(values[0], 1000.0);
}
POLYPORT_BOTH_CAN_WAITS(SocketCanLinkNotificationTest);

// Error frames as a controller driver sends them; vcan delivers a frame with CAN_ERR_FLAG
// (cansend's 8-digit id 2xxxxxxx) to sockets with CAN_RAW_ERR_FILTER like any other.
TEST_F(SocketCanRobustTest, ErrorFramesAreCountedLoggedAndDeliveredAsEvents) {
  ASSERT_TRUE(build("events_app.xml")) << problems();
  DataInPort* events = probe("bus0.bus");
  ASSERT_TRUE(events);
  start();

  struct Case {
    const char* frame;
    CanBusEventKind kind;
    CanBusState state;
    std::uint32_t error_class;
    int tx_errors;
  };
  const Case cases[] = {
      // CAN_ERR_CRTL, data[1] CAN_ERR_CRTL_TX_WARNING, data[6] = 96 transmit errors
      {"20000004#0008000000006000", CanBusEventKind::error_warning, CanBusState::warning, 0x4, 96},
      // CAN_ERR_CRTL, data[1] CAN_ERR_CRTL_TX_PASSIVE, 128 transmit errors
      {"20000004#0020000000008000", CanBusEventKind::error_passive, CanBusState::passive, 0x4, 128},
      // CAN_ERR_BUSOFF
      {"20000040#0000000000000000", CanBusEventKind::bus_off, CanBusState::bus_off, 0x40, 0},
      // CAN_ERR_RESTARTED
      {"20000100#0000000000000000", CanBusEventKind::restarted, CanBusState::active, 0x100, 0},
      // CAN_ERR_PROT | CAN_ERR_BUSERROR, data[2] CAN_ERR_PROT_FORM: another kind
      {"20000088#0000020000000000", CanBusEventKind::error_frame, CanBusState::active, 0x88, 0},
  };
  for (const Case& c : cases) {
    ASSERT_EQ(cansend("vcan0", c.frame), "");
    CanBusEventSample event;
    ASSERT_TRUE(next_event(*events, event)) << "no event for " << c.frame;
    EXPECT_EQ(event.kind, static_cast<int>(c.kind)) << c.frame;
    EXPECT_EQ(event.state, static_cast<int>(c.state)) << c.frame;
    EXPECT_EQ(event.error_class, c.error_class) << c.frame;
    EXPECT_EQ(event.tx_errors, c.tx_errors) << c.frame;
    if (c.kind == CanBusEventKind::bus_off) {
      EXPECT_TRUE(eventually([&] { return logged("bus0: CAN interface 'vcan0': bus-off: the controller sends"); },
                             kDeadline))
          << log();
    }
  }
  CanBusEventSample extra;
  EXPECT_EQ(events->read(&extra, sizeof extra), Status::no_data) << "one event per error frame";

  const nlohmann::json socket = socket_counters("bus0");
  const nlohmann::json& bus = socket["bus"];
  EXPECT_EQ(bus["error_frames"], 5) << socket.dump(2);
  EXPECT_EQ(bus["state"], "error-active");
  EXPECT_EQ(bus["kinds"]["error_warning"], 1);
  EXPECT_EQ(bus["kinds"]["error_passive"], 1);
  EXPECT_EQ(bus["kinds"]["bus_off"], 1);
  EXPECT_EQ(bus["kinds"]["restarted"], 1);
  EXPECT_EQ(bus["kinds"]["other"], 1);
  EXPECT_EQ(bus["classes"]["controller"], 2);
  EXPECT_EQ(bus["classes"]["bus_off"], 1);
  EXPECT_EQ(bus["classes"]["restarted"], 1);
  EXPECT_EQ(bus["classes"]["protocol"], 1);
  EXPECT_EQ(bus["classes"]["bus_error"], 1);
  EXPECT_EQ(socket["events"], 5);
  EXPECT_EQ(socket["unknown_id"], 0) << "error frames are no data frames of another id";
  EXPECT_EQ(port_counters("bus0", "engine")["received"], 0);
  EXPECT_TRUE(eventually([&] { return logged("bus0: CAN interface 'vcan0': bus state error-active"); }, kDeadline))
      << log();
}

// One line of `candump -L`: "(1700000000.123456) vcan1 1A0#04D23E80008500AA".
struct DumpLine {
  double time = 0;
  std::string frame;
};

std::vector<DumpLine> parse_candump(const std::string& output) {
  std::vector<DumpLine> lines;
  std::istringstream in(output);
  std::string line;
  while (std::getline(in, line)) {
    double time = 0;
    char interface[32];
    char frame[160];
    if (std::sscanf(line.c_str(), "(%lf) %31s %159s", &time, interface, frame) == 3) lines.push_back({time, frame});
  }
  return lines;
}

// The median of the intervals between consecutive lines, in ms.
double median_interval_ms(const std::vector<DumpLine>& lines) {
  std::vector<double> intervals;
  for (std::size_t i = 1; i < lines.size(); ++i) intervals.push_back((lines[i].time - lines[i - 1].time) * 1e3);
  std::sort(intervals.begin(), intervals.end());
  return intervals.empty() ? 0.0 : intervals[intervals.size() / 2];
}

// `count` frames of vcan1 as candump -L prints them.
std::vector<DumpLine> dump_frames(int count, std::string& output) {
  CanPeer candump({"candump", "-L", "-n", std::to_string(count), "vcan1"});
  EXPECT_EQ(candump.error(), "");
  const auto status = candump.finish(Clock::now() + std::chrono::seconds(10));
  output = candump.output();
  EXPECT_TRUE(status.has_value()) << "candump saw fewer than " << count << " frames in 10 s: " << output;
  return parse_candump(output);
}

// The tolerance: the median interval between the frames candump stamps is within half and
// twice the cycle. The guest is slow and single-CPU; the median ignores single late frames.
void expect_cycle(const std::vector<DumpLine>& lines, double cycle_ms, const std::string& output) {
  ASSERT_GE(lines.size(), 10u) << output;
  const double median = median_interval_ms(lines);
  std::printf("median interval %.2f ms over %zu frames for a %g ms cycle\n", median, lines.size(), cycle_ms);
  EXPECT_GE(median, cycle_ms / 2) << "median interval " << median << " ms for a " << cycle_ms << " ms cycle:\n" << output;
  EXPECT_LE(median, cycle_ms * 2) << "median interval " << median << " ms for a " << cycle_ms << " ms cycle:\n" << output;
}

// BrakeStatus: <cycle_ms>50</cycle_ms> in the profile (the DBC says 20). One frame on
// vcan0 starts the broadcast manager's task on vcan1; a second frame replaces its data.
TEST_F(SocketCanRobustTest, AProfileCycleTimeSendsTheLastSampleEveryCycle) {
  ASSERT_TRUE(build("cyclic_app.xml")) << problems();
  start();
  EXPECT_EQ(port_counters("bus1", "brake")["scheduled"], false);

  ASSERT_EQ(cansend("vcan0", "1A0#04D23E80008500AA"), "");
  ASSERT_TRUE(eventually([&] { return port_counters("bus1", "brake")["scheduled"] == true; }, kDeadline))
      << port_counters("bus1", "brake").dump(2);
  std::string output;
  std::vector<DumpLine> lines = dump_frames(12, output);
  expect_cycle(lines, 50, output);
  for (const DumpLine& line : lines) EXPECT_EQ(line.frame, "1A0#04D23E80008500AA") << output;

  ASSERT_EQ(cansend("vcan0", "1A0#04D23E80008600BB"), "");
  ASSERT_TRUE(eventually([&] { return port_counters("bus1", "brake")["sent"] == 2; }, kDeadline))
      << port_counters("bus1", "brake").dump(2);
  lines = dump_frames(12, output);
  expect_cycle(lines, 50, output);
  for (const DumpLine& line : lines) EXPECT_EQ(line.frame, "1A0#04D23E80008600BB") << output;
  EXPECT_EQ(port_counters("bus1", "brake")["send_failed"], 0);

  // EngineData says <cycle_ms>0</cycle_ms>: each sample is one frame, no task.
  EXPECT_FALSE(port_counters("bus1", "engine").contains("scheduled"));
}

// EngineData's GenMsgCycleTime (10 ms in vehicle.dbc) schedules it without a profile word.
TEST_F(SocketCanRobustTest, TheDbcCycleTimeSchedulesAMessage) {
  ASSERT_TRUE(build("passthrough_app.xml")) << problems();
  start();
  ASSERT_EQ(cansend("vcan0", kEngineFrame), "");
  ASSERT_TRUE(eventually([&] { return port_counters("bus1", "engine")["scheduled"] == true; }, kDeadline))
      << port_counters("bus1", "engine").dump(2);
  std::string output;
  const std::vector<DumpLine> lines = dump_frames(21, output);
  expect_cycle(lines, 10, output);
  for (const DumpLine& line : lines) EXPECT_EQ(line.frame, "100#A00F78C8307D0100") << output;
}

// The broadcast manager's task dies with the interface; when it is back, the task starts
// again with the last frame, without a new sample; a new sample then replaces its data.
TEST_F(SocketCanRobustTest, APeriodicMessageGoesOnAfterTheInterfaceComesBack) {
  ASSERT_TRUE(build("cyclic_app.xml")) << problems();
  start();
  ASSERT_EQ(cansend("vcan0", "1A0#04D23E80008500AA"), "");
  ASSERT_TRUE(eventually([&] { return port_counters("bus1", "brake")["scheduled"] == true; }, kDeadline));

  ASSERT_EQ(run_command({"ip", "link", "del", "vcan1"}), "");
  ASSERT_TRUE(eventually([&] { return socket_counters("bus1")["losses"] == 1; }, kDeadline))
      << socket_counters("bus1").dump(2);
  ASSERT_EQ(add_vcan("vcan1"), "");
  ASSERT_TRUE(eventually([&] { return socket_counters("bus1")["recoveries"] == 1; }, kDeadline))
      << socket_counters("bus1").dump(2);
  EXPECT_EQ(port_counters("bus1", "brake")["scheduled"], true) << port_counters("bus1", "brake").dump(2);
  std::string output;
  std::vector<DumpLine> lines = dump_frames(12, output);
  expect_cycle(lines, 50, output);
  for (const DumpLine& line : lines) EXPECT_EQ(line.frame, "1A0#04D23E80008500AA") << output;
  EXPECT_EQ(port_counters("bus1", "brake")["sent"], 1) << "no new sample was needed";

  ASSERT_EQ(cansend("vcan0", "1A0#04D23E80008600BB"), "");
  ASSERT_TRUE(eventually([&] { return port_counters("bus1", "brake")["sent"] == 2; }, kDeadline))
      << port_counters("bus1", "brake").dump(2);
  lines = dump_frames(12, output);
  expect_cycle(lines, 50, output);
  for (const DumpLine& line : lines) EXPECT_EQ(line.frame, "1A0#04D23E80008600BB") << output;
}

}  // namespace
}  // namespace polyport
