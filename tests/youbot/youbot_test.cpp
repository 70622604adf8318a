// The youBot case end to end (profiles/youbot*.xml): polyportd runs the shipped profiles, the
// other side is youbot_dds_node (built with idlc from config/types/youbot.idl) where the
// profile puts it on Cyclone DDS. Each run plays the monitor's script to its end; the test
// then reads, field by field, what the monitor saw: the queried joint positions equal to the
// commanded pose, busy and idle notifications (they carried the script from phase to phase),
// refreshes, and the driver's cycles per second from its state stamps before and after the
// period change. No timing bound: the driver's period goes from 10 to 40 ms, and the rate
// measured after must be the lower one.
#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <string>

#include "../support/daemon_harness.hpp"

namespace polyport::test {
namespace {

const fs::path kProfiles = POLYPORT_SOURCE_DIR "/profiles";
constexpr double kPoseB[5] = {-0.2, 0.3, -0.5, 0.4, 0.0};  // youbot_model.hpp: the script's last pose

class YoubotTest : public DaemonTest {
 public:
  YoubotTest() : DaemonTest("polyport-youbot") {}
  void SetUp() override {
    DaemonTest::SetUp();
    // The DDS programs on loopback, as polyport's own side (the profiles' default config).
    setenv("CYCLONEDDS_URI", "file://" POLYPORT_SOURCE_DIR "/config/cyclonedds-loopback.xml", 1);
  }

  // The last report the in-process monitor wrote (--trace Monitor.report).
  Json last_report(const fs::path& trace) const {
    Json last;
    std::ifstream in(trace);
    std::string text;
    while (std::getline(in, text)) {
      Json j = Json::parse(text, nullptr, false);
      if (!j.is_discarded() && j.contains("value")) last = j["value"];
    }
    return last;
  }
};

// What every configuration's monitor must have seen at the end of its script.
void check_report(const Json& r) {
  ASSERT_TRUE(r.is_object()) << "no report";
  EXPECT_EQ(r["phase"].get<int>(), 2) << r.dump();
  for (int j = 0; j < 5; ++j) {
    EXPECT_DOUBLE_EQ(r["commanded_rad"][j].get<double>(), kPoseB[j]) << "joint " << j + 1;
    EXPECT_NEAR(r["queried_rad"][j].get<double>(), kPoseB[j], 1e-6) << "joint " << j + 1;
  }
  EXPECT_GE(r["busy"].get<int>(), 2) << r.dump();  // one per pose
  EXPECT_GE(r["idle"].get<int>(), 2) << r.dump();
  EXPECT_GT(r["refresh"].get<int>(), 0) << r.dump();
  EXPECT_GT(r["queries"].get<int>(), 0) << r.dump();
  EXPECT_DOUBLE_EQ(r["period_before_s"].get<double>(), 0.010) << r.dump();
  EXPECT_DOUBLE_EQ(r["period_after_s"].get<double>(), 0.040) << r.dump();
  EXPECT_GT(r["rate_before_hz"].get<double>(), 0.0) << r.dump();
  EXPECT_GT(r["rate_after_hz"].get<double>(), 0.0) << r.dump();
  EXPECT_LT(r["rate_after_hz"].get<double>(), r["rate_before_hz"].get<double>()) << r.dump();
}

bool monitor_done(const Child& daemon) { return daemon.errors().find("pose B reached") != std::string::npos; }

TEST_F(YoubotTest, CheckAcceptsEveryShippedProfileAndShowsTheNotificationPort) {
  for (const char* profile : {"youbot.xml", "youbot_dds_monitor.xml", "youbot_dds_driver.xml"}) {
    const fs::path out = dir() / (std::string(profile) + ".check");
    const std::string command = std::string(POLYPORTD) + " check " + (kProfiles / profile).string() + " > " +
                                out.string() + " 2>&1";
    EXPECT_EQ(std::system(command.c_str()), 0) << profile;
    std::ifstream in(out);
    const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    EXPECT_NE(text.find("polyport::ComponentNotification"), std::string::npos) << profile << ":\n" << text;
  }
}

TEST_F(YoubotTest, InProcessMonitorCommandsQueriesHearsNotificationsAndChangesThePeriod) {
  const fs::path trace = dir() / "report.jsonl";
  auto daemon = this->daemon(kProfiles / "youbot.xml", {"--trace", "Monitor.report", "--trace-file", trace.string()});
  ASSERT_TRUE(eventually([&] { return monitor_done(*daemon); }, 60s)) << daemon->errors();
  const Json stats = stop(*daemon);
  check_report(last_report(trace));
  // The driver's own context runs at the period the monitor asked for.
  bool found = false;
  for (const Json& ec : stats["execution_contexts"]) {
    if (ec["name"] != "Driver") continue;
    found = true;
    EXPECT_EQ(ec["period_ns"].get<std::int64_t>(), 40'000'000) << ec.dump();
    EXPECT_GE(ec["period_changes"].get<int>(), 1) << ec.dump();
  }
  EXPECT_TRUE(found) << stats["execution_contexts"].dump();
}

#ifdef YOUBOT_DDS_NODE
TEST_F(YoubotTest, DdsMonitorProgramDrivesTheInProcessDriver) {
  if (std::string(POLYPORT_CYCLONE_MISSING) != "") GTEST_SKIP() << POLYPORT_CYCLONE_MISSING;
  auto daemon = this->daemon(kProfiles / "youbot_dds_monitor.xml");
  auto monitor = peer(YOUBOT_DDS_NODE, "monitor", {"--role", "monitor", "--exit-when-done"});
  EXPECT_EQ(monitor->wait(90s), 0) << monitor->errors() << daemon->errors();
  stop(*daemon);
  Json report;
  for (const Json& line : monitor->lines()) {
    if (line.value("event", "") == "report") report = line;
  }
  check_report(report);
}

TEST_F(YoubotTest, InProcessMonitorDrivesTheDdsDriverProgram) {
  if (std::string(POLYPORT_CYCLONE_MISSING) != "") GTEST_SKIP() << POLYPORT_CYCLONE_MISSING;
  auto driver = peer(YOUBOT_DDS_NODE, "driver", {"--role", "driver"});
  ASSERT_TRUE(eventually([&] { return driver->saw_event("running"); })) << driver->errors();
  const fs::path trace = dir() / "report.jsonl";
  auto daemon =
      this->daemon(kProfiles / "youbot_dds_driver.xml", {"--trace", "Monitor.report", "--trace-file", trace.string()});
  ASSERT_TRUE(eventually([&] { return monitor_done(*daemon); }, 60s)) << daemon->errors() << driver->errors();
  stop(*daemon);
  check_report(last_report(trace));
  // The driver program took the new period from the period topic.
  bool period_changed = false;
  for (const Json& line : driver->lines()) {
    if (line.value("event", "") == "period") period_changed = line["period_s"].get<double>() == 0.040;
  }
  EXPECT_TRUE(period_changed);
}
#endif

}  // namespace
}  // namespace polyport::test
