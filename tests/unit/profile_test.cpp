// The profile loader against the fixtures in tests/data/profiles: valid profiles read into
// the expected structs, and every invalid profile gives exactly the expected diagnostics
// (file names shown relative to tests/data/profiles).

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <optional>
#include <string>
#include <vector>

#include "polyport/diagnostics.hpp"
#include "polyport/profile.hpp"
#include "polyport/types.hpp"

namespace {

using namespace polyport;
namespace fs = std::filesystem;

fs::path profiles_dir() {
#ifdef POLYPORT_TEST_DATA
  const fs::path data = POLYPORT_TEST_DATA;
#else
  const fs::path data = fs::path(__FILE__).parent_path().parent_path() / "data";
#endif
  // The loader reports weakly_canonical paths; compare against the same spelling.
  return fs::weakly_canonical(data / "profiles");
}

fs::path schema_file() {
#ifdef POLYPORT_SOURCE_DIR
  return fs::path(POLYPORT_SOURCE_DIR) / "config" / "polyport.xsd";
#else
  return profiles_dir().parent_path().parent_path().parent_path() / "config" / "polyport.xsd";
#endif
}

// Every diagnostic as the user reads it, with the fixture folder cut out of file names.
std::vector<std::string> rendered(const Diagnostics& diagnostics, const fs::path& base) {
  const std::string prefix = base.string() + "/";
  std::vector<std::string> out;
  for (const Diagnostic& item : diagnostics.all()) {
    std::string text = item.to_string();
    for (auto at = text.find(prefix); at != std::string::npos; at = text.find(prefix, at)) {
      text.erase(at, prefix.size());
    }
    out.push_back(std::move(text));
  }
  return out;
}

class ProfileLoader : public ::testing::Test {
 protected:
  std::optional<ApplicationProfile> load(const fs::path& relative) {
    return load_application_profile(profiles_dir() / relative, types_, options_, diagnostics_);
  }
  std::vector<std::string> messages() const { return rendered(diagnostics_, profiles_dir()); }

