// <mapping> inside a <port_connection>: its rules read here, compiled by MappingProgram
// (mapping.hpp) once both ends' types are known; connections whose ends have different types
// get a by-name mapping even without one.

#include "loader.hpp"

namespace polyport::detail {

MappingSpec Loader::read_mapping(const Reporter& report, pugi::xml_node element) {
  MappingSpec spec;
  spec.where = report.xml().at(element);
  spec.element_path = element_path(element);
  if (const auto by_name = element.attribute("by_name")) {
    const std::string text(trim(by_name.value()));
    if (const auto value = lookup(kBooleans, text)) {
      spec.by_name = *value;
    } else {
      report.error_attribute(element, "by_name",
                             "bad by_name " + in_quotes(text) + " (accepted: " + accepted(kBooleans) + ")");
    }
  }
  const Children children = scan(report, element, kMappingRules);
  for (const pugi::xml_node field : children.all("field")) {
    if (auto rule = read_rule(report, field)) spec.rules.push_back(std::move(*rule));
  }
  return spec;
}

// Reads one <field>: its attributes' syntax and which go together. Whether the paths,
// units and sizes fit the types is the mapping compiler's to say, once types are loaded.
std::optional<MappingRule> Loader::read_rule(const Reporter& report, pugi::xml_node field) {
  MappingRule rule;
  rule.where = report.xml().at(field);
  rule.element_path = element_path(field);
  bool ok = true;
  const auto text = [&](const char* name) { return std::string(trim(field.attribute(name).value())); };
  const auto has = [&](const char* name) { return static_cast<bool>(field.attribute(name)); };
  const auto not_for = [&](std::initializer_list<const char*> names, const std::string& what) {
    for (const char* name : names) {
      if (!has(name)) continue;
      report.error_attribute(field, name, std::string(name) + " does not apply to " + what);
      ok = false;
    }
  };

  rule.target = text("target");
  if (rule.target.empty()) {
    report.error(field, has("target") ? "empty attribute 'target'" : "missing attribute 'target'");
    ok = false;
  }
  if (has("source") && has("value")) {
    report.error_attribute(field, "value", "source and value exclude each other");
    ok = false;
  } else if (!has("source") && !has("value")) {
    report.error(field, "missing attribute 'source' or 'value'");
    ok = false;
  } else if (has("source")) {
    rule.source = text("source");
    if (rule.source.empty()) {
      report.error_attribute(field, "source", "empty attribute 'source'");
      ok = false;
    }
  }

  for (const char* name : {"scale", "offset"}) {
    if (!has(name)) continue;
    const std::string value = text(name);
    if (const auto number = parse_number(value)) {
      (std::string_view(name) == "scale" ? rule.scale : rule.offset) = *number;
    } else {
      report.error_attribute(field, name, "bad " + std::string(name) + " " + in_quotes(value) + ": expected a number");
      ok = false;
    }
  }
  for (const char* name : {"allow_narrowing", "truncate"}) {
    if (!has(name)) continue;
    const std::string value = text(name);
    if (const auto flag = lookup(kBooleans, value)) {
      (std::string_view(name) == "truncate" ? rule.truncate : rule.allow_narrowing) = *flag;
    } else {
      report.error_attribute(field, name,
                             "bad " + std::string(name) + " " + in_quotes(value) + " (accepted: " +
                                 accepted(kBooleans) + ")");
      ok = false;
    }
  }
  rule.from_unit = text("from_unit");
  rule.to_unit = text("to_unit");

  if (has("value")) {
    rule.kind = MappingRule::Kind::constant;
    // Not trimmed: a string constant may begin or end with blanks.
    rule.value = field.attribute("value").value();
    not_for({"scale", "offset", "from_unit", "to_unit", "allow_narrowing", "truncate", "transform", "matrix",
             "translation"},
            "a constant (value)");
    return ok ? std::optional<MappingRule>(std::move(rule)) : std::nullopt;
  }
  if (!has("transform")) {
    for (const char* name : {"matrix", "translation"}) {
      if (has(name)) {
        report.error_attribute(field, name, std::string(name) + " needs transform=\"linear\" or \"affine\"");
        ok = false;
      }
    }
    return ok ? std::optional<MappingRule>(std::move(rule)) : std::nullopt;
  }
  const std::string transform = text("transform");
  if (const auto kind = lookup(kTransforms, transform)) {
    rule.kind = *kind;
  } else {
    report.error_attribute(field, "transform",
                           "bad transform " + in_quotes(transform) + " (accepted: " + accepted(kTransforms) + ")");
    return std::nullopt;
  }
  not_for({"scale", "offset", "from_unit", "to_unit", "truncate"}, "a transform (fold it into the matrix)");
  if (!has("matrix")) {
    report.error(field, "missing attribute 'matrix' (needed by a transform)");
    ok = false;
  } else if (!read_matrix(report, field, rule)) {
    ok = false;
  }
  if (rule.kind == MappingRule::Kind::affine && !has("translation")) {
    report.error(field, "missing attribute 'translation' (needed by transform=\"affine\")");
    ok = false;
  } else if (rule.kind == MappingRule::Kind::linear && has("translation")) {
    report.error_attribute(field, "translation", "a translation needs transform=\"affine\"");
    ok = false;
  } else if (has("translation")) {
    std::string bad;
    if (auto values = parse_numbers(field.attribute("translation").value(), bad)) {
      rule.translation = std::move(*values);
    } else {
      report.error_attribute(field, "translation", "bad translation: " + not_a_number(bad));
      ok = false;
    }
  }
  return ok ? std::optional<MappingRule>(std::move(rule)) : std::nullopt;
}

std::string Loader::not_a_number(const std::string& entry) {
  return entry.empty() ? "an entry is missing" : in_quotes(entry) + " is not a number";
}

// matrix="m11 m12; m21 m22": rows separated by ';', the entries of a row by blanks or commas.
bool Loader::read_matrix(const Reporter& report, pugi::xml_node field, MappingRule& rule) {
  const std::string_view text = field.attribute("matrix").value();
  std::size_t rows = 0;
  std::size_t cols = 0;
  std::size_t start = 0;
  while (true) {
    const std::size_t end = std::min(text.find(';', start), text.size());
    std::string bad;
    const auto row = parse_numbers(text.substr(start, end - start), bad);
    if (!row) {
      report.error_attribute(field, "matrix", "bad matrix: " + not_a_number(bad));
      return false;
    }
    ++rows;
    if (rows == 1) {
      cols = row->size();
    } else if (row->size() != cols) {
      report.error_attribute(field, "matrix",
                             "bad matrix: row " + std::to_string(rows) + " has " + std::to_string(row->size()) +
                                 " entries but row 1 has " + std::to_string(cols));
      return false;
    }
    rule.matrix.insert(rule.matrix.end(), row->begin(), row->end());
    if (end == text.size()) break;
    start = end + 1;
  }
  if (rows > kMaxMatrixSide || cols > kMaxMatrixSide) {
    report.error_attribute(field, "matrix",
                           "bad matrix: " + std::to_string(rows) + "x" + std::to_string(cols) +
                               " (at most 6 rows and 6 columns)");
    return false;
  }
  rule.matrix_rows = static_cast<std::uint32_t>(rows);
  rule.matrix_cols = static_cast<std::uint32_t>(cols);
  return true;
}

// Compiles the mapping of a data or event connection whose ends are both known: the
// profile's <mapping>, or a by-name one when the types differ. A mapping that cannot work
// is one "type mismatch" at the connection (when the types differ) that says why, and the
// problems a rule causes at that rule's <field>.
void Loader::compile_mapping(const Reporter& report, pugi::xml_node node, ConnectionSpec& spec,
                     const std::string& source_type, const std::string& target_type, bool readable) {
  const pugi::xml_node mapping_node = node.child("mapping");
  if (source_type.empty() || target_type.empty()) {
    // An event without a payload: there is nothing to map (a mismatch is not an error).
    if (spec.mapping) report.error(mapping_node, "a mapping needs a data type on both ports");
    return;
  }
  const Type* from = types_.find(source_type);
  const Type* to = types_.find(target_type);
  if (from == nullptr || to == nullptr) return;  // reported at the port
  const bool same = from == to;
  if (same && !spec.mapping) return;
  if (!readable) return;  // its rules' problems are reported; compiling would repeat them
  const MappingSpec by_name;
  const MappingSpec& mapping = spec.mapping ? *spec.mapping : by_name;
  std::vector<MappingProblem> problems;
  auto program = MappingProgram::compile(*from, *to, mapping, problems);
  if (program) {
    spec.program = std::move(program);
    return;
  }
  std::vector<std::string> reasons;
  std::set<const MappingRule*> faulty_rules;
  for (const MappingProblem& problem : problems) {
    if (problem.rule == nullptr) {
      reasons.push_back(problem.message);
    } else {
      faulty_rules.insert(problem.rule);
    }
  }
  if (!faulty_rules.empty()) {
    reasons.push_back(faulty_rules.size() == 1
                          ? std::string("1 rule of the <mapping> is at fault (reported at its <field>)")
                          : std::to_string(faulty_rules.size()) +
                                " rules of the <mapping> are at fault (reported at their <field>s)");
  }
  const std::string source_name = spec.source.component + "." + spec.source.port;
  const std::string target_name = spec.target.component + "." + spec.target.port;
  if (!same) {
    report.error(node, "type mismatch: " + source_name + " is " + in_quotes(source_type) + " but " + target_name +
                           " is " + in_quotes(target_type) + ": " + join(reasons, "; "));
  } else if (faulty_rules.size() != problems.size()) {
    // The same type on both ends always maps by name; only rules can fail, but say so if not.
    report.error(mapping_node, "the mapping from " + source_name + " to " + target_name +
                                   " does not compile: " + join(reasons, "; "));
  }
  for (const MappingProblem& problem : problems) {
    if (problem.rule != nullptr) {
      diagnostics_.error(problem.rule->where, problem.rule->element_path, problem.message);
    }
  }
}

}  // namespace polyport::detail
