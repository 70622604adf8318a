// Connections that convert: decode the source's wire format, map, encode the target's.
// The codecs here are small stand-ins with a visible encoding (a 4-byte tag, then the
// flat bytes); the real formats are tested against their reference implementations in
// tests/cross/.
#include <gtest/gtest.h>

#include <cstring>
#include <limits>

#include "polyport/runtime/component.hpp"
#include "polyport/runtime/connection.hpp"
#include "polyport/types/types.hpp"

namespace polyport {
namespace {

constexpr std::uint32_t kTag = 0x7A7A7A7A;

class TaggedCodec final : public Codec {
 public:
  explicit TaggedCodec(const Type& type) : type_(type) {}
  WireFormat format() const noexcept override { return WireFormat::lcm; }
  const Type& type() const noexcept override { return type_; }
  CodecResult decode(const std::byte* wire, std::uint32_t size, std::byte* flat, std::uint32_t cap) const noexcept override {
    std::uint32_t tag = 0;
    if (size != 4 + type_.size) return {CodecError::truncated, 0, 0};
    std::memcpy(&tag, wire, 4);
    if (tag != kTag) return {CodecError::fingerprint_mismatch, 0, 0};
    if (cap < type_.size) return {CodecError::output_too_small, 0, 0};
    std::memcpy(flat, wire + 4, type_.size);
    return {CodecError::ok, type_.size, 0};
  }
  CodecResult encode(const std::byte* flat, std::uint32_t size, std::byte* wire, std::uint32_t cap) const noexcept override {
    if (size < type_.size || cap < 4 + type_.size) return {CodecError::output_too_small, 0, 0};
    std::memcpy(wire, &kTag, 4);
    std::memcpy(wire + 4, flat, type_.size);
    double first = 0;
    std::memcpy(&first, flat, sizeof first);
    return {CodecError::ok, 4 + type_.size, first > 100.0 ? 1u : 0u};  // "clamps" values over 100
  }
  std::uint32_t max_wire_size(std::uint32_t) const noexcept override { return 4 + type_.size; }

 private:
  const Type& type_;
};

// Doubles the first field of a two-double struct and swaps its fields; refuses NaN.
class SwapMapping final : public MappingProgram {
 public:
  bool run(const std::byte* source, std::uint32_t size, std::byte* target, std::uint32_t cap,
           std::uint32_t& target_size) const noexcept override {
    double v[2];
    if (size < sizeof v || cap < sizeof v) return false;
    std::memcpy(v, source, sizeof v);
    if (v[0] != v[0]) return false;
    const double out[2] = {v[1], 2 * v[0]};
    std::memcpy(target, out, sizeof out);
    target_size = sizeof out;
    return true;
  }
  std::vector<std::string> describe() const override { return {"swap"}; }
};

class Conversion : public ::testing::Test {
 protected:
  void SetUp() override {
    Diagnostics d;
    ASSERT_TRUE(types.add_idl_text("struct A { double x; double y; }; struct B { double u; double v; };", "c.idl", d));
    a = types.find("A");
    b = types.find("B");
    ASSERT_TRUE(a && b);
  }
  TypeRegistry types;
  const Type* a = nullptr;
  const Type* b = nullptr;
  Component src{"S", "lcm"};
  Component dst{"D", "inproc"};
};

TEST_F(Conversion, SameFormatAndTypePassesBytesThrough) {
  TaggedCodec codec(*a);
  auto& out = src.add_port<DataOutPort>("out", PortKind::data, a, 4 + a->size);
  auto& in = dst.add_port<DataInPort>("in", PortKind::data, a, 4 + a->size, QueuePolicy::data, 1);
  out.set_wire_format(WireFormat::lcm, &codec);
  in.set_wire_format(WireFormat::lcm, &codec);
  Connection c(out, in, QueuePolicy::data, 1);
  EXPECT_TRUE(c.passthrough());
  EXPECT_EQ(c.conversion(), "passthrough");
}

TEST_F(Conversion, DecodeMapAndEncodeRunOnlyWhenNeeded) {
  TaggedCodec source_codec(*a), target_codec(*b);
  SwapMapping mapping;
  auto& out = src.add_port<DataOutPort>("out", PortKind::data, a, 4 + a->size);
  auto& in = dst.add_port<DataInPort>("in", PortKind::data, b, 4 + b->size, QueuePolicy::buffer, 4);
  out.set_wire_format(WireFormat::lcm, &source_codec);
  in.set_wire_format(WireFormat::lcm, &target_codec);
  Connection c(out, in, QueuePolicy::buffer, 4, &mapping);
  out.connections().add(c);
  in.connections().add(c);
  EXPECT_FALSE(c.passthrough());
  EXPECT_EQ(c.conversion(), "lcm -> flat -> map -> lcm");

  std::byte wire[20];
  const double xy[2] = {3, 4};
  std::memcpy(wire, &kTag, 4);
  std::memcpy(wire + 4, xy, 16);
  ASSERT_EQ(out.write(wire, sizeof wire), Status::ok);
  std::byte got[20];
  ASSERT_EQ(in.read(got, sizeof got), Status::ok);
  std::uint32_t tag = 0;
  double uv[2];
  std::memcpy(&tag, got, 4);
  std::memcpy(uv, got + 4, 16);
  EXPECT_EQ(tag, kTag);
  EXPECT_EQ(uv[0], 4.0);
  EXPECT_EQ(uv[1], 6.0);

  wire[0] = std::byte{0};  // a malformed sample: counted, dropped, and the next one works
  out.write(wire, sizeof wire);
  EXPECT_EQ(c.counters().dropped_decode_error.load(), 1u);
  std::memcpy(wire, &kTag, 4);
  const double nan_first[2] = {std::numeric_limits<double>::quiet_NaN(), 1};
  std::memcpy(wire + 4, nan_first, 16);
  out.write(wire, sizeof wire);
  EXPECT_EQ(c.counters().dropped_map_error.load(), 1u);
  const double big[2] = {1, 500};
  std::memcpy(wire + 4, big, 16);
  out.write(wire, sizeof wire);
  EXPECT_EQ(c.counters().clamped.load(), 1u);
  EXPECT_EQ(c.counters().delivered.load(), 2u);
  EXPECT_EQ(c.counters().dropped(), 2u);
}

TEST_F(Conversion, FlatSourceIntoAnEncodedTarget) {
  TaggedCodec target_codec(*a);
  auto& out = src.add_port<DataOutPort>("out", PortKind::data, a, a->size);
  auto& in = dst.add_port<DataInPort>("in", PortKind::data, a, 4 + a->size, QueuePolicy::data, 1);
  in.set_wire_format(WireFormat::lcm, &target_codec);
  Connection c(out, in, QueuePolicy::data, 1);
  out.connections().add(c);
  in.connections().add(c);
  EXPECT_EQ(c.conversion(), "flat -> lcm");
  const double xy[2] = {1, 2};
  out.write(xy, sizeof xy);
  std::byte got[20];
  ASSERT_EQ(in.read(got, sizeof got), Status::ok);
  double back[2];
  std::memcpy(back, got + 4, 16);
  EXPECT_EQ(back[1], 2.0);
}

}  // namespace
}  // namespace polyport

