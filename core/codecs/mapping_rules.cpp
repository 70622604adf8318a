// The rules of a mapping (mapping_compiler.hpp): each rule's target and source paths parsed
// and resolved in their types; a rule set twice, or inside the target of one that sets a
// whole value other than by a plain copy, refused; units, scale and offset folded into one
// y = x * scale + offset, from the unit table. Also whether a target path has a rule, or rules
// below it, for the walk. Runs at load time.
#include "mapping_compiler.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <system_error>
#include <utility>
#include <vector>

namespace polyport::mapping {

namespace {

// ---------------------------------------------------------------------------------------
// Units: value_in_base = value * factor + offset (the offset only for temperatures).

struct Unit {
  std::string_view name;
  std::string_view dimension;
  double factor;
  double offset;
};

constexpr double kPi = 3.14159265358979323846;

constexpr Unit kUnits[] = {
    {"rad", "angle", 1.0, 0.0},
    {"deg", "angle", kPi / 180.0, 0.0},
    {"m", "length", 1.0, 0.0},
    {"cm", "length", 1e-2, 0.0},
    {"mm", "length", 1e-3, 0.0},
    {"km", "length", 1e3, 0.0},
    {"s", "time", 1.0, 0.0},
    {"ms", "time", 1e-3, 0.0},
    {"us", "time", 1e-6, 0.0},
    {"ns", "time", 1e-9, 0.0},
    {"m/s", "speed", 1.0, 0.0},
    {"km/h", "speed", 1000.0 / 3600.0, 0.0},
    {"mph", "speed", 0.44704, 0.0},  // 1609.344 m per hour, exactly
    {"rad/s", "angular velocity", 1.0, 0.0},
    {"deg/s", "angular velocity", kPi / 180.0, 0.0},
    {"rpm", "angular velocity", 2.0 * kPi / 60.0, 0.0},
    {"kg", "mass", 1.0, 0.0},
    {"g", "mass", 1e-3, 0.0},
    {"K", "temperature", 1.0, 0.0},
    {"degC", "temperature", 1.0, 273.15},
    {"degF", "temperature", 5.0 / 9.0, 273.15 - 32.0 * 5.0 / 9.0},
    {"Pa", "pressure", 1.0, 0.0},
    {"kPa", "pressure", 1e3, 0.0},
    {"bar", "pressure", 1e5, 0.0},
    {"psi", "pressure", 6894.757293168361, 0.0},  // lbf/in^2
};

const Unit* find_unit(std::string_view name) noexcept {
  for (const Unit& unit : kUnits) {
    if (unit.name == name) return &unit;
  }
  return nullptr;
}

std::string known_units() {
  std::string out;
  for (const Unit& unit : kUnits) {
    if (!out.empty()) out += ", ";
    out += unit.name;
  }
  return out;
}

// ---------------------------------------------------------------------------------------
// Paths: "a.b[1].c"

struct PathPart {
  std::string name;  // empty for an index
  std::uint32_t index = 0;
};

bool is_name_start(char c) { return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || c == '_'; }
bool is_name_char(char c) { return is_name_start(c) || (c >= '0' && c <= '9'); }

std::optional<std::vector<PathPart>> parse_path(std::string_view text) {
  std::vector<PathPart> parts;
  std::size_t i = 0;
  bool expect_name = true;
  while (i < text.size() || expect_name) {
    if (expect_name) {
      if (i >= text.size() || !is_name_start(text[i])) return std::nullopt;
      const std::size_t start = i;
      while (i < text.size() && is_name_char(text[i])) ++i;
      parts.push_back({std::string(text.substr(start, i - start)), 0});
      expect_name = false;
    } else if (text[i] == '.') {
      ++i;
      expect_name = true;
    } else if (text[i] == '[') {
      const std::size_t start = ++i;
      while (i < text.size() && text[i] >= '0' && text[i] <= '9') ++i;
      std::uint32_t index = 0;
      const auto [end, ec] = std::from_chars(text.data() + start, text.data() + i, index);
      if (ec != std::errc{} || end != text.data() + i || i >= text.size() || text[i] != ']') {
        return std::nullopt;
      }
      ++i;
      parts.push_back({std::string(), index});
    } else {
      return std::nullopt;
    }
  }
  return parts;
}

// Whether path `inner` names a part of what path `outer` names ("a.b" and "a[1]" are in "a").
bool is_inside(const std::string& outer, const std::string& inner) {
  return inner.size() > outer.size() && inner.compare(0, outer.size(), outer) == 0 &&
         (inner[outer.size()] == '.' || inner[outer.size()] == '[');
}

}  // namespace

}  // namespace polyport::mapping

