// Component profiles: name, model, library, execution semantics, properties and ports, each
// problem at its place; the model's own elements go to model_elements.cpp.

#include "loader.hpp"
#include "polyport/profile/notifications.hpp"
#include "polyport/profile/runtime_checks.hpp"

#include <cstdio>

namespace polyport::detail {

namespace {

constexpr const char* kNotificationType = "polyport::ComponentNotification";

// <notifications port="notifications" auto="false"/>: adds the component's notification
// port (an event output of polyport::ComponentNotification) to its ports. After <ports>, so
// a name already taken is reported here.
void read_notifications(const Reporter& report, pugi::xml_node element, LoadedComponent& component) {
  ComponentProfile& profile = component.profile;
  NotificationSettings spec;
  spec.where = report.xml().at(element);
  if (const auto port = element.attribute("port")) {
    spec.port = std::string(trim(port.value()));
    if (spec.port.empty()) {
      report.error_attribute(element, "port", "empty attribute 'port'");
      return;
    }
  }
  if (const auto automatic = element.attribute("auto")) {
    const std::string text(trim(automatic.value()));
    if (const auto value = lookup(kBooleans, text)) {
      spec.automatic = *value;
    } else {
      report.error_attribute(element, "auto", "bad auto " + in_quotes(text) + " (accepted: " + accepted(kBooleans) + ")");
      return;
    }
  }
  if (const auto kind = element.attribute("kind")) {
    const std::string text(trim(kind.value()));
    if (text == "data") {
      spec.kind = PortKind::data;
    } else if (text != "event") {
      report.error_attribute(element, "kind", "bad kind " + in_quotes(text) + " (accepted: event, data)");
      return;
    }
  }
  if (profile.model != "inproc") {
    report.error(element, "<notifications> are raised by in-process components; a component of model " +
                              in_quotes(profile.model) + " carries " + kNotificationType +
                              " on a port of its own");
    return;
  }
  if (profile.find_port(spec.port) != nullptr) {
    const std::string message =
        "the notification port " + in_quotes(spec.port) + " is already a port of the component";
    if (element.attribute("port")) report.error_attribute(element, "port", message);
    else report.error(element, message + " (name another with port=\"...\")");
    return;
  }
  PortSpec port;
  port.name = spec.port;
  port.kind = spec.kind;
  port.direction = PortDirection::output;
  port.data_type = kNotificationType;
  port.where = spec.where;
  component.type_uses.push_back({kNotificationType, spec.where, element_path(element)});
  profile.ports.push_back(std::move(port));
  // The in-process model has no settings of its own otherwise (no section reader).
  profile.model_settings = std::make_shared<const NotificationSettings>(std::move(spec));
}

}  // namespace

void Loader::load_component(const fs::path& file, const SourceLocation& referenced_at,
                    const std::string& referenced_path) {
  // Several instances may share one component profile: read (and report) it once.
  if (components_.count(file) != 0) return;
  auto& component = *components_.emplace(file, std::make_unique<LoadedComponent>()).first->second;
  load_order_.push_back(&component);
  component.profile.file = file;
  XmlFile xml;
  if (!xml.load(file, "component profile", referenced_at, referenced_path, diagnostics_)) return;
  const Reporter report(xml);
  const pugi::xml_node root = xml.root();
  if (std::string_view(root.name()) != "component_profile") {
    report.error(root, "expected root element <component_profile>, found <" +
                           std::string(root.name()) + ">");
    return;
  }
  check_attributes(report, root, {}, true);
  component.readable = true;
  read_component(report, root, component);
}

void Loader::read_component(const Reporter& report, pugi::xml_node root, LoadedComponent& component) {
  ComponentProfile& profile = component.profile;
  profile.where = report.xml().at(root);
  profile.execution.where = profile.where;
  const Children children = scan(report, root, rules_.component);
  if (auto name = required_text(report, root, children, "name", "name")) profile.name = *name;
  if (const auto model = children.one("model")) {
    const std::string text = text_of(model);
    if (text.empty()) {
      report.error(model, "empty <model>");
    } else {
      profile.model = text;
    }
  }
  const pugi::xml_node environment = children.one("execution_environment");
  const Children environment_children =
      environment ? scan(report, environment, kEnvironmentRules) : Children();
  if (auto class_name = optional_text(environment_children, "class_name");
      class_name && !class_name->empty()) {
    profile.class_name = *class_name;
  } else {
    profile.class_name = profile.name;
  }
  if (profile.model == "inproc") {
    read_library(report, root, environment, environment_children, profile);
  }
  if (const auto semantics = children.one("execution_semantics")) {
    read_execution(report, semantics, profile);
  }
  if (const ModelSection* own = rules_.section_of(profile.model)) component.own_reader = own->reader(profile.model);
  read_model_elements(report, children, component);
  if (const auto types = children.one("types")) {
    read_type_files(report, types, profile.type_files);
  }
  if (const auto properties = children.one("properties")) {
    read_properties(report, properties, profile);
  }
  if (const auto ports = children.one("ports")) read_ports(report, ports, component);
  if (component.own_reader) profile.model_settings = component.own_reader->finish();
  if (const auto notifications = children.one("notifications")) read_notifications(report, notifications, component);
  component.foreign_readers.clear();
}

void Loader::read_library(const Reporter& report, pugi::xml_node root, pugi::xml_node environment,
                  const Children& children, ComponentProfile& profile) {
  const pugi::xml_node library = children.one("library_name");
  if (!library) {
    report.error(environment ? environment : root,
                 environment ? "missing <library_name> (needed by model 'inproc')"
                             : "missing <execution_environment> with <library_name> (needed by "
                               "model 'inproc')");
    return;
  }
  profile.library = text_of(library);
  if (profile.library.empty()) {
    report.error(library, "empty <library_name>");
    return;
  }
  std::vector<fs::path> folders;
  folders.push_back(profile.file.parent_path());
  for (const auto& folder : options_.library_path) folders.push_back(absolute_path(folder));
  const fs::path library_file(profile.library);
  if (library_file.is_absolute()) folders.assign(1, library_file.parent_path());
  for (const auto& folder : folders) {
    const fs::path candidate = library_file.is_absolute() ? library_file : folder / library_file;
    std::error_code ec;
    if (fs::is_regular_file(candidate, ec)) {
      // Not canonical: a library is often a symlink to a versioned file, and logs should
      // show the name the profile asked for.
      profile.library_path = fs::absolute(candidate, ec).lexically_normal();
      return;
    }
  }
  std::vector<std::string> names;
  for (const auto& folder : folders) names.push_back(folder.string());
  report.error_text(library, "component library " + in_quotes(profile.library) +
                                 " not found (looked in: " + join(names, ", ") + ")");
}

void Loader::read_execution(const Reporter& report, pugi::xml_node element, ComponentProfile& profile,
                            bool instance) {
  ExecutionSemantics& execution = profile.execution;
  // Diagnostics about the component (its type, its period) keep pointing at its own profile.
  if (!instance) execution.where = report.xml().at(element);
  const SchedPolicy policy_before = execution.policy;
  const Children children = scan(report, element, kSemanticsRules);
  if (instance) {
    // What the component is designed for (its control law is tuned to its period) stays in
    // its component profile; an instance sets where and when it runs.
    for (const char* own : {"type", "period", "lifecycle_type"}) {
      if (const pugi::xml_node node = children.one(own)) {
        report.error(node, "<" + std::string(node.name()) +
                               "> belongs in the component profile; a subcomponent's <execution_semantics> sets "
                               "only phase, priority, policy, cpu (cpu_affinity) and spin_us");
      }
    }
  }
  if (const auto type = children.one("type")) {
    if (auto value = enum_text(report, type, kExecutionTypes, "execution type")) {
      execution.type = *value;
    }
  }
  bool period_ok = true;
  if (const auto period = children.one("period")) {
    const std::string text = text_of(period);
    const auto value = parse_decimal(text);
    period_ok = value && *value > 0.0;
    if (!value || *value < 0.0) {
      report.error_text(period, "bad period " + in_quotes(text) +
                                    ": expected a number of milliseconds, 0 or more");
    } else {
      execution.period_ms = *value;
      if (is_periodic(execution.type) && *value <= 0.0) {
        report.error_text(period, "period must be greater than 0 ms for a periodic component");
      }
    }
  }
  const pugi::xml_node priority = children.one("priority");
  if (priority) {
    const std::string text = text_of(priority);
    if (const auto value = parse_integer<int>(text)) {
      execution.priority = *value;
    } else {
      report.error_text(priority, "bad priority " + in_quotes(text) + ": expected an integer");
    }
  }
  const pugi::xml_node policy = children.one("policy");
  bool policy_ok = true;
  if (policy) {
    const auto value = enum_text(report, policy, kSchedPolicies, "scheduling policy");
    policy_ok = value.has_value();
    if (value) execution.policy = *value;
  }
  // Real-time policies need a real-time priority; SCHED_OTHER ignores it (OPRoS profiles
  // use it to group components onto shared executors). A subcomponent's own
  // <execution_semantics> may keep the component profile's real-time priority, not take an
  // SCHED_OTHER grouping number for one.
  if (policy_ok && execution.policy != SchedPolicy::other) {
    const std::string name(sched_policy_name(execution.policy));
    if (!priority && (execution.priority < kMinRtPriority || execution.priority > kMaxRtPriority ||
                      (instance && policy_before == SchedPolicy::other))) {
      report.error(policy, name + " needs a <priority> from " + std::to_string(kMinRtPriority) +
                               " to " + std::to_string(kMaxRtPriority));
    } else if (parse_integer<int>(text_of(priority)) &&
               (execution.priority < kMinRtPriority || execution.priority > kMaxRtPriority)) {
      report.error_text(priority, "priority " + std::to_string(execution.priority) +
                                      " is out of range for " + name + " (" +
                                      std::to_string(kMinRtPriority) + " to " +
                                      std::to_string(kMaxRtPriority) + ")");
    }
  }
  if (const auto cpu = children.one("cpu")) {
    const std::string text = text_of(cpu);
    const auto value = parse_integer<int>(text);
    if (!value || *value < 0 || *value > kMaxCpu) {
      report.error_text(cpu, "bad " + std::string(cpu.name()) + " " + in_quotes(text) +
                                 ": expected an integer from 0 to " + std::to_string(kMaxCpu));
    } else {
      execution.cpu = *value;
    }
  }
  if (const auto spin = children.one("spin_us")) {
    // Checked against the period only when the period itself was read well and is used.
    const std::string text = text_of(spin);
    const auto value = parse_integer<std::int64_t>(text);
    const double period_us = execution.period_ms * 1000.0;
    if (!value || *value < 0) {
      report.error_text(spin, "bad spin_us " + in_quotes(text) +
                                  ": expected an integer number of microseconds, 0 or more");
    } else if (is_periodic(execution.type) && period_ok &&
               static_cast<double>(*value) > period_us) {
      char period_text[32];
      std::snprintf(period_text, sizeof period_text, "%.15g", period_us);
      report.error_text(spin, "spin_us " + std::to_string(*value) + " is longer than the period (" +
                                  period_text + " us): expected 0 to the period");
    } else {
      execution.spin_us = *value;
    }
  }
  const pugi::xml_node phase = children.one("phase");
  if (phase) {
    const std::string text = text_of(phase);
    const auto value = parse_decimal(text);
    if (!value || *value < 0.0) {
      report.error_text(phase, "bad phase " + in_quotes(text) + ": expected a number of milliseconds, 0 or more");
    } else {
      execution.phase_ms = *value;
    }
  }
  // Checked against the period that applies: a subcomponent's phase against its component's.
  if (phase && execution.phase_ms && is_periodic(execution.type) && period_ok &&
      *execution.phase_ms >= execution.period_ms) {
    char text[128];
    std::snprintf(text, sizeof text, "phase %.15g ms is not shorter than the period (%.15g ms)", *execution.phase_ms,
                  execution.period_ms);
    report.error_text(phase, std::string(text) + ": expected 0 to less than the period");
  }
  if (const auto lifecycle = children.one("lifecycle_type")) {
    if (auto value = enum_text(report, lifecycle, kLifecycleTypes, "lifecycle_type")) {
      profile.initial_state = *value;
    }
  }
}

void Loader::read_properties(const Reporter& report, pugi::xml_node element, ComponentProfile& profile) {
  const Children children = scan(report, element, kPropertiesRules);
  std::map<std::string, pugi::xml_node, std::less<>> seen;
  for (const pugi::xml_node node : children.all("property")) {
    PropertySpec property;
    property.where = report.xml().at(node);
    property.name = std::string(trim(node.attribute("name").value()));
    property.type = std::string(trim(node.attribute("type").value()));
    property.value = text_of(node);
    if (property.name.empty()) {
      report.error(
          node, node.attribute("name") ? "empty attribute 'name'" : "missing attribute 'name'");
      continue;
    }
    const auto [it, inserted] = seen.emplace(property.name, node);
    if (!inserted) {
      report.error_attribute(node, "name",
                             "duplicate property " + in_quotes(property.name) +
                                 ": already given at line " +
                                 std::to_string(report.xml().at(it->second).line));
      continue;
    }
    check_property_value(report, node, property);
    profile.properties.push_back(std::move(property));
  }
}

// A component reads its properties at configure time; a value that cannot be read as its
// declared type would fail there, far from the profile, so it is checked here.
void Loader::check_property_value(const Reporter& report, pugi::xml_node node,
                                 const PropertySpec& property) {
  std::string problem = property_value_problem(property, property.value);
  if (!problem.empty()) report.error_text(node, std::move(problem));
}

void Loader::read_ports(const Reporter& report, pugi::xml_node element, LoadedComponent& component) {
  const Children children = scan(report, element, kPortsRules);
  std::map<std::string, pugi::xml_node, std::less<>> seen;
  for (const pugi::xml_node node : children.all("port")) {
    PortSpec port;
    port.where = report.xml().at(node);
    const std::string_view tag = node.name();
    port.kind = tag == "service_port" ? PortKind::service
                : tag == "event_port" ? PortKind::event
                                      : PortKind::data;
    bool complete = false;
    const Children fields =
        scan(report, node, port.kind == PortKind::service ? rules_.service_port : rules_.data_port);
    const auto name = required_text(report, node, fields, "name", "name");
    if (name) port.name = *name;
    if (port.kind == PortKind::service) {
      complete = read_service_port(report, node, fields, port, component);
    } else {
      complete = read_data_port(report, node, fields, port, component);
    }
    if (!name) continue;
    port.name = *name;
    const auto [it, inserted] = seen.emplace(port.name, fields.one("name"));
    if (!inserted) {
      report.error_text(fields.one("name"), "duplicate port name " + in_quotes(port.name) +
                                                ": already used at line " +
                                                std::to_string(report.xml().at(it->second).line));
      continue;
    }
    if (!complete) component.incomplete_ports.insert(port.name);
    component.profile.ports.push_back(std::move(port));
  }
}

// Returns whether the port's kind and direction are known (so connections can be checked).
bool Loader::read_data_port(const Reporter& report, pugi::xml_node node, const Children& fields,
                    PortSpec& port, LoadedComponent& component) {
  bool complete = true;
  if (const auto data_type = fields.one("data_type")) {
    port.data_type = text_of(data_type);
    if (port.data_type.empty()) {
      if (port.kind == PortKind::data) report.error(data_type, "empty <data_type>");
    } else {
      component.type_uses.push_back(
          {port.data_type, report.xml().at_text(data_type), element_path(data_type)});
    }
  } else if (port.kind == PortKind::data) {
    report.error(node, "missing <data_type>");
  }
  if (const auto usage = required_text(report, node, fields, "usage", "usage")) {
    const std::string context = " for " + port_noun(port);
    if (auto direction = enum_text(report, fields.one("usage"), kDataUsages, "usage", context)) {
      port.direction = *direction;
    } else {
      complete = false;
    }
  } else {
    complete = false;
  }

  read_model_port(report, fields, port, component);
  if (const pugi::xml_node push = fields.one("push")) read_push(report, push, port, component.profile);

  const pugi::xml_node policy = fields.one("policy");
  if (policy) {
    port.policy = enum_text(report, policy, kQueuePolicies, "queueing policy");
  }
  // The depth comes from <queue_size>, <queueing_size> or <policy_param name="size">.
  pugi::xml_node depth = fields.one("depth");
  for (const pugi::xml_node param : fields.all("policy_param")) {
    const std::string param_name(trim(param.attribute("name").value()));
    if (param_name != "size") {
      report.warning(param, "unknown policy_param " + in_quotes(param_name) + " (known: size)");
      continue;
    }
    if (depth) {
      report.error(param, "duplicate <policy_param name=\"size\">: depth already given at line " +
                              std::to_string(report.xml().at(depth).line));
      continue;
    }
    depth = param;
  }
  if (depth) {
    const std::string text = text_of(depth);
    port.depth = depth_value(text);
    if (!port.depth) {
      report.error_text(depth, "bad depth " + in_quotes(text) + ": " + kDepthExpected);
    }
  }
  if (complete && port.direction == PortDirection::output) {
    // The queue lives on the reading side. OPRoS editors write `data` on outputs too, which
    // is harmless; asking an output for a queue is a misunderstanding worth a warning.
    if (policy && port.policy && *port.policy != QueuePolicy::data) {
      report.warning(policy,
                     "a queueing policy on an output port is ignored (the input port "
                     "or the connection sets it)");
    }
    if (depth) {
      report.warning(depth,
                     "a queue size on an output port is ignored (the input port or "
                     "the connection sets it)");
    }
    port.policy.reset();
    port.depth.reset();
    return complete;
  }
  if (port.policy == QueuePolicy::data && port.depth) {
    // OPRoS writes "LAST with size 1" for the latest value; more than one is a contradiction.
    if (*port.depth != 1) {
      report.error_text(depth, "a depth of " + std::to_string(*port.depth) +
                                   " contradicts the data policy (latest value only); use "
                                   "buffer or circular for a queue");
    }
    port.depth.reset();
  }
  if (port.policy && port.policy != QueuePolicy::data && !port.depth) port.depth = kDefaultDepth;
  return complete;
}

bool Loader::read_service_port(const Reporter& report, pugi::xml_node node, const Children& fields,
                       PortSpec& port, LoadedComponent& component) {
  bool complete = true;
  read_model_port(report, fields, port, component);
  if (auto type = optional_text(fields, "type")) port.service_type = *type;
  if (const auto usage = required_text(report, node, fields, "usage", "usage")) {
    if (auto direction = enum_text(report, fields.one("usage"), kServiceUsages, "usage",
                                   " for a service port")) {
      port.direction = *direction;
    } else {
      complete = false;
    }
  } else {
    complete = false;
  }
  std::map<std::string, pugi::xml_node, std::less<>> seen;
  for (const pugi::xml_node element : fields.all("operation")) {
    OperationSpec operation;
    operation.where = report.xml().at(element);
    operation.name = std::string(trim(element.attribute("name").value()));
    operation.request_type = std::string(trim(element.attribute("request").value()));
    operation.reply_type = std::string(trim(element.attribute("reply").value()));
    if (const auto oneway = element.attribute("oneway")) {
      const std::string text(trim(oneway.value()));
      if (const auto value = lookup(kBooleans, text)) {
        operation.oneway = *value;
      } else {
        report.error_attribute(
            element, "oneway",
            "bad oneway " + in_quotes(text) + " (accepted: " + accepted(kBooleans) + ")");
      }
    }
    if (operation.oneway && !operation.reply_type.empty()) {
      report.error_attribute(element, "reply", "a oneway operation has no reply");
    }
    std::vector<TypeUse> model_uses;
    read_model_operation(report, element, port, operation, component, model_uses);
    for (const std::string_view attribute : {"request", "reply"}) {
      const std::string& type_name = attribute == "request" ? operation.request_type : operation.reply_type;
      if (type_name.empty()) continue;
      component.type_uses.push_back({type_name, report.xml().at_attribute(element, attribute),
                                     attribute_path(element, attribute)});
    }
    component.type_uses.insert(component.type_uses.end(), model_uses.begin(), model_uses.end());
    if (operation.name.empty()) {
      report.error(element, element.attribute("name") ? "empty attribute 'name'"
                                                      : "missing attribute 'name'");
      continue;
    }
    const auto [it, inserted] = seen.emplace(operation.name, element);
    if (!inserted) {
      report.error_attribute(element, "name",
                             "duplicate operation " + in_quotes(operation.name) +
                                 ": already given at line " +
                                 std::to_string(report.xml().at(it->second).line));
      continue;
    }
    port.operations.push_back(std::move(operation));
  }
  return complete;
}

}  // namespace polyport::detail
