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
  EXPECT_NE(text.find("(events without a payload, e.g. bus-off, are planned)"), std::string::npos) << text;
  EXPECT_NE(text.find("data port 'battery': message 'vehicle::BatteryFD' (64 bytes) is a CAN FD frame"),
            std::string::npos)
      << text;
  EXPECT_NE(text.find("service port 'diag': model 'socketcan' has no service ports yet (planned"), std::string::npos)
      << text;
  EXPECT_EQ(diagnostics.error_count(), 4u) << text;
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