  TypeRegistry types_;
  Diagnostics diagnostics_;
  LoadOptions options_{{profiles_dir() / "libs"}};
};

TEST_F(ProfileLoader, ReadsTheValidApplication) {
  const auto app = load("valid_app.xml");
  ASSERT_TRUE(app.has_value()) << ::testing::PrintToString(messages());
  EXPECT_TRUE(diagnostics_.all().empty()) << ::testing::PrintToString(messages());

  const fs::path dir = profiles_dir();
  EXPECT_EQ(app->file, dir / "valid_app.xml");
  EXPECT_EQ(app->name, "wheelchair");
  EXPECT_EQ(app->description,
            "Joystick, control and motor, as in the OPRoS/RTM wheelchair experiment.");
  EXPECT_EQ(app->type_files, std::vector<fs::path>{dir / "types" / "wheelchair.idl"});
  ASSERT_EQ(app->components.size(), 3U);
  EXPECT_NE(types_.find("wheelchair::Joystick"), nullptr);

  const Subcomponent* joystick = app->find_component("Joystick");
  ASSERT_NE(joystick, nullptr);
  EXPECT_EQ(joystick->reference, dir / "components" / "Joystick.xml");
  EXPECT_EQ(joystick->where.line, 13U);
  EXPECT_EQ(joystick->where.column, 5U);
  const ComponentProfile& joystick_profile = joystick->profile;
  EXPECT_EQ(joystick_profile.file, dir / "components" / "Joystick.xml");
  EXPECT_EQ(joystick_profile.name, "Joystick");
  EXPECT_EQ(joystick_profile.model, "inproc");
  EXPECT_EQ(joystick_profile.library, "libjoystick.so");
  // Found next to the component profile before the library path is searched.
  EXPECT_EQ(joystick_profile.library_path, dir / "components" / "libjoystick.so");
  EXPECT_EQ(joystick_profile.class_name, "Joystick");  // default: the component's name
  EXPECT_EQ(joystick_profile.execution.type, ExecutionType::periodic);
  EXPECT_DOUBLE_EQ(joystick_profile.execution.period_ms, 10.0);
  EXPECT_EQ(joystick_profile.execution.policy, SchedPolicy::other);
  EXPECT_FALSE(joystick_profile.execution.cpu.has_value());
  EXPECT_EQ(joystick_profile.initial_state, InitialState::active);
  EXPECT_EQ(joystick_profile.type_files, std::vector<fs::path>{dir / "types" / "wheelchair.idl"});
  ASSERT_EQ(joystick_profile.properties.size(), 2U);
  const PropertySpec* dead_zone = joystick_profile.find_property("dead_zone");
  ASSERT_NE(dead_zone, nullptr);
  EXPECT_EQ(dead_zone->type, "double");
  EXPECT_EQ(dead_zone->value, "0.05");
  EXPECT_EQ(dead_zone->where.file, (dir / "components" / "Joystick.xml").string());
  EXPECT_EQ(dead_zone->where.line, 27U);
  EXPECT_EQ(joystick_profile.find_property("nothing"), nullptr);
  const PortSpec* busy = joystick_profile.find_port("busy");
  ASSERT_NE(busy, nullptr);
  EXPECT_EQ(busy->kind, PortKind::event);
  EXPECT_EQ(busy->direction, PortDirection::output);
  EXPECT_TRUE(busy->data_type.empty());
  EXPECT_EQ(joystick_profile.find_port("nothing"), nullptr);

  // `components/../components/Control.xml` is stored normalised.
  const Subcomponent* control = app->find_component("Control");
  ASSERT_NE(control, nullptr);
  EXPECT_EQ(control->reference, dir / "components" / "Control.xml");
  const ComponentProfile& control_profile = control->profile;
  EXPECT_EQ(control_profile.library_path, dir / "libs" / "libcontrol.so");
  EXPECT_EQ(control_profile.class_name, "ControlComponent");
  EXPECT_EQ(control_profile.execution.type, ExecutionType::periodic_exclusive);
  EXPECT_EQ(control_profile.execution.priority, 80);
  EXPECT_EQ(control_profile.execution.policy, SchedPolicy::fifo);
  EXPECT_EQ(control_profile.execution.cpu, 1);
  EXPECT_EQ(control_profile.initial_state, InitialState::inactive);
  const PortSpec* control_joystick = control_profile.find_port("joystick");
  ASSERT_NE(control_joystick, nullptr);
  EXPECT_EQ(control_joystick->kind, PortKind::data);
  EXPECT_EQ(control_joystick->direction, PortDirection::input);
  EXPECT_EQ(control_joystick->data_type, "wheelchair::Joystick");
  EXPECT_EQ(control_joystick->policy, QueuePolicy::buffer);
  EXPECT_EQ(control_joystick->depth, 16U);  // the default depth of a queue
  const PortSpec* status = control_profile.find_port("status");
  ASSERT_NE(status, nullptr);
  EXPECT_EQ(status->policy, QueuePolicy::circular);
  EXPECT_EQ(status->depth, 8U);
  const PortSpec* motor = control_profile.find_port("motor");
  ASSERT_NE(motor, nullptr);
  EXPECT_EQ(motor->kind, PortKind::service);
  EXPECT_EQ(motor->direction, PortDirection::required);
  EXPECT_EQ(motor->service_type, "wheelchair::MotorService");
  ASSERT_EQ(motor->operations.size(), 2U);
  EXPECT_EQ(motor->operations[0].name, "set_gain");
  EXPECT_EQ(motor->operations[0].request_type, "wheelchair::Gain");
  EXPECT_EQ(motor->operations[0].reply_type, "wheelchair::Status");
  EXPECT_FALSE(motor->operations[0].oneway);
  EXPECT_EQ(motor->operations[1].name, "stop");
  EXPECT_TRUE(motor->operations[1].oneway);
  EXPECT_TRUE(motor->operations[1].request_type.empty());
  EXPECT_EQ(motor->where.line, 49U);
  EXPECT_EQ(motor->where.column, 5U);

  const ComponentProfile& motor_profile = app->find_component("Motor")->profile;
  EXPECT_EQ(motor_profile.model, "lcm");
  EXPECT_TRUE(motor_profile.library.empty());
  EXPECT_TRUE(motor_profile.library_path.empty());
  EXPECT_EQ(motor_profile.execution.type, ExecutionType::passive);
  EXPECT_EQ(motor_profile.find_port("motor")->direction, PortDirection::provided);
  EXPECT_EQ(app->find_component("Nobody"), nullptr);

  // Connections carry their effective policy and depth.
  ASSERT_EQ(app->connections.size(), 6U);
  const ConnectionSpec& buffered = app->connections[0];
  EXPECT_EQ(buffered.kind, PortKind::data);
  EXPECT_EQ(buffered.source.component, "Joystick");
  EXPECT_EQ(buffered.source.port, "joystick");
  EXPECT_EQ(buffered.target.component, "Control");
  EXPECT_EQ(buffered.target.port, "joystick");
  EXPECT_EQ(buffered.policy, QueuePolicy::buffer);  // the input port's
  EXPECT_EQ(buffered.depth, 16U);
  EXPECT_EQ(buffered.where.line, 30U);
  EXPECT_EQ(buffered.where.column, 5U);
  EXPECT_EQ(buffered.source.where.line, 31U);
  EXPECT_EQ(buffered.source.where.column, 7U);
  EXPECT_EQ(app->connections[1].policy, QueuePolicy::circular);  // the connection's own
  EXPECT_EQ(app->connections[1].depth, 4U);
  EXPECT_EQ(app->connections[2].kind, PortKind::event);
  EXPECT_EQ(app->connections[2].policy, QueuePolicy::circular);  // events: not replaced
  EXPECT_EQ(app->connections[2].depth, 16U);
  EXPECT_EQ(app->connections[3].kind, PortKind::service);  // no port_type: OPRoS "method"
  EXPECT_FALSE(app->connections[3].policy.has_value());
  EXPECT_FALSE(app->connections[3].depth.has_value());
  EXPECT_EQ(app->connections[4].policy, QueuePolicy::circular);  // the input port's
  EXPECT_EQ(app->connections[4].depth, 8U);
  EXPECT_EQ(app->connections[5].policy, QueuePolicy::data);  // the default
  EXPECT_FALSE(app->connections[5].depth.has_value());
}

TEST_F(ProfileLoader, AcceptsOprosAliasesAndWarnsAboutUnknownNames) {
  const auto app = load("aliases_app.xml");
  ASSERT_TRUE(app.has_value()) << ::testing::PrintToString(messages());
  // The shared component profile is read, and warned about, once.
  EXPECT_EQ(messages(), (std::vector<std::string>{
      "aliases_app.xml:5:3: /application_profile/descripton: warning: unknown element "
      "<descripton>",
      "components/OprosAliases.xml:51:7: /component_profile/ports/data_port[4]/queueing_policy: "
      "warning: a queueing policy on an output port is ignored (the input port or the "
      "connection sets it)",
      "aliases_app.xml:29:40: /application_profile/port_connections/port_connection[4]/@priority: "
      "warning: unknown attribute 'priority'",
  }));
  EXPECT_FALSE(diagnostics_.has_errors());

  ASSERT_EQ(app->components.size(), 2U);
  EXPECT_EQ(app->components[0].reference, app->components[1].reference);
  const ComponentProfile& profile = app->components[1].profile;
  EXPECT_EQ(profile.name, "OprosAliases");
  EXPECT_EQ(profile.execution.type, ExecutionType::periodic);  // periodic-shared
  EXPECT_DOUBLE_EQ(profile.execution.period_ms, 20.5);
  EXPECT_EQ(profile.execution.priority, 5);
  EXPECT_EQ(profile.execution.policy, SchedPolicy::rr);  // RR
  EXPECT_EQ(profile.execution.cpu, 3);                   // <cpu>
  EXPECT_EQ(profile.initial_state, InitialState::inactive);  // READY

  const PortSpec* last = profile.find_port("last");
  ASSERT_NE(last, nullptr);
  EXPECT_EQ(last->policy, QueuePolicy::data);  // OPROS_LAST, size 1: the latest value
  EXPECT_FALSE(last->depth.has_value());
  const PortSpec* fifo = profile.find_port("fifo");
  ASSERT_NE(fifo, nullptr);
  EXPECT_EQ(fifo->policy, QueuePolicy::circular);  // <policy>FIFO
  EXPECT_EQ(fifo->depth, 5U);                      // <policy_param name="size">
  const PortSpec* opros_fifo = profile.find_port("opros_fifo");
  ASSERT_NE(opros_fifo, nullptr);
  EXPECT_EQ(opros_fifo->policy, QueuePolicy::circular);
  EXPECT_EQ(opros_fifo->depth, 7U);  // <queueing_size>
  const PortSpec* notify = profile.find_port("notify");
  ASSERT_NE(notify, nullptr);
  EXPECT_EQ(notify->policy, QueuePolicy::data);  // LAST
  const PortSpec* out = profile.find_port("out");
  ASSERT_NE(out, nullptr);
  EXPECT_FALSE(out->policy.has_value());  // outputs have no queue
  const PortSpec* svc = profile.find_port("svc");
  ASSERT_NE(svc, nullptr);
  EXPECT_EQ(svc->service_type, "Svc");
  EXPECT_TRUE(svc->operations.empty());

  ASSERT_EQ(app->connections.size(), 5U);
  EXPECT_EQ(app->connections[0].policy, QueuePolicy::data);
  EXPECT_EQ(app->connections[1].policy, QueuePolicy::circular);
  EXPECT_EQ(app->connections[1].depth, 5U);
  EXPECT_EQ(app->connections[2].policy, QueuePolicy::circular);
  EXPECT_EQ(app->connections[2].depth, 2U);  // the connection's depth wins over the port's
  EXPECT_EQ(app->connections[3].policy, QueuePolicy::data);  // the event port asked for LAST
  EXPECT_EQ(app->connections[4].kind, PortKind::service);    // port_type="method"
}

TEST_F(ProfileLoader, MissingApplicationProfile) {
  EXPECT_FALSE(load("invalid/nowhere.xml").has_value());
  EXPECT_EQ(messages(), (std::vector<std::string>{
      "invalid/nowhere.xml: application profile 'invalid/nowhere.xml' not found",
  }));
}

TEST_F(ProfileLoader, XmlSyntaxError) {
  EXPECT_FALSE(load("invalid/syntax_error.xml").has_value());
  EXPECT_EQ(messages(), (std::vector<std::string>{
      "invalid/syntax_error.xml:7:7: XML syntax error: Start-end tags mismatch",
  }));
}

TEST_F(ProfileLoader, WrongRootElement) {
  EXPECT_FALSE(load("invalid/wrong_root.xml").has_value());
  EXPECT_EQ(messages(), (std::vector<std::string>{
      "invalid/wrong_root.xml:3:1: /component_profile: expected root element "
      "<application_profile>, found <component_profile>",
  }));
}

TEST_F(ProfileLoader, MissingAndUnreadableFiles) {
  EXPECT_FALSE(load("invalid/missing_files.xml").has_value());
  EXPECT_EQ(messages(), (std::vector<std::string>{
      "invalid/missing_files.xml:6:11: /application_profile/types/file[2]: type file "
      "'invalid/types/nowhere.idl' not found",
      "invalid/missing_files.xml:7:11: /application_profile/types/file[3]: unsupported type file "
      "'invalid/types/motor.lcm' (supported: .idl)",
      "invalid/missing_files.xml:12:18: /application_profile/subcomponents/subcomponent[1]/"
      "reference: component profile 'invalid/components/Ghost.xml' not found",
      "invalid/components/BrokenSyntax.xml:6:5: XML syntax error: Start-end tags mismatch",
      "valid_app.xml:2:1: /application_profile: expected root element <component_profile>, "
      "found <application_profile>",
      "invalid/components/NoLibrary.xml:6:19: /component_profile/execution_environment/"
      "library_name: component library 'libnowhere.so' not found (looked in: "
      "invalid/components, libs)",
  }));
}

TEST_F(ProfileLoader, BadApplicationFields) {
  EXPECT_FALSE(load("invalid/bad_app_fields.xml").has_value());
  EXPECT_EQ(messages(), (std::vector<std::string>{
      "invalid/bad_app_fields.xml:2:1: /application_profile: missing <name>",
      "invalid/bad_app_fields.xml:5:5: /application_profile/subcomponents/subcomponent[1]: "
      "missing <name>",
      "invalid/bad_app_fields.xml:8:5: /application_profile/subcomponents/subcomponent[2]: "
      "missing <reference>",
      "invalid/bad_app_fields.xml:12:13: /application_profile/subcomponents/subcomponent[3]/name: "
      "duplicate subcomponent name 'Joystick': already used at line 9",
      "invalid/bad_app_fields.xml:18:7: /application_profile/subcomponents/subcomponent[4]/"
      "reference[2]: duplicate <reference>: already given at line 17",
      "invalid/bad_app_fields.xml:21:7: /application_profile/subcomponents/subcomponent[5]/name: "
      "empty <name>",
      "invalid/bad_app_fields.xml:26:33: /application_profile/port_connections/port_connection[1]/"
      "@port_type: bad port_type 'stream' (accepted: data, service, event, method)",
      "invalid/bad_app_fields.xml:30:47: /application_profile/port_connections/port_connection[2]/"
      "@policy: bad policy 'LIFO' (accepted: data, LAST, OPROS_LAST, buffer, circular, FIFO, "
      "OPROS_FIFO)",
      "invalid/bad_app_fields.xml:30:60: /application_profile/port_connections/port_connection[2]/"
      "@depth: bad depth 'zero': expected an integer from 1 to 4294967295",
      "invalid/bad_app_fields.xml:35:7: /application_profile/port_connections/port_connection[3]/"
      "source: missing attribute 'component_name'",
      "invalid/bad_app_fields.xml:34:5: /application_profile/port_connections/port_connection[3]: "
      "missing <target>",
      "invalid/bad_app_fields.xml:37:46: /application_profile/port_connections/port_connection[4]/"
      "@depth: bad depth '0': expected an integer from 1 to 4294967295",
      "invalid/bad_app_fields.xml:38:52: /application_profile/port_connections/port_connection[4]/"
      "source/@port_name: empty attribute 'port_name'",
      "invalid/bad_app_fields.xml:31:7: /application_profile/port_connections/port_connection[2]/"
      "source: Motor.status is an event port; this is a data connection",
  }));
}

TEST_F(ProfileLoader, BadExecutionSemantics) {
  EXPECT_FALSE(load("invalid/bad_execution.xml").has_value());
  EXPECT_EQ(messages(), (std::vector<std::string>{
      "invalid/components/BadExecution.xml:2:1: /component_profile: missing "
      "<execution_environment> with <library_name> (needed by model 'inproc')",
      "invalid/components/BadExecution.xml:7:5: /component_profile/execution_semantics/period[2]: "
      "duplicate <period>: already given at line 6",
      "invalid/components/BadExecution.xml:11:5: /component_profile/execution_semantics/cpu: "
      "duplicate <cpu>: already given as <cpu_affinity> at line 10",
      "invalid/components/BadExecution.xml:13:5: /component_profile/execution_semantics/deadline: "
      "warning: unknown element <deadline>",
      "invalid/components/BadExecution.xml:5:11: /component_profile/execution_semantics/type: bad "
      "execution type 'sometimes' (accepted: periodic, periodic-shared, periodic-exclusive, "
      "aperiodic, non-periodic, passive)",
      "invalid/components/BadExecution.xml:6:13: /component_profile/execution_semantics/period[1]: "
      "bad period 'ten': expected a number of milliseconds, 0 or more",
      "invalid/components/BadExecution.xml:8:15: /component_profile/execution_semantics/priority: "
      "bad priority 'high': expected an integer",
      "invalid/components/BadExecution.xml:9:13: /component_profile/execution_semantics/policy: "
      "bad scheduling policy 'SCHED_DEADLINE' (accepted: SCHED_OTHER, SCHED_FIFO, SCHED_RR, "
      "OTHER, FIFO, RR)",
      "invalid/components/BadExecution.xml:10:19: /component_profile/execution_semantics/"
      "cpu_affinity: bad cpu_affinity '2048': expected an integer from 0 to 1023",
      "invalid/components/BadExecution.xml:12:21: /component_profile/execution_semantics/"
      "lifecycle_type: bad lifecycle_type 'paused' (accepted: start, stop, active, running, "
      "ACTIVE, inactive, stopped, READY, INACTIVE)",
      "invalid/components/ZeroPeriod.xml:7:13: /component_profile/execution_semantics/period: "
      "period must be greater than 0 ms for a periodic component",
      "invalid/components/ZeroPeriod.xml:8:5: /component_profile/execution_semantics/policy: "
      "SCHED_FIFO needs a <priority> from 1 to 99",
      "invalid/components/RoundRobin.xml:7:13: /component_profile/execution_semantics/period: bad "
      "period '-1.5': expected a number of milliseconds, 0 or more",
      "invalid/components/RoundRobin.xml:8:15: /component_profile/execution_semantics/priority: "
      "priority 0 is out of range for SCHED_RR (1 to 99)",
      "invalid/components/RoundRobin.xml:10:10: /component_profile/execution_semantics/cpu: bad "
      "cpu '-1': expected an integer from 0 to 1023",
  }));
}

TEST_F(ProfileLoader, BadPortsPropertiesAndTypes) {
  EXPECT_FALSE(load("invalid/bad_ports.xml").has_value());
  EXPECT_EQ(messages(), (std::vector<std::string>{
      "invalid/components/BadPorts.xml:2:1: /component_profile: missing <name>",
      "invalid/components/BadPorts.xml:8:5: /component_profile/properties/property[1]: missing "
      "attribute 'name'",
      "invalid/components/BadPorts.xml:9:38: /component_profile/properties/property[2]: bad value "
      "'fast' for property 'rate' of type 'int'",
      "invalid/components/BadPorts.xml:10:21: /component_profile/properties/property[3]/@name: "
      "duplicate property 'rate': already given at line 9",
      "invalid/components/BadPorts.xml:11:42: /component_profile/properties/property[4]: bad value "
      "'yes' for property 'enabled' of type 'bool'",
      "invalid/components/BadPorts.xml:12:41: /component_profile/properties/property[5]: bad value "
      "'1.5x' for property 'gain' of type 'double'",
      "invalid/components/BadPorts.xml:71:5: /component_profile/ports/datport: warning: unknown "
      "element <datport>",
      "invalid/components/BadPorts.xml:16:5: /component_profile/ports/data_port[1]: missing <name>",
      "invalid/components/BadPorts.xml:20:5: /component_profile/ports/data_port[2]: missing "
      "<data_type>",
      "invalid/components/BadPorts.xml:20:5: /component_profile/ports/data_port[2]: missing "
      "<usage>",
      "invalid/components/BadPorts.xml:26:14: /component_profile/ports/data_port[3]/usage: bad "
      "usage 'inout' for a data port (accepted: input, output)",
      "invalid/components/BadPorts.xml:29:13: /component_profile/ports/data_port[4]/name: "
      "duplicate port name 'p1': already used at line 21",
      "invalid/components/BadPorts.xml:37:24: /component_profile/ports/data_port[5]/"
      "queueing_policy: bad queueing policy 'LIFO' (accepted: data, LAST, OPROS_LAST, buffer, "
      "circular, FIFO, OPROS_FIFO)",
      "invalid/components/BadPorts.xml:38:19: /component_profile/ports/data_port[5]/queue_size: "
      "bad depth '-1': expected an integer from 1 to 4294967295",
      "invalid/components/BadPorts.xml:46:7: /component_profile/ports/data_port[6]/policy_param: "
      "warning: unknown policy_param 'lifo' (known: size)",
      "invalid/components/BadPorts.xml:45:19: /component_profile/ports/data_port[6]/queue_size: a "
      "depth of 4 contradicts the data policy (latest value only); use buffer or circular for a "
      "queue",
      "invalid/components/BadPorts.xml:54:7: /component_profile/ports/data_port[7]/policy_param: "
      "duplicate <policy_param name=\"size\">: depth already given at line 53",
      "invalid/components/BadPorts.xml:64:14: /component_profile/ports/service_port/usage: bad "
      "usage 'input' for a service port (accepted: required, provided)",
      "invalid/components/BadPorts.xml:65:7: /component_profile/ports/service_port/operation[1]: "
      "missing attribute 'name'",
      "invalid/components/BadPorts.xml:66:36: /component_profile/ports/service_port/operation[2]/"
      "@oneway: bad oneway 'yes' (accepted: true, false, 1, 0)",
      "invalid/components/BadPorts.xml:67:24: /component_profile/ports/service_port/operation[3]/"
      "@name: duplicate operation 'go': already given at line 66",
      "invalid/components/BadPorts.xml:68:51: /component_profile/ports/service_port/operation[4]/"
      "@reply: a oneway operation has no reply",
      "invalid/components/BadPorts.xml:25:18: /component_profile/ports/data_port[3]/data_type: "
      "unknown type 'wheelchair::Unknown'",
      "invalid/components/BadPorts.xml:69:38: /component_profile/ports/service_port/operation[5]/"
      "@request: unknown type 'wheelchair::Nope'",
  }));
}

TEST_F(ProfileLoader, BadConnections) {
  EXPECT_FALSE(load("invalid/bad_connections.xml").has_value());
  EXPECT_EQ(messages(), (std::vector<std::string>{
      "invalid/bad_connections.xml:32:7: /application_profile/port_connections/port_connection[1]/"
      "target: unknown component 'Nobody'",
      "invalid/bad_connections.xml:35:7: /application_profile/port_connections/port_connection[2]/"
      "source: component 'Joystick' has no port 'joystik'",
      "invalid/bad_connections.xml:39:7: /application_profile/port_connections/port_connection[3]/"
      "source: Control.motor is a service port; this is a data connection",
      "invalid/bad_connections.xml:43:7: /application_profile/port_connections/port_connection[4]/"
      "source: Joystick.joystick is a data port; this is a service connection (port_type is "
      "missing: OPRoS's default is a service connection)",
      "invalid/bad_connections.xml:44:7: /application_profile/port_connections/port_connection[4]/"
      "target: Control.joystick is a data port; this is a service connection (port_type is "
      "missing: OPRoS's default is a service connection)",
      "invalid/bad_connections.xml:47:7: /application_profile/port_connections/port_connection[5]/"
      "source: Control.joystick is an input port; a data connection's source must be an output "
      "port",
      "invalid/bad_connections.xml:52:7: /application_profile/port_connections/port_connection[6]/"
      "target: Control.reference is an output port; a data connection's target must be an input "
      "port",
      "invalid/bad_connections.xml:54:5: /application_profile/port_connections/port_connection[7]: "
      "type mismatch: Joystick.joystick is 'wheelchair::Joystick' but Motor.reference is "
      "'::wheelchair::Reference'",
      "invalid/bad_connections.xml:65:7: /application_profile/port_connections/port_connection[9]/"
      "source: Motor.motor is a provided port; a service connection's source must be a required "
      "port",
      "invalid/bad_connections.xml:66:7: /application_profile/port_connections/port_connection[9]/"
      "target: Control.motor is a required port; a service connection's target must be a "
      "provided port",
      "invalid/bad_connections.xml:68:5: /application_profile/port_connections/"
      "port_connection[10]: service interface mismatch: Control.motor is "
      "'wheelchair::MotorService' but OtherMotor.other is 'wheelchair::OtherService'",
      "invalid/bad_connections.xml:72:5: /application_profile/port_connections/"
      "port_connection[11]: operation 'set_gain' mismatch: Control2.motor has "
      "(wheelchair::Gain) -> wheelchair::Status but OtherMotor.motor has (wheelchair::Gain) -> ()",
      "invalid/bad_connections.xml:72:5: /application_profile/port_connections/"
      "port_connection[11]: operation 'stop' of Control2.motor is not provided by "
      "OtherMotor.motor",
      "invalid/bad_connections.xml:76:50: /application_profile/port_connections/"
      "port_connection[12]/@policy: policy applies only to data and event connections",
      "invalid/bad_connections.xml:76:65: /application_profile/port_connections/"
      "port_connection[12]/@depth: depth applies only to data and event connections",
      "invalid/bad_connections.xml:77:7: /application_profile/port_connections/"
      "port_connection[12]/source: required port Control2.motor is already connected to "
      "OtherMotor.motor (line 72)",
      "invalid/bad_connections.xml:80:60: /application_profile/port_connections/"
      "port_connection[13]/@depth: a depth needs a buffer or circular policy, but this "
      "connection uses the data policy (latest value only)",
      "invalid/bad_connections.xml:84:46: /application_profile/port_connections/"
      "port_connection[14]/@depth: a depth needs a buffer or circular policy, but the input port "
      "Motor.joystick_monitor uses the data policy (latest value only)",
  }));
}

TEST_F(ProfileLoader, RelativePathIsStoredAbsolute) {
  const fs::path relative = fs::relative(profiles_dir() / "valid_app.xml", fs::current_path());
  const auto app = load_application_profile(relative, types_, options_, diagnostics_);
  ASSERT_TRUE(app.has_value()) << ::testing::PrintToString(messages());
  EXPECT_TRUE(app->file.is_absolute());
  EXPECT_EQ(app->file, profiles_dir() / "valid_app.xml");
  EXPECT_EQ(app->components[0].where.file, (profiles_dir() / "valid_app.xml").string());
}

TEST_F(ProfileLoader, EarlierErrorsDoNotFailALaterLoad) {
  diagnostics_.error({"other.xml", 1, 1}, "", "an earlier problem");
  EXPECT_TRUE(load("valid_app.xml").has_value());
  EXPECT_EQ(diagnostics_.error_count(), 1U);
}

TEST(ProfileNames, ToString) {
  EXPECT_EQ(to_string(PortKind::data), "data");
  EXPECT_EQ(to_string(PortKind::service), "service");
  EXPECT_EQ(to_string(PortKind::event), "event");
  EXPECT_EQ(to_string(PortDirection::input), "input");
  EXPECT_EQ(to_string(PortDirection::output), "output");
  EXPECT_EQ(to_string(PortDirection::provided), "provided");
  EXPECT_EQ(to_string(PortDirection::required), "required");
  EXPECT_EQ(to_string(QueuePolicy::data), "data");
  EXPECT_EQ(to_string(QueuePolicy::buffer), "buffer");
  EXPECT_EQ(to_string(QueuePolicy::circular), "circular");
  EXPECT_EQ(to_string(ExecutionType::periodic), "periodic");
  EXPECT_EQ(to_string(ExecutionType::periodic_exclusive), "periodic-exclusive");
  EXPECT_EQ(to_string(ExecutionType::aperiodic), "aperiodic");
  EXPECT_EQ(to_string(ExecutionType::passive), "passive");
}

// Every spelling of every enumerated element, through a one-component application written
// to a scratch folder.
class ProfileAliases : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::path(::testing::TempDir()) /
           (std::string("polyport_profile_") + info->name() + "_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    dir_ = fs::weakly_canonical(dir_);  // as the loader reports it
  }
  void TearDown() override { fs::remove_all(dir_); }

