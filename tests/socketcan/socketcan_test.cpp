// The SocketCAN model in the engine, in one process, against can-utils on real kernel vcan
// interfaces (label vm: each case in a guest of its own with vcan0 and vcan1, classic MTU).
// cansend puts frames on the bus; the tests read what polyport made of them through pull
// probes on the output ports (the decoded DBC signals) and through the interceptor's
// describe() counters; candump shows what polyport sends.
//
// Every wait polls a condition until a deadline; nothing sleeps a fixed time, nothing
// measures latency.
#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "../support/engine_fixture.hpp"
#include "../support/eventually.hpp"
#include "socketcan_fixture.hpp"
#include "polyport/runtime/engine.hpp"
#include "socketcan_model.hpp"

namespace polyport {
namespace {

using test::CanPeer;
using test::cansend;
using test::Clock;
using test::eventually;

using test::kDeadline;

// EngineData (0x100, Intel): EngineSpeed 4000 * 0.25 = 1000 rpm, CoolantTemp 120 - 40 = 80,
// Torque 200 * 0.5 = 100 Nm, Gear 3, ThrottlePos 125 * 0.4 = 50 %, EngineRunning 1.
constexpr const char* kEngineFrame = "100#A00F78C8307D0100";
constexpr double kEngineValues[] = {1000.0, 80.0, 100.0, 3.0, 50.0, 1.0};
// BrakeStatus (0x1A0, Motorola): BrakePressure 1234 * 0.1, WheelSpeedFL 1000 * 0.05,
// BrakeTemp 0 * 0.01 + 250, AbsActive 1, Counter 5, Checksum 0xAA.
constexpr const char* kBrakeFrame = "1A0#04D23E80008500AA";
constexpr double kBrakeValues[] = {123.4, 50.0, 250.0, 1.0, 5.0, 170.0};

using SocketCanEngineTest = test::SocketCanFixture;

void expect_values(const std::vector<double>& got, const double* want, const char* what) {
  for (std::size_t i = 0; i < got.size(); ++i) EXPECT_NEAR(got[i], want[i], 1e-9) << what << " signal " << i;
}

TEST_F(SocketCanEngineTest, CansendFramesArriveDecodedIntelAndMotorola) {
  ASSERT_TRUE(build("receive_app.xml")) << problems();
  DataInPort* engine_probe = probe("bus0.engine");
  DataInPort* brake_probe = probe("bus0.brake");
  ASSERT_TRUE(engine_probe && brake_probe);
  start();

  ASSERT_EQ(cansend("vcan0", kEngineFrame), "");
  std::vector<double> engine_values(6);
  ASSERT_TRUE(next_sample(*engine_probe, engine_values)) << "no EngineData within 5 s";
  expect_values(engine_values, kEngineValues, "EngineData");

  ASSERT_EQ(cansend("vcan0", kBrakeFrame), "");
  std::vector<double> brake_values(6);
  ASSERT_TRUE(next_sample(*brake_probe, brake_values)) << "no BrakeStatus within 5 s";
  expect_values(brake_values, kBrakeValues, "BrakeStatus");

  const nlohmann::json engine_port = port_counters("bus0", "engine");
  EXPECT_EQ(engine_port["can_id"], "0x100");
  EXPECT_EQ(engine_port["message"], "vehicle::EngineData");
  EXPECT_EQ(engine_port["received"], 1);
  EXPECT_EQ(engine_port["bad_length"], 0);
  EXPECT_EQ(socket_counters("bus0")["interface"], "vcan0");
}

// A sample's source time is the kernel's receive time (SO_TIMESTAMPNS, wall clock) on the
// monotonic clock: between a stamp taken before cansend starts and one after the sample is
// read (1 ms of slack for the clock offset measured at start; no latency is measured).
TEST_F(SocketCanEngineTest, SamplesCarryTheKernelReceiveTimeOnTheMonotonicClock) {
  ASSERT_TRUE(build("receive_app.xml")) << problems();
  DataInPort* engine_probe = probe("bus0.engine");
  ASSERT_TRUE(engine_probe);
  start();

  const MonoTime before = mono_now();
  ASSERT_EQ(cansend("vcan0", kEngineFrame), "");
  std::vector<double> values(6);
  SampleMeta meta;
  ASSERT_TRUE(eventually([&] { return engine_probe->read(values.data(), 6 * sizeof(double), &meta) == Status::ok; },
                         kDeadline));
  const MonoTime after = mono_now();
  constexpr Nanos kSlack{1'000'000};
  EXPECT_GE(meta.t_source.ns, before.ns - kSlack.count);
  EXPECT_LE(meta.t_source.ns, after.ns + kSlack.count);
  EXPECT_LE(meta.t_source.ns, meta.t_in.ns + kSlack.count) << "received before it entered the connection";
}

// The kernel filter passes only the profile's ids: a frame of another id, sent before one
// the component takes, never reaches the component (frames of one socket arrive in order).
TEST_F(SocketCanEngineTest, FramesOfOtherIdsAreFilteredOutByTheKernel) {
  ASSERT_TRUE(build("receive_app.xml")) << problems();
  DataInPort* engine_probe = probe("bus0.engine");
  ASSERT_TRUE(engine_probe);
  start();

  ASSERT_EQ(cansend("vcan0", "123#1122334455667788"), "");
  ASSERT_EQ(cansend("vcan0", "00000100#A00F78C8307D0100"), "") << "the 29-bit id 0x100 is not 0x100";
  ASSERT_EQ(cansend("vcan0", "100#R"), "") << "a remote request for 0x100 carries no data";
  ASSERT_EQ(cansend("vcan0", kEngineFrame), "");
  std::vector<double> values(6);
  ASSERT_TRUE(next_sample(*engine_probe, values)) << "no EngineData within 5 s";

  const nlohmann::json socket = socket_counters("bus0");
  EXPECT_EQ(socket["unknown_id"], 0) << socket.dump(2);
  EXPECT_EQ(port_counters("bus0", "engine")["received"], 1);
  EXPECT_EQ(port_counters("bus0", "brake")["received"], 0);
  EXPECT_EQ(engine_probe->read(values.data(), 6 * sizeof(double)), Status::no_data);
}

TEST_F(SocketCanEngineTest, AFrameOfTheWrongLengthIsCountedAndDropped) {
  ASSERT_TRUE(build("receive_app.xml")) << problems();
  DataInPort* engine_probe = probe("bus0.engine");
  ASSERT_TRUE(engine_probe);
  start();

  ASSERT_EQ(cansend("vcan0", "100#0102"), "");
  ASSERT_EQ(cansend("vcan0", kEngineFrame), "");
  std::vector<double> values(6);
  ASSERT_TRUE(next_sample(*engine_probe, values)) << "no EngineData within 5 s";
  expect_values(values, kEngineValues, "EngineData");
  EXPECT_EQ(engine_probe->read(values.data(), 6 * sizeof(double)), Status::no_data) << "the short frame went through";

  const nlohmann::json engine_port = port_counters("bus0", "engine");
  EXPECT_EQ(engine_port["received"], 2);
  EXPECT_EQ(engine_port["bad_length"], 1);
}

// CAN -> CAN: EngineData from vcan0 goes out on vcan1 byte for byte (a passthrough
// connection), as candump sees it. candump binds its socket some time after it starts, so
// the frame is sent every 20 ms until candump has printed one.
using SocketCanPassthrough = test::SocketCanIoFixture;

TEST_P(SocketCanPassthrough, SendsTheFrameOnAnotherInterface) {
  ASSERT_TRUE(build("passthrough_app.xml")) << problems();
  start();
  expect_io("bus1");
  nlohmann::json graph;
  engine.describe(graph);
  ASSERT_EQ(graph["connections"].size(), 1u) << graph.dump(2);
  EXPECT_EQ(graph["connections"][0]["conversion"], "passthrough") << graph.dump(2);

  CanPeer candump({"candump", "-L", "-n", "1", "vcan1"});
  ASSERT_EQ(candump.error(), "");
  const auto deadline = Clock::now() + kDeadline;
  int sent = 0;
  while (!candump.output_ready(sent == 0 ? 0 : 20)) {
    ASSERT_LT(Clock::now(), deadline) << "candump printed nothing within 5 s of " << sent << " frames";
    ASSERT_EQ(cansend("vcan0", kEngineFrame), "");
    ++sent;
  }
  ASSERT_TRUE(candump.finish(deadline).has_value()) << "candump did not exit after one frame: " << candump.output();
  const std::string line = candump.output().substr(0, candump.output().find('\n'));
  EXPECT_NE(line.find(") vcan1 100#A00F78C8307D0100"), std::string::npos) << candump.output();

  EXPECT_TRUE(eventually([&] { return port_counters("bus1", "engine")["sent"] == sent; }, kDeadline))
      << port_counters("bus1", "engine").dump(2) << " after " << sent << " frames";
  EXPECT_EQ(port_counters("bus1", "engine")["send_failed"], 0);
  EXPECT_EQ(port_counters("bus1", "engine")["can_id"], "0x100");
}

POLYPORT_BOTH_CAN_WAITS(SocketCanPassthrough);

// CAN -> CAN converting, with nested multiplexers (extended multiplexing, SG_MUL_VAL_):
// Cascaded (0x642) from vcan0 goes out on vcan1 as CascadedOut (0x652), decoded and encoded
// again, so candump shows which multiplexed signals polyport found in each frame. MuxA = 2
// puts MuxB in the frame and MuxB = 0 puts Value in it; with MuxB = 1 Value is absent and not
// sent (its byte stays zero), whatever the incoming frame holds there.
TEST_F(SocketCanEngineTest, NestedMultiplexersAreDecodedAndEncodedAgain) {
  ASSERT_TRUE(build("mux_convert_app.xml")) << problems();
  start();
  int sent = 0;
  // One candump per frame: it binds some time after it starts, so the frame is sent every
  // 20 ms until candump has printed one (and exited).
  const auto forwarded_as = [&](const char* frame) {
    // Every frame of the last phase is out before this one's candump starts.
    EXPECT_TRUE(eventually([&] { return port_counters("bus1", "cascaded")["sent"] == sent; }, kDeadline));
    CanPeer candump({"candump", "-L", "-n", "1", "vcan1,652:7FF"});
    EXPECT_EQ(candump.error(), "");
    const auto deadline = Clock::now() + kDeadline;
    while (!candump.output_ready(sent == 0 ? 0 : 20)) {
      if (Clock::now() > deadline) return "candump printed nothing within 5 s, " + std::to_string(sent) + " frames sent";
      EXPECT_EQ(cansend("vcan0", frame), "");
      ++sent;
    }
    EXPECT_TRUE(candump.finish(deadline).has_value()) << candump.output();
    return candump.output().substr(0, candump.output().find('\n'));
  };
  const std::string all_there = forwarded_as("642#02002A0000000000");
  EXPECT_NE(all_there.find(") vcan1 652#02002A0000000000"), std::string::npos) << all_there;
  const std::string value_absent = forwarded_as("642#02012A0000000000");
  EXPECT_NE(value_absent.find(") vcan1 652#0201000000000000"), std::string::npos) << value_absent;
  EXPECT_TRUE(eventually([&] { return port_counters("bus1", "cascaded")["sent"] == sent; }, kDeadline))
      << port_counters("bus1", "cascaded").dump(2) << " after " << sent << " frames";
  EXPECT_EQ(port_counters("bus1", "cascaded")["send_failed"], 0);
}

TEST_F(SocketCanEngineTest, FdOnAClassicInterfaceFailsTheStart) {
  ASSERT_TRUE(build("fd_on_classic_app.xml")) << problems();
  std::vector<std::string> warnings;
  auto started = engine.start(warnings);
  ASSERT_FALSE(started);
  EXPECT_NE(started.error().message.find("CAN interface 'vcan0' carries no CAN FD frames (MTU 16)"),
            std::string::npos)
      << started.error().message;
}

}  // namespace
}  // namespace polyport
