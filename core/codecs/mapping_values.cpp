// Mapping whole values by name (mapping_compiler.hpp), below the last rule: a byte copy where
// the layouts agree, else numbers converted or scaled, enums by enumerator name, strings and
// sequences with their bounds checked, arrays and structs element by element and field by
// field; the length members of LCM target structs set from their sequences' counts. Runs at
// load time.
//
// Also the number conversion kernels, one per (source, target) number kind, that map_numbers
// picks at load time: the steps call them on the forwarding path, through Step::convert and
// Step::scaled, on the thread and with the buffers of CompiledMapping::run() (mapping_run.cpp).
#include "mapping_compiler.hpp"

#include <algorithm>
#include <charconv>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <string>
#include <utility>
#include <vector>

namespace polyport::mapping {

namespace {

// Number conversion kernels, one per (source, target) number kind: what Step::convert and
// Step::scaled point to.
template <class S, class T>
void convert_numbers(const std::byte* src, std::byte* dst, std::uint32_t count,
                     std::uint32_t src_stride, std::uint32_t dst_stride) noexcept {
  for (std::uint32_t i = 0; i < count; ++i) {
    store<T>(dst + std::size_t{i} * dst_stride, convert_value<T>(load<S>(src + std::size_t{i} * src_stride)));
  }
}

template <class S, class T>
void scale_numbers(const std::byte* src, std::byte* dst, std::uint32_t count,
                   std::uint32_t src_stride, std::uint32_t dst_stride, double scale,
                   double offset) noexcept {
  for (std::uint32_t i = 0; i < count; ++i) {
    const double value = static_cast<double>(load<S>(src + std::size_t{i} * src_stride));
    store<T>(dst + std::size_t{i} * dst_stride, from_double<T>(value * scale + offset));
  }
}

ConvertFn pick_converter(Num from, Num to) {
  return with_number(from, [to](auto s) {
    return with_number(to, [](auto t) -> ConvertFn {
      return &convert_numbers<typename decltype(s)::type, typename decltype(t)::type>;
    });
  });
}

ScaleFn pick_scaler(Num from, Num to) {
  return with_number(from, [to](auto s) {
    return with_number(to, [](auto t) -> ScaleFn {
      return &scale_numbers<typename decltype(s)::type, typename decltype(t)::type>;
    });
  });
}

std::string number_text(double value) {
  char buffer[32];
  const auto result = std::to_chars(buffer, buffer + sizeof buffer, value);
  return std::string(buffer, result.ptr);
}

}  // namespace

// Whether a source of type `s` can be copied byte for byte into `t`: the same layout of
// the same fields, nothing that needs checking on the way (bounded strings and sequences
// carry lengths that must be checked, enums of other types translate).
bool Compiler::same_bytes(const Type& s, const Type& t) {
  if (&s == &t) return plain(s);
  if (s.kind != t.kind || s.size != t.size) return false;
  if (s.is_primitive()) return true;
  switch (s.kind) {
    case TypeKind::array: return s.bound == t.bound && same_bytes(s.element->resolved(), t.element->resolved());
    case TypeKind::structure:
      if (s.fields.size() != t.fields.size()) return false;
      for (std::size_t i = 0; i < s.fields.size(); ++i) {
        if (s.fields[i].name != t.fields[i].name || s.fields[i].offset != t.fields[i].offset ||
            !same_bytes(s.fields[i].type->resolved(), t.fields[i].type->resolved())) {
          return false;
        }
      }
      return true;
    default: return false;
  }
}

bool Compiler::plain(const Type& type) {
  switch (type.kind) {
    case TypeKind::string:
    case TypeKind::sequence: return false;
    case TypeKind::array: return plain(type.element->resolved());
    case TypeKind::structure:
      return std::all_of(type.fields.begin(), type.fields.end(),
                         [](const Field& field) { return plain(field.type->resolved()); });
    default: return true;
  }
}

// Maps a whole source value onto a whole target value, recursively and by name; no rules
// apply below this point.
void Compiler::map_value(const Place& source, const Place& target, const Options& options) {
  const Type& s = *source.type;
  const Type& t = *target.type;
  if (options.scaled && !number_kind(t.kind) && !(t.kind == TypeKind::array || t.kind == TypeKind::sequence)) {
    problem(options.rule, "scale, offset and units apply to numbers: target " + in_quotes(label(target.path)) +
                              " is " + in_quotes(t.name));
    return;
  }
  if (!options.scaled && same_bytes(s, t)) {
    Step step;
    step.op = Op::copy;
    step.src = source.offset;
    step.dst = target.offset;
    step.size = t.size;
    emit(step, arrow(source.path, target.path));
    return;
  }
  const auto s_number = number_kind(s.kind);
  const auto t_number = number_kind(t.kind);
  if (s_number && t_number) {
    map_numbers(source, target, *s_number, *t_number, 1, options);
    return;
  }
  const auto cannot = [&](const std::string& detail) {
    problem(options.rule, "cannot map " + pair_text(source, target) + (detail.empty() ? "" : ": " + detail));
  };
  if (s.kind != t.kind) {
    cannot("");
    return;
  }
  switch (t.kind) {
    case TypeKind::enumeration: map_enum(source, target, options); return;
    case TypeKind::string: map_string(source, target, options); return;
    case TypeKind::array: map_array(source, target, options); return;
    case TypeKind::sequence: map_sequence(source, target, options); return;
    case TypeKind::structure: map_struct(source, target, options); return;
    default: cannot(""); return;  // boolean and char only map to themselves (same_bytes)
  }
}

void Compiler::map_numbers(const Place& source, const Place& target, Num s, Num t, std::uint32_t count,
                           const Options& options) {
  // Scaled values are computed in double: into an integer that rounds.
  const bool narrowing = options.scaled ? (!is_float(t) || !widens(s, t)) : !widens(s, t);
  if (narrowing && !options.allow_narrowing) {
    problem(options.rule, "narrowing " + pair_text(source, target) + " needs allow_narrowing=\"true\"" +
                              (options.scaled ? " (scaled values are computed as double)" : ""));
    return;
  }
  Step step;
  step.src = source.offset;
  step.dst = target.offset;
  step.count = count;
  step.src_stride = number_size(s);
  step.dst_stride = number_size(t);
  step.size = number_size(t);
  const std::string note = arrow(source.path, target.path);
  const std::string types = std::string(kind_name(scalar_kind(s))) + " -> " + std::string(kind_name(scalar_kind(t)));
  const std::string times = count > 1 ? " x" + std::to_string(count) : "";
  if (options.scaled) {
    step.op = Op::scale;
    step.scale = options.scale;
    step.offset = options.offset;
    step.scaled = pick_scaler(s, t);
    emit(step, "scale " + types + times + ": y = x * " + number_text(options.scale) + " + " +
                   number_text(options.offset) + " @" + std::to_string(step.src) + " -> @" +
                   std::to_string(step.dst) + " (" + note + ")");
  } else if (s == t) {
    step.op = Op::copy;
    step.size = count * number_size(t);
    emit(step, note);
  } else {
    step.op = Op::convert;
    step.convert = pick_converter(s, t);
    emit(step, "convert " + types + times + " @" + std::to_string(step.src) + " -> @" +
                   std::to_string(step.dst) + " (" + note + ")");
  }
}

TypeKind Compiler::scalar_kind(Num kind) {
  switch (kind) {
    case Num::i8: return TypeKind::int8;
    case Num::u8: return TypeKind::uint8;
    case Num::i16: return TypeKind::int16;
    case Num::u16: return TypeKind::uint16;
    case Num::i32: return TypeKind::int32;
    case Num::u32: return TypeKind::uint32;
    case Num::i64: return TypeKind::int64;
    case Num::u64: return TypeKind::uint64;
    case Num::f32: return TypeKind::float32;
    case Num::f64: break;
  }
  return TypeKind::float64;
}

void Compiler::map_enum(const Place& source, const Place& target, const Options& options) {
  const Type& s = *source.type;
  const Type& t = *target.type;
  std::vector<std::pair<std::int32_t, std::int32_t>> pairs;
  std::vector<std::string> missing;
  for (const Enumerator& from : s.enumerators) {
    const auto to = std::find_if(t.enumerators.begin(), t.enumerators.end(),
                                 [&](const Enumerator& candidate) { return candidate.name == from.name; });
    if (to == t.enumerators.end()) {
      missing.push_back(in_quotes(from.name));
    } else {
      pairs.emplace_back(from.value, to->value);
    }
  }
  if (!missing.empty()) {
    problem(options.rule, "cannot map " + pair_text(source, target) + ": no enumerator " + join(missing, ", ") +
                              " in " + in_quotes(t.name));
    return;
  }
  std::stable_sort(pairs.begin(), pairs.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  pairs.erase(std::unique(pairs.begin(), pairs.end(), [](const auto& a, const auto& b) { return a.first == b.first; }),
              pairs.end());
  Step step;
  step.op = Op::enum_map;
  step.src = source.offset;
  step.dst = target.offset;
  step.pool = static_cast<std::uint32_t>(program_->enum_pairs_.size());
  step.pool_count = static_cast<std::uint32_t>(pairs.size());
  for (const auto& [from, to] : pairs) {
    program_->enum_pairs_.push_back(from);
    program_->enum_pairs_.push_back(to);
  }
  emit(step, "enum by name " + in_quotes(s.name) + " -> " + in_quotes(t.name) + " (" + std::to_string(pairs.size()) +
                 " values) @" + std::to_string(step.src) + " -> @" + std::to_string(step.dst) + " (" +
                 arrow(source.path, target.path) + ")");
}

void Compiler::map_string(const Place& source, const Place& target, const Options& options) {
  const Type& s = *source.type;
  const Type& t = *target.type;
  Step step;
  step.op = Op::string;
  step.src = source.offset;
  step.dst = target.offset;
  step.size = t.size;
  step.src_unbounded = s.bound == 0;
  step.dst_unbounded = t.bound == 0;
  step.src_bound = s.bound;
  step.dst_bound = t.bound;
  step.truncate = options.truncate;
  std::string note = "string " + bound_text(s.bound) + " -> " + bound_text(t.bound);
  if (t.bound == 0) note += ", into the target's tail";
  const bool may_overflow = t.bound != 0 && (s.bound == 0 || s.bound > t.bound);
  if (may_overflow) note += options.truncate ? ", cut if longer" : ", fails if longer";
  emit(step, note + " @" + std::to_string(step.src) + " -> @" + std::to_string(step.dst) + " (" +
                 arrow(source.path, target.path) + ")");
}

// Peels matching dimensions of two arrays: the innermost element types and the total count.
bool Compiler::same_shape(const Type*& s, const Type*& t, std::uint32_t& count) {
  count = 1;
  while (s->kind == TypeKind::array && t->kind == TypeKind::array) {
    if (s->bound != t->bound) return false;
    count *= s->bound;
    s = &s->element->resolved();
    t = &t->element->resolved();
  }
  return true;
}

void Compiler::map_array(const Place& source, const Place& target, const Options& options) {
  const Type& s = *source.type;
  const Type& t = *target.type;
  if (s.bound != t.bound) {
    problem(options.rule, "cannot map " + pair_text(source, target) + ": the lengths differ");
    return;
  }
  // Numbers in arrays of any dimension: one conversion over all of them.
  const Type* s_leaf = &s;
  const Type* t_leaf = &t;
  std::uint32_t count = 0;
  if (same_shape(s_leaf, t_leaf, count)) {
    const auto s_number = number_kind(s_leaf->kind);
    const auto t_number = number_kind(t_leaf->kind);
    if (s_number && t_number) {
      map_numbers(source, target, *s_number, *t_number, count, options);
      return;
    }
  }
  const Type& s_element = s.element->resolved();
  const Type& t_element = t.element->resolved();
  std::vector<Emitted> body;
  if (!compile_body(source, target, s_element, t_element, options, body)) return;
  Step step;
  step.op = Op::repeat;
  step.src = source.offset;
  step.dst = target.offset;
  step.count = t.bound;
  step.src_stride = s_element.size;
  step.dst_stride = t_element.size;
  step.body = static_cast<std::uint32_t>(body.size());
  emit(step, "for each of " + std::to_string(t.bound) + " elements @" + std::to_string(step.src) + " -> @" +
                 std::to_string(step.dst) + " (" + arrow(source.path, target.path) + "):");
  for (Emitted& emitted : body) out_->push_back(std::move(emitted));
}

// Compiles how one element maps, in its own frame. Returns false when it failed.
bool Compiler::compile_body(const Place& source, const Place& target, const Type& s_element, const Type& t_element,
                            const Options& options, std::vector<Emitted>& body) {
  const std::size_t before = problems_.size();
  std::vector<Emitted>* outer = out_;
  out_ = &body;
  map_value(Place{&s_element, 0, source.path + "[]"}, Place{&t_element, 0, target.path + "[]"}, options);
  out_ = outer;
  finalize(body, t_element.size);
  return problems_.size() == before;
}

void Compiler::map_sequence(const Place& source, const Place& target, const Options& options) {
  const Type& s = *source.type;
  const Type& t = *target.type;
  const Type& s_element = s.element->resolved();
  const Type& t_element = t.element->resolved();
  std::vector<Emitted> body;
  if (!compile_body(source, target, s_element, t_element, options, body)) return;
  // Elements that copy whole need no per-element loop.
  if (body.size() == 1 && body[0].step.op == Op::copy && body[0].step.src == 0 && body[0].step.dst == 0 &&
      body[0].step.size == t_element.size && s_element.size == t_element.size) {
    body.clear();
  }
  Step step;
  step.op = Op::sequence;
  step.src = source.offset;
  step.dst = target.offset;
  step.size = t.size;
  step.src_unbounded = s.bound == 0;
  step.dst_unbounded = t.bound == 0;
  step.src_bound = s.bound;
  step.dst_bound = t.bound;
  step.src_first = static_cast<std::uint32_t>(align_up(sizeof(std::uint32_t), s_element.align));
  step.dst_first = static_cast<std::uint32_t>(align_up(sizeof(std::uint32_t), t_element.align));
  step.dst_align = t_element.align;
  step.src_stride = s_element.size;
  step.dst_stride = t_element.size;
  step.truncate = options.truncate;
  step.body = static_cast<std::uint32_t>(body.size());
  std::string note = "sequence " + bound_text(s.bound) + " -> " + bound_text(t.bound);
  if (t.bound == 0) note += ", into the target's tail";
  const bool may_overflow = t.bound != 0 && (s.bound == 0 || s.bound > t.bound);
  if (may_overflow) note += options.truncate ? ", cut if longer" : ", fails if longer";
  note += " @" + std::to_string(step.src) + " -> @" + std::to_string(step.dst) + " (" +
          arrow(source.path, target.path) + ")";
  emit(step, note + (body.empty() ? ", elements copied whole" : ", per element:"));
  for (Emitted& emitted : body) out_->push_back(std::move(emitted));
}

void Compiler::map_struct(const Place& source, const Place& target, const Options& options) {
  const std::vector<LengthMember> lengths = length_members(*target.type);
  std::vector<const LengthMember*> derived;
  std::vector<std::string> missing;
  for (const Field& field : target.type->fields) {
    const LengthMember* length = length_member(lengths, field.name);
    if (length != nullptr && length->derived()) {
      // Set from the count below, even when the source has a field of its name: that field
      // says what the source claims, the count what the target really holds.
      derived.push_back(length);
      continue;
    }
    const Place child = field_of(source, field.name);
    const Place target_child{&field.type->resolved(), target.offset + field.offset,
                             join_path(target.path, field.name)};
    if (child.type == nullptr) {
      if (length != nullptr) {
        refuse_length(*length, target, options);
      } else {
        missing.push_back(target_child.path);
      }
      continue;
    }
    map_value(child, target_child, options);
  }
  report_missing(missing, source, options);
  // After every field, so the sequences they count are written when they run.
  for (const LengthMember* length : derived) derive_length(*length, target);
}

// -- LCM length members ------------------------------------------------------------------
//
// An LCM variable-size array `double samples[nsamples]` is a sequence whose length the message
// also carries in an earlier integer member, and the LCM codec refuses a sample where the two
// disagree. So when the target is such a struct, the mapping does not copy that member from
// the source (a source of another format has no such member, and one that has it may claim a
// count its sequence does not have): it sets it from the element count of the target sequence
// once that is written, checking that the count fits the member's type (int8_t holds at most
// 127) and, when several sequences share the member, that their counts agree. A failed check
// fails run(), as a sequence too long for a bounded target does. A rule for the member is kept
// as written (the LCM codec then checks it). Only outermost dimensions are counted: a member
// that sizes an inner one (`double m[n][k]`'s k, `boolean bits[2][m]`'s m) is mapped like any
// other field, and is an error without a source.

std::vector<LengthMember> Compiler::length_members(const Type& target) {
  std::vector<LengthMember> members;
  for (const Field& field : target.fields) {
    for (std::size_t level = 0; level < field.length_fields.size(); ++level) {
      const Field* member = target.find_field(field.length_fields[level]);
      if (member == nullptr || member == &field || member->type == nullptr) continue;
      const auto kind = number_kind(member->type->resolved().kind);
      if (!kind || is_float(*kind)) continue;  // the LCM parser allows only integers
      auto found = std::find_if(members.begin(), members.end(),
                                [&](const LengthMember& length) { return length.member == member; });
      if (found == members.end()) {
        members.push_back(LengthMember{member, *kind, {}, {}});
        found = members.end() - 1;
      }
      const bool outermost = level == 0 && field.type->resolved().kind == TypeKind::sequence;
      auto& uses = outermost ? found->sequences : found->nested;
      if (std::find(uses.begin(), uses.end(), &field) == uses.end()) uses.push_back(&field);
    }
  }
  return members;
}

const LengthMember* Compiler::length_member(const std::vector<LengthMember>& members, const std::string& name) {
  for (const LengthMember& length : members) {
    if (length.member->name == name) return &length;
  }
  return nullptr;
}

void Compiler::refuse_length(const LengthMember& length, const Place& target, const Options& options) {
  std::vector<std::string> names;
  for (const Field* field : length.nested) names.push_back(in_quotes(join_path(target.path, field->name)));
  const std::string member = in_quotes(join_path(target.path, length.member->name));
  problem(options.rule, "target field " + member + " of " + in_quotes(to_.name) + " has no source in " +
                            in_quotes(from_.name) + " and is not derived: it is the length of an inner dimension of " +
                            join(names, ", ") + ", and a mapping counts only outermost ones (give it a rule or a " +
                            "source field of its name)");
}

void Compiler::derive_length(const LengthMember& length, const Place& target) {
  const std::string member = join_path(target.path, length.member->name);
  const std::uint64_t range = with_number(length.kind, [](auto t) {
    return static_cast<std::uint64_t>(std::numeric_limits<typename decltype(t)::type>::max());
  });
  constexpr std::uint64_t kMaxCount = std::numeric_limits<std::uint32_t>::max();
  const auto largest = static_cast<std::uint32_t>(std::min(range, kMaxCount));
  for (std::size_t i = 0; i < length.sequences.size(); ++i) {
    const Field& sequence = *length.sequences[i];
    const Type& sequence_type = sequence.type->resolved();
    Step step;
    step.op = Op::length;
    step.dst = target.offset + length.member->offset;
    step.size = number_size(length.kind);
    step.counted = target.offset + sequence.offset;
    step.dst_unbounded = sequence_type.bound == 0;
    step.dst_bound = largest;
    step.compare = i > 0;
    step.convert = pick_converter(Num::u32, length.kind);
    // The most elements the sequence can get: its bound, the bound of the source the step that
    // writes it reads, and what a sample (at most 4 GiB) can hold of its elements.
    std::uint64_t most = kMaxCount / std::max<std::uint32_t>(1, sequence_type.element->size);
    if (sequence_type.bound != 0) most = std::min<std::uint64_t>(most, sequence_type.bound);
    for (std::size_t k = 0; k < out_->size(); k += 1 + (*out_)[k].step.body) {
      const Step& writer = (*out_)[k].step;
      if (writer.op == Op::sequence && writer.dst == step.counted && !writer.src_unbounded) {
        most = std::min<std::uint64_t>(most, writer.src_bound);
      }
    }
    const std::string counted = "count(" + join_path(target.path, sequence.name) + ")";
    std::string note = step.compare ? "check " + member + " == " + counted + ", fails if they differ"
                                    : member + " = " + counted;
    if (most > largest) note += ", fails above " + std::to_string(largest);
    emit(step, note);
  }
}

}  // namespace polyport::mapping
