// The profile loader's parts, shared by the files that implement it:
//   profile_loader.cpp     application profiles, type files, the public entry points
//   component_reader.cpp   component profiles: execution, properties, ports
//   model_elements.cpp     the models' own elements, handed to their sections
//   mapping_reader.cpp     <mapping> rules and their compilation
//   connection_checks.cpp  connections against the ports they join
//   condition_reader.cpp   an event connection's <condition>
// Private to core/profile.
#pragma once

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <sstream>
#include <string>
#include <string_view>
#include <utility>
#include <vector>
#include <pugixml.hpp>
#include "polyport/base/diagnostics.hpp"
#include "polyport/profile/model_section.hpp"
#include "polyport/profile/profile.hpp"
#include "polyport/profile/profile_element.hpp"
#include "polyport/profile/profile_text.hpp"
#include "polyport/types/types.hpp"
#include "xml_file.hpp"

namespace polyport::detail {

namespace fs = std::filesystem;

// A buffer or circular queue without an explicit size gets this many samples: enough to ride
// out a few missed periods of a 10 ms reader without hiding a reader that has stopped.
constexpr std::uint32_t kDefaultDepth = 16;
// CPU_SETSIZE on Linux; a profile may be checked on another machine than the one it runs on,
// so the real CPU count is checked when the execution context pins its thread, not here.
constexpr int kMaxCpu = 1023;
constexpr int kMinRtPriority = 1;
constexpr int kMaxRtPriority = 99;

using namespace text;

// Case-sensitive on purpose: the XSD's enumerations are, and both must accept the same files.
constexpr Spelling<QueuePolicy> kQueuePolicies[] = {
    {"data", QueuePolicy::data},           {"LAST", QueuePolicy::data},
    {"OPROS_LAST", QueuePolicy::data},     {"buffer", QueuePolicy::buffer},
    {"circular", QueuePolicy::circular},   {"FIFO", QueuePolicy::circular},
    {"OPROS_FIFO", QueuePolicy::circular},
};
constexpr Spelling<ExecutionType> kExecutionTypes[] = {
    {"periodic", ExecutionType::periodic},
    {"periodic-shared", ExecutionType::periodic},
    {"periodic-exclusive", ExecutionType::periodic_exclusive},
    {"aperiodic", ExecutionType::aperiodic},
    {"non-periodic", ExecutionType::aperiodic},
    {"passive", ExecutionType::passive},
};
constexpr Spelling<SchedPolicy> kSchedPolicies[] = {
    {"SCHED_OTHER", SchedPolicy::other}, {"SCHED_FIFO", SchedPolicy::fifo},
    {"SCHED_RR", SchedPolicy::rr},       {"OTHER", SchedPolicy::other},
    {"FIFO", SchedPolicy::fifo},         {"RR", SchedPolicy::rr},
};
constexpr Spelling<InitialState> kLifecycleTypes[] = {
    {"start", InitialState::active},      {"stop", InitialState::inactive},
    {"active", InitialState::active},     {"running", InitialState::active},
    {"ACTIVE", InitialState::active},     {"inactive", InitialState::inactive},
    {"stopped", InitialState::inactive},  {"READY", InitialState::inactive},
    {"INACTIVE", InitialState::inactive},
};
constexpr Spelling<PortKind> kPortTypes[] = {
    {"data", PortKind::data},
    {"service", PortKind::service},
    {"event", PortKind::event},
    {"method", PortKind::service},  // OPRoS's name for service connections
};
constexpr Spelling<PortDirection> kDataUsages[] = {
    {"input", PortDirection::input},
    {"output", PortDirection::output},
};
constexpr Spelling<PortDirection> kServiceUsages[] = {
    {"required", PortDirection::required},
    {"provided", PortDirection::provided},
};

inline std::string_view sched_policy_name(SchedPolicy policy) {
  switch (policy) {
    case SchedPolicy::fifo: return "SCHED_FIFO";
    case SchedPolicy::rr: return "SCHED_RR";
    case SchedPolicy::other: break;
  }
  return "SCHED_OTHER";
}

inline bool is_periodic(ExecutionType type) {
  return type == ExecutionType::periodic || type == ExecutionType::periodic_exclusive;
}

inline std::string port_noun(const PortSpec& port) {
  return std::string(port.kind == PortKind::event ? "an " : "a ") +
         std::string(to_string(port.kind)) + " port";
}

inline std::string direction_noun(PortDirection direction) {
  const bool vowel = direction == PortDirection::input || direction == PortDirection::output;
  return std::string(vowel ? "an " : "a ") + std::string(to_string(direction)) + " port";
}


inline std::optional<std::uint32_t> depth_value(std::string_view text) {
  const auto value = parse_integer<std::uint32_t>(text);
  if (!value || *value == 0) return std::nullopt;
  return value;
}

const std::string kDepthExpected = "expected an integer from 1 to 4294967295";

// ---------------------------------------------------------------------------------------
// Child tables, one per element kind.

const std::vector<ChildRule> kApplicationRules = {
    {"name", {"name"}},
    {"description", {"description"}},
    {"", {"id", "copyright"}},
    {"types", {"types"}},
    {"subcomponents", {"subcomponents"}},
    {"port_connections", {"port_connections"}},
    {"composites", {"composites"}},
};
const std::vector<ChildRule> kTypesRules = {{"file", {"file"}, true}};
const std::vector<ChildRule> kSubcomponentsRules = {{"subcomponent", {"subcomponent"}, true}};
const std::vector<ChildRule> kSubcomponentRules = {
    {"name", {"name"}},
    {"reference", {"reference"}},
    {"execution_semantics", {"execution_semantics"}},
    {"", {"id", "type", "node_id"}},
};
const std::vector<ChildRule> kCompositesRules = {{"composite", {"composite"}, true}};
const std::vector<ChildRule> kCompositeRules = {
    {"name", {"name"}},
    {"description", {"description"}},
    {"promote", {"promote"}, true, {"component_name", "port_name", "as"}},
};
const std::vector<ChildRule> kConnectionsRules = {
    {"port_connection", {"port_connection"}, true, {"port_type", "policy", "depth"}},
};
const std::vector<ChildRule> kConnectionRules = {
    {"source", {"source"}, false, {"component_name", "port_name"}},
    {"target", {"target"}, false, {"component_name", "port_name"}},
    {"mapping", {"mapping"}, false, {"by_name"}},
    {"watchdog", {"watchdog"}, false, {"deadline_ms", "max_age_ms"}},
    {"rate_limit", {"rate_limit"}, false, {"per_second"}},
    {"poll", {"poll"}, false, {"period_ms"}},
    {"deadband", {"deadband"}, false, {}},
    {"condition", {"condition"}, false, {"mode", "active"}},
    {"subscription", {"subscription"}, false, {"every"}},
};
const std::vector<ChildRule> kConditionRules = {
    {"field", {"field"}, true, {"name", "op", "value", "param"}},
};
const std::vector<ChildRule> kDeadbandRules = {
    {"field", {"field"}, true, {"name", "threshold"}},
};
const std::vector<ChildRule> kWatchdogRules = {
    {"upstream", {"upstream"}, false, {"component_name", "port_name"}},
    {"event", {"event"}, false, {"component_name", "port_name"}},
    {"safe_value", {"safe_value"}, false, {}},
};
const std::vector<ChildRule> kMappingRules = {
    {"field",
     {"field"},
     true,
     {"target", "source", "value", "scale", "offset", "from_unit", "to_unit", "allow_narrowing", "truncate",
      "transform", "matrix", "translation"}},
};
constexpr Spelling<MappingRule::Kind> kTransforms[] = {
    {"linear", MappingRule::Kind::linear},
    {"affine", MappingRule::Kind::affine},
};
// A matrix has at most this many rows and columns: vector fields have 1 to 6 elements.
constexpr std::size_t kMaxMatrixSide = 6;
const std::vector<ChildRule> kComponentRules = {
    {"name", {"name"}},
    {"description", {"description"}},
    {"", {"id", "copyright"}},
    {"model", {"model"}},
    {"execution_environment", {"execution_environment"}},
    {"execution_semantics", {"execution_semantics"}},
    {"types", {"types"}},
    {"properties", {"properties"}},
    {"ports", {"ports"}},
    {"notifications", {"notifications"}, false, {"port", "auto", "kind"}},
};
const std::vector<ChildRule> kEnvironmentRules = {
    {"library_type", {"library_type"}},
    {"library_name", {"library_name"}},
    {"class_name", {"class_name"}},
    {"", {"os", "cpu", "impl_language", "compiler"}},
};
const std::vector<ChildRule> kSemanticsRules = {
    {"type", {"type"}},
    {"period", {"period"}},
    {"priority", {"priority"}},
    {"policy", {"policy"}},
    {"cpu", {"cpu_affinity", "cpu"}},
    {"spin_us", {"spin_us"}},
    {"phase", {"phase"}},
    {"lifecycle_type", {"lifecycle_type"}},
    {"", {"creation_type", "instance_creation"}},
};
const std::vector<ChildRule> kPropertiesRules = {
    {"property", {"property"}, true, {"name", "type"}},
};
const std::vector<ChildRule> kPortsRules = {
    {"port", {"data_port", "event_port", "service_port"}, true},
};
const std::vector<ChildRule> kDataPortRules = {
    {"name", {"name"}},
    {"", {"description"}},
    {"data_type", {"data_type"}},
    {"usage", {"usage"}},
    {"policy", {"queueing_policy", "policy"}},
    {"depth", {"queue_size", "queueing_size"}},
    {"policy_param", {"policy_param"}, true, {"name"}},
    {"push", {"push"}, false, {"pattern", "cycle_ms"}},
};
const std::vector<ChildRule> kServicePortRules = {
    {"name", {"name"}},
    {"", {"description", "reference"}},
    {"type", {"type"}},
    {"usage", {"usage"}},
    {"operation", {"operation"}, true, {"name", "request", "reply", "oneway"}},
};

// ---------------------------------------------------------------------------------------
// The loader

// A name that must resolve in the type registry once every type file is loaded.
struct LoadedComponent {
  bool readable = false;  // the file was parsed and had the right root
  ComponentProfile profile;
  std::vector<TypeUse> type_uses;
  std::set<std::string, std::less<>> incomplete_ports;  // kind/direction unknown: not checked
  // The readers of model elements: the component's own model's, and those of other models
  // whose elements it carries (read for their problems, then dropped).
  std::unique_ptr<ComponentSectionReader> own_reader;
  std::map<const ModelSection*, std::unique_ptr<ComponentSectionReader>> foreign_readers;
};

// The names every known model owns, added to core's own child tables.
struct ModelRules {
  std::vector<ChildRule> component;
  std::vector<ChildRule> data_port;
  std::vector<ChildRule> service_port;
  std::vector<std::pair<std::string_view, const ModelSection*>> sections;

