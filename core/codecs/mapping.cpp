// Mappings between two flat sample layouts (see mapping.hpp and types.hpp).
//
// This file: the entry points of mapping.hpp, MappingProgram::compile() in its two forms (the
// Diagnostics one reports each problem at its rule's location, or the spec's), and
// describe(), the steps of a compiled program as the lines `polyportd check` prints.
//
// The rest, by responsibility:
//   mapping_program.hpp     the program: Steps, their tables; number kinds and conversions
//   mapping_run.cpp         run(), the forwarding path
//   mapping_compiler.hpp    the Compiler and what its parts share
//   mapping_compiler.cpp    compile(): the walk over the target type where rules apply, and
//                           finishing a frame (merging copies, zeroing what no step writes)
//   mapping_rules.cpp       the rules: their paths, conflicts, units, scale and offset
//   mapping_values.cpp      whole values by name: numbers, enums, strings, arrays,
//                           sequences, structs; LCM length members from their
//                           sequences' counts; the number conversion kernels
//   mapping_constants.cpp   constants: a rule's value text into target bytes
//   mapping_transforms.cpp  linear and affine transforms: vector fields, the Eigen kernels
#include "polyport/codecs/mapping.hpp"

#include <cstddef>
#include <memory>
#include <string>
#include <vector>

#include "mapping_compiler.hpp"

namespace polyport {

std::unique_ptr<MappingProgram> MappingProgram::compile(const Type& from, const Type& to, const MappingSpec& spec,
                                                        std::vector<MappingProblem>& problems) {
  return mapping::Compiler(from, to, spec, problems).compile();
}

std::unique_ptr<MappingProgram> MappingProgram::compile(const Type& from, const Type& to, const MappingSpec& spec,
                                                        Diagnostics& diagnostics) {
  std::vector<MappingProblem> problems;
  auto program = compile(from, to, spec, problems);
  for (const MappingProblem& item : problems) {
    if (item.rule != nullptr) {
      diagnostics.error(item.rule->where, item.rule->element_path, item.message);
    } else {
      diagnostics.error(spec.where, spec.element_path, item.message);
    }
  }
  return program;
}

namespace mapping {

std::vector<std::string> CompiledMapping::describe() const {
  std::vector<std::string> lines;
  describe_steps(0, steps_.size(), 0, lines);
  return lines;
}

void CompiledMapping::describe_steps(std::size_t first, std::size_t last, int depth,
                                     std::vector<std::string>& lines) const {
  const std::string indent(static_cast<std::size_t>(depth) * 2, ' ');
  for (std::size_t i = first; i < last; i += 1 + steps_[i].body) {
    const Step& step = steps_[i];
    if (step.op == Op::copy) {
      // Copies are merged at compile time; their note is the list of what they carry.
      lines.push_back(indent + "copy " + std::to_string(step.size) + " bytes @" + std::to_string(step.src) +
                      " -> @" + std::to_string(step.dst) + " (" + notes_[i] + ")");
    } else {
      lines.push_back(indent + notes_[i]);
    }
    if (steps_[i].body > 0) describe_steps(i + 1, i + 1 + steps_[i].body, depth + 1, lines);
  }
}

}  // namespace mapping

}  // namespace polyport
