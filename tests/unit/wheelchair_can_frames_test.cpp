// The wheelchair's hand-packed CAN frames (components/wheelchair/can_frames.hpp, used by
// wheelchair_sim and the native DDS HW node) against polyport's DBC codec on the shipped
// config/types/wheelchair_can.dbc: same ids, lengths and values both ways, so the programs
// without polyport and polyport's CAN proxy agree on the bus.
#include <gtest/gtest.h>

#include <array>
#include <cstring>
#include <string>

#include "can_frames.hpp"
#include "polyport/codecs/codec.hpp"
#include "polyport/types/dbc.hpp"
#include "polyport/types/types.hpp"

namespace polyport {
namespace {

namespace can = wheelchair::can;

class WheelchairCanFrames : public ::testing::Test {
 protected:
  void SetUp() override {
    Diagnostics d;
    ASSERT_TRUE(types.add_dbc_file(POLYPORT_SOURCE_DIR "/config/types/wheelchair_can.dbc", d));
    for (const auto& p : d.all()) ADD_FAILURE() << p.to_string();
  }

  // The DBC message: its frame id and length, and the values the codec decodes from `payload`.
  std::array<double, 2> decode(const std::string& name, std::uint32_t id, const can::Payload& payload) {
    const Type* type = types.find("wheelchair_can::" + name);
    EXPECT_NE(type, nullptr) << name;
    if (type == nullptr) return {};
    const DbcMessage* message = type->dbc;
    EXPECT_NE(message, nullptr);
    if (message != nullptr) {
      EXPECT_EQ(message->frame_id, id) << name;
      EXPECT_EQ(message->length, can::kLength) << name;
    }
    auto codec = make_codec(WireFormat::dbc, *type);
    EXPECT_TRUE(codec) << (codec ? "" : codec.error().message);
    std::array<double, 2> flat{};
    if (!codec) return flat;
    EXPECT_EQ(type->size, sizeof flat);
    const CodecResult r = codec.value()->decode(reinterpret_cast<const std::byte*>(payload.data()), can::kLength,
                                                reinterpret_cast<std::byte*>(flat.data()), sizeof flat);
    EXPECT_TRUE(r.ok()) << name;
    return flat;
  }

  // What the codec encodes for `values`.
  can::Payload encode(const std::string& name, const std::array<double, 2>& values) {
    const Type* type = types.find("wheelchair_can::" + name);
    can::Payload out{};
    if (type == nullptr) {
      ADD_FAILURE() << name;
      return out;
    }
    auto codec = make_codec(WireFormat::dbc, *type);
    std::array<std::byte, 8> wire{};
    const CodecResult r = codec.value()->encode(reinterpret_cast<const std::byte*>(values.data()), sizeof values,
                                                wire.data(), wire.size());
    EXPECT_TRUE(r.ok()) << name;
    EXPECT_EQ(r.size, can::kLength);
    std::memcpy(out.data(), wire.data(), out.size());
    return out;
  }

  // The hand-packed `payload` of `values` is the DBC codec's frame for them, both ways.
  void expect_same_as_the_codec(const std::string& name, std::uint32_t id, const std::array<double, 2>& values,
                                const can::Payload& payload) {
    const auto decoded = decode(name, id, payload);
    EXPECT_NEAR(decoded[0], values[0], 1e-9) << name;
    EXPECT_NEAR(decoded[1], values[1], 1e-9) << name;
    EXPECT_EQ(encode(name, values), payload) << name;
  }

  TypeRegistry types;
};

TEST_F(WheelchairCanFrames, JoystickFrameDecodesWithTheDbc) {
  const wheelchair::JoystickPosition stick{0.2052, -0.5638};
  expect_same_as_the_codec("JoystickPosition", can::kJoystickId, {stick.x, stick.y}, can::pack(stick));
  const auto back = can::unpack_joystick(can::pack(stick).data());
  EXPECT_NEAR(back.x, stick.x, 1e-9);
  EXPECT_NEAR(back.y, stick.y, 1e-9);
}

TEST_F(WheelchairCanFrames, EncoderFrameDecodesWithTheDbc) {
  const wheelchair::EncoderSpeeds speeds{6.184, -4.403};
  expect_same_as_the_codec("EncoderSpeeds", can::kEncoderId, {speeds.left_rad_s, speeds.right_rad_s}, can::pack(speeds));
}

TEST_F(WheelchairCanFrames, VoltageFrameDecodesWithTheDbcAndSaturates) {
  const wheelchair::MotorVoltages volts{12.91, -9.22};
  expect_same_as_the_codec("MotorVoltages", can::kVoltagesId, {volts.left_v, volts.right_v}, can::pack(volts));
  const auto back = can::unpack_voltages(can::pack(volts).data());
  EXPECT_NEAR(back.left_v, volts.left_v, 1e-9);
  // Beyond the 16-bit raw range the hand packing saturates rather than wrapping.
  const auto huge = can::unpack_voltages(can::pack(wheelchair::MotorVoltages{1e6, -1e6}).data());
  EXPECT_NEAR(huge.left_v, 327.67, 1e-9);
  EXPECT_NEAR(huge.right_v, -327.68, 1e-9);
}

}  // namespace
}  // namespace polyport
