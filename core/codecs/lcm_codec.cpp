// The LCM codec: between a flat sample of an LCM struct and LCM's wire format (an 8-byte
// big-endian fingerprint, then the members big-endian, nested structs inline without their
// own fingerprint, strings as int32 length with NUL + bytes + NUL, arrays without a length
// prefix: a variable dimension's length is an earlier integer member).
//
// Buffers and threads: encode() and decode() only read the caller's input and write the
// caller's output; both run on whatever thread forwards the sample. The codec owns just its
// program (built once by make_lcm_codec and never changed), so any number of threads may
// use one codec at once. Neither allocates, locks or throws: the per-call state is a small
// array of loop frames on the stack.
//
// The type is compiled into a flat program: runs of primitives become one instruction
// (8 doubles are one byte-swapping loop), fixed arrays of non-primitives and member-sized
// arrays become loops with a frame each. Frames hold flat offsets, not pointers, so every
// access is checked against the sample's size by the same arithmetic for both directions.
#include <algorithm>
#include <array>
#include <bit>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "polyport/codecs/codec.hpp"

namespace polyport {

namespace {

// Loop frames one sample may need (the root's plus one per nested array level). A deeper
// type is refused when the codec is made, so the run time never checks.
constexpr int kMaxFrames = 32;
// Struct nesting, so a hand-built or hostile type ends in an error, not a stack overflow.
constexpr int kMaxNesting = 64;
constexpr std::uint32_t kFingerprintSize = 8;
constexpr std::uint64_t kNoLimit = std::numeric_limits<std::uint32_t>::max();

enum class Op : std::uint8_t {
  scalars,           // `count` primitives of `width` bytes at base + offset
  string,            // a FlatSpan string at base + offset
  sequence_scalars,  // a member-sized array whose elements are primitives (or fixed arrays of
                     // them): FlatSpan at base + offset, `count` primitives per element
  loop_array,        // a fixed array of `count` non-primitive elements at base + offset
  loop_sequence,     // a member-sized array of non-primitive elements: FlatSpan at base + offset
  loop_end,          // next element (base += stride, back to `jump`), or close the frame
};

struct Instruction {
  Op op = Op::scalars;
  std::uint8_t width = 0;         // scalars, sequence_scalars: bytes per primitive
  bool boolean = false;           // scalars, sequence_scalars: only 0 and 1 are valid
  bool zero_fill = false;         // loop_sequence: the elements have padding to clear on decode
  std::uint8_t length_width = 0;  // sequences: bytes of the (signed) length member
  std::uint8_t up = 0;            // sequences: frames up to the struct holding the length member
  std::uint32_t offset = 0;       // in the current frame
  std::uint32_t count = 0;        // scalars, loop_array: elements; sequence_scalars: per element
  std::uint32_t length_offset = 0;  // sequences: the length member, in frame[top - up]
  std::uint32_t stride = 0;       // loops: flat bytes per element
  std::uint32_t align = 1;        // sequences: alignment of the elements' block in the tail
  std::uint32_t min_wire = 0;     // loop_sequence: least wire bytes of one element (may be 0)
  std::uint32_t jump = 0;         // loop_array/loop_sequence: past the loop; loop_end: body start
};

struct Frame {
  std::uint64_t base;
  std::uint32_t remaining;
};

// Loop control shared by the encoder and the decoder. Enters a loop of `count` elements
// starting at `base` (or jumps past it when empty); at loop_end, steps to the next element
// or leaves the loop.
inline void enter_loop(Frame* frames, int& top, std::uint64_t base, std::uint32_t count, const Instruction& in,
                       std::size_t& pc) noexcept {
  if (count == 0) {
    pc = in.jump;
    return;
  }
  frames[++top] = Frame{base, count};
  ++pc;
}

inline void end_loop(Frame* frames, int& top, const Instruction& in, std::size_t& pc) noexcept {
  Frame& frame = frames[top];
  if (--frame.remaining > 0) {
    frame.base += in.stride;
    pc = in.jump;
  } else {
    --top;
    ++pc;
  }
}

// ---- byte order -------------------------------------------------------------------------

template <class U>
U to_big_endian(U value) noexcept {
  if constexpr (std::endian::native == std::endian::big || sizeof(U) == 1) {
    return value;
  } else if constexpr (sizeof(U) == 2) {
    return __builtin_bswap16(value);
  } else if constexpr (sizeof(U) == 4) {
    return __builtin_bswap32(value);
  } else {
    return __builtin_bswap64(value);
  }
}

// Converts `count` values of U between the two byte orders (the same operation both ways).
// memcpy because neither side need be aligned; the compiler turns it into plain loads.
template <class U>
void swap_copy(const std::byte* from, std::byte* to, std::uint64_t count) noexcept {
  for (std::uint64_t i = 0; i < count; ++i) {
    U value;
    std::memcpy(&value, from + i * sizeof(U), sizeof(U));
    value = to_big_endian(value);
    std::memcpy(to + i * sizeof(U), &value, sizeof(U));
  }
}

void convert(const std::byte* from, std::byte* to, std::uint64_t count, std::uint8_t width) noexcept {
  switch (width) {
    case 1: std::memcpy(to, from, count); break;
    case 2: swap_copy<std::uint16_t>(from, to, count); break;
    case 4: swap_copy<std::uint32_t>(from, to, count); break;
    default: swap_copy<std::uint64_t>(from, to, count); break;
  }
}

bool booleans_valid(const std::byte* bytes, std::uint64_t count) noexcept {
  unsigned char high = 0;
  for (std::uint64_t i = 0; i < count; ++i) high |= static_cast<unsigned char>(bytes[i]);
  return high <= 1;
}

std::uint64_t load_be64(const std::byte* at) noexcept {
  std::uint64_t value;
  std::memcpy(&value, at, sizeof value);
  return to_big_endian(value);
}

void store_be64(std::byte* at, std::uint64_t value) noexcept {
  value = to_big_endian(value);
  std::memcpy(at, &value, sizeof value);
}

std::int32_t load_be_int32(const std::byte* at) noexcept {
  std::uint32_t value;
  std::memcpy(&value, at, sizeof value);
  return static_cast<std::int32_t>(to_big_endian(value));
}

void store_be_int32(std::byte* at, std::int32_t value) noexcept {
  const std::uint32_t bits = to_big_endian(static_cast<std::uint32_t>(value));
  std::memcpy(at, &bits, sizeof bits);
}

// A length member as the flat sample holds it: a native signed integer of 1 to 8 bytes.
std::int64_t load_length(const std::byte* at, std::uint8_t width) noexcept {
  switch (width) {
    case 1: return static_cast<std::int8_t>(at[0]);
    case 2: {
      std::int16_t value;
      std::memcpy(&value, at, sizeof value);
      return value;
    }
    case 4: {
      std::int32_t value;
      std::memcpy(&value, at, sizeof value);
      return value;
    }
    default: {
      std::int64_t value;
      std::memcpy(&value, at, sizeof value);
      return value;
    }
  }
}

FlatSpan load_span(const std::byte* at) noexcept {
  FlatSpan span;
  std::memcpy(&span, at, sizeof span);
  return span;
}

void store_span(std::byte* at, FlatSpan span) noexcept { std::memcpy(at, &span, sizeof span); }

std::uint64_t align_up(std::uint64_t value, std::uint64_t alignment) noexcept {
  return alignment <= 1 ? value : (value + alignment - 1) / alignment * alignment;
}

// ---- compiling a type ------------------------------------------------------------------

bool is_lcm_scalar(TypeKind kind) {
  switch (kind) {
    case TypeKind::boolean:
    case TypeKind::octet:
    case TypeKind::int8:
    case TypeKind::int16:
    case TypeKind::int32:
    case TypeKind::int64:
    case TypeKind::float32:
    case TypeKind::float64: return true;
    default: return false;
  }
}

bool is_length_kind(TypeKind kind) {
  return kind == TypeKind::int8 || kind == TypeKind::int16 || kind == TypeKind::int32 || kind == TypeKind::int64;
}

// Strips fixed dimensions: T[a][b] -> T, with a * b elements.
const Type& innermost(const Type& type, std::uint64_t& elements) {
  const Type* at = &type;
  elements = 1;
  while (at->kind == TypeKind::array && at->element != nullptr) {
    elements *= at->bound;
    at = at->element;
  }
  return *at;
}

// The fewest wire bytes a value of the type takes (strings: length and NUL; member-sized
// arrays: none), saturated at 2^32 - 1.
std::uint64_t min_wire_size(const Type& type, int nesting) {
  if (nesting > kMaxNesting) return 0;
  switch (type.kind) {
    case TypeKind::string: return 5;
    case TypeKind::sequence: return 0;
    case TypeKind::array:
    {
      const std::uint64_t element = type.element == nullptr ? 0 : min_wire_size(*type.element, nesting + 1);
      return element != 0 && type.bound > kNoLimit / element ? kNoLimit : type.bound * element;
    }
    case TypeKind::structure: {
      std::uint64_t sum = 0;
      for (const Field& field : type.fields) {
        if (field.type != nullptr) sum = std::min(kNoLimit, sum + min_wire_size(*field.type, nesting + 1));
      }
      return sum;
    }
    default: return type.size;
  }
}

// Whether the flat layout has padding bytes that decode would otherwise leave unwritten.
bool has_padding(const Type& type, int nesting) {
  if (nesting > kMaxNesting) return true;
  if (type.kind == TypeKind::array) return type.element != nullptr && has_padding(*type.element, nesting + 1);
  if (type.kind != TypeKind::structure) return false;
  std::uint64_t sum = 0;
  for (const Field& field : type.fields) {
    if (field.type == nullptr) continue;
    sum += field.type->size;
    if (has_padding(*field.type, nesting + 1)) return true;
  }
  return sum != type.size;
}

class Compiler {
 public:
  // Compiles `root`; returns an empty string on success or why the type is refused.
  std::string compile(const Type& root) {
    compile_struct(root, 0, 0, 0);
    return error_;
  }

