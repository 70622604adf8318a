// The program a CDR codec runs: a flat vector of Instr plus small side tables, compiled from a
// type once, at load time (cdr_compiler.cpp), and never modified afterwards. decode() and
// encode() (cdr_codec.cpp) only read it, so any number of threads may run one program at once.
// What the instructions put on the wire is described at the top of cdr_codec.cpp.
//
// Private to the codecs layer; hidden, so that nothing here is exported from libpolyport_core
// (as nothing was while it all lived in one file's anonymous namespace).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "polyport/types/types.hpp"

#pragma GCC visibility push(hidden)

namespace polyport::cdr {

// Nesting of sequences/arrays of non-primitive elements, and of DHEADERs, that a program
// may have: the run loops keep these stacks in fixed arrays.
constexpr int kMaxDepth = 32;

enum class OpCode : std::uint8_t {
  block,               // primitives laid out alike in flat and CDR: align, copy `count` bytes
  booleans,            // `count` booleans, each 0 or 1
  enums,               // `count` int32 enumerators, each a declared value
  bounded_string,      // char[bound + 1]
  string,              // FlatSpan into the tail
  primitive_sequence,  // sequence of primitives, booleans or enumerators, copied in bulk
  array_loop,          // runs the body `count` times, the base advancing by `stride`
  sequence_loop,       // writes/reads the length, then runs the body once per element
  loop_end,            // back to the body while elements remain
  dheader_open,        // XCDR2 DHEADER: reserve (encode) or read and bound by (decode)
  dheader_close,       // patch the size in (encode) or skip to the DHEADER's end (decode)
  member_check,        // decode, appendable struct: members from here on absent if at its end
  jump,                // to `aux` (over the defaults of absent members)
  enum_default,        // decode: `count` absent enumerators take their default, `aux`
  end,
};

enum class ElemKind : std::uint8_t { plain, boolean, enumeration, composite };

struct Instr {
  OpCode op = OpCode::end;
  std::uint8_t align = 1;       // CDR alignment of the first thing written
  std::uint8_t elem_size = 0;   // primitive sequences: bytes per element
  std::uint8_t elem_align = 1;  // primitive sequences: CDR alignment of the elements
  ElemKind elem_kind = ElemKind::plain;
  std::uint32_t offset = 0;      // flat offset from the current base
  std::uint32_t count = 0;       // block: bytes; booleans, enums, array_loop: elements;
                                 // sequence_loop: least wire bytes of one element
  std::uint32_t bound = 0;       // strings and sequences: bound (0 = unbounded); block: leaves
  std::uint32_t stride = 0;      // sequences and loops: flat bytes per element
  std::uint32_t first = 0;       // bounded sequences: offset of element 0 from the length
  std::uint32_t tail_align = 1;  // unbounded sequences: alignment of the elements in the tail
  std::uint32_t aux = 0;         // block: first leaf; enums: enum table; loops: index of their
                                 // loop_end; loop_end: body start; member_check: defaults of
                                 // the absent members; jump: target; enum_default: the value
};

// A run of primitives inside a block, for byte swapping: `count` items of `size` bytes at
// `offset` from the block's start.
struct Leaf {
  std::uint32_t offset;
  std::uint32_t count;
  std::uint32_t size;
};

struct EnumTable {
  std::int32_t min = 0;
  std::int32_t max = -1;
  bool dense = false;       // every value in [min, max] is an enumerator
  std::uint32_t first = 0;  // sorted values in Program::enum_values
  std::uint32_t count = 0;
};

struct Program {
  std::vector<Instr> code;
  std::vector<Leaf> leaves;
  std::vector<EnumTable> enums;
  std::vector<std::int32_t> enum_values;
  std::uint32_t root_size = 0;
  bool zero_fill = true;  // decode must zero the fixed part first
  bool appendable_root = false;
  // max_wire_size(): wire bytes of the fixed part at most, and at most how many wire bytes
  // one byte of tail turns into, in 1/65536 (rounded up).
  std::uint64_t fixed_wire_max = 0;
  std::uint64_t tail_ratio_q16 = 0;  // no unbounded members: the tail adds nothing
};

inline std::uint64_t align_up(std::uint64_t value, std::uint64_t alignment) noexcept {
  return (value + alignment - 1) & ~(alignment - 1);
}

// Compiles `root` into `program` for XCDR2 (`xcdr2`) or XCDR1 (cdr_compiler.cpp). Empty
// string on success, else why the type cannot be carried.
std::string compile_program(const Type& root, bool xcdr2, Program& program);

}  // namespace polyport::cdr

#pragma GCC visibility pop
