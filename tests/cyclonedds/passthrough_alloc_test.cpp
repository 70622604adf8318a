// Zero heap allocations per forwarded sample on the DDS passthrough path, against Cyclone DDS:
// polyport bridges domain 146 to 147 (tests/data/cyclonedds/alloc_app.xml); an idlc-generated
// writer publishes, an idlc-generated reader takes. This binary interposes malloc and
// counts, on each thread, only while that thread is inside polyport's part of the path: from
// entering polyport's reader callback to calling the SDK's write, and from that write's return
// to the callback's end (a wrapping Domain switches counting on and off at those edges). The
// SDK's own allocations are counted apart and reported, not asserted: they are Cyclone's.
#include <gtest/gtest.h>

#include "generated_peer.hpp"

#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <nlohmann/json.hpp>

#include "../support/engine_fixture.hpp"
#include "../support/eventually.hpp"
#include "cyclonedds_domain.hpp"
#include "dds_model.hpp"

#include "../support/alloc_gate.hpp"

namespace polyport {
namespace {

using test::eventually;
using test::g_callbacks;
using test::g_all_allocations;
using test::g_polyport_allocations;

class PassthroughAlloc : public test::EngineFixture {
 protected:
  PassthroughAlloc() : EngineFixture(POLYPORT_TEST_DATA "/cyclonedds", LoadOptions{}) {
    models.add(test::counting_model("cyclonedds", cyclonedds::make_cyclonedds_domain, cyclonedds::default_config()));
  }
};

TEST_F(PassthroughAlloc, ForwardingASampleAllocatesNothingInPolyport) {
  ASSERT_TRUE(build("alloc_app.xml")) << problems();
  std::vector<std::string> warnings;
  ASSERT_TRUE(engine.start(warnings));
  {
    test::GeneratedPeer left(146, "polyport_alloc_pose");
    test::GeneratedPeer right(147, "polyport_alloc_pose");
    ASSERT_TRUE(left.ok() && right.ok());
    const dds_entity_t writer = left.make_writer();
    const dds_entity_t reader = right.make_reader();
    ASSERT_GT(writer, 0);
    ASSERT_GT(reader, 0);
    ASSERT_TRUE(eventually([&] { return test::publication_matches(writer) >= 1; }));
    ASSERT_TRUE(eventually([&] { return test::subscription_matches(reader) >= 1; }));

    std::vector<double> samples{0.5, -1.0, 3.75};
    raw_peer_Pose sent{};
    sent.frame = const_cast<char*>("base_link");
    sent.samples._buffer = samples.data();
    sent.samples._length = sent.samples._maximum = 3;
    auto send_and_take = [&](int count) {
      for (int i = 0; i < count; ++i) {
        sent.id = i;
        ASSERT_EQ(dds_write(writer, &sent), DDS_RETCODE_OK);
        void* buffers[1] = {nullptr};
        dds_sample_info_t infos[1];
        dds_return_t taken = 0;
        ASSERT_TRUE(eventually([&] {
          taken = dds_take(reader, buffers, infos, 1, 1);
          return taken > 0 && infos[0].valid_data;
        })) << "sample " << i << " did not arrive on domain 147";
        EXPECT_EQ(static_cast<const raw_peer_Pose*>(buffers[0])->id, i);
        dds_return_loan(reader, buffers, taken);
      }
    };
    send_and_take(50);  // warm-up: first-use allocations (histogram pages, SDK caches)

    constexpr int kSamples = 1000;
    const std::uint64_t callbacks_before = g_callbacks.load();
    const std::uint64_t polyport_before = g_polyport_allocations.load();
    const std::uint64_t all_before = g_all_allocations.load();
    send_and_take(kSamples);
    const std::uint64_t polyport = g_polyport_allocations.load() - polyport_before;
    const std::uint64_t all = g_all_allocations.load() - all_before;

    EXPECT_EQ(g_callbacks.load() - callbacks_before, static_cast<std::uint64_t>(kSamples));
    EXPECT_EQ(polyport, 0u) << "polyport allocated on the forwarding path";
    // Everything else in the process (Cyclone, the test's own peer code): reported.
    RecordProperty("allocations_per_sample_outside_polyport", std::to_string(static_cast<double>(all) / kSamples));
    std::printf("allocations per forwarded sample: polyport %.3f, whole process %.3f\n",
                static_cast<double>(polyport) / kSamples, static_cast<double>(all) / kSamples);
  }
  nlohmann::json stats;
  engine.stats(stats);
  EXPECT_EQ(stats["connections"][0]["conversion"], "passthrough") << stats.dump(2);
  EXPECT_EQ(stats["connections"][0]["dropped"], 0) << stats.dump(2);
  engine.stop();
}

}  // namespace
}  // namespace polyport
