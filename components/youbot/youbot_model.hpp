// The simulated youBot and the monitor's script, shared by the in-process components
// (youbot_components.cpp) and the Cyclone DDS programs (native/youbot_dds_node.cpp), which
// use no polyport code: plain structs of doubles, no allocation.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>

namespace polyport::youbot::model {

inline constexpr std::size_t kJoints = 5;
inline constexpr double kDefaultMaxJointSpeed = 0.8;  // rad/s
// The monitor's scripted motion: pose A, then back to pose B at the new period.
inline constexpr double kPoseA[kJoints] = {0.5, -0.4, 0.8, -0.3, 1.0};
inline constexpr double kPoseB[kJoints] = {-0.2, 0.3, -0.5, 0.4, 0.0};
inline constexpr double kBaseVelocity[3] = {0.2, 0.0, 0.1};  // vx m/s, vy m/s, wz rad/s
// How close a queried joint must be to its set position for the monitor to call it arrived.
inline constexpr double kTolerance = 1e-6;

// The arm: each joint moves toward its set position at most max_speed * dt per step and stops
// exactly on it.
struct Arm {
  double position[kJoints] = {};
  double target[kJoints] = {};
  double max_speed = kDefaultMaxJointSpeed;

  bool moving() const noexcept {
    for (std::size_t j = 0; j < kJoints; ++j) {
      if (position[j] != target[j]) return true;
    }
    return false;
  }
  void step(double dt) noexcept {
    const double reach = max_speed * dt;
    for (std::size_t j = 0; j < kJoints; ++j) {
      const double error = target[j] - position[j];
      position[j] = std::fabs(error) <= reach ? target[j] : position[j] + std::copysign(reach, error);
    }
  }
};

// The omnidirectional base: its pose integrated from a velocity in its own frame.
struct Base {
  double x = 0.0, y = 0.0, yaw = 0.0;
  double vx = 0.0, vy = 0.0, wz = 0.0;

  void step(double dt) noexcept {
    const double c = std::cos(yaw), s = std::sin(yaw);
    x += (vx * c - vy * s) * dt;
    y += (vx * s + vy * c) * dt;
    yaw = std::remainder(yaw + wz * dt, 2.0 * M_PI);
  }
};

// Cycles per second of the driver, from its states' cycle numbers and stamps: one estimate
// for the first period the states report, one for the period after it changed.
class RateMeter {
 public:
  void add(std::uint64_t cycle, std::int64_t stamp_ns, double period_s) noexcept {
    if (!first_.seen) {
      period_before_ = period_s;
    }
    Window& w = period_s == period_before_ ? first_ : second_;
    if (&w == &second_ && !second_.seen) period_after_ = period_s;
    if (&w == &second_ && period_s != period_after_) return;  // a third period: not measured
    if (!w.seen) {
      w.seen = true;
      w.first_cycle = cycle;
      w.first_ns = stamp_ns;
    }
    w.last_cycle = cycle;
    w.last_ns = stamp_ns;
  }
  double rate_before_hz() const noexcept { return first_.rate(); }
  double rate_after_hz() const noexcept { return second_.rate(); }
  double period_before_s() const noexcept { return period_before_; }
  double period_after_s() const noexcept { return period_after_; }
  bool changed() const noexcept { return second_.seen; }
  // States seen at the new period, past the first.
  std::uint64_t cycles_after() const noexcept { return second_.seen ? second_.last_cycle - second_.first_cycle : 0; }

 private:
  struct Window {
    bool seen = false;
    std::uint64_t first_cycle = 0, last_cycle = 0;
    std::int64_t first_ns = 0, last_ns = 0;
    double rate() const noexcept {
      if (!seen || last_ns <= first_ns) return 0.0;
      return static_cast<double>(last_cycle - first_cycle) * 1e9 / static_cast<double>(last_ns - first_ns);
    }
  };
  Window first_, second_;
  double period_before_ = 0.0, period_after_ = 0.0;
};

}  // namespace polyport::youbot::model

