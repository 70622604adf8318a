// polyportd between LCM applications built with lcm-gen (tests/lcm_e2e/lcm_peer), and between
// LCM and DDS applications built with idlc and fastddsgen (tests/dds_peers): every
// field checked where it arrives, wrong and cut-short messages counted and dropped, a message
// of 200 KB (fragmented on the wire) carried intact, a restarted publisher picked up, and a
// host without a multicast route told which route to add.
//
// Each case runs in a network namespace of its own (the test process unshares it; ctest runs
// each case as a process of its own) with loopback up and a route for LCM's group on it, so
// the fixture adds the route it needs and the route goes with the namespace. That needs root
// (CAP_SYS_ADMIN); without it the cases fail and say so.

#include <cstdlib>

#include "../support/multicast_namespace.hpp"
#include "pose_checks.hpp"

namespace polyport::test {
namespace {

constexpr const char* kUrl = "udpm://239.255.76.67:7667?ttl=0";

class LcmEndToEnd : public DaemonTest {
 protected:
  LcmEndToEnd() : DaemonTest("polyport-lcm-e2e") {}

  void SetUp() override {
    DaemonTest::SetUp();
    isolate_with_multicast_route();
  }

  // `dds_model`: the model of the DDS end in the *_dds_app.xml templates.
  fs::path app(const std::string& name, const std::string& dds_model = "cyclonedds") {
    return fill_templates(POLYPORT_TEST_DATA "/lcm_e2e",
                          {{"@URL@", kUrl},
                           {"@DDS_MODEL@", dds_model},
                           {"@SOURCE_CHANNEL@", "POSE_IN"},
                           {"@SINK_CHANNEL@", "POSE_OUT"},
                           {"@A@", "17"},
                           {"@SRC@", POLYPORT_SOURCE_DIR}},
                          name);
  }
  std::unique_ptr<Child> lcm_peer(const std::string& tag, std::vector<std::string> args) {
    return peer(LCM_PEER, tag, std::move(args));
  }
};

// The statistics' entry of an LCM channel of a component.
const Json* lcm_channel(const Json& stats, const std::string& component, const std::string& port) {
  for (const Json& c : stats["components"]) {
    if (c["name"] != component || !c.contains("lcm")) continue;
    for (const Json& channel : c["lcm"]["channels"]) {
      if (channel["port"] == port) return &channel;
    }
  }
  ADD_FAILURE() << "no LCM channel " << component << "." << port << " in " << stats.dump(2);
  return nullptr;
}

std::vector<Json> blobs(const Child& subscriber) {
  std::vector<Json> out;
  for (const Json& j : subscriber.lines()) {
    if (j.contains("blob") && !j.contains("event")) out.push_back(j);
  }
  return out;
}

TEST_F(LcmEndToEnd, LcmToLcmPassesEveryFieldThrough) {
  auto sub = lcm_peer("sub", {"sub", kUrl, "POSE_OUT"});
  auto daemon = this->daemon(app("passthrough_app.xml"));
  auto pub = lcm_peer("pub", {"pub", kUrl, "POSE_IN", "10"});
  ASSERT_TRUE(eventually([&] { return poses(*sub).size() >= 20; }, 30s))
      << "sub: " << poses(*sub).size() << " poses\n" << daemon->errors() << sub->errors();
  const std::vector<Json> got = poses(*sub);
  for (const Json& pose : got) expect_pose(pose);
  expect_increasing(got);
  pub.reset();
  const Json stats = stop(*daemon);
  const Json* link = connection(stats, "source.pose -> sink.pose");
  ASSERT_NE(link, nullptr);
  EXPECT_EQ((*link)["conversion"], "passthrough");
  const Json* in = lcm_channel(stats, "source", "pose");
  ASSERT_NE(in, nullptr);
  EXPECT_GE((*in)["received"].get<int>(), 20);
  EXPECT_EQ((*in)["wrong_fingerprint"], 0);
  const Json* out = lcm_channel(stats, "sink", "pose");
  ASSERT_NE(out, nullptr);
  EXPECT_GE((*out)["published"].get<int>(), 20);
  EXPECT_EQ((*out)["failed"], 0);
}

TEST_F(LcmEndToEnd, WrongAndCutShortMessagesAreCountedAndDropped) {
  if (std::string(CYCLONE_PEER).empty()) FAIL() << "cyclone_peer was not built (the Cyclone DDS model is needed)";
  setenv("CYCLONEDDS_URI", "file://" POLYPORT_SOURCE_DIR "/config/cyclonedds-loopback.xml", 1);
  auto sub = peer(CYCLONE_PEER, "dds_sub", {"sub", "17", "pose", "10", "60"});
  auto daemon = this->daemon(app("to_dds_app.xml"));
  // Each round: an other_t (wrong fingerprint), a pose cut short, then a good pose.
  auto bad = lcm_peer("bad", {"bad", kUrl, "POSE_IN", "20"});
  ASSERT_TRUE(eventually([&] { return poses(*sub).size() >= 10; }, 60s))
      << "DDS sub: " << poses(*sub).size() << " poses\n" << daemon->errors() << sub->errors();
  for (const Json& pose : poses(*sub)) expect_pose(pose);
  bad.reset();
  const Json stats = stop(*daemon);
  const Json* channel = lcm_channel(stats, "lcm", "pose");
  ASSERT_NE(channel, nullptr);
  EXPECT_GE((*channel)["wrong_fingerprint"].get<int>(), 10);
  const Json* link = connection(stats, "lcm.pose -> dds.pose");
  ASSERT_NE(link, nullptr);
  EXPECT_NE((*link)["conversion"], "passthrough");
  EXPECT_GE((*link)["dropped_by_reason"]["decode_error"].get<int>(), 10) << link->dump(2);
  EXPECT_GE((*link)["delivered"].get<int>(), 10) << link->dump(2);
}

TEST_F(LcmEndToEnd, DdsToLcmCarriesEveryFieldWithItsLengthMember) {
  if (std::string(CYCLONE_PEER).empty()) FAIL() << "cyclone_peer was not built (the Cyclone DDS model is needed)";
  setenv("CYCLONEDDS_URI", "file://" POLYPORT_SOURCE_DIR "/config/cyclonedds-loopback.xml", 1);
  auto sub = lcm_peer("sub", {"sub", kUrl, "POSE_OUT"});
  auto daemon = this->daemon(app("from_dds_app.xml"));
  auto pub = peer(CYCLONE_PEER, "dds_pub", {"pub", "17", "pose", "0", "10"}  /* COUNT 0: until stopped */);
  // The LCM peer decodes with lcm-gen code: nsamples must match the samples polyport wrote.
  ASSERT_TRUE(eventually([&] { return poses(*sub).size() >= 10; }, 60s))
      << "LCM sub: " << poses(*sub).size() << " poses\n" << daemon->errors() << pub->errors();
  for (const Json& pose : poses(*sub)) expect_pose(pose);
  expect_increasing(poses(*sub));
  pub.reset();
  const Json stats = stop(*daemon);
  const Json* link = connection(stats, "dds.pose -> lcm.pose");
  ASSERT_NE(link, nullptr);
  EXPECT_EQ((*link)["dropped"], 0) << link->dump(2);
}

TEST_F(LcmEndToEnd, AMessageOf200KilobytesArrivesIntact) {
  auto sub = lcm_peer("blob_sub", {"blob-sub", kUrl, "POSE_OUT"});
  auto daemon = this->daemon(app("blob_app.xml"));
  auto pub = lcm_peer("blob_pub", {"blob-pub", kUrl, "POSE_IN", "200000", "50"});
  ASSERT_TRUE(eventually([&] { return blobs(*sub).size() >= 3; }, 30s))
      << "blob sub: " << blobs(*sub).size() << "\n" << daemon->errors() << sub->errors();
  for (const Json& blob : blobs(*sub)) {
    EXPECT_EQ(blob["size"], 200000) << blob.dump();
    EXPECT_TRUE(blob["ok"].get<bool>()) << blob.dump();
  }
  pub.reset();
  const Json stats = stop(*daemon);
  const Json* in = lcm_channel(stats, "source", "blob");
  ASSERT_NE(in, nullptr);
  EXPECT_EQ((*in)["too_large"], 0);
}

TEST_F(LcmEndToEnd, ARestartedPublisherIsPickedUpAgain) {
  auto sub = lcm_peer("sub", {"sub", kUrl, "POSE_OUT"});
  auto daemon = this->daemon(app("passthrough_app.xml"));
  auto pub = lcm_peer("pub", {"pub", kUrl, "POSE_IN", "10", "0"});
  ASSERT_TRUE(eventually([&] { return poses(*sub).size() >= 5; }, 30s)) << daemon->errors();
  pub.reset();  // SIGTERM: the publisher exits
  auto again = lcm_peer("pub_again", {"pub", kUrl, "POSE_IN", "10", "500"});
  ASSERT_TRUE(eventually(
      [&] {
        const auto got = poses(*sub);
        return !got.empty() && got.back()["id"].get<int>() >= peer_values::id(505);
      },
      30s))
      << daemon->errors();
  for (const Json& pose : poses(*sub)) expect_pose(pose);
  again.reset();
  stop(*daemon);
}

// The shipped profiles/lcm_inproc.xml as it is: an LCM teleop (lcm-gen, wheelchair.lcm) asks
// for 1 m/s straight ahead; the in-process control drives the simulated chair, whose wheel
// speeds come back on LCM, mapped from the IDL types.
TEST_F(LcmEndToEnd, TheShippedLcmWheelchairProfileDrivesTheChair) {
  auto teleop = lcm_peer("teleop", {"teleop", kUrl, "1.0"});
  auto daemon = this->daemon(POLYPORT_SOURCE_DIR "/profiles/lcm_inproc.xml");
  const auto speeds = [&] {
    std::vector<Json> out;
    for (const Json& j : teleop->lines()) {
      if (j.contains("left")) out.push_back(j);
    }
    return out;
  };
  // 1 m/s needs a few hundred ms of 10 ms periods to reach; wait for the wheels to turn.
  ASSERT_TRUE(eventually(
      [&] {
        const auto got = speeds();
        return got.size() >= 50 && got.back()["left"].get<double>() > 1.0 && got.back()["right"].get<double>() > 1.0;
      },
      30s))
      << speeds().size() << " wheel speed messages\n" << daemon->errors() << teleop->errors();
  const auto got = speeds();
  for (std::size_t k = 1; k < got.size(); ++k) {
    EXPECT_GE(got[k]["time"].get<double>(), got[k - 1]["time"].get<double>()) << "the plant's clock went back";
  }
  // Straight ahead: both wheels alike and the heading stays put.
  EXPECT_NEAR(got.back()["left"].get<double>(), got.back()["right"].get<double>(), 1e-6);
  EXPECT_NEAR(got.back()["heading"].get<double>(), 0.0, 1e-6);
  teleop.reset();
  const Json stats = stop(*daemon);
  const Json* link = connection(stats, "Teleop.reference -> Control.reference");
  ASSERT_NE(link, nullptr);
  EXPECT_EQ((*link)["conversion"], "lcm -> flat -> map");
  EXPECT_EQ((*link)["dropped"], 0);
}

TEST_F(LcmEndToEnd, NoMulticastRouteIsAClearError) {
  // A namespace of its own again, where loopback is down and nothing is routed.
  const fs::path profile = app("passthrough_app.xml");
  auto daemon = peer("/usr/bin/unshare", "polyportd", {"-n", POLYPORTD, "run", profile.string()});
  ASSERT_EQ(daemon->wait(20s), 1) << daemon->errors();
  const std::string errors = daemon->errors();
  EXPECT_NE(errors.find("no route to multicast group 239.255.76.67"), std::string::npos) << errors;
  EXPECT_NE(errors.find("ip route add 239.255.76.67/32 dev lo"), std::string::npos) << errors;
}

// Fast DDS at the other end: the same mapping both ways as with Cyclone DDS above, against
// a fastddsgen program (tests/dds_peers/fastdds_peer).
class LcmFastDds : public LcmEndToEnd {
 protected:
  void SetUp() override {
    LcmEndToEnd::SetUp();
    if (std::string(FASTDDS_PEER).empty()) FAIL() << "fastdds_peer was not built (the Fast DDS model and fastddsgen are needed)";
    setenv("FASTRTPS_DEFAULT_PROFILES_FILE", POLYPORT_SOURCE_DIR "/config/fastdds-loopback.xml", 1);
  }
};

TEST_F(LcmFastDds, LcmToFastDdsCarriesEveryField) {
  auto sub = peer(FASTDDS_PEER, "fast_sub", {"sub", "17", "pose", "10", "60"});
  auto daemon = this->daemon(app("to_dds_app.xml", "fastdds"));
  auto pub = lcm_peer("pub", {"pub", kUrl, "POSE_IN", "10"});
  ASSERT_TRUE(eventually([&] { return poses(*sub).size() >= 10; }, 60s))
      << "Fast DDS sub: " << poses(*sub).size() << " poses\n" << daemon->errors() << sub->errors();
  for (const Json& pose : poses(*sub)) expect_pose(pose);
  expect_increasing(poses(*sub));
  pub.reset();
  const Json stats = stop(*daemon);
  const Json* link = connection(stats, "lcm.pose -> dds.pose");
  ASSERT_NE(link, nullptr);
  EXPECT_NE((*link)["conversion"], "passthrough");
  EXPECT_GE((*link)["delivered"].get<int>(), 10) << link->dump(2);
}

TEST_F(LcmFastDds, FastDdsToLcmCarriesEveryFieldWithItsLengthMember) {
  auto sub = lcm_peer("sub", {"sub", kUrl, "POSE_OUT"});
  auto daemon = this->daemon(app("from_dds_app.xml", "fastdds"));
  auto pub = peer(FASTDDS_PEER, "fast_pub", {"pub", "17", "pose", "0", "10"}  /* COUNT 0: until stopped */);
  ASSERT_TRUE(eventually([&] { return poses(*sub).size() >= 10; }, 60s))
      << "LCM sub: " << poses(*sub).size() << " poses\n" << daemon->errors() << pub->errors();
  for (const Json& pose : poses(*sub)) expect_pose(pose);
  expect_increasing(poses(*sub));
  pub.reset();
  const Json stats = stop(*daemon);
  const Json* link = connection(stats, "dds.pose -> lcm.pose");
  ASSERT_NE(link, nullptr);
  EXPECT_EQ((*link)["dropped"], 0) << link->dump(2);
}

}  // namespace
}  // namespace polyport::test
