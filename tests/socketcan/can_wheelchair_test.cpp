// The shipped profiles/can_inproc.xml in the engine, on a real kernel vcan0 (label vm): an IO
// board's joystick frame put on the bus by cansend asks for full speed ahead; the in-process
// Joystick, Control and HW components run at 10 ms, and candump sees Control's motor voltages
// go out as CAN frames (0x201), positive and equal on both sides for a straight drive.
#include <gtest/gtest.h>

#include <cstdlib>
#include <sstream>
#include <string>
#include <vector>

#include "../support/engine_fixture.hpp"
#include "can_peer.hpp"
#include "inproc_model.hpp"
#include "socketcan_model.hpp"

namespace polyport {
namespace {

using test::CanPeer;
using test::cansend;
using test::Clock;

struct Voltages {
  double left = 0;
  double right = 0;
};

// `candump -L` lines of 0x201 ("(t) vcan0 201#LLLLRRRR"): little-endian int16, 0.01 V each.
std::vector<Voltages> motor_frames(const std::string& candump) {
  std::vector<Voltages> out;
  std::istringstream lines(candump);
  std::string line;
  while (std::getline(lines, line)) {
    const auto at = line.find("201#");
    if (at == std::string::npos || line.size() < at + 12) continue;
    const std::string hex = line.substr(at + 4, 8);
    const auto byte = [&](int k) { return static_cast<unsigned>(std::stoul(hex.substr(2 * k, 2), nullptr, 16)); };
    const auto le16 = [&](int k) { return static_cast<std::int16_t>(byte(k) | (byte(k + 1) << 8)); };
    out.push_back({le16(0) * 0.01, le16(2) * 0.01});
  }
  return out;
}

class CanWheelchair : public test::EngineFixture {
 protected:
  CanWheelchair() : EngineFixture(POLYPORT_SOURCE_DIR "/profiles", LoadOptions{{POLYPORT_PLUGIN_DIR}}) {
    models.add(std::make_unique<inproc::InprocModel>());
    models.add(std::make_unique<socketcan::SocketCanModel>());
  }
};

TEST_F(CanWheelchair, AJoystickFrameDrivesTheMotorFramesOnTheBus) {
  ASSERT_TRUE(build("can_inproc.xml")) << problems();
  std::vector<std::string> warnings;
  auto started = engine.start(warnings);
  ASSERT_TRUE(started) << started.error().message;
  CanPeer candump({"candump", "-L", "-n", "60", "vcan0,201:7FF"});
  ASSERT_TRUE(candump.error().empty()) << candump.error();
  // x = 0, y = 10000 * 0.0001 = 1: full speed ahead (little-endian int16 signals).
  ASSERT_EQ(cansend("vcan0", "101#00001027"), "");
  const auto status = candump.finish(Clock::now() + std::chrono::seconds(10));
  ASSERT_TRUE(status.has_value()) << "candump saw fewer than 60 motor frames in 10 s:\n" << candump.output();
  const std::vector<Voltages> frames = motor_frames(candump.output());
  ASSERT_EQ(frames.size(), 60u) << candump.output();
  // Some frame after the joystick frame commands the motors forward, both alike.
  bool forward = false;
  for (const Voltages& v : frames) {
    if (v.left > 0.5 && v.right > 0.5) {
      forward = true;
      EXPECT_NEAR(v.left, v.right, 0.011) << "a straight drive sends the same voltage to both motors";
    }
  }
  EXPECT_TRUE(forward) << candump.output();
  engine.stop();
}

}  // namespace
}  // namespace polyport
