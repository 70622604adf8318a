// C++ mirrors of the port types in config/types/wheelchair.idl. The engine checks each port's
// sizeof/alignof against the flat layout it computes from the IDL, so every struct here must
// keep the IDL's field order and types: flat doubles, no padding, trivially copyable.
// Units and sign conventions are documented in the IDL file.
#pragma once

#include <type_traits>

namespace polyport::wheelchair {

struct JoystickPosition {
  double x = 0.0;  // normalized -1..1, positive to the right
  double y = 0.0;  // normalized -1..1, positive forward
};

struct Reference {
  double direction_deg = 0.0;  // steering angle, positive = right turn
  double speed_mps = 0.0;      // axle-midpoint speed, negative = reversing
};

struct WheelSpeeds {
  double left_rad_s = 0.0;
  double right_rad_s = 0.0;
  double heading_deg = 0.0;   // clockwise, wrapped to (-180, 180]
  double steering_deg = 0.0;  // realised by the current wheel speed ratio
  double time_s = 0.0;
};

struct EncoderSpeeds {
  double left_rad_s = 0.0;
  double right_rad_s = 0.0;
};

struct MotorVoltages {
  double left_v = 0.0;
  double right_v = 0.0;
};

// The flat layout of an IDL struct of n doubles is n * 8 bytes, aligned to 8.
static_assert(sizeof(JoystickPosition) == 2 * sizeof(double) && alignof(JoystickPosition) == alignof(double));
static_assert(sizeof(Reference) == 2 * sizeof(double) && alignof(Reference) == alignof(double));
static_assert(sizeof(WheelSpeeds) == 5 * sizeof(double) && alignof(WheelSpeeds) == alignof(double));
static_assert(sizeof(EncoderSpeeds) == 2 * sizeof(double) && alignof(EncoderSpeeds) == alignof(double));
static_assert(sizeof(MotorVoltages) == 2 * sizeof(double) && alignof(MotorVoltages) == alignof(double));
static_assert(std::is_trivially_copyable_v<JoystickPosition> && std::is_trivially_copyable_v<Reference> &&
              std::is_trivially_copyable_v<WheelSpeeds> && std::is_trivially_copyable_v<MotorVoltages>);

}  // namespace polyport::wheelchair
