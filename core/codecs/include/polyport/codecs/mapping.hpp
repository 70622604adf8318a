// Mappings between two types, compiled at load time into a flat program of moves and
// conversions that runs on the forwarding path without allocation: flat sample of the
// source type in, flat sample of the target type out.
//
// By default every target field takes the source field of the same name (recursively for
// nested structs, element-wise for arrays); rules rename, scale and offset, convert units,
// set constants and apply Eigen fixed-size linear or affine transforms to vector fields. A
// mapping that cannot work is a load-time error naming both sides.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "polyport/base/diagnostics.hpp"
#include "polyport/types/types.hpp"

namespace polyport {

struct MappingRule {
  enum class Kind : std::uint8_t { copy, constant, linear, affine };
  std::string target;   // dotted path in the target type ("pose.position", "speeds[1]")
  std::string source;   // dotted path in the source type (copy, linear, affine)
  Kind kind = Kind::copy;
  double scale = 1.0;   // copy: target = source * scale + offset (after unit conversion)
  double offset = 0.0;
  std::string from_unit, to_unit;  // copy: unit conversion, e.g. "deg" -> "rad", "km/h" -> "m/s"
  std::string value;    // constant: the value as written
  // linear/affine: y = M x (+ t). M has matrix_rows x matrix_cols entries, row-major; the
  // dimensions are kept because a flat list cannot tell a 2x3 from a 3x2 matrix, and a
  // wrong shape must be reported as such rather than silently reinterpreted.
  std::vector<double> matrix;
  std::uint32_t matrix_rows = 0;
  std::uint32_t matrix_cols = 0;
  std::vector<double> translation;  // affine: rows entries
  bool allow_narrowing = false;     // e.g. double -> int32, int64 -> int16
  // Strings and sequences longer than a bounded target are cut to the bound (at a UTF-8
  // character boundary for strings) instead of failing run().
  bool truncate = false;
  SourceLocation where;
  std::string element_path;  // where in the profile (`.../mapping/field[2]`), for diagnostics
};

struct MappingSpec {
  std::vector<MappingRule> rules;
  // Target fields no rule names take the source field of the same name; a target field with
  // no such source field is an error. false: they are left zero.
  bool by_name = true;
  SourceLocation where;
  std::string element_path;
};

// A field of a flat sample found by its path ("a.b[1].c": names through structs, indices into
// fixed arrays): its resolved type and offset, and the path as the user reads it.
struct FieldPlace {
  const Type* type = nullptr;
  std::uint32_t offset = 0;
  std::string path;
};
struct FieldPathResult {
  std::optional<FieldPlace> place;  // empty: not found
  bool bad_syntax = false;          // the text is not a path at all
  std::string why;                  // not found: what there is instead ("fields: a, b")
};
FieldPathResult find_field_path(const Type& root, std::string_view text);

// A problem found by MappingProgram::compile: `rule` is the rule at fault, or null when the
// problem is the types' (a target field without a source, two fields that cannot convert).
struct MappingProblem {
  const MappingRule* rule = nullptr;
  std::string message;
};

class MappingProgram {
 public:
  // Compiles `spec` for samples of `from` into samples of `to`. Every problem goes to
  // diagnostics (with the rule's location when there is one); null if there was any.
  static std::unique_ptr<MappingProgram> compile(const Type& from, const Type& to, const MappingSpec& spec,
                                                 Diagnostics& diagnostics);
  // The same, with the problems as values, so a caller can word the ones that are not a
  // rule's fault itself (the profile loader folds them into one "type mismatch" error).
  static std::unique_ptr<MappingProgram> compile(const Type& from, const Type& to, const MappingSpec& spec,
                                                 std::vector<MappingProblem>& problems);
  virtual ~MappingProgram() = default;

  // Writes a complete target sample (fields no rule sets are zero). `target_capacity`
  // bounds the target's tail for unbounded strings and sequences. Returns false (and
  // leaves the target unspecified) when the source sample is malformed (shorter than its
  // fixed part, a length beyond its bound, a span outside `source_size`, an enum value that is
  // no enumerator), when a tail does not fit, or when a string or sequence is longer than a
  // bounded target and its rule does not truncate. Never allocates, locks or throws; one
  // program may run on several threads at once.
  virtual bool run(const std::byte* source, std::uint32_t source_size, std::byte* target,
                   std::uint32_t target_capacity, std::uint32_t& target_size) const noexcept = 0;
  // One line per step, for `polyportd check`.
  virtual std::vector<std::string> describe() const = 0;
  // The steps run() walks (their first bytes), for a caller that prefetches them.
  virtual const void* program_data() const noexcept { return nullptr; }
};

}  // namespace polyport
