// Recording end to end: polyportd records an LCM -> LCM connection (`run --record`), and
// Debian's lcm-logplayer replays the log into an LCM application built with lcm-gen
// (tests/lcm_e2e/lcm_peer), which checks every field of every pose against what the
// publisher sent. A DDS -> LCM connection is recorded in its CDR bytes on the channel named
// after the connection, which lcm-logplayer -v lists.
//
// Each case runs in a network namespace of its own with a multicast route on loopback
// (tests/support/multicast_namespace.hpp); that needs root.
#include <cstdlib>
#include <fstream>
#include <set>

#include "../support/multicast_namespace.hpp"
#include "pose_checks.hpp"

namespace polyport::test {
namespace {

constexpr const char* kUrl = "udpm://239.255.76.67:7667?ttl=0";

class RecordEndToEnd : public DaemonTest {
 protected:
  RecordEndToEnd() : DaemonTest("polyport-record") {}

  void SetUp() override {
    DaemonTest::SetUp();
    isolate_with_multicast_route();
  }
  fs::path app(const std::string& name) {
    return fill_templates(POLYPORT_TEST_DATA "/lcm_e2e",
                          {{"@URL@", kUrl},
                           {"@DDS_MODEL@", "cyclonedds"},
                           {"@SOURCE_CHANNEL@", "POSE_IN"},
                           {"@SINK_CHANNEL@", "POSE_OUT"},
                           {"@A@", "17"},
                           {"@CAP@", "16"},
                           {"@TIMEOUT@", "150"},
                           {"@SRC@", POLYPORT_SOURCE_DIR}},
                          name);
  }
  std::unique_ptr<Child> lcm_peer(const std::string& tag, std::vector<std::string> args) {
    return peer(LCM_PEER, tag, std::move(args));
  }
  // The ids a publisher printed as published.
  static std::set<int> published(const Child& publisher) {
    std::set<int> ids;
    for (const Json& j : publisher.lines()) {
      if (j.value("event", "") == "published" && j.contains("id")) ids.insert(j["id"].get<int>());
    }
    return ids;
  }
  // The recording's entry of a connection in the statistics.
  static const Json* recorded(const Json& stats, const std::string& name) {
    if (!stats.contains("recording")) {
      ADD_FAILURE() << "no recording in " << stats.dump(2);
      return nullptr;
    }
    for (const Json& c : stats["recording"]["connections"]) {
      if (c["connection"] == name) return &c;
    }
    ADD_FAILURE() << "no recorded connection " << name << " in " << stats.dump(2);
    return nullptr;
  }
  // Runs lcm-logplayer on the log to its end; its output (stdout and stderr) in `output`.
  int play(const fs::path& log, const std::string& options, std::string& output) {
    const fs::path out = dir() / "logplayer.txt";
    const std::string command = "lcm-logplayer " + options + " -l '" + kUrl + "' '" + log.string() + "' > '" +
                                out.string() + "' 2>&1";
    const int status = std::system(command.c_str());
    std::ifstream in(out);
    output.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
    return status;
  }
};

TEST_F(RecordEndToEnd, LogplayerReplaysAnLcmConnectionIntoAnLcmGenPeerWithEveryValue) {
  const fs::path log = dir() / "run.lcmlog";
  auto sub = lcm_peer("sub", {"sub", kUrl, "POSE_OUT"});
  ASSERT_TRUE(eventually([&] { return sub->saw_event("subscribed"); }));
  auto daemon = this->daemon(app("passthrough_app.xml"),
                             {"--record", log.string(), "--record-connection", "source.pose->sink.pose"});
  auto pub = lcm_peer("pub", {"pub", kUrl, "POSE_IN", "10"});
  ASSERT_TRUE(eventually([&] { return poses(*sub).size() >= 30; }, 30s))
      << "sub: " << poses(*sub).size() << " poses\n" << daemon->errors() << sub->errors();
  pub->signal(SIGINT);
  pub->wait(10s);
  const std::set<int> sent = published(*pub);
  const Json stats = stop(*daemon);
  const Json* entry = recorded(stats, "source.pose -> sink.pose");
  ASSERT_NE(entry, nullptr);
  EXPECT_EQ((*entry)["channel"], "POSE_IN");
  EXPECT_EQ((*entry)["encoding"], "lcm");
  EXPECT_EQ((*entry)["dropped"], 0);
  const Json* link = connection(stats, "source.pose -> sink.pose");
  ASSERT_NE(link, nullptr);
  // Every sample that entered the connection is in the log.
  const int count = (*entry)["recorded"].get<int>();
  EXPECT_EQ(count, (*link)["received"].get<int>());
  EXPECT_EQ((*link)["recorded"], count);
  EXPECT_EQ((*link)["record_dropped"], 0);
  ASSERT_GE(count, 30);
  std::set<int> forwarded;
  for (const Json& pose : poses(*sub)) forwarded.insert(pose["id"].get<int>());
  sub.reset();

  // The daemon is gone: only the log speaks on POSE_IN now.
  auto replayed_sub = lcm_peer("replayed", {"sub", kUrl, "POSE_IN"});
  ASSERT_TRUE(eventually([&] { return replayed_sub->saw_event("subscribed"); }));
  std::string output;
  ASSERT_EQ(play(log, "-s 4", output), 0) << output;
  ASSERT_TRUE(eventually([&] { return poses(*replayed_sub).size() >= static_cast<std::size_t>(count); }, 30s))
      << "replayed " << poses(*replayed_sub).size() << " of " << count << "\n" << replayed_sub->errors();
  const std::vector<Json> replayed = poses(*replayed_sub);
  EXPECT_EQ(replayed.size(), static_cast<std::size_t>(count));
  for (const Json& pose : replayed) expect_pose(pose);
  expect_increasing(replayed);
  // What was forwarded live is what the log replays (the sink saw every pose the source took).
  std::set<int> replayed_ids;
  for (const Json& pose : replayed) replayed_ids.insert(pose["id"].get<int>());
  EXPECT_EQ(replayed_ids, forwarded);
  for (const int id : replayed_ids) EXPECT_TRUE(sent.count(id)) << "replayed pose " << id << " was never published";
}

}  // namespace
}  // namespace polyport::test
