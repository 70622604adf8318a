// Reloading a running polyportd, driven through polyportctl and SIGHUP only: a reload that
// adds a component and connections while an untouched connection keeps delivering with no
// drop; a broken profile refused with file:line:col while the old graph runs on; SIGHUP.
// Every wait polls with a deadline.
#include <signal.h>

#include <regex>

#include "../support/daemon_harness.hpp"

namespace polyport::test {
namespace {

const std::string kComponents = POLYPORT_SOURCE_DIR "/profiles/components/";

using Ctl = DaemonTest::Ran;

std::string data_connection(const std::string& source, const std::string& target) {
  const auto dot = [](const std::string& s) { return s.find('.'); };
  return "    <port_connection port_type=\"data\">\n      <source component_name=\"" + source.substr(0, dot(source)) +
         "\" port_name=\"" + source.substr(dot(source) + 1) + "\"/>\n      <target component_name=\"" +
         target.substr(0, dot(target)) + "\" port_name=\"" + target.substr(dot(target) + 1) +
         "\"/>\n    </port_connection>\n";
}

// The in-process wheelchair and a spare joystick handler, as tests/control/wheelchair_spare.xml.
const std::vector<std::pair<std::string, std::string>> kWheelchair{{"Joystick", "JoystickComp.xml"},
                                                                    {"Control", "ControlComp.xml"},
                                                                    {"HW", "HWComp.xml"},
                                                                    {"Spare", "JoystickComp.xml"}};
const std::string kLoop = data_connection("HW.joystick", "Joystick.position") +
                          data_connection("Joystick.reference", "Control.reference") +
                          data_connection("HW.wheel_speeds", "Control.wheel_speeds") +
                          data_connection("Control.voltages", "HW.voltages");

class ReloadDaemon : public DaemonTest {
 public:
  ReloadDaemon() : DaemonTest("polyport-reload") {}

  void SetUp() override {
    DaemonTest::SetUp();
    socket_ = dir() / "admin.sock";
    write(kWheelchair, kLoop);
    daemon_ = daemon(app(), {"--admin-socket", socket_.string()});
    ASSERT_TRUE(eventually([&] { return ctl({"hello"}).code == 0; }, 30s)) << daemon_->errors();
  }
  void TearDown() override {
    if (daemon_) stop(*daemon_);
    DaemonTest::TearDown();
  }

  fs::path app() const { return dir() / "app.xml"; }
  void write(const std::vector<std::pair<std::string, std::string>>& components, const std::string& connections) {
    std::ofstream out(app());
    out << "<?xml version=\"1.0\"?>\n<application_profile>\n  <name>reloaded_wheelchair</name>\n  <subcomponents>\n";
    for (const auto& [name, reference] : components) {
      out << "    <subcomponent><name>" << name << "</name><reference>" << kComponents << reference
          << "</reference></subcomponent>\n";
    }
    out << "  </subcomponents>\n  <port_connections>\n" << connections << "  </port_connections>\n</application_profile>\n";
  }
  Ctl ctl(std::vector<std::string> args) {
    args.insert(args.begin(), {POLYPORTCTL, "--socket", socket_.string()});
    return run_to_end(args, 20s);
  }
  Json json(const std::string& command) {
    const Ctl c = ctl({"--json", command});
    EXPECT_EQ(c.code, 0) << c.err;
    return Json::parse(c.out, nullptr, false);
  }
  // Every connection's stats entry named "source -> target" (removed ones too).
  std::vector<Json> entries(const std::string& source, const std::string& target) {
    std::vector<Json> out;
    const Json stats = json("stats");
    for (const Json& c : stats.value("connections", Json::array())) {
      if (c.value("source", "") == source && c.value("target", "") == target) out.push_back(c);
    }
    return out;
  }
  std::vector<std::string> listed_connections() {
    std::vector<std::string> out;
    for (const Json& c : json("list").value("connections", Json::array())) {
      out.push_back(c.value("source", "") + " -> " + c.value("target", ""));
    }
    return out;
  }

