// Loop prevention on CAN (label vm: a guest of its own with vcan0 and vcan1):
// tests/data/socketcan/loop_app.xml bridges EngineData (0x100) both ways between the two
// buses, a reading and a sending component (two raw sockets) on each. The kernel hands each
// frame polyport sends on a bus to polyport's reading socket of that bus too, so without loop
// prevention a frame would go from bus to bus for as long as the daemon runs (candump would
// show it again and again). cansend sends five frames on each bus; each reaches the other bus
// exactly once, and each reading socket drops exactly the five frames polyport sent on its bus
// (`loop_dropped`). candump and cansend are the peers; every wait has a deadline.
#include <gtest/gtest.h>

#include <fstream>
#include <map>
#include <sstream>
#include <string>

#include "../support/daemon_harness.hpp"
#include "can_peer.hpp"

namespace polyport {
namespace {

using test::cansend;
using test::Child;
using test::Json;
namespace fs = std::filesystem;
using namespace std::chrono_literals;

class SocketCanLoop : public test::DaemonTest {
 protected:
  SocketCanLoop() : DaemonTest("polyport-can-loop") {}

  std::string text_of(const std::string& tag) const {
    std::ifstream in(dir() / (tag + ".out"));
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
  }
  // EngineData frames candump printed ("vcan1 100#..." lines), by data, with their counts.
  std::map<std::string, int> engine_frames(const std::string& tag) const {
    std::map<std::string, int> frames;
    std::istringstream lines(text_of(tag));
    for (std::string line; std::getline(lines, line);) {
      const auto at = line.find(" 100#");
      if (at != std::string::npos) ++frames[line.substr(at + 5)];
    }
    return frames;
  }
  Json live_stats(const fs::path& socket) {
    Child ctl(dir(), "ctl", {POLYPORTCTL, "--socket", socket.string(), "--json", "stats"});
    EXPECT_EQ(ctl.wait(20s), 0) << ctl.errors();
    std::ifstream out(dir() / "ctl.out");
    const Json s = Json::parse(out, nullptr, false);
    return s.is_discarded() ? Json::object() : s;
  }
};

std::int64_t loop_dropped(const Json& stats, const std::string& component) {
  if (!stats.contains("components")) return -1;
  for (const Json& c : stats["components"]) {
    if (c.value("name", "") == component && c.contains("socketcan")) return c["socketcan"].value("loop_dropped", -1);
  }
  return -1;
}

TEST_F(SocketCanLoop, IdBridgedBothWaysBetweenTwoBusesForwardsEachFrameOnce) {
  const fs::path socket = dir() / "admin.sock";
  auto daemon = this->daemon(POLYPORT_TEST_DATA "/socketcan/loop_app.xml", {"--admin-socket", socket.string()});
  auto dump0 = std::make_unique<Child>(dir(), "dump0", std::vector<std::string>{CANDUMP, "-L", "vcan0"});
  auto dump1 = std::make_unique<Child>(dir(), "dump1", std::vector<std::string>{CANDUMP, "-L", "vcan1"});
  // candump binds some time after it starts: a frame of an id nobody bridges until both print one.
  ASSERT_TRUE(test::eventually([&] {
    EXPECT_EQ(cansend("vcan0", "7FF#00"), "");
    EXPECT_EQ(cansend("vcan1", "7FF#00"), "");
    return text_of("dump0").find("7FF#") != std::string::npos && text_of("dump1").find("7FF#") != std::string::npos;
  }, 10s)) << "candump printed nothing";

  for (int i = 1; i <= 5; ++i) {
    ASSERT_EQ(cansend("vcan0", "100#00000000000000A" + std::to_string(i)), "");
    ASSERT_EQ(cansend("vcan1", "100#00000000000000B" + std::to_string(i)), "");
  }
  // Each frame polyport sent on a bus came back to its reading socket of that bus, and went
  // no further.
  ASSERT_TRUE(test::eventually([&] {
    const Json s = live_stats(socket);
    return loop_dropped(s, "r0") == 5 && loop_dropped(s, "r1") == 5;
  }, 10s)) << live_stats(socket).dump(2) << daemon->errors();
  const Json stats = stop(*daemon);
  dump0.reset();  // SIGTERM: candump ends and its output is complete
  dump1.reset();

  for (const char* tag : {"dump0", "dump1"}) {
    const auto frames = engine_frames(tag);
    EXPECT_EQ(frames.size(), 10u) << tag << ":\n" << text_of(tag);  // its own bus's five, the other's five
    for (const auto& [data, count] : frames) EXPECT_EQ(count, 1) << tag << ": " << data << "\n" << text_of(tag);
  }
  for (const Json& c : stats["connections"]) {
    EXPECT_EQ(c["received"], 5) << c.dump(2);
    EXPECT_EQ(c["delivered"], 5) << c.dump(2);
  }
  EXPECT_EQ(loop_dropped(stats, "r0"), 5) << stats.dump(2);
  EXPECT_EQ(loop_dropped(stats, "r1"), 5) << stats.dump(2);
}

}  // namespace
}  // namespace polyport