namespace polyport {
namespace {

// Each real wire format: a good sample is delivered, a malformed one is counted and
// dropped, and the connection goes on delivering.
class MalformedSamples : public ::testing::TestWithParam<WireFormat> {
 protected:
  void SetUp() override {
    Diagnostics d;
    ASSERT_TRUE(types.add_idl_text("module m { struct Pair { double a; double b; }; };", "m.idl", d));
    ASSERT_TRUE(types.add_lcm_text("package m; struct pair_t { double a; double b; }", "m.lcm", d));
    ASSERT_TRUE(types.add_dbc_text("VERSION \"\"\n\nNS_ :\n\nBS_:\n\nBU_: N\n\n"
                                   "BO_ 16 PairFrame: 2 N\n SG_ a : 0|8@1+ (1,0) [0|255] \"\" N\n"
                                   " SG_ b : 8|8@1+ (1,0) [0|255] \"\" N\n",
                                   "m.dbc", d));
    for (const auto& p : d.all()) ADD_FAILURE() << p.to_string();
  }
  const Type& type_for(WireFormat format) {
    switch (format) {
      case WireFormat::lcm: return *types.find("m::pair_t");
      case WireFormat::dbc: return *types.find("m::PairFrame");
      default: return *types.find("m::Pair");
    }
  }
  TypeRegistry types;
};

TEST_P(MalformedSamples, AreCountedAndDroppedAndTheConnectionGoesOn) {
  const WireFormat format = GetParam();
  const Type& type = type_for(format);
  auto codec = make_codec(format, type);
  ASSERT_TRUE(codec) << codec.error().message;
  Component src{"S", "foreign"};
  Component dst{"D", "inproc"};
  auto& out = src.add_port<DataOutPort>("out", PortKind::data, &type, 256);
  auto& in = dst.add_port<DataInPort>("in", PortKind::data, &type, type.size, QueuePolicy::buffer, 4);
  out.set_wire_format(format, codec.value().get());
  Connection c(out, in, QueuePolicy::buffer, 4);
  out.connections().add(c);
  in.connections().add(c);
  EXPECT_EQ(c.conversion(), std::string(to_string(format)) + " -> flat");

  const double values[2] = {7, 9};
  std::byte wire[256];
  const CodecResult good = codec.value()->encode(reinterpret_cast<const std::byte*>(values), sizeof values, wire, sizeof wire);
  ASSERT_TRUE(good.ok());
  std::byte bad[256];
  std::memcpy(bad, wire, good.size);
  std::uint32_t bad_size = good.size;
  if (format == WireFormat::lcm) bad[0] ^= std::byte{0xFF};  // another type's fingerprint
  else bad_size = good.size - 1;                               // truncated CDR, short CAN frame

  out.write(wire, good.size);
  out.write(bad, bad_size);
  out.write(wire, good.size);
  double got[2] = {0, 0};
  EXPECT_EQ(in.read(got, sizeof got), Status::ok);
  EXPECT_EQ(got[0], 7.0);
  EXPECT_EQ(got[1], 9.0);
  EXPECT_EQ(in.read(got, sizeof got), Status::ok);
  EXPECT_EQ(in.read(got, sizeof got), Status::no_data);
  EXPECT_EQ(c.counters().dropped_decode_error.load(), 1u);
  EXPECT_EQ(c.counters().delivered.load(), 2u);
}

// A struct of doubles in XCDR1 needs no decoding in the host's byte order (the connection
// takes it after the header, codec.hpp's InPlaceLayout); the other byte order is decoded.
// Either way the reader gets the same values, and a deadband on the source still compares
// them.
TEST_F(MalformedSamples, PlainCdrSamplesReachTheReaderInEitherByteOrder) {
  const Type& type = type_for(WireFormat::xcdr1);
  auto codec = make_codec(WireFormat::xcdr1, type);
  ASSERT_TRUE(codec) << codec.error().message;
  ASSERT_EQ(codec.value()->in_place().flat_size, type.size);
  for (const bool deadband : {false, true}) {
    Component src{"S", "foreign"};
    Component dst{"D", "inproc"};
    auto& out = src.add_port<DataOutPort>("out", PortKind::data, &type, 256);
    auto& in = dst.add_port<DataInPort>("in", PortKind::data, &type, type.size, QueuePolicy::buffer, 4);
    out.set_wire_format(WireFormat::xcdr1, codec.value().get());
    Connection c(out, in, QueuePolicy::buffer, 4);
    if (deadband) c.set_deadbands({DeadbandField{8, TypeKind::float64, 0.5, "b"}});
    out.connections().add(c);
    in.connections().add(c);
    const double values[2] = {7, 9};
    std::byte little[64];
    const CodecResult good = codec.value()->encode(reinterpret_cast<const std::byte*>(values), sizeof values,
                                                   little, sizeof little);
    ASSERT_TRUE(good.ok());
    // The same sample big-endian: identifier 0x0000, each double's bytes reversed.
    std::byte big[64];
    std::memcpy(big, little, good.size);
    big[1] = std::byte{0};
    for (int field = 0; field < 2; ++field) {
      for (int i = 0; i < 8; ++i) big[4 + 8 * field + i] = little[4 + 8 * field + 7 - i];
    }
    // A third that moved b by less than the deadband.
    const double close[2] = {1, 9.25};
    std::byte near[64];
    ASSERT_TRUE(codec.value()->encode(reinterpret_cast<const std::byte*>(close), sizeof close, near, sizeof near).ok());
    out.write(little, good.size);
    out.write(big, good.size);
    out.write(near, good.size);
    double got[2] = {0, 0};
    ASSERT_EQ(in.read(got, sizeof got), Status::ok) << "deadband " << deadband;
    EXPECT_EQ(got[0], 7.0);
    EXPECT_EQ(got[1], 9.0);
    if (deadband) {
      // The big-endian copy moved nothing; neither did the third.
      EXPECT_EQ(in.read(got, sizeof got), Status::no_data);
      EXPECT_EQ(c.counters().dropped_filtered.load(), 2u);
      continue;
    }
    got[0] = got[1] = 0;
    ASSERT_EQ(in.read(got, sizeof got), Status::ok);
    EXPECT_EQ(got[0], 7.0);
    EXPECT_EQ(got[1], 9.0);
    ASSERT_EQ(in.read(got, sizeof got), Status::ok);
    EXPECT_EQ(got[0], 1.0);
    EXPECT_EQ(got[1], 9.25);
    EXPECT_EQ(c.counters().delivered.load(), 3u);
    EXPECT_EQ(c.counters().dropped(), 0u);
  }
}

INSTANTIATE_TEST_SUITE_P(Formats, MalformedSamples,
                         ::testing::Values(WireFormat::xcdr1, WireFormat::xcdr2, WireFormat::lcm, WireFormat::dbc),
                         [](const auto& param_info) { return std::string(to_string(param_info.param)); });

}  // namespace
}  // namespace polyport
