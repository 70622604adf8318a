// Run-time changes checked by the loader's own code (runtime_checks.hpp). A connection asked
// for at run time is written as the <port_connection> a profile would hold and goes through
// read_connections and check_connections, so the two can never disagree.

#include "polyport/profile/runtime_checks.hpp"

#include "loader.hpp"

namespace polyport {

std::string property_value_problem(const PropertySpec& property, std::string_view value) {
  const std::string& type = property.type;
  bool ok = true;
  if (type == "int" || type == "long" || type == "short") {
    ok = text::parse_integer<std::int64_t>(value).has_value();
  } else if (type == "double" || type == "float") {
    // The XSD leaves property text free, so the usual C spellings (1e-3) are fine here.
    double number = 0.0;
    const char* first = value.data();
    const char* last = first + value.size();
    if (first != last && *first == '+') ++first;
    const auto [end, ec] = std::from_chars(first, last, number);
    ok = first != last && ec == std::errc{} && end == last && std::isfinite(number);
  } else if (type == "bool" || type == "boolean") {
    ok = text::lookup(text::kBooleans, value).has_value();
  }
  if (ok) return {};
  return "bad value " + text::in_quotes(value) + " for property " + text::in_quotes(property.name) + " of type " +
         text::in_quotes(type);
}

std::optional<ConnectionSpec> check_connection(const ApplicationProfile& application, TypeRegistry& types,
                                               const ConnectionRequest& request, Diagnostics& diagnostics,
                                               const std::string& where) {
  // The kind a profile would give in port_type: the source port's, when it is known.
  PortKind kind = PortKind::data;
  const std::string source_path = application.member_path(request.source);
  const std::string_view source(source_path);
  if (const auto dot = source.find('.'); dot != std::string_view::npos) {
    if (const Subcomponent* component = application.find_component(source.substr(0, dot))) {
      if (const PortSpec* port = component->profile.find_port(source.substr(dot + 1))) kind = port->kind;
    }
  }
  // Built with pugixml, so names and values are escaped however they are spelled.
  pugi::xml_document document;
  pugi::xml_node connection = document.append_child("port_connections").append_child("port_connection");
  connection.append_attribute("port_type").set_value(std::string(to_string(kind)).c_str());
  if (!request.policy.empty()) connection.append_attribute("policy").set_value(request.policy.c_str());
  if (!request.depth.empty()) connection.append_attribute("depth").set_value(request.depth.c_str());
  for (const auto& [tag, path] : {std::pair{"source", &request.source}, std::pair{"target", &request.target}}) {
    pugi::xml_node end = connection.append_child(tag);
    const auto dot = path->find('.');
    end.append_attribute("component_name").set_value(path->substr(0, dot).c_str());
    end.append_attribute("port_name").set_value(dot == std::string::npos ? "" : path->substr(dot + 1).c_str());
  }
  std::ostringstream text;
  document.save(text, "", pugi::format_raw | pugi::format_no_declaration);

  detail::XmlFile xml;
  if (!xml.parse(where, text.str(), diagnostics)) return std::nullopt;
  LoadOptions options;  // nothing is read from files: the components are the application's
  detail::Loader loader(types, options, diagnostics);
  return loader.check_one(application, xml);
}

namespace detail {

std::optional<ConnectionSpec> Loader::check_one(const ApplicationProfile& application, XmlFile& xml) {
  const std::size_t errors_before = diagnostics_.error_count();
  // The components as the loader knew them once the profile was read: readable, every port
  // complete (a profile with an incomplete port does not load).
  ApplicationProfile one;
  one.file = application.file;
  one.name = application.name;
  one.components = application.components;
  one.composites = application.composites;
  for (const Subcomponent& component : one.components) {
    auto& loaded = components_[component.reference];
    if (loaded) continue;
    loaded = std::make_unique<LoadedComponent>();
    loaded->readable = true;
    loaded->profile = component.profile;
  }
  const Reporter report(xml);
  std::vector<pugi::xml_node> nodes;
  read_connections(report, xml.root(), one, nodes);
  resolve_promoted(report, one, one.connections, nodes);
  check_connections(report, one, nodes);
  if (diagnostics_.error_count() != errors_before || one.connections.size() != 1) return std::nullopt;
  return std::move(one.connections.front());
}

}  // namespace detail
}  // namespace polyport
