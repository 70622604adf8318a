// The wheelchair's math without the engine: the joystick mapping, the electronic
// differential and PI control, the plant, the scenario parser, and the three of them in a
// closed loop run the way the components run it (Joystick, Control, HW in one 10 ms tick).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>
#include <string_view>

#include "steering.hpp"

namespace polyport::wheelchair {
namespace {

constexpr double kDt = 0.01;
constexpr double kPi = std::numbers::pi;
double deg_to_rad(double deg) { return deg * kPi / 180.0; }

// The three components' onExecute bodies in profile order. Like the components, Control
// sees the wheel speeds HW published in the previous tick and HW the voltages Control
// published in this one.
class ClosedLoop {
 public:
  explicit ClosedLoop(std::string_view scenario_text = kDefaultScenario) {
    const ScenarioParseResult parsed = parse_scenario(scenario_text);
    EXPECT_TRUE(parsed.ok()) << parsed.error;
    scenario_ = parsed.scenario;
  }

  void tick() {
    reference_ = joystick_to_reference(position_, kDefaultMaxSpeedMps);        // JoystickComp
    voltages_ = controller_.step(reference_, speeds_, kDt);                     // ControlComp
    plant_.step(voltages_, kDt);                                                 // HWComp
    speeds_ = plant_.output();
    position_ = scenario_.position_at(speeds_.time_s);
    max_abs_voltage_ = std::max({max_abs_voltage_, std::abs(voltages_.left_v), std::abs(voltages_.right_v)});
  }
  // Ticks until the plant clock reaches t (to the nearest step).
  void run_until(double time_s) {
    while (plant_.time_s() < time_s - kDt / 2) tick();
  }

  const WheelSpeeds& speeds() const { return speeds_; }
  const Reference& reference() const { return reference_; }
  const MotorVoltages& voltages() const { return voltages_; }
  double max_abs_voltage() const { return max_abs_voltage_; }

