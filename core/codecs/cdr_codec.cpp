// CDR codec: flat samples (types.hpp) <-> XCDR1 / XCDR2 with the 4-byte encapsulation
// header, byte for byte as Cyclone DDS 0.10.2 writes them (and Fast DDS 2.9.1 for XCDR1, up
// to the trailing padding, see below).
//
// Buffers and threads: make_cdr_codec() compiles the type once, at load time, into a flat
// program (a vector of Instr plus small side tables) that is never modified afterwards, so
// any number of threads may call encode() and decode() on one codec at once. The caller owns
// both buffers of every call: decode() reads `wire` and writes the fixed part and the tail of
// the flat sample into `flat`; encode() reads `flat` and writes `wire`. Neither allocates,
// locks, logs or throws: the only state is on the stack (a loop stack and a DHEADER stack of
// a depth that was checked when the program was compiled).
//
// Files: this one holds the codec and runs its program (decode, encode); the program itself
// is cdr_program.hpp, and cdr_compiler.cpp compiles a type into one.
//
// What goes on the wire (and why the program looks the way it does):
//  - Header: a 2-byte encapsulation identifier, big-endian, then 2 bytes of options.
//    XCDR1: CDR_BE 0x0000, CDR_LE 0x0001. XCDR2: PLAIN_CDR2_BE 0x0006 / _LE 0x0007 when the
//    top-level type is final, D_CDR2_BE 0x0008 / _LE 0x0009 when it is appendable
//    (DDS-XTypes 1.3; what Cyclone 0.10.2 writes). Encode writes the native byte order;
//    decode reads both. A codec accepts only its own identifiers (an XCDR1 codec refuses
//    XCDR2 data): bad_header.
//  - Trailing padding: encode pads the body with zeros to a multiple of 4 and stores the
//    number of padding bytes in the low two bits of the last options byte, as the XTypes
//    spec asks and Cyclone 0.10.2 does. Fast DDS 2.9.1 (Fast CDR 1.0.26) pads nothing and
//    writes options 0, so its bytes are ours minus the padding, with options 0. Decode drops
//    the padding the options announce (more than the body holds: bad_header), then accepts
//    at most 3 bytes after the sample (padding a writer did not announce); more than that
//    is trailing_bytes, as it means another type or a corrupt sample, except after an XCDR1
//    appendable top-level struct, where they are the members a newer version of the type
//    appended and are skipped as the spec says.
//  - Alignment, relative to the first byte after the header: each primitive at a multiple
//    of its size, capped at 8 in XCDR1 and at 4 in XCDR2. Padding bytes are written as 0
//    and not checked on decode. An empty sequence is not aligned for its element type
//    (neither vendor does that).
//  - Strings: uint32 length including the NUL, the characters, the NUL. IDL strings never
//    hold a NUL (OMG IDL 4.2), so a length of 0, a missing final NUL or a NUL inside are
//    bad_value, both ways; a bounded string longer than its bound is bound_exceeded.
//    Sequences: uint32 element count, then the elements.
//  - XCDR2 DHEADER (uint32 byte count of what follows): before every appendable struct, and
//    before every sequence or array whose element type is not primitive. Like Cyclone
//    0.10.2, enumerations count as not primitive there (its maintainers read the spec that
//    way, cyclonedds-cxx#218), booleans as primitive. Decode bounds everything inside by the
//    DHEADER; an appendable struct that ends early gives its remaining members their
//    default values (a writer with an older version of the type): zero, an empty string or
//    sequence as FlatSpan {0, 0}, an enumeration its first enumerator. One with bytes left
//    over has them skipped (a newer version).
//  - XCDR1 has no DHEADER: appendable structs are written like final ones (PLAIN_CDR, as
//    DDS-XTypes 1.3 has it), which is what Fast DDS 2.9 does with them. Cyclone 0.10.2
//    refuses XCDR1 for types that hold an appendable struct. Mutable structs (PL_CDR,
//    PL_CDR2) are refused when the codec is made.
//  - Arrays of arrays (also through typedefs) are one array of the innermost element type,
//    as idlc compiles them: one DHEADER in XCDR2, not one per row.
//  - Booleans other than 0/1 and enum values that are not enumerators are bad_value both
//    ways; so is a flat sample smaller than the type's fixed part or a FlatSpan that points
//    outside `flat_size`.
//
// Decode writes a complete flat sample: the fixed part is zeroed first (unless the program
// writes every byte of it), as is every tail region it hands out, so padding, unused
// bounded-sequence slots and the bytes after a bounded string's NUL are 0. An empty
// unbounded sequence is the FlatSpan {0, 0}; an unbounded string always has its NUL in the
// tail, the empty one too.
#include <algorithm>
#include <bit>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "polyport/codecs/codec.hpp"

