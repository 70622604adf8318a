// Compiling a type into the program a CDR codec runs (cdr_program.hpp), once per (type,
// format), at load time, for make_cdr_codec() (cdr_codec.cpp): the instructions for every
// member, merged into blocks where flat and CDR lay primitives out alike; the defaults of the
// members an older writer leaves out of an appendable struct; the least wire size of a
// sequence's element, which bounds the element count a header may claim; and the most wire
// bytes a sample can take, for max_wire_size(). A type CDR cannot carry is refused here,
// naming the member and why. The wire format itself is described at the top of cdr_codec.cpp.
#include "cdr_program.hpp"

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

namespace polyport::cdr {

namespace {

std::uint32_t cdr_align(std::uint32_t size, bool xcdr2) noexcept {
  return std::min<std::uint32_t>(size, xcdr2 ? 4u : 8u);
}

bool is_plain(TypeKind kind) noexcept {
  return kind != TypeKind::boolean && kind >= TypeKind::char8 && kind <= TypeKind::float64;
}

// ---- compiling a type into a program ------------------------------------------------------

class Compiler {
 public:
  explicit Compiler(bool xcdr2) : xcdr2_(xcdr2) {}

  // Empty string on success, else why the type cannot be carried.
  std::string compile(const Type& root, Program& program) {
    program_ = &program;
    const Type& type = root.resolved();
    program.root_size = root.size;
    program.appendable_root =
        type.kind == TypeKind::structure && type.extensibility == Extensibility::appendable;
    covered_ = 0;
    if (!emit(root, 0, root.name, 0, 0)) return error_;
    emit_op(Instr{.op = OpCode::end});
    // Skip zeroing when the program writes every byte of the fixed part: no padding, no
    // bounded containers, no members that may be absent.
    program.zero_fill = !(covered_ == root.size && all_fixed_);
    Cursor cursor;
    program.fixed_wire_max = wire_max(root, cursor, 0);
    if (!tail_ratio(root, 0)) return error_;
    return {};
  }

 private:
  bool fail(const std::string& path, const std::string& why) {
    error_ = "member '" + path + "': " + why;
    return false;
  }

  std::uint32_t emit_op(const Instr& instr) {
    program_->code.push_back(instr);
    return static_cast<std::uint32_t>(program_->code.size() - 1);
  }

  // A run of `count` primitives of `size` bytes at flat `offset`: appended to the previous
  // block when it continues it without padding, in flat and in CDR alike.
  void emit_leaf(std::uint32_t offset, std::uint32_t size, std::uint32_t count) {
    const std::uint32_t align = cdr_align(size, xcdr2_);
    const std::uint32_t bytes = size * count;
    covered_ += bytes;
    std::vector<Instr>& code = program_->code;
    if (!code.empty()) {
      Instr& last = code.back();
      if (last.op == OpCode::block && align <= last.align && offset == last.offset + last.count &&
          last.count % align == 0 &&
          last.count <= std::numeric_limits<std::uint32_t>::max() - bytes) {
        program_->leaves.push_back(Leaf{last.count, count, size});
        last.count += bytes;
        ++last.bound;
        return;
      }
    }
    Instr block{.op = OpCode::block,
                .align = static_cast<std::uint8_t>(align),
                .offset = offset,
                .count = bytes,
                .bound = 1,
                .aux = static_cast<std::uint32_t>(program_->leaves.size())};
    program_->leaves.push_back(Leaf{0, count, size});
    emit_op(block);
  }

  std::uint32_t enum_table(const Type& type) {
    for (std::size_t i = 0; i < enum_types_.size(); ++i) {
      if (enum_types_[i] == &type) return static_cast<std::uint32_t>(i);
    }
    std::vector<std::int32_t> values;
    for (const Enumerator& enumerator : type.enumerators) values.push_back(enumerator.value);
    std::sort(values.begin(), values.end());
    values.erase(std::unique(values.begin(), values.end()), values.end());
    EnumTable table;
    table.first = static_cast<std::uint32_t>(program_->enum_values.size());
    table.count = static_cast<std::uint32_t>(values.size());
    if (!values.empty()) {
      table.min = values.front();
      table.max = values.back();
      table.dense = static_cast<std::int64_t>(table.max) - table.min + 1 ==
                    static_cast<std::int64_t>(values.size());
    }
    program_->enum_values.insert(program_->enum_values.end(), values.begin(), values.end());
    program_->enums.push_back(table);
    enum_types_.push_back(&type);
    return static_cast<std::uint32_t>(program_->enums.size() - 1);
  }