 private:
  Scenario scenario_;
  SpeedRatioController controller_;
  WheelchairPlant plant_;
  JoystickPosition position_;
  Reference reference_;
  MotorVoltages voltages_;
  WheelSpeeds speeds_;
  double max_abs_voltage_ = 0.0;
};

// ---- Steering: joystick mapping ------------------------------------------------------------

TEST(Steering, JoystickMapsDirectionAndSpeed) {
  const Reference ahead = joystick_to_reference({0.0, 1.0});
  EXPECT_DOUBLE_EQ(ahead.direction_deg, 0.0);
  EXPECT_DOUBLE_EQ(ahead.speed_mps, 1.5);

  const double angle = deg_to_rad(20.0);
  const Reference turn = joystick_to_reference({0.6 * std::sin(angle), 0.6 * std::cos(angle)});
  EXPECT_NEAR(turn.direction_deg, 20.0, 1e-12);
  EXPECT_NEAR(turn.speed_mps, 0.9, 1e-12);

  const Reference left = joystick_to_reference({-0.3, 0.3}, 2.0);
  EXPECT_NEAR(left.direction_deg, -45.0, 1e-12);
  EXPECT_NEAR(left.speed_mps, 2.0 * std::hypot(0.3, 0.3), 1e-12);

  const Reference centred = joystick_to_reference({0.0, 0.0});
  EXPECT_EQ(centred.direction_deg, 0.0);
  EXPECT_EQ(centred.speed_mps, 0.0);
}

TEST(Steering, ReferenceMappingClamps) {
  // Direction to +-45 degrees.
  EXPECT_DOUBLE_EQ(joystick_to_reference({1.0, 0.0}).direction_deg, 45.0);
  EXPECT_DOUBLE_EQ(joystick_to_reference({-1.0, 0.2}).direction_deg, -45.0);
  EXPECT_DOUBLE_EQ(joystick_to_reference({0.9, 0.1}, 1.5, 30.0).direction_deg, 30.0);
  // Speed to max_speed at the rim and beyond.
  EXPECT_DOUBLE_EQ(joystick_to_reference({1.0, 1.0}).speed_mps, 1.5);
  EXPECT_DOUBLE_EQ(joystick_to_reference({0.0, 7.0}).speed_mps, 1.5);
  const Reference wild = joystick_to_reference({3.0, 3.0});
  EXPECT_DOUBLE_EQ(wild.direction_deg, 45.0);
  EXPECT_DOUBLE_EQ(wild.speed_mps, 1.5);
  // A broken reading does not drive.
  const Reference broken = joystick_to_reference({std::nan(""), std::nan("")});
  EXPECT_EQ(broken.direction_deg, 0.0);
  EXPECT_EQ(broken.speed_mps, 0.0);
}

TEST(Steering, PulledBackStickReverses) {
  const Reference back = joystick_to_reference({0.0, -1.0});
  EXPECT_DOUBLE_EQ(back.direction_deg, 0.0);
  EXPECT_DOUBLE_EQ(back.speed_mps, -1.5);
  const Reference back_right = joystick_to_reference({0.5, -0.5});
  EXPECT_NEAR(back_right.direction_deg, 45.0, 1e-12);
  EXPECT_LT(back_right.speed_mps, 0.0);
}

// ---- Steering: electronic differential and PI ----------------------------------------------

TEST(Steering, RightTurnSpeedsUpTheLeftWheel) {
  const ChairGeometry geometry;
  const WheelPair straight = wheel_speed_reference({0.0, 0.9}, geometry);
  EXPECT_DOUBLE_EQ(straight.left, straight.right);
  EXPECT_NEAR(straight.left, 0.9 / 0.17, 1e-12);

  const WheelPair right = wheel_speed_reference({20.0, 0.9}, geometry);
  const double k = 0.55 * std::tan(deg_to_rad(20.0)) / (2.0 * 0.6);
  EXPECT_NEAR(right.left, 0.9 * (1.0 + k) / 0.17, 1e-12);
  EXPECT_NEAR(right.right, 0.9 * (1.0 - k) / 0.17, 1e-12);
  EXPECT_GT(right.left, right.right);
  // The midpoint still runs at the reference speed.
  EXPECT_NEAR((right.left + right.right) / 2.0 * 0.17, 0.9, 1e-12);

  const WheelPair left = wheel_speed_reference({-20.0, 0.9}, geometry);
  EXPECT_NEAR(left.left, right.right, 1e-12);
  EXPECT_NEAR(left.right, right.left, 1e-12);
}

TEST(Steering, RealisedSteeringInvertsTheDifferential) {
  const ChairGeometry geometry;
  for (double delta : {-45.0, -20.0, -1.0, 0.0, 5.0, 20.0, 45.0}) {
    for (double speed : {0.3, 1.5, -0.8}) {
      const WheelPair wheels = wheel_speed_reference({delta, speed}, geometry);
      EXPECT_NEAR(realised_steering_deg(wheels.left, wheels.right, geometry), delta, 1e-9)
          << "delta " << delta << " speed " << speed;
    }
  }
  EXPECT_EQ(realised_steering_deg(0.0, 0.0, geometry), 0.0);
  EXPECT_EQ(realised_steering_deg(0.05, 0.02, geometry), 0.0);  // creeping: below 2 cm/s
  EXPECT_NEAR(realised_steering_deg(2.0, -2.0, geometry), 90.0, 1e-12);  // spin clockwise
  EXPECT_NEAR(realised_steering_deg(-2.0, 2.0, geometry), -90.0, 1e-12);
}

TEST(Steering, ControllerSaturatesWithoutWindingUp) {
  SpeedRatioController controller;
  const WheelSpeeds stopped{};
  MotorVoltages voltages;
  // Full speed ahead while the wheels are held: the output saturates...
  for (int i = 0; i < 500; ++i) voltages = controller.step({0.0, 1.5}, stopped, kDt);
  EXPECT_DOUBLE_EQ(voltages.left_v, kDefaultVoltageLimitV);
  EXPECT_DOUBLE_EQ(voltages.right_v, kDefaultVoltageLimitV);
  // ...but the integral did not wind up: once the wheels overshoot the reference the
  // output leaves saturation at once instead of after seconds of unwinding.
  const double reference = 1.5 / 0.17;
  const WheelSpeeds fast{reference + 0.5, reference + 0.5, 0.0, 0.0, 0.0};
  voltages = controller.step({0.0, 1.5}, fast, kDt);
  EXPECT_LT(voltages.left_v, kDefaultVoltageLimitV);
  EXPECT_LT(voltages.right_v, kDefaultVoltageLimitV);
}

TEST(Steering, ControllerProportionalAndIntegralParts) {
  ControllerParams params;
  params.kp = 2.0;
  params.ki = 10.0;
  SpeedRatioController controller(params);
  const WheelSpeeds measured{1.0, 1.0, 0.0, 0.0, 0.0};
  const Reference reference{0.0, 2.0 * 0.17};  // 2 rad/s on both wheels: error 1 rad/s
  const MotorVoltages first = controller.step(reference, measured, kDt);
  EXPECT_NEAR(first.left_v, 2.0 * 1.0 + 10.0 * 1.0 * kDt, 1e-12);
  const MotorVoltages second = controller.step(reference, measured, kDt);
  EXPECT_NEAR(second.left_v, 2.0 + 2.0 * 10.0 * kDt, 1e-12);
  EXPECT_DOUBLE_EQ(second.left_v, second.right_v);
  controller.reset();
  EXPECT_NEAR(controller.step(reference, measured, 0.0).left_v, 2.0, 1e-12);
}

// ---- Steering: scenario parser -------------------------------------------------------------

TEST(Steering, ScenarioParserAcceptsTheDefault) {
  const ScenarioParseResult parsed = parse_scenario(kDefaultScenario);
  ASSERT_TRUE(parsed.ok()) << parsed.error << " at " << parsed.error_offset;
  ASSERT_EQ(parsed.scenario.size(), 3u);
  EXPECT_EQ(parsed.scenario[1].time_s, 0.5);
  EXPECT_EQ(parsed.scenario[1].magnitude, 0.6);
  EXPECT_EQ(parsed.scenario[2].time_s, 2.0);
  EXPECT_EQ(parsed.scenario[2].angle_deg, 20.0);

  const Scenario& scenario = parsed.scenario;
  EXPECT_EQ(scenario.position_at(0.49).y, 0.0);
  EXPECT_DOUBLE_EQ(scenario.position_at(0.5).y, 0.6);
  EXPECT_DOUBLE_EQ(scenario.position_at(1.99).x, 0.0);
  const JoystickPosition turned = scenario.position_at(2.0);
  EXPECT_NEAR(turned.x, 0.6 * std::sin(deg_to_rad(20.0)), 1e-15);
  EXPECT_NEAR(turned.y, 0.6 * std::cos(deg_to_rad(20.0)), 1e-15);
  EXPECT_EQ(scenario.position_at(100.0).x, turned.x);
}

TEST(Steering, ScenarioParserAcceptsSpacingSignsAndATrailingSeparator) {
  const ScenarioParseResult parsed = parse_scenario("  1e-1 : -30 : 1 ;2:+15.5:0.25;  ");
  ASSERT_TRUE(parsed.ok()) << parsed.error << " at " << parsed.error_offset;
  ASSERT_EQ(parsed.scenario.size(), 2u);
  EXPECT_EQ(parsed.scenario[0].time_s, 0.1);
  EXPECT_EQ(parsed.scenario[0].angle_deg, -30.0);
  EXPECT_EQ(parsed.scenario[1].angle_deg, 15.5);
  // Before the first step the stick is centred.
  EXPECT_EQ(parsed.scenario.position_at(0.05).y, 0.0);
}

TEST(Steering, ScenarioParserRejectsMalformedText) {
  const char* const malformed[] = {
      "",               // nothing
      "   ",            // nothing either
      "0:0",            // two fields
      "0:0:0:0",        // four fields
      "0:0:0;;1:0:0",   // empty step
      ";0:0:0",         // empty first step
      "0:0:0 1:0:0",    // missing separator
      "a:0:0",          // not a number
      "0:0:0.5x",       // trailing junk
      "0:0:nan",        // not finite
      "0:inf:0",        // not finite
      "-1:0:0",         // negative time
      "1:0:0; 0.5:0:0", // time going back
      "1:0:0; 1:10:0",  // time standing still
      "0:190:0.5",      // angle out of range
      "0:0:1.5",        // magnitude out of range
      "0:0:-0.1",       // magnitude out of range
  };
  for (const char* text : malformed) {
    const ScenarioParseResult parsed = parse_scenario(text);
    EXPECT_FALSE(parsed.ok()) << "accepted '" << text << "'";
    EXPECT_FALSE(parsed.error.empty());
    EXPECT_LE(parsed.error_offset, std::string_view(text).size());
  }
  const ScenarioParseResult bad = parse_scenario("0:0:0; 0.5:zero:0.6");
  EXPECT_EQ(bad.error_offset, 11u);  // points at "zero"
}

TEST(Steering, ScenarioParserRejectsTooManySteps) {
  std::string text;
  for (std::size_t i = 0; i <= kMaxScenarioSteps; ++i) text += std::to_string(i) + ":0:0;";
  EXPECT_FALSE(parse_scenario(text).ok());
  text.clear();
  for (std::size_t i = 0; i < kMaxScenarioSteps; ++i) text += std::to_string(i) + ":0:0;";
  EXPECT_TRUE(parse_scenario(text).ok());
}

// ---- Steering: the closed loop -------------------------------------------------------------

TEST(Steering, ClosedLoopDrivesStraightBeforeTheTurn) {
  ClosedLoop loop;
  loop.run_until(0.5);
  EXPECT_EQ(loop.speeds().left_rad_s, 0.0);  // nothing happens while the stick is centred
  double peak = 0.0;
  while (loop.speeds().time_s < 1.9 - kDt / 2) {
    loop.tick();
    peak = std::max(peak, loop.speeds().left_rad_s);
    EXPECT_NEAR(loop.speeds().left_rad_s, loop.speeds().right_rad_s, 1e-9);
    EXPECT_NEAR(loop.speeds().heading_deg, 0.0, 1e-9);
    EXPECT_NEAR(loop.speeds().steering_deg, 0.0, 1e-6);
  }
  const double target = 0.6 * 1.5 / 0.17;  // 0.9 m/s on 0.17 m wheels
  EXPECT_NEAR(loop.speeds().time_s, 1.9, 1e-12);
  EXPECT_NEAR(loop.speeds().left_rad_s, target, 0.01 * target);
  EXPECT_NEAR(loop.speeds().right_rad_s, target, 0.01 * target);
  EXPECT_LT(peak, 1.05 * target);  // well damped: at most 5 % overshoot
}

TEST(Steering, ClosedLoopTurnsRightAfterTheStep) {
  ClosedLoop loop;
  loop.run_until(2.0);
  const double heading_at_turn = loop.speeds().heading_deg;
  EXPECT_NEAR(heading_at_turn, 0.0, 1e-9);

  const ChairGeometry geometry;
  const WheelPair target = wheel_speed_reference({20.0, 0.9}, geometry);
  double previous_heading = heading_at_turn;
  double settled_at = -1.0;
  while (loop.speeds().time_s < 4.0 - kDt / 2) {
    loop.tick();
    const WheelSpeeds& s = loop.speeds();
    if (s.time_s > 2.05) {
      EXPECT_GT(s.left_rad_s, s.right_rad_s) << "t=" << s.time_s;  // outer (left) wheel faster
      EXPECT_GT(s.heading_deg, previous_heading) << "t=" << s.time_s;  // turning clockwise
      EXPECT_GT(s.steering_deg, 0.0);
    }
    previous_heading = s.heading_deg;
    if (std::abs(s.steering_deg - 20.0) > 2.0) settled_at = -1.0;
    else if (settled_at < 0.0) settled_at = s.time_s;
  }
  // The realised steering angle is within 2 degrees of 20 from some time on, and that time
  // is less than 1.5 s after the step.
  ASSERT_GT(settled_at, 0.0);
  EXPECT_LT(settled_at - 2.0, 1.5);
  EXPECT_NEAR(loop.speeds().steering_deg, 20.0, 0.5);
  EXPECT_NEAR(loop.speeds().left_rad_s, target.left, 0.01 * target.left);
  EXPECT_NEAR(loop.speeds().right_rad_s, target.right, 0.01 * target.right);
  // Yaw rate v tan(delta) / L = 31 deg/s once settled: well over 45 degrees in two seconds.
  EXPECT_GT(loop.speeds().heading_deg - heading_at_turn, 45.0);
  EXPECT_LT(loop.speeds().heading_deg - heading_at_turn, 65.0);
}

TEST(Steering, ClosedLoopVoltagesStayWithinSaturation) {
  ClosedLoop loop("0:0:0; 0.2:0:1; 1.5:45:1; 3:-45:1; 4.5:180:1; 6:0:0");
  loop.run_until(8.0);
  EXPECT_LE(loop.max_abs_voltage(), kDefaultVoltageLimitV);
  EXPECT_GT(loop.max_abs_voltage(), 0.99 * kDefaultVoltageLimitV);  // the start does saturate
  // And the chair comes to rest again.
  EXPECT_NEAR(loop.speeds().left_rad_s, 0.0, 0.01);
  EXPECT_NEAR(loop.speeds().right_rad_s, 0.0, 0.01);
}

// ---- WheelchairPlant -----------------------------------------------------------------------

TEST(WheelchairPlant, MatrixExponentialOfKnownMatrices) {
  const double theta = 2.5;
  Eigen::Matrix2d generator;
  generator << 0.0, -theta, theta, 0.0;
  const Eigen::Matrix2d rotation = matrix_exponential<2>(generator);
  EXPECT_NEAR(rotation(0, 0), std::cos(theta), 1e-14);
  EXPECT_NEAR(rotation(1, 0), std::sin(theta), 1e-14);
  Eigen::Matrix3d diagonal = Eigen::Vector3d(-300.0, 0.0, 4.0).asDiagonal();
  const Eigen::Matrix3d exp_diagonal = matrix_exponential<3>(diagonal);
  EXPECT_NEAR(exp_diagonal(0, 0), std::exp(-300.0), 1e-14);
  EXPECT_NEAR(exp_diagonal(1, 1), 1.0, 1e-14);
  EXPECT_NEAR(exp_diagonal(2, 2) / std::exp(4.0), 1.0, 1e-12);  // ten squarings of rounding
}

TEST(WheelchairPlant, ExactStepMatchesFineIntegration) {
  // The ZOH discretisation against RK4 with 1 us substeps over 0.3 s of asymmetric voltages.
  WheelchairPlant plant;
  const MotorVoltages u{18.0, -6.0};
  for (int i = 0; i < 30; ++i) plant.step(u, kDt);

  WheelchairPlant::State x = WheelchairPlant::State::Zero();
  const WheelchairPlant::Input input(u.left_v, u.right_v);
  const auto derivative = [&](const WheelchairPlant::State& state) {
    return WheelchairPlant::State(plant.a() * state + plant.b() * input);
  };
  const double h = 1e-6;
  for (int i = 0; i < 300000; ++i) {
    const WheelchairPlant::State k1 = derivative(x);
    const WheelchairPlant::State k2 = derivative(x + h / 2 * k1);
    const WheelchairPlant::State k3 = derivative(x + h / 2 * k2);
    const WheelchairPlant::State k4 = derivative(x + h * k3);
    x += h / 6 * (k1 + 2 * k2 + 2 * k3 + k4);
  }
  for (int i = 0; i < WheelchairPlant::kStates; ++i) EXPECT_NEAR(plant.state()[i], x[i], 1e-8) << "state " << i;
}

TEST(WheelchairPlant, SteadyStateMatchesTheMotorEquations) {
  const PlantParams params;
  WheelchairPlant plant(params);
  const double volts = 12.0;
  for (int i = 0; i < 500; ++i) plant.step({volts, volts}, kDt);  // 5 s: many time constants
  const double k = params.motor_constant;
  const double speed = k * volts / (k * k + params.armature_resistance_ohm * params.viscous_friction);
  const WheelSpeeds out = plant.output();
  EXPECT_NEAR(out.left_rad_s, speed, 1e-6);
  EXPECT_NEAR(out.right_rad_s, speed, 1e-6);
  EXPECT_NEAR(plant.state()[WheelchairPlant::kCurrentLeft], params.viscous_friction * speed / k, 1e-6);
  EXPECT_NEAR(out.heading_deg, 0.0, 1e-9);
  EXPECT_EQ(out.time_s, 5.0);
  // The documented no-load top speed at the full 24 V: about 1.95 m/s.
  EXPECT_NEAR(2.0 * speed * params.geometry.wheel_radius_m, 1.95, 0.01);
}

TEST(WheelchairPlant, LeftFasterTurnsClockwise) {
  WheelchairPlant plant;
  for (int i = 0; i < 100; ++i) plant.step({12.0, 8.0}, kDt);
  const WheelSpeeds out = plant.output();
  EXPECT_GT(out.left_rad_s, out.right_rad_s);
  EXPECT_GT(out.heading_deg, 0.0);
  EXPECT_GT(out.steering_deg, 0.0);
  // Heading rate r (omega_L - omega_R) / b, integrated: check against the state's own speeds.
  const double rate = 0.17 * (out.left_rad_s - out.right_rad_s) / 0.55 * 180.0 / kPi;
  plant.step({12.0, 8.0}, kDt);
  EXPECT_NEAR(plant.output().heading_deg - out.heading_deg, rate * kDt, 0.01 * rate * kDt);
}

TEST(WheelchairPlant, SpinningOnTheSpotWrapsTheHeading) {
  WheelchairPlant plant;
  double max_abs_heading = 0.0;
  for (int i = 0; i < 2000; ++i) {
    plant.step({12.0, -12.0}, kDt);
    max_abs_heading = std::max(max_abs_heading, std::abs(plant.output().heading_deg));
    EXPECT_GT(plant.output().heading_deg, -180.0);
    EXPECT_LE(plant.output().heading_deg, 180.0);
  }
  EXPECT_GT(max_abs_heading, 170.0);  // it did go round
  EXPECT_NEAR(plant.output().steering_deg, 90.0, 1e-9);
  plant.reset();
  EXPECT_EQ(plant.output().heading_deg, 0.0);
  EXPECT_EQ(plant.output().time_s, 0.0);
}

TEST(WheelchairPlant, InputsAreClampedToTheSupply) {
  WheelchairPlant clamped;
  WheelchairPlant full;
  for (int i = 0; i < 50; ++i) {
    clamped.step({100.0, -100.0}, kDt);
    full.step({24.0, -24.0}, kDt);
  }
  EXPECT_EQ(clamped.output().left_rad_s, full.output().left_rad_s);
  EXPECT_EQ(clamped.output().right_rad_s, full.output().right_rad_s);
}

TEST(WheelchairPlant, ClockIsExactAndSurvivesAPeriodChange) {
  WheelchairPlant plant;
  for (int i = 0; i < 200; ++i) plant.step({}, kDt);
  EXPECT_EQ(plant.time_s(), 2.0);
  for (int i = 0; i < 10; ++i) plant.step({}, 0.005);
  EXPECT_NEAR(plant.time_s(), 2.05, 1e-12);
  plant.step({}, 0.0);  // ignored
  EXPECT_NEAR(plant.time_s(), 2.05, 1e-12);
}

TEST(WheelchairPlant, ValidateRejectsImpossibleParameters) {
  EXPECT_TRUE(validate(PlantParams{}).empty());
  EXPECT_TRUE(validate(ControllerParams{}).empty());
  PlantParams plant;
  plant.armature_inductance_h = 0.0;
  EXPECT_FALSE(validate(plant).empty());
  plant = {};
  plant.geometry.track_m = -0.5;
  EXPECT_FALSE(validate(plant).empty());
  plant = {};
  plant.mass_kg = std::nan("");
  EXPECT_FALSE(validate(plant).empty());
  ControllerParams controller;
  controller.kp = -1.0;
  EXPECT_FALSE(validate(controller).empty());
  controller = {};
  controller.geometry.wheel_radius_m = 0.0;
  EXPECT_FALSE(validate(controller).empty());
}

}  // namespace
}  // namespace polyport::wheelchair
