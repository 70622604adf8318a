// The wheelchair's math, free of the engine so that tests can close the loop without loading
// the plugin: the joystick mapping (JoystickComp), speed-ratio steering control with a PI
// speed loop per wheel (ControlComp), the two-motor differential-drive plant (HWComp), and
// the parser of the joystick scenario the simulated IO board plays.
//
// Sign conventions (the same everywhere, see config/types/wheelchair.idl):
//  - angles are positive clockwise seen from above: a positive steering angle is a right
//    turn, and during a forward right turn the heading grows;
//  - a right turn (delta > 0) needs the left (outer) wheel faster than the right (inner):
//      k = b * tan(delta) / (2 L),  omega_L = v (1 + k) / r,  omega_R = v (1 - k) / r
//    (turning radius of the axle midpoint R = L / tan(delta); b track, L wheelbase,
//    r wheel radius), the heading rate is r (omega_L - omega_R) / b, and the inverse,
//    the steering angle a pair of wheel speeds realises, is
//      delta = atan(2 L (omega_L - omega_R) / (b (omega_L + omega_R))).
//
// Threading and memory: every class here is owned by one component (or test) and used from
// one thread. Nothing allocates after construction: the state lives in fixed-size Eigen
// matrices and std::array; the scenario parser fills a fixed-capacity table.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <string_view>

#include <Eigen/Core>

#include "wheelchair_types.hpp"

namespace polyport::wheelchair {

inline constexpr double kMaxSteeringDeg = 45.0;
inline constexpr double kDefaultMaxSpeedMps = 1.5;
inline constexpr double kDefaultVoltageLimitV = 24.0;
inline constexpr double kDefaultPeriodS = 0.01;  // the paper's 10 ms period
// Below this axle-midpoint speed of both wheels the chair counts as stopped and no steering
// angle is reported (the ratio of two near-zero speeds is noise).
inline constexpr double kStoppedSpeedMps = 0.02;

// A powered wheelchair of the usual rear-wheel-drive size.
struct ChairGeometry {
  double wheel_radius_m = 0.17;  // 13.5-inch drive wheels
  double track_m = 0.55;         // distance between the two drive wheels
  double wheelbase_m = 0.6;      // drive axle to caster axle: the virtual steering geometry
};

// ---- (1) JoystickComp ----------------------------------------------------------------------

// Stick deflection to driver reference. The direction is atan2(x, y) clamped to
// +-max_steering_deg and the speed min(1, |stick|) * max_speed. Deviation from a plain
// atan2(x, y): a stick pulled back (y < 0) drives in reverse, with direction atan2(x, -y),
// so back-right moves the chair towards its back-right; otherwise pulling back would turn at
// full lock while driving forward. Coordinates outside -1..1 are clamped, NaN reads as 0.
Reference joystick_to_reference(const JoystickPosition& position, double max_speed_mps = kDefaultMaxSpeedMps,
                                double max_steering_deg = kMaxSteeringDeg) noexcept;

// ---- (2) ControlComp -----------------------------------------------------------------------

struct WheelPair {
  double left = 0.0;
  double right = 0.0;
};

// Electronic differential: the wheel speeds (rad/s) that drive the axle midpoint at
// reference.speed_mps on a circle of radius L / tan(direction).
WheelPair wheel_speed_reference(const Reference& reference, const ChairGeometry& geometry) noexcept;

// The steering angle (degrees) that a pair of wheel speeds realises; 0 when stopped, +-90
// when spinning on the spot (+90 clockwise). While reversing the sign follows the formula:
// a positive angle then turns the heading anticlockwise, as a car reversing with its
// wheels turned right does.
double realised_steering_deg(double left_rad_s, double right_rad_s, const ChairGeometry& geometry) noexcept;

struct ControllerParams {
  // PI gains of each wheel's speed loop (V per rad/s, V per rad). With the default plant the
  // crossover is near 11 rad/s, so the one period of measurement delay costs only ~6 deg of
  // phase; ki/kp = 5 1/s puts the PI zero just above the mechanical poles (3.8 1/s for
  // driving, 4.2 1/s for turning), which removes the slow integral tail without overshoot
  // to speak of (speed +0.05 %, steering angle +1 % on the 20 deg step).
  double kp = 6.0;
  double ki = 30.0;
  double voltage_limit_v = kDefaultVoltageLimitV;  // the motor drivers' supply
  ChairGeometry geometry;
};

// Returns an empty view when the parameters are usable, else what is wrong.
std::string_view validate(const ControllerParams& params) noexcept;

// Speed-ratio steering control (Fig. 10 of the paper): reference -> wheel speed references
// via the electronic differential, then one PI speed loop per wheel with anti-windup by
// conditional integration (the integral stops growing while the output is saturated in the
// direction the error pushes), outputs saturated at +-voltage_limit_v.
class SpeedRatioController {
 public:
  explicit SpeedRatioController(const ControllerParams& params = {}) noexcept : params_(params) {}