#include "cdr_program.hpp"

namespace polyport {

namespace cdr {

namespace {

constexpr std::uint32_t kHeaderSize = 4;
constexpr bool kNativeLittle = std::endian::native == std::endian::little;

constexpr std::uint16_t kCdrBe = 0x0000;
constexpr std::uint16_t kCdrLe = 0x0001;
constexpr std::uint16_t kPlainCdr2Be = 0x0006;
constexpr std::uint16_t kPlainCdr2Le = 0x0007;
constexpr std::uint16_t kDelimitedCdr2Be = 0x0008;
constexpr std::uint16_t kDelimitedCdr2Le = 0x0009;

// ---- running a program --------------------------------------------------------------------

template <class T>
T load(const void* from) noexcept {
  T value;
  std::memcpy(&value, from, sizeof value);
  return value;
}

template <class T>
void store(void* to, T value) noexcept {
  std::memcpy(to, &value, sizeof value);
}

std::uint32_t load_u32(const std::uint8_t* from, bool swap) noexcept {
  const auto value = load<std::uint32_t>(from);
  return swap ? __builtin_bswap32(value) : value;
}

void swap_in_place(std::byte* data, std::uint32_t size, std::uint32_t count) noexcept {
  switch (size) {
    case 2:
      for (std::uint32_t i = 0; i < count; ++i, data += 2)
        store(data, __builtin_bswap16(load<std::uint16_t>(data)));
      break;
    case 4:
      for (std::uint32_t i = 0; i < count; ++i, data += 4)
        store(data, __builtin_bswap32(load<std::uint32_t>(data)));
      break;
    case 8:
      for (std::uint32_t i = 0; i < count; ++i, data += 8)
        store(data, __builtin_bswap64(load<std::uint64_t>(data)));
      break;
    default: break;  // single bytes need no swapping
  }
}

bool enum_ok(const Program& program, std::uint32_t table_index, std::int32_t value) noexcept {
  const EnumTable& table = program.enums[table_index];
  if (value < table.min || value > table.max) return false;
  if (table.dense) return true;
  const std::int32_t* first = program.enum_values.data() + table.first;
  return std::binary_search(first, first + table.count, value);
}

bool booleans_ok(const void* data, std::uint32_t count) noexcept {
  const auto* bytes = static_cast<const std::uint8_t*>(data);
  std::uint8_t any = 0;
  for (std::uint32_t i = 0; i < count; ++i) any |= bytes[i];
  return (any & 0xFE) == 0;
}

template <class Pointer>
struct LoopFrame {
  Pointer base;  // the base to restore after the last element
  std::uint32_t remaining;
  std::uint32_t stride;
  std::uint32_t body;
};

struct Outcome {
  CodecError error = CodecError::ok;
  std::uint32_t pos = 0;   // body bytes read or written
  std::uint32_t tail = 0;  // decode: flat bytes used
};

// Decodes the `size` body bytes after the header into `flat`. kSwap: the data's byte order
// is not the host's.
template <bool kSwap>
Outcome decode_body(const Program& program, const std::uint8_t* in, std::uint32_t size,
                    std::byte* flat, std::uint32_t capacity) noexcept {
  std::uint32_t pos = 0;
  std::uint32_t limit = size;  // the end of the input or of the innermost DHEADER
  std::uint32_t tail = program.root_size;
  std::byte* base = flat;
  LoopFrame<std::byte*> loops[kMaxDepth];
  int loop_depth = 0;
  std::uint32_t limits[kMaxDepth];
  int limit_depth = 0;
  const Instr* const code = program.code.data();

  // Moves to the next multiple of `alignment` if `bytes` follow there before the limit.
  const auto seek = [&](std::uint32_t alignment, std::uint64_t bytes) noexcept {
    const std::uint64_t at = align_up(pos, alignment);
    if (at + bytes > limit) return false;
    pos = static_cast<std::uint32_t>(at);
    return true;
  };
  // Past the limit: the input ended early, or the data overruns its DHEADER.
  const auto short_read = [&]() noexcept {
    return Outcome{limit == size ? CodecError::truncated : CodecError::bad_value, pos, tail};
  };
  const auto fail = [&](CodecError error) noexcept { return Outcome{error, pos, tail}; };
  // Hands out `bytes` of tail at `alignment`, zeroing them and the gap before them.
  const auto take_tail = [&](std::uint64_t bytes, std::uint32_t alignment,
                             std::uint32_t& at) noexcept {
    const std::uint64_t start = align_up(tail, alignment);
    if (start + bytes > capacity) return false;
    std::memset(flat + tail, 0, static_cast<std::size_t>(start + bytes - tail));
    at = static_cast<std::uint32_t>(start);
    tail = static_cast<std::uint32_t>(start + bytes);
    return true;
  };

  for (const Instr* ip = code;;) {
    const Instr& op = *ip;
    switch (op.op) {
      case OpCode::block: {
        if (!seek(op.align, op.count)) return short_read();
        std::byte* to = base + op.offset;
        std::memcpy(to, in + pos, op.count);
        if constexpr (kSwap) {
          const Leaf* leaf = program.leaves.data() + op.aux;
          for (std::uint32_t i = 0; i < op.bound; ++i, ++leaf)
            swap_in_place(to + leaf->offset, leaf->size, leaf->count);
        }
        pos += op.count;
        ++ip;
        break;
      }
      case OpCode::booleans: {
        if (!seek(1, op.count)) return short_read();
        if (!booleans_ok(in + pos, op.count)) return fail(CodecError::bad_value);
        std::memcpy(base + op.offset, in + pos, op.count);
        pos += op.count;
        ++ip;
        break;
      }
      case OpCode::enums: {
        if (!seek(4, 4ull * op.count)) return short_read();
        std::byte* to = base + op.offset;
        for (std::uint32_t i = 0; i < op.count; ++i, pos += 4, to += 4) {
          const auto value = static_cast<std::int32_t>(load_u32(in + pos, kSwap));
          if (!enum_ok(program, op.aux, value)) return fail(CodecError::bad_value);
          store(to, value);
        }
        ++ip;
        break;
      }
      case OpCode::bounded_string:
      case OpCode::string: {
        if (!seek(4, 4)) return short_read();
        const std::uint32_t length = load_u32(in + pos, kSwap);  // with the NUL
        pos += 4;
        if (length == 0) return fail(CodecError::bad_value);
        if (op.bound > 0 && length - 1 > op.bound) return fail(CodecError::bound_exceeded);
        if (!seek(1, length)) return short_read();
        const std::uint8_t* chars = in + pos;
        if (chars[length - 1] != 0 || std::memchr(chars, 0, length - 1) != nullptr)
          return fail(CodecError::bad_value);
        if (op.op == OpCode::bounded_string) {
          std::memcpy(base + op.offset, chars, length);
        } else {
          std::uint32_t at = 0;
          if (!take_tail(length, 1, at)) return fail(CodecError::output_too_small);
          std::memcpy(flat + at, chars, length);
          store(base + op.offset, FlatSpan{at, length - 1});
        }
        pos += length;
        ++ip;
        break;
      }
      case OpCode::primitive_sequence: {
        if (!seek(4, 4)) return short_read();
        const std::uint32_t count = load_u32(in + pos, kSwap);
        pos += 4;
        if (op.bound > 0 && count > op.bound) return fail(CodecError::bound_exceeded);
        const std::uint64_t bytes = static_cast<std::uint64_t>(count) * op.elem_size;
        if (count > 0 && !seek(op.elem_align, bytes)) return short_read();
        std::byte* to = nullptr;
        if (op.bound > 0) {
          store(base + op.offset, count);
          to = base + op.offset + op.first;
        } else {
          std::uint32_t at = 0;
          if (count > 0 && !take_tail(bytes, op.tail_align, at))
            return fail(CodecError::output_too_small);
          store(base + op.offset, FlatSpan{count > 0 ? at : 0, count});
          to = flat + at;
        }
        if (count == 0) {
          ++ip;
          break;
        }
        const std::uint8_t* from = in + pos;
        if (op.elem_kind == ElemKind::enumeration) {
          for (std::uint32_t i = 0; i < count; ++i) {
            const auto value = static_cast<std::int32_t>(load_u32(from + 4 * i, kSwap));
            if (!enum_ok(program, op.aux, value)) return fail(CodecError::bad_value);
            store(to + 4 * i, value);
          }
        } else {
          if (op.elem_kind == ElemKind::boolean && !booleans_ok(from, count))
            return fail(CodecError::bad_value);
          std::memcpy(to, from, static_cast<std::size_t>(bytes));
          if constexpr (kSwap) swap_in_place(to, op.elem_size, count);
        }
        pos += static_cast<std::uint32_t>(bytes);
        ++ip;
        break;
      }
      case OpCode::sequence_loop: {
        if (!seek(4, 4)) return short_read();
        const std::uint32_t count = load_u32(in + pos, kSwap);
        pos += 4;
        if (op.bound > 0 && count > op.bound) return fail(CodecError::bound_exceeded);
        // Every element takes at least op.count bytes: a count the rest cannot hold is cut.
        if (count > (limit - pos) / op.count) return short_read();
        std::byte* first = nullptr;
        if (op.bound > 0) {
          store(base + op.offset, count);
          first = base + op.offset + op.first;
        } else if (count > 0) {
          std::uint32_t at = 0;
          if (!take_tail(static_cast<std::uint64_t>(count) * op.stride, op.tail_align, at))
            return fail(CodecError::output_too_small);
          store(base + op.offset, FlatSpan{at, count});
          first = flat + at;
        }
        if (count == 0) {
          if (op.bound == 0) store(base + op.offset, FlatSpan{0, 0});
          ip = code + op.aux + 1;  // past the loop_end
          break;
        }
        loops[loop_depth++] = LoopFrame<std::byte*>{base, count, op.stride,
                                                    static_cast<std::uint32_t>(ip - code) + 1};
        base = first;
        ++ip;
        break;
      }
      case OpCode::array_loop: {
        loops[loop_depth++] = LoopFrame<std::byte*>{base, op.count, op.stride,
                                                    static_cast<std::uint32_t>(ip - code) + 1};
        base += op.offset;
        ++ip;
        break;
      }
      case OpCode::loop_end: {
        LoopFrame<std::byte*>& frame = loops[loop_depth - 1];
        if (--frame.remaining > 0) {
          base += frame.stride;
          ip = code + frame.body;
        } else {
          base = frame.base;
          --loop_depth;
          ++ip;
        }
        break;
      }
      case OpCode::dheader_open: {
        if (!seek(4, 4)) return short_read();
        const std::uint32_t bytes = load_u32(in + pos, kSwap);
        pos += 4;
        if (bytes > limit - pos) return short_read();
        limits[limit_depth++] = limit;
        limit = pos + bytes;
        ++ip;
        break;
      }
      case OpCode::dheader_close:
        pos = limit;  // skips what a newer version of the type appended
        limit = limits[--limit_depth];
        ++ip;
        break;
      case OpCode::member_check:
        // A writer with an older version of the type stopped here: the rest get defaults.
        ip = pos >= limit ? code + op.aux : ip + 1;
        break;
      case OpCode::jump: ip = code + op.aux; break;
      case OpCode::enum_default: {
        std::byte* to = base + op.offset;
        for (std::uint32_t i = 0; i < op.count; ++i, to += 4)
          store(to, static_cast<std::int32_t>(op.aux));
        ++ip;
        break;
      }
      case OpCode::end: return Outcome{CodecError::ok, pos, tail};
    }
  }
}

// Encodes `flat` (a sample of `flat_size` bytes) into the `capacity` body bytes at `out`.
Outcome encode_body(const Program& program, const std::byte* flat, std::uint32_t flat_size,
                    std::uint8_t* out, std::uint32_t capacity) noexcept {
  std::uint32_t pos = 0;
  const std::byte* base = flat;
  LoopFrame<const std::byte*> loops[kMaxDepth];
  int loop_depth = 0;
  std::uint32_t dheaders[kMaxDepth];
  int dheader_depth = 0;
  const Instr* const code = program.code.data();

  // Pads with zeros to a multiple of `alignment` if `bytes` fit after that.
  const auto reserve = [&](std::uint32_t alignment, std::uint64_t bytes) noexcept {
    const std::uint64_t at = align_up(pos, alignment);
    if (at + bytes > capacity) return false;
    std::memset(out + pos, 0, static_cast<std::size_t>(at - pos));
    pos = static_cast<std::uint32_t>(at);
    return true;
  };
  const auto fail = [&](CodecError error) noexcept { return Outcome{error, pos, 0}; };
  const auto too_small = [&]() noexcept { return Outcome{CodecError::output_too_small, pos, 0}; };
  // The elements of the sequence at base + op.offset: count and first byte, checked
  // against the bound and the sample.
  const auto elements = [&](const Instr& op, std::uint32_t element_size, std::uint32_t& count,
                            const std::byte*& first) noexcept {
    if (op.bound > 0) {
      count = load<std::uint32_t>(base + op.offset);
      if (count > op.bound) return CodecError::bound_exceeded;
      first = base + op.offset + op.first;
      return CodecError::ok;
    }
    const auto span = load<FlatSpan>(base + op.offset);
    if (static_cast<std::uint64_t>(span.offset) +
            static_cast<std::uint64_t>(span.count) * element_size >
        flat_size)
      return CodecError::bad_value;
    count = span.count;
    first = flat + span.offset;
    return CodecError::ok;
  };

  for (const Instr* ip = code;;) {
    const Instr& op = *ip;
    switch (op.op) {
      case OpCode::block:
        if (!reserve(op.align, op.count)) return too_small();
        std::memcpy(out + pos, base + op.offset, op.count);
        pos += op.count;
        ++ip;
        break;
      case OpCode::booleans:
        if (!booleans_ok(base + op.offset, op.count)) return fail(CodecError::bad_value);
        if (!reserve(1, op.count)) return too_small();
        std::memcpy(out + pos, base + op.offset, op.count);
        pos += op.count;
        ++ip;
        break;
      case OpCode::enums: {
        if (!reserve(4, 4ull * op.count)) return too_small();
        const std::byte* from = base + op.offset;
        for (std::uint32_t i = 0; i < op.count; ++i, pos += 4, from += 4) {
          const auto value = load<std::int32_t>(from);
          if (!enum_ok(program, op.aux, value)) return fail(CodecError::bad_value);
          store(out + pos, value);
        }
        ++ip;
        break;
      }
      case OpCode::bounded_string:
      case OpCode::string: {
        const char* chars = nullptr;
        std::size_t length = 0;
        if (op.op == OpCode::bounded_string) {
          chars = reinterpret_cast<const char*>(base + op.offset);
          length = strnlen(chars, static_cast<std::size_t>(op.bound) + 1);
          if (length > op.bound) return fail(CodecError::bad_value);  // no NUL in char[N + 1]
        } else {
          const auto span = load<FlatSpan>(base + op.offset);
          if (static_cast<std::uint64_t>(span.offset) + span.count > flat_size ||
              span.count == std::numeric_limits<std::uint32_t>::max())
            return fail(CodecError::bad_value);
          chars = reinterpret_cast<const char*>(flat + span.offset);
          length = span.count;
          if (std::memchr(chars, 0, length) != nullptr) return fail(CodecError::bad_value);
        }
        if (!reserve(4, 4 + static_cast<std::uint64_t>(length) + 1)) return too_small();
        store(out + pos, static_cast<std::uint32_t>(length + 1));
        std::memcpy(out + pos + 4, chars, length);
        out[pos + 4 + length] = 0;
        pos += static_cast<std::uint32_t>(4 + length + 1);
        ++ip;
        break;
      }
      case OpCode::primitive_sequence: {
        std::uint32_t count = 0;
        const std::byte* first = nullptr;
        if (const CodecError error = elements(op, op.elem_size, count, first);
            error != CodecError::ok)
          return fail(error);
        if (op.elem_kind == ElemKind::boolean && !booleans_ok(first, count))
          return fail(CodecError::bad_value);
        if (!reserve(4, 4)) return too_small();
        store(out + pos, count);
        pos += 4;
        if (count > 0) {
          const std::uint64_t bytes = static_cast<std::uint64_t>(count) * op.elem_size;
          if (!reserve(op.elem_align, bytes)) return too_small();
          if (op.elem_kind == ElemKind::enumeration) {
            for (std::uint32_t i = 0; i < count; ++i) {
              const auto value = load<std::int32_t>(first + 4 * i);
              if (!enum_ok(program, op.aux, value)) return fail(CodecError::bad_value);
              store(out + pos + 4 * i, value);
            }
          } else {
            std::memcpy(out + pos, first, static_cast<std::size_t>(bytes));
          }
          pos += static_cast<std::uint32_t>(bytes);
        }
        ++ip;
        break;
      }
      case OpCode::sequence_loop: {
        std::uint32_t count = 0;
        const std::byte* first = nullptr;
        if (const CodecError error = elements(op, op.stride, count, first); error != CodecError::ok)
          return fail(error);
        if (!reserve(4, 4)) return too_small();
        store(out + pos, count);
        pos += 4;
        if (count == 0) {
          ip = code + op.aux + 1;  // past the loop_end
          break;
        }
        loops[loop_depth++] = LoopFrame<const std::byte*>{
            base, count, op.stride, static_cast<std::uint32_t>(ip - code) + 1};
        base = first;
        ++ip;
        break;
      }
      case OpCode::array_loop:
        loops[loop_depth++] = LoopFrame<const std::byte*>{
            base, op.count, op.stride, static_cast<std::uint32_t>(ip - code) + 1};
        base += op.offset;
        ++ip;
        break;
      case OpCode::loop_end: {
        LoopFrame<const std::byte*>& frame = loops[loop_depth - 1];
        if (--frame.remaining > 0) {
          base += frame.stride;
          ip = code + frame.body;
        } else {
          base = frame.base;
          --loop_depth;
          ++ip;
        }
        break;
      }
      case OpCode::dheader_open:
        if (!reserve(4, 4)) return too_small();
        dheaders[dheader_depth++] = pos;
        pos += 4;
        ++ip;
        break;
      case OpCode::dheader_close: {
        const std::uint32_t at = dheaders[--dheader_depth];
        store(out + at, pos - at - 4);
        ++ip;
        break;
      }
      case OpCode::member_check:
      case OpCode::enum_default: ++ip; break;  // never reached: the jump skips the defaults
      case OpCode::jump: ip = code + op.aux; break;
      case OpCode::end: return Outcome{CodecError::ok, pos, 0};
    }
  }
}

class CdrCodec final : public Codec {
 public:
  CdrCodec(const Type& type, WireFormat format, Program program)
      : type_(type), format_(format), program_(std::move(program)) {
    if (format == WireFormat::xcdr1) {
      big_id_ = kCdrBe;
      little_id_ = kCdrLe;
    } else if (program_.appendable_root) {
      big_id_ = kDelimitedCdr2Be;
      little_id_ = kDelimitedCdr2Le;
    } else {
      big_id_ = kPlainCdr2Be;
      little_id_ = kPlainCdr2Le;
    }
    // XCDR1 has no DHEADER: what follows an appendable top-level struct is what a newer
    // version of the type appended.
    tolerate_trailing_ = format == WireFormat::xcdr1 && program_.appendable_root;
  }

