// polyportd between DDS applications that are programs of their own (tests/dds_peers:
// idlc-generated Cyclone DDS and fastddsgen-generated Fast DDS code), on loopback: data across
// vendors and domains, DDS <-> in-process components, services both ways with a timeout, a
// sample that does not decode, a publisher that restarts. Every process is a child of the
// test; every wait is for a line in a child's output or a file, with a deadline.
//
// Each test gets its own pair of DDS domains (the profile templates in tests/data/dds_e2e
// are filled in per test) so that tests running in parallel do not hear each other.
#include "e2e_scenarios.hpp"

namespace polyport {
namespace {

using namespace test;
using namespace std::chrono_literals;

TEST_F(DdsEndToEnd, CyclonePublisherReachesFastddsSubscriberAndBack) {
  auto polyportd = daemon(profiles("cross_vendor_app.xml", 182, 183));
  auto fast_sub = peer(FASTDDS_PEER, "fast_sub", {"sub", "183", "pose", "5", "60"});
  auto cyclone_sub = peer(CYCLONE_PEER, "cyclone_sub", {"sub", "182", "pose_back", "4", "60"});
  auto cyclone_pub = peer(CYCLONE_PEER, "cyclone_pub", {"pub", "182", "pose", kForever, "5"});
  auto fast_pub = peer(FASTDDS_PEER, "fast_pub", {"pub", "183", "pose_back", kForever, "5", "20"});

  ASSERT_EQ(fast_sub->wait(60s), 0) << "Fast DDS subscriber: " << fast_sub->errors();
  ASSERT_EQ(cyclone_sub->wait(60s), 0) << "Cyclone subscriber: " << cyclone_sub->errors();
  const auto forward = poses(*fast_sub);
  ASSERT_EQ(forward.size(), 5u);
  for (const Json& pose : forward) expect_pose(pose);
  expect_increasing(forward);
  const auto back = poses(*cyclone_sub);
  ASSERT_EQ(back.size(), 4u);
  for (const Json& pose : back) expect_pose(pose);
  expect_increasing(back);
  EXPECT_GE(back[0]["id"].get<int>(), peer_values::id(20));  // the Fast DDS publisher's

  cyclone_pub.reset();
  fast_pub.reset();
  const Json stats = stop(*polyportd);
  const Json* there = connection(stats, "cyclone.pose -> fast.pose");
  const Json* home = connection(stats, "fast.pose_back -> cyclone.pose_back");
  ASSERT_TRUE(there && home);
  EXPECT_EQ((*there)["conversion"], "passthrough");
  EXPECT_GE((*there)["delivered"].get<int>(), 5);
  EXPECT_GE((*home)["delivered"].get<int>(), 4);
  EXPECT_EQ((*there)["dropped"], 0);
  EXPECT_EQ((*home)["dropped"], 0);
}

// Cyclone publishes on domain A, Fast DDS subscribes on domain B.
const Route kCycloneToFastdds{186, 187, CYCLONE_PEER, 186, "pose", FASTDDS_PEER, 187, "pose"};

TEST_F(DdsEndToEnd, DdsToInProcessComponentAndOnToDds) {
  relay_scenario(*this, "relay_app.xml", kCycloneToFastdds, "cyclone.pose -> relay.in", "relay.out -> fast.pose");
}

TEST_F(DdsEndToEnd, UndecodableSampleIsCountedAndTheConnectionGoesOn) {
  Route route = kCycloneToFastdds;
  route.domain_a = route.pub_domain = 188;
  route.domain_b = route.sub_domain = 189;
  undecodable_scenario(*this, "relay_app.xml", route, "cyclone.pose -> relay.in");
}

TEST_F(DdsEndToEnd, PublisherThatRestartsIsPickedUpAgain) {
  Route route = kCycloneToFastdds;
  route.domain_a = route.pub_domain = 190;
  route.domain_b = route.sub_domain = 191;
  // The Cyclone application goes away without saying goodbye.
  restart_scenario(*this, "cross_vendor_app.xml", route, SIGKILL, 128 + SIGKILL, "cyclone.pose -> fast.pose");
}

TEST_F(DdsEndToEnd, DdsClientCallsAnInProcessService) {
  client_scenario(*this, "client_app.xml", 192, 193, CYCLONE_PEER, 192);
}

TEST_F(DdsEndToEnd, InProcessCallerCallsADdsServerAndTimesOutWithoutOne) {
  server_scenario(*this, "server_app.xml", 194, 195, FASTDDS_PEER, 195);
}

// <dds><receive_thread>: Cyclone's receive, delivery and timed-event threads run SCHED_FIFO
// at the asked priority (root here); for a process that may not, one warning and SCHED_OTHER.
TEST_F(DdsEndToEnd, CycloneThreadsRunWithTheProfilesScheduling) {
  const fs::path app = one_component_app(
      "cyclonedds", R"(<dds><domain>223</domain><receive_thread policy="SCHED_FIFO" priority="30"/></dds>)",
      POLYPORT_SOURCE_DIR "/config/types/wheelchair.idl", "wheelchair::Reference");
  auto daemon = this->daemon(app);
  ASSERT_TRUE(eventually([&] { return thread_scheduling(daemon->pid(), "recv").has_value(); })) << daemon->errors();
  if (geteuid() == 0) {
    for (const char* name : {"recv", "dq.user", "tev"}) {
      const auto scheduling = thread_scheduling(daemon->pid(), name);
      ASSERT_TRUE(scheduling) << name;
      EXPECT_EQ(scheduling->second, 1) << name << " runs SCHED_FIFO";
      EXPECT_EQ(scheduling->first, 30) << name;
    }
    ASSERT_TRUE(thread_scheduling(daemon->pid(), "gc"));
    EXPECT_EQ(thread_scheduling(daemon->pid(), "gc")->second, 0) << "the others are left as they are";
  } else {
    EXPECT_NE(daemon->errors().find("cyclonedds receive threads: real-time priority 30 is not allowed"),
              std::string::npos) << daemon->errors();
    EXPECT_EQ(thread_scheduling(daemon->pid(), "recv")->second, 0);
  }
  stop(*daemon);
}

}  // namespace
}  // namespace polyport
