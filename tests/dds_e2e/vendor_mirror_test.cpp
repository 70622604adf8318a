// polyportd between DDS peer programs (tests/dds_peers), each vendor on the side that
// tests/dds_e2e gives the other: there Cyclone DDS feeds polyport and Fast DDS is fed, and a
// Cyclone client and a Fast DDS server take part in services. Here the Fast DDS model decodes
// into an in-process component (and counts a sample that does not decode), the Cyclone model
// encodes, a Fast DDS client calls an in-process provider, an in-process caller calls a Cyclone
// server, and a Fast DDS publisher restarts. So each model's reading, writing, client-side and
// server-side paths run against a real application of its vendor.
//
// Every process is a child of the test, written to files in the test's own directory; every
// wait is for a line in a child's output or a file, with a deadline. Each test has its own
// pair of DDS domains (200..209) so that tests running in parallel do not hear each other.
#include "e2e_fixture.hpp"

namespace polyport {
namespace {

using namespace test;
using namespace std::chrono_literals;

// The same harness; the name says which half of the matrix a case belongs to.
class DdsVendorMirror : public DdsEndToEnd {};

TEST_F(DdsVendorMirror, FastddsPublisherThroughAnInProcessComponentToACycloneSubscriber) {
  auto polyportd = daemon(profiles("relay_from_fastdds_app.xml", 200, 201));
  auto cyclone_sub = peer(CYCLONE_PEER, "cyclone_sub", {"sub", "200", "pose_back", "6", "60"});
  auto fast_pub = peer(FASTDDS_PEER, "fast_pub", {"pub", "201", "pose_back", kForever, "5"});
  ASSERT_EQ(cyclone_sub->wait(60s), 0) << "Cyclone subscriber: " << cyclone_sub->errors();
  const auto got = poses(*cyclone_sub);
  ASSERT_EQ(got.size(), 6u);
  for (const Json& pose : got) expect_pose(pose, kRelayOffset);
  expect_increasing(got);

  fast_pub.reset();
  const Json stats = stop(*polyportd);
  const Json* in = connection(stats, "fast.pose_back -> relay.in");
  const Json* out = connection(stats, "relay.out -> cyclone.pose_back");
  ASSERT_TRUE(in && out);
  EXPECT_EQ((*in)["conversion"], "xcdr1 -> flat");
  EXPECT_EQ((*out)["conversion"], "flat -> xcdr1");
  EXPECT_GE((*in)["delivered"].get<int>(), 6);
  EXPECT_GE((*out)["delivered"].get<int>(), 6);
  EXPECT_EQ((*in)["dropped"], 0) << in->dump(2);
  EXPECT_EQ((*out)["dropped"], 0) << out->dump(2);
}

TEST_F(DdsVendorMirror, UndecodableSampleReachingTheFastddsModelIsCountedAndTheConnectionGoesOn) {
  auto polyportd = daemon(profiles("relay_from_fastdds_app.xml", 202, 203));
  auto cyclone_sub = peer(CYCLONE_PEER, "cyclone_sub", {"sub", "202", "pose_back", "100000", "60"});
  auto good = peer(FASTDDS_PEER, "good", {"pub", "203", "pose_back", kForever, "5"});
  ASSERT_TRUE(eventually([&] { return poses(*cyclone_sub).size() >= 3; })) << "nothing relayed";
  // A Cyclone application in the Fast DDS model's domain (the two vendors interoperate on the
  // wire) publishes bad_pose.idl's peer::Pose, one octet, on the same topic. The peer exits
  // once polyport's reader has acknowledged both samples.
  auto bad = peer(CYCLONE_BAD_PEER, "bad", {"pub", "203", "pose_back", "2", "5"});
  ASSERT_EQ(bad->wait(60s), 0) << bad->errors();
  const std::size_t before = poses(*cyclone_sub).size();
  ASSERT_TRUE(eventually([&] { return poses(*cyclone_sub).size() >= before + 3; })) << "nothing relayed after";
  good.reset();
  const auto got = poses(*cyclone_sub);
  for (const Json& pose : got) expect_pose(pose, kRelayOffset);
  expect_increasing(got);
  cyclone_sub.reset();

  const Json stats = stop(*polyportd);
  const Json* in = connection(stats, "fast.pose_back -> relay.in");
  ASSERT_TRUE(in);
  EXPECT_EQ((*in)["dropped_by_reason"]["decode_error"], 2) << in->dump(2);
  EXPECT_EQ((*in)["dropped"], 2) << in->dump(2);
  EXPECT_EQ((*in)["delivered"].get<int>() + 2, (*in)["received"].get<int>()) << in->dump(2);
}

TEST_F(DdsVendorMirror, FastddsPublisherThatRestartsIsPickedUpAgain) {
  auto polyportd = daemon(profiles("cross_vendor_app.xml", 204, 205));
  auto cyclone_sub = peer(CYCLONE_PEER, "cyclone_sub", {"sub", "204", "pose_back", "100000", "60"});
  auto first = peer(FASTDDS_PEER, "first_run", {"pub", "205", "pose_back", kForever, "5", "0"});
  ASSERT_TRUE(eventually([&] { return poses(*cyclone_sub).size() >= 2; })) << "first run not forwarded";
  // The application ends (SIGTERM: it deletes its participant, so no shared-memory segment
  // of a killed Fast DDS process is left behind on the test machine; tests/dds_e2e covers a
  // Cyclone publisher killed outright) ...
  first->signal(SIGTERM);
  EXPECT_EQ(first->wait(20s), 0) << first->errors();
  // ... and a new process of it numbers its samples from 1000.
  auto second = peer(FASTDDS_PEER, "second_run", {"pub", "205", "pose_back", kForever, "5", "1000"});
  ASSERT_TRUE(eventually([&] {
    const auto got = poses(*cyclone_sub);
    return !got.empty() && got.back()["id"].get<int>() >= peer_values::id(1002);
  })) << "the restarted publisher was not picked up";
  second.reset();
  const auto got = poses(*cyclone_sub);
  for (const Json& pose : got) expect_pose(pose);
  expect_increasing(got);
  cyclone_sub.reset();
  const Json stats = stop(*polyportd);
  const Json* back = connection(stats, "fast.pose_back -> cyclone.pose_back");
  ASSERT_TRUE(back);
  EXPECT_EQ((*back)["dropped"], 0) << back->dump(2);
}

TEST_F(DdsVendorMirror, FastddsClientCallsAnInProcessService) {
  auto polyportd = daemon(profiles("fastdds_client_app.xml", 206, 207));
  auto client = peer(FASTDDS_PEER, "client", {"call", "207", "calc", "5", "5000"});
  ASSERT_EQ(client->wait(90s), 0) << client->errors();
  int replies = 0;
  for (const Json& j : client->lines()) {
    if (!j.contains("seq")) continue;
    ++replies;
    EXPECT_EQ(j["status"], 0) << j.dump();
    EXPECT_DOUBLE_EQ(j["sum"].get<double>(), j["seq"].get<int>() + 0.5) << j.dump();  // add(i, 0.5)
  }
  EXPECT_EQ(replies, 5);
  const Json stats = stop(*polyportd);
  ASSERT_EQ(stats["services"].size(), 1u);
  EXPECT_EQ(stats["services"][0]["ok"], 5) << stats["services"].dump(2);
}

TEST_F(DdsVendorMirror, InProcessCallerCallsACycloneServerAndTimesOutWithoutOne) {
  const fs::path trace = dir() / "sums.jsonl";
  auto polyportd =
      daemon(profiles("cyclone_server_app.xml", 208, 209), {"--trace", "caller.sums", "--trace-file", trace.string()});
  // A server that takes three requests and answers none: each of those calls ends with the
  // bridge's call timeout (150 ms in DdsCalcServerCyclone.xml) and PeerCaller gets `timeout`.
  auto silent = peer(CYCLONE_PEER, "silent", {"serve", "208", "calc", "3", "silent"});
  ASSERT_EQ(silent->wait(60s), 0) << silent->errors();
  EXPECT_TRUE(traced_sums(trace).empty()) << "a sum without an answering server";
  // The daemon went on: an answering server's sums (n + 0.5) appear. It answers 20 requests,
  // and the test needs 5 of them back, so that one reply slower than the call timeout on a
  // busy machine does not decide the outcome.
  auto server = peer(CYCLONE_PEER, "server", {"serve", "208", "calc", "20"});
  ASSERT_EQ(server->wait(60s), 0) << server->errors();
  ASSERT_TRUE(eventually([&] { return traced_sums(trace).size() >= 5; }, 20s)) << "no sums traced";
  const Json stats = stop(*polyportd);
  const auto sums = traced_sums(trace);
  for (double sum : sums) EXPECT_EQ(sum - std::floor(sum), 0.5) << sum;
  ASSERT_EQ(stats["services"].size(), 1u);
  const Json& calls = stats["services"][0];
  EXPECT_GE(calls["timeouts"].get<int>(), 3) << calls.dump(2);  // at least the silent server's
  EXPECT_EQ(calls["ok"].get<std::size_t>(), sums.size()) << calls.dump(2);  // every answer published
}

}  // namespace
}  // namespace polyport
