// The youBot case's port types (config/types/youbot.idl) as the components' C++ structs: the
// same fields in the same order, so that they have the flat layout polyport gives the IDL
// types (the engine checks size and alignment when it loads the plugin).
#pragma once

#include <cstddef>
#include <cstdint>

namespace polyport::youbot {

inline constexpr std::size_t kArmJoints = 5;

struct JointPositions {
  double rad[kArmJoints];
};

struct BaseVelocity {
  double vx_mps;
  double vy_mps;
  double wz_rad_s;
};

struct JointQuery {
  std::uint32_t query_id;
};

struct JointReply {
  std::uint32_t query_id;
  double rad[kArmJoints];
  bool moving;
  std::uint64_t cycle;
};

struct Period {
  double seconds;
};

struct State {
  std::uint64_t cycle;
  std::int64_t stamp_ns;
  double period_s;
  double joints_rad[kArmJoints];
  double targets_rad[kArmJoints];
  double base_x_m;
  double base_y_m;
  double base_yaw_rad;
  BaseVelocity base_velocity;
  bool moving;
};

struct MonitorReport {
  std::uint32_t phase;
  std::uint64_t busy;
  std::uint64_t idle;
  std::uint64_t refresh;
  std::uint64_t states;
  std::uint32_t queries;
  double queried_rad[kArmJoints];
  double commanded_rad[kArmJoints];
  double rate_before_hz;
  double rate_after_hz;
  double period_before_s;
  double period_after_s;
};

static_assert(sizeof(State) == 160);
static_assert(sizeof(JointReply) == 64);

}  // namespace polyport::youbot