  // Arrays of arrays are one array of the innermost element (idlc does the same).
  static const Type& innermost(const Type& array, std::uint64_t& count) {
    const Type* type = &array;
    count = 1;
    while (type->kind == TypeKind::array && type->element != nullptr) {
      count *= type->bound;
      type = &type->element->resolved();
    }
    return *type;
  }

  bool check_element(const Type& type, const std::string& path) {
    if (type.element == nullptr) return fail(path, "'" + type.name + "' has no element type");
    return true;
  }

  // Emits the instructions for a `declared` value at flat `offset` from the current base.
  bool emit(const Type& declared, std::uint32_t offset, const std::string& path, int loops,
            int dheaders) {
    const Type& type = declared.resolved();
    if (type.kind == TypeKind::alias)
      return fail(path, "typedef '" + declared.name + "' is unresolved");
    if (type.is_primitive()) {
      if (type.kind == TypeKind::boolean) {
        covered_ += 1;
        std::vector<Instr>& code = program_->code;
        if (!code.empty() && code.back().op == OpCode::booleans &&
            code.back().offset + code.back().count == offset) {
          ++code.back().count;
        } else {
          emit_op(Instr{.op = OpCode::booleans, .offset = offset, .count = 1});
        }
        return true;
      }
      emit_leaf(offset, type.size, 1);
      return true;
    }
    switch (type.kind) {
      case TypeKind::enumeration:
        covered_ += 4;
        emit_op(Instr{.op = OpCode::enums,
                      .align = 4,
                      .offset = offset,
                      .count = 1,
                      .aux = enum_table(type)});
        return true;
      case TypeKind::string:
        all_fixed_ = false;
        emit_op(Instr{.op = type.bound > 0 ? OpCode::bounded_string : OpCode::string,
                      .align = 4,
                      .offset = offset,
                      .bound = type.bound});
        return true;
      case TypeKind::structure: return emit_struct(type, offset, path, loops, dheaders);
      case TypeKind::array: return emit_array(type, offset, path, loops, dheaders);
      case TypeKind::sequence: return emit_sequence(type, offset, path, loops, dheaders);
      default: break;
    }
    return fail(path, "type '" + declared.name + "' cannot be carried in CDR");
  }

  bool emit_struct(const Type& type, std::uint32_t offset, const std::string& path, int loops,
                   int dheaders) {
    if (type.extensibility == Extensibility::mutable_) {
      return fail(path, "mutable struct '" + type.name +
                            "' is not supported yet (it needs the PL_CDR encodings)");
    }
    if (type.fields.empty()) return fail(path, "struct '" + type.name + "' has no members");
    const bool delimited = xcdr2_ && type.extensibility == Extensibility::appendable;
    std::vector<std::uint32_t> checks;
    if (delimited) {
      if (dheaders + 1 > kMaxDepth) return fail(path, "nests DHEADERs too deeply");
      all_fixed_ = false;
      emit_op(Instr{.op = OpCode::dheader_open, .align = 4});
    }
    for (const Field& field : type.fields) {
      const std::string member = path + "." + field.name;
      if (field.type == nullptr) return fail(member, "has no type");
      if (delimited) checks.push_back(emit_op(Instr{.op = OpCode::member_check}));
      if (!emit(*field.type, offset + field.offset, member, loops, dheaders + (delimited ? 1 : 0)))
        return false;
    }
    if (!delimited) return true;
    // Members an older writer did not send take their default values: zero, which decode
    // has written already, except enumerations, whose default is their first enumerator
    // (XTypes, as there is no @default_literal). A member_check that finds the DHEADER's end jumps
    // to the defaults of its member, which run on through those of the members after it.
    const std::uint32_t skip = emit_op(Instr{.op = OpCode::jump});
    for (std::size_t i = 0; i < type.fields.size(); ++i) {
      program_->code[checks[i]].aux = static_cast<std::uint32_t>(program_->code.size());
      if (!emit_defaults(*type.fields[i].type, offset + type.fields[i].offset, loops)) {
        return fail(path + "." + type.fields[i].name, "nests arrays too deeply");
      }
    }
    program_->code[skip].aux = emit_op(Instr{.op = OpCode::dheader_close});
    return true;
  }