namespace polyport::youbot::model {

// The monitor's scripted motion, the same in-process and as a DDS program: set the base moving
// and the arm to pose A; once the driver said busy then idle and a query finds every joint on
// pose A, ask for the new period and send the arm to pose B; once busy, idle, a query on pose
// B and a few states at the new period came, stop the base. The caller feeds in what it
// receives and carries out the actions step() returns, once per cycle.
class MonitorScript {
 public:
  enum Kind : std::int32_t { kBusy = 0, kIdle = 1, kRefresh = 2 };
  struct Actions {
    bool set_base = false;
    double base[3] = {};
    bool set_joints = false;
    double joints[kJoints] = {};
    bool set_period = false;
    double period_s = 0.0;
    bool query = false;        // ask getJointPositions (when no query is outstanding)
    bool phase_changed = false;
  };
  static constexpr std::uint64_t kStatesAfterChange = 5;
  // One-way commands may be lost (a DDS driver not matched yet): a command that brought no
  // busy within this many steps (a second at the monitor's 20 ms) is sent again.
  static constexpr std::uint32_t kResendAfterSteps = 50;

  explicit MonitorScript(double new_period_s) : new_period_s_(new_period_s) {}

  void on_state(std::uint64_t cycle, std::int64_t stamp_ns, double period_s) noexcept {
    ++states_;
    meter_.add(cycle, stamp_ns, period_s);
  }
  void on_notification(std::int32_t kind) noexcept {
    if (kind == kBusy) {
      ++busy_;
      busy_seen_ = true;
    } else if (kind == kIdle) {
      ++idle_;
      if (busy_seen_) idle_seen_ = true;
    } else if (kind == kRefresh) {
      ++refresh_;
    }
  }
  void on_reply(const double rad[kJoints], bool moving) noexcept {
    ++queries_;
    bool there = !moving;
    for (std::size_t j = 0; j < kJoints; ++j) {
      queried_[j] = rad[j];
      there = there && std::fabs(rad[j] - commanded_[j]) <= kTolerance;
    }
    arrived_ = arrived_ || (idle_seen_ && there);
  }

  Actions step() noexcept {
    Actions a;
    if (!started_) {
      started_ = true;
      a.set_base = true;
      for (int i = 0; i < 3; ++i) a.base[i] = kBaseVelocity[i];
      command(a, kPoseA);
      a.phase_changed = true;
      return a;
    }
    if (phase_ >= 2) return a;
    if (!busy_seen_ && ++steps_without_busy_ >= kResendAfterSteps) {
      steps_without_busy_ = 0;
      a.set_base = phase_ == 0;
      for (int i = 0; i < 3; ++i) a.base[i] = kBaseVelocity[i];
      a.set_period = phase_ == 1;
      a.period_s = new_period_s_;
      a.set_joints = true;
      for (std::size_t j = 0; j < kJoints; ++j) a.joints[j] = commanded_[j];
      return a;
    }
    if (!arrived_) {
      a.query = idle_seen_;
      return a;
    }
    if (phase_ == 0) {
      phase_ = 1;
      a.set_period = true;
      a.period_s = new_period_s_;
      command(a, kPoseB);
      a.phase_changed = true;
    } else if (meter_.cycles_after() >= kStatesAfterChange) {
      phase_ = 2;
      a.set_base = true;  // stop
      a.phase_changed = true;
    }
    return a;
  }

  std::uint32_t phase() const noexcept { return phase_; }
  std::uint64_t busy() const noexcept { return busy_; }
  std::uint64_t idle() const noexcept { return idle_; }
  std::uint64_t refresh() const noexcept { return refresh_; }
  std::uint64_t states() const noexcept { return states_; }
  std::uint32_t queries() const noexcept { return queries_; }
  const double* queried() const noexcept { return queried_; }
  const double* commanded() const noexcept { return commanded_; }
  const RateMeter& meter() const noexcept { return meter_; }

 private:
  void command(Actions& a, const double (&pose)[kJoints]) noexcept {
    a.set_joints = true;
    for (std::size_t j = 0; j < kJoints; ++j) a.joints[j] = commanded_[j] = pose[j];
    busy_seen_ = idle_seen_ = arrived_ = false;
    steps_without_busy_ = 0;
  }

  double new_period_s_;
  bool started_ = false;
  std::uint32_t phase_ = 0;
  bool busy_seen_ = false, idle_seen_ = false, arrived_ = false;
  std::uint32_t steps_without_busy_ = 0;
  std::uint64_t busy_ = 0, idle_ = 0, refresh_ = 0, states_ = 0;
  std::uint32_t queries_ = 0;
  double queried_[kJoints] = {};
  double commanded_[kJoints] = {};
  RateMeter meter_;
};

}  // namespace polyport::youbot::model