  explicit ModelRules(const ModelSections* models)
      : component(kComponentRules), data_port(kDataPortRules), service_port(kServicePortRules) {
    if (models != nullptr) sections = models->sections();
    std::set<std::string_view> component_tags;
    std::set<std::string_view> port_tags;
    std::set<std::string_view> attributes;
    const std::size_t operation = service_port.size() - 1;  // {"operation", ...}
    for (const auto& [model, section] : sections) {
      const ModelVocabulary& vocabulary = section->vocabulary();
      for (const std::string_view tag : vocabulary.component_elements) {
        if (component_tags.insert(tag).second) component.push_back(ChildRule(tag, {tag}));
      }
      for (const std::string_view tag : vocabulary.port_elements) {
        if (!port_tags.insert(tag).second) continue;
        data_port.push_back(ChildRule(tag, {tag}));
        service_port.push_back(ChildRule(tag, {tag}));
      }
      for (const std::string_view attribute : vocabulary.operation_attributes) {
        if (attributes.insert(attribute).second) service_port[operation].attributes.push_back(attribute);
      }
    }
  }

  const ModelSection* section_of(std::string_view model) const {
    for (const auto& [name, section] : sections) {
      if (name == model) return section;
    }
    return nullptr;
  }

  // The model that reads `name` (a member of `list` of its vocabulary): the first that has it.
  template <class List>
  const ModelSection* owner_of(std::string_view name, List ModelVocabulary::*list) const {
    for (const auto& [model, section] : sections) {
      const auto& names = section->vocabulary().*list;
      if (std::find(names.begin(), names.end(), name) != names.end()) return section;
    }
    return nullptr;
  }
};

inline bool owns(const ModelSection* section, std::string_view name,
          std::vector<std::string_view> ModelVocabulary::*list) {
  if (section == nullptr) return false;
  const auto& names = section->vocabulary().*list;
  return std::find(names.begin(), names.end(), name) != names.end();
}

class Loader {
 public:
  Loader(TypeRegistry& types, const LoadOptions& options, Diagnostics& diagnostics)
      : types_(types), options_(options), diagnostics_(diagnostics), rules_(options.models) {}

