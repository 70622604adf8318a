// Composites in the daemon's views of the graph (`polyportd check`, `polyportctl list`) and
// lifecycle commands sent to a composite. A composite is resolved by the profile loader
// (profile.hpp: CompositeSpec): the engine has no node of its own for it, its connections are
// its members' ports' connections and so are their statistics, counted per real port.
// Control thread only.
#pragma once

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "polyport/profile/profile.hpp"
#include "polyport/runtime/component_api.hpp"
#include "polyport/runtime/engine.hpp"
#include "polyport/runtime/lifecycle.hpp"

namespace polyport::daemon {

// Adds `composites` to a graph of Engine::describe: each composite with its members and, for
// every promoted name, the member port it stands for and that port's kind, direction and
// type (read from the graph's components). A connection the profiles wrote with a
// composite's name gets "source_promoted" / "target_promoted": the name as written.
void describe_composites(const ApplicationProfile& application, nlohmann::json& graph);

// One member's part in a lifecycle command sent to a composite.
struct MemberOutcome {
  std::string component;
  std::string state;     // after the command
  std::string outcome;   // "done", "already <state>" (left as it was), or the refusal's code
  bool refused = false;
};

// Applies `command` to every member of `composite`: activate in the order the members were
// first promoted, deactivate in the reverse order, reset in promote order. A member already in
// the state the command leads to is left alone (a facade activated twice is not an error), and
// reset goes only to members in the error state; the first refusal stops the walk, and the
// members done before it stay done.
std::vector<MemberOutcome> command_members(Engine& engine, const CompositeSpec& composite, LifecycleCommand command);

}  // namespace polyport::daemon