  // Writes `text` (component_profile content) and an application using it; returns the
  // loaded component profile, or nothing with the diagnostics kept.
  std::optional<ComponentProfile> load_component(const std::string& text,
                                                 const std::string& prefix = "") {
    write(dir_ / "Comp.xml", prefix +
                                 "<component_profile>\n  <name>Comp</name>\n"
                                 "  <model>lcm</model>\n" +
                                 text + "</component_profile>\n");
    write(dir_ / "app.xml",
          "<application_profile>\n  <name>app</name>\n  <subcomponents>\n    <subcomponent>\n"
          "      <name>C</name>\n      <reference>Comp.xml</reference>\n    </subcomponent>\n"
          "  </subcomponents>\n</application_profile>\n");
    TypeRegistry types;
    diagnostics_ = Diagnostics();
    const auto app = load_application_profile(dir_ / "app.xml", types, LoadOptions{}, diagnostics_);
    if (!app) return std::nullopt;
    return app->components.at(0).profile;
  }

  std::vector<std::string> messages() const { return rendered(diagnostics_, dir_); }

  static void write(const fs::path& file, const std::string& text) {
    std::ofstream out(file, std::ios::binary);
    out << text;
  }

  fs::path dir_;
  Diagnostics diagnostics_;
};

TEST_F(ProfileAliases, ExecutionTypes) {
  const std::vector<std::pair<std::string, ExecutionType>> cases = {
      {"periodic", ExecutionType::periodic},
      {"periodic-shared", ExecutionType::periodic},
      {"periodic-exclusive", ExecutionType::periodic_exclusive},
      {"aperiodic", ExecutionType::aperiodic},
      {"non-periodic", ExecutionType::aperiodic},
      {"passive", ExecutionType::passive},
  };
  for (const auto& [text, expected] : cases) {
    SCOPED_TRACE(text);
    // Surrounding blanks are not part of the value.
    const auto profile = load_component("  <execution_semantics><type> " + text +
                                        " </type></execution_semantics>\n");
    ASSERT_TRUE(profile.has_value()) << ::testing::PrintToString(messages());
    EXPECT_EQ(profile->execution.type, expected);
  }
}

