// Application and component profiles: the OPRoS `application_profile` / `component_profile`
// XML shapes, extended with what polyport needs (model, policy, depth, type files). The
// loader reads them into these plain structs, reporting every problem as
// `file:line:col: element path: message`; nothing runs when any problem was found.
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "polyport/base/diagnostics.hpp"
#include "polyport/codecs/mapping.hpp"
#include "polyport/profile/condition_spec.hpp"

namespace polyport {

class TypeRegistry;
class ModelSettings;
class ModelSections;

enum class PortKind : std::uint8_t { data, service, event };
enum class PortDirection : std::uint8_t { input, output, provided, required };
enum class QueuePolicy : std::uint8_t { data, buffer, circular };
enum class ExecutionType : std::uint8_t { periodic, periodic_exclusive, aperiodic, passive };
enum class SchedPolicy : std::uint8_t { other, fifo, rr };
enum class InitialState : std::uint8_t { inactive, active };
enum class PushPattern : std::uint8_t { newest, timed };

struct OperationSpec {
  std::string name;
  std::string request_type;  // empty: no request payload
  std::string reply_type;    // empty: no reply payload
  bool oneway = false;       // `send`: no reply at all
  SourceLocation where;
};

// SmartSoft's push patterns on an output data port (<push pattern cycle_ms> in its
// <data_port>): `newest` keeps the latest sample for subscribers that come later; `timed`
// publishes once per base cycle, and each subscribing connection takes every Nth
// (<subscription every> in its <port_connection>).
struct PushSpec {
  PushPattern pattern = PushPattern::newest;
  double cycle_ms = 0.0;  // timed: the base cycle
  SourceLocation where;
};

struct PortSpec {
  std::string name;
  PortKind kind = PortKind::data;
  PortDirection direction = PortDirection::input;
  std::string data_type;               // data and event ports (event: may be empty)
  std::string service_type;            // service ports: the interface name both sides share
  std::vector<OperationSpec> operations;  // service ports
  std::optional<QueuePolicy> policy;   // input data/event ports: reading-side policy
  std::optional<std::uint32_t> depth;  // buffer/circular depth
  std::optional<PushSpec> push;        // output data ports: <push>
  SourceLocation where;
};

struct PropertySpec {
  std::string name;
  std::string type;   // as written ("double", "int", "string", "bool"); may be empty
  std::string value;
  SourceLocation where;
};

struct ExecutionSemantics {
  ExecutionType type = ExecutionType::periodic;
  double period_ms = 10.0;          // OPRoS: milliseconds
  int priority = 0;                 // SCHED_FIFO / SCHED_RR priority when policy asks for it
  SchedPolicy policy = SchedPolicy::other;
  std::optional<int> cpu;           // pin the execution context's thread to this CPU
  // polyport: the execution context sleeps until this long before each deadline, then spins
  // on the clock until the deadline (0: no spin tail). At most the period.
  std::int64_t spin_us = 0;
  // polyport: the cycles' place on a grid of the period counted from CLOCK_MONOTONIC's zero:
  // every cycle starts at k * period + phase (0 <= phase < period). None: the first cycle
  // runs when the context starts and the others follow it.
  std::optional<double> phase_ms;
  SourceLocation where;
};

struct ComponentProfile {
  std::filesystem::path file;       // absolute path of the component profile
  std::string name;                 // the component type's name
  std::string model = "inproc";     // which model runs it
  std::string library;              // inproc: the shared library as written
  std::filesystem::path library_path;  // inproc: resolved path (empty if not found)
  std::string class_name;           // inproc: component class in the library (default: name)
  ExecutionSemantics execution;
  // What the component's model read from its own elements (model_section.hpp); null when the
  // model reads none. Core never looks inside: the model's create_proxy does.
  std::shared_ptr<const ModelSettings> model_settings;
  InitialState initial_state = InitialState::active;  // OPRoS lifecycle_type start|stop
  std::vector<PropertySpec> properties;
  std::vector<PortSpec> ports;
  std::vector<std::filesystem::path> type_files;
  SourceLocation where;

  const PortSpec* find_port(std::string_view port_name) const noexcept;
  const PropertySpec* find_property(std::string_view property_name) const noexcept;
};

struct Subcomponent {
  std::string name;                 // instance name, used by port_connections
  std::filesystem::path reference;  // resolved path of the component profile
  ComponentProfile profile;
  SourceLocation where;
  // What the profiles say of this instance, for a reload to tell a changed one from one that
  // is the same: its <subcomponent> element, its component profile file and that file's type
  // files, as text.
  std::string definition;
};

struct ConnectionEnd {
  std::string component;
  std::string port;
  SourceLocation where;
  // "Composite.name" as the profile wrote it, when this end names a port a composite promotes;
  // `component` and `port` are then the member's own (the loader resolves them). Empty else.
  std::string promoted;
};

// A composite (<composite> in <composites>): a facade over components of the profile that
// promotes chosen ports of theirs (data, event and service) under its own name. It is no
// component of its own: a connection naming "Composite.name" is the member port's connection,
// and lifecycle commands sent to it go to its members.
struct PromotedPort {
  std::string name;  // the composite's name for it (<promote as>, else the port's own)
  ConnectionEnd member;
  SourceLocation where;
};

struct CompositeSpec {
  std::string name;
  std::string description;
  std::vector<PromotedPort> ports;
  // The components that own a promoted port, each once, in the order of their first <promote>.
  std::vector<std::string> members;
  SourceLocation where;
  // Its <composite> element as text, for a reload to tell a changed one.
  std::string definition;

