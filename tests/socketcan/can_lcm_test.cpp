// The shipped profiles/can_lcm_bridge.xml in the engine, on a real kernel vcan0 (label vm,
// a guest of its own): frames put on the bus by cansend arrive as LCM messages, taken by
// lcm-gen code (config/types/wheelchair.lcm) on LCM's default provider, their signals decoded
// from the DBC and mapped by name. The guest's network is the test's own: the multicast
// route on loopback LCM needs is added there and goes with the guest.
#include <gtest/gtest.h>
#include <poll.h>

#include <chrono>
#include <string>
#include <vector>

#include <lcm/lcm.h>

#include "../support/engine_fixture.hpp"
#include "../support/multicast_namespace.hpp"
#include "can_peer.hpp"
#include "lcm_model.hpp"
#include "socketcan_model.hpp"
#include "wheelchair_lcm_joystick_t.h"
#include "wheelchair_lcm_motor_voltages_t.h"

namespace polyport {
namespace {

using test::cansend;
using test::Clock;

struct Received {
  std::vector<wheelchair_lcm_joystick_t> joystick;
  std::vector<wheelchair_lcm_motor_voltages_t> voltages;
};

void on_joystick(const lcm_recv_buf_t*, const char*, const wheelchair_lcm_joystick_t* message, void* user) {
  static_cast<Received*>(user)->joystick.push_back(*message);
}
void on_voltages(const lcm_recv_buf_t*, const char*, const wheelchair_lcm_motor_voltages_t* message, void* user) {
  static_cast<Received*>(user)->voltages.push_back(*message);
}

class CanToLcm : public test::EngineFixture {
 protected:
  CanToLcm() : EngineFixture(POLYPORT_SOURCE_DIR "/profiles", LoadOptions{}) {
    models.add(std::make_unique<socketcan::SocketCanModel>());
    models.add(std::make_unique<lcm::LcmModel>());
  }
  void SetUp() override { test::add_multicast_route(); }

  // Handles LCM messages until `done` or 5 s (a bound on a failure, not a latency).
  static bool handle_until(lcm_t* lcm, const std::function<bool()>& done) {
    const auto deadline = Clock::now() + std::chrono::seconds(5);
    while (!done()) {
      pollfd p{lcm_get_fileno(lcm), POLLIN, 0};
      const int left = test::ms_until(deadline);
      if (left == 0) return false;
      if (::poll(&p, 1, left) > 0) lcm_handle(lcm);
    }
    return true;
  }
};

TEST_F(CanToLcm, CansendFramesArriveAsLcmMessages) {
  ASSERT_TRUE(build("can_lcm_bridge.xml")) << problems();
  std::vector<std::string> warnings;
  auto started = engine.start(warnings);
  ASSERT_TRUE(started) << started.error().message;

  lcm_t* lcm = lcm_create(nullptr);  // LCM's default provider, as the profile's
  ASSERT_NE(lcm, nullptr);
  Received got;
  wheelchair_lcm_joystick_t_subscribe(lcm, "WHEELCHAIR_JOYSTICK", on_joystick, &got);
  wheelchair_lcm_motor_voltages_t_subscribe(lcm, "WHEELCHAIR_MOTOR_VOLTAGES", on_voltages, &got);

  // x = 5000 * 1e-4 = 0.5, y = -2500 * 1e-4 = -0.25 (Intel int16).
  ASSERT_EQ(cansend("vcan0", "101#88133CF6"), "");
  ASSERT_TRUE(handle_until(lcm, [&] { return !got.joystick.empty(); })) << "no joystick_t on WHEELCHAIR_JOYSTICK";
  EXPECT_DOUBLE_EQ(got.joystick[0].x, 0.5);
  EXPECT_DOUBLE_EQ(got.joystick[0].y, -0.25);

  // left_v = 1200 * 0.01 = 12 V, right_v = -600 * 0.01 = -6 V.
  ASSERT_EQ(cansend("vcan0", "201#B004A8FD"), "");
  ASSERT_TRUE(handle_until(lcm, [&] { return !got.voltages.empty(); })) << "no motor_voltages_t";
  EXPECT_DOUBLE_EQ(got.voltages[0].left_v, 12.0);
  EXPECT_DOUBLE_EQ(got.voltages[0].right_v, -6.0);
  EXPECT_EQ(got.joystick.size(), 1u) << "one frame, one message";
  lcm_destroy(lcm);
  engine.stop();
}

}  // namespace
}  // namespace polyport
