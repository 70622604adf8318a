// Connections against the ports they join: components and ports exist, kinds and directions
// fit, types match or map, service operations agree, and each connection's effective policy.

#include "loader.hpp"

namespace polyport::detail {

Loader::ResolvedEnd Loader::resolve(const Reporter& report, const ApplicationProfile& app, pugi::xml_node end,
                    const ConnectionEnd& spec) {
  ResolvedEnd resolved;
  if (!end || spec.component.empty()) return resolved;
  resolved.component = app.find_component(spec.component);
  // Reported at the end element, like every other problem of a connection end: the end is
  // the pair (component_name, port_name), and its path reads as `.../source`.
  if (resolved.component == nullptr) {
    // A composite's name that promotes no such port: reported by resolve_promoted.
    if (app.find_composite(spec.component) != nullptr) return resolved;
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
bool Loader::check_end(const Reporter& report, pugi::xml_node connection, pugi::xml_node end,
               const ConnectionSpec& spec, const ConnectionEnd& end_spec,
               const ResolvedEnd& resolved, bool is_source) {
  if (!resolved.checkable) return false;
  std::string name = end_spec.component + "." + end_spec.port;
  if (!end_spec.promoted.empty()) name = end_spec.promoted + " (" + name + ")";
  const PortSpec& port = *resolved.port;
  const std::string kind(to_string(spec.kind));
  // An event with a condition tests the server's state, which a model without event ports
  // (DDS) publishes on a data port.
  const bool state_source = is_source && spec.kind == PortKind::event && port.kind == PortKind::data &&
                            connection.child("condition");
  if (port.kind != spec.kind && !state_source) {
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
bool Loader::same_type(std::string_view a, std::string_view b) const {
  if (a.empty() || b.empty()) return a.empty() && b.empty();
  const Type* type_a = types_.find(a);
  const Type* type_b = types_.find(b);
  if (type_a == nullptr || type_b == nullptr) return true;
  return type_a == type_b;
}

std::string Loader::signature(const OperationSpec& operation) {
  std::string text = "(" + operation.request_type + ")";
  if (operation.oneway) return text + " oneway";
  return text + " -> " + (operation.reply_type.empty() ? "()" : operation.reply_type);
}

void Loader::check_connections(const Reporter& report, ApplicationProfile& app,
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
    check_watchdog(report, app, node, spec, target_ok ? target.port : nullptr);
    check_rate_policies(report, node, spec, source_ok ? source.port : nullptr, source.component);
    check_condition(report, node, spec, source_ok ? source.port : nullptr);
    check_subscription(report, node, spec, source_ok ? source.port : nullptr);

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
void Loader::resolve_policy(const Reporter& report, pugi::xml_node node, ConnectionSpec& spec,
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

void Loader::check_service_pair(const Reporter& report, pugi::xml_node node, const ConnectionSpec& spec,
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

}  // namespace polyport::detail
