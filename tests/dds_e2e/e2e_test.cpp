// polyportd between DDS applications that are programs of their own (tests/dds_peers:
// idlc-generated Cyclone DDS and fastddsgen-generated Fast DDS code), on loopback: data across
// vendors and domains, DDS <-> in-process components, services both ways with a timeout, a
// sample that does not decode, a publisher that restarts. Every process is a child of the
// test; every wait is for a line in a child's output or a file, with a deadline.
//
// Each test gets its own pair of DDS domains (the profile templates in tests/data/dds_e2e
// are filled in per test) so that tests running in parallel do not hear each other.
#include "e2e_fixture.hpp"

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

TEST_F(DdsEndToEnd, DdsToInProcessComponentAndOnToDds) {
  // Cyclone publisher -> polyport decodes into the in-process PoseRelay -> the relay's output
  // is encoded for a Fast DDS subscriber. Both hops are checked field by field.
  auto polyportd = daemon(profiles("relay_app.xml", 186, 187));
  auto fast_sub = peer(FASTDDS_PEER, "fast_sub", {"sub", "187", "pose", "6", "60"});
  auto cyclone_pub = peer(CYCLONE_PEER, "cyclone_pub", {"pub", "186", "pose", kForever, "5"});
  ASSERT_EQ(fast_sub->wait(60s), 0) << fast_sub->errors();
  const auto got = poses(*fast_sub);
  ASSERT_EQ(got.size(), 6u);
  for (const Json& pose : got) expect_pose(pose, kRelayOffset);
  expect_increasing(got);

  cyclone_pub.reset();
  const Json stats = stop(*polyportd);
  const Json* in = connection(stats, "cyclone.pose -> relay.in");
  const Json* out = connection(stats, "relay.out -> fast.pose");
  ASSERT_TRUE(in && out);
  EXPECT_EQ((*in)["conversion"], "xcdr1 -> flat");
  EXPECT_EQ((*out)["conversion"], "flat -> xcdr1");
  EXPECT_GE((*in)["delivered"].get<int>(), 6);
  EXPECT_GE((*out)["delivered"].get<int>(), 6);
  EXPECT_EQ((*in)["dropped"], 0);
}

TEST_F(DdsEndToEnd, UndecodableSampleIsCountedAndTheConnectionGoesOn) {
  auto polyportd = daemon(profiles("relay_app.xml", 188, 189));
  auto fast_sub = peer(FASTDDS_PEER, "fast_sub", {"sub", "189", "pose", "1000", "60"});
  auto good = peer(CYCLONE_PEER, "good", {"pub", "188", "pose", kForever, "5"});
  ASSERT_TRUE(eventually([&] { return poses(*fast_sub).size() >= 3; })) << "nothing relayed";
  // Same topic, same type name, another layout: one octet where a Pose is expected. The
  // peer waits until polyport has acknowledged both samples before it exits.
  auto bad = peer(CYCLONE_BAD_PEER, "bad", {"pub", "188", "pose", "2", "5"});
  ASSERT_EQ(bad->wait(60s), 0) << bad->errors();
  const std::size_t before = poses(*fast_sub).size();
  ASSERT_TRUE(eventually([&] { return poses(*fast_sub).size() >= before + 3; })) << "nothing relayed after";
  good.reset();
  const auto got = poses(*fast_sub);
  for (const Json& pose : got) expect_pose(pose, kRelayOffset);
  expect_increasing(got);
  fast_sub.reset();

  const Json stats = stop(*polyportd);
  const Json* in = connection(stats, "cyclone.pose -> relay.in");
  ASSERT_TRUE(in);
  EXPECT_EQ((*in)["dropped_by_reason"]["decode_error"], 2) << in->dump(2);
  EXPECT_EQ((*in)["dropped"], 2) << in->dump(2);
  EXPECT_EQ((*in)["delivered"].get<int>() + 2, (*in)["received"].get<int>()) << in->dump(2);
}

