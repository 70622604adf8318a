// Loads OPRoS-shaped application and component profiles (see docs/PROFILES.md and
// config/polyport.xsd). The loader never stops at the first problem: it reads as much as it
// can and reports every problem as `file:line:col: element path: message`, so a user fixes a
// profile in one round. Set-up code only; nothing here runs on the forwarding path.
//
// A <mapping> inside a <port_connection> is read here and compiled by MappingProgram (see
// mapping.hpp) once the types are known; connections whose ends have different types get a
// by-name mapping even without one.
//
// Element paths follow libxml2's xmlGetNodePath: an element gets a 1-based `[n]` only when its
// parent has more than one child element of that name (`/.../port_connection[2]/source`,
// but `/.../ports/data_port` when there is one). Attributes are addressed as `/@name`.

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <sstream>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <pugixml.hpp>

#include "polyport/base/diagnostics.hpp"
#include "polyport/profile/model_section.hpp"
#include "polyport/profile/profile.hpp"
#include "polyport/profile/profile_element.hpp"
#include "polyport/profile/profile_text.hpp"
#include "xml_file.hpp"
#include "polyport/types/types.hpp"

namespace polyport {

namespace fs = std::filesystem;

namespace {

// A buffer or circular queue without an explicit size gets this many samples: enough to ride
// out a few missed periods of a 10 ms reader without hiding a reader that has stopped.
constexpr std::uint32_t kDefaultDepth = 16;
// CPU_SETSIZE on Linux; a profile may be checked on another machine than the one it runs on,
// so the real CPU count is checked when the execution context pins its thread, not here.
constexpr int kMaxCpu = 1023;
constexpr int kMinRtPriority = 1;
constexpr int kMaxRtPriority = 99;

using namespace text;
using namespace detail;


// Case-sensitive on purpose: the XSD's enumerations are, and both must accept the same files.
constexpr Spelling<QueuePolicy> kQueuePolicies[] = {
    {"data", QueuePolicy::data},           {"LAST", QueuePolicy::data},
    {"OPROS_LAST", QueuePolicy::data},     {"buffer", QueuePolicy::buffer},
    {"circular", QueuePolicy::circular},   {"FIFO", QueuePolicy::circular},
    {"OPROS_FIFO", QueuePolicy::circular},
};
constexpr Spelling<ExecutionType> kExecutionTypes[] = {
    {"periodic", ExecutionType::periodic},
    {"periodic-shared", ExecutionType::periodic},
    {"periodic-exclusive", ExecutionType::periodic_exclusive},
    {"aperiodic", ExecutionType::aperiodic},
    {"non-periodic", ExecutionType::aperiodic},
    {"passive", ExecutionType::passive},
};
constexpr Spelling<SchedPolicy> kSchedPolicies[] = {
    {"SCHED_OTHER", SchedPolicy::other}, {"SCHED_FIFO", SchedPolicy::fifo},
    {"SCHED_RR", SchedPolicy::rr},       {"OTHER", SchedPolicy::other},
    {"FIFO", SchedPolicy::fifo},         {"RR", SchedPolicy::rr},
};
constexpr Spelling<InitialState> kLifecycleTypes[] = {
    {"start", InitialState::active},      {"stop", InitialState::inactive},
    {"active", InitialState::active},     {"running", InitialState::active},
    {"ACTIVE", InitialState::active},     {"inactive", InitialState::inactive},
    {"stopped", InitialState::inactive},  {"READY", InitialState::inactive},
    {"INACTIVE", InitialState::inactive},
};
constexpr Spelling<PortKind> kPortTypes[] = {
    {"data", PortKind::data},
    {"service", PortKind::service},
    {"event", PortKind::event},
    {"method", PortKind::service},  // OPRoS's name for service connections
};
constexpr Spelling<PortDirection> kDataUsages[] = {
    {"input", PortDirection::input},
    {"output", PortDirection::output},
};
constexpr Spelling<PortDirection> kServiceUsages[] = {
    {"required", PortDirection::required},
    {"provided", PortDirection::provided},
};

std::string_view sched_policy_name(SchedPolicy policy) {
  switch (policy) {
    case SchedPolicy::fifo: return "SCHED_FIFO";
    case SchedPolicy::rr: return "SCHED_RR";
    case SchedPolicy::other: break;
  }
  return "SCHED_OTHER";
}

bool is_periodic(ExecutionType type) {
  return type == ExecutionType::periodic || type == ExecutionType::periodic_exclusive;
}

std::string port_noun(const PortSpec& port) {
  return std::string(port.kind == PortKind::event ? "an " : "a ") +
         std::string(to_string(port.kind)) + " port";
}

std::string direction_noun(PortDirection direction) {
  const bool vowel = direction == PortDirection::input || direction == PortDirection::output;
  return std::string(vowel ? "an " : "a ") + std::string(to_string(direction)) + " port";
}


std::optional<std::uint32_t> depth_value(std::string_view text) {
  const auto value = parse_integer<std::uint32_t>(text);
  if (!value || *value == 0) return std::nullopt;
  return value;
}

const std::string kDepthExpected = "expected an integer from 1 to 4294967295";

// ---------------------------------------------------------------------------------------
// Child tables, one per element kind.

const std::vector<ChildRule> kApplicationRules = {
    {"name", {"name"}},
    {"description", {"description"}},
    {"", {"id", "copyright"}},
    {"types", {"types"}},
    {"subcomponents", {"subcomponents"}},
    {"port_connections", {"port_connections"}},
};
const std::vector<ChildRule> kTypesRules = {{"file", {"file"}, true}};
const std::vector<ChildRule> kSubcomponentsRules = {{"subcomponent", {"subcomponent"}, true}};
const std::vector<ChildRule> kSubcomponentRules = {
    {"name", {"name"}},
    {"reference", {"reference"}},
    {"", {"id", "type", "node_id"}},
};
const std::vector<ChildRule> kConnectionsRules = {
    {"port_connection", {"port_connection"}, true, {"port_type", "policy", "depth"}},
};
const std::vector<ChildRule> kConnectionRules = {
    {"source", {"source"}, false, {"component_name", "port_name"}},
    {"target", {"target"}, false, {"component_name", "port_name"}},
    {"mapping", {"mapping"}, false, {"by_name"}},
};
const std::vector<ChildRule> kMappingRules = {
    {"field",
     {"field"},
     true,
     {"target", "source", "value", "scale", "offset", "from_unit", "to_unit", "allow_narrowing", "truncate",
      "transform", "matrix", "translation"}},
};
constexpr Spelling<MappingRule::Kind> kTransforms[] = {
    {"linear", MappingRule::Kind::linear},
    {"affine", MappingRule::Kind::affine},
};
// A matrix has at most this many rows and columns: vector fields have 1 to 6 elements.
constexpr std::size_t kMaxMatrixSide = 6;
const std::vector<ChildRule> kComponentRules = {
    {"name", {"name"}},
    {"description", {"description"}},
    {"", {"id", "copyright"}},
    {"model", {"model"}},
    {"execution_environment", {"execution_environment"}},
    {"execution_semantics", {"execution_semantics"}},
    {"types", {"types"}},
    {"properties", {"properties"}},
    {"ports", {"ports"}},
};
const std::vector<ChildRule> kEnvironmentRules = {
    {"library_type", {"library_type"}},
    {"library_name", {"library_name"}},
    {"class_name", {"class_name"}},
    {"", {"os", "cpu", "impl_language", "compiler"}},
};
const std::vector<ChildRule> kSemanticsRules = {
    {"type", {"type"}},
    {"period", {"period"}},
    {"priority", {"priority"}},
    {"policy", {"policy"}},
    {"cpu", {"cpu_affinity", "cpu"}},
    {"lifecycle_type", {"lifecycle_type"}},
    {"", {"creation_type", "instance_creation"}},
};
const std::vector<ChildRule> kPropertiesRules = {
    {"property", {"property"}, true, {"name", "type"}},
};
const std::vector<ChildRule> kPortsRules = {
    {"port", {"data_port", "event_port", "service_port"}, true},
};
const std::vector<ChildRule> kDataPortRules = {
    {"name", {"name"}},
    {"", {"description"}},
    {"data_type", {"data_type"}},
    {"usage", {"usage"}},
    {"policy", {"queueing_policy", "policy"}},
    {"depth", {"queue_size", "queueing_size"}},
    {"policy_param", {"policy_param"}, true, {"name"}},
};
const std::vector<ChildRule> kServicePortRules = {
    {"name", {"name"}},
    {"", {"description", "reference"}},
    {"type", {"type"}},
    {"usage", {"usage"}},
    {"operation", {"operation"}, true, {"name", "request", "reply", "oneway"}},
};

// ---------------------------------------------------------------------------------------
// The loader

// A name that must resolve in the type registry once every type file is loaded.
struct LoadedComponent {
  bool readable = false;  // the file was parsed and had the right root
  ComponentProfile profile;
  std::vector<TypeUse> type_uses;
  std::set<std::string, std::less<>> incomplete_ports;  // kind/direction unknown: not checked
  // The readers of model elements: the component's own model's, and those of other models
  // whose elements it carries (read for their problems, then dropped).
  std::unique_ptr<ComponentSectionReader> own_reader;
  std::map<const ModelSection*, std::unique_ptr<ComponentSectionReader>> foreign_readers;
};

// The names every known model owns, added to core's own child tables.
struct ModelRules {
  std::vector<ChildRule> component;
  std::vector<ChildRule> data_port;
  std::vector<ChildRule> service_port;
  std::vector<std::pair<std::string_view, const ModelSection*>> sections;

