// The wheelchair's three CAN frames (config/types/wheelchair_can.dbc) packed and unpacked by
// hand, for the programs that own a raw CAN socket without polyport: the bus simulator
// (wheelchair_sim) and the HW node of the native DDS configuration. Every signal is a
// little-endian signed 16-bit raw value times its factor; packing rounds to nearest and
// saturates at the raw range. A unit test checks these against polyport's DBC codec, so the
// file and the DBC cannot drift apart.
//
// Header-only, no allocation, no state.
#pragma once

#include <array>
#include <cmath>
#include <cstdint>

#include "wheelchair_types.hpp"

namespace polyport::wheelchair::can {

inline constexpr std::uint32_t kJoystickId = 0x101;  // IOBoard -> Controller
inline constexpr std::uint32_t kEncoderId = 0x181;   // DSPBoard -> Controller
inline constexpr std::uint32_t kVoltagesId = 0x201;  // Controller -> DSPBoard
inline constexpr std::uint8_t kLength = 4;           // every frame: two 16-bit signals

inline constexpr double kJoystickFactor = 0.0001;
inline constexpr double kEncoderFactor = 0.001;  // rad/s
inline constexpr double kVoltageFactor = 0.01;   // V

using Payload = std::array<std::uint8_t, kLength>;

inline std::int16_t to_raw(double value, double factor) noexcept {
  const double raw = std::nearbyint(value / factor);
  if (!(raw > -32768.0)) return raw != raw ? 0 : -32768;  // NaN packs as 0
  if (raw > 32767.0) return 32767;
  return static_cast<std::int16_t>(raw);
}

inline double from_raw(std::uint8_t low, std::uint8_t high, double factor) noexcept {
  const auto raw = static_cast<std::int16_t>(static_cast<std::uint16_t>(low | (high << 8)));
  return static_cast<double>(raw) * factor;
}

inline Payload pack_pair(double first, double second, double factor) noexcept {
  const auto a = static_cast<std::uint16_t>(to_raw(first, factor));
  const auto b = static_cast<std::uint16_t>(to_raw(second, factor));
  return {static_cast<std::uint8_t>(a & 0xff), static_cast<std::uint8_t>(a >> 8),
          static_cast<std::uint8_t>(b & 0xff), static_cast<std::uint8_t>(b >> 8)};
}

inline Payload pack(const JoystickPosition& p) noexcept { return pack_pair(p.x, p.y, kJoystickFactor); }
inline Payload pack(const EncoderSpeeds& s) noexcept {
  return pack_pair(s.left_rad_s, s.right_rad_s, kEncoderFactor);
}
inline Payload pack(const MotorVoltages& v) noexcept { return pack_pair(v.left_v, v.right_v, kVoltageFactor); }

// `data` holds at least kLength bytes.
inline JoystickPosition unpack_joystick(const std::uint8_t* data) noexcept {
  return {from_raw(data[0], data[1], kJoystickFactor), from_raw(data[2], data[3], kJoystickFactor)};
}
inline EncoderSpeeds unpack_encoders(const std::uint8_t* data) noexcept {
  return {from_raw(data[0], data[1], kEncoderFactor), from_raw(data[2], data[3], kEncoderFactor)};
}
inline MotorVoltages unpack_voltages(const std::uint8_t* data) noexcept {
  return {from_raw(data[0], data[1], kVoltageFactor), from_raw(data[2], data[3], kVoltageFactor)};
}

}  // namespace polyport::wheelchair::can