  // Whether a value of `type` holds an enumeration whose default (first enumerator) is not 0,
  // outside sequences (absent sequences are empty).
  static bool needs_defaults(const Type& declared, int depth = 0) {
    const Type& type = declared.resolved();
    if (depth > 4 * kMaxDepth) return false;
    switch (type.kind) {
      case TypeKind::enumeration:
        return !type.enumerators.empty() && type.enumerators.front().value != 0;
      case TypeKind::structure:
        return std::any_of(type.fields.begin(), type.fields.end(), [&](const Field& field) {
          return field.type != nullptr && needs_defaults(*field.type, depth + 1);
        });
      case TypeKind::array: {
        std::uint64_t count = 0;
        return needs_defaults(innermost(type, count), depth + 1);
      }
      default: return false;
    }
  }

  // Sets the enumerations in an absent value of `type` at `offset` to their defaults.
  bool emit_defaults(const Type& declared, std::uint32_t offset, int loops) {
    const Type& type = declared.resolved();
    if (!needs_defaults(type)) return true;
    switch (type.kind) {
      case TypeKind::enumeration:
        emit_op(Instr{.op = OpCode::enum_default,
                      .offset = offset,
                      .count = 1,
                      .aux = static_cast<std::uint32_t>(type.enumerators.front().value)});
        return true;
      case TypeKind::structure:
        for (const Field& field : type.fields) {
          if (!emit_defaults(*field.type, offset + field.offset, loops)) return false;
        }
        return true;
      case TypeKind::array: {
        std::uint64_t count = 0;
        const Type& element = innermost(type, count);
        if (element.kind == TypeKind::enumeration) {
          emit_op(Instr{.op = OpCode::enum_default,
                        .offset = offset,
                        .count = static_cast<std::uint32_t>(count),
                        .aux = static_cast<std::uint32_t>(element.enumerators.front().value)});
          return true;
        }
        if (loops + 1 > kMaxDepth) return false;
        const std::uint32_t loop = emit_op(Instr{.op = OpCode::array_loop,
                                                 .offset = offset,
                                                 .count = static_cast<std::uint32_t>(count),
                                                 .stride = element.size});
        if (!emit_defaults(element, 0, loops + 1)) return false;
        const std::uint32_t end = emit_op(Instr{.op = OpCode::loop_end, .aux = loop + 1});
        program_->code[loop].aux = end;
        return true;
      }
      default: return true;
    }
  }

  bool emit_array(const Type& type, std::uint32_t offset, const std::string& path, int loops,
                  int dheaders) {
    if (!check_element(type, path)) return false;
    std::uint64_t count = 0;
    const Type& element = innermost(type, count);
    if (count > std::numeric_limits<std::uint32_t>::max()) return fail(path, "array is too large");
    const auto n = static_cast<std::uint32_t>(count);
    if (is_plain(element.kind)) {
      emit_leaf(offset, element.size, n);
      return true;
    }
    if (element.kind == TypeKind::boolean) {
      covered_ += n;
      emit_op(Instr{.op = OpCode::booleans, .offset = offset, .count = n});
      return true;
    }
    const bool delimited = xcdr2_;  // elements are not primitive
    if (delimited) {
      if (dheaders + 1 > kMaxDepth) return fail(path, "nests DHEADERs too deeply");
      emit_op(Instr{.op = OpCode::dheader_open, .align = 4});
    }
    if (element.kind == TypeKind::enumeration) {
      covered_ += 4 * n;
      emit_op(Instr{.op = OpCode::enums,
                    .align = 4,
                    .offset = offset,
                    .count = n,
                    .aux = enum_table(element)});
    } else {
      if (loops + 1 > kMaxDepth) return fail(path, "nests arrays and sequences too deeply");
      all_fixed_ = false;
      const std::uint32_t loop = emit_op(
          Instr{.op = OpCode::array_loop, .offset = offset, .count = n, .stride = element.size});
      const std::uint64_t covered = covered_;
      if (!emit(element, 0, path + "[]", loops + 1, dheaders + (delimited ? 1 : 0))) return false;
      covered_ = covered;
      const std::uint32_t end = emit_op(Instr{.op = OpCode::loop_end, .aux = loop + 1});
      program_->code[loop].aux = end;
    }
    if (delimited) emit_op(Instr{.op = OpCode::dheader_close});
    return true;
  }