  std::vector<Instruction> take() { return std::move(program_); }

 private:
  // Where the member being compiled gets its variable lengths from.
  struct MemberContext {
    const Type* owner;            // the struct that declares the member
    const Field* field;
    std::uint32_t owner_offset;   // of the owner in its frame
    int owner_depth;              // that frame
    std::size_t level = 0;        // next entry of field->length_fields
  };

  void refuse(const MemberContext* member, const std::string& why) {
    if (!error_.empty()) return;
    error_ = member == nullptr ? why
                               : "member '" + member->field->name + "' of '" + member->owner->name + "': " + why;
  }

  void compile_struct(const Type& type, std::uint32_t offset, int depth, int nesting) {
    if (nesting > kMaxNesting) {
      refuse(nullptr, "'" + type.name + "' is nested more than " + std::to_string(kMaxNesting) + " levels deep");
      return;
    }
    if (type.origin != TypeOrigin::lcm) {
      refuse(nullptr, "'" + type.name + "' is not a struct from an .lcm file");
      return;
    }
    for (const Field& field : type.fields) {
      if (!error_.empty()) return;
      MemberContext member{&type, &field, offset, depth};
      if (field.type == nullptr) {
        refuse(&member, "has no type");
        return;
      }
      compile_value(*field.type, offset + field.offset, depth, member, nesting);
      if (member.level != field.length_fields.size()) {
        refuse(&member, "names more length members than it has variable dimensions");
      }
    }
  }

