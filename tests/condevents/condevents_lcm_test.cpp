// Events with conditions across LCM: the server is an LCM application built with lcm-gen
// (tests/lcm_e2e/lcm_peer pub: its pose is the server's state), the clients are LCM
// applications too (lcm_peer sub on the event channels). polyportd tests each state on the
// way: a continuous event gets every state for which its condition holds, a single-shot one
// the first such state only, and one whose condition never holds gets nothing, which its
// statistics show (tested, never fired), live through polyportctl and at the end.
//
// Runs in a network namespace of its own with a multicast route on loopback (needs root),
// like tests/lcm_e2e.
#include <fstream>
#include <iterator>

#include "../dds_peers/pose_checks.hpp"
#include "../support/multicast_namespace.hpp"

namespace polyport::test {
namespace {

constexpr const char* kUrl = "udpm://239.255.76.67:7667?ttl=0";

class ConditionEventsLcm : public DaemonTest {
 protected:
  ConditionEventsLcm() : DaemonTest("polyport-condevents") {}

  void SetUp() override {
    DaemonTest::SetUp();
    isolate_with_multicast_route();
    socket_ = dir() / "admin.sock";
  }
  fs::path app(const std::string& name = "lcm_app.xml") const {
    return fill_templates(POLYPORT_TEST_DATA "/condevents_lcm",
                          {{"@URL@", kUrl}, {"@A@", "17"}, {"@SRC@", POLYPORT_SOURCE_DIR}}, name);
  }
  std::unique_ptr<Child> lcm_peer(const std::string& tag, std::vector<std::string> args) {
    return peer(LCM_PEER, tag, std::move(args));
  }
  // `polyportctl --json stats`, parsed (discarded when it failed).
  Json ctl_stats() {
    const Ran stats = ctl({"--json", "stats"});
    return stats.code == 0 ? stats.json() : Json::parse("x", nullptr, false);
  }

  // `polyportctl ARGS...` on the daemon's socket.
  Ran ctl(std::vector<std::string> args) {
    args.insert(args.begin(), {POLYPORTCTL, "--socket", socket_.string()});
    return run_to_end(args);
  }