  WireFormat format() const noexcept override { return format_; }
  const Type& type() const noexcept override { return type_; }

  CodecResult decode(const std::byte* wire, std::uint32_t wire_size, std::byte* flat,
                     std::uint32_t flat_capacity) const noexcept override {
    if (wire_size < kHeaderSize) return {CodecError::truncated, 0, 0};
    const auto* in = reinterpret_cast<const std::uint8_t*>(wire);
    const auto id = static_cast<std::uint16_t>(in[0] << 8 | in[1]);
    if (id != big_id_ && id != little_id_) return {CodecError::bad_header, 0, 0};
    const std::uint32_t padding = in[3] & 3u;
    const std::uint32_t body = wire_size - kHeaderSize;
    if (padding > body) return {CodecError::bad_header, 0, 0};
    if (flat_capacity < program_.root_size) return {CodecError::output_too_small, 0, 0};
    if (program_.zero_fill) std::memset(flat, 0, program_.root_size);
    const bool swap = (id == little_id_) != kNativeLittle;
    const std::uint32_t size = body - padding;
    const Outcome outcome =
        swap ? decode_body<true>(program_, in + kHeaderSize, size, flat, flat_capacity)
             : decode_body<false>(program_, in + kHeaderSize, size, flat, flat_capacity);
    if (outcome.error != CodecError::ok) return {outcome.error, 0, 0};
    if (size - outcome.pos > 3 && !tolerate_trailing_) return {CodecError::trailing_bytes, 0, 0};
    return {CodecError::ok, outcome.tail, 0};
  }

