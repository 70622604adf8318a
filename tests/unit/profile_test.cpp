// The profile loader against the fixtures in tests/data/profiles: valid profiles read into
// the expected structs, and every invalid profile gives exactly the expected diagnostics
// (file names shown relative to tests/data/profiles).

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "polyport/base/diagnostics.hpp"
#include "polyport/profile/profile.hpp"
#include "polyport/runtime/model.hpp"
#include "polyport/types/types.hpp"
#include "dds_model.hpp"
#include "dds_settings.hpp"

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

  // The DDS models read their own elements (<dds>, <topic>, <qos>, dds_request / dds_reply).
  ProfileLoader() {
    models_.add(std::make_unique<dds::DdsModel>("cyclonedds", dds::DdsModel::DomainFactory(), ""));
    models_.add(std::make_unique<dds::DdsModel>("fastdds", dds::DdsModel::DomainFactory(), ""));
    options_.models = &models_;
  }

  TypeRegistry types_;
  Diagnostics diagnostics_;
  ModelRegistry models_;
  LoadOptions options_{{profiles_dir() / "libs"}};
};

// What a DDS model read from a component profile.
const dds::DdsSettings& dds_of(const ComponentProfile& profile) { return *dds::dds_settings(profile); }

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

// pugixml alone reads these comments; xmllint (and the XSD check) refuses the file, and so does
// the loader, at the first forbidden dash.
TEST_F(ProfileLoader, DoubleHyphenInACommentIsASyntaxError) {
  EXPECT_FALSE(load("invalid/comment_dashes.xml").has_value());
  EXPECT_EQ(messages(), (std::vector<std::string>{
      "invalid/comment_dashes.xml:5:17: XML syntax error: '--' is not allowed inside a comment (nor a '-' right "
      "before its '-->')",
      "invalid/comment_dashes.xml:8:24: XML syntax error: '--' is not allowed inside a comment (nor a '-' right "
      "before its '-->')",
  }));
}