  explicit ModelRules(const ModelSections* models)
      : component(kComponentRules), data_port(kDataPortRules), service_port(kServicePortRules) {
    if (models != nullptr) sections = models->sections();
    std::set<std::string_view> component_tags;
    std::set<std::string_view> port_tags;
    std::set<std::string_view> attributes;
    const std::size_t operation = service_port.size() - 1;  // {"operation", ...}
    for (const auto& [model, section] : sections) {
      const ModelVocabulary& vocabulary = section->vocabulary();
      for (const std::string_view tag : vocabulary.component_elements) {
        if (component_tags.insert(tag).second) component.push_back(ChildRule(tag, {tag}));
      }
      for (const std::string_view tag : vocabulary.port_elements) {
        if (!port_tags.insert(tag).second) continue;
        data_port.push_back(ChildRule(tag, {tag}));
        service_port.push_back(ChildRule(tag, {tag}));
      }
      for (const std::string_view attribute : vocabulary.operation_attributes) {
        if (attributes.insert(attribute).second) service_port[operation].attributes.push_back(attribute);
      }
    }
  }

  const ModelSection* section_of(std::string_view model) const {
    for (const auto& [name, section] : sections) {
      if (name == model) return section;
    }
    return nullptr;
  }

  // The model that reads `name` (a member of `list` of its vocabulary): the first that has it.
  template <class List>
  const ModelSection* owner_of(std::string_view name, List ModelVocabulary::*list) const {
    for (const auto& [model, section] : sections) {
      const auto& names = section->vocabulary().*list;
      if (std::find(names.begin(), names.end(), name) != names.end()) return section;
    }
    return nullptr;
  }
};

bool owns(const ModelSection* section, std::string_view name,
          std::vector<std::string_view> ModelVocabulary::*list) {
  if (section == nullptr) return false;
  const auto& names = section->vocabulary().*list;
  return std::find(names.begin(), names.end(), name) != names.end();
}

class Loader {
 public:
  Loader(TypeRegistry& types, const LoadOptions& options, Diagnostics& diagnostics)
      : types_(types), options_(options), diagnostics_(diagnostics), rules_(options.models) {}

  std::optional<ApplicationProfile> run(const fs::path& requested) {
    const std::size_t errors_before = diagnostics_.error_count();
    const fs::path file = absolute_path(requested);
    XmlFile xml;
    if (!xml.load(file, "application profile", SourceLocation{file.string(), 0, 0}, "",
                  diagnostics_)) {
      return std::nullopt;
    }
    const Reporter report(xml);
    const pugi::xml_node root = xml.root();
    if (std::string_view(root.name()) != "application_profile") {
      report.error(root, "expected root element <application_profile>, found <" +
                             std::string(root.name()) + ">");
      return std::nullopt;
    }
    check_attributes(report, root, {}, true);

    ApplicationProfile app;
    app.file = file;
    const Children children = scan(report, root, kApplicationRules);
    if (auto name = required_text(report, root, children, "name", "name")) app.name = *name;
    if (auto description = optional_text(children, "description")) app.description = *description;
    if (const auto types = children.one("types")) read_type_files(report, types, app.type_files);
    if (const auto subcomponents = children.one("subcomponents")) {
      read_subcomponents(report, subcomponents, app);
    }
    std::vector<pugi::xml_node> connection_nodes;
    if (const auto connections = children.one("port_connections")) {
      read_connections(report, connections, app, connection_nodes);
    }

    load_type_files();
    for (const LoadedComponent* component : load_order_) check_types(*component);
    for (auto& subcomponent : app.components) {
      const auto it = components_.find(subcomponent.reference);
      if (it != components_.end() && it->second->readable) {
        subcomponent.profile = it->second->profile;
      }
    }
    check_connections(report, app, connection_nodes);

    if (diagnostics_.error_count() != errors_before) return std::nullopt;
    return app;
  }