TEST_F(ProfileAliases, PassiveAndAperiodicMayHaveNoPeriod) {
  for (const std::string type : {"passive", "aperiodic"}) {
    SCOPED_TRACE(type);
    const auto profile = load_component("  <execution_semantics><type>" + type +
                                        "</type><period>0</period></execution_semantics>\n");
    ASSERT_TRUE(profile.has_value()) << ::testing::PrintToString(messages());
    EXPECT_EQ(profile->execution.period_ms, 0.0);
  }
}

TEST_F(ProfileAliases, SchedulingPolicies) {
  const std::vector<std::pair<std::string, SchedPolicy>> cases = {
      {"SCHED_OTHER", SchedPolicy::other}, {"SCHED_FIFO", SchedPolicy::fifo},
      {"SCHED_RR", SchedPolicy::rr},       {"OTHER", SchedPolicy::other},
      {"FIFO", SchedPolicy::fifo},         {"RR", SchedPolicy::rr},
  };
  for (const auto& [text, expected] : cases) {
    SCOPED_TRACE(text);
    const auto profile = load_component("  <execution_semantics><policy>" + text +
                                        "</policy><priority>10</priority></execution_semantics>\n");
    ASSERT_TRUE(profile.has_value()) << ::testing::PrintToString(messages());
    EXPECT_EQ(profile->execution.policy, expected);
    EXPECT_EQ(profile->execution.priority, 10);
  }
}

