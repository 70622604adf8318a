// The SocketCAN model with CAN FD frames, in the engine, against can-utils on real kernel
// vcan interfaces with the FD MTU (label vm: each case in a guest of its own with vcan0 and
// vcan1, started with --fd). Every wait polls a condition until a deadline.
#include <gtest/gtest.h>

#include <chrono>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "../support/engine_fixture.hpp"
#include "../support/eventually.hpp"
#include "socketcan_fixture.hpp"
#include "polyport/runtime/engine.hpp"
#include "polyport/types/dbc.hpp"
#include "socketcan_model.hpp"

namespace polyport {
namespace {

using test::CanPeer;
using test::cansend;
using test::Clock;
using test::eventually;

using test::kDeadline;

// BatteryFD (0x300, 64 bytes): Cell01 0x100E * 0.001 = 4.110 V, Cell02 0x0FD4 * 0.001 =
// 4.052 V, StateOfCharge (byte 32, Motorola) 0xA0 * 0.5 = 80 %, the rest 0.
const std::string kBatteryData = "0E10D40F" + std::string(2 * 28, '0') + "A0" + std::string(2 * 31, '0');

// The FD profiles have one port per component: "battery".
class SocketCanFdTest : public test::SocketCanFixture {
 protected:
  nlohmann::json battery_port(const std::string& component) { return port_counters(component, "battery"); }
};

// A 64-byte FD frame with the bit rate switch from cansend is decoded on vcan0 and goes out
// on vcan1 byte for byte, as an FD frame with the bit rate switch, as candump sees it.
TEST_F(SocketCanFdTest, SixtyFourByteFramesAreDecodedAndPassedThrough) {
  ASSERT_TRUE(build("fd_passthrough_app.xml")) << problems();
  auto probe = engine.add_probe("bus0.battery", 16);
  ASSERT_TRUE(probe) << probe.error().message;
  std::vector<std::string> warnings;
  auto started = engine.start(warnings);
  ASSERT_TRUE(started) << started.error().message;
  const Type* type = types.find("vehicle::BatteryFD");
  ASSERT_NE(type, nullptr);
  std::vector<double> values(type->resolved().size / sizeof(double));
  const auto bytes = static_cast<std::uint32_t>(values.size() * sizeof(double));

  CanPeer candump({"candump", "-L", "-n", "1", "vcan1"});
  ASSERT_EQ(candump.error(), "");
  const auto deadline = Clock::now() + kDeadline;
  int sent = 0;
  while (!candump.output_ready(sent == 0 ? 0 : 20)) {
    ASSERT_LT(Clock::now(), deadline) << "candump printed nothing within 5 s of " << sent << " frames";
    ASSERT_EQ(cansend("vcan0", "300##1" + kBatteryData), "");
    ++sent;
  }
  ASSERT_TRUE(candump.finish(deadline).has_value()) << "candump did not exit after one frame: " << candump.output();
  // candump's FD format: ID##<flags nibble><data>; kernels from 6.2 add CANFD_FDF (4).
  const std::string& output = candump.output();
  const std::string prefix = ") vcan1 300##";
  const auto at = output.find(prefix);
  ASSERT_NE(at, std::string::npos) << output;
  const std::string flags = output.substr(at + prefix.size(), 1);
  EXPECT_TRUE(flags == "1" || flags == "5") << "bit rate switch: " << output;
  EXPECT_EQ(output.substr(at + prefix.size() + 1, kBatteryData.size()), kBatteryData) << output;

  ASSERT_TRUE(eventually([&] { return probe.value()->read(values.data(), bytes) == Status::ok; }, kDeadline));
  EXPECT_NEAR(values[0], 4.110, 1e-9);
  EXPECT_NEAR(values[1], 4.052, 1e-9);
  const DbcMessage* dbc = type->resolved().dbc;
  ASSERT_NE(dbc, nullptr);
  for (std::size_t i = 0; i < dbc->signals.size(); ++i) {
    if (dbc->signals[i].name == "StateOfCharge") {
      EXPECT_NEAR(values[i], 80.0, 1e-9);
    }
  }

  EXPECT_TRUE(eventually([&] { return battery_port("bus1")["sent"] == sent; }, kDeadline))
      << battery_port("bus1").dump(2) << " after " << sent << " frames";
  EXPECT_EQ(battery_port("bus1")["send_failed"], 0);
  EXPECT_EQ(battery_port("bus0")["bad_length"], 0);
}

}  // namespace
}  // namespace polyport
