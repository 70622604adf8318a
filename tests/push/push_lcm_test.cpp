// Push timed and push newest between LCM applications built with lcm-gen (tests/lcm_e2e's
// lcm_peer): the publisher's channel is the push server, subscribers are LCM channels that
// other lcm_peer programs read.
//  - push timed: a subscriber of every 3rd base cycle gets poses whose ids step by 3, one of
//    each cycle gets every pose; the statistics count what each skipped;
//  - push newest: a subscriber connected while the application runs (polyportctl connect, or
//    a reload that adds its connection) gets the latest pose at once, though the publisher
//    has gone quiet.
// LCM has no late joining of its own: only subscribers on polyport's side are primed.
//
// Each case runs in a network namespace of its own with a multicast route on loopback (needs
// root, as tests/lcm_e2e).

#include <fstream>
#include <iterator>

#include "../dds_peers/pose_checks.hpp"
#include "../support/multicast_namespace.hpp"

namespace polyport::test {
namespace {

constexpr const char* kUrl = "udpm://239.255.76.67:7667?ttl=0";

class PushLcm : public DaemonTest {
 protected:
  PushLcm() : DaemonTest("polyport-push-lcm") {}

  void SetUp() override {
    DaemonTest::SetUp();
    isolate_with_multicast_route();
    socket_ = dir() / "admin.sock";
  }
  fs::path app(const std::string& name, const std::string& push) {
    return fill_templates(POLYPORT_SOURCE_DIR "/tests/push/data",
                          {{"@URL@", kUrl}, {"@PUSH@", push}, {"@SRC@", POLYPORT_SOURCE_DIR}}, name);
  }
  std::unique_ptr<Child> lcm_peer(const std::string& tag, std::vector<std::string> args) {
    return peer(LCM_PEER, tag, std::move(args));
  }
  // polyportctl's exit code and output.
  std::pair<int, std::string> ctl(std::vector<std::string> args) {
    args.insert(args.begin(), {POLYPORTCTL, "--socket", socket_.string()});
    const std::string tag = "ctl-" + std::to_string(++calls_);
    int code = -1;
    {
      Child child(dir(), tag, args);
      code = child.wait(30s);
    }
    return {code, read_file(dir() / (tag + ".out")) + read_file(dir() / (tag + ".err"))};
  }