TEST_F(ProfileAliases, LifecycleTypes) {
  const std::vector<std::pair<std::string, InitialState>> cases = {
      {"start", InitialState::active},      {"stop", InitialState::inactive},
      {"active", InitialState::active},     {"running", InitialState::active},
      {"ACTIVE", InitialState::active},     {"inactive", InitialState::inactive},
      {"stopped", InitialState::inactive},  {"READY", InitialState::inactive},
      {"INACTIVE", InitialState::inactive},
  };
  for (const auto& [text, expected] : cases) {
    SCOPED_TRACE(text);
    const auto profile = load_component("  <execution_semantics><lifecycle_type>" + text +
                                        "</lifecycle_type></execution_semantics>\n");
    ASSERT_TRUE(profile.has_value()) << ::testing::PrintToString(messages());
    EXPECT_EQ(profile->initial_state, expected);
  }
}

TEST_F(ProfileAliases, QueuePolicies) {
  const std::vector<std::pair<std::string, QueuePolicy>> cases = {
      {"data", QueuePolicy::data},         {"LAST", QueuePolicy::data},
      {"OPROS_LAST", QueuePolicy::data},   {"buffer", QueuePolicy::buffer},
      {"circular", QueuePolicy::circular}, {"FIFO", QueuePolicy::circular},
      {"OPROS_FIFO", QueuePolicy::circular},
  };
  for (const auto& [text, expected] : cases) {
    SCOPED_TRACE(text);
    const auto profile = load_component(
        "  <ports><data_port><name>in</name><data_type>double</data_type><usage>input</usage>"
        "<queueing_policy>" + text + "</queueing_policy></data_port></ports>\n");
    ASSERT_TRUE(profile.has_value()) << ::testing::PrintToString(messages());
    const PortSpec& port = profile->ports.at(0);
    EXPECT_EQ(port.policy, expected);
    if (expected == QueuePolicy::data) {
      EXPECT_FALSE(port.depth.has_value());
    } else {
      EXPECT_EQ(port.depth, 16U);
    }
  }
}