  const PromotedPort* find_port(std::string_view port_name) const noexcept;
};

// A data connection's fail-safe (<watchdog> inside <port_connection>): while the source
// port (and the upstream port, if named) has written within the deadline, samples pass as
// usual; once either has been silent longer, or a sample's source stamp is older than
// max_age, the connection hands its target the safe value instead, counts it, and says so
// (watchdog.hpp in the runtime).
struct WatchdogSpec {
  std::int64_t deadline_ns = 0;
  std::int64_t max_age_ns = 0;          // 0: no bound on a sample's age
  std::optional<ConnectionEnd> upstream;  // an output data port whose silence also trips it
  // An input event or data port of type polyport::WatchdogEvent (config/types/
  // watchdog_event.idl) that is told of each trip and recovery.
  std::optional<ConnectionEnd> event;
  MappingSpec safe_value;               // constants only (by_name false): the rest is zero
  // Set by the loader: the safe value's program, from the target's type to itself (it reads
  // nothing of its source). Null when the target's type is unknown (reported already).
  std::shared_ptr<const MappingProgram> safe_program;
  SourceLocation where;
};

// One field of a data connection's deadband (<deadband><field name threshold/></deadband>): a
// sample passes only when a field of the source's type moved by more than its threshold since
// the last sample that passed (any one of the fields suffices).
struct DeadbandSpec {
  std::string field;  // path in the source port's type ("speed", "pose.x", "wheels[1]")
  double threshold = 0.0;
  SourceLocation where;
  std::string element_path;  // where in the profile, for diagnostics
};

struct ConnectionSpec {
  PortKind kind = PortKind::data;
  ConnectionEnd source;
  ConnectionEnd target;
  std::optional<QueuePolicy> policy;   // overrides the input port's policy
  std::optional<std::uint32_t> depth;
  std::optional<MappingSpec> mapping;  // <mapping> inside <port_connection>
  std::optional<WatchdogSpec> watchdog;  // <watchdog> inside <port_connection>
  // <rate_limit per_second>: at most this many samples per second reach the target; a sample
  // that comes sooner waits for its turn and is replaced by a newer one (newest wins).
  std::optional<double> rate_limit_per_second;
  // <poll period_ms>: the target gets, every period, the newest sample that came since the
  // last tick (none when none came); at least twice the rate of an in-process periodic source.
  std::optional<double> poll_period_ms;
  std::vector<DeadbandSpec> deadbands;  // the <field>s of <deadband> inside <port_connection>
  std::optional<ConditionSpec> condition;  // <condition> of an event connection
  // <subscription every>: a subscriber of a push timed port takes every Nth of its cycles.
  std::optional<std::uint32_t> subscription_every;
  // Set by the loader when the two ends' types differ: the compiled mapping (the spec's, or
  // by name when there is none). Null when the types are the same.
  std::shared_ptr<const MappingProgram> program;
  SourceLocation where;
  // Its <port_connection> element as text (attributes and children, whitespace aside): what a
  // reload compares.
  std::string definition;
};

struct ApplicationProfile {
  std::filesystem::path file;
  std::string name;
  std::string description;
  std::vector<std::filesystem::path> type_files;
  std::vector<Subcomponent> components;
  std::vector<ConnectionSpec> connections;
  std::vector<CompositeSpec> composites;

  const Subcomponent* find_component(std::string_view instance_name) const noexcept;
  const CompositeSpec* find_composite(std::string_view composite_name) const noexcept;
  // "Component.port" for a "Composite.name" that a composite promotes; `path` as it is
  // otherwise (a component's own port, or a name nothing promotes).
  std::string member_path(std::string_view path) const;
};

struct LoadOptions {
  // Where component libraries are looked for, after the component profile's own folder.
  std::vector<std::filesystem::path> library_path;
  // The models whose own elements the loader hands over (the daemon's model registry). Null:
  // no model reads any, and their elements warn as unknown.
  const ModelSections* models = nullptr;
};

// Reads an application profile, every component profile it references and every type file
// they name (into `types`), then checks the graph: components, ports, kinds, directions and
// types across each connection, periods, files. Returns the profile when there was no error.
std::optional<ApplicationProfile> load_application_profile(const std::filesystem::path& file,
                                                           TypeRegistry& types,
                                                           const LoadOptions& options,
                                                           Diagnostics& diagnostics);

std::string_view to_string(PortKind kind) noexcept;
std::string_view to_string(PortDirection direction) noexcept;
std::string_view to_string(QueuePolicy policy) noexcept;
std::string_view to_string(ExecutionType type) noexcept;
std::string_view to_string(PushPattern pattern) noexcept;

}  // namespace polyport