  std::optional<ApplicationProfile> run(const fs::path& requested);
  // One <port_connection> (the root of `xml`), checked against the components of
  // `application` as run() checks a profile's connections (runtime_checks.cpp).
  std::optional<ConnectionSpec> check_one(const ApplicationProfile& application, XmlFile& xml);

 private:
  // -- shared ----------------------------------------------------------------------------

  void read_type_files(const Reporter& report, pugi::xml_node types, std::vector<fs::path>& out);

  void load_type_files();

  void check_types(const LoadedComponent& component);

  // -- application profile ---------------------------------------------------------------

  // own_semantics: each subcomponent's own <execution_semantics>, by its index in app.components.
  void read_subcomponents(const Reporter& report, pugi::xml_node element, ApplicationProfile& app,
                          std::map<std::size_t, pugi::xml_node>& own_semantics);

  void read_connections(const Reporter& report, pugi::xml_node element, ApplicationProfile& app,
                        std::vector<pugi::xml_node>& nodes);

  void read_end(const Reporter& report, pugi::xml_node connection, pugi::xml_node end,
                std::string_view tag, ConnectionEnd& out);

  // -- composites (composite_reader.cpp) ---------------------------------------------------

  // Reads <composites> once the components' profiles are known: names, promoted ports.
  void read_composites(const Reporter& report, pugi::xml_node element, ApplicationProfile& app);