  // One control period. dt <= 0 skips the integration (the proportional part still acts).
  MotorVoltages step(const Reference& reference, const WheelSpeeds& measured, double dt) noexcept;
  void reset() noexcept;

  const ControllerParams& params() const noexcept { return params_; }
  // Takes effect at the next step; the integral is kept in volts, so a gain change does not
  // make the output jump.
  void set_params(const ControllerParams& params) noexcept { params_ = params; }
  const WheelPair& wheel_reference() const noexcept { return wheel_reference_; }

 private:
  ControllerParams params_;
  Eigen::Vector2d integral_v_ = Eigen::Vector2d::Zero();  // integral term, already times ki
  WheelPair wheel_reference_;
};

// ---- (3) HWComp: the plant -----------------------------------------------------------------

// Two 24 V permanent-magnet DC motors, each through a reduction gear to one drive wheel of a
// differential-drive chair. All motor quantities are referred to the wheel axle (through
// the gear ratio), so one constant K is both the back-EMF constant (V s/rad) and the torque
// constant (N m/A) at the wheel. Defaults: a 120 kg chair with occupant, top speed 1.5 m/s
// at about 18 V, no-load 1.95 m/s at 24 V, 40 A stall current.
struct PlantParams {
  double armature_resistance_ohm = 0.6;
  double armature_inductance_h = 0.002;  // 3.3 ms electrical time constant
  double motor_constant = 2.0;           // V s/rad = N m/A, at the wheel
  double drive_inertia_kg_m2 = 0.12;     // rotor and gears (times ratio^2) plus wheel
  double viscous_friction = 0.3;         // N m s/rad per wheel: gears, bearings, rolling
  double mass_kg = 120.0;                // chair and occupant
  double yaw_inertia_kg_m2 = 8.0;        // about the vertical axis through the axle midpoint
  double voltage_limit_v = kDefaultVoltageLimitV;  // inputs are clamped to the supply
  ChairGeometry geometry;
};

// Returns an empty view when the parameters are usable, else what is wrong.
std::string_view validate(const PlantParams& params) noexcept;

// exp(m) by scaling and squaring with a Taylor series; fixed-size, so no allocation.
template <int N>
Eigen::Matrix<double, N, N> matrix_exponential(const Eigen::Matrix<double, N, N>& m) noexcept;

// The chair as a linear system x' = A x + B u with
//   x = [i_L, i_R, omega_L, omega_R, heading],  u = [u_L, u_R]:
//   La di/dt = u - Ra i - K omega                                   (each armature)
//   M domega/dt = K i - c omega                                     (both wheels at once)
//   dheading/dt = r (omega_L - omega_R) / b
// M is the 2x2 inertia matrix seen at the wheels: the drive inertia on the diagonal plus
// the chair's mass and yaw inertia through v = r (omega_L + omega_R) / 2 and
// yaw rate = r (omega_L - omega_R) / b:
//   M = [[J + m r^2/4 + Iz r^2/b^2, m r^2/4 - Iz r^2/b^2], [same, transposed]].
// (With Iz = m (b/2)^2 it is diagonal: each wheel carries half the mass, J + m r^2 / 2.)
// The motor drivers hold the voltage over a period, so the plant is discretised exactly for
// a zero-order-hold input: [Ad Bd; 0 I] = exp([A B; 0 0] dt), computed once per distinct dt
// (in the first step, and again only if the period changes). One step is then
// x <- Ad x + Bd u, exact for any dt and free of the stiffness of the 3 ms armature.
// The heading is wrapped to (-pi, pi] after each step; nothing depends on it.
class WheelchairPlant {
 public:
  static constexpr int kStates = 5;
  static constexpr int kInputs = 2;
  enum StateIndex : int { kCurrentLeft = 0, kCurrentRight, kSpeedLeft, kSpeedRight, kHeading };
  using State = Eigen::Matrix<double, kStates, 1>;
  using Input = Eigen::Matrix<double, kInputs, 1>;
  using StateMatrix = Eigen::Matrix<double, kStates, kStates>;
  using InputMatrix = Eigen::Matrix<double, kStates, kInputs>;

