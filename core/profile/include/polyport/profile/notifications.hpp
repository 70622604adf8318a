// <notifications port=".." auto=".." kind=".."/> of an in-process component's profile: its
// busy / idle / refresh notifications (polyport::ComponentNotification) on an output port the
// engine adds (docs/PROFILES.md, "Notifications"). The loader puts the port among the
// component's ports, so connections and `polyportd check` treat it as any other; what only
// the in-process model uses (the port to bind, auto) travels as the component's model
// settings, which the in-process model otherwise has none of.
#pragma once

#include <string>

#include "polyport/profile/model_section.hpp"
#include "polyport/profile/profile.hpp"

namespace polyport {

class NotificationSettings final : public ModelSettings {
 public:
  std::string port = "notifications";
  bool automatic = false;  // the execution context raises busy / idle around each onExecute
  // event (default) or data: a data port, for a connection to a topic of a model without
  // event ports (DDS) or to a data port.
  PortKind kind = PortKind::event;
  SourceLocation where;
};

}  // namespace polyport
