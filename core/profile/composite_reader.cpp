// Composites (<composites><composite>): facades that promote chosen ports of the profile's
// components under a name of their own. A composite is resolved here, at load time: every
// connection end (and watchdog port) that names "Composite.name" is rewritten to the member's
// own port, so the engine, its statistics and a reload's diff only ever see real ports; the
// end keeps what was written (ConnectionEnd::promoted) for diagnostics and introspection.
// Composites do not nest: a member is always a component.

#include "loader.hpp"

namespace polyport::detail {

namespace {

std::string promoted_names(const CompositeSpec& composite) {
  std::string names;
  for (const PromotedPort& port : composite.ports) names += (names.empty() ? "" : ", ") + port.name;
  return names.empty() ? "none" : names;
}

}  // namespace

void Loader::read_composites(const Reporter& report, pugi::xml_node element, ApplicationProfile& app) {
  const Children children = scan(report, element, kCompositesRules);
  std::map<std::string, pugi::xml_node, std::less<>> seen;
  // Every composite's name, before any is read: a member may name one further down.
  std::set<std::string, std::less<>> composite_names;
  for (const pugi::xml_node node : children.all("composite")) composite_names.insert(text_of(node.child("name")));
  for (const pugi::xml_node node : children.all("composite")) {
    const Children fields = scan(report, node, kCompositeRules);
    CompositeSpec composite;
    composite.where = report.xml().at(node);
    composite.definition = element_text(node);
    const auto name = required_text(report, node, fields, "name", "name");
    bool usable = name.has_value();
    if (name) {
      composite.name = *name;
      const pugi::xml_node name_node = fields.one("name");
      if (const auto [it, inserted] = seen.emplace(*name, name_node); !inserted) {
        report.error_text(name_node, "duplicate composite name " + in_quotes(*name) + ": already used at line " +
                                         std::to_string(report.xml().at(it->second).line));
        usable = false;
      } else if (name->find('.') != std::string::npos) {
        report.error_text(name_node, "composite name " + in_quotes(*name) + " contains '.' (connections write Name.port)");
        usable = false;
      } else if (const Subcomponent* component = app.find_component(*name)) {
        // Connections name both the same way ("Name.port"), so one name cannot be both.
        report.error_text(name_node, "composite name " + in_quotes(*name) +
                                         " is already a subcomponent's (line " +
                                         std::to_string(component->where.line) + ")");
        usable = false;
      }
    }
    if (const auto description = optional_text(fields, "description")) composite.description = *description;
    const std::vector<pugi::xml_node>& promotes = fields.all("promote");
    if (promotes.empty()) report.error(node, "a composite promotes at least one port (<promote>)");
    std::map<std::string, pugi::xml_node, std::less<>> exported;
    for (const pugi::xml_node promote : promotes) {
      PromotedPort port;
      read_end(report, node, promote, "promote", port.member);
      port.where = report.xml().at(promote);
      port.name = port.member.port;
      if (const pugi::xml_attribute as = promote.attribute("as")) {
        port.name = std::string(trim(as.value()));
        if (port.name.empty()) report.error_attribute(promote, "as", "empty attribute 'as'");
      }
      if (port.name.empty() || port.member.component.empty()) continue;  // reported already
      if (port.name.find('.') != std::string::npos) {
        report.error(promote, "promoted name " + in_quotes(port.name) + " contains '.'");
        continue;
      }
      if (const auto [it, inserted] = exported.emplace(port.name, promote); !inserted) {
        report.error(promote, "duplicate promoted name " + in_quotes(port.name) + " in composite " +
                                  in_quotes(composite.name) + ": already promoted at line " +
                                  std::to_string(report.xml().at(it->second).line));
        continue;
      }
      if (!check_promoted(report, app, promote, composite.name, composite_names, port)) continue;
      if (std::find(composite.members.begin(), composite.members.end(), port.member.component) ==
          composite.members.end()) {
        composite.members.push_back(port.member.component);
      }
      composite.ports.push_back(std::move(port));
    }
    if (usable) app.composites.push_back(std::move(composite));
  }
}

bool Loader::check_promoted(const Reporter& report, const ApplicationProfile& app, pugi::xml_node promote,
                            const std::string& composite,
                            const std::set<std::string, std::less<>>& composite_names, const PromotedPort& port) {
  const std::string& member = port.member.component;
  // (A composite named like a subcomponent is refused already; its members are that one's.)
  if (member == composite && app.find_component(member) == nullptr) {
    report.error(promote, "composite " + in_quotes(composite) + " promotes a port of its own");
    return false;
  }
  const Subcomponent* component = app.find_component(member);
  if (component == nullptr) {
    if (composite_names.count(member) != 0) {
      report.error(promote, "composite " + in_quotes(composite) + " promotes a port of composite " +
                                in_quotes(member) + ": composites do not nest (promote the member component's port)");
    } else {
      report.error(promote, "unknown component " + in_quotes(member));
    }
    return false;
  }
  const auto it = components_.find(component->reference);
  // Its profile could not be read: reported already, its ports are unknown (kept, so that the
  // connections naming it report nothing more).
  if (it == components_.end() || !it->second->readable) return true;
  if (component->profile.find_port(port.member.port) == nullptr) {
    std::string ports;
    for (const PortSpec& p : component->profile.ports) ports += (ports.empty() ? "" : ", ") + p.name;
    report.error(promote, "component " + in_quotes(member) + " has no port " + in_quotes(port.member.port) +
                              " (ports: " + (ports.empty() ? "none" : ports) + ")");
    return false;
  }
  return true;
}

void Loader::resolve_promoted(const Reporter& report, const ApplicationProfile& app,
                              std::vector<ConnectionSpec>& connections, const std::vector<pugi::xml_node>& nodes) {
  if (app.composites.empty()) return;
  const auto resolve_end = [&](pugi::xml_node end, ConnectionEnd& spec) {
    const CompositeSpec* composite = app.find_composite(spec.component);
    if (!end || composite == nullptr || spec.port.empty()) return;
    const PromotedPort* promoted = composite->find_port(spec.port);
    if (promoted == nullptr) {
      report.error(end, "composite " + in_quotes(composite->name) + " promotes no port " + in_quotes(spec.port) +
                            " (it promotes: " + promoted_names(*composite) + ")");
      return;
    }
    spec.promoted = spec.component + "." + spec.port;
    spec.component = promoted->member.component;
    spec.port = promoted->member.port;
  };
  for (std::size_t i = 0; i < connections.size() && i < nodes.size(); ++i) {
    ConnectionSpec& spec = connections[i];
    resolve_end(nodes[i].child("source"), spec.source);
    resolve_end(nodes[i].child("target"), spec.target);
    if (!spec.watchdog) continue;
    const pugi::xml_node watchdog = nodes[i].child("watchdog");
    if (spec.watchdog->upstream) resolve_end(watchdog.child("upstream"), *spec.watchdog->upstream);
    if (spec.watchdog->event) resolve_end(watchdog.child("event"), *spec.watchdog->event);
  }
}

}  // namespace polyport::detail