  // The parameters should pass validate(); invalid ones give a meaningless (but finite when
  // possible) plant rather than a crash.
  explicit WheelchairPlant(const PlantParams& params = {}) noexcept;

  // Advances the plant by dt seconds with the voltages held; dt <= 0 does nothing.
  void step(const MotorVoltages& voltages, double dt) noexcept;
  // Back to rest at heading 0, time 0.
  void reset() noexcept;

  // Wheel speeds, heading, realised steering angle and time, as HWComp publishes them.
  WheelSpeeds output() const noexcept;
  double time_s() const noexcept { return time_base_s_ + static_cast<double>(steps_since_base_) * dt_; }
  const State& state() const noexcept { return x_; }
  const PlantParams& params() const noexcept { return params_; }
  const StateMatrix& a() const noexcept { return a_; }
  const InputMatrix& b() const noexcept { return b_; }

 private:
  void discretise(double dt) noexcept;

  PlantParams params_;
  StateMatrix a_ = StateMatrix::Zero();
  InputMatrix b_ = InputMatrix::Zero();
  StateMatrix ad_ = StateMatrix::Identity();
  InputMatrix bd_ = InputMatrix::Zero();
  State x_ = State::Zero();
  double dt_ = 0.0;  // the step Ad/Bd were computed for
  // The clock counts steps of the current dt from a base, so 10 ms steps do not accumulate
  // rounding (t = 2.0 at step 200 exactly, where the default scenario turns).
  double time_base_s_ = 0.0;
  std::int64_t steps_since_base_ = 0;
};

// ---- The scripted joystick of HWComp -------------------------------------------------------

inline constexpr std::string_view kDefaultScenario = "0:0:0; 0.5:0:0.6; 2.0:20:0.6";
inline constexpr std::size_t kMaxScenarioSteps = 64;

// From time_s on, the stick is held at angle_deg (clockwise from forward) with the given
// magnitude: x = magnitude sin(angle), y = magnitude cos(angle).
struct ScenarioStep {
  double time_s = 0.0;
  double angle_deg = 0.0;
  double magnitude = 0.0;
};

class Scenario {
 public:
  // The stick position at time t: the last step whose time is <= t (with a nanosecond of
  // slack for clock rounding), centred before the first step.
  JoystickPosition position_at(double time_s) const noexcept;

  std::size_t size() const noexcept { return count_; }
  bool empty() const noexcept { return count_ == 0; }
  const ScenarioStep& operator[](std::size_t index) const noexcept { return steps_[index]; }
  // False when full.
  bool push_back(const ScenarioStep& step) noexcept;

 private:
  std::array<ScenarioStep, kMaxScenarioSteps> steps_{};
  std::size_t count_ = 0;
};

struct ScenarioParseResult {
  Scenario scenario;
  std::string_view error;    // empty on success; a static string otherwise
  std::size_t error_offset = 0;  // where in the text the problem is
  bool ok() const noexcept { return error.empty(); }
  explicit operator bool() const noexcept { return ok(); }
};

// Parses "time_s:angle_deg:magnitude; ..." (whitespace allowed around every token, one
// trailing ';' allowed). Every step needs three finite numbers; times >= 0 and strictly
// increasing, angles within +-180, magnitudes within 0..1; 1..kMaxScenarioSteps steps.
ScenarioParseResult parse_scenario(std::string_view text) noexcept;

// ---- Template definitions ------------------------------------------------------------------

template <int N>
Eigen::Matrix<double, N, N> matrix_exponential(const Eigen::Matrix<double, N, N>& m) noexcept {
  using Matrix = Eigen::Matrix<double, N, N>;
  // Scale so that the 1-norm is at most 0.5; then 18 Taylor terms leave a truncation error
  // below 0.5^19 / 19! ~ 1e-23, far under double rounding, and squaring undoes the scaling.
  const double norm = m.cwiseAbs().colwise().sum().maxCoeff();
  int squarings = 0;
  while (norm / static_cast<double>(std::int64_t{1} << squarings) > 0.5 && squarings < 60) ++squarings;
  const Matrix scaled = m / static_cast<double>(std::int64_t{1} << squarings);
  Matrix result = Matrix::Identity();
  Matrix term = Matrix::Identity();
  for (int k = 1; k <= 18; ++k) {
    term = (term * scaled) / static_cast<double>(k);
    result += term;
  }
  for (int i = 0; i < squarings; ++i) result = result * result;
  return result;
}

}  // namespace polyport::wheelchair
