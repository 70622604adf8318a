// Reloading the profiles of a running daemon (SIGHUP, `polyportctl reload`; docs/CONTROL.md).
//
// The profiles are read again and validated completely, in a type registry of their own, so
// a broken profile is refused with every problem as file:line:col before anything changes.
// Types are read once per run: a type the new profiles declare differently from the running
// one is refused (the daemon must be restarted to change it). Then the new application is
// compared with the running one, element by element (Subcomponent::definition,
// ConnectionSpec::definition), and the difference is applied by Engine::apply, make before
// break; what did not change keeps running and loses no sample.
#pragma once

#include <functional>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "polyport/base/result.hpp"
#include "polyport/profile/profile.hpp"
#include "polyport/runtime/engine.hpp"

namespace polyport::daemon {

// What a reload changes, by name ("Component", "Source.port -> Target.port"), and the
// engine's change that does it (pointing into the new application profile).
struct GraphDiff {
  std::vector<std::string> components_added, components_removed, components_changed;
  std::vector<std::string> connections_added, connections_removed, connections_changed;
  // Composites by name. A composite is no node of the engine: what its change does to the
  // graph shows as the connections that name it, which resolve to other member ports.
  std::vector<std::string> composites_added, composites_removed, composites_changed;
  Engine::Change change;

  bool empty() const noexcept;
  bool graph_unchanged() const noexcept;  // nothing for the engine to do
  nlohmann::json to_json() const;
};

// The difference from `running` to `next`. A component is changed when its definition is;
// a connection when its definition is, or when a component it names (its ends, a watchdog's
// upstream or event port) is changed; service connections alike (a caller is bound anew).
Result<GraphDiff> diff(const ApplicationProfile& running, const ApplicationProfile& next);

// The first type `fresh` declares that `live` declares with another shape (fields, offsets,
// sizes, enumerators, fingerprint), as a message; nullopt when they agree.
std::optional<std::string> changed_type(const TypeRegistry& live, const TypeRegistry& fresh);

// Reads the application's profiles into `types`; problems go to `diagnostics`.
using ProfileReader = std::function<std::optional<ApplicationProfile>(TypeRegistry& types, Diagnostics& diagnostics)>;

// The whole reload: read and validate in a registry of its own, check the types, read again
// into the live registry, diff and apply. On success `application` is the new one and the
// result is the diff's JSON; on failure nothing changed and the error says why (every profile
// problem as file:line:col).
// Connections made at run time (`run_time`, "Component.port" pairs) that the new profiles
// also make are replaced by the profiles' own.
Result<nlohmann::json> reload(Engine& engine, TypeRegistry& types, ApplicationProfile& application,
                              const ProfileReader& read, const std::set<std::pair<std::string, std::string>>& run_time,
                              std::vector<std::string>& warnings);

}  // namespace polyport::daemon
