#include "composites.hpp"

#include <algorithm>

namespace polyport::daemon {
namespace {

// The graph's entry of a member port (a pointer into `graph`); null when it lists none.
const nlohmann::json* port_of(const nlohmann::json& graph, const ConnectionEnd& end) {
  const auto components = graph.find("components");
  if (components == graph.end()) return nullptr;
  for (const auto& c : *components) {
    const auto ports = c.find("ports");
    if (c.value("name", "") != end.component || ports == c.end()) continue;
    for (const auto& p : *ports) {
      if (p.value("name", "") == end.port) return &p;
    }
  }
  return nullptr;
}

std::string path_of(const ConnectionEnd& end) { return end.component + "." + end.port; }

}  // namespace

void describe_composites(const ApplicationProfile& application, nlohmann::json& graph) {
  nlohmann::json composites = nlohmann::json::array();
  for (const CompositeSpec& composite : application.composites) {
    nlohmann::json ports = nlohmann::json::array();
    for (const PromotedPort& promoted : composite.ports) {
      nlohmann::json p{{"name", promoted.name}, {"member", path_of(promoted.member)}};
      if (const nlohmann::json* port = port_of(graph, promoted.member)) {
        for (const char* key : {"kind", "direction", "type", "service_type"}) {
          if (port->contains(key)) p[key] = (*port)[key];
        }
      }
      ports.push_back(std::move(p));
    }
    nlohmann::json c{{"name", composite.name}, {"members", composite.members}, {"ports", std::move(ports)}};
    if (!composite.description.empty()) c["description"] = composite.description;
    composites.push_back(std::move(c));
  }
  graph["composites"] = std::move(composites);
  if (!graph.contains("connections")) return;
  for (const ConnectionSpec& spec : application.connections) {
    if (spec.source.promoted.empty() && spec.target.promoted.empty()) continue;
    for (auto& c : graph["connections"]) {
      if (c.value("source", "") != path_of(spec.source) || c.value("target", "") != path_of(spec.target)) continue;
      if (!spec.source.promoted.empty()) c["source_promoted"] = spec.source.promoted;
      if (!spec.target.promoted.empty()) c["target_promoted"] = spec.target.promoted;
    }
  }
}

std::vector<MemberOutcome> command_members(Engine& engine, const CompositeSpec& composite, LifecycleCommand command) {
  std::vector<std::string> order = composite.members;
  // Stopping goes the other way round, as Engine::stop does: the later members first.
  if (command == LifecycleCommand::deactivate) std::reverse(order.begin(), order.end());
  std::string_view leads_to;
  if (command == LifecycleCommand::activate) leads_to = to_string(LifecycleState::active);
  if (command == LifecycleCommand::deactivate || command == LifecycleCommand::reset) {
    leads_to = to_string(LifecycleState::inactive);
  }
  std::vector<MemberOutcome> out;
  for (const std::string& member : order) {
    MemberOutcome outcome{member, {}, {}, false};
    Interceptor* interceptor = engine.find_interceptor(member);
    if (interceptor == nullptr) {  // a reload took it away and the composite with it; never here
      outcome.outcome = "no such component";
      outcome.refused = true;
      out.push_back(std::move(outcome));
      break;
    }
    const std::string before = interceptor->status().state;
    if (!leads_to.empty() && before == leads_to) {
      outcome.state = before;
      outcome.outcome = "already " + before;
      out.push_back(std::move(outcome));
      continue;
    }
    // Reset is the way out of the error state; a member that is not there needs none.
    if (command == LifecycleCommand::reset && before != to_string(LifecycleState::error)) {
      outcome.state = before;
      outcome.outcome = "not in error";
      out.push_back(std::move(outcome));
      continue;
    }
    const ReturnCode code = interceptor->command(command);
    outcome.state = interceptor->status().state;
    outcome.refused = code != ReturnCode::ok;
    outcome.outcome = outcome.refused ? std::string(to_string(code)) : "done";
    const bool refused = outcome.refused;
    out.push_back(std::move(outcome));
    if (refused) break;
  }
  return out;
}

}  // namespace polyport::daemon
