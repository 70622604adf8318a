// libFuzzer target for the LCM type source and the LCM codec. Each input is used twice:
//  (a) as the text of a .lcm file, parsed into a fresh registry; every struct it declares
//      is compiled into a codec (or refused) and decodes the same input as a message;
//  (b) as a message for a struct with every LCM construct. A message that decodes must
//      re-encode to exactly the same bytes (LCM has one encoding per value) and decode again
//      to exactly the same flat sample; anything else traps.
// Build with ./scripts/fuzz.sh (clang, -DPOLYPORT_FUZZ=ON, into build-fuzz/), then run by hand:
//   ./build-fuzz/bin/fuzz_lcm -max_total_time=30 corpus/   (seeds: any .lcm files, and encoded fz.all_t messages)
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <memory>
#include <string_view>
#include <vector>

#include "polyport/codecs/codec.hpp"
#include "polyport/base/diagnostics.hpp"
#include "polyport/types/types.hpp"

namespace {

using namespace polyport;

constexpr std::string_view kEveryConstruct = R"(package fz;
struct inner_t { int8_t n; double v[n]; string s; boolean b; }
struct all_t {
  const int32_t K = 3, L = -0x10;
  const double D = 0.5;
  int8_t i8; int16_t i16; int32_t i32; int64_t i64; byte raw; float f; double d; string text; boolean flag;
  int16_t rows;
  int64_t cols;
  double fixed[2][3];
  float dyn[rows];
  int32_t mixed[2][rows][2][cols];
  string names[rows];
  boolean bits[cols];
  byte blob[rows][cols];
  inner_t one;
  inner_t some[rows];
  inner_t grid[2][cols];
  fz.inner_t pair[2];
}
)";

// Flat samples get at most this much room: larger messages end in output_too_small.
constexpr std::uint32_t kFlatCapacity = 1 << 16;

struct Target {
  TypeRegistry registry;
  std::unique_ptr<Codec> codec;

  Target() {
    Diagnostics diagnostics;
    if (!registry.add_lcm_text(kEveryConstruct, "every_construct.lcm", diagnostics)) __builtin_trap();
    const Type* type = registry.find("fz.all_t");
    if (type == nullptr) __builtin_trap();
    auto made = make_lcm_codec(*type);
    if (!made.ok()) __builtin_trap();
    codec = std::move(made).value();
  }
};

const Target& target() {
  static const Target instance;
  return instance;
}

std::vector<std::byte>& buffer(int which, std::size_t size) {
  static std::vector<std::byte> buffers[3];
  if (buffers[which].size() < size) buffers[which].resize(size);
  return buffers[which];
}

void parse_as_lcm_text(const std::byte* data, std::size_t size) {
  TypeRegistry registry;
  Diagnostics diagnostics;
  registry.add_lcm_text(std::string_view(reinterpret_cast<const char*>(data), size), "input.lcm", diagnostics);
  for (const Diagnostic& item : diagnostics.all()) {
    if (item.where.line == 0 || item.where.column == 0) __builtin_trap();  // every error has a place
  }
  std::vector<std::byte>& flat = buffer(2, kFlatCapacity);
  for (const Type* type : registry.declared()) {
    if (type->origin != TypeOrigin::lcm) __builtin_trap();
    auto made = make_lcm_codec(*type);
    if (!made.ok()) continue;
    made.value()->decode(data, static_cast<std::uint32_t>(size), flat.data(), kFlatCapacity);
  }
}

void decode_as_message(const std::byte* data, std::size_t size) {
  const Codec& codec = *target().codec;
  std::vector<std::byte>& flat = buffer(0, kFlatCapacity);
  const CodecResult decoded = codec.decode(data, static_cast<std::uint32_t>(size), flat.data(), kFlatCapacity);
  if (!decoded.ok()) return;
  if (decoded.size < codec.type().size || decoded.size > kFlatCapacity) __builtin_trap();

  std::vector<std::byte>& wire = buffer(1, codec.max_wire_size(decoded.size));
  if (codec.max_wire_size(decoded.size) < size) __builtin_trap();  // the bound must hold
  const CodecResult encoded =
      codec.encode(flat.data(), decoded.size, wire.data(), static_cast<std::uint32_t>(wire.size()));
  if (!encoded.ok()) __builtin_trap();
  if (encoded.size != size || std::memcmp(wire.data(), data, size) != 0) __builtin_trap();

  std::vector<std::byte> again(decoded.size);
  const CodecResult redecoded = codec.decode(wire.data(), encoded.size, again.data(), decoded.size);
  if (!redecoded.ok() || redecoded.size != decoded.size) __builtin_trap();
  if (std::memcmp(again.data(), flat.data(), decoded.size) != 0) __builtin_trap();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size > 0xFFFFFFFFu) return 0;  // the codec's sizes are 32-bit
  const auto* bytes = reinterpret_cast<const std::byte*>(data);
  parse_as_lcm_text(bytes, size);
  decode_as_message(bytes, size);
  return 0;
}