  fs::path socket_;
};

Json condition_of(const Json& stats, const std::string& name) {
  const Json* c = connection(stats, name);
  return c != nullptr && c->contains("condition") ? (*c)["condition"] : Json();
}

TEST_F(ConditionEventsLcm, LcmClientsGetOnlyTheStatesTheirConditionsHoldFor) {
  auto continuous = lcm_peer("continuous", {"sub", kUrl, "EVENT_CONTINUOUS"});
  auto single = lcm_peer("single", {"sub", kUrl, "EVENT_SINGLE"});
  auto never = lcm_peer("never", {"sub", kUrl, "EVENT_NEVER"});
  auto daemon = this->daemon(app(), {"--admin-socket", socket_.string()});
  auto server = lcm_peer("server", {"pub", kUrl, "STATE", "5"});
  // Twenty events on the continuous channel; the never-holding condition tested as often.
  Json live;
  ASSERT_TRUE(eventually([&] {
    if (poses(*continuous).size() < 20) return false;
    live = ctl_stats();
    return !live.is_discarded() && condition_of(live, "server.state -> never.event").value("tested", 0) >= 20;
  }, 60s)) << "continuous: " << poses(*continuous).size() << " poses\n" << live.dump(2) << daemon->errors();
  const Json never_live = condition_of(live, "server.state -> never.event");
  EXPECT_EQ(never_live["fired"], 0) << never_live.dump();
  EXPECT_EQ(never_live["suppressed"], never_live["tested"]) << never_live.dump();
  server.reset();

  // continuous: x > 2, every field as published, each state once, in order.
  const std::vector<Json> got = poses(*continuous);
  for (const Json& pose : got) {
    expect_pose(pose);
    EXPECT_GT(pose["x"].get<double>(), 2.0) << pose.dump();
  }
  expect_increasing(got);
  // single: one state, the first with heading >= 1 and id >= 1005 that polyport saw.
  const std::vector<Json> once = poses(*single);
  ASSERT_EQ(once.size(), 1u) << single->errors();
  expect_pose(once[0]);
  EXPECT_GE(once[0]["heading"].get<double>(), 1.0);
  EXPECT_GE(once[0]["id"].get<int>(), 1005);
  // never: nothing.
  EXPECT_TRUE(poses(*never).empty());

  const Json stats = stop(*daemon);
  const Json c = condition_of(stats, "server.state -> continuous.event");
  EXPECT_EQ(c["mode"], "continuous");
  EXPECT_EQ(c["tested"].get<long long>(), c["fired"].get<long long>() + c["suppressed"].get<long long>()) << c.dump();
  EXPECT_GE(c["fired"].get<long long>(), static_cast<long long>(got.size())) << c.dump();
  EXPECT_GT(c["suppressed"].get<long long>(), 0) << c.dump();  // the states with x <= 2 (i < 11)
  const Json* link = connection(stats, "server.state -> continuous.event");
  ASSERT_NE(link, nullptr);
  EXPECT_EQ((*link)["conversion"], "passthrough");  // decoded to test, the bytes forwarded as they came
  EXPECT_EQ((*link)["delivered"], c["fired"]);

  const Json s = condition_of(stats, "server.state -> single.event");
  EXPECT_EQ(s["fired"], 1) << s.dump();
  EXPECT_EQ(s["active"], false);
  EXPECT_GT(s["inactive"].get<long long>(), 0) << s.dump();  // every state after it

  const Json n = condition_of(stats, "server.state -> never.event");
  EXPECT_EQ(n["fired"], 0) << n.dump();
  EXPECT_GE(n["tested"].get<long long>(), 20);
  EXPECT_EQ((*connection(stats, "server.state -> never.event"))["delivered"], 0);
}

// A Cyclone DDS server (idlc-generated program): DDS has no event ports, so its state is a
// topic on a data port, which the event connection tests and maps onto the LCM client's
// pose_t.
TEST_F(ConditionEventsLcm, CycloneDdsServerStateToAnLcmClient) {
  if (std::string(CYCLONE_PEER).empty()) GTEST_SKIP() << "the Cyclone DDS model or its test peer is not built";
  // The peer on loopback, as polyport's Cyclone DDS model is (config/cyclonedds-loopback.xml).
  setenv("CYCLONEDDS_URI", "file://" POLYPORT_SOURCE_DIR "/config/cyclonedds-loopback.xml", 1);
  auto client = lcm_peer("client", {"sub", kUrl, "EVENT_CONTINUOUS"});
  auto daemon = this->daemon(app("dds_app.xml"));
  auto server = peer(CYCLONE_PEER, "server", {"pub", "17", "state", "0", "5"});  // COUNT 0: until stopped
  ASSERT_TRUE(eventually([&] { return poses(*client).size() >= 10; }, 60s))
      << "client: " << poses(*client).size() << " poses\n" << daemon->errors() << server->errors();
  server.reset();
  const std::vector<Json> got = poses(*client);
  for (const Json& pose : got) {
    expect_pose(pose);
    EXPECT_GT(pose["x"].get<double>(), 2.0) << pose.dump();
  }
  expect_increasing(got);
  const Json stats = stop(*daemon);
  const Json* link = connection(stats, "server.state -> continuous.event");
  ASSERT_NE(link, nullptr) << stats.dump(2);
  EXPECT_EQ((*link)["dropped"], 0) << link->dump(2);
  const Json& c = (*link)["condition"];
  EXPECT_GE(c["fired"].get<long long>(), static_cast<long long>(got.size())) << c.dump();
  EXPECT_EQ(c["tested"].get<long long>(), c["fired"].get<long long>() + c["suppressed"].get<long long>());
  EXPECT_EQ((*link)["delivered"], c["fired"]);
}

// A foreign client cannot activate its condition itself: the operator does, with polyportctl
// condition, giving the threshold as a parameter; off again, and on for a single shot.
TEST_F(ConditionEventsLcm, PolyportctlSwitchesAForeignClientsCondition) {
  auto client = lcm_peer("client", {"sub", kUrl, "EVENT_CONTINUOUS"});
  auto daemon = this->daemon(app("ctl_app.xml"), {"--admin-socket", socket_.string()});
  auto server = lcm_peer("server", {"pub", kUrl, "STATE", "5"});
  const std::string link = "server.state -> client.event";
  auto counter = [&](const char* name) {
    const Json stats = ctl_stats();
    return stats.is_discarded() ? -1LL : condition_of(stats, link).value(name, -1LL);
  };
  // Off: states come and are counted as inactive; none reaches the client.
  ASSERT_TRUE(eventually([&] { return counter("inactive") >= 10; }, 60s)) << daemon->errors();
  EXPECT_TRUE(poses(*client).empty());

  // Refused, with the reason, and nothing changed.
  Ran bad = ctl({"condition", "client.event", "on", "--param", "max_y=3"});
  EXPECT_EQ(bad.code, 1) << bad.out << bad.err;
  EXPECT_NE(bad.err.find("their parameters: 'min_x'"), std::string::npos) << bad.err;
  Ran output = ctl({"condition", "server.state", "on"});
  EXPECT_EQ(output.code, 1) << output.out << output.err;
  EXPECT_NE(output.err.find("no event input port 'server.state' (ports with conditions: client.event)"),
            std::string::npos) << output.err;
  EXPECT_EQ(ctl({"condition", "client.event", "maybe"}).code, 2);
  EXPECT_EQ(counter("activations"), 0);

  // On, with x > 2: states come through, each with x > 2.
  Ran on = ctl({"condition", "client.event", "on", "--param", "min_x=2"});
  ASSERT_EQ(on.code, 0) << on.err;
  EXPECT_EQ(on.out, link + ": continuous, x gt 2\n");
  ASSERT_TRUE(eventually([&] { return poses(*client).size() >= 10; }, 60s)) << client->errors();
  for (const Json& pose : poses(*client)) EXPECT_GT(pose["x"].get<double>(), 2.0) << pose.dump();

  // Off: once polyport counts states as inactive again, it delivers no more, and the client
  // gets exactly what polyport delivered.
  Ran off = ctl({"condition", "client.event", "off", "--single"});
  EXPECT_EQ(off.code, 2) << "--single goes with on only";
  off = ctl({"condition", "client.event", "off"});
  ASSERT_EQ(off.code, 0) << off.err;
  const long long inactive_at_off = counter("inactive");
  ASSERT_TRUE(eventually([&] { return counter("inactive") >= inactive_at_off + 5; }, 60s));
  const long long fired_when_off = counter("fired");
  ASSERT_TRUE(eventually([&] { return static_cast<long long>(poses(*client).size()) == fired_when_off; }, 60s))
      << poses(*client).size() << " poses, " << fired_when_off << " fired";
  ASSERT_TRUE(eventually([&] { return counter("inactive") >= inactive_at_off + 20; }, 60s));
  EXPECT_EQ(counter("fired"), fired_when_off);
  EXPECT_EQ(static_cast<long long>(poses(*client).size()), fired_when_off);
  const std::size_t delivered_when_off = poses(*client).size();

  // A single shot: exactly one more state, then off by itself.
  const long long fired_before = counter("fired");
  Ran once = ctl({"condition", "client.event", "on", "--single", "--param", "min_x=2"});
  ASSERT_EQ(once.code, 0) << once.err;
  ASSERT_TRUE(eventually([&] { return counter("fired") == fired_before + 1; }, 60s));
  ASSERT_TRUE(eventually([&] { return poses(*client).size() == delivered_when_off + 1; }, 60s));
  const long long inactive_after_shot = counter("inactive");
  ASSERT_TRUE(eventually([&] { return counter("inactive") >= inactive_after_shot + 10; }, 60s));
  EXPECT_EQ(counter("fired"), fired_before + 1);
  EXPECT_EQ(poses(*client).size(), delivered_when_off + 1);
  server.reset();
  const Json stats = stop(*daemon);
  EXPECT_EQ(condition_of(stats, link)["activations"], 2) << stats.dump(2);
}

// polyportd check shows each condition: mode, activation, fields.
TEST_F(ConditionEventsLcm, CheckShowsTheConditions) {
  const std::string tag = "check";
  int code = -1;
  {
    Child child(dir(), tag, {POLYPORTD, "check", app().string()});
    code = child.wait(30s);
  }
  const std::string out = read_file(dir() / (tag + ".out"));
  EXPECT_EQ(code, 0) << out << read_file(dir() / (tag + ".err"));
  EXPECT_NE(out.find("condition=continuous x gt 2"), std::string::npos) << out;
  EXPECT_NE(out.find("condition=single heading ge 1 id ge 1005"), std::string::npos) << out;
  EXPECT_NE(out.find("condition=continuous x lt -1000"), std::string::npos) << out;
}

}  // namespace
}  // namespace polyport::test