  CodecResult encode(const std::byte* flat, std::uint32_t flat_size, std::byte* wire,
                     std::uint32_t wire_capacity) const noexcept override {
    if (flat_size < program_.root_size) return {CodecError::bad_value, 0, 0};
    if (wire_capacity < kHeaderSize) return {CodecError::output_too_small, 0, 0};
    auto* out = reinterpret_cast<std::uint8_t*>(wire);
    const std::uint16_t id = kNativeLittle ? little_id_ : big_id_;
    out[0] = static_cast<std::uint8_t>(id >> 8);
    out[1] = static_cast<std::uint8_t>(id);
    out[2] = 0;
    const Outcome outcome =
        encode_body(program_, flat, flat_size, out + kHeaderSize, wire_capacity - kHeaderSize);
    if (outcome.error != CodecError::ok) return {outcome.error, 0, 0};
    const std::uint32_t padding = (4 - outcome.pos % 4) % 4;
    const std::uint64_t total = std::uint64_t{kHeaderSize} + outcome.pos + padding;
    if (total > wire_capacity) return {CodecError::output_too_small, 0, 0};
    std::memset(out + kHeaderSize + outcome.pos, 0, padding);
    out[3] = static_cast<std::uint8_t>(padding);
    return {CodecError::ok, static_cast<std::uint32_t>(total), 0};
  }

