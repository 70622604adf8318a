// The Compiler: a MappingSpec for two types into a CompiledMapping (mapping_program.hpp).
//
// compile() runs once at load time: it walks the target type, pairs every target field with
// a source field (by name, or by a rule), checks that each pair can convert, and emits a
// flat vector of Steps (copy bytes, convert a number, scale, look an enum up, write a
// constant, copy a string or sequence, apply a matrix, set an LCM length member from the
// count of its sequence). Adjacent copies are merged, and the target bytes no step writes
// (padding, fields left unset) get explicit zero steps, so run() never has to clear the
// whole sample first.
//
// One class, its parts in several files by responsibility (see the declarations below); this
// header is what they share: places in a sample, how the fields under a node are mapped, the
// prepared rules, emitted steps, and the text helpers of notes and problems. All of it runs at
// load time, on the thread that loads the profile.
//
// Private to the codecs layer, and hidden, as mapping_program.hpp is.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "mapping_program.hpp"

#pragma GCC visibility push(hidden)

namespace polyport::mapping {

// Paths and text, for notes and problems (mapping_compiler.cpp).
std::string join_path(const std::string& parent, const std::string& name);
std::string index_path(const std::string& parent, std::uint32_t index);
std::string in_quotes(std::string_view text);
std::string join(const std::vector<std::string>& items, std::string_view separator);
std::string field_list(const Type& type);

// A field of one side, at a known place in the current frame.
struct Place {
  const Type* type = nullptr;  // resolved; null: there is none
  std::uint32_t offset = 0;
  std::string path;            // as the user reads it ("pose.x", "items[].x")
};

// How the fields under one node are mapped.
struct Options {
  const MappingRule* rule = nullptr;  // whose fault a problem is; null: the types'
  bool required = true;               // a target field without a source is an error
  bool allow_narrowing = false;
  bool truncate = false;
  bool scaled = false;                // scale/offset/units given
  double scale = 1.0;
  double offset = 0.0;
};

// A rule with its paths resolved.
struct PreparedRule {
  const MappingRule* rule = nullptr;
  std::string target_path;  // canonical
  Place target;
  Place source;             // copy / transform
  Options options;
  bool ok = false;          // false: its problems are reported, its target is left alone
};

// An LCM length member of a target struct (Field::length_fields): an integer field that holds
// the element count of variable-size arrays of the same struct.
struct LengthMember {
  const Field* member = nullptr;
  Num kind = Num::i32;
  std::vector<const Field*> sequences;  // the fields whose outermost dimension it sizes
  std::vector<const Field*> nested;     // the fields one of whose inner dimensions it sizes
  // Whether the mapping sets it from the count (else it is mapped like any other field).
  bool derived() const { return nested.empty() && !sequences.empty(); }
};

struct Emitted {
  Step step;
  std::string note;
};

class Compiler {
 public:
  Compiler(const Type& from, const Type& to, const MappingSpec& spec, std::vector<MappingProblem>& problems)
      : from_(from), to_(to), spec_(spec), problems_(problems) {}

  std::unique_ptr<MappingProgram> compile();  // mapping_compiler.cpp

 private:
  void problem(const MappingRule* rule, std::string message) {
    problems_.push_back(MappingProblem{rule, std::move(message)});
  }

  void emit(Step step, std::string note) { out_->push_back(Emitted{step, std::move(note)}); }

  static std::string label(const std::string& path) { return path.empty() ? "(sample)" : path; }

  std::string pair_text(const Place& source, const Place& target_place) const {
    return "source " + in_quotes(label(source.path)) + " (" + in_quotes(source.type->name) + ") to target " +
           in_quotes(label(target_place.path)) + " (" + in_quotes(target_place.type->name) + ")";
  }

  static std::string arrow(const std::string& source, const std::string& target) {
    if (source.empty() && target.empty()) return "the whole sample";
    if (source == target) return label(target);
    return label(source) + " -> " + label(target);
  }

  // -- rules (mapping_rules.cpp) -----------------------------------------------------------

  std::optional<Place> resolve(const MappingRule& rule, const Type& root, const std::string& text,
                               std::string_view side, std::string* canonical);
  void prepare_rules();
  bool prepare_scale(const MappingRule& rule, Options& options);
  const PreparedRule* exact(const std::string& path) const;
  bool has_rules_below(const std::string& path) const;

  // -- the walk, where rules apply (mapping_compiler.cpp) ----------------------------------

  bool node(const Type& target, std::uint32_t target_offset, const std::string& target_path,
            const Place& source, const Options& options);
  void descend(const Place& target, const Place& source, const Options& options);
  static Place field_of(const Place& parent, const std::string& name);
  static Place element_of(const Place& parent, std::uint32_t index);
  void report_missing(const std::vector<std::string>& missing, const Place& source, const Options& options);
  void apply_rule(const PreparedRule& rule, const Place& target);

  // -- whole values, by name, where no rules apply (mapping_values.cpp) --------------------

  static bool same_bytes(const Type& s, const Type& t);
  static bool plain(const Type& type);
  void map_value(const Place& source, const Place& target, const Options& options);
  void map_numbers(const Place& source, const Place& target, Num s, Num t, std::uint32_t count,
                   const Options& options);
  static TypeKind scalar_kind(Num kind);
  void map_enum(const Place& source, const Place& target, const Options& options);
  static std::string bound_text(std::uint32_t bound) { return bound == 0 ? "unbounded" : "<=" + std::to_string(bound); }
  void map_string(const Place& source, const Place& target, const Options& options);
  static bool same_shape(const Type*& s, const Type*& t, std::uint32_t& count);
  void map_array(const Place& source, const Place& target, const Options& options);
  bool compile_body(const Place& source, const Place& target, const Type& s_element, const Type& t_element,
                    const Options& options, std::vector<Emitted>& body);
  void map_sequence(const Place& source, const Place& target, const Options& options);
  void map_struct(const Place& source, const Place& target, const Options& options);

  // -- LCM length members (mapping_values.cpp) ---------------------------------------------

  static std::vector<LengthMember> length_members(const Type& target);
  static const LengthMember* length_member(const std::vector<LengthMember>& members, const std::string& name);
  void refuse_length(const LengthMember& length, const Place& target, const Options& options);
  void derive_length(const LengthMember& length, const Place& target);

  // -- constants (mapping_constants.cpp) ---------------------------------------------------

  void map_constant(const MappingRule& rule, const Place& target);

  // -- transforms (mapping_transforms.cpp) -------------------------------------------------

  static std::optional<std::vector<VectorElement>> vector_elements(const Place& place);
  void map_transform(const MappingRule& rule, const Place& source, const Place& target);

  // -- finishing a frame (mapping_compiler.cpp) --------------------------------------------

  void finalize(std::vector<Emitted>& steps, std::uint32_t frame_size) const;

  const Type& from_;
  const Type& to_;
  const MappingSpec& spec_;
  std::vector<MappingProblem>& problems_;
  std::vector<PreparedRule> rules_;
  std::unique_ptr<CompiledMapping> program_;
  std::vector<Emitted>* out_ = nullptr;
};

}  // namespace polyport::mapping

#pragma GCC visibility pop