TEST_F(DdsEndToEnd, PublisherThatRestartsIsPickedUpAgain) {
  auto polyportd = daemon(profiles("cross_vendor_app.xml", 190, 191));
  auto fast_sub = peer(FASTDDS_PEER, "fast_sub", {"sub", "191", "pose", "1000", "60"});
  auto first = peer(CYCLONE_PEER, "first_run", {"pub", "190", "pose", kForever, "5", "0"});
  ASSERT_TRUE(eventually([&] { return poses(*fast_sub).size() >= 2; })) << "first run not forwarded";
  first->signal(SIGKILL);  // the application goes away without saying goodbye
  EXPECT_NE(first->wait(20s), -1);
  // A new process of the same application, numbering its samples from 1000.
  auto second = peer(CYCLONE_PEER, "second_run", {"pub", "190", "pose", kForever, "5", "1000"});
  ASSERT_TRUE(eventually([&] {
    const auto got = poses(*fast_sub);
    return !got.empty() && got.back()["id"].get<int>() >= peer_values::id(1002);
  })) << "the restarted publisher was not picked up";
  second.reset();
  const auto got = poses(*fast_sub);
  for (const Json& pose : got) expect_pose(pose);
  expect_increasing(got);
  fast_sub.reset();
  stop(*polyportd);
}

TEST_F(DdsEndToEnd, DdsClientCallsAnInProcessService) {
  auto polyportd = daemon(profiles("client_app.xml", 192, 193));
  auto client = peer(CYCLONE_PEER, "client", {"call", "192", "calc", "5", "5000"});
  ASSERT_EQ(client->wait(90s), 0) << client->errors();
  int replies = 0;
  for (const Json& j : client->lines()) {
    if (!j.contains("seq")) continue;
    ++replies;
    EXPECT_EQ(j["status"], 0) << j.dump();
    EXPECT_DOUBLE_EQ(j["sum"].get<double>(), j["seq"].get<int>() + 0.5) << j.dump();
  }
  EXPECT_EQ(replies, 5);
  const Json stats = stop(*polyportd);
  ASSERT_EQ(stats["services"].size(), 1u);
  EXPECT_EQ(stats["services"][0]["ok"], 5) << stats["services"].dump(2);
}

TEST_F(DdsEndToEnd, InProcessCallerCallsADdsServerAndTimesOutWithoutOne) {
  const fs::path trace = dir() / "sums.jsonl";
  auto polyportd = daemon(profiles("server_app.xml", 194, 195), {"--trace", "caller.sums", "--trace-file", trace.string()});
  // A server that takes requests and never answers: every call ends with the bridge's call
  // timeout (150 ms in DdsCalcServer.xml), and nothing is published.
  auto silent = peer(FASTDDS_PEER, "silent", {"serve", "195", "calc", "3", "silent"});
  ASSERT_EQ(silent->wait(60s), 0) << silent->errors();
  // An answering server: sums (n + 0.5) appear. It answers 20 requests and the test needs 5
  // back, so that one reply slower than the call timeout on a busy machine decides nothing.
  auto server = peer(FASTDDS_PEER, "server", {"serve", "195", "calc", "20"});
  ASSERT_EQ(server->wait(60s), 0) << server->errors();
  ASSERT_TRUE(eventually([&] { return traced_sums(trace).size() >= 5; }, 20s)) << "no sums traced";
  const Json stats = stop(*polyportd);
  const auto sums = traced_sums(trace);
  for (double sum : sums) EXPECT_EQ(sum - std::floor(sum), 0.5) << sum;  // n + 0.5 for some n
  ASSERT_EQ(stats["services"].size(), 1u);
  const Json& calls = stats["services"][0];
  EXPECT_GE(calls["timeouts"].get<int>(), 3) << calls.dump(2);  // at least the silent server's
  EXPECT_EQ(calls["ok"].get<std::size_t>(), sums.size()) << calls.dump(2);  // every answer published
}

}  // namespace
}  // namespace polyport
