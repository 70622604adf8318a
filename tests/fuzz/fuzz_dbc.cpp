// Fuzzes the DBC parser and the DBC codec with the same input:
//  (a) the input as a DBC file: no input may crash, hang or leak; every message it
//      registers must give a codec, and that codec must survive a frame of input bytes;
//  (b) the input as a frame for fixed messages (Intel, Motorola, multiplexed, 64-byte CAN
//      FD, float and double): a frame that decodes and re-encodes without clamping must
//      decode to the very same values again (factor 1 and offset 0 here, so no rounding).
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <memory>
#include <string_view>
#include <vector>

#include "polyport/codecs/codec.hpp"
#include "polyport/types/dbc.hpp"
#include "polyport/types/types.hpp"

namespace {

constexpr std::string_view kFixedDbc = R"(
BO_ 100 Intel: 8 N
 SG_ A : 0|12@1+ (1,0) [0|0] "" N
 SG_ B : 12|20@1- (1,0) [0|0] "" N
 SG_ C : 32|32@1- (1,0) [0|0] "" N
BO_ 101 Motorola: 8 N
 SG_ A : 7|12@0+ (1,0) [0|0] "" N
 SG_ B : 11|20@0- (1,0) [0|0] "" N
 SG_ C : 39|32@0+ (1,0) [0|0] "" N
BO_ 102 Muxed: 8 N
 SG_ Page M : 0|4@1+ (1,0) [0|0] "" N
 SG_ P1 m1 : 4|28@1- (1,0) [0|0] "" N
 SG_ P2 m2 : 11|16@0+ (1,0) [0|0] "" N
 SG_ Q2 m2 : 32|24@1+ (1,0) [0|0] "" N
 SG_ Always : 56|8@1- (1,0) [0|0] "" N
BO_ 103 Nested: 8 N
 SG_ Service M : 0|8@1+ (1,0) [0|0] "" N
 SG_ Pid m1M : 15|8@0+ (1,0) [0|0] "" N
 SG_ Speed m13 : 16|8@1- (1,0) [0|0] "" N
 SG_ Rpm m12 : 16|16@1+ (1,0) [0|0] "" N
 SG_ Dtc m3 : 8|24@1+ (1,0) [0|0] "" N
 SG_ Always : 56|8@1+ (1,0) [0|0] "" N
BO_ 2147483751 Fd: 64 N
 SG_ F : 0|32@1- (1,0) [0|0] "" N
 SG_ D : 39|64@0- (1,0) [0|0] "" N
 SG_ Spill : 100|64@1+ (1,0) [0|0] "" N
 SG_ SpillMoto : 195|64@0- (1,0) [0|0] "" N
 SG_ Tail : 511|3@0+ (1,0) [0|0] "" N
SIG_VALTYPE_ 2147483751 F : 1;
SIG_VALTYPE_ 2147483751 D : 2;
SG_MUL_VAL_ 103 Pid Service 1-1;
SG_MUL_VAL_ 103 Speed Pid 13-13, 40-60;
SG_MUL_VAL_ 103 Rpm Pid 12-12;
SG_MUL_VAL_ 103 Dtc Service 3-9;
)";

struct Fixed {
  polyport::TypeRegistry registry;
  std::vector<std::unique_ptr<polyport::Codec>> codecs;

  Fixed() {
    polyport::Diagnostics diagnostics;
    if (!registry.add_dbc_text(kFixedDbc, "fixed.dbc", diagnostics)) __builtin_trap();
    for (const char* name : {"fixed::Intel", "fixed::Motorola", "fixed::Muxed", "fixed::Nested", "fixed::Fd"}) {
      const polyport::Type* type = registry.find(name);
      if (type == nullptr) __builtin_trap();
      auto made = polyport::make_dbc_codec(*type);
      if (!made.ok()) __builtin_trap();
      codecs.push_back(std::move(made).value());
    }
  }
};

// The input's bytes as a frame of exactly `length` bytes (zero padded).
std::vector<std::byte> frame_of(const std::uint8_t* data, std::size_t size, std::uint32_t length) {
  std::vector<std::byte> frame(length);
  if (size > 0 && length > 0) std::memcpy(frame.data(), data, size < length ? size : length);
  return frame;
}

bool same(double a, double b) { return (std::isnan(a) && std::isnan(b)) || a == b; }

// Decodes, re-encodes and decodes again; `strict`: values must survive exactly.
void round_trip(const polyport::Codec& codec, const std::uint8_t* data, std::size_t size, bool strict) {
  const std::uint32_t length = codec.max_wire_size(0);
  const std::uint32_t flat_size = codec.type().size;
  std::vector<std::byte> flat(flat_size);
  std::vector<std::byte> flat_again(flat_size);
  // The input's own size is almost never the length: it must be refused, not read.
  if (size != length) {
    if (codec.decode(reinterpret_cast<const std::byte*>(data), static_cast<std::uint32_t>(size), flat.data(),
                     flat_size).error != polyport::CodecError::wrong_size) {
      __builtin_trap();
    }
  }
  const std::vector<std::byte> frame = frame_of(data, size, length);
  if (!codec.decode(frame.data(), length, flat.data(), flat_size).ok()) __builtin_trap();
  std::vector<std::byte> wire(length + 1);
  const polyport::CodecResult encoded = codec.encode(flat.data(), flat_size, wire.data(), length);
  // NaN in a float signal (or an absent multiplexed one being packed) is a bad value.
  if (!encoded.ok() || encoded.clamped != 0 || !strict) return;
  if (encoded.size != length) __builtin_trap();
  if (!codec.decode(wire.data(), length, flat_again.data(), flat_size).ok()) __builtin_trap();
  for (const polyport::Field& field : codec.type().fields) {
    double a;
    double b;
    std::memcpy(&a, flat.data() + field.offset, sizeof a);
    std::memcpy(&b, flat_again.data() + field.offset, sizeof b);
    if (!same(a, b)) __builtin_trap();
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const Fixed fixed;
  {
    polyport::TypeRegistry registry;
    polyport::Diagnostics diagnostics;
    const std::string_view text(reinterpret_cast<const char*>(data), size);
    registry.add_dbc_text(text, "fuzz.dbc", diagnostics);
    for (const polyport::Type* type : registry.declared()) {
      auto made = polyport::make_dbc_codec(*type);
      if (!made.ok()) __builtin_trap();  // the parser registers only what the codec can carry
      round_trip(*made.value(), data, size, false);
    }
  }
  for (const auto& codec : fixed.codecs) round_trip(*codec, data, size, true);
  return 0;
}