  // Checks that a <promote> names a port of a component (not of a composite); returns whether
  // the port may be promoted.
  bool check_promoted(const Reporter& report, const ApplicationProfile& app, pugi::xml_node promote,
                      const std::string& composite, const std::set<std::string, std::less<>>& composite_names,
                      const PromotedPort& port);

  // Rewrites every connection end (and watchdog port) naming "Composite.name" to the member
  // port it promotes; `nodes` are the connections' elements, in the same order.
  void resolve_promoted(const Reporter& report, const ApplicationProfile& app,
                        std::vector<ConnectionSpec>& connections, const std::vector<pugi::xml_node>& nodes);

  // -- mappings --------------------------------------------------------------------------

  MappingSpec read_mapping(const Reporter& report, pugi::xml_node element);

  // Reads one <field>: its attributes' syntax and which go together. Whether the paths,
  // units and sizes fit the types is the mapping compiler's to say, once types are loaded.
  static std::optional<MappingRule> read_rule(const Reporter& report, pugi::xml_node field);

  static std::string not_a_number(const std::string& entry);

  // matrix="m11 m12; m21 m22": rows separated by ';', the entries of a row by blanks or commas.
  static bool read_matrix(const Reporter& report, pugi::xml_node field, MappingRule& rule);

  // Compiles the mapping of a data or event connection whose ends are both known: the
  // profile's <mapping>, or a by-name one when the types differ. A mapping that cannot work
  // is one "type mismatch" at the connection (when the types differ) that says why, and the
  // problems a rule causes at that rule's <field>.
  void compile_mapping(const Reporter& report, pugi::xml_node node, ConnectionSpec& spec,
                       const std::string& source_type, const std::string& target_type, bool readable);

  // -- connection policies (policy_reader.cpp) --------------------------------------------

  // Reads a <watchdog>: its times, its upstream end and its safe value's rules.
  std::optional<WatchdogSpec> read_watchdog(const Reporter& report, pugi::xml_node element);

  // Reads <rate_limit> and every <deadband> of a connection.
  void read_rate_policies(const Reporter& report, const Children& children, ConnectionSpec& spec);

  // Checks a connection's rate limit and deadbands: a data connection, deadband fields that
  // are numbers of the source's type.
  void check_rate_policies(const Reporter& report, pugi::xml_node node, ConnectionSpec& spec,
                           const PortSpec* source, const Subcomponent* source_component);

  // Reads an event connection's <condition> (condition_reader.cpp).
  std::optional<ConditionSpec> read_condition(const Reporter& report, pugi::xml_node element);

  // Checks a <condition> against the graph: an event connection, fields that are numbers of
  // the source's type.
  void check_condition(const Reporter& report, pugi::xml_node node, ConnectionSpec& spec, const PortSpec* source);

  // Checks a connection's watchdog against the graph: a data connection, an upstream output
  // data port, a safe value of constants that compiles for the target's type.
  void check_watchdog(const Reporter& report, const ApplicationProfile& app, pugi::xml_node node,
                      ConnectionSpec& spec, const PortSpec* target);

  // -- push newest / push timed (push_reader.cpp) ------------------------------------------

  // Reads a data port's <push>: its pattern and base cycle, checked against the period of an
  // in-process periodic component.
  void read_push(const Reporter& report, pugi::xml_node element, PortSpec& port, const ComponentProfile& profile);

  // Reads a connection's <subscription every>.
  static void read_subscription(const Reporter& report, const Children& children, ConnectionSpec& spec);