  // One block from the flat sample's first byte to its last, nothing else: decode copies the
  // body as it is (the block starts the body, so it needs no alignment) and zeroes nothing.
  InPlaceLayout in_place() const noexcept override {
    const std::vector<Instr>& code = program_.code;
    const bool one_block = code.size() == 2 && code[0].op == OpCode::block && code[0].offset == 0 &&
                           code[0].count == program_.root_size && code[1].op == OpCode::end;
    if (!one_block || program_.root_size == 0 || program_.zero_fill || tolerate_trailing_ ||
        program_.appendable_root) {
      return {};
    }
    return {program_.root_size, kNativeLittle ? little_id_ : big_id_};
  }

  const void* program_data() const noexcept override { return program_.code.data(); }
  std::uint32_t max_wire_size(std::uint32_t flat_capacity) const noexcept override {
    const std::uint64_t tail =
        flat_capacity > program_.root_size ? flat_capacity - program_.root_size : 0;
    // The ratio is at most a few dozen, so the fixed-point product stays far below 2^64.
    const std::uint64_t tail_wire = (tail * program_.tail_ratio_q16 + 0xFFFF) >> 16;
    const std::uint64_t total = kHeaderSize + program_.fixed_wire_max + tail_wire + 3;
    return static_cast<std::uint32_t>(
        std::min<std::uint64_t>(total, std::numeric_limits<std::uint32_t>::max()));
  }

 private:
  const Type& type_;
  WireFormat format_;
  Program program_;
  std::uint16_t big_id_ = kCdrBe;
  std::uint16_t little_id_ = kCdrLe;
  bool tolerate_trailing_ = false;
};

}  // namespace

}  // namespace cdr

Result<std::unique_ptr<Codec>> make_cdr_codec(const Type& type, WireFormat format) {
  if (format != WireFormat::xcdr1 && format != WireFormat::xcdr2) {
    return make_error("the CDR codec writes xcdr1 or xcdr2, not " + std::string(to_string(format)));
  }
  cdr::Program program;
  const std::string why = cdr::compile_program(type, format == WireFormat::xcdr2, program);
  if (!why.empty()) {
    return make_error("cannot carry '" + type.name + "' in " + std::string(to_string(format)) +
                      ": " + why);
  }
  std::unique_ptr<Codec> codec = std::make_unique<cdr::CdrCodec>(type, format, std::move(program));
  return codec;
}

}  // namespace polyport
