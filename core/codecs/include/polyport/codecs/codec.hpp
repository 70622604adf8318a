// Codecs: between a type's flat in-memory sample (types.hpp) and one wire format.
//
// decode() and encode() run on the forwarding path when the two ends of a connection speak
// different formats: no allocation, no lock, no logging, no exceptions. Every failure is a
// CodecError that the connection counts, and the sample is dropped; never garbage data.
// A codec is built once per (format, type) at load time and is immutable afterwards, so any
// number of threads may use it at once.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string_view>

#include "polyport/base/result.hpp"
#include "polyport/types/types.hpp"

namespace polyport {

enum class WireFormat : std::uint8_t {
  flat,   // the in-memory layout itself (in-process components)
  xcdr1,  // DDS: 4-byte encapsulation header + XCDR1 (plain CDR); reads both endiannesses
  xcdr2,  // DDS: 4-byte encapsulation header + XCDR2 (DHEADER for appendable types)
  lcm,    // LCM: big-endian, 8-byte fingerprint first, nested types inline
  dbc,    // CAN: a frame's data bytes, signals packed as the DBC message says
};

enum class CodecError : std::uint8_t {
  ok,
  truncated,             // the input ended early
  output_too_small,      // the output buffer (or the flat sample's tail) is too small
  bad_header,            // a CDR encapsulation header that is not XCDR1/XCDR2 for this codec
  fingerprint_mismatch,  // LCM: the message is of another type (or another version of it)
  bound_exceeded,        // a sequence or string longer than its bound
  bad_value,             // e.g. a boolean not 0/1, a string without its NUL, a bad length
  wrong_size,            // DBC: a frame whose length is not the message's DLC
  trailing_bytes,        // input left over after a complete sample (where the format forbids it)
};

std::string_view to_string(WireFormat format) noexcept;
std::string_view to_string(CodecError error) noexcept;

struct CodecResult {
  CodecError error = CodecError::ok;
  std::uint32_t size = 0;     // bytes written to the output
  std::uint32_t clamped = 0;  // DBC encode: signals out of range, clamped to min/max
  bool ok() const noexcept { return error == CodecError::ok; }
};

// A type whose CDR form is the flat sample itself: a struct of primitives laid out alike in
// both (no padding, no booleans or enums to check, nothing variable), final. In the host's
// byte order such a sample is the 4-byte encapsulation header, then exactly the flat bytes,
// then at most 3 bytes of padding; decode() would only copy it. A caller that only copies
// the flat sample on (Connection, into its buffer) may take the bytes where they lie instead,
// touching neither the codec nor its program: on a path that runs every few milliseconds,
// each of those cache lines comes from memory.
struct InPlaceLayout {
  std::uint32_t flat_size = 0;  // the type's size; 0: no sample of this codec is in place
  std::uint16_t id = 0;         // the encapsulation identifier for the host's byte order
};

// The flat sample inside `wire` when decode() would give exactly its bytes (and flat_size
// as the size); null when decode() must run: another byte order or identifier, a size that
// decode() refuses. The checks are decode()'s own (cdr_codec.cpp).
inline const std::byte* in_place_flat(const InPlaceLayout& layout, const std::byte* wire,
                                      std::uint32_t wire_size) noexcept {
  constexpr std::uint32_t kHeader = 4;
  if (layout.flat_size == 0 || wire_size < kHeader) return nullptr;
  const auto id = static_cast<std::uint16_t>(std::to_integer<unsigned>(wire[0]) << 8 |
                                             std::to_integer<unsigned>(wire[1]));
  if (id != layout.id) return nullptr;
  const std::uint32_t padding = std::to_integer<std::uint32_t>(wire[3]) & 3u;
  const std::uint32_t body = wire_size - kHeader;
  if (padding > body) return nullptr;
  const std::uint32_t size = body - padding;
  // Short: truncated; more than 3 bytes after the sample: trailing_bytes.
  if (size < layout.flat_size || size - layout.flat_size > 3) return nullptr;
  return wire + kHeader;
}

class Codec {
 public:
  virtual ~Codec() = default;
  virtual WireFormat format() const noexcept = 0;
  virtual const Type& type() const noexcept = 0;

  // wire -> flat. `flat` holds the type's fixed part, then room for the tail of unbounded
  // strings and sequences (FlatSpan offsets are relative to `flat`).
  virtual CodecResult decode(const std::byte* wire, std::uint32_t wire_size, std::byte* flat,
                             std::uint32_t flat_capacity) const noexcept = 0;
  // flat -> wire. `flat_size` bounds every FlatSpan of the sample.
  virtual CodecResult encode(const std::byte* flat, std::uint32_t flat_size, std::byte* wire,
                             std::uint32_t wire_capacity) const noexcept = 0;
  // The largest encoded size of a sample whose flat form fits `flat_capacity` bytes.
  virtual std::uint32_t max_wire_size(std::uint32_t flat_capacity) const noexcept = 0;
  // See InPlaceLayout; only the CDR codecs have one, for the types described there.
  virtual InPlaceLayout in_place() const noexcept { return {}; }
  // The program decode() and encode() walk (its first bytes), for a caller that prefetches
  // it; null when there is none.
  virtual const void* program_data() const noexcept { return nullptr; }
};

// Each format's factory (cdr_codec.cpp, lcm_codec.cpp, dbc_codec.cpp). They refuse a type
// the format cannot carry, saying which member and why.
Result<std::unique_ptr<Codec>> make_cdr_codec(const Type& type, WireFormat format /* xcdr1 or xcdr2 */);
Result<std::unique_ptr<Codec>> make_lcm_codec(const Type& type);
Result<std::unique_ptr<Codec>> make_dbc_codec(const Type& type);
// Dispatches on the format (codec.cpp); `flat` is refused (no codec is needed).
Result<std::unique_ptr<Codec>> make_codec(WireFormat format, const Type& type);

}  // namespace polyport
