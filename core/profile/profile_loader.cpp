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

#include "loader.hpp"

#include <cctype>

namespace polyport::detail {

std::optional<ApplicationProfile> Loader::run(const fs::path& requested) {
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
  std::map<std::size_t, pugi::xml_node> own_semantics;
  if (const auto subcomponents = children.one("subcomponents")) {
    read_subcomponents(report, subcomponents, app, own_semantics);
  }
  std::vector<pugi::xml_node> connection_nodes;
  if (const auto connections = children.one("port_connections")) {
    read_connections(report, connections, app, connection_nodes);
  }

  load_type_files();
  for (const LoadedComponent* component : load_order_) check_types(*component);
  for (std::size_t i = 0; i < app.components.size(); ++i) {
    Subcomponent& subcomponent = app.components[i];
    const auto it = components_.find(subcomponent.reference);
    if (it != components_.end() && it->second->readable) {
      subcomponent.profile = it->second->profile;
      // The instance's own execution semantics: what it gives replaces the component profile's.
      if (const auto own = own_semantics.find(i); own != own_semantics.end()) {
        read_execution(report, own->second, subcomponent.profile, true);
      }
      subcomponent.definition += file_text(subcomponent.reference);
      for (const fs::path& type_file : subcomponent.profile.type_files) subcomponent.definition += file_text(type_file);
    }
  }
  if (const auto composites = children.one("composites")) read_composites(report, composites, app);
  resolve_promoted(report, app, app.connections, connection_nodes);
  check_connections(report, app, connection_nodes);

  if (diagnostics_.error_count() != errors_before) return std::nullopt;
  return app;
}

void Loader::read_type_files(const Reporter& report, pugi::xml_node types, std::vector<fs::path>& out) {
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
    std::string extension = file.extension().string();  // in any case, as add_type_file reads it
    for (char& c : extension) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    if (extension != ".idl" && extension != ".lcm" && extension != ".dbc") {
      report.error_text(element, "unsupported type file " + in_quotes(file.string()) +
                                     " (supported: .idl, .lcm, .dbc)");
      continue;
    }
    pending_type_files_.push_back(file);
  }
}

void Loader::load_type_files() {
  // Type files may name each other's types, so all are read before any name is checked.
  std::set<fs::path> loaded;
  for (const auto& file : pending_type_files_) {
    if (!loaded.insert(file).second) continue;
    types_.add_type_file(file, diagnostics_);
  }
}

void Loader::check_types(const LoadedComponent& component) {
  if (!component.readable) return;
  for (const auto& use : component.type_uses) {
    if (types_.find(use.name) != nullptr) continue;
    // A type its file declares but cannot provide (a DBC message with overlapping signals):
    // the file loaded with a warning; naming the type is the error, with the reason.
    if (const UnusableType* unusable = types_.find_unusable(use.name)) {
      const SourceLocation& at = unusable->where;
      diagnostics_.error(use.where, use.path,
                         "type " + in_quotes(use.name) + " cannot be used: " + at.file + ":" +
                             std::to_string(at.line) + ":" + std::to_string(at.column) + ": " +
                             unusable->reason);
    } else {
      diagnostics_.error(use.where, use.path, "unknown type " + in_quotes(use.name));
    }
  }
}

void Loader::read_subcomponents(const Reporter& report, pugi::xml_node element, ApplicationProfile& app,
                                std::map<std::size_t, pugi::xml_node>& own_semantics) {
  const Children children = scan(report, element, kSubcomponentsRules);
  const fs::path base = app.file.parent_path();
  std::map<std::string, pugi::xml_node, std::less<>> seen;
  for (const pugi::xml_node node : children.all("subcomponent")) {
    const Children fields = scan(report, node, kSubcomponentRules);
    Subcomponent subcomponent;
    subcomponent.where = report.xml().at(node);
    subcomponent.definition = element_text(node);
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
    if (usable) {
      if (const auto semantics = fields.one("execution_semantics")) own_semantics[app.components.size()] = semantics;
      app.components.push_back(std::move(subcomponent));
    }
  }
}

void Loader::read_connections(const Reporter& report, pugi::xml_node element, ApplicationProfile& app,
                      std::vector<pugi::xml_node>& nodes) {
  const Children children = scan(report, element, kConnectionsRules);
  for (const pugi::xml_node node : children.all("port_connection")) {
    ConnectionSpec connection;
    connection.where = report.xml().at(node);
    connection.definition = element_text(node);
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
    if (const auto watchdog = ends.one("watchdog")) connection.watchdog = read_watchdog(report, watchdog);
    read_rate_policies(report, ends, connection);
    if (const auto condition = ends.one("condition")) connection.condition = read_condition(report, condition);
    read_subscription(report, ends, connection);
    app.connections.push_back(std::move(connection));
    nodes.push_back(node);
    mapping_readable_.push_back(mapping_readable);
  }
}

void Loader::read_end(const Reporter& report, pugi::xml_node connection, pugi::xml_node end,
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

}  // namespace polyport::detail

namespace polyport {


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

const PromotedPort* CompositeSpec::find_port(std::string_view port_name) const noexcept {
  for (const auto& port : ports) {
    if (port.name == port_name) return &port;
  }
  return nullptr;
}

const CompositeSpec* ApplicationProfile::find_composite(std::string_view composite_name) const noexcept {
  for (const auto& composite : composites) {
    if (composite.name == composite_name) return &composite;
  }
  return nullptr;
}

std::string ApplicationProfile::member_path(std::string_view path) const {
  const auto dot = path.find('.');
  if (dot == std::string_view::npos) return std::string(path);
  const CompositeSpec* composite = find_composite(path.substr(0, dot));
  const PromotedPort* port = composite != nullptr ? composite->find_port(path.substr(dot + 1)) : nullptr;
  if (port == nullptr) return std::string(path);
  return port->member.component + "." + port->member.port;
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
  detail::Loader loader(types, options, diagnostics);
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
