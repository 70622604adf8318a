// <notifications> in component profiles: the port the loader adds, and each problem with its
// exact diagnostic.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <unistd.h>

#include "polyport/profile/notifications.hpp"
#include "polyport/profile/profile.hpp"
#include "polyport/types/types.hpp"

namespace polyport {
namespace {

namespace fs = std::filesystem;

class NotificationsProfile : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("polyport-notifications-" + std::to_string(getpid()) + "-" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  // One component of `model` with `element` (and an output port `state`), in one application.
  std::optional<ApplicationProfile> load(const std::string& model, const std::string& element) {
    const std::string environment =
        model == "inproc" ? "<execution_environment><library_name>libpolyport_youbot.so</library_name>"
                            "<class_name>YoubotDriver</class_name></execution_environment>"
                          : "";
    std::ofstream(dir_ / "C.xml") << "<?xml version=\"1.0\"?>\n<component_profile><name>C</name><model>" << model
                                  << "</model>" << environment << "\n<types><file>" POLYPORT_SOURCE_DIR
                                     "/config/types/component_notification.idl</file></types>\n"
                                  << "<ports><data_port><name>state</name><data_type>double</data_type>"
                                     "<usage>output</usage></data_port></ports>\n"
                                  << element << "\n</component_profile>\n";
    std::ofstream(dir_ / "app.xml") << "<?xml version=\"1.0\"?>\n<application_profile><name>a</name><subcomponents>"
                                       "<subcomponent><name>c</name><reference>C.xml</reference></subcomponent>"
                                       "</subcomponents></application_profile>\n";
    diagnostics_ = Diagnostics();
    return load_application_profile(dir_ / "app.xml", types_, LoadOptions{{POLYPORT_PLUGIN_DIR}, nullptr}, diagnostics_);
  }
  std::vector<std::string> errors() const {
    std::vector<std::string> out;
    for (const Diagnostic& d : diagnostics_.all()) {
      if (d.severity == Severity::error) out.push_back(d.path + ": " + d.message);
    }
    return out;
  }

  fs::path dir_;
  TypeRegistry types_;
  Diagnostics diagnostics_;
};

TEST_F(NotificationsProfile, AddsAnEventOutputPortOfTheNotificationType) {
  auto app = load("inproc", "<notifications auto=\"true\"/>");
  ASSERT_TRUE(app) << ::testing::PrintToString(errors());
  const ComponentProfile& c = app->components.front().profile;
  const PortSpec* port = c.find_port("notifications");
  ASSERT_NE(port, nullptr);
  EXPECT_EQ(port->kind, PortKind::event);
  EXPECT_EQ(port->direction, PortDirection::output);
  EXPECT_EQ(port->data_type, "polyport::ComponentNotification");
  const auto* settings = dynamic_cast<const NotificationSettings*>(c.model_settings.get());
  ASSERT_NE(settings, nullptr);
  EXPECT_EQ(settings->port, "notifications");
  EXPECT_TRUE(settings->automatic);
}

TEST_F(NotificationsProfile, ADataPortWithAnotherName) {
  auto app = load("inproc", "<notifications port=\"events\" kind=\"data\"/>");
  ASSERT_TRUE(app) << ::testing::PrintToString(errors());
  const PortSpec* port = app->components.front().profile.find_port("events");
  ASSERT_NE(port, nullptr);
  EXPECT_EQ(port->kind, PortKind::data);
}

TEST_F(NotificationsProfile, EachProblemIsReportedAtItsPlace) {
  EXPECT_FALSE(load("inproc", "<notifications port=\"state\"/>"));
  EXPECT_EQ(errors(), std::vector<std::string>{"/component_profile/notifications/@port: the notification port "
                                               "'state' is already a port of the component"});
  EXPECT_FALSE(load("inproc", "<notifications auto=\"maybe\"/>"));
  ASSERT_EQ(errors().size(), 1u);
  EXPECT_EQ(errors()[0].rfind("/component_profile/notifications/@auto: bad auto 'maybe' (accepted: ", 0), 0u)
      << errors()[0];
  EXPECT_FALSE(load("inproc", "<notifications kind=\"topic\"/>"));
  EXPECT_EQ(errors(), std::vector<std::string>{"/component_profile/notifications/@kind: bad kind 'topic' "
                                               "(accepted: event, data)"});
  EXPECT_FALSE(load("lcm", "<notifications/>"));
  EXPECT_EQ(errors(), std::vector<std::string>{"/component_profile/notifications: <notifications> are raised by "
                                               "in-process components; a component of model 'lcm' carries "
                                               "polyport::ComponentNotification on a port of its own"});
}

}  // namespace
}  // namespace polyport
