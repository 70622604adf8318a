// Recording end to end: polyportd records an LCM -> LCM connection (`run --record`), and
// Debian's lcm-logplayer replays the log into an LCM application built with lcm-gen
// (tests/lcm_e2e/lcm_peer), which checks every field of every pose against what the
// publisher sent. A DDS -> LCM connection is recorded in its CDR bytes on the channel named
// after the connection, which lcm-logplayer -v lists.
//
// Each case runs in a network namespace of its own with a multicast route on loopback
// (tests/support/multicast_namespace.hpp); that needs root.
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iterator>
#include <set>
#include <sstream>

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

// An event of an LCM log, read by hand (the format of lcm/eventlog.c: big-endian magic
// 0xEDA1DA01, event number, microseconds, channel length, data length, channel, data).
struct LogEvent {
  std::int64_t timestamp_us = 0;
  std::string channel;
  std::string data;
};

std::vector<LogEvent> read_log(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  auto be = [&](std::size_t at, int n) {
    std::uint64_t v = 0;
    for (int k = 0; k < n; ++k) v = (v << 8) | static_cast<unsigned char>(bytes[at + static_cast<std::size_t>(k)]);
    return v;
  };
  std::vector<LogEvent> out;
  std::size_t at = 0;
  while (at + 28 <= bytes.size()) {
    EXPECT_EQ(be(at, 4), 0xEDA1DA01u) << "at byte " << at;
    if (be(at, 4) != 0xEDA1DA01u) break;
    LogEvent e;
    e.timestamp_us = static_cast<std::int64_t>(be(at + 12, 8));
    const std::size_t channel_len = be(at + 20, 4), data_len = be(at + 24, 4);
    e.channel = bytes.substr(at + 28, channel_len);
    e.data = bytes.substr(at + 28 + channel_len, data_len);
    at += 28 + channel_len + data_len;
    out.push_back(std::move(e));
  }
  EXPECT_EQ(at, bytes.size()) << "the log ends inside an event";
  return out;
}

TEST_F(RecordEndToEnd, ADdsSourceIsRecordedInItsCdrBytesOnTheConnectionsChannel) {
  if (std::string(CYCLONE_PEER).empty()) GTEST_SKIP() << "the Cyclone DDS model or its test peer is not built";
  // Cyclone DDS on loopback in this namespace (as in tests/lcm_e2e).
  setenv("CYCLONEDDS_URI", "file://" POLYPORT_SOURCE_DIR "/config/cyclonedds-loopback.xml", 1);
  const fs::path log = dir() / "dds.lcmlog";
  auto sub = lcm_peer("sub", {"sub", kUrl, "POSE_OUT"});
  ASSERT_TRUE(eventually([&] { return sub->saw_event("subscribed"); }));
  auto daemon = this->daemon(app("from_dds_app.xml"), {"--record", log.string()});  // every data connection
  auto pub = peer(CYCLONE_PEER, "dds_pub", {"pub", "17", "pose", "0", "10"});
  ASSERT_TRUE(eventually([&] { return poses(*sub).size() >= 10; }, 60s))
      << "LCM sub: " << poses(*sub).size() << " poses\n" << daemon->errors() << pub->errors();
  pub.reset();
  const Json stats = stop(*daemon);
  const Json* entry = recorded(stats, "dds.pose -> lcm.pose");
  ASSERT_NE(entry, nullptr);
  EXPECT_EQ((*entry)["channel"], "dds.pose->lcm.pose");
  EXPECT_EQ((*entry)["encoding"], "xcdr1");
  EXPECT_EQ((*entry)["dropped"], 0);
  const std::vector<LogEvent> events = read_log(log);
  ASSERT_EQ(events.size(), (*entry)["recorded"].get<std::size_t>());
  ASSERT_GE(events.size(), 10u);
  std::set<int> forwarded;
  for (const Json& pose : poses(*sub)) forwarded.insert(pose["id"].get<int>());
  for (const LogEvent& e : events) {
    EXPECT_EQ(e.channel, "dds.pose->lcm.pose");
    // CDR as the DDS writer sent it: the encapsulation header (plain CDR, little endian),
    // then Pose.id.
    ASSERT_GE(e.data.size(), 8u);
    EXPECT_EQ(e.data[0], 0);
    EXPECT_EQ(e.data[1], 1);
    std::int32_t id = 0;
    std::memcpy(&id, e.data.data() + 4, sizeof id);
    EXPECT_TRUE(forwarded.count(id)) << "recorded pose " << id << " never reached the LCM sink";
  }
  // lcm-logplayer reads the log and lists every event on that channel.
  std::string output;
  ASSERT_EQ(play(log, "-v -s 100", output), 0) << output;
  std::size_t listed = 0;  // lines "<seconds> Channel dds.pose->lcm.pose   size <bytes>"
  std::istringstream lines(output);
  for (std::string text; std::getline(lines, text);) {
    if (text.find(" Channel dds.pose->lcm.pose ") != std::string::npos && text.find(" size ") != std::string::npos) ++listed;
  }
  EXPECT_EQ(listed, events.size()) << output;
}

}  // namespace
}  // namespace polyport::test