  void emit_scalars(std::uint32_t offset, std::uint64_t count, const Type& scalar) {
    const auto width = static_cast<std::uint8_t>(scalar.size);
    const bool boolean = scalar.kind == TypeKind::boolean;
    if (!program_.empty()) {
      // Neighbouring members that are contiguous in both forms are one run.
      Instruction& last = program_.back();
      if (last.op == Op::scalars && last.width == width && last.boolean == boolean &&
          static_cast<std::uint64_t>(last.offset) + static_cast<std::uint64_t>(last.count) * width == offset &&
          last.count + count <= kNoLimit) {
        last.count += static_cast<std::uint32_t>(count);
        return;
      }
    }
    Instruction instruction;
    instruction.op = Op::scalars;
    instruction.width = width;
    instruction.boolean = boolean;
    instruction.offset = offset;
    instruction.count = static_cast<std::uint32_t>(count);
    program_.push_back(instruction);
  }

  // Opens a loop frame one deeper than `depth`; false (and refused) when too deep.
  bool can_open_frame(int depth, const MemberContext& member) {
    if (depth + 1 >= kMaxFrames) {
      refuse(&member, "more than " + std::to_string(kMaxFrames - 1) + " nested array levels");
      return false;
    }
    return true;
  }

  void close_loop(std::size_t begin, std::uint32_t stride) {
    Instruction end;
    end.op = Op::loop_end;
    end.stride = stride;
    end.jump = static_cast<std::uint32_t>(begin + 1);
    program_.push_back(end);
    program_[begin].jump = static_cast<std::uint32_t>(program_.size());
  }

