// The youBot case end to end (profiles/youbot*.xml): polyportd runs the shipped profiles, the
// other side is youbot_dds_node (built with idlc from config/types/youbot.idl) where the
// profile puts it on Cyclone DDS. Each run plays the monitor's script to its end; the test
// then reads, field by field, what the monitor saw: the queried joint positions equal to the
// commanded pose, busy and idle notifications (they carried the script from phase to phase),
// refreshes, and the driver's cycles per second from its state stamps before and after the
// period change. No timing bound: the driver's period goes from 10 to 40 ms, and the rate
// measured after must be the lower one.
#include <gtest/gtest.h>

#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "../support/daemon_harness.hpp"
#include "../support/multicast_namespace.hpp"

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

// One notification as lcm-logger recorded it: component_notification.lcm's struct, LCM's
// big-endian encoding after the 8-byte fingerprint.
struct LoggedNotification {
  std::int32_t kind;
  std::int64_t serial;
  std::int64_t time_ns;
  std::string component;
};

std::uint64_t big_endian(const std::vector<std::uint8_t>& bytes, std::size_t at, int size) {
  std::uint64_t v = 0;
  for (int i = 0; i < size; ++i) v = (v << 8) | bytes.at(at + static_cast<std::size_t>(i));
  return v;
}

// The events of an LCM log file (LCM's log format: sync word, event number, time, channel
// length, data length, channel, data) on `channel`, decoded.
std::vector<LoggedNotification> logged_notifications(const fs::path& log, const std::string& channel) {
  std::ifstream in(log, std::ios::binary);
  const std::vector<std::uint8_t> b((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::vector<LoggedNotification> out;
  std::size_t at = 0;
  while (at + 28 <= b.size()) {
    if (big_endian(b, at, 4) != 0xEDA1DA01u) break;
    const auto channel_size = static_cast<std::size_t>(big_endian(b, at + 20, 4));
    const auto data_size = static_cast<std::size_t>(big_endian(b, at + 24, 4));
    const std::size_t data = at + 28 + channel_size;
    if (data + data_size > b.size()) break;  // the logger was still writing it
    if (std::string(b.begin() + static_cast<std::ptrdiff_t>(at + 28), b.begin() + static_cast<std::ptrdiff_t>(data)) ==
            channel &&
        data_size >= 8 + 4 + 8 + 8 + 4) {
      LoggedNotification n;
      std::size_t p = data + 8;  // past the fingerprint
      n.kind = static_cast<std::int32_t>(big_endian(b, p, 4));
      n.serial = static_cast<std::int64_t>(big_endian(b, p + 4, 8));
      n.time_ns = static_cast<std::int64_t>(big_endian(b, p + 12, 8));
      const auto length = static_cast<std::size_t>(big_endian(b, p + 20, 4));  // with the NUL
      if (length > 0 && p + 24 + length <= data + data_size) {
        n.component.assign(b.begin() + static_cast<std::ptrdiff_t>(p + 24),
                           b.begin() + static_cast<std::ptrdiff_t>(p + 24 + length - 1));
      }
      out.push_back(n);
    }
    at = data + data_size;
  }
  return out;
}

// The driver's notifications on an LCM channel as well: lcm-logger (Debian's lcm-tools), a
// program that knows nothing of polyport, records them; the test decodes its log.
TEST_F(YoubotTest, NotificationsReachAnLcmChannel) {
  isolate_with_multicast_route();
  if (HasFatalFailure()) return;
  if (std::system("command -v lcm-logger > /dev/null") != 0) GTEST_SKIP() << "lcm-logger (lcm-tools) is not installed";
  const fs::path log = dir() / "notifications.lcmlog";
  auto logger = peer("/usr/bin/lcm-logger", "logger",
                     {"-q", "-f", "--flush-interval=10", "-c", "YOUBOT_NOTIFICATIONS", log.string()});
  auto daemon = this->daemon(POLYPORT_SOURCE_DIR "/tests/youbot/data/youbot_lcm.xml");
  ASSERT_TRUE(eventually([&] { return monitor_done(*daemon); }, 60s)) << daemon->errors();
  std::vector<LoggedNotification> logged;
  // Done means busy and idle twice: wait for the logger to have them on disk.
  ASSERT_TRUE(eventually([&] {
    logged = logged_notifications(log, "YOUBOT_NOTIFICATIONS");
    int idle = 0;
    for (const auto& n : logged) idle += n.kind == 1;
    return idle >= 2;
  })) << logged.size() << " notifications logged";
  stop(*daemon);
  int busy = 0, idle = 0, refresh = 0;
  for (std::size_t i = 0; i < logged.size(); ++i) {
    const LoggedNotification& n = logged[i];
    EXPECT_EQ(n.component, "Driver");
    ASSERT_TRUE(n.kind >= 0 && n.kind <= 2) << n.kind;
    busy += n.kind == 0;
    idle += n.kind == 1;
    refresh += n.kind == 2;
    if (i > 0) {
      EXPECT_GT(n.serial, logged[i - 1].serial);
      EXPECT_GE(n.time_ns, logged[i - 1].time_ns);
    }
  }
  EXPECT_GE(busy, 2);
  EXPECT_GE(idle, 2);
  EXPECT_GT(refresh, 0);
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
