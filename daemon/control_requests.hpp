// The admin requests that change a running application: get / set of component properties
// and connect / disconnect of ports (docs/CONTROL.md). Each runs on the engine's control
// thread (polyportd's main thread, through AdminServer::serve), checks what it is asked
// against the loaded profile with the loader's own checks (runtime_checks.hpp), and only then
// touches the engine. The forwarding path is never called from here and takes no lock of
// ours: a property change is handed to the component's execution context, a connection is
// published by swapping the ports' connection lists.
#pragma once

#include <optional>
#include <set>
#include <string>
#include <utility>

#include <nlohmann/json.hpp>

#include "admin_protocol.hpp"
#include "reload.hpp"
#include "polyport/profile/profile.hpp"
#include "polyport/runtime/engine.hpp"
#include "polyport/runtime/lifecycle.hpp"

namespace polyport::daemon {

class ControlRequests {
 public:
  // `application`: every loaded profile's components and connections, as the engine was
  // built from them.
  ControlRequests(Engine& engine, TypeRegistry& types, ApplicationProfile application)
      : engine_(engine), types_(types), application_(std::move(application)) {}

  // Reply lines (admin::ok_reply / admin::error_reply).
  std::string get(const admin::Request& request) const;
  std::string set(const admin::Request& request);
  std::string connect(const admin::Request& request);
  std::string disconnect(const admin::Request& request);
  // Activates or deactivates the conditions on the event connections into a client's event
  // input (`request.port`), whatever model the client is in: what an in-process client does
  // with EventInPort::activate, for clients that cannot (LCM and CAN programs).
  std::string condition(const admin::Request& request);
  // Re-reads the profiles and applies what changed (reload.hpp), for SIGHUP and `reload`. The
  // diff as JSON, or why the running graph was kept.
  Result<nlohmann::json> reload(const ProfileReader& read, std::vector<std::string>& warnings);
  std::string reload(const admin::Request& request, const ProfileReader& read);
  // Marks each connection of `list`'s graph with its origin: "profile" or "run time", and adds
  // the composites (composites.hpp).
  void annotate(nlohmann::json& graph) const;
  // activate / deactivate / reset sent to a composite: applied to its members
  // (composites.hpp: command_members). Nullopt when `request.component` names no composite.
  std::optional<std::string> composite_command(const admin::Request& request, LifecycleCommand command);
  // "Component.port" for a composite's "Composite.name"; `path` itself otherwise.
  std::string member_path(const std::string& path) const { return application_.member_path(path); }

 private:
  // The component named by the request, or an unknown_component reply in `refusal`.
  const Subcomponent* component(const admin::Request& request, std::string& refusal) const;

  Engine& engine_;
  TypeRegistry& types_;
  ApplicationProfile application_;
  std::set<std::pair<std::string, std::string>> added_;  // run-time connections (source, target)
};

// A property's value as JSON of its declared type (number, integer, boolean; else string).
nlohmann::json typed_value(const PropertySpec& property, const std::string& value);

}  // namespace polyport::daemon