 private:
  // -- shared ----------------------------------------------------------------------------

  void read_type_files(const Reporter& report, pugi::xml_node types, std::vector<fs::path>& out) {
    const Children children = scan(report, types, kTypesRules);
    const fs::path base = fs::path(report.xml().name()).parent_path();
    for (const pugi::xml_node element : children.all("file")) {
      const std::string text = text_of(element);
      if (text.empty()) {
        report.error(element, "empty <file>");
        continue;
      }
      const fs::path file = absolute_path(base / text);
      out.push_back(file);
      std::error_code ec;
      if (!fs::exists(file, ec)) {
        report.error_text(element, "type file " + in_quotes(file.string()) + " not found");
        continue;
      }
      if (file.extension() != ".idl") {
        report.error_text(
            element, "unsupported type file " + in_quotes(file.string()) + " (supported: .idl)");
        continue;
      }
      pending_type_files_.push_back(file);
    }
  }

  void load_type_files() {
    // Type files may name each other's types, so all are read before any name is checked.
    std::set<fs::path> loaded;
    for (const auto& file : pending_type_files_) {
      if (!loaded.insert(file).second) continue;
      types_.add_type_file(file, diagnostics_);
    }
  }

  void check_types(const LoadedComponent& component) {
    if (!component.readable) return;
    for (const auto& use : component.type_uses) {
      if (types_.find(use.name) == nullptr) {
        diagnostics_.error(use.where, use.path, "unknown type " + in_quotes(use.name));
      }
    }
  }

  // -- application profile ---------------------------------------------------------------

  void read_subcomponents(const Reporter& report, pugi::xml_node element, ApplicationProfile& app) {
    const Children children = scan(report, element, kSubcomponentsRules);
    const fs::path base = app.file.parent_path();
    std::map<std::string, pugi::xml_node, std::less<>> seen;
    for (const pugi::xml_node node : children.all("subcomponent")) {
      const Children fields = scan(report, node, kSubcomponentRules);
      Subcomponent subcomponent;
      subcomponent.where = report.xml().at(node);
      const auto name = required_text(report, node, fields, "name", "name");
      const auto reference = required_text(report, node, fields, "reference", "reference");
      bool usable = name.has_value();
      if (name) {
        subcomponent.name = *name;
        const auto [it, inserted] = seen.emplace(*name, fields.one("name"));
        if (!inserted) {
          report.error_text(fields.one("name"),
                            "duplicate subcomponent name " + in_quotes(*name) +
                                ": already used at line " +
                                std::to_string(report.xml().at(it->second).line));
          usable = false;
        }
      }
      if (reference) {
        subcomponent.reference = absolute_path(base / *reference);
        const pugi::xml_node reference_node = fields.one("reference");
        load_component(subcomponent.reference, report.xml().at_text(reference_node),
                       element_path(reference_node));
      }
      // A duplicate stays out of the list so connections resolve against the first one.
      if (usable) app.components.push_back(std::move(subcomponent));
    }
  }

  void read_connections(const Reporter& report, pugi::xml_node element, ApplicationProfile& app,
                        std::vector<pugi::xml_node>& nodes) {
    const Children children = scan(report, element, kConnectionsRules);
    for (const pugi::xml_node node : children.all("port_connection")) {
      ConnectionSpec connection;
      connection.where = report.xml().at(node);
      // OPRoS: a port_connection without port_type is a "method" (service) connection.
      connection.kind = PortKind::service;
      if (const auto port_type = node.attribute("port_type")) {
        const std::string text(trim(port_type.value()));
        if (const auto kind = lookup(kPortTypes, text)) {
          connection.kind = *kind;
        } else {
          report.error_attribute(
              node, "port_type",
              "bad port_type " + in_quotes(text) + " (accepted: " + accepted(kPortTypes) + ")");
        }
      }
      if (const auto policy = node.attribute("policy")) {
        const std::string text(trim(policy.value()));
        connection.policy = lookup(kQueuePolicies, text);
        if (!connection.policy) {
          report.error_attribute(
              node, "policy",
              "bad policy " + in_quotes(text) + " (accepted: " + accepted(kQueuePolicies) + ")");
        }
      }
      if (const auto depth = node.attribute("depth")) {
        const std::string text(trim(depth.value()));
        connection.depth = depth_value(text);
        if (!connection.depth) {
          report.error_attribute(node, "depth",
                                 "bad depth " + in_quotes(text) + ": " + kDepthExpected);
        }
      }
      const Children ends = scan(report, node, kConnectionRules);
      read_end(report, node, ends.one("source"), "source", connection.source);
      read_end(report, node, ends.one("target"), "target", connection.target);
      bool mapping_readable = true;
      if (const auto mapping = ends.one("mapping")) {
        const std::size_t errors_before = diagnostics_.error_count();
        connection.mapping = read_mapping(report, mapping);
        mapping_readable = diagnostics_.error_count() == errors_before;
      }
      app.connections.push_back(std::move(connection));
      nodes.push_back(node);
      mapping_readable_.push_back(mapping_readable);
    }
  }

  void read_end(const Reporter& report, pugi::xml_node connection, pugi::xml_node end,
                std::string_view tag, ConnectionEnd& out) {
    if (!end) {
      report.error(connection, "missing <" + std::string(tag) + ">");
      return;
    }
    out.where = report.xml().at(end);
    for (const std::string_view attribute : {"component_name", "port_name"}) {
      const std::string value(trim(end.attribute(attribute.data()).value()));
      if (value.empty()) {
        if (end.attribute(attribute.data())) {
          report.error_attribute(end, attribute,
                                 "empty attribute '" + std::string(attribute) + "'");
        } else {
          report.error(end, "missing attribute '" + std::string(attribute) + "'");
        }
      }
      (attribute == "component_name" ? out.component : out.port) = value;
    }
  }

