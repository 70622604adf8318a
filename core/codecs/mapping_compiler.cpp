// Compiling a mapping (mapping_compiler.hpp): Compiler::compile(), the walk over the target
// type where rules apply (a node with a rule, or with rules below it, or mapped whole by
// name), and finishing each frame: adjacent copies merged, the bytes no step writes zeroed.
// Also the path and text helpers every part of the Compiler uses. Runs at load time.
#include "mapping_compiler.hpp"

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace polyport::mapping {

// ---------------------------------------------------------------------------------------
// Paths and text

std::string join_path(const std::string& parent, const std::string& name) {
  return parent.empty() ? name : parent + "." + name;
}

std::string index_path(const std::string& parent, std::uint32_t index) {
  return parent + "[" + std::to_string(index) + "]";
}

std::string in_quotes(std::string_view text) { return "'" + std::string(text) + "'"; }

std::string join(const std::vector<std::string>& items, std::string_view separator) {
  std::string out;
  for (const auto& item : items) {
    if (!out.empty()) out += separator;
    out += item;
  }
  return out;
}

std::string field_list(const Type& type) {
  std::vector<std::string> names;
  for (const Field& field : type.fields) names.push_back(field.name);
  return names.empty() ? "none" : join(names, ", ");
}

std::unique_ptr<MappingProgram> Compiler::compile() {
  const std::size_t problems_before = problems_.size();
  program_ = std::make_unique<CompiledMapping>();
  program_->source_fixed_ = from_.resolved().size;
  program_->target_fixed_ = to_.resolved().size;
  prepare_rules();

  Place root{&from_.resolved(), 0, ""};
  Options options;
  options.required = spec_.by_name;
  if (!spec_.by_name) root.type = nullptr;
  std::vector<Emitted> steps;
  out_ = &steps;
  // The root always has a source when one is required (by_name), so node() cannot report
  // it missing.
  node(to_.resolved(), 0, "", root, options);
  finalize(steps, program_->target_fixed_);
  if (problems_.size() != problems_before) return nullptr;
  for (Emitted& emitted : steps) {
    program_->steps_.push_back(emitted.step);
    program_->notes_.push_back(std::move(emitted.note));
  }
  return std::move(program_);
}

// -- the walk ----------------------------------------------------------------------------

// Maps one target node of the sample's own frame, where rules apply. Returns false when
// the node needs a source and has none (the caller reports those together).
bool Compiler::node(const Type& target, std::uint32_t target_offset, const std::string& target_path,
                    const Place& source, const Options& options) {
  const Place target_place{&target, target_offset, target_path};
  const bool below = has_rules_below(target_path);
  if (const PreparedRule* rule = exact(target_path)) {
    if (!rule->ok) return true;  // reported already
    if (!below) {
      apply_rule(*rule, target_place);
      return true;
    }
    descend(target_place, rule->source, rule->options);  // a rename with finer rules inside
    return true;
  }
  if (below) {
    descend(target_place, source, options);
    return true;
  }
  if (source.type == nullptr) return !options.required;
  map_value(source, target_place, options);
  return true;
}

// The fields (or elements) of a target struct (or array) with rules below it.
void Compiler::descend(const Place& target, const Place& source, const Options& options) {
  std::vector<std::string> missing;
  if (target.type->kind == TypeKind::structure) {
    // LCM length members without a rule of their own are set from their sequences' counts,
    // after the fields (see map_struct).
    const std::vector<LengthMember> lengths = length_members(*target.type);
    std::vector<const LengthMember*> derived;
    for (const Field& field : target.type->fields) {
      const std::string path = join_path(target.path, field.name);
      const LengthMember* length = length_member(lengths, field.name);
      if (length != nullptr && length->derived() && exact(path) == nullptr) {
        derived.push_back(length);
        continue;
      }
      if (!node(field.type->resolved(), target.offset + field.offset, path, field_of(source, field.name), options)) {
        if (length != nullptr) {
          refuse_length(*length, target, options);
        } else {
          missing.push_back(path);
        }
      }
    }
    report_missing(missing, source, options);
    for (const LengthMember* length : derived) derive_length(*length, target);
    return;
  }
  // An array: a rule path can only go through structs and arrays.
  const Type& element = target.type->element->resolved();
  for (std::uint32_t i = 0; i < target.type->bound; ++i) {
    const std::string path = index_path(target.path, i);
    if (!node(element, target.offset + i * element.size, path, element_of(source, i), options)) {
      missing.push_back(path);
    }
  }
  report_missing(missing, source, options);
}

Place Compiler::field_of(const Place& parent, const std::string& name) {
  Place child;
  child.path = join_path(parent.path, name);
  if (parent.type != nullptr && parent.type->kind == TypeKind::structure) {
    if (const Field* field = parent.type->find_field(name)) {
      child.type = &field->type->resolved();
      child.offset = parent.offset + field->offset;
    }
  }
  return child;
}

Place Compiler::element_of(const Place& parent, std::uint32_t index) {
  Place child;
  child.path = index_path(parent.path, index);
  if (parent.type != nullptr && parent.type->kind == TypeKind::array && index < parent.type->bound) {
    child.type = &parent.type->element->resolved();
    child.offset = parent.offset + index * parent.type->element->size;
  }
  return child;
}

void Compiler::report_missing(const std::vector<std::string>& missing, const Place& source, const Options& options) {
  if (missing.empty()) return;
  std::vector<std::string> names;
  for (const auto& name : missing) names.push_back(in_quotes(name));
  std::string why;
  if (source.type == nullptr) {
    why = "no source field " + in_quotes(source.path);
  } else if (source.type->kind == TypeKind::structure) {
    why = (source.path.empty() ? std::string("source fields: ") : "fields of source " + in_quotes(source.path) + ": ") +
          field_list(*source.type);
  } else {
    why = "source " + in_quotes(label(source.path)) + " is " + in_quotes(source.type->name);
  }
  problem(options.rule, std::string(missing.size() == 1 ? "target field " : "target fields ") + join(names, ", ") +
                            " of " + in_quotes(to_.name) + (missing.size() == 1 ? " has" : " have") +
                            " no source in " + in_quotes(from_.name) + " (" + why + ")");
}

void Compiler::apply_rule(const PreparedRule& rule, const Place& target) {
  switch (rule.rule->kind) {
    case MappingRule::Kind::copy: map_value(rule.source, target, rule.options); return;
    case MappingRule::Kind::constant: map_constant(*rule.rule, target); return;
    case MappingRule::Kind::linear:
    case MappingRule::Kind::affine: map_transform(*rule.rule, rule.source, target); return;
  }
}

// -- finishing a frame -------------------------------------------------------------------

// Merges adjacent copies, then zeroes every byte of the frame no step writes (padding,
// fields left unset), so run() never clears the whole sample first.
void Compiler::finalize(std::vector<Emitted>& steps, std::uint32_t frame_size) const {
  std::vector<Emitted> merged;
  for (std::size_t i = 0; i < steps.size();) {
    const std::size_t next = i + 1 + steps[i].step.body;
    if (steps[i].step.op == Op::copy && !merged.empty()) {
      Emitted& last = merged.back();
      const Step& step = steps[i].step;
      if (last.step.op == Op::copy && last.step.src + last.step.size == step.src &&
          last.step.dst + last.step.size == step.dst) {
        last.step.size += step.size;
        last.note += ", " + steps[i].note;
        i = next;
        continue;
      }
    }
    for (std::size_t k = i; k < next; ++k) merged.push_back(std::move(steps[k]));
    i = next;
  }
  std::vector<std::pair<std::uint64_t, std::uint64_t>> written;
  for (std::size_t i = 0; i < merged.size(); i += 1 + merged[i].step.body) {
    const Step& step = merged[i].step;
    switch (step.op) {
      case Op::zero:
      case Op::copy:
      case Op::constant:
      case Op::string:
      case Op::sequence: written.emplace_back(step.dst, step.dst + step.size); break;
      case Op::tail_constant: written.emplace_back(step.dst, step.dst + sizeof(FlatSpan)); break;
      case Op::enum_map: written.emplace_back(step.dst, step.dst + sizeof(std::int32_t)); break;
      case Op::length: written.emplace_back(step.dst, step.dst + step.size); break;
      case Op::convert:
      case Op::scale:
        for (std::uint32_t k = 0; k < step.count; ++k) {
          const std::uint64_t at = step.dst + std::uint64_t{k} * step.dst_stride;
          written.emplace_back(at, at + step.size);
        }
        break;
      case Op::repeat: written.emplace_back(step.dst, step.dst + std::uint64_t{step.count} * step.dst_stride); break;
      case Op::transform:
        for (std::uint32_t r = 0; r < step.count; ++r) {
          const VectorElement& element = program_->elements_[step.elements + step.pool_count + r];
          written.emplace_back(element.offset, element.offset + number_size(element.kind));
        }
        break;
    }
  }
  std::sort(written.begin(), written.end());
  std::vector<Emitted> result;
  std::uint64_t at = 0;
  const auto zero_until = [&](std::uint64_t end) {
    if (end <= at) return;
    Step step;
    step.op = Op::zero;
    step.dst = static_cast<std::uint32_t>(at);
    step.size = static_cast<std::uint32_t>(end - at);
    result.push_back(Emitted{step, "zero " + std::to_string(step.size) + " bytes @" + std::to_string(step.dst)});
  };
  for (const auto& [first, last] : written) {
    zero_until(std::min<std::uint64_t>(first, frame_size));
    at = std::max(at, last);
  }
  zero_until(frame_size);
  for (Emitted& emitted : merged) result.push_back(std::move(emitted));
  steps = std::move(result);
}

}  // namespace polyport::mapping