  fs::path socket_;
  int calls_ = 0;
};

TEST_F(PushLcm, ATimedSubscriberOfEveryThirdCycleGetsEveryThirdPose) {
  auto every3 = lcm_peer("every3", {"sub", kUrl, "POSE_OUT"});
  auto each = lcm_peer("each", {"sub", kUrl, "POSE_ALL"});
  auto daemon = this->daemon(app("timed_app.xml", R"(<push pattern="timed" cycle_ms="5"/>)"));
  auto pub = lcm_peer("pub", {"pub", kUrl, "POSE_IN", "5"});
  ASSERT_TRUE(eventually([&] { return poses(*every3).size() >= 10; }, 30s))
      << "every3: " << poses(*every3).size() << " poses\n" << daemon->errors() << every3->errors();
  pub->signal(SIGTERM);
  ASSERT_EQ(pub->wait(10s), 0) << pub->errors();
  const std::vector<Json> got = poses(*every3);
  for (const Json& pose : got) expect_pose(pose);
  for (std::size_t i = 1; i < got.size(); ++i) {
    EXPECT_EQ(got[i]["id"].get<long long>() - got[i - 1]["id"].get<long long>(), 3) << got[i].dump();
  }
  const std::vector<Json> all = poses(*each);
  for (const Json& pose : all) expect_pose(pose);
  for (std::size_t i = 1; i < all.size(); ++i) {
    EXPECT_EQ(all[i]["id"].get<long long>() - all[i - 1]["id"].get<long long>(), 1) << all[i].dump();
  }

  const Json stats = stop(*daemon);
  const Json* thinned = connection(stats, "source.pose -> every3.pose");
  ASSERT_NE(thinned, nullptr);
  EXPECT_EQ((*thinned)["subscription"]["every"], 3) << thinned->dump(2);
  EXPECT_EQ((*thinned)["subscription"]["cycle_ns"], 15'000'000) << thinned->dump(2);
  EXPECT_EQ((*thinned)["push"]["pattern"], "timed") << thinned->dump(2);
  const long long received = (*thinned)["received"].get<long long>();
  const long long delivered = (*thinned)["delivered"].get<long long>();
  const long long skipped = (*thinned)["subscription"]["skipped"].get<long long>();
  EXPECT_EQ(delivered + skipped, received) << thinned->dump(2);
  EXPECT_EQ(delivered, (received + 2) / 3) << thinned->dump(2);  // the first of every 3
  EXPECT_EQ((*thinned)["dropped"], 0) << thinned->dump(2);
  const Json* plain = connection(stats, "source.pose -> each.pose");
  ASSERT_NE(plain, nullptr);
  EXPECT_FALSE(plain->contains("subscription")) << plain->dump(2);
  EXPECT_EQ((*plain)["delivered"], (*plain)["received"]) << plain->dump(2);
}

TEST_F(PushLcm, ANewestSubscriberConnectedLaterGetsTheLatestPoseAtOnce) {
  auto each = lcm_peer("each", {"sub", kUrl, "POSE_ALL"});
  auto late = lcm_peer("late", {"sub", kUrl, "POSE_LATE"});
  auto daemon = this->daemon(app("newest_app.xml", R"(<push pattern="newest"/>)"),
                             {"--admin-socket", socket_.string()});
  ASSERT_TRUE(eventually([&] { return ctl({"hello"}).first == 0; }, 30s)) << daemon->errors();
  auto pub = lcm_peer("pub", {"pub", kUrl, "POSE_IN", "10"});
  ASSERT_TRUE(eventually([&] { return poses(*each).size() >= 5; }, 30s))
      << "each: " << poses(*each).size() << " poses\n" << daemon->errors();
  pub->signal(SIGTERM);
  ASSERT_EQ(pub->wait(10s), 0) << pub->errors();
  long long last_published = -1;
  for (const Json& j : pub->lines()) {
    if (j.value("event", "") == "published") last_published = j["id"].get<long long>();
  }
  ASSERT_GE(last_published, 0);
  ASSERT_TRUE(eventually([&] {
    const auto got = poses(*each);
    return !got.empty() && got.back()["id"].get<long long>() == last_published;
  }, 10s)) << "each got " << poses(*each).size() << " poses, the last published was " << last_published;
  EXPECT_TRUE(poses(*late).empty());

  // The publisher is quiet now: what `late` gets is the pose the server kept.
  const auto [code, out] = ctl({"connect", "source.pose", "late.pose"});
  ASSERT_EQ(code, 0) << out;
  ASSERT_TRUE(eventually([&] { return !poses(*late).empty(); }, 10s)) << daemon->errors();
  const std::vector<Json> primed = poses(*late);
  ASSERT_EQ(primed.size(), 1u);
  expect_pose(primed.front());
  EXPECT_EQ(primed.front()["id"].get<long long>(), last_published);

  const Json stats = stop(*daemon);
  const Json* link = connection(stats, "source.pose -> late.pose");
  ASSERT_NE(link, nullptr);
  EXPECT_EQ((*link)["push"]["pattern"], "newest") << link->dump(2);
  EXPECT_EQ((*link)["push"]["primed"], 1) << link->dump(2);
  EXPECT_EQ((*link)["delivered"], 1) << link->dump(2);
}

TEST_F(PushLcm, AReloadThatAddsANewestSubscriberPrimesIt) {
  auto each = lcm_peer("each", {"sub", kUrl, "POSE_ALL"});
  auto late = lcm_peer("late", {"sub", kUrl, "POSE_LATE"});
  const fs::path profile = app("newest_app.xml", R"(<push pattern="newest"/>)");
  auto daemon = this->daemon(profile, {"--admin-socket", socket_.string()});
  ASSERT_TRUE(eventually([&] { return ctl({"hello"}).first == 0; }, 30s)) << daemon->errors();
  auto pub = lcm_peer("pub", {"pub", kUrl, "POSE_IN", "10"});
  ASSERT_TRUE(eventually([&] { return poses(*each).size() >= 5; }, 30s)) << daemon->errors();
  pub->signal(SIGTERM);
  ASSERT_EQ(pub->wait(10s), 0) << pub->errors();
  long long last_published = -1;
  for (const Json& j : pub->lines()) {
    if (j.value("event", "") == "published") last_published = j["id"].get<long long>();
  }
  ASSERT_TRUE(eventually([&] {
    const auto got = poses(*each);
    return !got.empty() && got.back()["id"].get<long long>() == last_published;
  }, 10s)) << "each got " << poses(*each).size() << " poses, the last published was " << last_published;

  // The profile gains source.pose -> late.pose; the running connection stays as it is.
  std::string text = read_file(profile);
  const std::string end = "  </port_connections>";
  const auto at = text.find(end);
  ASSERT_NE(at, std::string::npos);
  text.insert(at, "    <port_connection port_type=\"data\">\n"
                  "      <source component_name=\"source\" port_name=\"pose\"/>\n"
                  "      <target component_name=\"late\" port_name=\"pose\"/>\n"
                  "    </port_connection>\n");
  std::ofstream(profile) << text;
  const auto [code, out] = ctl({"reload"});
  ASSERT_EQ(code, 0) << out;
  EXPECT_NE(out.find("source.pose -> late.pose"), std::string::npos) << out;
  ASSERT_TRUE(eventually([&] { return !poses(*late).empty(); }, 10s)) << daemon->errors();
  const std::vector<Json> primed = poses(*late);
  ASSERT_EQ(primed.size(), 1u);
  expect_pose(primed.front());
  EXPECT_EQ(primed.front()["id"].get<long long>(), last_published);
  const Json stats = stop(*daemon);
  const Json* kept = connection(stats, "source.pose -> each.pose");
  ASSERT_NE(kept, nullptr);
  EXPECT_EQ((*kept)["delivered"].get<long long>(), static_cast<long long>(poses(*each).size())) << kept->dump(2);
}

}  // namespace
}  // namespace polyport::test