  // -- mappings --------------------------------------------------------------------------

  MappingSpec read_mapping(const Reporter& report, pugi::xml_node element) {
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
  static std::optional<MappingRule> read_rule(const Reporter& report, pugi::xml_node field) {
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

  static std::string not_a_number(const std::string& entry) {
    return entry.empty() ? "an entry is missing" : in_quotes(entry) + " is not a number";
  }

  // matrix="m11 m12; m21 m22": rows separated by ';', the entries of a row by blanks or commas.
  static bool read_matrix(const Reporter& report, pugi::xml_node field, MappingRule& rule) {
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
  void compile_mapping(const Reporter& report, pugi::xml_node node, ConnectionSpec& spec,
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

  // -- component profiles ----------------------------------------------------------------

  void load_component(const fs::path& file, const SourceLocation& referenced_at,
                      const std::string& referenced_path) {
    // Several instances may share one component profile: read (and report) it once.
    if (components_.count(file) != 0) return;
    auto& component = *components_.emplace(file, std::make_unique<LoadedComponent>()).first->second;
    load_order_.push_back(&component);
    component.profile.file = file;
    XmlFile xml;
    if (!xml.load(file, "component profile", referenced_at, referenced_path, diagnostics_)) return;
    const Reporter report(xml);
    const pugi::xml_node root = xml.root();
    if (std::string_view(root.name()) != "component_profile") {
      report.error(root, "expected root element <component_profile>, found <" +
                             std::string(root.name()) + ">");
      return;
    }
    check_attributes(report, root, {}, true);
    component.readable = true;
    read_component(report, root, component);
  }

  void read_component(const Reporter& report, pugi::xml_node root, LoadedComponent& component) {
    ComponentProfile& profile = component.profile;
    profile.where = report.xml().at(root);
    profile.execution.where = profile.where;
    const Children children = scan(report, root, rules_.component);
    if (auto name = required_text(report, root, children, "name", "name")) profile.name = *name;
    if (const auto model = children.one("model")) {
      const std::string text = text_of(model);
      if (text.empty()) {
        report.error(model, "empty <model>");
      } else {
        profile.model = text;
      }
    }
    const pugi::xml_node environment = children.one("execution_environment");
    const Children environment_children =
        environment ? scan(report, environment, kEnvironmentRules) : Children();
    if (auto class_name = optional_text(environment_children, "class_name");
        class_name && !class_name->empty()) {
      profile.class_name = *class_name;
    } else {
      profile.class_name = profile.name;
    }
    if (profile.model == "inproc") {
      read_library(report, root, environment, environment_children, profile);
    }
    if (const auto semantics = children.one("execution_semantics")) {
      read_execution(report, semantics, profile);
    }
    if (const ModelSection* own = rules_.section_of(profile.model)) component.own_reader = own->reader(profile.model);
    read_model_elements(report, children, component);
    if (const auto types = children.one("types")) {
      read_type_files(report, types, profile.type_files);
    }
    if (const auto properties = children.one("properties")) {
      read_properties(report, properties, profile);
    }
    if (const auto ports = children.one("ports")) read_ports(report, ports, component);
    if (component.own_reader) profile.model_settings = component.own_reader->finish();
    component.foreign_readers.clear();
  }

  // -- model elements --------------------------------------------------------------------

  // The reader of another model's elements on this component, made on first use.
  ComponentSectionReader& foreign_reader(LoadedComponent& component, const ModelSection* section) {
    auto& reader = component.foreign_readers[section];
    if (!reader) {
      for (const auto& [model, candidate] : rules_.sections) {
        if (candidate == section) {
          reader = section->reader(model);
          break;
        }
      }
    }
    return *reader;
  }

  // The component-level elements of every model: the own model reads its own; another
  // model's are ignored with a warning, after that model has checked them.
  void read_model_elements(const Reporter& report, const Children& children, LoadedComponent& component) {
    const std::string& model = component.profile.model;
    const ModelSection* own = rules_.section_of(model);
    for (const ChildRule& rule : rules_.component) {
      const pugi::xml_node node = children.one(rule.key);
      if (!node || !rules_.owner_of(rule.key, &ModelVocabulary::component_elements)) continue;
      const ProfileElement element(report.xml(), node.internal_object());
      if (owns(own, rule.key, &ModelVocabulary::component_elements)) {
        component.own_reader->read_component_element(element);
        continue;
      }
      report.warning(node, "<" + std::string(rule.key) + "> is ignored by model " + in_quotes(model));
      foreign_reader(component, rules_.owner_of(rule.key, &ModelVocabulary::component_elements))
          .read_component_element(element);
    }
  }

  // A port's model elements, the same way.
  void read_model_port(const Reporter& report, const Children& fields, const PortSpec& port,
                       LoadedComponent& component) {
    const std::string& model = component.profile.model;
    const ModelSection* own = rules_.section_of(model);
    ProfileChildren own_elements;
    std::map<const ModelSection*, ProfileChildren> foreign;
    for (const ChildRule& rule : port.kind == PortKind::service ? rules_.service_port : rules_.data_port) {
      const ModelSection* owner = rules_.owner_of(rule.key, &ModelVocabulary::port_elements);
      const pugi::xml_node node = fields.one(rule.key);
      if (owner == nullptr || !node) continue;
      const ProfileElement element(report.xml(), node.internal_object());
      if (owns(own, rule.key, &ModelVocabulary::port_elements)) {
        own_elements.add(rule.key, element);
        continue;
      }
      report.warning(node, "<" + std::string(rule.key) + "> is ignored by model " + in_quotes(model));
      foreign[owner].add(rule.key, element);
    }
    if (component.own_reader) component.own_reader->read_port(port, own_elements);
    for (const auto& [section, elements] : foreign) foreign_reader(component, section).read_port(port, elements);
  }

  // An operation's model attributes: the own model reads them; another model's are ignored
  // with one warning that names them all.
  void read_model_operation(const Reporter& report, pugi::xml_node element, const PortSpec& port,
                            const OperationSpec& operation, LoadedComponent& component,
                            std::vector<TypeUse>& uses) {
    const std::string& model = component.profile.model;
    const ModelSection* own = rules_.section_of(model);
    for (const auto& [name, section] : rules_.sections) {
      if (section == own) continue;
      const auto& attributes = section->vocabulary().operation_attributes;
      const bool present = std::any_of(attributes.begin(), attributes.end(), [&](std::string_view attribute) {
        return static_cast<bool>(element.attribute(std::string(attribute).c_str())) &&
               !owns(own, attribute, &ModelVocabulary::operation_attributes);
      });
      if (!present || section != rules_.owner_of(attributes.front(), &ModelVocabulary::operation_attributes)) {
        continue;
      }
      std::vector<std::string> names(attributes.begin(), attributes.end());
      report.warning(element, join(names, " / ") + " are ignored by model " + in_quotes(model));
    }
    if (component.own_reader) {
      component.own_reader->read_operation(port, operation, ProfileElement(report.xml(), element.internal_object()),
                                           uses);
    }
  }

  void read_library(const Reporter& report, pugi::xml_node root, pugi::xml_node environment,
                    const Children& children, ComponentProfile& profile) {
    const pugi::xml_node library = children.one("library_name");
    if (!library) {
      report.error(environment ? environment : root,
                   environment ? "missing <library_name> (needed by model 'inproc')"
                               : "missing <execution_environment> with <library_name> (needed by "
                                 "model 'inproc')");
      return;
    }
    profile.library = text_of(library);
    if (profile.library.empty()) {
      report.error(library, "empty <library_name>");
      return;
    }
    std::vector<fs::path> folders;
    folders.push_back(profile.file.parent_path());
    for (const auto& folder : options_.library_path) folders.push_back(absolute_path(folder));
    const fs::path library_file(profile.library);
    if (library_file.is_absolute()) folders.assign(1, library_file.parent_path());
    for (const auto& folder : folders) {
      const fs::path candidate = library_file.is_absolute() ? library_file : folder / library_file;
      std::error_code ec;
      if (fs::is_regular_file(candidate, ec)) {
        // Not canonical: a library is often a symlink to a versioned file, and logs should
        // show the name the profile asked for.
        profile.library_path = fs::absolute(candidate, ec).lexically_normal();
        return;
      }
    }
    std::vector<std::string> names;
    for (const auto& folder : folders) names.push_back(folder.string());
    report.error_text(library, "component library " + in_quotes(profile.library) +
                                   " not found (looked in: " + join(names, ", ") + ")");
  }

  void read_execution(const Reporter& report, pugi::xml_node element, ComponentProfile& profile) {
    ExecutionSemantics& execution = profile.execution;
    execution.where = report.xml().at(element);
    const Children children = scan(report, element, kSemanticsRules);
    if (const auto type = children.one("type")) {
      if (auto value = enum_text(report, type, kExecutionTypes, "execution type")) {
        execution.type = *value;
      }
    }
    if (const auto period = children.one("period")) {
      const std::string text = text_of(period);
      const auto value = parse_decimal(text);
      if (!value || *value < 0.0) {
        report.error_text(period, "bad period " + in_quotes(text) +
                                      ": expected a number of milliseconds, 0 or more");
      } else {
        execution.period_ms = *value;
        if (is_periodic(execution.type) && *value <= 0.0) {
          report.error_text(period, "period must be greater than 0 ms for a periodic component");
        }
      }
    }
    const pugi::xml_node priority = children.one("priority");
    if (priority) {
      const std::string text = text_of(priority);
      if (const auto value = parse_integer<int>(text)) {
        execution.priority = *value;
      } else {
        report.error_text(priority, "bad priority " + in_quotes(text) + ": expected an integer");
      }
    }
    const pugi::xml_node policy = children.one("policy");
    bool policy_ok = true;
    if (policy) {
      const auto value = enum_text(report, policy, kSchedPolicies, "scheduling policy");
      policy_ok = value.has_value();
      if (value) execution.policy = *value;
    }
    // Real-time policies need a real-time priority; SCHED_OTHER ignores it (OPRoS profiles
    // use it to group components onto shared executors).
    if (policy_ok && execution.policy != SchedPolicy::other) {
      const std::string name(sched_policy_name(execution.policy));
      if (!priority) {
        report.error(policy, name + " needs a <priority> from " + std::to_string(kMinRtPriority) +
                                 " to " + std::to_string(kMaxRtPriority));
      } else if (parse_integer<int>(text_of(priority)) &&
                 (execution.priority < kMinRtPriority || execution.priority > kMaxRtPriority)) {
        report.error_text(priority, "priority " + std::to_string(execution.priority) +
                                        " is out of range for " + name + " (" +
                                        std::to_string(kMinRtPriority) + " to " +
                                        std::to_string(kMaxRtPriority) + ")");
      }
    }
    if (const auto cpu = children.one("cpu")) {
      const std::string text = text_of(cpu);
      const auto value = parse_integer<int>(text);
      if (!value || *value < 0 || *value > kMaxCpu) {
        report.error_text(cpu, "bad " + std::string(cpu.name()) + " " + in_quotes(text) +
                                   ": expected an integer from 0 to " + std::to_string(kMaxCpu));
      } else {
        execution.cpu = *value;
      }
    }
    if (const auto lifecycle = children.one("lifecycle_type")) {
      if (auto value = enum_text(report, lifecycle, kLifecycleTypes, "lifecycle_type")) {
        profile.initial_state = *value;
      }
    }
  }

  void read_properties(const Reporter& report, pugi::xml_node element, ComponentProfile& profile) {
    const Children children = scan(report, element, kPropertiesRules);
    std::map<std::string, pugi::xml_node, std::less<>> seen;
    for (const pugi::xml_node node : children.all("property")) {
      PropertySpec property;
      property.where = report.xml().at(node);
      property.name = std::string(trim(node.attribute("name").value()));
      property.type = std::string(trim(node.attribute("type").value()));
      property.value = text_of(node);
      if (property.name.empty()) {
        report.error(
            node, node.attribute("name") ? "empty attribute 'name'" : "missing attribute 'name'");
        continue;
      }
      const auto [it, inserted] = seen.emplace(property.name, node);
      if (!inserted) {
        report.error_attribute(node, "name",
                               "duplicate property " + in_quotes(property.name) +
                                   ": already given at line " +
                                   std::to_string(report.xml().at(it->second).line));
        continue;
      }
      check_property_value(report, node, property);
      profile.properties.push_back(std::move(property));
    }
  }

  // A component reads its properties at configure time; a value that cannot be read as its
  // declared type would fail there, far from the profile, so it is checked here.
  static void check_property_value(const Reporter& report, pugi::xml_node node,
                                   const PropertySpec& property) {
    const std::string& type = property.type;
    bool ok = true;
    if (type == "int" || type == "long" || type == "short") {
      ok = parse_integer<std::int64_t>(property.value).has_value();
    } else if (type == "double" || type == "float") {
      // The XSD leaves property text free, so the usual C spellings (1e-3) are fine here.
      double value = 0.0;
      const char* first = property.value.data();
      const char* last = first + property.value.size();
      if (first != last && *first == '+') ++first;
      const auto [end, ec] = std::from_chars(first, last, value);
      ok = first != last && ec == std::errc{} && end == last && std::isfinite(value);
    } else if (type == "bool" || type == "boolean") {
      ok = lookup(kBooleans, property.value).has_value();
    }
    if (!ok) {
      report.error_text(node, "bad value " + in_quotes(property.value) + " for property " +
                                  in_quotes(property.name) + " of type " + in_quotes(type));
    }
  }

  void read_ports(const Reporter& report, pugi::xml_node element, LoadedComponent& component) {
    const Children children = scan(report, element, kPortsRules);
    std::map<std::string, pugi::xml_node, std::less<>> seen;
    for (const pugi::xml_node node : children.all("port")) {
      PortSpec port;
      port.where = report.xml().at(node);
      const std::string_view tag = node.name();
      port.kind = tag == "service_port" ? PortKind::service
                  : tag == "event_port" ? PortKind::event
                                        : PortKind::data;
      bool complete = false;
      const Children fields =
          scan(report, node, port.kind == PortKind::service ? rules_.service_port : rules_.data_port);
      const auto name = required_text(report, node, fields, "name", "name");
      if (name) port.name = *name;
      if (port.kind == PortKind::service) {
        complete = read_service_port(report, node, fields, port, component);
      } else {
        complete = read_data_port(report, node, fields, port, component);
      }
      if (!name) continue;
      port.name = *name;
      const auto [it, inserted] = seen.emplace(port.name, fields.one("name"));
      if (!inserted) {
        report.error_text(fields.one("name"), "duplicate port name " + in_quotes(port.name) +
                                                  ": already used at line " +
                                                  std::to_string(report.xml().at(it->second).line));
        continue;
      }
      if (!complete) component.incomplete_ports.insert(port.name);
      component.profile.ports.push_back(std::move(port));
    }
  }

  // Returns whether the port's kind and direction are known (so connections can be checked).
  bool read_data_port(const Reporter& report, pugi::xml_node node, const Children& fields,
                      PortSpec& port, LoadedComponent& component) {
    bool complete = true;
    if (const auto data_type = fields.one("data_type")) {
      port.data_type = text_of(data_type);
      if (port.data_type.empty()) {
        if (port.kind == PortKind::data) report.error(data_type, "empty <data_type>");
      } else {
        component.type_uses.push_back(
            {port.data_type, report.xml().at_text(data_type), element_path(data_type)});
      }
    } else if (port.kind == PortKind::data) {
      report.error(node, "missing <data_type>");
    }
    if (const auto usage = required_text(report, node, fields, "usage", "usage")) {
      const std::string context = " for " + port_noun(port);
      if (auto direction = enum_text(report, fields.one("usage"), kDataUsages, "usage", context)) {
        port.direction = *direction;
      } else {
        complete = false;
      }
    } else {
      complete = false;
    }

    read_model_port(report, fields, port, component);

    const pugi::xml_node policy = fields.one("policy");
    if (policy) {
      port.policy = enum_text(report, policy, kQueuePolicies, "queueing policy");
    }
    // The depth comes from <queue_size>, <queueing_size> or <policy_param name="size">.
    pugi::xml_node depth = fields.one("depth");
    for (const pugi::xml_node param : fields.all("policy_param")) {
      const std::string param_name(trim(param.attribute("name").value()));
      if (param_name != "size") {
        report.warning(param, "unknown policy_param " + in_quotes(param_name) + " (known: size)");
        continue;
      }
      if (depth) {
        report.error(param, "duplicate <policy_param name=\"size\">: depth already given at line " +
                                std::to_string(report.xml().at(depth).line));
        continue;
      }
      depth = param;
    }
    if (depth) {
      const std::string text = text_of(depth);
      port.depth = depth_value(text);
      if (!port.depth) {
        report.error_text(depth, "bad depth " + in_quotes(text) + ": " + kDepthExpected);
      }
    }
    if (complete && port.direction == PortDirection::output) {
      // The queue lives on the reading side. OPRoS editors write `data` on outputs too, which
      // is harmless; asking an output for a queue is a misunderstanding worth a warning.
      if (policy && port.policy && *port.policy != QueuePolicy::data) {
        report.warning(policy,
                       "a queueing policy on an output port is ignored (the input port "
                       "or the connection sets it)");
      }
      if (depth) {
        report.warning(depth,
                       "a queue size on an output port is ignored (the input port or "
                       "the connection sets it)");
      }
      port.policy.reset();
      port.depth.reset();
      return complete;
    }
    if (port.policy == QueuePolicy::data && port.depth) {
      // OPRoS writes "LAST with size 1" for the latest value; more than one is a contradiction.
      if (*port.depth != 1) {
        report.error_text(depth, "a depth of " + std::to_string(*port.depth) +
                                     " contradicts the data policy (latest value only); use "
                                     "buffer or circular for a queue");
      }
      port.depth.reset();
    }
    if (port.policy && port.policy != QueuePolicy::data && !port.depth) port.depth = kDefaultDepth;
    return complete;
  }

  bool read_service_port(const Reporter& report, pugi::xml_node node, const Children& fields,
                         PortSpec& port, LoadedComponent& component) {
    bool complete = true;
    read_model_port(report, fields, port, component);
    if (auto type = optional_text(fields, "type")) port.service_type = *type;
    if (const auto usage = required_text(report, node, fields, "usage", "usage")) {
      if (auto direction = enum_text(report, fields.one("usage"), kServiceUsages, "usage",
                                     " for a service port")) {
        port.direction = *direction;
      } else {
        complete = false;
      }
    } else {
      complete = false;
    }
    std::map<std::string, pugi::xml_node, std::less<>> seen;
    for (const pugi::xml_node element : fields.all("operation")) {
      OperationSpec operation;
      operation.where = report.xml().at(element);
      operation.name = std::string(trim(element.attribute("name").value()));
      operation.request_type = std::string(trim(element.attribute("request").value()));
      operation.reply_type = std::string(trim(element.attribute("reply").value()));
      if (const auto oneway = element.attribute("oneway")) {
        const std::string text(trim(oneway.value()));
        if (const auto value = lookup(kBooleans, text)) {
          operation.oneway = *value;
        } else {
          report.error_attribute(
              element, "oneway",
              "bad oneway " + in_quotes(text) + " (accepted: " + accepted(kBooleans) + ")");
        }
      }
      if (operation.oneway && !operation.reply_type.empty()) {
        report.error_attribute(element, "reply", "a oneway operation has no reply");
      }
      std::vector<TypeUse> model_uses;
      read_model_operation(report, element, port, operation, component, model_uses);
      for (const std::string_view attribute : {"request", "reply"}) {
        const std::string& type_name = attribute == "request" ? operation.request_type : operation.reply_type;
        if (type_name.empty()) continue;
        component.type_uses.push_back({type_name, report.xml().at_attribute(element, attribute),
                                       attribute_path(element, attribute)});
      }
      component.type_uses.insert(component.type_uses.end(), model_uses.begin(), model_uses.end());
      if (operation.name.empty()) {
        report.error(element, element.attribute("name") ? "empty attribute 'name'"
                                                        : "missing attribute 'name'");
        continue;
      }
      const auto [it, inserted] = seen.emplace(operation.name, element);
      if (!inserted) {
        report.error_attribute(element, "name",
                               "duplicate operation " + in_quotes(operation.name) +
                                   ": already given at line " +
                                   std::to_string(report.xml().at(it->second).line));
        continue;
      }
      port.operations.push_back(std::move(operation));
    }
    return complete;
  }

  // -- connections -----------------------------------------------------------------------

  struct ResolvedEnd {
    const Subcomponent* component = nullptr;
    const PortSpec* port = nullptr;
    bool checkable = false;  // port known with a known kind and direction
  };

  ResolvedEnd resolve(const Reporter& report, const ApplicationProfile& app, pugi::xml_node end,
                      const ConnectionEnd& spec) {
    ResolvedEnd resolved;
    if (!end || spec.component.empty()) return resolved;
    resolved.component = app.find_component(spec.component);
    // Reported at the end element, like every other problem of a connection end: the end is
    // the pair (component_name, port_name), and its path reads as `.../source`.
    if (resolved.component == nullptr) {
      report.error(end, "unknown component " + in_quotes(spec.component));
      return resolved;
    }
    const auto it = components_.find(resolved.component->reference);
    // Its profile could not be read: that is reported already, its ports are unknown.
    if (it == components_.end() || !it->second->readable || spec.port.empty()) return resolved;
    resolved.port = resolved.component->profile.find_port(spec.port);
    if (resolved.port == nullptr) {
      report.error(end, "component " + in_quotes(spec.component) + " has no port " +
                            in_quotes(spec.port));
      return resolved;
    }
    resolved.checkable = it->second->incomplete_ports.count(spec.port) == 0;
    return resolved;
  }

  // Checks that `end` is a `kind` port facing the right way; returns whether it is.
  bool check_end(const Reporter& report, pugi::xml_node connection, pugi::xml_node end,
                 const ConnectionSpec& spec, const ConnectionEnd& end_spec,
                 const ResolvedEnd& resolved, bool is_source) {
    if (!resolved.checkable) return false;
    const std::string name = end_spec.component + "." + end_spec.port;
    const PortSpec& port = *resolved.port;
    const std::string kind(to_string(spec.kind));
    if (port.kind != spec.kind) {
      std::string message = name + " is " + port_noun(port) + "; this is " +
                            (spec.kind == PortKind::event ? "an " : "a ") + kind + " connection";
      if (!connection.attribute("port_type")) {
        message += " (port_type is missing: OPRoS's default is a service connection)";
      }
      report.error(end, message);
      return false;
    }
    PortDirection wanted = PortDirection::input;
    if (spec.kind == PortKind::service) {
      wanted = is_source ? PortDirection::required : PortDirection::provided;
    } else if (is_source) {
      wanted = PortDirection::output;
    }
    if (port.direction != wanted) {
      report.error(end, name + " is " + direction_noun(port.direction) + "; " +
                            (spec.kind == PortKind::event ? "an " : "a ") + kind +
                            " connection's " + (is_source ? "source" : "target") + " must be " +
                            direction_noun(wanted));
      return false;
    }
    return true;
  }

  // Two type names match when they name the same registered type, however spelled
  // ("::a::T" and "a::T"); an empty name (no payload) matches only another empty one. A name
  // the registry does not know is reported at its port already, so it matches anything here.
  bool same_type(std::string_view a, std::string_view b) const {
    if (a.empty() || b.empty()) return a.empty() && b.empty();
    const Type* type_a = types_.find(a);
    const Type* type_b = types_.find(b);
    if (type_a == nullptr || type_b == nullptr) return true;
    return type_a == type_b;
  }

  static std::string signature(const OperationSpec& operation) {
    std::string text = "(" + operation.request_type + ")";
    if (operation.oneway) return text + " oneway";
    return text + " -> " + (operation.reply_type.empty() ? "()" : operation.reply_type);
  }

  void check_connections(const Reporter& report, ApplicationProfile& app,
                         const std::vector<pugi::xml_node>& nodes) {
    // Required service port ("A.p") -> the connection that uses it first (target, line).
    std::map<std::string, std::pair<std::string, std::uint32_t>, std::less<>> required_used;
    for (std::size_t i = 0; i < app.connections.size(); ++i) {
      ConnectionSpec& spec = app.connections[i];
      const pugi::xml_node node = nodes[i];
      const pugi::xml_node source_node = node.child("source");
      const pugi::xml_node target_node = node.child("target");
      const ResolvedEnd source = resolve(report, app, source_node, spec.source);
      const ResolvedEnd target = resolve(report, app, target_node, spec.target);
      const pugi::xml_attribute port_type = node.attribute("port_type");
      // With a bad port_type (reported already) kinds, directions and policies mean nothing.
      if (port_type && !lookup(kPortTypes, trim(port_type.value()))) continue;
      const bool source_ok = check_end(report, node, source_node, spec, spec.source, source, true);
      const bool target_ok = check_end(report, node, target_node, spec, spec.target, target, false);
      const std::string source_name = spec.source.component + "." + spec.source.port;
      const std::string target_name = spec.target.component + "." + spec.target.port;

      if (spec.kind == PortKind::service) {
        for (const std::string_view attribute : {"policy", "depth"}) {
          if (node.attribute(attribute.data())) {
            report.error_attribute(
                node, attribute,
                std::string(attribute) + " applies only to data and event connections");
          }
        }
        spec.policy.reset();
        spec.depth.reset();
        if (spec.mapping) {
          report.error(node.child("mapping"), "a mapping applies only to data and event connections");
          spec.mapping.reset();
        }
        if (source_ok) {
          const auto line = report.xml().at(node).line;
          const auto [it, inserted] =
              required_used.emplace(source_name, std::make_pair(target_name, line));
          if (!inserted) {
            report.error(source_node, "required port " + source_name + " is already connected to " +
                                          it->second.first + " (line " +
                                          std::to_string(it->second.second) + ")");
          }
        }
        if (source_ok && target_ok) {
          check_service_pair(report, node, spec, *source.port, *target.port);
        }
        continue;
      }

      // An event may carry no payload: types are mapped only when both ends name one (a
      // data port without <data_type> is reported already).
      if (source_ok && target_ok) {
        compile_mapping(report, node, spec, source.port->data_type, target.port->data_type, mapping_readable_[i]);
      }
      resolve_policy(report, node, spec, target_ok ? target.port : nullptr);
    }
  }

  // Leaves the connection with its effective policy and depth: the connection's own, else the
  // input port's, else the default: data (latest value) for data connections, circular for
  // events, which are notifications that a newer one must not silently replace. A queue
  // without a size gets the input port's size, else kDefaultDepth.
  static void resolve_policy(const Reporter& report, pugi::xml_node node, ConnectionSpec& spec,
                             const PortSpec* target) {
    if (node.attribute("policy") && !spec.policy) return;  // a bad policy, reported already
    const bool policy_given = spec.policy.has_value();
    const bool depth_given = spec.depth.has_value();
    if (!spec.policy) {
      if (target == nullptr) return;  // the input port is unknown (reported already)
      spec.policy = target->policy ? *target->policy
                                   : (spec.kind == PortKind::event ? QueuePolicy::circular
                                                                   : QueuePolicy::data);
    }
    if (*spec.policy == QueuePolicy::data) {
      if (depth_given) {
        report.error_attribute(node, "depth",
                               std::string("a depth needs a buffer or circular policy, but ") +
                                   (policy_given ? "this connection"
                                                 : "the input port " + spec.target.component + "." +
                                                       spec.target.port) +
                                   " uses the data policy (latest value only)");
      }
      spec.depth.reset();
      return;
    }
    if (!spec.depth) {
      spec.depth = target != nullptr && target->depth ? *target->depth : kDefaultDepth;
    }
  }

  void check_service_pair(const Reporter& report, pugi::xml_node node, const ConnectionSpec& spec,
                          const PortSpec& required, const PortSpec& provided) {
    const std::string source_name = spec.source.component + "." + spec.source.port;
    const std::string target_name = spec.target.component + "." + spec.target.port;
    if (!required.service_type.empty() && !provided.service_type.empty() &&
        required.service_type != provided.service_type) {
      report.error(node, "service interface mismatch: " + source_name + " is " +
                             in_quotes(required.service_type) + " but " + target_name + " is " +
                             in_quotes(provided.service_type));
      return;
    }
    // Profiles that list no operations (OPRoS keeps them in a separate service file) are
    // matched by interface name alone.
    if (required.operations.empty() || provided.operations.empty()) return;
    for (const auto& operation : required.operations) {
      const auto match = std::find_if(
          provided.operations.begin(), provided.operations.end(),
          [&](const OperationSpec& candidate) { return candidate.name == operation.name; });
      if (match == provided.operations.end()) {
        report.error(node, "operation " + in_quotes(operation.name) + " of " + source_name +
                               " is not provided by " + target_name);
        continue;
      }
      const bool same = operation.oneway == match->oneway &&
                        same_type(operation.request_type, match->request_type) &&
                        same_type(operation.reply_type, match->reply_type);
      if (!same) {
        report.error(node, "operation " + in_quotes(operation.name) + " mismatch: " + source_name +
                               " has " + signature(operation) + " but " + target_name + " has " +
                               signature(*match));
      }
    }
  }

  TypeRegistry& types_;
  const LoadOptions& options_;
  Diagnostics& diagnostics_;
  std::map<fs::path, std::unique_ptr<LoadedComponent>> components_;
  std::vector<const LoadedComponent*> load_order_;  // so diagnostics follow the profile
  std::vector<fs::path> pending_type_files_;
  std::vector<bool> mapping_readable_;  // per connection: its <mapping> read without errors
  const ModelRules rules_;
};

}  // namespace

const PortSpec* ComponentProfile::find_port(std::string_view port_name) const noexcept {
  for (const auto& port : ports) {
    if (port.name == port_name) return &port;
  }
  return nullptr;
}

const PropertySpec* ComponentProfile::find_property(std::string_view property_name) const noexcept {
  for (const auto& property : properties) {
    if (property.name == property_name) return &property;
  }
  return nullptr;
}

const Subcomponent* ApplicationProfile::find_component(
    std::string_view instance_name) const noexcept {
  for (const auto& component : components) {
    if (component.name == instance_name) return &component;
  }
  return nullptr;
}

std::optional<ApplicationProfile> load_application_profile(const std::filesystem::path& file,
                                                           TypeRegistry& types,
                                                           const LoadOptions& options,
                                                           Diagnostics& diagnostics) {
  Loader loader(types, options, diagnostics);
  return loader.run(file);
}

std::string_view to_string(PortKind kind) noexcept {
  switch (kind) {
    case PortKind::data: return "data";
    case PortKind::service: return "service";
    case PortKind::event: return "event";
  }
  return "unknown";
}

std::string_view to_string(PortDirection direction) noexcept {
  switch (direction) {
    case PortDirection::input: return "input";
    case PortDirection::output: return "output";
    case PortDirection::provided: return "provided";
    case PortDirection::required: return "required";
  }
  return "unknown";
}

std::string_view to_string(QueuePolicy policy) noexcept {
  switch (policy) {
    case QueuePolicy::data: return "data";
    case QueuePolicy::buffer: return "buffer";
    case QueuePolicy::circular: return "circular";
  }
  return "unknown";
}

std::string_view to_string(ExecutionType type) noexcept {
  switch (type) {
    case ExecutionType::periodic: return "periodic";
    case ExecutionType::periodic_exclusive: return "periodic-exclusive";
    case ExecutionType::aperiodic: return "aperiodic";
    case ExecutionType::passive: return "passive";
  }
  return "unknown";
}

}  // namespace polyport
