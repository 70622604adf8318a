// The SocketCAN model's profile side, without CAN (label unit): what it refuses, each at
// its port, and its <socketcan> element's values.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <string>

#include "../support/engine_fixture.hpp"
#include "socketcan_model.hpp"
#include "socketcan_settings.hpp"

namespace polyport {
namespace {

class SocketCanProfileTest : public test::EngineFixture {
 protected:
  SocketCanProfileTest() : EngineFixture(POLYPORT_TEST_DATA "/socketcan", LoadOptions{}) {
    models.add(std::make_unique<socketcan::SocketCanModel>());
  }
};

TEST_F(SocketCanProfileTest, RefusesWhatTheModelCannotCarryYet) {
  EXPECT_FALSE(build("refused_app.xml"));
  const std::string text = problems();
  EXPECT_NE(text.find("data port 'plain': type 'double' is not a DBC message"), std::string::npos) << text;
  EXPECT_NE(text.find("event port 'bus_off': a CAN port carries the frames of one DBC message"), std::string::npos)
      << text;
  EXPECT_NE(text.find("(or polyport::CanBusEvent for the bus's errors"), std::string::npos) << text;
  EXPECT_NE(text.find("data port 'battery': message 'vehicle::BatteryFD' (64 bytes) is a CAN FD frame"),
            std::string::npos)
      << text;
  EXPECT_NE(text.find("service port 'diag': model 'socketcan' has no service ports yet (planned"), std::string::npos)
      << text;
  EXPECT_NE(text.find("event port 'events_in' of type polyport::CanBusEvent: the bus's events come from the bus; "
                      "say <usage>output</usage>"),
            std::string::npos)
      << text;
  EXPECT_EQ(diagnostics.error_count(), 5u) << text;
}

TEST_F(SocketCanProfileTest, RefusesACycleTimeOnAReceivedPortAndOneThatIsNoNumber) {
  EXPECT_FALSE(build("refused_cycle_app.xml"));
  const std::string text = problems();
  EXPECT_NE(text.find("RefusedCycle.xml:8:"), std::string::npos) << text;
  EXPECT_NE(text.find("<cycle_ms> is for a port polyport sends (usage input); port 'engine' receives frames"),
            std::string::npos)
      << text;
  EXPECT_NE(text.find("RefusedCycle.xml:9:"), std::string::npos) << text;
  EXPECT_NE(text.find("bad cycle_ms 'fast': expected whole milliseconds from 0 to 3600000"), std::string::npos)
      << text;
}

// A port polyport sends takes the DBC's GenMsgCycleTime (EngineData: 10 ms) unless the
// profile says <cycle_ms> (BrakeStatus: 50 instead of 20; EngineData: 0, each sample once).
TEST_F(SocketCanProfileTest, CycleTimesComeFromTheDbcOrTheProfile) {
  ASSERT_TRUE(build("passthrough_app.xml")) << problems();
  nlohmann::json out;
  engine.find_interceptor("bus1")->describe(out);
  ASSERT_EQ(out["socketcan"]["ports"].size(), 1u);
  EXPECT_EQ(out["socketcan"]["ports"][0]["cycle_ms"], 10) << out.dump(2);
  EXPECT_EQ(out["socketcan"]["ports"][0]["scheduled"], false) << "nothing is sent before the first sample";
}

TEST_F(SocketCanProfileTest, AProfileCycleTimeOverridesTheDbc) {
  ASSERT_TRUE(build("cyclic_app.xml")) << problems();
  nlohmann::json out;
  engine.find_interceptor("bus1")->describe(out);
  const auto& ports = out["socketcan"]["ports"];
  ASSERT_EQ(ports.size(), 2u) << out.dump(2);
  EXPECT_EQ(ports[0]["port"], "brake");
  EXPECT_EQ(ports[0]["cycle_ms"], 50);
  EXPECT_EQ(ports[1]["port"], "engine");
  EXPECT_EQ(ports[1]["cycle_ms"], 0);
  EXPECT_FALSE(ports[1].contains("scheduled"));
}

TEST_F(SocketCanProfileTest, TheBusEventPortIsDescribed) {
  ASSERT_TRUE(build("events_app.xml")) << problems();
  nlohmann::json out;
  engine.find_interceptor("bus0")->describe(out);
  EXPECT_EQ(out["socketcan"]["bus_events"], "bus") << out.dump(2);
  EXPECT_EQ(out["socketcan"]["bus"]["state"], "error-active");
  EXPECT_EQ(out["socketcan"]["bus"]["error_frames"], 0);
  EXPECT_EQ(out["socketcan"]["link"], "missing") << "not started";
  ASSERT_EQ(out["socketcan"]["ports"].size(), 1u) << "the event port is no frame's port";
}

TEST_F(SocketCanProfileTest, ReadsInterfaceAndFd) {
  ASSERT_TRUE(build("passthrough_app.xml")) << problems();
  nlohmann::json out;
  engine.find_interceptor("bus0")->describe(out);
  EXPECT_EQ(out["socketcan"]["interface"], "vcan0");
  EXPECT_EQ(out["socketcan"]["fd"], false);
  out = {};
  engine.find_interceptor("bus1")->describe(out);
  EXPECT_EQ(out["socketcan"]["interface"], "vcan1");
  ASSERT_EQ(out["socketcan"]["ports"].size(), 1u);
  EXPECT_EQ(out["socketcan"]["ports"][0]["polyport"], "sends");
  EXPECT_EQ(out["socketcan"]["ports"][0]["sent"], 0);
}

TEST(SocketCanInterfaceName, BadNamesSayWhy) {
  EXPECT_EQ(socketcan::bad_interface_name("vcan0"), "");
  EXPECT_EQ(socketcan::bad_interface_name("can-bus_1.2"), "");
  EXPECT_EQ(socketcan::bad_interface_name(""), "empty <interface>");
  EXPECT_NE(socketcan::bad_interface_name("a_very_long_name"), "");  // 16 characters
  EXPECT_NE(socketcan::bad_interface_name("vcan 0"), "");
  EXPECT_NE(socketcan::bad_interface_name("vcan/0"), "");
}

}  // namespace
}  // namespace polyport
