// Composites (<composites>): the loader resolves every connection end that names a
// composite's port to the member's own port, data, event and service alike; every problem of
// a composite is reported at its place; run-time connections and a reload's diff see the
// member ports (fixtures in tests/data/profiles/composite).

#include <gtest/gtest.h>

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "polyport/base/diagnostics.hpp"
#include "polyport/profile/profile.hpp"
#include "polyport/profile/runtime_checks.hpp"
#include "polyport/types/types.hpp"
#include "reload.hpp"

namespace {

using namespace polyport;
namespace fs = std::filesystem;

fs::path profiles_dir() { return fs::weakly_canonical(fs::path(POLYPORT_TEST_DATA) / "profiles"); }

class Composites : public ::testing::Test {
 protected:
  std::optional<ApplicationProfile> load(const std::string& relative) {
    return load_application_profile(profiles_dir() / "composite" / relative, types_, options_, diagnostics_);
  }
  // Every diagnostic as the user reads it, with the fixture folder cut out of file names.
  std::vector<std::string> messages() const {
    const std::string prefix = (profiles_dir() / "composite").string() + "/";
    std::vector<std::string> out;
    for (const Diagnostic& item : diagnostics_.all()) {
      std::string text = item.to_string();
      for (auto at = text.find(prefix); at != std::string::npos; at = text.find(prefix, at)) text.erase(at, prefix.size());
      out.push_back(std::move(text));
    }
    return out;
  }
  static std::string path(const ConnectionEnd& end) { return end.component + "." + end.port; }