TEST_F(ProfileAliases, ColumnsCountCharactersAndSkipTheByteOrderMark) {
  const auto profile = load_component("  <description>Größe</description><bogus/>\n",
                                      "\xEF\xBB\xBF");
  ASSERT_TRUE(profile.has_value()) << ::testing::PrintToString(messages());
  EXPECT_EQ(messages(), (std::vector<std::string>{
      "Comp.xml:4:35: /component_profile/bogus: warning: unknown element <bogus>",
  }));
  EXPECT_EQ(profile->where.line, 1U);
  EXPECT_EQ(profile->where.column, 1U);
}

TEST(ProfileSchema, FixturesAgainstTheXsd) {
  if (std::system("xmllint --version > /dev/null 2>&1") != 0) {
    GTEST_SKIP() << "xmllint not installed (libxml2-utils)";
  }
  const auto validates = [](const fs::path& file) {
    const std::string command = "xmllint --noout --schema '" + schema_file().string() + "' '" +
                                file.string() + "' > /dev/null 2>&1";
    return std::system(command.c_str()) == 0;
  };
  const fs::path dir = profiles_dir();
  for (const char* valid : {"valid_app.xml", "components/Joystick.xml", "components/Control.xml",
                            "components/Motor.xml", "components/OprosAliases.xml"}) {
    EXPECT_TRUE(validates(dir / valid)) << valid;
  }
  // The schema is strict where the loader only warns, and checks what XML Schema can express.
  for (const char* invalid : {"aliases_app.xml", "invalid/bad_app_fields.xml",
                              "invalid/bad_connections.xml", "invalid/components/BadPorts.xml",
                              "invalid/components/BadExecution.xml"}) {
    EXPECT_FALSE(validates(dir / invalid)) << invalid;
  }
}

}  // namespace