  // Checks that a subscription's source is a push timed port.
  void check_subscription(const Reporter& report, pugi::xml_node node, ConnectionSpec& spec, const PortSpec* source);

  // -- component profiles ----------------------------------------------------------------

  void load_component(const fs::path& file, const SourceLocation& referenced_at,
                      const std::string& referenced_path);

  void read_component(const Reporter& report, pugi::xml_node root, LoadedComponent& component);

  // -- model elements --------------------------------------------------------------------

  // The reader of another model's elements on this component, made on first use.
  ComponentSectionReader& foreign_reader(LoadedComponent& component, const ModelSection* section);

  // The component-level elements of every model: the own model reads its own; another
  // model's are ignored with a warning, after that model has checked them.
  void read_model_elements(const Reporter& report, const Children& children, LoadedComponent& component);

  // A port's model elements, the same way.
  void read_model_port(const Reporter& report, const Children& fields, const PortSpec& port,
                       LoadedComponent& component);

  // An operation's model attributes: the own model reads them; another model's are ignored
  // with one warning that names them all.
  void read_model_operation(const Reporter& report, pugi::xml_node element, const PortSpec& port,
                            const OperationSpec& operation, LoadedComponent& component,
                            std::vector<TypeUse>& uses);

  void read_library(const Reporter& report, pugi::xml_node root, pugi::xml_node environment,
                    const Children& children, ComponentProfile& profile);

  // instance: a subcomponent's own <execution_semantics>, applied over its component profile's.
  void read_execution(const Reporter& report, pugi::xml_node element, ComponentProfile& profile,
                      bool instance = false);

  void read_properties(const Reporter& report, pugi::xml_node element, ComponentProfile& profile);

  // A component reads its properties at configure time; a value that cannot be read as its
  // declared type would fail there, far from the profile, so it is checked here.
  static void check_property_value(const Reporter& report, pugi::xml_node node,
                                   const PropertySpec& property);

  void read_ports(const Reporter& report, pugi::xml_node element, LoadedComponent& component);

  // Returns whether the port's kind and direction are known (so connections can be checked).
  bool read_data_port(const Reporter& report, pugi::xml_node node, const Children& fields,
                      PortSpec& port, LoadedComponent& component);

  bool read_service_port(const Reporter& report, pugi::xml_node node, const Children& fields,
                         PortSpec& port, LoadedComponent& component);

  // -- connections -----------------------------------------------------------------------

  struct ResolvedEnd {
    const Subcomponent* component = nullptr;
    const PortSpec* port = nullptr;
    bool checkable = false;  // port known with a known kind and direction
  };

  ResolvedEnd resolve(const Reporter& report, const ApplicationProfile& app, pugi::xml_node end,
                      const ConnectionEnd& spec);

  // Checks that `end` is a `kind` port facing the right way; returns whether it is.
  bool check_end(const Reporter& report, pugi::xml_node connection, pugi::xml_node end,
                 const ConnectionSpec& spec, const ConnectionEnd& end_spec,
                 const ResolvedEnd& resolved, bool is_source);

  // Two type names match when they name the same registered type, however spelled
  // ("::a::T" and "a::T"); an empty name (no payload) matches only another empty one. A name
  // the registry does not know is reported at its port already, so it matches anything here.
  bool same_type(std::string_view a, std::string_view b) const;

  static std::string signature(const OperationSpec& operation);

  void check_connections(const Reporter& report, ApplicationProfile& app,
                         const std::vector<pugi::xml_node>& nodes);

  // Leaves the connection with its effective policy and depth: the connection's own, else the
  // input port's, else the default: data (latest value) for data connections, circular for
  // events, which are notifications that a newer one must not silently replace. A queue
  // without a size gets the input port's size, else kDefaultDepth.
  static void resolve_policy(const Reporter& report, pugi::xml_node node, ConnectionSpec& spec,
                             const PortSpec* target);

  void check_service_pair(const Reporter& report, pugi::xml_node node, const ConnectionSpec& spec,
                          const PortSpec& required, const PortSpec& provided);

  TypeRegistry& types_;
  const LoadOptions& options_;
  Diagnostics& diagnostics_;
  std::map<fs::path, std::unique_ptr<LoadedComponent>> components_;
  std::vector<const LoadedComponent*> load_order_;  // so diagnostics follow the profile
  std::vector<fs::path> pending_type_files_;
  std::vector<bool> mapping_readable_;  // per connection: its <mapping> read without errors
  const ModelRules rules_;
};

}  // namespace polyport::detail
