#include "control_requests.hpp"

#include "composites.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <charconv>
#include <cstdlib>

#include "polyport/profile/profile_text.hpp"
#include "polyport/profile/runtime_checks.hpp"
#include "polyport/runtime/component_api.hpp"
#include "polyport/runtime/connection.hpp"
#include "polyport/runtime/event_condition.hpp"
#include "polyport/runtime/port.hpp"
#include "polyport/types/types.hpp"

namespace polyport::daemon {
namespace {

std::string names_of_properties(const ComponentProfile& profile) {
  std::string names;
  for (const PropertySpec& p : profile.properties) names += (names.empty() ? "" : ", ") + p.name;
  return names.empty() ? "it has none" : "properties: " + names;
}

// The problems of a check, one sentence each, without the location in the one-line document
// the check was run on (the operator wrote a command line, not that document).
std::string problems_of(const Diagnostics& diagnostics) {
  std::string out;
  for (const Diagnostic& d : diagnostics.all()) {
    if (d.severity != Severity::error) continue;
    out += (out.empty() ? "" : "; ") + d.message;
  }
  return out;
}

nlohmann::json describe(const Connection& c, std::string_view origin) {
  nlohmann::json j{{"source", c.source().full_name()},
                   {"target", c.target().full_name()},
                   {"kind", to_string(c.source().kind())},
                   {"type", c.source().type() ? c.source().type()->name : std::string()},
                   {"policy", to_string(c.policy())},
                   {"mode", c.push_mode() ? "push" : "pull"},
                   {"conversion", c.conversion()},
                   {"origin", origin}};
  if (c.policy() != QueuePolicy::data) j["depth"] = c.depth();
  return j;
}

}  // namespace

nlohmann::json typed_value(const PropertySpec& property, const std::string& value) {
  const std::string& type = property.type;
  if (type == "int" || type == "long" || type == "short") {
    if (auto v = text::parse_integer<std::int64_t>(value)) return *v;
  } else if (type == "double" || type == "float") {
    char* end = nullptr;
    const double v = std::strtod(value.c_str(), &end);
    if (end != value.c_str() && *end == '\0') return v;
  } else if (type == "bool" || type == "boolean") {
    if (auto v = text::lookup(text::kBooleans, value)) return *v;
  }
  return value;
}

const Subcomponent* ControlRequests::component(const admin::Request& request, std::string& refusal) const {
  const Subcomponent* found = application_.find_component(request.component);
  if (found != nullptr && engine_.find_interceptor(request.component) != nullptr) return found;
  std::string names;
  for (const Subcomponent& c : application_.components) names += (names.empty() ? "" : ", ") + c.name;
  refusal = admin::error_reply(request.id, admin::kUnknownComponent,
                               "no component named '" + request.component + "' (components: " + names + ")");
  return nullptr;
}

std::string ControlRequests::get(const admin::Request& request) const {
  std::string refusal;
  const Subcomponent* sub = component(request, refusal);
  if (sub == nullptr) return refusal;
  const ComponentProfile& profile = sub->profile;
  if (!request.property.empty() && profile.find_property(request.property) == nullptr) {
    return admin::error_reply(request.id, admin::kUnknownProperty,
                              request.component + " has no property '" + request.property + "' (" +
                                  names_of_properties(profile) + ")");
  }
  const Interceptor* interceptor = engine_.find_interceptor(request.component);
  const auto* current = interceptor->properties();
  nlohmann::json properties = nlohmann::json::array();
  for (const PropertySpec& p : profile.properties) {
    if (!request.property.empty() && p.name != request.property) continue;
    std::string value = p.value;
    if (current != nullptr) {
      if (auto it = current->find(p.name); it != current->end()) value = it->second;
    }
    properties.push_back({{"name", p.name},
                          {"type", p.type.empty() ? "string" : p.type},
                          {"value", typed_value(p, value)},
                          {"profile_value", typed_value(p, p.value)}});
  }
  // Whether `set` can reach the component at all (each property may still be refused by it).
  const bool settable = current != nullptr && profile.execution.type != ExecutionType::passive;
  return admin::ok_reply(request.id, {{"component", request.component},
                                      {"model", profile.model},
                                      {"settable", settable},
                                      {"properties", std::move(properties)}});
}

std::string ControlRequests::set(const admin::Request& request) {
  std::string refusal;
  const Subcomponent* sub = component(request, refusal);
  if (sub == nullptr) return refusal;
  const PropertySpec* property = sub->profile.find_property(request.property);
  if (property == nullptr) {
    return admin::error_reply(request.id, admin::kUnknownProperty,
                              request.component + " has no property '" + request.property + "' (" +
                                  names_of_properties(sub->profile) + ")");
  }
  if (std::string problem = property_value_problem(*property, request.value); !problem.empty()) {
    return admin::error_reply(request.id, admin::kBadValue, problem);
  }
  Interceptor* interceptor = engine_.find_interceptor(request.component);
  std::string previous = property->value;
  if (const auto* current = interceptor->properties()) {
    if (auto it = current->find(property->name); it != current->end()) previous = it->second;
  }
  std::string why;
  const ReturnCode code = interceptor->set_property(property->name, request.value, why);
  const std::string what = request.component + "." + property->name + " = " + request.value;
  if (code == ReturnCode::unsupported) {
    return admin::error_reply(request.id, admin::kUnsupported,
                              "cannot set " + what + ": " + why + " (" + sub->profile.model + " component)");
  }
  if (code != ReturnCode::ok) {
    return admin::error_reply(request.id, admin::kRefused, "cannot set " + what + ": " + why);
  }
  spdlog::info("admin: set {} (was {})", what, previous);
  return admin::ok_reply(request.id, {{"component", request.component},
                                      {"property", property->name},
                                      {"type", property->type.empty() ? "string" : property->type},
                                      {"value", typed_value(*property, request.value)},
                                      {"previous", typed_value(*property, previous)}});
}

std::string ControlRequests::connect(const admin::Request& request) {
  ConnectionRequest wanted{request.source, request.target, request.policy,
                           request.depth ? std::to_string(*request.depth) : std::string()};
  Diagnostics diagnostics;
  const std::optional<ConnectionSpec> spec = check_connection(application_, types_, wanted, diagnostics);
  if (!spec) {
    return admin::error_reply(request.id, admin::kInvalidConnection,
                              request.source + " -> " + request.target + ": " + problems_of(diagnostics));
  }
  Result<Connection*> added = engine_.add_connection(*spec);
  if (!added) {
    return admin::error_reply(request.id, admin::kRefused,
                              request.source + " -> " + request.target + ": " + added.error().message);
  }
  // By the member ports' names: a composite's are only another way to write them.
  added_.emplace(spec->source.component + "." + spec->source.port, spec->target.component + "." + spec->target.port);
  const Connection* connection = added.value();
  if (connection == nullptr) {  // a service connection: the caller's binding, replaced whole
    spdlog::info("admin: connected {} -> {} (service)", request.source, request.target);
    return admin::ok_reply(request.id, {{"source", request.source},
                                        {"target", request.target},
                                        {"kind", "service"},
                                        {"origin", "run time"}});
  }
  spdlog::info("admin: connected {} ({}{}, {})", connection->name(), to_string(connection->policy()),
               connection->policy() != QueuePolicy::data ? "/" + std::to_string(connection->depth()) : "",
               connection->conversion());
  return admin::ok_reply(request.id, describe(*connection, "run time"));
}

std::string ControlRequests::disconnect(const admin::Request& request) {
  // A composite's port stands for its member's: the engine knows only the latter.
  const std::string source = application_.member_path(request.source);
  const std::string target = application_.member_path(request.target);
  nlohmann::json graph;
  engine_.describe(graph);
  bool known = false;  // data, event and service connections alike
  for (const auto& c : graph["connections"]) {
    known = known || (c.value("source", "") == source && c.value("target", "") == target);
  }
  const bool runtime = added_.count({source, target}) != 0;
  Result<void> removed = engine_.remove_connection(source, target);
  if (!removed) {
    return admin::error_reply(request.id, known ? admin::kRefused : admin::kUnknownConnection,
                              removed.error().message);
  }
  added_.erase({source, target});
  spdlog::info("admin: disconnected {} -> {}", source, target);
  nlohmann::json reply{{"source", source}, {"target", target}, {"origin", runtime ? "run time" : "profile"}};
  if (source != request.source) reply["source_promoted"] = request.source;
  if (target != request.target) reply["target_promoted"] = request.target;
  return admin::ok_reply(request.id, reply);
}

std::string ControlRequests::condition(const admin::Request& request) {
  const std::string path = application_.member_path(request.port);
  auto* port = dynamic_cast<DataInPort*>(engine_.find_port(path));
  // The event inputs that have a condition: what the error lists.
  auto conditioned = [&] {
    std::set<std::string> names;
    for (const auto& c : engine_.connections()) {
      if (c->condition() != nullptr) names.insert(c->target().full_name());
    }
    std::string out;
    for (const std::string& name : names) out += (out.empty() ? "" : ", ") + name;
    return out.empty() ? std::string("no connection has a condition") : "ports with conditions: " + out;
  };
  if (port == nullptr || port->kind() != PortKind::event) {
    return admin::error_reply(request.id, admin::kUnknownPort,
                              "no event input port '" + request.port + "' (" + conditioned() + ")");
  }
  const bool has_condition = std::any_of(port->connections().current().begin(), port->connections().current().end(),
                                         [](const Connection* c) { return c->condition() != nullptr; });
  if (!has_condition) {
    return admin::error_reply(request.id, admin::kRefused,
                              "no connection into " + request.port + " has a condition (" + conditioned() + ")");
  }
  const EventMode mode = request.mode == "single" ? EventMode::single : EventMode::continuous;
  std::vector<ConditionParameter> parameters;
  for (const auto& [name, value] : request.parameters) parameters.push_back({name, value});
  const Status status = request.active ? activate_conditions(*port, mode, parameters) : deactivate_conditions(*port);
  if (status == Status::not_connected) {
    return admin::error_reply(request.id, admin::kRefused,
                              "no connection into " + request.port + " has a condition (" + conditioned() + ")");
  }
  if (status != Status::ok) {
    std::string used;
    for (Connection* c : port->connections().current()) {
      if (const EventCondition* k = c->condition()) {
        for (const ConditionField& f : k->fields()) {
          if (!f.param.empty() && used.find("'" + f.param + "'") == std::string::npos) {
            used += (used.empty() ? "'" : ", '") + f.param + "'";
          }
        }
      }
    }
    return admin::error_reply(request.id, admin::kBadValue,
                              "a parameter names no field of " + request.port + "'s conditions (their parameters: " +
                                  (used.empty() ? "none" : used) + "); nothing changed");
  }
  nlohmann::json conditions = nlohmann::json::array();
  for (Connection* c : port->connections().current()) {
    const EventCondition* k = c->condition();
    if (k == nullptr) continue;
    nlohmann::json fields = nlohmann::json::array();
    const std::vector<double> thresholds = k->thresholds();
    for (std::size_t i = 0; i < k->fields().size(); ++i) {
      fields.push_back({{"field", k->fields()[i].path}, {"op", to_string(k->fields()[i].op)}, {"value", thresholds[i]}});
    }
    conditions.push_back({{"connection", c->name()}, {"fields", std::move(fields)}});
  }
  spdlog::info("admin: condition {} {}{}", request.port, request.active ? "activated, " : "deactivated",
               request.active ? std::string(to_string(mode)) : std::string());
  nlohmann::json reply{{"port", path}, {"active", request.active}, {"conditions", std::move(conditions)}};
  if (request.active) reply["mode"] = to_string(mode);
  if (path != request.port) reply["port_promoted"] = request.port;
  return admin::ok_reply(request.id, reply);
}

std::optional<std::string> ControlRequests::composite_command(const admin::Request& request,
                                                              LifecycleCommand command) {
  const CompositeSpec* composite = application_.find_composite(request.component);
  if (composite == nullptr) return std::nullopt;
  const std::vector<MemberOutcome> outcomes = command_members(engine_, *composite, command);
  nlohmann::json members = nlohmann::json::array();
  std::string refusal;
  std::string done;  // the members the command changed before one refused
  for (const MemberOutcome& m : outcomes) {
    members.push_back({{"component", m.component}, {"state", m.state}, {"outcome", m.outcome}});
    if (m.refused) refusal = m.component + ": " + m.outcome + " (state " + m.state + ")";
    if (m.outcome == "done") done += (done.empty() ? "" : ", ") + m.component;
  }
  if (!refusal.empty()) {
    return admin::error_reply(request.id, admin::kRefused,
                              std::string(to_string(command)) + " " + composite->name + ": member " + refusal +
                                  "; done before it: " + (done.empty() ? "none" : done));
  }
  spdlog::info("admin: {} composite {}: {} member(s)", to_string(command), composite->name, outcomes.size());
  return admin::ok_reply(request.id, {{"composite", composite->name}, {"members", std::move(members)}});
}

void ControlRequests::annotate(nlohmann::json& graph) const {
  describe_composites(application_, graph);
  for (auto& c : graph["connections"]) {
    const bool runtime = added_.count({c.value("source", ""), c.value("target", "")}) != 0;
    c["origin"] = runtime ? "run time" : "profile";
  }
}

Result<nlohmann::json> ControlRequests::reload(const ProfileReader& read, std::vector<std::string>& warnings) {
  Result<nlohmann::json> done = daemon::reload(engine_, types_, application_, read, added_, warnings);
  if (!done) return done;
  // Run-time connections a reload took away (a component of theirs left, or the profiles now
  // make them) are run-time connections no more.
  std::erase_if(added_, [&](const auto& ends) {
    return std::none_of(engine_.connections().begin(), engine_.connections().end(), [&](const auto& c) {
      return c->source().full_name() == ends.first && c->target().full_name() == ends.second;
    });
  });
  for (const ConnectionSpec& c : application_.connections) {
    added_.erase({c.source.component + "." + c.source.port, c.target.component + "." + c.target.port});
  }
  return done;
}

std::string ControlRequests::reload(const admin::Request& request, const ProfileReader& read) {
  std::vector<std::string> warnings;
  Result<nlohmann::json> done = reload(read, warnings);
  for (const std::string& warning : warnings) spdlog::warn("reload: {}", warning);
  if (!done) {
    spdlog::error("reload refused, the running graph is unchanged: {}", done.error().message);
    return admin::error_reply(request.id, admin::kRefused, done.error().message);
  }
  spdlog::info("reload: {}", done.value().dump());
  return admin::ok_reply(request.id, done.value());
}

}  // namespace polyport::daemon