  bool emit_sequence(const Type& type, std::uint32_t offset, const std::string& path, int loops,
                     int dheaders) {
    if (!check_element(type, path)) return false;
    all_fixed_ = false;
    const Type& element = type.element->resolved();
    if (element.kind == TypeKind::alias)
      return fail(path, "typedef '" + type.element->name + "' is unresolved");
    const std::uint32_t first =
        type.bound > 0 ? static_cast<std::uint32_t>(align_up(sizeof(std::uint32_t), element.align))
                       : 0;
    Instr seq{.align = 4,
              .offset = offset,
              .bound = type.bound,
              .stride = element.size,
              .first = first,
              .tail_align = std::max<std::uint32_t>(element.align, 1)};
    if (is_plain(element.kind) || element.kind == TypeKind::boolean) {
      seq.op = OpCode::primitive_sequence;
      seq.elem_size = static_cast<std::uint8_t>(element.size);
      seq.elem_align = static_cast<std::uint8_t>(cdr_align(element.size, xcdr2_));
      seq.elem_kind = element.kind == TypeKind::boolean ? ElemKind::boolean : ElemKind::plain;
      emit_op(seq);
      return true;
    }
    const bool delimited = xcdr2_;
    if (delimited) {
      if (dheaders + 1 > kMaxDepth) return fail(path, "nests DHEADERs too deeply");
      emit_op(Instr{.op = OpCode::dheader_open, .align = 4});
    }
    if (element.kind == TypeKind::enumeration) {
      seq.op = OpCode::primitive_sequence;
      seq.elem_size = 4;
      seq.elem_align = 4;
      seq.elem_kind = ElemKind::enumeration;
      seq.aux = enum_table(element);
      emit_op(seq);
    } else {
      if (loops + 1 > kMaxDepth) return fail(path, "nests arrays and sequences too deeply");
      seq.op = OpCode::sequence_loop;
      seq.elem_kind = ElemKind::composite;
      seq.count = std::max<std::uint64_t>(
          1,
          std::min<std::uint64_t>(wire_min(element, 0), std::numeric_limits<std::uint32_t>::max()));
      const std::uint32_t loop = emit_op(seq);
      const std::uint64_t covered = covered_;
      if (!emit(element, 0, path + "[]", loops + 1, dheaders + (delimited ? 1 : 0))) return false;
      covered_ = covered;
      const std::uint32_t end = emit_op(Instr{.op = OpCode::loop_end, .aux = loop + 1});
      program_->code[loop].aux = end;
    }
    if (delimited) emit_op(Instr{.op = OpCode::dheader_close});
    return true;
  }

  // The least number of wire bytes a value of `type` takes (no padding counted): bounds the
  // element count a sequence header may claim, so a few bytes cannot start a huge loop.
  std::uint64_t wire_min(const Type& declared, int depth) const {
    const Type& type = declared.resolved();
    if (depth > 4 * kMaxDepth) return 1;
    if (type.is_primitive()) return type.size;
    switch (type.kind) {
      case TypeKind::enumeration: return 4;
      case TypeKind::string: return 5;  // length and NUL
      case TypeKind::sequence: return xcdr2_ && !is_primitive_element(type) ? 8 : 4;
      case TypeKind::array: {
        std::uint64_t count = 0;
        const Type& element = innermost(type, count);
        return (xcdr2_ && !is_primitive_element(type) ? 4 : 0) +
               count * wire_min(element, depth + 1);
      }
      case TypeKind::structure: {
        // An appendable struct may arrive without members (an older version of the type).
        if (xcdr2_ && type.extensibility == Extensibility::appendable) return 4;
        std::uint64_t sum = 0;
        for (const Field& field : type.fields) {
          if (field.type != nullptr) sum += wire_min(*field.type, depth + 1);
        }
        return sum;
      }
      default: return 1;
    }
  }

  static bool is_primitive_element(const Type& container) {
    if (container.element == nullptr) return true;  // refused by emit() anyway
    std::uint64_t count = 0;
    const Type& element = container.kind == TypeKind::array ? innermost(container, count)
                                                            : container.element->resolved();
    return element.is_primitive();
  }

  // Where the encoder stands, as far as the compiler knows: position = residue (mod modulus).
  // Known exactly (mod 8) at the start; strings and sequences make it unknown (modulus 1).
  struct Cursor {
    std::uint32_t modulus = 8;
    std::uint32_t residue = 0;

    // Bytes of padding before an item aligned to `alignment`, then `bytes` of it.
    std::uint64_t advance(std::uint32_t alignment, std::uint64_t bytes) {
      std::uint64_t padding = 0;
      if (alignment <= modulus) {
        padding = (alignment - residue % alignment) % alignment;
        residue = static_cast<std::uint32_t>((residue + padding + bytes) % modulus);
      } else {
        padding = alignment - 1;  // the worst case
        modulus = alignment;
        residue = static_cast<std::uint32_t>(bytes % modulus);
      }
      return padding + bytes;
    }
    void lose() { modulus = 1, residue = 0; }
  };

