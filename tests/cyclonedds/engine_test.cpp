// The Cyclone DDS model in the engine, in one process: polyport bridges domain 144 to
// domain 145 (tests/data/cyclonedds/bridge_app.xml). An idlc-generated writer publishes on
// 144, the model's raw reader hands the XCDR1 bytes to the `left` adaptor, the passthrough
// connection gives them to the `right` adaptor's sink, whose raw writer publishes on 145,
// where an idlc-generated reader takes them. Also: the loader's <dds> errors.
// Every wait polls a condition until a deadline; nothing sleeps a fixed time.
#include <gtest/gtest.h>

#include "generated_peer.hpp"

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "../support/engine_fixture.hpp"
#include "../support/eventually.hpp"
#include "cyclonedds_domain.hpp"
#include "dds_model.hpp"
#include "dds/dds.h"
#include "polyport/runtime/engine.hpp"

namespace polyport {
namespace {

using test::eventually;

constexpr dds_domainid_t kLeftDomain = 144;
constexpr dds_domainid_t kRightDomain = 145;
constexpr const char* kTopic = "polyport_bridge_pose";

// An application built the usual way: generated type, reliable keep-last-10 like polyport.
using test::GeneratedPeer;
using test::publication_matches;
using test::subscription_matches;

class CycloneEngineTest : public test::EngineFixture {
 protected:
  CycloneEngineTest() : EngineFixture(POLYPORT_TEST_DATA "/cyclonedds", LoadOptions{}) {
    models.add(std::make_unique<dds::DdsModel>("cyclonedds", cyclonedds::make_cyclonedds_domain,
                                                 cyclonedds::default_config()));
  }
};

TEST_F(CycloneEngineTest, BridgesTwoDomainsAsPassthrough) {
  ASSERT_TRUE(build("bridge_app.xml")) << problems();
  std::vector<std::string> warnings;
  ASSERT_TRUE(engine.start(warnings));

  nlohmann::json graph;
  engine.describe(graph);
  ASSERT_EQ(graph["connections"].size(), 1u) << graph.dump(2);
  EXPECT_EQ(graph["connections"][0]["conversion"], "passthrough") << graph.dump(2);

  {
    // The peers join the domains the model created (with the loopback configuration); they
    // go before the engine, whose participants own those domains.
    GeneratedPeer left(kLeftDomain, kTopic);
    GeneratedPeer right(kRightDomain, kTopic);
    ASSERT_TRUE(left.ok());
    ASSERT_TRUE(right.ok());
    const dds_entity_t writer = left.make_writer();
    const dds_entity_t reader = right.make_reader();
    ASSERT_GT(writer, 0) << dds_strretcode(writer);
    ASSERT_GT(reader, 0) << dds_strretcode(reader);
    ASSERT_TRUE(eventually([&] { return publication_matches(writer) >= 1; }))
        << "the generated writer never matched polyport's reader on domain 144";
    ASSERT_TRUE(eventually([&] { return subscription_matches(reader) >= 1; }))
        << "the generated reader never matched polyport's writer on domain 145";

    std::vector<double> samples{0.5, -1.0, 3.75};
    raw_peer_Pose sent{};
    sent.id = -42;
    sent.x = 1.25;
    sent.heading = -0.5F;
    sent.valid = true;
    sent.frame = const_cast<char*>("base_link");
    sent.samples._buffer = samples.data();
    sent.samples._length = sent.samples._maximum = static_cast<std::uint32_t>(samples.size());
    sent.samples._release = false;
    sent.last = 0xab;
    ASSERT_EQ(dds_write(writer, &sent), DDS_RETCODE_OK);

    void* buffers[1] = {nullptr};
    dds_sample_info_t infos[1];
    dds_return_t taken = 0;
    ASSERT_TRUE(eventually([&] {
      taken = dds_take(reader, buffers, infos, 1, 1);
      return taken > 0 && infos[0].valid_data;
    })) << "nothing arrived on domain 145";
    const auto* got = static_cast<const raw_peer_Pose*>(buffers[0]);
    EXPECT_EQ(got->id, -42);
    EXPECT_EQ(got->x, 1.25);
    EXPECT_EQ(got->heading, -0.5F);
    EXPECT_TRUE(got->valid);
    EXPECT_STREQ(got->frame, "base_link");
    ASSERT_EQ(got->samples._length, 3u);
    EXPECT_EQ(got->samples._buffer[0], 0.5);
    EXPECT_EQ(got->samples._buffer[1], -1.0);
    EXPECT_EQ(got->samples._buffer[2], 3.75);
    EXPECT_EQ(got->last, 0xab);
    dds_return_loan(reader, buffers, taken);

    // The statistics carry the DDS component's own counters: what polyport's reader on the
    // left took from the generated writer (counted once the forward has returned, so read
    // until it shows), and the writer it matched, which is still there.
    const auto left_topic = [&] {
      nlohmann::json live;
      engine.stats(live);
      for (const auto& c : live["components"]) {
        if (c["name"] == "left" && c.contains("dds")) return c["dds"]["topics"][0];
      }
      return nlohmann::json::object();
    };
    EXPECT_TRUE(eventually([&] { return left_topic().value("received", 0) == 1; })) << left_topic().dump(2);
    const nlohmann::json topic = left_topic();
    EXPECT_EQ(topic["polyport"], "reads") << topic.dump(2);
    EXPECT_EQ(topic["refused"], 0) << topic.dump(2);
    EXPECT_EQ(topic["matched_writers"], 1) << topic.dump(2);
  }

  nlohmann::json stats;
  engine.stats(stats);
  const auto& connection = stats["connections"][0];
  EXPECT_GE(connection["received"].get<std::uint64_t>(), 1u) << stats.dump(2);
  EXPECT_EQ(connection["dropped"], 0) << stats.dump(2);
  nlohmann::json left_component;
  for (const auto& c : graph["components"]) {
    if (c["name"] == "left") left_component = c;
  }
  EXPECT_EQ(left_component["dds"]["domain"], kLeftDomain) << graph.dump(2);
  EXPECT_EQ(left_component["dds"]["topics"][0]["type"], "raw_peer::Pose") << graph.dump(2);
  engine.stop();
}

TEST_F(CycloneEngineTest, BadDomainAndMissingConfigAreReportedWithLocations) {
  EXPECT_FALSE(build("bad_domain.xml"));
  const std::string all = problems();
  EXPECT_NE(all.find("BadDomain.xml:5:16: /component_profile/dds/domain: bad DDS domain '300': expected an "
                     "integer from 0 to 232"),
            std::string::npos)
      << all;
  EXPECT_NE(all.find("BadDomain.xml:5:36: /component_profile/dds/config: DDS configuration file '"),
            std::string::npos)
      << all;
  EXPECT_NE(all.find("missing.xml' not found"), std::string::npos) << all;
}

}  // namespace
}  // namespace polyport
