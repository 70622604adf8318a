// What an operator changes in a running application (polyportctl set / connect), checked by
// the same code that checks a profile: a property value against its declared type, a
// connection against the ports it joins, its policy, depth and types (the loader's
// check_connections, run on a one-element <port_connection> document). Control path only.
#pragma once

#include <optional>
#include <string>
#include <string_view>

#include "polyport/base/diagnostics.hpp"
#include "polyport/profile/profile.hpp"

namespace polyport {

class TypeRegistry;

// Empty when `value` reads as a property of `type` (as written in a component profile:
// int/long/short, double/float, bool/boolean, anything else free text); else the reason,
// worded as the loader reports a bad <property>.
std::string property_value_problem(const PropertySpec& property, std::string_view value);

// A connection asked for while the application runs. The ends are "Component.port"; policy
// and depth are as a <port_connection>'s attributes would spell them (empty: not given).
struct ConnectionRequest {
  std::string source;
  std::string target;
  std::string policy;
  std::string depth;
};

// Checks `request` exactly as the loader checks a <port_connection> in `application` (the
// running application's profile: its components and their ports): components and ports
// exist, kinds and directions fit, types match or map by name, the policy and depth are
// valid. The connection's kind is the source port's (data when that is unknown). Returns the
// connection with its effective policy, depth and compiled mapping, or nullopt with every
// problem in `diagnostics` (located in the one-line document named `where`).
std::optional<ConnectionSpec> check_connection(const ApplicationProfile& application, TypeRegistry& types,
                                               const ConnectionRequest& request, Diagnostics& diagnostics,
                                               const std::string& where = "run-time connection");

}  // namespace polyport