  // The most wire bytes the fixed part of `type` can take, padding included, from
  // `cursor` on; the contents of unbounded strings and sequences count in the tail instead.
  std::uint64_t wire_max(const Type& declared, Cursor& cursor, int depth) const {
    const Type& type = declared.resolved();
    if (depth > 4 * kMaxDepth) return 0;
    if (type.is_primitive()) return cursor.advance(cdr_align(type.size, xcdr2_), type.size);
    switch (type.kind) {
      case TypeKind::enumeration: return cursor.advance(4, 4);
      case TypeKind::string: {
        const std::uint64_t bytes =
            cursor.advance(4, 4 + static_cast<std::uint64_t>(type.bound) + 1);
        cursor.lose();
        return bytes;
      }
      case TypeKind::structure: {
        std::uint64_t sum = 0;
        if (xcdr2_ && type.extensibility == Extensibility::appendable) sum += cursor.advance(4, 4);
        for (const Field& field : type.fields) {
          if (field.type != nullptr) sum += wire_max(*field.type, cursor, depth + 1);
        }
        return sum;
      }
      case TypeKind::array: {
        std::uint64_t count = 0;
        const Type& element = innermost(type, count);
        if (element.is_primitive())
          return cursor.advance(cdr_align(element.size, xcdr2_), count * element.size);
        std::uint64_t sum = xcdr2_ ? cursor.advance(4, 4) : 0;
        sum += elements_max(element, count, cursor, depth);
        return sum;
      }
      case TypeKind::sequence: {
        const Type& element = type.element->resolved();
        std::uint64_t sum = xcdr2_ && !element.is_primitive() ? cursor.advance(4, 4) : 0;
        sum += cursor.advance(4, 4);
        if (type.bound > 0) {
          if (element.is_primitive()) {
            sum += cursor.advance(cdr_align(element.size, xcdr2_),
                                  static_cast<std::uint64_t>(type.bound) * element.size);
          } else {
            sum += elements_max(element, type.bound, cursor, depth);
          }
        } else if (element.is_primitive()) {
          sum += cdr_align(element.size, xcdr2_) - 1;  // aligning the elements in the tail
        }
        cursor.lose();
        return sum;
      }
      default: return 0;
    }
  }

  // `count` elements, each from an unknown position (their padding may differ).
  std::uint64_t elements_max(const Type& element, std::uint64_t count, Cursor& cursor,
                             int depth) const {
    Cursor unknown;
    unknown.lose();
    const std::uint64_t each = wire_max(element, unknown, depth + 1);
    cursor.lose();
    return count * each;
  }

  // Raises the tail ratio to cover every unbounded string and sequence in `type`.
  bool tail_ratio(const Type& declared, int depth) {
    const Type& type = declared.resolved();
    if (depth > 4 * kMaxDepth) return true;
    std::uint64_t& ratio = program_->tail_ratio_q16;
    switch (type.kind) {
      case TypeKind::string:
        if (type.bound == 0) ratio = std::max<std::uint64_t>(ratio, 1u << 16);  // a byte a byte
        return true;
      case TypeKind::structure:
        for (const Field& field : type.fields) {
          if (field.type != nullptr && !tail_ratio(*field.type, depth + 1)) return false;
        }
        return true;
      case TypeKind::array: {
        std::uint64_t count = 0;
        return tail_ratio(innermost(type, count), depth + 1);
      }
      case TypeKind::sequence: {
        const Type& element = type.element->resolved();
        if (type.bound == 0 && element.size > 0) {
          std::uint64_t each = element.size;
          if (!element.is_primitive()) {
            Cursor unknown;
            unknown.lose();
            each = wire_max(element, unknown, 0);
          }
          ratio = std::max(ratio, (each * 65536 + element.size - 1) / element.size);
        }
        return tail_ratio(element, depth + 1);
      }
      default: return true;
    }
  }

  bool xcdr2_;
  Program* program_ = nullptr;
  std::string error_;
  std::vector<const Type*> enum_types_;
  std::uint64_t covered_ = 0;  // bytes of the fixed part that decode writes
  bool all_fixed_ = true;      // no strings, sequences, loops or DHEADERs in the fixed part
};

}  // namespace

std::string compile_program(const Type& root, bool xcdr2, Program& program) {
  Compiler compiler(xcdr2);
  return compiler.compile(root, program);
}

}  // namespace polyport::cdr