namespace polyport {

FieldPathResult find_field_path(const Type& root, std::string_view text) {
  using namespace mapping;
  FieldPathResult result;
  const auto parts = parse_path(text);
  if (!parts) {
    result.bad_syntax = true;
    return result;
  }
  FieldPlace place{&root.resolved(), 0, ""};
  for (const PathPart& part : *parts) {
    const Type& type = *place.type;
    const std::string at = place.path;
    if (!part.name.empty()) {
      place.path = join_path(at, part.name);
      if (type.kind != TypeKind::structure) {
        result.why = in_quotes(at) + " is " + in_quotes(type.name) + ", which has no fields";
        return result;
      }
      const Field* field = type.find_field(part.name);
      if (field == nullptr) {
        result.why = (at.empty() ? std::string("fields: ") : "fields of " + in_quotes(at) + ": ") + field_list(type);
        return result;
      }
      place.type = &field->type->resolved();
      place.offset += field->offset;
    } else {
      place.path = index_path(at, part.index);
      if (type.kind != TypeKind::array) {
        result.why = in_quotes(at) + " is " + in_quotes(type.name) + "; an index needs a fixed array";
        return result;
      }
      if (part.index >= type.bound) {
        result.why = in_quotes(at) + " is " + in_quotes(type.name);
        return result;
      }
      place.type = &type.element->resolved();
      place.offset += part.index * type.element->size;
    }
  }
  result.place = std::move(place);
  return result;
}

}  // namespace polyport

