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
#include <vector>

#include "polyport/diagnostics.hpp"
#include "polyport/types.hpp"

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
  std::vector<double> matrix;       // linear/affine: rows x cols, row-major
  std::vector<double> translation;  // affine: rows entries
  bool allow_narrowing = false;     // e.g. double -> int32, int64 -> int16
  SourceLocation where;
};

struct MappingSpec {
  std::vector<MappingRule> rules;
  bool by_name = true;  // fields no rule names are copied by name (false: left zero)
  SourceLocation where;
};

class MappingProgram {
 public:
  // Compiles `spec` for samples of `from` into samples of `to`. Every problem goes to
  // diagnostics (with the rule's location when there is one); null if there was any.
  static std::unique_ptr<MappingProgram> compile(const Type& from, const Type& to, const MappingSpec& spec,
                                                 Diagnostics& diagnostics);
  virtual ~MappingProgram() = default;

  // Writes a complete target sample (fields no rule sets are zero). `target_capacity`
  // bounds the target's tail for unbounded strings and sequences. Returns false (and
  // leaves the target unspecified) when the source sample is malformed or a tail does not fit.
  virtual bool run(const std::byte* source, std::uint32_t source_size, std::byte* target,
                   std::uint32_t target_capacity, std::uint32_t& target_size) const noexcept = 0;
  // One line per step, for `polyportd check`.
  virtual std::vector<std::string> describe() const = 0;
};

}  // namespace polyport
