// Loop prevention in both DDS models: topic `loop` bridged both ways between two domains
// (tests/data/dds_e2e/loop_app.xml), Cyclone DDS to Fast DDS, Fast DDS to Fast DDS and Cyclone
// DDS to Cyclone DDS. Each side's reader of the topic would also match polyport's own writer of
// it, so every sample polyport forwards would come back to polyport at once. Real peers
// (tests/dds_peers) publish and subscribe on both sides; the test shows that each peer sample
// is forwarded exactly once, that no subscriber sees a sample twice, and that each of
// polyport's writes that the SDK hands back is dropped (Fast DDS: the reading topic's
// `loop_dropped` equals the writes into that domain; Cyclone DDS never hands them back).
// Without loop prevention a sample goes round for as long as the daemon runs: the forwarded
// counts exceed what the peers published and the subscribers see repeats. With both sides'
// publishers running at once, the test also shows that the bridge does not deadlock: a
// reader's listener writing to the other side while that side's listener writes back.
#include <set>

#include "e2e_scenarios.hpp"

namespace polyport {
namespace {

using namespace test;
using namespace std::chrono_literals;

// The topic polyport reads (from_dds) of component `component` in the statistics.
const Json* read_topic(const Json& stats, const std::string& component) {
  for (const Json& c : stats["components"]) {
    if (c["name"] != component) continue;
    for (const Json& topic : c["dds"]["topics"]) {
      if (topic["polyport"] == "reads") return &topic;
    }
  }
  ADD_FAILURE() << "no topic read by " << component << " in " << stats.dump(2);
  return nullptr;
}

std::set<int> ids_of(const Child& subscriber) {
  std::set<int> ids;
  for (const Json& pose : poses(subscriber)) ids.insert(pose["id"].get<int>());
  return ids;
}

// Every pose a subscriber printed is right, and came once.
void expect_each_once(const Child& subscriber, const char* who) {
  const auto got = poses(subscriber);
  for (const Json& pose : got) expect_pose(pose);
  EXPECT_EQ(ids_of(subscriber).size(), got.size()) << who << " saw a pose more than once";
}

struct Side {
  const char* model;
  const char* peer;
  int domain;
};

class DdsLoop : public DdsEndToEnd {
 protected:
  void bridge_both_ways(const Side& a, const Side& b) {
    constexpr int kCount = 40;
    const fs::path app = fill_templates(POLYPORT_TEST_DATA "/dds_e2e",
                                        {{"@A@", text(a.domain)},
                                         {"@B@", text(b.domain)},
                                         {"@MODEL_A@", a.model},
                                         {"@MODEL_B@", b.model},
                                         {"@SRC@", POLYPORT_SOURCE_DIR}},
                                        "loop_app.xml");
    auto polyportd = daemon(app);
    auto sub_a = peer(a.peer, "sub_a", {"sub", text(a.domain), "loop", "100000", "60"});
    auto sub_b = peer(b.peer, "sub_b", {"sub", text(b.domain), "loop", "100000", "60"});
    ASSERT_TRUE(eventually([&] { return sub_a->saw_event("matched") && sub_b->saw_event("matched"); }))
        << "the subscribers matched no writer of polyport's";
    // Both sides publish at once, ids from 0 on side a and from 1000 on side b; each
    // publisher ends once every reader it matched has acknowledged every sample.
    auto pub_a = peer(a.peer, "pub_a", {"pub", text(a.domain), "loop", text(kCount), "5", "0"});
    auto pub_b = peer(b.peer, "pub_b", {"pub", text(b.domain), "loop", text(kCount), "5", "1000"});
    ASSERT_EQ(pub_a->wait(60s), 0) << pub_a->errors();
    ASSERT_EQ(pub_b->wait(60s), 0) << pub_b->errors();
    // Some of each side's samples reach the other side's subscriber (the first ones may go
    // before polyport's writer has matched it: volatile topics).
    ASSERT_TRUE(eventually([&] {
      const std::set<int> at_b = ids_of(*sub_b);
      const std::set<int> at_a = ids_of(*sub_a);
      return !at_b.empty() && *at_b.begin() < peer_values::id(1000) && !at_a.empty() &&
             *at_a.rbegin() >= peer_values::id(1000);
    })) << "nothing crossed";

    const Json stats = stop(*polyportd);
    expect_each_once(*sub_a, "side a's subscriber");
    expect_each_once(*sub_b, "side b's subscriber");
    sub_a.reset();
    sub_b.reset();
    const Json* there = connection(stats, "a.from_dds -> b.to_dds");
    const Json* back = connection(stats, "b.from_dds -> a.to_dds");
    const Json* topic_a = read_topic(stats, "a");
    const Json* topic_b = read_topic(stats, "b");
    ASSERT_TRUE(there && back && topic_a && topic_b);
    EXPECT_EQ((*there)["conversion"], "passthrough");
    // What polyport read on each side came from that side's publisher (at most kCount) and
    // was forwarded once.
    for (const Json* link : {there, back}) {
      EXPECT_GE((*link)["delivered"].get<int>(), 1) << link->dump(2);
      EXPECT_LE((*link)["delivered"].get<int>(), kCount) << link->dump(2);
      EXPECT_EQ((*link)["dropped"], 0) << link->dump(2);
    }
    EXPECT_EQ((*topic_a)["received"], (*there)["received"]) << topic_a->dump(2);
    EXPECT_EQ((*topic_b)["received"], (*back)["received"]) << topic_b->dump(2);
    // Each of polyport's writes that the SDK handed back to polyport's reader was dropped.
    const auto handed_back = [](const Side& side, const Json& into) {
      return std::string(side.model) == "fastdds" ? into["delivered"].get<int>() : 0;
    };
    EXPECT_EQ((*topic_b)["loop_dropped"].get<int>(), handed_back(b, *there)) << topic_b->dump(2);
    EXPECT_EQ((*topic_a)["loop_dropped"].get<int>(), handed_back(a, *back)) << topic_a->dump(2);
  }
};

TEST_F(DdsLoop, CycloneAndFastddsTopicBridgedBothWaysForwardsEachPeerSampleOnce) {
  bridge_both_ways({"cyclonedds", CYCLONE_PEER, 214}, {"fastdds", FASTDDS_PEER, 215});
}

TEST_F(DdsLoop, FastddsTopicBridgedBothWaysAcrossDomainsForwardsEachPeerSampleOnce) {
  bridge_both_ways({"fastdds", FASTDDS_PEER, 216}, {"fastdds", FASTDDS_PEER, 217});
}

TEST_F(DdsLoop, CycloneTopicBridgedBothWaysAcrossDomainsForwardsEachPeerSampleOnce) {
  bridge_both_ways({"cyclonedds", CYCLONE_PEER, 218}, {"cyclonedds", CYCLONE_PEER, 219});
}

}  // namespace
}  // namespace polyport