// CRLF line ends: the place is counted in the file as written.
TEST_F(ProfileLoader, DoubleHyphenInACrlfCommentIsReportedWhereItIs) {
  EXPECT_FALSE(load("invalid/comment_dashes_crlf.xml").has_value());
  EXPECT_EQ(messages(), (std::vector<std::string>{
      "invalid/comment_dashes_crlf.xml:3:45: XML syntax error: '--' is not allowed inside a comment (nor a '-' "
      "right before its '-->')",
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
      "'invalid/types/Motor.msg' (supported: .idl, .lcm, .dbc)",
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
      // Different types map by name when they can; these cannot, and the message says why.
      "invalid/bad_connections.xml:54:5: /application_profile/port_connections/port_connection[7]: "
      "type mismatch: Joystick.joystick is 'wheelchair::Joystick' but Motor.reference is "
      "'::wheelchair::Reference': target fields 'left', 'right' of 'wheelchair::Reference' have no "
      "source in 'wheelchair::Joystick' (source fields: x, y)",
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

// Mappings (tests/data/profiles/mapping): the loader reads <mapping>, compiles a program for
// every data or event connection whose ends differ in type (or that has a <mapping>), and
// the programs it compiled run here on hand-built flat samples.
class ProfileMappings : public ProfileLoader {
 protected:
  // The offset of a field in a registered type ("a.x"; no indices).
  std::uint32_t at(std::string_view type_name, std::string_view path) {
    const Type* type = types_.find(type_name);
    EXPECT_NE(type, nullptr) << type_name;
    std::uint32_t offset = 0;
    while (type != nullptr && !path.empty()) {
      const std::size_t dot = path.find('.');
      const Field* field = type->find_field(path.substr(0, dot));
      EXPECT_NE(field, nullptr) << path;
      if (field == nullptr) return 0;
      offset += field->offset;
      type = &field->type->resolved();
      path = dot == std::string_view::npos ? std::string_view() : path.substr(dot + 1);
    }
    return offset;
  }

  template <class T>
  static void put(std::vector<std::byte>& sample, std::uint32_t offset, T value) {
    std::memcpy(sample.data() + offset, &value, sizeof value);
  }
  template <class T>
  static T get(const std::vector<std::byte>& sample, std::uint32_t offset) {
    T value;
    std::memcpy(&value, sample.data() + offset, sizeof value);
    return value;
  }

  // Runs a connection's program on `source` into a target of `capacity` bytes.
  static std::vector<std::byte> run(const ConnectionSpec& connection, const std::vector<std::byte>& source,
                                    std::uint32_t capacity) {
    std::vector<std::byte> target(capacity, std::byte{0xAB});
    std::uint32_t size = 0;
    EXPECT_TRUE(connection.program->run(source.data(), static_cast<std::uint32_t>(source.size()),
                                        target.data(), capacity, size));
    return target;
  }
};

TEST_F(ProfileMappings, CompilesAProgramWhereTheTypesDifferOrAMappingIsGiven) {
  const auto app = load("mapping/valid_app.xml");
  ASSERT_TRUE(app.has_value()) << ::testing::PrintToString(messages());
  EXPECT_TRUE(diagnostics_.all().empty()) << ::testing::PrintToString(messages());
  ASSERT_EQ(app->connections.size(), 7U);

  // Sensor.odom -> Planner.state: units, a rename, a constant; the rest by name.
  const ConnectionSpec& state = app->connections[0];
  ASSERT_TRUE(state.mapping.has_value());
  EXPECT_TRUE(state.mapping->by_name);
  ASSERT_EQ(state.mapping->rules.size(), 4U);
  const MappingRule& speed = state.mapping->rules[0];
  EXPECT_EQ(speed.kind, MappingRule::Kind::copy);
  EXPECT_EQ(speed.target, "speed_mps");
  EXPECT_EQ(speed.source, "speed_kmh");
  EXPECT_EQ(speed.from_unit, "km/h");
  EXPECT_EQ(speed.to_unit, "m/s");
  EXPECT_EQ(speed.where.line, 16U);
  EXPECT_EQ(speed.where.column, 9U);
  EXPECT_EQ(speed.element_path,
            "/application_profile/port_connections/port_connection[1]/mapping/field[1]");
  EXPECT_EQ(state.mapping->rules[3].kind, MappingRule::Kind::constant);
  EXPECT_EQ(state.mapping->rules[3].value, "1.5");
  ASSERT_NE(state.program, nullptr);
  std::vector<std::byte> odometry(types_.find("nav::Odometry")->size, std::byte{0});
  put(odometry, at("nav::Odometry", "speed_kmh"), 36.0);
  put(odometry, at("nav::Odometry", "heading_deg"), 90.0);
  put(odometry, at("nav::Odometry", "position") + 8, -4.0);
  put(odometry, at("nav::Odometry", "mode"), std::int32_t{2});  // BRAKE
  std::memcpy(odometry.data() + at("nav::Odometry", "frame"), "map", 3);
  put(odometry, at("nav::Odometry", "seq"), std::int32_t{-7});
  const std::uint32_t state_size = types_.find("nav::State")->size;
  const auto mapped = run(state, odometry, state_size + 16);
  EXPECT_DOUBLE_EQ(get<double>(mapped, at("nav::State", "speed_mps")), 10.0);
  EXPECT_DOUBLE_EQ(get<double>(mapped, at("nav::State", "heading_rad")), 1.5707963267948966);
  EXPECT_EQ(get<double>(mapped, at("nav::State", "xy") + 8), -4.0);
  EXPECT_EQ(get<std::int32_t>(mapped, at("nav::State", "mode")), 0);  // BRAKE in nav::Gear
  const auto frame = get<FlatSpan>(mapped, at("nav::State", "frame"));
  EXPECT_EQ(frame.offset, state_size);  // the tail starts after the fixed part
  EXPECT_EQ(std::string(reinterpret_cast<const char*>(mapped.data() + frame.offset), frame.count), "map");
  EXPECT_EQ(get<std::int64_t>(mapped, at("nav::State", "seq")), -7);
  EXPECT_EQ(get<double>(mapped, at("nav::State", "gain")), 1.5);

  // Sensor.imu -> Planner.accel: an affine transform into a struct; seq by name.
  const ConnectionSpec& accel = app->connections[1];
  ASSERT_TRUE(accel.mapping.has_value());
  const MappingRule& transform = accel.mapping->rules.at(0);
  EXPECT_EQ(transform.kind, MappingRule::Kind::affine);
  EXPECT_EQ(transform.matrix_rows, 3U);
  EXPECT_EQ(transform.matrix_cols, 3U);
  EXPECT_EQ(transform.matrix, (std::vector<double>{0, 1, 0, 1, 0, 0, 0, 0, -1}));
  EXPECT_EQ(transform.translation, (std::vector<double>{0, 0, 9.81}));
  ASSERT_NE(accel.program, nullptr);
  std::vector<std::byte> imu(types_.find("nav::Imu")->size, std::byte{0});
  put(imu, at("nav::Imu", "accel"), 1.0);
  put(imu, at("nav::Imu", "accel") + 8, 2.0);
  put(imu, at("nav::Imu", "accel") + 16, 3.0);
  put(imu, at("nav::Imu", "seq"), std::int32_t{5});
  const auto accelerations = run(accel, imu, types_.find("nav::Accel")->size);
  EXPECT_EQ(get<double>(accelerations, at("nav::Accel", "a.x")), 2.0);
  EXPECT_EQ(get<double>(accelerations, at("nav::Accel", "a.y")), 1.0);
  EXPECT_DOUBLE_EQ(get<double>(accelerations, at("nav::Accel", "a.z")), 6.81);
  EXPECT_EQ(get<std::int32_t>(accelerations, at("nav::Accel", "seq")), 5);

  // Different types, no <mapping>: by name.
  EXPECT_FALSE(app->connections[2].mapping.has_value());
  EXPECT_NE(app->connections[2].program, nullptr);
  // The same type and no <mapping>: nothing to do.
  EXPECT_EQ(app->connections[3].program, nullptr);
  // The same type with a <mapping>: it applies.
  ASSERT_NE(app->connections[4].program, nullptr);
  std::vector<std::byte> fahrenheit(8);
  put(fahrenheit, 0, 212.0);
  EXPECT_DOUBLE_EQ(get<double>(run(app->connections[4], fahrenheit, 8), 0), 100.0);
  // allow_narrowing="1", and numbers with an exponent.
  const MappingRule& narrowing = app->connections[5].mapping->rules.at(0);
  EXPECT_TRUE(narrowing.allow_narrowing);
  EXPECT_EQ(narrowing.scale, 0.5);
  EXPECT_EQ(narrowing.offset, -0.1);
  ASSERT_NE(app->connections[5].program, nullptr);
  EXPECT_EQ(get<float>(run(app->connections[5], fahrenheit, 4), 0), 105.9f);
  // An event without a payload has nothing to map.
  EXPECT_EQ(app->connections[6].program, nullptr);
}

TEST_F(ProfileMappings, EveryProblemAtItsPlace) {
  EXPECT_FALSE(load("mapping/invalid_app.xml").has_value());
  const std::string file = "mapping/invalid_app.xml:";
  const std::string connection = "/application_profile/port_connections/port_connection";
  EXPECT_EQ(messages(), (std::vector<std::string>{
      // Reading: what a <mapping> says, before any type is looked at.
      file + "26:25: " + connection + "[3]/mapping/@by_name: bad by_name 'maybe' (accepted: true, "
      "false, 1, 0)",
      file + "39:42: " + connection + "[3]/mapping/field[13]/@units: warning: unknown attribute 'units'",
      file + "40:9: " + connection + "[3]/mapping/fields: warning: unknown element <fields>",
      file + "27:9: " + connection + "[3]/mapping/field[1]: missing attribute 'target'",
      file + "28:49: " + connection + "[3]/mapping/field[2]/@value: source and value exclude each other",
      file + "29:9: " + connection + "[3]/mapping/field[3]: missing attribute 'source' or 'value'",
      file + "30:49: " + connection + "[3]/mapping/field[4]/@scale: bad scale 'fast': expected a number",
      file + "31:53: " + connection + "[3]/mapping/field[5]/@transform: bad transform 'rotate' "
      "(accepted: linear, affine)",
      file + "32:50: " + connection + "[3]/mapping/field[6]/@matrix: matrix needs "
      "transform=\"linear\" or \"affine\"",
      file + "33:69: " + connection + "[3]/mapping/field[7]/@matrix: bad matrix: row 2 has 2 entries "
      "but row 1 has 3",
      file + "34:69: " + connection + "[3]/mapping/field[8]/@matrix: bad matrix: 'x' is not a number",
      file + "34:9: " + connection + "[3]/mapping/field[8]: missing attribute 'translation' (needed by "
      "transform=\"affine\")",
      file + "35:69: " + connection + "[3]/mapping/field[9]/@matrix: bad matrix: an entry is missing",
      file + "35:88: " + connection + "[3]/mapping/field[9]/@translation: a translation needs "
      "transform=\"affine\"",
      file + "36:46: " + connection + "[3]/mapping/field[10]/@scale: scale does not apply to a "
      "constant (value)",
      file + "37:84: " + connection + "[3]/mapping/field[11]/@offset: offset does not apply to a "
      "transform (fold it into the matrix)",
      file + "38:59: " + connection + "[3]/mapping/field[12]/@allow_narrowing: bad allow_narrowing "
      "'yes' (accepted: true, false, 1, 0)",
      file + "59:7: " + connection + "[6]/mapping[2]: duplicate <mapping>: already given at line 56",
      // Connections: without a <mapping>, by name, which does not narrow.
      file + "10:5: " + connection + "[1]: type mismatch: Sensor.wide is 'nav::Wide' but "
      "Planner.narrow is 'nav::Narrow': narrowing source 'value' ('double') to target 'value' "
      "('float') needs allow_narrowing=\"true\"",
      // One error at the connection that says why, then each faulty rule at its <field>.
      file + "14:5: " + connection + "[2]: type mismatch: Sensor.odom is 'nav::Odometry' but "
      "Planner.state is 'nav::State': target field 'gain' of 'nav::State' has no source in "
      "'nav::Odometry' (source fields: speed_kmh, heading_deg, position, mode, frame, seq); 2 rules "
      "of the <mapping> are at fault (reported at their <field>s)",
      file + "18:9: " + connection + "[2]/mapping/field[1]: unknown unit 'furlong' (known: rad, deg, "
      "m, cm, mm, km, s, ms, us, ns, m/s, km/h, mph, rad/s, deg/s, rpm, kg, g, K, degC, degF, Pa, "
      "kPa, bar, psi)",
      file + "19:9: " + connection + "[2]/mapping/field[2]: source 'heading' not found in "
      "'nav::Odometry' (fields: speed_kmh, heading_deg, position, mode, frame, seq)",
      // The unreadable <mapping> of connection 3 is not compiled: no type mismatch there.
      file + "46:7: " + connection + "[4]/mapping: a mapping applies only to data and event "
      "connections",
      file + "51:7: " + connection + "[5]/mapping: a mapping needs a data type on both ports",
      // The same type on both ends: only the rule is at fault.
      file + "57:9: " + connection + "[6]/mapping[1]/field: cannot convert 'degC' (temperature) to "
      "'m' (length)",
  }));
}

// <watchdog> on a data connection: times in nanoseconds, the upstream end, and the safe
// value compiled for the target's type (constants only, the rest zero).
TEST_F(ProfileMappings, ReadsWatchdogsAndCompilesTheirSafeValues) {
  const auto app = load("watchdog/valid_app.xml");
  ASSERT_TRUE(app.has_value()) << ::testing::PrintToString(messages());
  EXPECT_TRUE(diagnostics_.all().empty()) << ::testing::PrintToString(messages());
  ASSERT_EQ(app->connections.size(), 4U);

  const ConnectionSpec& temp = app->connections[0];
  EXPECT_FALSE(temp.rate_limit_per_second.has_value());
  EXPECT_TRUE(temp.deadbands.empty());
  ASSERT_TRUE(temp.watchdog.has_value());
  EXPECT_EQ(temp.watchdog->deadline_ns, 20'000'000);
  EXPECT_EQ(temp.watchdog->max_age_ns, 0);
  EXPECT_FALSE(temp.watchdog->upstream.has_value());
  EXPECT_EQ(temp.watchdog->where.line, 15U);
  ASSERT_NE(temp.watchdog->safe_program, nullptr);
  const std::vector<std::byte> any(8, std::byte{0x55});  // the program reads nothing of it
  std::vector<std::byte> safe(8);
  std::uint32_t size = 0;
  ASSERT_TRUE(temp.watchdog->safe_program->run(any.data(), 8, safe.data(), 8, size));
  EXPECT_EQ(size, 8U);
  EXPECT_EQ(get<double>(safe, 0), -40.0);

  const ConnectionSpec& odom = app->connections[1];
  ASSERT_TRUE(odom.watchdog.has_value());
  EXPECT_EQ(odom.watchdog->deadline_ns, 2'500'000);
  EXPECT_EQ(odom.watchdog->max_age_ns, 50'000'000);
  ASSERT_TRUE(odom.watchdog->upstream.has_value());
  EXPECT_EQ(odom.watchdog->upstream->component, "Sensor");
  EXPECT_EQ(odom.watchdog->upstream->port, "imu");
  ASSERT_NE(odom.watchdog->safe_program, nullptr);  // no <safe_value>: all zero
  const std::uint32_t odometry_size = types_.find("nav::Odometry")->size;
  std::vector<std::byte> source(odometry_size, std::byte{0x55}), zero(odometry_size + 16, std::byte{0x55});
  ASSERT_TRUE(odom.watchdog->safe_program->run(source.data(), odometry_size, zero.data(), odometry_size + 16, size));
  EXPECT_EQ(size, odometry_size);
  for (std::uint32_t i = 0; i < size; ++i) ASSERT_EQ(zero[i], std::byte{0}) << "byte " << i;

  // A rate limit and a deadband of two fields, on a connection without a watchdog.
  const ConnectionSpec& accel = app->connections[2];
  EXPECT_FALSE(accel.watchdog.has_value());
  ASSERT_TRUE(accel.rate_limit_per_second.has_value());
  EXPECT_EQ(*accel.rate_limit_per_second, 12.5);
  ASSERT_EQ(accel.deadbands.size(), 2U);
  EXPECT_EQ(accel.deadbands[0].field, "accel[2]");
  EXPECT_EQ(accel.deadbands[0].threshold, 0.5);
  EXPECT_EQ(accel.deadbands[1].field, "seq");
  EXPECT_EQ(accel.deadbands[1].threshold, 0.0);
  EXPECT_EQ(accel.deadbands[1].where.line, 32U);
  EXPECT_FALSE(accel.poll_period_ms.has_value());

  // Polling a source of another model (its rate is its own): accepted.
  const ConnectionSpec& pose = app->connections[3];
  ASSERT_TRUE(pose.poll_period_ms.has_value());
  EXPECT_EQ(*pose.poll_period_ms, 2.5);
  EXPECT_FALSE(pose.rate_limit_per_second.has_value());
}

// Polling an in-process periodic source slower than twice its rate is refused (JOrocos).
TEST_F(ProfileMappings, PollingSlowerThanTwiceTheSourcesRateIsRefused) {
  EXPECT_FALSE(load("watchdog/poll_app.xml").has_value());
  const std::string file = "watchdog/poll_app.xml:";
  const std::string connection = "/application_profile/port_connections/port_connection";
  EXPECT_EQ(messages(), (std::vector<std::string>{
      file + "21:7: " + connection + "[2]/poll: a connection either polls or has a rate limit, not both",
      file + "15:24: " + connection + "[1]/poll/@period_ms: polls every 6 ms, slower than twice the rate of "
      "Joystick (period 10 ms): poll every 5 ms or faster",
      file + "20:7: " + connection + "[2]/rate_limit: a rate limit applies only to data connections",
      file + "21:7: " + connection + "[2]/poll: polling applies only to data connections",
  }));
}

TEST_F(ProfileMappings, EveryWatchdogProblemAtItsPlace) {
  EXPECT_FALSE(load("watchdog/invalid_app.xml").has_value());
  const std::string file = "watchdog/invalid_app.xml:";
  const std::string connection = "/application_profile/port_connections/port_connection";
  const std::string expected_ms = ": expected milliseconds, a decimal above 0 and at most 86400000";
  EXPECT_EQ(messages(), (std::vector<std::string>{
      // Reading.
      file + "13:33: " + connection + "[1]/watchdog/@period: warning: unknown attribute 'period'",
      file + "13:7: " + connection + "[1]/watchdog: missing attribute 'deadline_ms' (how long the source may be "
      "silent)",
      file + "13:29: " + connection + "[1]/watchdog/@max_age_ms: bad max_age_ms '-1'" + expected_ms,
      file + "13:44: " + connection + "[1]/watchdog/kick: warning: unknown element <kick>",
      file + "18:30: " + connection + "[2]/watchdog/@deadline_ms: bad deadline_ms '0'" + expected_ms,
      file + "25:11: " + connection + "[3]/watchdog/safe_value/field: a safe value sets constants only: give "
      "'value', not 'source' or a transform",
      file + "64:31: " + connection + "[8]/rate_limit/@per_second: bad per_second '0': expected a decimal from 0.001 "
      "to 1000000",
      file + "68:36: " + connection + "[8]/deadband/field[3]/@threshold: bad threshold '-1': expected a number of "
      "0 or more",
      file + "69:9: " + connection + "[8]/deadband/field[4]: missing attribute 'name' (the number whose change "
      "lets a sample pass)",
      // Against the graph and the target's type.
      file + "33:9: " + connection + "[4]/watchdog/upstream: Planner.state is a data port (input); a "
      "watchdog's upstream must be an output data port",
      file + "34:9: " + connection + "[4]/watchdog/event: the type polyport::WatchdogEvent is not loaded: add "
      "config/types/watchdog_event.idl to the profile's <types>",
      file + "36:11: " + connection + "[4]/watchdog/safe_value/field[1]: target 'speed' not found in "
      "'nav::Odometry' (fields: speed_kmh, heading_deg, position, mode, frame, seq)",
      file + "37:11: " + connection + "[4]/watchdog/safe_value/field[2]: bad constant 'fast' for target "
      "'heading_deg' ('double'): expected a finite number",
      file + "38:11: " + connection + "[4]/watchdog/safe_value/field[3]: 'PARK' is not an enumerator of "
      "'nav::Mode' (enumerators: IDLE, DRIVE, BRAKE)",
      file + "46:34: " + connection + "[5]/watchdog/@max_age_ms: warning: max_age_ms is shorter than "
      "deadline_ms: every sample that arrives late enough to be within the deadline is replaced anyway",
      file + "47:9: " + connection + "[5]/watchdog/upstream: unknown component 'Nobody'",
      file + "48:9: " + connection + "[5]/watchdog/event: Sensor.tick is an event port (output); a watchdog's "
      "events go to an input event or data port",
      file + "54:7: " + connection + "[6]/watchdog: a watchdog applies only to data connections",
      file + "59:7: " + connection + "[7]/watchdog: a watchdog applies only to data connections",
      file + "66:9: " + connection + "[8]/deadband/field[1]: a deadband compares numbers; 'frame' of Sensor.odom "
      "is 'string<16>'",
      file + "67:9: " + connection + "[8]/deadband/field[2]: field 'position[2]' not found in 'nav::Odometry' of "
      "Sensor.odom ('position' is 'double[2]')",
      file + "70:9: " + connection + "[8]/deadband/field[5]: bad field '2x' (expected names and [index], e.g. "
      "a.b[1].c)",
      file + "71:9: " + connection + "[8]/deadband/field[6]: a deadband compares numbers; 'mode' of Sensor.odom "
      "is 'nav::Mode'",
      file + "77:7: " + connection + "[9]/rate_limit: a rate limit applies only to data connections",
      file + "78:7: " + connection + "[9]/deadband: a deadband applies only to data connections",
  }));
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
  // `instance`: more of the <subcomponent> element (line 7 of app.xml).
  std::optional<ComponentProfile> load_component(const std::string& text,
                                                 const std::string& prefix = "", const std::string& instance = "") {
    write(dir_ / "Comp.xml", prefix +
                                 "<component_profile>\n  <name>Comp</name>\n"
                                 "  <model>lcm</model>\n" +
                                 text + "</component_profile>\n");
    write(dir_ / "app.xml",
          "<application_profile>\n  <name>app</name>\n  <subcomponents>\n    <subcomponent>\n"
          "      <name>C</name>\n      <reference>Comp.xml</reference>\n" + instance + "    </subcomponent>\n"
          "  </subcomponents>\n</application_profile>\n");
    TypeRegistry types;
    diagnostics_ = Diagnostics();
    const auto app = load_application_profile(dir_ / "app.xml", types, LoadOptions{}, diagnostics_);
    if (!app) return std::nullopt;
    return app->components.at(0).profile;
  }

  std::vector<std::string> messages() const { return rendered(diagnostics_, dir_); }

  // The messages of a component (and instance) that must not load.
  std::vector<std::string> refused(const std::string& text, const std::string& instance = "") {
    EXPECT_FALSE(load_component(text, "", instance).has_value());
    return messages();
  }

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

TEST_F(ProfileAliases, SpinTail) {
  auto profile = load_component("  <execution_semantics><period>1</period></execution_semantics>\n");
  ASSERT_TRUE(profile.has_value()) << ::testing::PrintToString(messages());
  EXPECT_EQ(profile->execution.spin_us, 0);  // off by default
  profile = load_component(
      "  <execution_semantics><period>1</period><spin_us> 1000 </spin_us></execution_semantics>\n");
  ASSERT_TRUE(profile.has_value()) << ::testing::PrintToString(messages());
  EXPECT_EQ(profile->execution.spin_us, 1000);  // up to the whole period
  // A passive component has no period to spin before: accepted, not used.
  profile = load_component(
      "  <execution_semantics><type>passive</type><spin_us>50000</spin_us></execution_semantics>\n");
  ASSERT_TRUE(profile.has_value()) << ::testing::PrintToString(messages());
}

TEST_F(ProfileAliases, SpinTailErrors) {
  // The text's place, or the element's when it has none.
  for (const auto& [text, column] : std::vector<std::pair<std::string, std::string>>{
           {"-5", "33"}, {"2.5", "33"}, {"fast", "33"}, {"", "24"}}) {
    SCOPED_TRACE(text);
    EXPECT_FALSE(load_component("  <execution_semantics><spin_us>" + text +
                                "</spin_us></execution_semantics>\n")
                     .has_value());
    EXPECT_EQ(messages(), (std::vector<std::string>{
        "Comp.xml:4:" + column + ": /component_profile/execution_semantics/spin_us: bad spin_us '" + text +
        "': expected an integer number of microseconds, 0 or more"}));
  }
  EXPECT_FALSE(load_component("  <execution_semantics><period>2.5</period><spin_us>2501</spin_us>"
                              "</execution_semantics>\n")
                   .has_value());
  EXPECT_EQ(messages(), (std::vector<std::string>{
      "Comp.xml:4:53: /component_profile/execution_semantics/spin_us: spin_us 2501 is longer than "
      "the period (2500 us): expected 0 to the period"}));
  // A bad period is reported once; the spin tail is not checked against it.
  EXPECT_FALSE(load_component("  <execution_semantics><period>ten</period><spin_us>20000</spin_us>"
                              "</execution_semantics>\n")
                   .has_value());
  EXPECT_EQ(messages(), (std::vector<std::string>{
      "Comp.xml:4:32: /component_profile/execution_semantics/period: bad period 'ten': expected a "
      "number of milliseconds, 0 or more"}));
}

TEST_F(ProfileAliases, Phase) {
  auto profile = load_component("  <execution_semantics><period>10</period></execution_semantics>\n");
  ASSERT_TRUE(profile.has_value()) << ::testing::PrintToString(messages());
  EXPECT_FALSE(profile->execution.phase_ms.has_value());  // free: the cycles follow the start
  profile = load_component("  <execution_semantics><period>10</period><phase> 2.5 </phase></execution_semantics>\n");
  ASSERT_TRUE(profile.has_value()) << ::testing::PrintToString(messages());
  EXPECT_EQ(profile->execution.phase_ms, 2.5);
  profile = load_component("  <execution_semantics><period>10</period><phase>0</phase></execution_semantics>\n");
  ASSERT_TRUE(profile.has_value()) << ::testing::PrintToString(messages());
  EXPECT_EQ(profile->execution.phase_ms, 0.0);
}

TEST_F(ProfileAliases, PhaseErrors) {
  for (const auto& [text, column] : std::vector<std::pair<std::string, std::string>>{
           {"-1", "50"}, {"soon", "50"}, {"", "43"}}) {
    SCOPED_TRACE(text);
    EXPECT_EQ(refused("  <execution_semantics><period>10</period><phase>" + text + "</phase></execution_semantics>\n"),
              (std::vector<std::string>{
        "Comp.xml:4:" + column + ": /component_profile/execution_semantics/phase: bad phase '" + text +
        "': expected a number of milliseconds, 0 or more"}));
  }
  EXPECT_EQ(refused("  <execution_semantics><period>2.5</period><phase>2.5</phase></execution_semantics>\n"),
            (std::vector<std::string>{
      "Comp.xml:4:51: /component_profile/execution_semantics/phase: phase 2.5 ms is not shorter than the "
      "period (2.5 ms): expected 0 to less than the period"}));
}

// A subcomponent's own <execution_semantics>: where and when this instance runs, over what
// its component profile says.
TEST_F(ProfileAliases, AnInstanceSetsItsPhaseAndSchedulingOverItsComponentProfile) {
  const std::string component =
      "  <execution_semantics><period>10</period><policy>SCHED_FIFO</policy><priority>50</priority>"
      "<phase>1</phase><spin_us>100</spin_us></execution_semantics>\n";
  auto profile = load_component(component, "",
                                "      <execution_semantics><phase>6</phase><cpu>1</cpu><policy>RR</policy>"
                                "</execution_semantics>\n");
  ASSERT_TRUE(profile.has_value()) << ::testing::PrintToString(messages());
  EXPECT_EQ(profile->execution.phase_ms, 6.0);
  EXPECT_EQ(profile->execution.cpu, 1);
  EXPECT_EQ(profile->execution.policy, SchedPolicy::rr);
  EXPECT_EQ(profile->execution.priority, 50);  // the component profile's, still a real-time one
  EXPECT_EQ(profile->execution.period_ms, 10.0);
  EXPECT_EQ(profile->execution.spin_us, 100);
  // Without one, the component profile's.
  profile = load_component(component);
  ASSERT_TRUE(profile.has_value()) << ::testing::PrintToString(messages());
  EXPECT_EQ(profile->execution.phase_ms, 1.0);
  EXPECT_FALSE(profile->execution.cpu.has_value());
}

TEST_F(ProfileAliases, AnInstanceDoesNotChangeWhatItsComponentIsDesignedFor) {
  const std::string component = "  <execution_semantics><period>10</period></execution_semantics>\n";
  EXPECT_EQ(refused(component, "      <execution_semantics><period>5</period><phase>1</phase></execution_semantics>\n"),
            (std::vector<std::string>{
      "app.xml:7:28: /application_profile/subcomponents/subcomponent/execution_semantics/period: <period> belongs "
      "in the component profile; a subcomponent's <execution_semantics> sets only phase, priority, policy, cpu "
      "(cpu_affinity) and spin_us"}));
  // The instance's phase is checked against the component's period, where the instance wrote it.
  EXPECT_EQ(refused(component, "      <execution_semantics><phase>12</phase></execution_semantics>\n"),
            (std::vector<std::string>{
      "app.xml:7:35: /application_profile/subcomponents/subcomponent/execution_semantics/phase: phase 12 ms is "
      "not shorter than the period (10 ms): expected 0 to less than the period"}));
}

TEST_F(ProfileAliases, AnInstanceTurnedRealTimeNamesItsPriority) {
  // The component profile's priority 3 groups SCHED_OTHER components; it is no real-time one.
  const std::string component =
      "  <execution_semantics><period>10</period><priority>3</priority></execution_semantics>\n";
  EXPECT_EQ(refused(component, "      <execution_semantics><policy>FIFO</policy></execution_semantics>\n"),
            (std::vector<std::string>{
      "app.xml:7:28: /application_profile/subcomponents/subcomponent/execution_semantics/policy: SCHED_FIFO needs "
      "a <priority> from 1 to 99"}));
  const auto profile = load_component(
      component, "", "      <execution_semantics><policy>FIFO</policy><priority>40</priority></execution_semantics>\n");
  ASSERT_TRUE(profile.has_value()) << ::testing::PrintToString(messages());
  EXPECT_EQ(profile->execution.policy, SchedPolicy::fifo);
  EXPECT_EQ(profile->execution.priority, 40);
  // Where the component is described stays its profile's, for what the model says of it.
  EXPECT_EQ(fs::path(profile->execution.where.file).filename(), "Comp.xml");
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

// A DBC file with a message that cannot be used (overlapping signals, as real files have)
// loads with a warning; only a port that names that message is an error, with the reason.
TEST_F(ProfileAliases, UnusableDbcMessageIsAnErrorOnlyWhereAPortUsesIt) {
  write(dir_ / "bus.dbc",
        "BO_ 1 Good: 8 N\n SG_ A : 0|8@1+ (1,0) [0|0] \"\" N\n"
        "BO_ 2 Broken: 8 N\n SG_ A : 0|8@1+ (1,0) [0|0] \"\" N\n SG_ B : 4|8@1+ (1,0) [0|0] \"\" N\n"
        "SIG_GROUP_ 1 G 1 : A;\n");
  const std::string types = "  <types><file>bus.dbc</file></types>\n";
  const auto port = [](const std::string& type) {
    return "  <ports>\n    <data_port><name>p</name><data_type>" + type +
           "</data_type><usage>output</usage></data_port>\n  </ports>\n";
  };
  const std::vector<std::string> file_warnings = {
      "bus.dbc:5:6: warning: message 'Broken' cannot be used: signal 'B' overlaps signal 'A'",
      "bus.dbc:6:1: warning: SIG_GROUP_ statements are not used by polyport and are ignored (1 in this file)",
  };

  const auto good = load_component(types + port("bus::Good"));
  ASSERT_TRUE(good.has_value()) << ::testing::PrintToString(messages());
  EXPECT_EQ(messages(), file_warnings);

  EXPECT_FALSE(load_component(types + port("bus::Broken")).has_value());
  std::vector<std::string> expected = file_warnings;
  expected.push_back(
      "Comp.xml:6:41: /component_profile/ports/data_port/data_type: type 'bus::Broken' cannot be used: "
      "bus.dbc:5:6: signal 'B' overlaps signal 'A'");
  EXPECT_EQ(messages(), expected);
}

// The number, list and matrix spellings of a <field>, which the XSD's Number, NumberList and
// Matrix types accept too.
class ProfileMappingSyntax : public ProfileAliases {
 protected:
  // One connection V -> W with `fields` inside its <mapping>.
  std::optional<ConnectionSpec> load_mapping(const std::string& fields, const std::string& attributes = "") {
    write(dir_ / "types.idl", "struct V { double p[2]; double y; };\nstruct W { double a[2]; double y; };\n");
    write(dir_ / "Comp.xml",
          "<component_profile>\n  <name>Comp</name>\n  <model>lcm</model>\n"
          "  <types><file>types.idl</file></types>\n  <ports>\n"
          "    <data_port><name>out</name><data_type>V</data_type><usage>output</usage></data_port>\n"
          "    <data_port><name>in</name><data_type>W</data_type><usage>input</usage></data_port>\n"
          "  </ports>\n</component_profile>\n");
    write(dir_ / "app.xml",
          "<application_profile>\n  <name>app</name>\n  <subcomponents>\n    <subcomponent>\n"
          "      <name>C</name>\n      <reference>Comp.xml</reference>\n    </subcomponent>\n"
          "  </subcomponents>\n  <port_connections>\n    <port_connection port_type=\"data\">\n"
          "      <source component_name=\"C\" port_name=\"out\"/>\n"
          "      <target component_name=\"C\" port_name=\"in\"/>\n"
          "      <mapping" + attributes + ">" + fields + "</mapping>\n"
          "    </port_connection>\n  </port_connections>\n</application_profile>\n");
    TypeRegistry types;
    diagnostics_ = Diagnostics();
    const auto app = load_application_profile(dir_ / "app.xml", types, LoadOptions{}, diagnostics_);
    if (!app) return std::nullopt;
    return app->connections.at(0);
  }
};

TEST_F(ProfileMappingSyntax, MatrixSpellings) {
  const std::vector<std::pair<std::string, std::vector<double>>> cases = {
      {"1 0; 0 1", {1, 0, 0, 1}},
      {" 1,0 ;0 , 1 ", {1, 0, 0, 1}},
      {"+1.5 -.5; 2. 1e-3", {1.5, -0.5, 2, 0.001}},
      {"1\t0;\n0\t1E+1", {1, 0, 0, 10}},
  };
  for (const auto& [text, expected] : cases) {
    SCOPED_TRACE(text);
    const auto connection =
        load_mapping("<field target=\"a\" source=\"p\" transform=\"linear\" matrix=\"" + text + "\"/>");
    ASSERT_TRUE(connection.has_value()) << ::testing::PrintToString(messages());
    const MappingRule& rule = connection->mapping->rules.at(0);
    EXPECT_EQ(rule.matrix, expected);
    EXPECT_EQ(rule.matrix_rows, 2U);
    EXPECT_EQ(rule.matrix_cols, 2U);
    EXPECT_NE(connection->program, nullptr);
  }
}

TEST_F(ProfileMappingSyntax, BadNumbers) {
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"matrix=\"1 0; 0 1;\"", "bad matrix: an entry is missing"},
      {"matrix=\"1,,0; 0 1\"", "bad matrix: an entry is missing"},
      {"matrix=\"1 0; 0 inf\"", "bad matrix: 'inf' is not a number"},
      {"matrix=\"0x10 0; 0 1\"", "bad matrix: '0x10' is not a number"},
      {"matrix=\"1 0; 0 1e\"", "bad matrix: '1e' is not a number"},
      {"matrix=\"1e999 0; 0 1\"", "bad matrix: '1e999' is not a number"},
      {"matrix=\"1;2;3;4;5;6;7\"", "bad matrix: 7x1 (at most 6 rows and 6 columns)"},
      {"matrix=\"1 0; 0 1\" translation=\"1 nan\"", "bad translation: 'nan' is not a number"},
  };
  for (const auto& [attributes, expected] : cases) {
    SCOPED_TRACE(attributes);
    const std::string kind = attributes.find("translation") != std::string::npos ? "affine" : "linear";
    EXPECT_FALSE(load_mapping("<field target=\"a\" source=\"p\" transform=\"" + kind + "\" " + attributes + "/>"));
    ASSERT_EQ(diagnostics_.all().size(), 1U) << ::testing::PrintToString(messages());
    EXPECT_EQ(diagnostics_.all()[0].message, expected);
  }
  EXPECT_FALSE(load_mapping("<field target=\"y\" source=\"y\" scale=\"1e\"/>"));
  ASSERT_EQ(diagnostics_.all().size(), 1U) << ::testing::PrintToString(messages());
  EXPECT_EQ(diagnostics_.all()[0].message, "bad scale '1e': expected a number");
}

TEST_F(ProfileMappingSyntax, ByNameFalseLeavesTheRestZero) {
  const auto connection = load_mapping("<field target=\"y\" value=\"-3\"/>");
  ASSERT_FALSE(connection.has_value());  // `a` has no source in V
  EXPECT_EQ(messages(), (std::vector<std::string>{
      "app.xml:10:5: /application_profile/port_connections/port_connection: type mismatch: C.out is "
      "'V' but C.in is 'W': target field 'a' of 'W' has no source in 'V' (source fields: p, y)",
  }));
  const auto zeroed = load_mapping("<field target=\"y\" value=\"-3\"/>", " by_name=\"false\"");
  ASSERT_TRUE(zeroed.has_value()) << ::testing::PrintToString(messages());
  ASSERT_NE(zeroed->program, nullptr);
  const double source[3] = {1.0, 2.0, 3.0};
  double target[3] = {9.0, 9.0, 9.0};
  std::uint32_t size = 0;
  ASSERT_TRUE(zeroed->program->run(reinterpret_cast<const std::byte*>(source), sizeof source,
                                   reinterpret_cast<std::byte*>(target), sizeof target, size));
  EXPECT_EQ(size, sizeof target);
  EXPECT_EQ(target[0], 0.0);
  EXPECT_EQ(target[1], 0.0);
  EXPECT_EQ(target[2], -3.0);
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
                            "components/Motor.xml", "components/OprosAliases.xml",
                            "mapping/valid_app.xml", "mapping/components/Sensor.xml",
                            "mapping/components/Planner.xml", "watchdog/valid_app.xml",
                            "watchdog/poll_app.xml" /* its problems are beyond XML Schema */}) {
    EXPECT_TRUE(validates(dir / valid)) << valid;
  }
  // The schema is strict where the loader only warns, and checks what XML Schema can express.
  for (const char* invalid : {"aliases_app.xml", "invalid/bad_app_fields.xml",
                              "invalid/bad_connections.xml", "invalid/components/BadPorts.xml",
                              "invalid/components/BadExecution.xml", "mapping/invalid_app.xml",
                              "watchdog/invalid_app.xml"}) {
    EXPECT_FALSE(validates(dir / invalid)) << invalid;
  }
}

}  // namespace

namespace {

// DDS components (tests/data/cyclonedds): <dds> and <topic> are read without any model or
// library being needed.
TEST_F(ProfileLoader, ReadsDdsDomainConfigAndTopics) {
  const auto app = load("../cyclonedds/bridge_app.xml");
  ASSERT_TRUE(app.has_value()) << ::testing::PrintToString(messages());
  EXPECT_TRUE(messages().empty()) << ::testing::PrintToString(messages());
  const Subcomponent* left = app->find_component("left");
  const Subcomponent* right = app->find_component("right");
  ASSERT_NE(left, nullptr);
  ASSERT_NE(right, nullptr);
  EXPECT_EQ(left->profile.model, "cyclonedds");
  EXPECT_EQ(dds_of(left->profile).domain, 144u);
  EXPECT_FALSE(dds_of(left->profile).config.has_value());  // the model's default
  EXPECT_EQ(dds_of(right->profile).domain, 145u);
  ASSERT_TRUE(dds_of(right->profile).config.has_value());
  EXPECT_EQ(dds_of(right->profile).config->filename(), "cyclonedds-loopback.xml");
  EXPECT_TRUE(dds_of(right->profile).config->is_absolute());
  ASSERT_EQ(left->profile.ports.size(), 1u);
  EXPECT_EQ(dds_of(left->profile).port("pose_in").topic, "polyport_bridge_pose");
  EXPECT_EQ(left->profile.ports[0].direction, PortDirection::output);
}

}  // namespace

namespace {

// DDS QoS, service-call limits and service ports over DDS (tests/data/profiles/dds).
TEST_F(ProfileLoader, DdsQosDefaultsWhenAbsent) {
  const auto app = load("../cyclonedds/bridge_app.xml");
  ASSERT_TRUE(app.has_value()) << ::testing::PrintToString(messages());
  const ComponentProfile& profile = app->find_component("left")->profile;
  const DdsQos& qos = dds_of(profile).port(profile.ports[0].name).qos;
  EXPECT_EQ(qos, DdsQos{});
  EXPECT_EQ(qos.reliability, DdsQos::Reliability::reliable);
  EXPECT_EQ(qos.durability, DdsQos::Durability::volatile_);
  EXPECT_EQ(qos.history, DdsQos::History::keep_last);
  EXPECT_EQ(qos.depth, 10);
  EXPECT_FALSE(qos.deadline_ns || qos.lifespan_ns || qos.lease_ns);
  EXPECT_EQ(qos.liveliness, DdsQos::Liveliness::automatic);
  EXPECT_TRUE(qos.partitions.empty());
  EXPECT_EQ(qos.data_sharing, DdsQos::DataSharing::automatic);
  EXPECT_EQ(dds_of(profile).max_calls_in_flight, 16u);
  EXPECT_EQ(dds_of(profile).call_timeout_ns, 1'000'000'000);
}

TEST_F(ProfileLoader, DdsQosFromTheComponentAndOverriddenByAPort) {
  const auto app = load("dds/qos_app.xml");
  ASSERT_TRUE(app.has_value()) << ::testing::PrintToString(messages());
  EXPECT_TRUE(messages().empty()) << ::testing::PrintToString(messages());
  const ComponentProfile& profile = app->find_component("comp")->profile;
  EXPECT_EQ(dds_of(profile).domain, 3u);
  EXPECT_EQ(dds_of(profile).max_calls_in_flight, 3u);
  EXPECT_EQ(dds_of(profile).call_timeout_ns, 40'000'000);

  const DdsQos& plain = dds_of(profile).port("plain").qos;  // the component's, as given
  EXPECT_EQ(plain, dds_of(profile).qos);
  EXPECT_EQ(plain.reliability, DdsQos::Reliability::best_effort);
  EXPECT_EQ(plain.durability, DdsQos::Durability::transient_local);
  EXPECT_EQ(plain.history, DdsQos::History::keep_all);
  EXPECT_EQ(plain.depth, 5);
  EXPECT_EQ(plain.deadline_ns, 100'000'000);
  EXPECT_EQ(plain.lifespan_ns, 250'500'000);
  EXPECT_EQ(plain.liveliness, DdsQos::Liveliness::manual_by_topic);
  EXPECT_EQ(plain.lease_ns, 2'000'000'000);
  EXPECT_EQ(plain.partitions, (std::vector<std::string>{"a", "b"}));
  EXPECT_EQ(plain.data_sharing, DdsQos::DataSharing::off);

  const dds::PortSettings* tuned = &dds_of(profile).port("tuned");
  EXPECT_EQ(tuned->topic, "t");
  EXPECT_EQ(tuned->qos.reliability, DdsQos::Reliability::reliable);  // overridden
  EXPECT_FALSE(tuned->qos.deadline_ns.has_value());                  // 0: infinite
  EXPECT_EQ(tuned->qos.partitions, (std::vector<std::string>{"c"})); // replaced, not added
  EXPECT_EQ(tuned->qos.durability, DdsQos::Durability::transient_local);  // kept
  EXPECT_EQ(tuned->qos.lifespan_ns, 250'500'000);
  EXPECT_EQ(tuned->qos.data_sharing, DdsQos::DataSharing::automatic);  // overridden

  const PortSpec* svc = profile.find_port("svc");
  EXPECT_EQ(dds_of(profile).port("svc").topic, "base");
  ASSERT_EQ(svc->operations.size(), 1u);
  EXPECT_EQ(dds_of(profile).port("svc").operation("op")->request_type, "q::Op_Request");
  EXPECT_EQ(dds_of(profile).port("svc").operation("op")->reply_type, "q::Op_Reply");
}

TEST_F(ProfileLoader, DdsQosAndServiceErrorsAtTheirPlaces) {
  EXPECT_FALSE(load("dds/bad_qos_app.xml").has_value());
  const std::vector<std::string> expected = {
      "dds/BadQos.xml:6:119: /component_profile/dds/qos/deadline_ms[2]: duplicate <deadline_ms>: already given at "
      "line 6",
      "dds/BadQos.xml:6:23: /component_profile/dds/qos/reliability: bad reliability 'sometimes' (accepted: reliable, "
      "best_effort)",
      "dds/BadQos.xml:6:53: /component_profile/dds/qos/depth: bad history depth '0': expected an integer from 1 to "
      "2147483647",
      "dds/BadQos.xml:6:75: /component_profile/dds/qos/deadline_ms[1]: bad deadline_ms '-1': expected a number of "
      "milliseconds from 0 to 86400000",
      "dds/BadQos.xml:7:26: /component_profile/dds/max_calls_in_flight: bad max_calls_in_flight '0': expected an "
      "integer from 1 to 4096",
      "dds/BadQos.xml:8:22: /component_profile/dds/call_timeout_ms: call_timeout_ms must be greater than 0",
      "dds/BadQos.xml:12:7: /component_profile/ports/service_port/operation[1]: missing attribute 'dds_request': the "
      "struct a DDS application writes on the request topic (a polyport::rpc::RequestHeader, then the request)",
      "dds/BadQos.xml:12:7: /component_profile/ports/service_port/operation[1]: missing attribute 'dds_reply': the "
      "struct a DDS application writes on the reply topic (a polyport::rpc::ReplyHeader, then the reply)",
      "dds/BadQos.xml:13:101: /component_profile/ports/service_port/operation[2]/@dds_reply: a oneway operation has "
      "no reply",
      "dds/Inproc.xml:7:83: /component_profile/ports/data_port/qos: warning: <qos> is ignored by model 'inproc'",
  };
  EXPECT_EQ(messages(), expected);
}

TEST(ProfileSchema, DdsFixturesAgainstTheXsd) {
  if (std::system("xmllint --version > /dev/null 2>&1") != 0) {
    GTEST_SKIP() << "xmllint not installed (libxml2-utils)";
  }
  const std::string command = "xmllint --noout --schema '" + schema_file().string() + "' '" +
                              (profiles_dir() / "dds" / "QosComp.xml").string() + "' > /dev/null 2>&1";
  EXPECT_EQ(std::system(command.c_str()), 0);
}

}  // namespace

namespace {

// More of the DDS elements (tests/data/profiles/dds): per-port QoS on event and service
// ports, every bad value at its place, and DDS elements on a component of another model.
TEST_F(ProfileLoader, DdsQosOfEventAndServicePortsOverTheComponents) {
  const auto app = load("dds/port_qos_app.xml");
  ASSERT_TRUE(app.has_value()) << ::testing::PrintToString(messages());
  // Only the event port's lifespan (50 ms) under the component's deadline (100 ms).
  EXPECT_EQ(messages(), (std::vector<std::string>{
      "dds/PortQos.xml:17:7: /component_profile/ports/event_port/qos: warning: lifespan_ms is shorter than "
      "deadline_ms: readers may miss every deadline",
  }));
  const ComponentProfile& profile = app->find_component("comp")->profile;
  EXPECT_FALSE(dds_of(profile).qos.lease_ns.has_value());  // 0: infinite
  EXPECT_EQ(dds_of(profile).qos.deadline_ns, 100'000'000);
  EXPECT_EQ(dds_of(profile).max_calls_in_flight, 16u);     // <dds> without the service limits
  EXPECT_EQ(dds_of(profile).call_timeout_ns, 1'000'000'000);

  const PortSpec* event = profile.find_port("ev");
  ASSERT_NE(event, nullptr);
  EXPECT_EQ(event->kind, PortKind::event);
  EXPECT_EQ(dds_of(profile).port("ev").topic, "");  // the port's name is the topic
  const DdsQos& ev = dds_of(profile).port("ev").qos;
  EXPECT_EQ(ev.durability, DdsQos::Durability::transient_local);          // the port's
  EXPECT_EQ(ev.liveliness, DdsQos::Liveliness::manual_by_participant);    // the port's
  EXPECT_EQ(ev.lease_ns, 1'250'000);                                      // over the component's 0
  EXPECT_EQ(ev.lifespan_ns, 50'000'000);                                  // the port's
  EXPECT_EQ(ev.history, DdsQos::History::keep_all);                       // the component's
  EXPECT_EQ(ev.deadline_ns, 100'000'000);                                 // the component's
  EXPECT_EQ(ev.partitions, (std::vector<std::string>{"x"}));              // the component's
  EXPECT_EQ(ev.reliability, DdsQos::Reliability::reliable);               // the default
  EXPECT_EQ(ev.depth, 10);                                                // the default

  const PortSpec* service = profile.find_port("svc");
  ASSERT_NE(service, nullptr);
  EXPECT_EQ(service->kind, PortKind::service);
  EXPECT_EQ(dds_of(profile).port("svc").topic, "calc/v1");
  const DdsQos& svc = dds_of(profile).port("svc").qos;
  EXPECT_EQ(svc.reliability, DdsQos::Reliability::best_effort);
  EXPECT_EQ(svc.history, DdsQos::History::keep_last);  // back from the component's keep_all
  EXPECT_EQ(svc.depth, 2);
  EXPECT_FALSE(svc.deadline_ns.has_value());           // 0 over the component's 100 ms
  EXPECT_EQ(svc.partitions, (std::vector<std::string>{"y", "z"}));  // replaced, not added
  EXPECT_EQ(svc.durability, DdsQos::Durability::volatile_);
  EXPECT_EQ(svc.liveliness, DdsQos::Liveliness::automatic);
  EXPECT_FALSE(svc.lifespan_ns.has_value());
  EXPECT_FALSE(svc.lease_ns.has_value());

  ASSERT_EQ(service->operations.size(), 2u);
  const OperationSpec& get = service->operations[0];
  EXPECT_EQ(get.name, "get");
  EXPECT_EQ(get.request_type, "");
  EXPECT_EQ(get.reply_type, "q::Result");
  EXPECT_EQ(dds_of(profile).port("svc").operation("get")->request_type, "q::Get_Request");
  EXPECT_EQ(dds_of(profile).port("svc").operation("get")->reply_type, "q::Get_Reply");
  const OperationSpec& fire = service->operations[1];
  EXPECT_TRUE(fire.oneway);
  EXPECT_EQ(dds_of(profile).port("svc").operation("fire")->request_type, "q::Fire_Request");
  EXPECT_EQ(dds_of(profile).port("svc").operation("fire")->reply_type, "");  // a oneway operation needs none
}

TEST_F(ProfileLoader, DdsBadValuesAtTheirPlaces) {
  EXPECT_FALSE(load("dds/bad_values_app.xml").has_value());
  const std::string ms = ": expected a number of milliseconds from 0 to 86400000";
  EXPECT_EQ(messages(), (std::vector<std::string>{
      "dds/BadValues.xml:8:19: /component_profile/dds/qos/durability: bad durability 'persistent' (accepted: "
      "volatile, transient_local)",
      "dds/BadValues.xml:9:16: /component_profile/dds/qos/history: bad history 'keep_some' (accepted: keep_last, "
      "keep_all)",
      "dds/BadValues.xml:10:14: /component_profile/dds/qos/depth: bad history depth 'two': expected an integer "
      "from 1 to 2147483647",
      "dds/BadValues.xml:11:20: /component_profile/dds/qos/deadline_ms: bad deadline_ms 'soon'" + ms,
      "dds/BadValues.xml:12:20: /component_profile/dds/qos/lifespan_ms: bad lifespan_ms '86400001'" + ms,
      "dds/BadValues.xml:13:19: /component_profile/dds/qos/liveliness: bad liveliness 'manual' (accepted: "
      "automatic, manual_by_participant, manual_by_topic)",
      "dds/BadValues.xml:14:17: /component_profile/dds/qos/lease_ms: bad lease_ms '-5'" + ms,
      "dds/BadValues.xml:15:21: /component_profile/dds/qos/data_sharing: bad data_sharing 'on' (accepted: auto, off)",
      "dds/BadValues.xml:17:26: /component_profile/dds/max_calls_in_flight: bad max_calls_in_flight '4097': "
      "expected an integer from 1 to 4096",
      "dds/BadValues.xml:18:22: /component_profile/dds/call_timeout_ms: bad call_timeout_ms '-1'" + ms,
      "dds/BadValues.xml:23:22: /component_profile/ports/data_port/qos/reliability: bad reliability 'Reliable' "
      "(accepted: reliable, best_effort)",
      "dds/BadValues.xml:24:16: /component_profile/ports/data_port/qos/depth: bad history depth '2147483648': "
      "expected an integer from 1 to 2147483647",
      // xs:decimal has no exponent, and neither has the loader.
      "dds/BadValues.xml:25:19: /component_profile/ports/data_port/qos/lease_ms: bad lease_ms '1e3'" + ms,
      // A Fast DDS setting on a Cyclone DDS component.
      "dds/BadValues.xml:26:9: /component_profile/ports/data_port/qos/data_sharing: warning: data_sharing is a "
      "Fast DDS setting: ignored",
      "dds/BadValues.xml:31:7: /component_profile/ports/service_port/operation[2]: missing attribute "
      "'dds_request': the struct a DDS application writes on the request topic (a polyport::rpc::RequestHeader, "
      "then the request)",
      // Type names resolve after every file is read, like request and reply.
      "dds/BadValues.xml:30:77: /component_profile/ports/service_port/operation[1]/@dds_request: unknown type "
      "'q::NoRequest'",
      "dds/BadValues.xml:30:102: /component_profile/ports/service_port/operation[1]/@dds_reply: unknown type "
      "'q::NoReply'",
  }));
}

TEST_F(ProfileLoader, DdsElementsOnAnInprocComponentWarnAndAreIgnored) {
  const auto app = load("dds/inproc_app.xml");
  ASSERT_TRUE(app.has_value()) << ::testing::PrintToString(messages());
  EXPECT_EQ(messages(), (std::vector<std::string>{
      "dds/InprocService.xml:8:3: /component_profile/dds: warning: <dds> is ignored by model 'inproc'",
      "dds/InprocService.xml:10:83: /component_profile/ports/data_port/topic: warning: <topic> is ignored by "
      "model 'inproc'",
      "dds/InprocService.xml:12:7: /component_profile/ports/service_port/qos: warning: <qos> is ignored by model "
      "'inproc'",
      "dds/InprocService.xml:13:7: /component_profile/ports/service_port/operation[1]: warning: dds_request / "
      "dds_reply are ignored by model 'inproc'",
  }));
  const PortSpec* service = app->find_component("inproc")->profile.find_port("svc");
  ASSERT_NE(service, nullptr);
  ASSERT_EQ(service->operations.size(), 2u);
  // Ignored: not kept, and 'q::Nothing' (no such type) is not looked up.
  EXPECT_EQ(app->find_component("inproc")->profile.model_settings, nullptr);  // nothing kept
  EXPECT_EQ(service->operations[0].request_type, "q::Args");
  EXPECT_EQ(service->operations[1].name, "plain");  // no dds_request needed
}

TEST(ProfileSchema, DdsFixturesValidAndInvalid) {
  if (std::system("xmllint --version > /dev/null 2>&1") != 0) {
    GTEST_SKIP() << "xmllint not installed (libxml2-utils)";
  }
  const auto validates = [](const fs::path& file) {
    const std::string command = "xmllint --noout --schema '" + schema_file().string() + "' '" +
                                file.string() + "' > /dev/null 2>&1";
    return std::system(command.c_str()) == 0;
  };
  const fs::path dir = profiles_dir() / "dds";
  // InprocService.xml: the loader warns about its DDS elements; the schema has no rule
  // tying them to the model.
  for (const char* valid : {"QosComp.xml", "qos_app.xml", "PortQos.xml", "port_qos_app.xml", "Inproc.xml",
                            "InprocService.xml", "inproc_app.xml", "bad_qos_app.xml", "bad_values_app.xml"}) {
    EXPECT_TRUE(validates(dir / valid)) << valid;
  }
  for (const char* invalid : {"BadQos.xml", "BadValues.xml"}) {
    EXPECT_FALSE(validates(dir / invalid)) << invalid;
  }
}

}  // namespace