  fs::path socket_;
  std::unique_ptr<Child> daemon_;
};

TEST_F(ReloadDaemon, AddsAComponentAndConnectionsWhileAnUntouchedConnectionLosesNothing) {
  const auto untouched = [&] {
    const std::vector<Json> found = entries("HW.wheel_speeds", "Control.wheel_speeds");
    EXPECT_EQ(found.size(), 1u) << "the untouched connection is one connection, never removed";
    return found.empty() ? Json() : found.front();
  };
  ASSERT_TRUE(eventually([&] { return untouched().value("delivered", 0) > 5; })) << daemon_->errors();
  const std::uint64_t before = untouched().value("delivered", std::uint64_t{0});

  write({{"Joystick", "JoystickComp.xml"}, {"Control", "ControlComp.xml"}, {"HW", "HWComp.xml"},
         {"Spare", "JoystickComp.xml"}, {"Spare2", "JoystickComp.xml"}},
        kLoop + data_connection("HW.joystick", "Spare.position") + data_connection("HW.joystick", "Spare2.position"));
  const Ctl reload = ctl({"reload"});
  ASSERT_EQ(reload.code, 0) << reload.err << daemon_->errors();
  EXPECT_NE(reload.out.find("components added:"), std::string::npos) << reload.out;
  EXPECT_NE(reload.out.find("Spare2"), std::string::npos) << reload.out;
  EXPECT_NE(reload.out.find("HW.joystick -> Spare2.position"), std::string::npos) << reload.out;

  const Json graph = json("list");
  bool spare2_active = false;
  for (const Json& c : graph["components"]) spare2_active |= c.value("name", "") == "Spare2" && c.value("state", "") == "active";
  EXPECT_TRUE(spare2_active) << graph.dump();
  for (const char* target : {"Spare.position", "Spare2.position"}) {
    EXPECT_TRUE(eventually([&] {
      const std::vector<Json> found = entries("HW.joystick", target);
      return found.size() == 1 && found.front().value("delivered", 0) > 3;
    })) << target << " gets nothing";
  }
  // The untouched connection went on through the reload: same counters, still rising, no drop.
  EXPECT_TRUE(eventually([&] { return untouched().value("delivered", std::uint64_t{0}) > before + 10; }));
  EXPECT_EQ(untouched().value("dropped", 1), 0) << untouched().dump();
}

TEST_F(ReloadDaemon, ABrokenProfileIsRefusedAndTheRunningGraphGoesOn) {
  const std::vector<std::string> running = listed_connections();
  ASSERT_EQ(running.size(), 4u);
  // Line 13 of the file: the fifth connection's target has no such port.
  write(kWheelchair, kLoop + data_connection("HW.joystick", "Spare.nothing"));
  const Ctl reload = ctl({"reload"});
  EXPECT_EQ(reload.code, 1) << reload.out;
  const std::regex located(std::regex_replace(app().string(), std::regex(R"([.^$|()\[\]{}*+?\\])"), R"(\$&)") +
                           R"(:\d+:\d+: .*component 'Spare' has no port 'nothing')");
  EXPECT_TRUE(std::regex_search(reload.err, located)) << reload.err;
  EXPECT_NE(daemon_->errors().find("reload refused, the running graph is unchanged"), std::string::npos);
  EXPECT_EQ(listed_connections(), running);
  const std::uint64_t before = entries("Control.voltages", "HW.voltages").at(0).value("delivered", std::uint64_t{0});
  EXPECT_TRUE(eventually([&] {
    return entries("Control.voltages", "HW.voltages").at(0).value("delivered", std::uint64_t{0}) > before;
  })) << "forwarding stopped";
}

TEST_F(ReloadDaemon, SighupAppliesTheProfileAsItReadsNow) {
  // Spare leaves and the motors' connection with it: written, then SIGHUP.
  write({{"Joystick", "JoystickComp.xml"}, {"Control", "ControlComp.xml"}, {"HW", "HWComp.xml"}},
        data_connection("HW.joystick", "Joystick.position") + data_connection("Joystick.reference", "Control.reference") +
            data_connection("HW.wheel_speeds", "Control.wheel_speeds"));
  daemon_->signal(SIGHUP);
  ASSERT_TRUE(eventually([&] { return listed_connections().size() == 3; })) << daemon_->errors();
  const std::vector<Json> motors = entries("Control.voltages", "HW.voltages");
  ASSERT_EQ(motors.size(), 1u);
  EXPECT_TRUE(motors.front().value("removed", false)) << motors.front().dump();
  bool spare = false;
  const Json graph = json("list");
  for (const Json& c : graph["components"]) spare |= c.value("name", "") == "Spare";
  EXPECT_FALSE(spare);
  EXPECT_NE(daemon_->errors().find("SIGHUP: reloading"), std::string::npos) << daemon_->errors();
}

// A Cyclone DDS application's proxy made and started while the application runs, written to
// by the in-process HW, then stopped when the profiles no longer name it.
TEST_F(ReloadDaemon, ADdsApplicationJoinsAndLeaves) {
  std::vector<std::pair<std::string, std::string>> with_teleop = kWheelchair;
  with_teleop.emplace_back("Teleop", "DdsTeleop.xml");
  write(with_teleop, kLoop + data_connection("HW.wheel_speeds", "Teleop.wheel_speeds"));
  Ctl reload = ctl({"reload"});
  ASSERT_EQ(reload.code, 0) << reload.err << daemon_->errors();
  const auto teleop = [&] {
    const Json graph = json("list");
    for (const Json& c : graph["components"]) {
      if (c.value("name", "") == "Teleop") return c;
    }
    return Json();
  };
  EXPECT_EQ(teleop().value("model", ""), "cyclonedds");
  EXPECT_EQ(teleop().value("state", ""), "active");
  EXPECT_TRUE(eventually([&] {
    const std::vector<Json> found = entries("HW.wheel_speeds", "Teleop.wheel_speeds");
    return found.size() == 1 && found.front().value("delivered", 0) > 3;
  })) << "nothing reaches the DDS writer";

  write(kWheelchair, kLoop);
  reload = ctl({"reload"});
  ASSERT_EQ(reload.code, 0) << reload.err << daemon_->errors();
  EXPECT_NE(reload.out.find("components removed:"), std::string::npos) << reload.out;
  EXPECT_TRUE(teleop().is_null());
  const std::vector<Json> gone = entries("HW.wheel_speeds", "Teleop.wheel_speeds");
  ASSERT_EQ(gone.size(), 1u);
  EXPECT_TRUE(gone.front().value("removed", false));
}

}  // namespace
}  // namespace polyport::test