namespace polyport::mapping {

// -- rules ------------------------------------------------------------------------------

// Resolves a path through structs and fixed arrays; reports and returns nothing if it
// does not lead to a field.
std::optional<Place> Compiler::resolve(const MappingRule& rule, const Type& root, const std::string& text,
                                       std::string_view side, std::string* canonical) {
  const FieldPathResult found = find_field_path(root, text);
  if (!found.place) {
    if (found.bad_syntax) {
      problem(&rule, "bad " + std::string(side) + " path " + in_quotes(text) +
                         " (expected names and [index], e.g. a.b[1].c)");
    } else {
      problem(&rule, std::string(side) + " " + in_quotes(text) + " not found in " + in_quotes(root.name) + " (" +
                         found.why + ")");
    }
    return std::nullopt;
  }
  if (canonical != nullptr) *canonical = found.place->path;
  return Place{found.place->type, found.place->offset, found.place->path};
}

void Compiler::prepare_rules() {
  for (const MappingRule& rule : spec_.rules) {
    PreparedRule prepared;
    prepared.rule = &rule;
    const auto target = resolve(rule, to_, rule.target, "target", &prepared.target_path);
    if (!target) continue;  // its target is unknown: nothing to leave alone either
    prepared.target = *target;
    prepared.ok = true;
    if (rule.kind != MappingRule::Kind::constant) {
      if (rule.source.empty()) {
        problem(&rule, "rule for target " + in_quotes(prepared.target_path) + " has no source");
        prepared.ok = false;
      } else if (const auto source = resolve(rule, from_, rule.source, "source", nullptr)) {
        prepared.source = *source;
      } else {
        prepared.ok = false;
      }
    }
    prepared.options.rule = &rule;
    prepared.options.required = true;
    prepared.options.allow_narrowing = rule.allow_narrowing;
    prepared.options.truncate = rule.truncate;
    if (!prepare_scale(rule, prepared.options)) prepared.ok = false;
    for (const PreparedRule& other : rules_) {
      if (other.target_path == prepared.target_path) {
        problem(&rule, "duplicate rule for target " + in_quotes(prepared.target_path) +
                           (other.rule->where.line > 0
                                ? ": already given at line " + std::to_string(other.rule->where.line)
                                : std::string()));
        prepared.ok = false;
        break;
      }
    }
    rules_.push_back(std::move(prepared));
  }
  // A rule inside the target of another is fine only when the outer one is a plain copy
  // of a struct or array: the inner one then overrides that part of it.
  for (PreparedRule& inner : rules_) {
    for (const PreparedRule& outer : rules_) {
      if (!is_inside(outer.target_path, inner.target_path)) continue;
      const bool plain = outer.rule->kind == MappingRule::Kind::copy && !outer.options.scaled;
      if (!plain) {
        problem(inner.rule, "rule for target " + in_quotes(inner.target_path) + " is inside " +
                                in_quotes(outer.target_path) + ", which " +
                                (outer.rule->where.line > 0
                                     ? "the rule at line " + std::to_string(outer.rule->where.line)
                                     : std::string("another rule")) +
                                " sets as a whole");
        inner.ok = false;
      }
    }
  }
}

// Folds the unit conversion and then scale and offset into one y = x * scale + offset.
bool Compiler::prepare_scale(const MappingRule& rule, Options& options) {
  double scale = 1.0;
  double offset = 0.0;
  const bool has_units = !rule.from_unit.empty() || !rule.to_unit.empty();
  if (has_units) {
    if (rule.from_unit.empty() || rule.to_unit.empty()) {
      problem(&rule, "from_unit and to_unit go together");
      return false;
    }
    const Unit* from = find_unit(rule.from_unit);
    const Unit* to = find_unit(rule.to_unit);
    for (const auto& [unit, name] : {std::pair{from, &rule.from_unit}, std::pair{to, &rule.to_unit}}) {
      if (unit == nullptr) problem(&rule, "unknown unit " + in_quotes(*name) + " (known: " + known_units() + ")");
    }
    if (from == nullptr || to == nullptr) return false;
    if (from->dimension != to->dimension) {
      problem(&rule, "cannot convert " + in_quotes(from->name) + " (" + std::string(from->dimension) + ") to " +
                         in_quotes(to->name) + " (" + std::string(to->dimension) + ")");
      return false;
    }
    scale = from->factor / to->factor;
    offset = (from->offset - to->offset) / to->factor;
  }
  options.scaled = has_units || rule.scale != 1.0 || rule.offset != 0.0;
  options.scale = scale * rule.scale;
  options.offset = offset * rule.scale + rule.offset;
  if (!std::isfinite(options.scale) || !std::isfinite(options.offset)) {
    problem(&rule, "scale and offset must be finite numbers");
    return false;
  }
  if (options.scaled && rule.kind != MappingRule::Kind::copy) {
    problem(&rule, "scale, offset and units apply to copies, not to a " +
                       std::string(rule.kind == MappingRule::Kind::constant ? "constant" : "transform"));
    return false;
  }
  return true;
}

const PreparedRule* Compiler::exact(const std::string& path) const {
  for (const PreparedRule& rule : rules_) {
    if (rule.target_path == path) return &rule;
  }
  return nullptr;
}

bool Compiler::has_rules_below(const std::string& path) const {
  // Rules already found at fault do not count: descending for them would only report
  // the fields around them as unmapped.
  return std::any_of(rules_.begin(), rules_.end(), [&](const PreparedRule& rule) {
    return rule.ok && (path.empty() || is_inside(path, rule.target_path));
  });
}

}  // namespace polyport::mapping