  void compile_value(const Type& type, std::uint32_t offset, int depth, MemberContext& member, int nesting) {
    if (!error_.empty()) return;
    if (is_lcm_scalar(type.kind)) {
      emit_scalars(offset, 1, type);
      return;
    }
    switch (type.kind) {
      case TypeKind::string: {
        if (type.bound != 0) break;
        Instruction instruction;
        instruction.op = Op::string;
        instruction.offset = offset;
        program_.push_back(instruction);
        return;
      }
      case TypeKind::structure: compile_struct(type, offset, depth, nesting + 1); return;
      case TypeKind::array: {
        if (type.element == nullptr) break;
        // Fixed dimensions are contiguous row-major in both forms: one run or one loop.
        std::uint64_t elements = 0;
        const Type& element = innermost(type, elements);
        if (elements == 0) return;
        if (is_lcm_scalar(element.kind)) {
          emit_scalars(offset, elements, element);
          return;
        }
        if (!can_open_frame(depth, member)) return;
        const std::size_t begin = program_.size();
        Instruction loop;
        loop.op = Op::loop_array;
        loop.offset = offset;
        loop.count = static_cast<std::uint32_t>(elements);
        program_.push_back(loop);
        compile_value(element, 0, depth + 1, member, nesting + 1);
        close_loop(begin, element.size);
        return;
      }
      case TypeKind::sequence: {
        if (type.bound != 0 || type.element == nullptr) break;
        compile_sequence(type, offset, depth, member, nesting);
        return;
      }
      default: break;
    }
    refuse(&member, "LCM has no '" + type.name + "'");
  }

  void compile_sequence(const Type& type, std::uint32_t offset, int depth, MemberContext& member, int nesting) {
    const std::vector<std::string>& names = member.field->length_fields;
    if (member.level >= names.size()) {
      refuse(&member, "a variable dimension without a length member");
      return;
    }
    const std::string& length_name = names[member.level++];
    const Field* length = nullptr;
    for (const Field& field : member.owner->fields) {
      if (&field == member.field) break;  // only earlier members size an array
      if (field.name == length_name) length = &field;
    }
    if (length == nullptr || length->type == nullptr || !is_length_kind(length->type->kind)) {
      refuse(&member, "length '" + length_name + "' is not an earlier integer member");
      return;
    }
    Instruction instruction;
    instruction.offset = offset;
    instruction.length_offset = member.owner_offset + length->offset;
    instruction.length_width = static_cast<std::uint8_t>(length->type->size);
    instruction.up = static_cast<std::uint8_t>(depth - member.owner_depth);

    std::uint64_t per_element = 0;
    const Type& element = innermost(*type.element, per_element);
    if (is_lcm_scalar(element.kind)) {
      instruction.op = Op::sequence_scalars;
      instruction.width = static_cast<std::uint8_t>(element.size);
      instruction.boolean = element.kind == TypeKind::boolean;
      instruction.count = static_cast<std::uint32_t>(per_element);
      instruction.stride = type.element->size;
      instruction.align = element.align;
      program_.push_back(instruction);
      return;
    }
    if (type.element->size == 0) {
      // Elements of no size: neither the message nor the sample would bound the length, so
      // decoding could loop 2^31 times on a few bytes.
      refuse(&member, "a member-sized array of '" + type.element->name + "', which has no members");
      return;
    }
    if (!can_open_frame(depth, member)) return;
    instruction.op = Op::loop_sequence;
    instruction.stride = type.element->size;
    instruction.align = type.element->align;
    instruction.min_wire = static_cast<std::uint32_t>(min_wire_size(*type.element, nesting + 1));
    instruction.zero_fill = has_padding(*type.element, nesting + 1);
    const std::size_t begin = program_.size();
    program_.push_back(instruction);
    compile_value(*type.element, 0, depth + 1, member, nesting + 1);
    close_loop(begin, type.element->size);
  }