  TypeRegistry types_;
  Diagnostics diagnostics_;
  LoadOptions options_{{profiles_dir() / "libs"}};
};

TEST_F(Composites, ResolveEveryConnectionToTheMemberPorts) {
  const auto app = load("composite_app.xml");
  ASSERT_TRUE(app.has_value()) << ::testing::PrintToString(messages());
  EXPECT_EQ(diagnostics_.error_count(), 0u);

  ASSERT_EQ(app->composites.size(), 2u);
  const CompositeSpec* chair = app->find_composite("Chair");
  ASSERT_NE(chair, nullptr);
  EXPECT_EQ(chair->description, "The hardware side: stick and motor.");
  EXPECT_EQ(chair->members, (std::vector<std::string>{"Joystick", "Motor"}));
  ASSERT_EQ(chair->ports.size(), 4u);
  // `as` names the port; without it the port keeps its own name.
  const std::vector<std::pair<std::string, std::string>> chair_ports{
      {"stick", "Joystick.joystick"}, {"busy", "Joystick.busy"}, {"drive", "Motor.reference"}, {"motor", "Motor.motor"}};
  for (std::size_t i = 0; i < chair_ports.size(); ++i) {
    EXPECT_EQ(chair->ports[i].name, chair_ports[i].first);
    EXPECT_EQ(path(chair->ports[i].member), chair_ports[i].second);
  }
  EXPECT_EQ(chair->ports[0].where.line, 18u);
  const CompositeSpec* brain = app->find_composite("Brain");
  ASSERT_NE(brain, nullptr);
  EXPECT_EQ(brain->members, (std::vector<std::string>{"Control"}));
  EXPECT_EQ(app->find_composite("Joystick"), nullptr);
  EXPECT_EQ(app->find_component("Chair"), nullptr);

  struct Expected {
    PortKind kind;
    std::string source, target, source_promoted, target_promoted;
  };
  const std::vector<Expected> expected{
      {PortKind::data, "Joystick.joystick", "Control.joystick", "Chair.stick", "Brain.input"},
      {PortKind::data, "Control.reference", "Motor.reference", "Brain.reference", "Chair.drive"},
      {PortKind::event, "Joystick.busy", "Control.joystick_busy", "Chair.busy", "Brain.busy"},
      {PortKind::service, "Control.motor", "Motor.motor", "Brain.motor", "Chair.motor"},
      {PortKind::data, "Joystick.joystick", "Motor.joystick_monitor", "Chair.stick", ""},
  };
  ASSERT_EQ(app->connections.size(), expected.size());
  for (std::size_t i = 0; i < expected.size(); ++i) {
    SCOPED_TRACE("connection " + std::to_string(i + 1));
    const ConnectionSpec& c = app->connections[i];
    EXPECT_EQ(c.kind, expected[i].kind);
    EXPECT_EQ(path(c.source), expected[i].source);
    EXPECT_EQ(path(c.target), expected[i].target);
    EXPECT_EQ(c.source.promoted, expected[i].source_promoted);
    EXPECT_EQ(c.target.promoted, expected[i].target_promoted);
  }
  // The connection's own policy, and the event connection's default, as for member ports.
  EXPECT_EQ(app->connections[1].policy, QueuePolicy::circular);
  EXPECT_EQ(app->connections[1].depth, 4u);
  EXPECT_EQ(app->connections[2].policy, QueuePolicy::circular);
  // Different types across a composite's ports map by name as across the members' own:
  // Control.reference is wheelchair::Reference and Motor.reference ::wheelchair::Reference.
  EXPECT_EQ(app->connections[1].program, nullptr);
  // A watchdog's upstream port may be a composite's too.
  ASSERT_TRUE(app->connections[1].watchdog && app->connections[1].watchdog->upstream);
  EXPECT_EQ(path(*app->connections[1].watchdog->upstream), "Joystick.joystick");
  EXPECT_EQ(app->connections[1].watchdog->upstream->promoted, "Chair.stick");

  EXPECT_EQ(app->member_path("Chair.stick"), "Joystick.joystick");
  EXPECT_EQ(app->member_path("Brain.motor"), "Control.motor");
  EXPECT_EQ(app->member_path("Chair.nothing"), "Chair.nothing");
  EXPECT_EQ(app->member_path("Motor.reference"), "Motor.reference");
  EXPECT_EQ(app->member_path("Chair"), "Chair");
}

// The failure case among them: a composite promoting a port that does not exist.
TEST_F(Composites, EveryProblemAtItsPlace) {
  EXPECT_FALSE(load("bad_composites.xml").has_value());
  EXPECT_EQ(messages(), (std::vector<std::string>{
      "bad_composites.xml:15:7: /application_profile/composites/composite[1]/promote[1]: "
      "component 'Joystick' has no port 'joystik' (ports: joystick, busy)",
      "bad_composites.xml:16:7: /application_profile/composites/composite[1]/promote[2]: "
      "unknown component 'Nobody'",
      "bad_composites.xml:18:7: /application_profile/composites/composite[1]/promote[4]: "
      "duplicate promoted name 'stick' in composite 'Chair': already promoted at line 17",
      "bad_composites.xml:19:7: /application_profile/composites/composite[1]/promote[5]: "
      "composite 'Chair' promotes a port of its own",
      "bad_composites.xml:20:7: /application_profile/composites/composite[1]/promote[6]: "
      "composite 'Chair' promotes a port of composite 'Outer': composites do not nest (promote the member "
      "component's port)",
      "bad_composites.xml:21:65: /application_profile/composites/composite[1]/promote[7]/@as: "
      "empty attribute 'as'",
      "bad_composites.xml:24:13: /application_profile/composites/composite[2]/name: "
      "composite name 'Motor' is already a subcomponent's (line 10)",
      "bad_composites.xml:28:13: /application_profile/composites/composite[3]/name: "
      "duplicate composite name 'Chair': already used at line 14",
      "bad_composites.xml:33:7: /application_profile/composites/composite[4]/promote: "
      "composite 'Outer' promotes a port of composite 'Chair': composites do not nest (promote the member "
      "component's port)",
      "bad_composites.xml:35:5: /application_profile/composites/composite[5]: "
      "a composite promotes at least one port (<promote>)",
      "bad_composites.xml:38:22: /application_profile/composites/composite[6]/name: "
      "composite name 'A.B' contains '.' (connections write Name.port)",
      "bad_composites.xml:38:32: /application_profile/composites/composite[6]/promote: "
      "promoted name 'x.y' contains '.'",
      "bad_composites.xml:43:7: /application_profile/port_connections/port_connection[1]/target: "
      "composite 'Chair' promotes no port 'monitor' (it promotes: stick)",
      "bad_composites.xml:47:7: /application_profile/port_connections/port_connection[2]/target: "
      "Chair.stick (Joystick.joystick) is an output port; a data connection's target must be an input port",
  }));
}

TEST_F(Composites, RunTimeConnectionsNameTheirPortsToo) {
  const auto app = load("composite_app.xml");
  ASSERT_TRUE(app.has_value()) << ::testing::PrintToString(messages());
  Diagnostics found;
  const auto spec = check_connection(*app, types_, {"Chair.stick", "Brain.input", "buffer", "8"}, found);
  ASSERT_TRUE(spec.has_value()) << ::testing::PrintToString(found.all().size());
  EXPECT_EQ(spec->kind, PortKind::data);
  EXPECT_EQ(path(spec->source), "Joystick.joystick");
  EXPECT_EQ(path(spec->target), "Control.joystick");
  EXPECT_EQ(spec->source.promoted, "Chair.stick");
  EXPECT_EQ(spec->policy, QueuePolicy::buffer);
  // The kind comes from the member port: an event connection.
  const auto event = check_connection(*app, types_, {"Chair.busy", "Control.joystick_busy", "", ""}, found);
  ASSERT_TRUE(event.has_value());
  EXPECT_EQ(event->kind, PortKind::event);

  Diagnostics refused;
  EXPECT_FALSE(check_connection(*app, types_, {"Chair.nothing", "Brain.input", "", ""}, refused).has_value());
  ASSERT_EQ(refused.all().size(), 1u);
  EXPECT_NE(refused.all()[0].to_string().find("composite 'Chair' promotes no port 'nothing' (it promotes: stick, busy, "
                                              "drive, motor)"),
            std::string::npos)
      << refused.all()[0].to_string();
}

// A composite that promotes another port: the connections naming it now join other member
// ports, and the diff says so by the member ports (what the engine is changed by).
TEST_F(Composites, AReloadSeesTheMemberPortsAComposite) {
  const auto running = load("composite_app.xml");
  const auto next = load("composite_app_repointed.xml");
  ASSERT_TRUE(running && next) << ::testing::PrintToString(messages());
  const auto diff = daemon::diff(*running, *next);
  ASSERT_TRUE(diff);
  const daemon::GraphDiff& d = diff.value();
  EXPECT_TRUE(d.components_added.empty() && d.components_removed.empty() && d.components_changed.empty());
  EXPECT_EQ(d.connections_added, std::vector<std::string>{});
  // The direct connection to Motor.joystick_monitor is gone from the profile; Chair.stick ->
  // Brain.input now makes one of the same ends, written otherwise: changed.
  EXPECT_EQ(d.connections_changed, (std::vector<std::string>{"Joystick.joystick -> Motor.joystick_monitor"}));
  EXPECT_EQ(d.connections_removed, (std::vector<std::string>{"Joystick.joystick -> Control.joystick"}));
  EXPECT_EQ(d.composites_changed, (std::vector<std::string>{"Brain"}));
  EXPECT_TRUE(d.composites_added.empty() && d.composites_removed.empty());
  EXPECT_FALSE(d.graph_unchanged());

  const auto same = daemon::diff(*running, *running);
  ASSERT_TRUE(same);
  EXPECT_TRUE(same.value().empty());
}

}  // namespace
