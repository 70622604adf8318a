// The wheelchair's math; see steering.hpp for the model, the parameters and the sign
// conventions. Runs on the calling component's thread; nothing here allocates.
#include "steering.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <numbers>

#include <Eigen/LU>  // Matrix2d::inverse

namespace polyport::wheelchair {
namespace {

constexpr double kDegPerRad = 180.0 / std::numbers::pi;
constexpr double kRadPerDeg = std::numbers::pi / 180.0;

double finite_or_zero(double value) noexcept { return std::isfinite(value) ? value : 0.0; }

bool positive(double value) noexcept { return std::isfinite(value) && value > 0.0; }
bool non_negative(double value) noexcept { return std::isfinite(value) && value >= 0.0; }

std::string_view validate_geometry(const ChairGeometry& geometry) noexcept {
  if (!positive(geometry.wheel_radius_m)) return "wheel_radius must be > 0";
  if (!positive(geometry.track_m)) return "track must be > 0";
  if (!positive(geometry.wheelbase_m)) return "wheelbase must be > 0";
  return {};
}

}  // namespace

Reference joystick_to_reference(const JoystickPosition& position, double max_speed_mps,
                                double max_steering_deg) noexcept {
  const double x = std::clamp(finite_or_zero(position.x), -1.0, 1.0);
  const double y = std::clamp(finite_or_zero(position.y), -1.0, 1.0);
  const double magnitude = std::min(1.0, std::hypot(x, y));
  // Reversing mirrors the forward mapping about the x axis (see the header).
  const bool reverse = y < 0.0;
  const double direction_deg = std::atan2(x, reverse ? -y : y) * kDegPerRad;
  const double limit = std::abs(finite_or_zero(max_steering_deg));
  const double speed = magnitude * finite_or_zero(max_speed_mps);
  return Reference{std::clamp(direction_deg, -limit, limit), reverse ? -speed : speed};
}

WheelPair wheel_speed_reference(const Reference& reference, const ChairGeometry& geometry) noexcept {
  const double delta = std::clamp(finite_or_zero(reference.direction_deg), -kMaxSteeringDeg, kMaxSteeringDeg) *
                       kRadPerDeg;
  const double v = finite_or_zero(reference.speed_mps);
  // k = b tan(delta) / (2 L): the outer wheel runs (1 + k) times, the inner (1 - k) times
  // the midpoint speed, which keeps both on circles about the same centre without slip.
  const double k = geometry.track_m * std::tan(delta) / (2.0 * geometry.wheelbase_m);
  return WheelPair{v * (1.0 + k) / geometry.wheel_radius_m, v * (1.0 - k) / geometry.wheel_radius_m};
}

double realised_steering_deg(double left_rad_s, double right_rad_s, const ChairGeometry& geometry) noexcept {
  const double stopped_rad_s = kStoppedSpeedMps / geometry.wheel_radius_m;
  if (!(std::abs(left_rad_s) >= stopped_rad_s || std::abs(right_rad_s) >= stopped_rad_s)) return 0.0;
  const double sum = left_rad_s + right_rad_s;
  const double difference = left_rad_s - right_rad_s;
  // atan(2L diff / (b sum)) written as atan2 with a non-negative second argument: the same
  // value, but defined (+-90 deg) when the wheels turn against each other on the spot. The
  // sign of sum is trusted only while the midpoint really moves; spinning on the spot, it is
  // rounding noise, so the angle follows the rotation (clockwise = +90) instead of flickering.
  const bool reversing = sum * geometry.wheel_radius_m / 2.0 < -kStoppedSpeedMps;
  const double sign = reversing ? -1.0 : 1.0;
  return std::atan2(2.0 * geometry.wheelbase_m * difference * sign, geometry.track_m * std::abs(sum)) * kDegPerRad;
}

std::string_view validate(const ControllerParams& params) noexcept {
  if (!non_negative(params.kp)) return "kp must be >= 0";
  if (!non_negative(params.ki)) return "ki must be >= 0";
  if (!positive(params.voltage_limit_v)) return "voltage_limit must be > 0";
  return validate_geometry(params.geometry);
}

MotorVoltages SpeedRatioController::step(const Reference& reference, const WheelSpeeds& measured,
                                         double dt) noexcept {
  wheel_reference_ = wheel_speed_reference(reference, params_.geometry);
  const Eigen::Vector2d error(wheel_reference_.left - finite_or_zero(measured.left_rad_s),
                              wheel_reference_.right - finite_or_zero(measured.right_rad_s));
  const double limit = params_.voltage_limit_v;
  Eigen::Vector2d output = params_.kp * error + integral_v_;
  if (dt > 0.0 && std::isfinite(dt)) {
    for (int wheel = 0; wheel < 2; ++wheel) {
      const double increment = params_.ki * error[wheel] * dt;
      // Conditional integration: while the output is saturated, integrate only errors that
      // pull it back, so the integral does not wind up during a long saturated start.
      const double unsaturated = output[wheel] + increment;
      const bool winding_up = std::abs(unsaturated) > limit && unsaturated * increment > 0.0;
      if (!winding_up) {
        integral_v_[wheel] = std::clamp(integral_v_[wheel] + increment, -limit, limit);
        output[wheel] = params_.kp * error[wheel] + integral_v_[wheel];
      }
    }
  }
  return MotorVoltages{std::clamp(output[0], -limit, limit), std::clamp(output[1], -limit, limit)};
}

void SpeedRatioController::reset() noexcept {
  integral_v_.setZero();
  wheel_reference_ = {};
}

std::string_view validate(const PlantParams& params) noexcept {
  if (!positive(params.armature_resistance_ohm)) return "armature_resistance must be > 0";
  if (!positive(params.armature_inductance_h)) return "armature_inductance must be > 0";
  if (!positive(params.motor_constant)) return "motor_constant must be > 0";
  if (!non_negative(params.drive_inertia_kg_m2)) return "drive_inertia must be >= 0";
  if (!non_negative(params.viscous_friction)) return "viscous_friction must be >= 0";
  if (!positive(params.mass_kg)) return "mass must be > 0";
  if (!positive(params.yaw_inertia_kg_m2)) return "yaw_inertia must be > 0";
  if (!positive(params.voltage_limit_v)) return "voltage_limit must be > 0";
  return validate_geometry(params.geometry);
}

WheelchairPlant::WheelchairPlant(const PlantParams& params) noexcept : params_(params) {
  const double ra = params.armature_resistance_ohm;
  const double la = params.armature_inductance_h;
  const double k = params.motor_constant;
  const double r = params.geometry.wheel_radius_m;
  const double b = params.geometry.track_m;

  const double translation = params.mass_kg * r * r / 4.0;
  const double rotation = params.yaw_inertia_kg_m2 * r * r / (b * b);
  Eigen::Matrix2d inertia;
  inertia << params.drive_inertia_kg_m2 + translation + rotation, translation - rotation,
      translation - rotation, params.drive_inertia_kg_m2 + translation + rotation;
  const Eigen::Matrix2d inertia_inverse = inertia.inverse();

  for (int wheel = 0; wheel < 2; ++wheel) {
    a_(kCurrentLeft + wheel, kCurrentLeft + wheel) = -ra / la;
    a_(kCurrentLeft + wheel, kSpeedLeft + wheel) = -k / la;
    b_(kCurrentLeft + wheel, wheel) = 1.0 / la;
  }
  a_.block<2, 2>(kSpeedLeft, kCurrentLeft) = k * inertia_inverse;
  a_.block<2, 2>(kSpeedLeft, kSpeedLeft) = -params.viscous_friction * inertia_inverse;
  a_(kHeading, kSpeedLeft) = r / b;
  a_(kHeading, kSpeedRight) = -r / b;
}

void WheelchairPlant::discretise(double dt) noexcept {
  constexpr int kAugmented = kStates + kInputs;
  Eigen::Matrix<double, kAugmented, kAugmented> augmented = Eigen::Matrix<double, kAugmented, kAugmented>::Zero();
  augmented.topLeftCorner<kStates, kStates>() = a_ * dt;
  augmented.topRightCorner<kStates, kInputs>() = b_ * dt;
  const Eigen::Matrix<double, kAugmented, kAugmented> phi = matrix_exponential<kAugmented>(augmented);
  ad_ = phi.topLeftCorner<kStates, kStates>();
  bd_ = phi.topRightCorner<kStates, kInputs>();
  // Keep the clock continuous across a change of period.
  time_base_s_ = time_s();
  steps_since_base_ = 0;
  dt_ = dt;
}

void WheelchairPlant::step(const MotorVoltages& voltages, double dt) noexcept {
  if (!(dt > 0.0) || !std::isfinite(dt)) return;
  if (dt != dt_) discretise(dt);
  const double limit = params_.voltage_limit_v;
  const Input u(std::clamp(finite_or_zero(voltages.left_v), -limit, limit),
                std::clamp(finite_or_zero(voltages.right_v), -limit, limit));
  x_ = ad_ * x_ + bd_ * u;
  x_[kHeading] = std::remainder(x_[kHeading], 2.0 * std::numbers::pi);
  if (x_[kHeading] <= -std::numbers::pi) x_[kHeading] += 2.0 * std::numbers::pi;
  ++steps_since_base_;
}

void WheelchairPlant::reset() noexcept {
  x_.setZero();
  time_base_s_ = 0.0;
  steps_since_base_ = 0;
}

WheelSpeeds WheelchairPlant::output() const noexcept {
  const double left = x_[kSpeedLeft];
  const double right = x_[kSpeedRight];
  return WheelSpeeds{left, right, x_[kHeading] * kDegPerRad,
                     realised_steering_deg(left, right, params_.geometry), time_s()};
}

JoystickPosition Scenario::position_at(double time_s) const noexcept {
  constexpr double kSlackS = 1e-9;
  const ScenarioStep* current = nullptr;
  for (std::size_t i = 0; i < count_ && steps_[i].time_s <= time_s + kSlackS; ++i) current = &steps_[i];
  if (current == nullptr) return {};
  const double angle = current->angle_deg * kRadPerDeg;
  return JoystickPosition{current->magnitude * std::sin(angle), current->magnitude * std::cos(angle)};
}

bool Scenario::push_back(const ScenarioStep& step) noexcept {
  if (count_ == steps_.size()) return false;
  steps_[count_++] = step;
  return true;
}

namespace {

bool is_space(char c) noexcept { return c == ' ' || c == '\t' || c == '\n' || c == '\r'; }

// A cursor over the scenario text that remembers where it failed.
class ScenarioReader {
 public:
  explicit ScenarioReader(std::string_view text) noexcept : text_(text) {}