  std::vector<Instruction> program_;
  std::string error_;
};

// ---- the codec ------------------------------------------------------------------------

class LcmCodec final : public Codec {
 public:
  LcmCodec(const Type& type, std::vector<Instruction> program)
      : type_(type),
        program_(std::move(program)),
        fingerprint_(type.lcm_fingerprint),
        fixed_size_(type.size),
        min_wire_(min_wire_size(type, 0)),
        zero_fixed_(has_padding(type, 0)) {}

  WireFormat format() const noexcept override { return WireFormat::lcm; }
  const Type& type() const noexcept override { return type_; }

  const void* program_data() const noexcept override { return program_.data(); }
  std::uint32_t max_wire_size(std::uint32_t flat_capacity) const noexcept override {
    // Every flat byte beyond the fixed part carries at most one wire byte (a primitive is
    // the same size in both forms; a string's or array's FlatSpan is larger than its wire
    // form), so the fixed part's largest wire form plus the tail bounds the message.
    const std::uint64_t tail = flat_capacity > fixed_size_ ? flat_capacity - fixed_size_ : 0;
    return static_cast<std::uint32_t>(std::min<std::uint64_t>(kNoLimit, kFingerprintSize + min_wire_ + tail));
  }

  CodecResult decode(const std::byte* wire, std::uint32_t wire_size, std::byte* flat,
                     std::uint32_t flat_capacity) const noexcept override {
    if (flat_capacity < fixed_size_) return {CodecError::output_too_small};
    if (wire_size < kFingerprintSize) return {CodecError::truncated};
    if (load_be64(wire) != fingerprint_) return {CodecError::fingerprint_mismatch};
    if (zero_fixed_) std::memset(flat, 0, fixed_size_);

    std::uint64_t pos = kFingerprintSize;
    std::uint64_t tail = fixed_size_;
    const std::uint64_t capacity = flat_capacity;
    std::array<Frame, kMaxFrames> frames;
    int top = 0;
    frames[0] = Frame{0, 1};
    const Instruction* const program = program_.data();
    const std::size_t size = program_.size();
    std::size_t pc = 0;
    while (pc < size) {
      const Instruction& in = program[pc];
      const std::uint64_t base = frames[top].base;
      switch (in.op) {
        case Op::scalars: {
          const std::uint64_t bytes = static_cast<std::uint64_t>(in.count) * in.width;
          if (bytes > wire_size - pos) return {CodecError::truncated};
          if (in.boolean && !booleans_valid(wire + pos, in.count)) return {CodecError::bad_value};
          convert(wire + pos, flat + base + in.offset, in.count, in.width);
          pos += bytes;
          ++pc;
          break;
        }
        case Op::string: {
          if (wire_size - pos < 4) return {CodecError::truncated};
          const std::int32_t length = load_be_int32(wire + pos);
          pos += 4;
          if (length < 1) return {CodecError::bad_value};  // the NUL is always counted
          if (static_cast<std::uint64_t>(length) > wire_size - pos) return {CodecError::truncated};
          if (wire[pos + length - 1] != std::byte{0}) return {CodecError::bad_value};
          if (static_cast<std::uint64_t>(length) > capacity - tail) return {CodecError::output_too_small};
          std::memcpy(flat + tail, wire + pos, static_cast<std::size_t>(length));
          store_span(flat + base + in.offset,
                     FlatSpan{static_cast<std::uint32_t>(tail), static_cast<std::uint32_t>(length - 1)});
          tail += static_cast<std::uint64_t>(length);
          pos += static_cast<std::uint64_t>(length);
          ++pc;
          break;
        }
        case Op::sequence_scalars: {
          const std::int64_t length = load_length(flat + frames[top - in.up].base + in.length_offset, in.length_width);
          if (length < 0) return {CodecError::bad_value};
          const std::uint64_t per_element = static_cast<std::uint64_t>(in.count) * in.width;
          if (per_element != 0 && static_cast<std::uint64_t>(length) > (wire_size - pos) / per_element) {
            return {CodecError::truncated};
          }
          const std::uint64_t bytes = static_cast<std::uint64_t>(length) * per_element;
          const std::uint64_t start = align_up(tail, in.align);
          if (start > capacity || bytes > capacity - start) return {CodecError::output_too_small};
          std::memset(flat + tail, 0, start - tail);
          if (in.boolean && !booleans_valid(wire + pos, bytes)) return {CodecError::bad_value};
          convert(wire + pos, flat + start, bytes / in.width, in.width);
          store_span(flat + base + in.offset,
                     FlatSpan{static_cast<std::uint32_t>(start), static_cast<std::uint32_t>(length)});
          tail = start + bytes;
          pos += bytes;
          ++pc;
          break;
        }
        case Op::loop_array:
          frames[++top] = Frame{base + in.offset, in.count};
          ++pc;
          break;
        case Op::loop_sequence: {
          const std::int64_t length = load_length(flat + frames[top - in.up].base + in.length_offset, in.length_width);
          if (length < 0) return {CodecError::bad_value};
          // Every element takes at least min_wire bytes: a length the rest of the message
          // cannot hold is refused before any work. Elements that may take none (arrays of
          // arrays sized by a zero) are bounded by the sample's room instead, just below.
          if (in.min_wire != 0 && static_cast<std::uint64_t>(length) > (wire_size - pos) / in.min_wire) {
            return {CodecError::truncated};
          }
          const std::uint64_t start = align_up(tail, in.align);
          if (start > capacity || static_cast<std::uint64_t>(length) > (capacity - start) / in.stride) {
            return {CodecError::output_too_small};
          }
          const std::uint64_t bytes = static_cast<std::uint64_t>(length) * in.stride;
          std::memset(flat + tail, 0, start - tail);
          if (in.zero_fill) std::memset(flat + start, 0, bytes);
          store_span(flat + base + in.offset,
                     FlatSpan{static_cast<std::uint32_t>(start), static_cast<std::uint32_t>(length)});
          tail = start + bytes;
          enter_loop(frames.data(), top, start, static_cast<std::uint32_t>(length), in, pc);
          break;
        }
        case Op::loop_end:
          end_loop(frames.data(), top, in, pc);
          break;
      }
    }
    if (pos != wire_size) return {CodecError::trailing_bytes};
    return {CodecError::ok, static_cast<std::uint32_t>(tail)};
  }

