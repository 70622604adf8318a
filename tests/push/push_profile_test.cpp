// <push> on output data ports and <subscription every> on connections: what the loader reads,
// and every problem, each at its file:line:col.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>
#include <vector>

#include "polyport/base/diagnostics.hpp"
#include "polyport/profile/profile.hpp"
#include "polyport/types/types.hpp"

namespace polyport {
namespace {

namespace fs = std::filesystem;

fs::path profiles_dir() { return fs::weakly_canonical(fs::path(POLYPORT_SOURCE_DIR) / "tests/push/profiles"); }

class PushProfiles : public ::testing::Test {
 protected:
  std::optional<ApplicationProfile> load(const std::string& file) {
    return load_application_profile(profiles_dir() / file, types_, options_, diagnostics_);
  }
  // Every diagnostic, the fixture folder cut out of file names.
  std::vector<std::string> messages() const {
    const std::string prefix = profiles_dir().string() + "/";
    std::vector<std::string> out;
    for (const Diagnostic& item : diagnostics_.all()) {
      std::string text = item.to_string();
      for (auto at = text.find(prefix); at != std::string::npos; at = text.find(prefix, at)) text.erase(at, prefix.size());
      out.push_back(std::move(text));
    }
    return out;
  }
  TypeRegistry types_;
  Diagnostics diagnostics_;
  LoadOptions options_;
};

TEST_F(PushProfiles, ReadsPushPortsAndSubscriptions) {
  const auto app = load("valid_app.xml");
  ASSERT_TRUE(app.has_value()) << ::testing::PrintToString(messages());
  EXPECT_TRUE(messages().empty()) << ::testing::PrintToString(messages());
  const ComponentProfile& server = app->find_component("server")->profile;
  ASSERT_TRUE(server.find_port("newest")->push.has_value());
  EXPECT_EQ(server.find_port("newest")->push->pattern, PushPattern::newest);
  ASSERT_TRUE(server.find_port("timed")->push.has_value());
  EXPECT_EQ(server.find_port("timed")->push->pattern, PushPattern::timed);
  EXPECT_EQ(server.find_port("timed")->push->cycle_ms, 20.0);
  EXPECT_FALSE(server.find_port("plain")->push.has_value());
  ASSERT_EQ(app->connections.size(), 2u);
  EXPECT_FALSE(app->connections[0].subscription_every.has_value());
  ASSERT_TRUE(app->connections[1].subscription_every.has_value());
  EXPECT_EQ(*app->connections[1].subscription_every, 3u);
}

TEST_F(PushProfiles, APushTimedSubscriberWithAnInvalidCycleIsALoadError) {
  EXPECT_FALSE(load("bad_subscriptions_app.xml").has_value());
  const std::string file = "bad_subscriptions_app.xml:";
  const std::string connection = "/application_profile/port_connections/port_connection";
  const std::string expected = ": expected a whole number of the server's base cycles, from 1 to 1000000";
  const std::string not_timed = " is not a push timed port: a subscription takes every Nth base cycle of an output "
                                "data port with <push pattern=\"timed\" cycle_ms=\"...\"/>";
  EXPECT_EQ(messages(), (std::vector<std::string>{
      // Reading: every="0", every="2.5", no every.
      file + "13:28: " + connection + "[1]/subscription/@every: bad every '0'" + expected,
      file + "18:28: " + connection + "[2]/subscription/@every: bad every '2.5'" + expected,
      file + "33:7: " + connection + "[5]/subscription: missing attribute 'every' (this subscriber takes every Nth "
      "cycle of the server)",
      file + "38:28: " + connection + "[6]/subscription/@every: bad every '4294967295'" + expected,
      // Checking against the ports: a plain port, a push newest port.
      file + "23:7: " + connection + "[3]/subscription: server.plain" + not_timed,
      file + "28:7: " + connection + "[4]/subscription: server.newest" + not_timed,
  }));
}

TEST_F(PushProfiles, EveryPushProblemAtItsPlace) {
  EXPECT_FALSE(load("bad_servers_app.xml").has_value());
  const std::string file = "BadServer.xml:";
  const std::string port = "/component_profile/ports/data_port";
  EXPECT_EQ(messages(), (std::vector<std::string>{
      file + "10:89: " + port + "[1]/push: missing attribute 'cycle_ms' (a push timed port's base cycle, which "
      "subscribers take multiples of)",
      file + "11:121: " + port + "[2]/push/@cycle_ms: a push timed port's base cycle is a whole multiple of its "
      "component's period (10 ms): cycle_ms 15 is not; e.g. 10, 20 or 30",
      file + "12:121: " + port + "[3]/push/@cycle_ms: bad cycle_ms '0': expected milliseconds, a decimal above 0 "
      "and at most 86400000",
      file + "13:122: " + port + "[4]/push/@cycle_ms: cycle_ms applies only to push timed (pattern=\"timed\"); "
      "push newest publishes whenever a new value comes",
      file + "14:104: " + port + "[5]/push/@pattern: bad pattern 'often': expected newest or timed",
      file + "15:88: " + port + "[6]/push: <push> applies only to output data ports: the server publishes, its "
      "subscribers are the connections from it",
      file + "16:89: " + port + "[7]/push: missing attribute 'pattern' (newest or timed)",
  }));
}

}  // namespace
}  // namespace polyport
