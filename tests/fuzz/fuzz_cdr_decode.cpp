// libFuzzer target for the CDR codec's decoder. Codecs for a final struct with every
// construct the codec supports (appendable structs inside) and for an appendable struct, in
// XCDR1 and XCDR2, are built once. Each decodes the input twice: as it is, and behind the
// codec's own header (so the fuzzer reaches the body without finding a header first).
// A sample that decodes must re-encode (decode only produces valid values) within
// max_wire_size(), and from then on be a fixed point: decoding normalises (absent
// appendable members get their defaults, padding and unknown members are dropped, big
// endian becomes native), but encode(decode(w)) must give w back for a w that encode
// wrote, and the values must survive the whole trip. Anything else traps.
// Build with ./scripts/fuzz.sh (clang, -DPOLYPORT_FUZZ=ON, into build-fuzz/).
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "polyport/codecs/codec.hpp"
#include "polyport/base/diagnostics.hpp"
#include "polyport/types/types.hpp"

namespace {

using namespace polyport;

constexpr std::string_view kEveryConstruct = R"(
  module fz {
    enum Mode { IDLE, RUN, @value(7) FAULT };
    enum Level { @value(3) LOW, @value(-2) HIGH };  // its default, LOW, is not 0
    struct Inner { short id; double value; boolean ok; };
    @appendable struct Tagged { unsigned long seq; string<6> tag; Level level; sequence<Mode> modes; string note; };
    typedef double Vec3[3];
    typedef sequence<long, 3> Longs;
    @final struct All {
      boolean flag; char letter; octet raw; int8 i8; uint8 u8; short i16; unsigned short u16;
      long i32; unsigned long u32; long long i64; unsigned long long u64; float f32; double f64;
      Mode mode; Level levels[2]; Inner inner; Inner inners[2]; double matrix[2][3]; Vec3 corners[2];
      boolean bits[3]; sequence<double, 4> bounded; sequence<long> longs; Longs aliased;
      string text; string<8> label; string names[2]; string<3> codes[2];
      sequence<Inner> inner_seq; sequence<Inner, 2> inner_bseq; sequence<string> texts;
      sequence<string<4>, 2> short_texts; sequence<boolean> flags; sequence<Mode> mode_seq;
      sequence<sequence<short> > nested; sequence<Vec3> path; Tagged tagged; Tagged pair[2];
      sequence<Tagged> more; sequence<Tagged, 1> one; octet last;
    };
  };
)";

// Flat samples get at most this much room: larger ones end in output_too_small.
constexpr std::uint32_t kFlatCapacity = 1 << 16;

struct Target {
  TypeRegistry registry;
  std::vector<std::unique_ptr<Codec>> codecs;

  Target() {
    Diagnostics diagnostics;
    if (!registry.add_idl_text(kEveryConstruct, "every_construct.idl", diagnostics))
      __builtin_trap();
    for (const char* name : {"fz::All", "fz::Tagged"}) {
      const Type* type = registry.find(name);
      if (type == nullptr) __builtin_trap();
      for (WireFormat format : {WireFormat::xcdr1, WireFormat::xcdr2}) {
        auto made = make_cdr_codec(*type, format);
        if (!made.ok()) __builtin_trap();
        codecs.push_back(std::move(made).value());
      }
    }
  }
};

const Target& target() {
  static const Target instance;
  return instance;
}

std::vector<std::byte>& buffer(int which, std::size_t size) {
  static std::vector<std::byte> buffers[5];
  if (buffers[which].size() < size) buffers[which].resize(size);
  return buffers[which];
}

// The little-endian header this codec writes (options 0: no padding announced).
std::vector<std::byte> own_header(const Codec& codec) {
  const bool xcdr2 = codec.format() == WireFormat::xcdr2;
  const bool appendable = codec.type().resolved().extensibility == Extensibility::appendable;
  const auto id = static_cast<std::uint8_t>(!xcdr2 ? 0x01 : appendable ? 0x09 : 0x07);
  return {std::byte{0}, std::byte{id}, std::byte{0}, std::byte{0}};
}

void check_round_trip(const Codec& codec, const std::byte* data, std::size_t size) {
  std::vector<std::byte>& flat = buffer(0, kFlatCapacity);
  const CodecResult decoded =
      codec.decode(data, static_cast<std::uint32_t>(size), flat.data(), kFlatCapacity);
  if (!decoded.ok()) return;
  if (decoded.size < codec.type().size || decoded.size > kFlatCapacity) __builtin_trap();

  // Whatever decode accepted encodes, within the announced bound.
  const std::uint32_t bound = codec.max_wire_size(decoded.size);
  std::vector<std::byte>& first = buffer(1, bound);
  const CodecResult encoded = codec.encode(flat.data(), decoded.size, first.data(), bound);
  if (!encoded.ok() || encoded.size > bound || encoded.size % 4 != 0) __builtin_trap();

  // The values survive: the same JSON before and after.
  std::vector<std::byte>& again = buffer(2, kFlatCapacity);
  const CodecResult redecoded =
      codec.decode(first.data(), encoded.size, again.data(), kFlatCapacity);
  if (!redecoded.ok()) __builtin_trap();
  if (sample_to_json(codec.type(), flat.data(), decoded.size) !=
      sample_to_json(codec.type(), again.data(), redecoded.size))
    __builtin_trap();

  // From here on a fixed point: the same bytes, the same flat sample.
  std::vector<std::byte>& second = buffer(3, bound);
  const CodecResult reencoded = codec.encode(again.data(), redecoded.size, second.data(), bound);
  if (!reencoded.ok() || reencoded.size != encoded.size) __builtin_trap();
  if (std::memcmp(first.data(), second.data(), encoded.size) != 0) __builtin_trap();
  std::vector<std::byte>& third = buffer(4, kFlatCapacity);
  const CodecResult last = codec.decode(second.data(), reencoded.size, third.data(), kFlatCapacity);
  if (!last.ok() || last.size != redecoded.size) __builtin_trap();
  if (std::memcmp(third.data(), again.data(), last.size) != 0) __builtin_trap();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size > (1u << 20)) return 0;  // sizes are 32-bit; bigger inputs add nothing
  const auto* bytes = reinterpret_cast<const std::byte*>(data);
  std::vector<std::byte> framed;
  for (const std::unique_ptr<Codec>& codec : target().codecs) {
    check_round_trip(*codec, bytes, size);
    framed = own_header(*codec);
    framed.insert(framed.end(), bytes, bytes + size);
    check_round_trip(*codec, framed.data(), framed.size());
  }
  return 0;
}