  void skip_spaces() noexcept {
    while (pos_ < text_.size() && is_space(text_[pos_])) ++pos_;
  }
  bool at_end() noexcept {
    skip_spaces();
    return pos_ == text_.size();
  }
  bool accept(char c) noexcept {
    skip_spaces();
    if (pos_ < text_.size() && text_[pos_] == c) {
      ++pos_;
      return true;
    }
    return false;
  }
  bool number(double& value) noexcept {
    skip_spaces();
    const char* first = text_.data() + pos_;
    const char* last = text_.data() + text_.size();
    if (first != last && *first == '+') ++first;  // from_chars rejects a leading '+'
    const auto [end, ec] = std::from_chars(first, last, value);
    if (ec != std::errc{} || !std::isfinite(value)) return false;
    pos_ = static_cast<std::size_t>(end - text_.data());
    return true;
  }
  std::size_t position() const noexcept { return pos_; }

 private:
  std::string_view text_;
  std::size_t pos_ = 0;
};

}  // namespace

ScenarioParseResult parse_scenario(std::string_view text) noexcept {
  ScenarioParseResult result;
  ScenarioReader reader(text);
  const auto fail = [&](std::string_view message, std::size_t offset) {
    result.error = message;
    result.error_offset = offset;
    return result;
  };
  if (reader.at_end()) return fail("empty scenario", reader.position());
  while (!reader.at_end()) {
    ScenarioStep step;
    reader.skip_spaces();
    const std::size_t start = reader.position();
    if (!reader.number(step.time_s)) return fail("expected a time in seconds", reader.position());
    if (!reader.accept(':')) return fail("expected ':' after the time", reader.position());
    if (!reader.number(step.angle_deg)) return fail("expected an angle in degrees", reader.position());
    if (!reader.accept(':')) return fail("expected ':' after the angle", reader.position());
    if (!reader.number(step.magnitude)) return fail("expected a magnitude", reader.position());
    if (step.time_s < 0.0) return fail("time must be >= 0", start);
    if (!result.scenario.empty() && step.time_s <= result.scenario[result.scenario.size() - 1].time_s) {
      return fail("times must be strictly increasing", start);
    }
    if (std::abs(step.angle_deg) > 180.0) return fail("angle must be within -180..180 degrees", start);
    if (step.magnitude < 0.0 || step.magnitude > 1.0) return fail("magnitude must be within 0..1", start);
    if (!result.scenario.push_back(step)) return fail("too many steps", start);
    if (reader.at_end()) break;
    if (!reader.accept(';')) return fail("expected ';' between steps", reader.position());
  }
  return result;
}

}  // namespace polyport::wheelchair