  CodecResult encode(const std::byte* flat, std::uint32_t flat_size, std::byte* wire,
                     std::uint32_t wire_capacity) const noexcept override {
    if (flat_size < fixed_size_) return {CodecError::truncated};
    if (wire_capacity < kFingerprintSize) return {CodecError::output_too_small};
    store_be64(wire, fingerprint_);

    std::uint64_t pos = kFingerprintSize;
    const std::uint64_t capacity = wire_capacity;
    std::array<Frame, kMaxFrames> frames;
    int top = 0;
    frames[0] = Frame{0, 1};
    const Instruction* const program = program_.data();
    const std::size_t size = program_.size();
    std::size_t pc = 0;
    // A span's `count` elements of `element_size` bytes must lie inside the sample.
    const auto span_fits = [flat_size](FlatSpan span, std::uint64_t element_size) {
      return span.offset <= flat_size &&
             (element_size == 0 || span.count <= (flat_size - span.offset) / element_size);
    };
    while (pc < size) {
      const Instruction& in = program[pc];
      const std::uint64_t base = frames[top].base;
      switch (in.op) {
        case Op::scalars: {
          const std::uint64_t bytes = static_cast<std::uint64_t>(in.count) * in.width;
          if (bytes > capacity - pos) return {CodecError::output_too_small};
          const std::byte* from = flat + base + in.offset;
          if (in.boolean && !booleans_valid(from, in.count)) return {CodecError::bad_value};
          convert(from, wire + pos, in.count, in.width);
          pos += bytes;
          ++pc;
          break;
        }
        case Op::string: {
          const FlatSpan span = load_span(flat + base + in.offset);
          // The wire length counts the NUL and is an int32.
          if (!span_fits(span, 1) || span.count >= 0x7FFFFFFFu) return {CodecError::bad_value};
          if (static_cast<std::uint64_t>(span.count) + 5 > capacity - pos) return {CodecError::output_too_small};
          store_be_int32(wire + pos, static_cast<std::int32_t>(span.count + 1));
          std::memcpy(wire + pos + 4, flat + span.offset, span.count);
          wire[pos + 4 + span.count] = std::byte{0};
          pos += static_cast<std::uint64_t>(span.count) + 5;
          ++pc;
          break;
        }
        case Op::sequence_scalars: {
          const std::int64_t length = load_length(flat + frames[top - in.up].base + in.length_offset, in.length_width);
          const FlatSpan span = load_span(flat + base + in.offset);
          if (length < 0 || static_cast<std::uint64_t>(length) != span.count) return {CodecError::bad_value};
          const std::uint64_t per_element = static_cast<std::uint64_t>(in.count) * in.width;
          if (!span_fits(span, per_element)) return {CodecError::bad_value};
          const std::uint64_t bytes = span.count * per_element;
          if (bytes > capacity - pos) return {CodecError::output_too_small};
          if (in.boolean && !booleans_valid(flat + span.offset, bytes)) return {CodecError::bad_value};
          convert(flat + span.offset, wire + pos, bytes / in.width, in.width);
          pos += bytes;
          ++pc;
          break;
        }
        case Op::loop_array:
          frames[++top] = Frame{base + in.offset, in.count};
          ++pc;
          break;
        case Op::loop_sequence: {
          const std::int64_t length = load_length(flat + frames[top - in.up].base + in.length_offset, in.length_width);
          const FlatSpan span = load_span(flat + base + in.offset);
          if (length < 0 || static_cast<std::uint64_t>(length) != span.count) return {CodecError::bad_value};
          if (!span_fits(span, in.stride)) return {CodecError::bad_value};
          enter_loop(frames.data(), top, span.offset, span.count, in, pc);
          break;
        }
        case Op::loop_end:
          end_loop(frames.data(), top, in, pc);
          break;
      }
    }
    return {CodecError::ok, static_cast<std::uint32_t>(pos)};
  }

 private:
  const Type& type_;
  const std::vector<Instruction> program_;
  const std::uint64_t fingerprint_;
  const std::uint32_t fixed_size_;
  const std::uint64_t min_wire_;
  const bool zero_fixed_;
};

}  // namespace

Result<std::unique_ptr<Codec>> make_lcm_codec(const Type& type) {
  const Type& resolved = type.resolved();
  if (resolved.kind != TypeKind::structure || resolved.origin != TypeOrigin::lcm) {
    return make_error("no lcm codec for '" + type.name +
                      "': only structs declared in .lcm files have an LCM fingerprint and layout");
  }
  Compiler compiler;
  const std::string why = compiler.compile(resolved);
  if (!why.empty()) return make_error("no lcm codec for '" + resolved.name + "': " + why);
  return std::unique_ptr<Codec>(new LcmCodec(resolved, compiler.take()));
}

}  // namespace polyport
