// Zero heap allocations per forwarded sample on the DDS passthrough path, against Fast DDS:
// polyport bridges domain 156 to 157 (tests/data/fastdds/alloc_app.xml, demo::Pose: samples
// cross the transports) and 169 to 170 (alloc_sized_app.xml, the bounded demo::Sized: every
// endpoint shares samples in memory, Fast DDS's data sharing). The application's
// ends are raw endpoints on participants of their own, so the test also sees that the bytes
// arrive untouched. Counting as in tests/support/alloc_gate.hpp: only polyport's part of the
// path is asserted; Fast DDS's own allocations are reported.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <mutex>
#include <nlohmann/json.hpp>
#include <vector>

#include "../support/engine_fixture.hpp"
#include "../support/eventually.hpp"
#include "dds_model.hpp"
#include "fastdds_domain.hpp"
#include "raw_type.hpp"

#include "../support/alloc_gate.hpp"

namespace polyport {
namespace {

using test::eventually;

// The application's two ends as raw endpoints on participants of their own (domains
// `from` and `to`), `sample_size` bytes a sample; the engine runs `app`.
struct Path {
  const char* app;
  std::uint32_t from;
  std::uint32_t to;
  const char* topic;
  const char* type;
  bool bounded;  // the ends share memory with polyport (raw_type.hpp, data sharing)
  std::size_t sample_size;
};

class FastddsPassthroughAlloc : public test::EngineFixture {
 protected:
  FastddsPassthroughAlloc() : EngineFixture(POLYPORT_TEST_DATA "/fastdds", LoadOptions{}) {
    models.add(test::counting_model("fastdds", fastdds::make_fastdds_domain, fastdds::default_config()));
  }
  void forward_and_count(const Path& path);
};

void FastddsPassthroughAlloc::forward_and_count(const Path& path) {
  ASSERT_TRUE(build(path.app)) << problems();
  std::vector<std::string> warnings;
  ASSERT_TRUE(engine.start(warnings));
  {
    fastdds::ParticipantOptions left_options;
    left_options.domain_id = path.from;
    fastdds::ParticipantOptions right_options;
    right_options.domain_id = path.to;
    auto left = fastdds::Participant::create(left_options);
    auto right = fastdds::Participant::create(right_options);
    ASSERT_TRUE(left && right);
    // A bounded type's largest sample (demo::Sized: 88 bytes) is every pool slot's size.
    const std::uint32_t max_size = path.bounded ? 128 : fastdds::kDefaultMaxPayload;
    auto writer = fastdds::RawWriter::create(*left.value(), path.topic, path.type, DdsQos{}, max_size, path.bounded);
    ASSERT_TRUE(writer) << writer.error().message;
    std::mutex mutex;
    std::vector<std::vector<std::byte>> received;
    auto reader = fastdds::RawReader::create(
        *right.value(), path.topic, path.type, DdsQos{},
        [&](const std::byte* cdr, std::uint32_t size, MonoTime) {
          std::lock_guard<std::mutex> lock(mutex);
          received.emplace_back(cdr, cdr + size);
        },
        max_size, false, nullptr, path.bounded);
    ASSERT_TRUE(reader) << reader.error().message;
    ASSERT_TRUE(eventually([&] { return writer.value()->matched_readers() >= 1; }));
    ASSERT_TRUE(eventually([&] { return reader.value()->matched_writers() >= 1; }));

    // XCDR1 bytes as a sample of the type would be; passthrough carries them without looking.
    std::vector<std::byte> sample(path.sample_size);
    sample[1] = std::byte{1};  // CDR_LE
    // Sample i carries i in byte 4 and 0 in byte 5; waiting is for that very sample, so a
    // late repeat of the first one (below) is never taken for another.
    auto arrived = [&](std::byte tag, std::byte mark, std::size_t from) {
      std::lock_guard<std::mutex> lock(mutex);
      for (std::size_t k = from; k < received.size(); ++k) {
        if (received[k].size() > 5 && received[k][4] == tag && received[k][5] == mark) return true;
      }
      return false;
    };
    auto count_received = [&] {
      std::lock_guard<std::mutex> lock(mutex);
      return received.size();
    };
    auto send_and_wait = [&](int count) {
      for (int i = 0; i < count; ++i) {
        sample[4] = static_cast<std::byte>(i);
        const std::size_t before = count_received();
        ASSERT_EQ(writer.value()->write(sample.data(), static_cast<std::uint32_t>(sample.size())), Status::ok);
        ASSERT_TRUE(eventually([&] { return arrived(sample[4], std::byte{0}, before); }))
            << "sample " << i << " did not arrive on domain " << path.to;
      }
    };
    // Discovery is not symmetric: the right reader may list polyport's writer before that
    // writer lists it, and a volatile sample written in between reaches nobody. So a first
    // sample (marked in byte 5) is repeated until one arrives; from then on every sample must.
    // Delivery is reliable and in order: every repeat that arrives at all does so before the
    // first warm-up sample.
    sample[5] = std::byte{0xFF};
    ASSERT_TRUE(eventually([&] {
      const std::size_t before = count_received();
      if (writer.value()->write(sample.data(), static_cast<std::uint32_t>(sample.size())) != Status::ok) return false;
      return eventually([&] { return arrived(sample[4], std::byte{0xFF}, before); }, std::chrono::milliseconds(200));
    })) << "no sample reached domain " << path.to;
    sample[5] = std::byte{0};
    send_and_wait(50);  // warm-up
    const std::uint64_t callbacks_before = test::g_callbacks.load();
    const std::uint64_t polyport_before = test::g_polyport_allocations.load();
    const std::uint64_t all_before = test::g_all_allocations.load();
    constexpr int kSamples = 500;
    send_and_wait(kSamples);
    const std::uint64_t polyport = test::g_polyport_allocations.load() - polyport_before;
    const std::uint64_t all = test::g_all_allocations.load() - all_before;
    EXPECT_EQ(test::g_callbacks.load() - callbacks_before, static_cast<std::uint64_t>(kSamples));
    EXPECT_EQ(polyport, 0u) << "polyport allocated on the forwarding path";
    std::printf("allocations per forwarded sample: polyport %.3f, whole process %.3f\n",
                static_cast<double>(polyport) / kSamples, static_cast<double>(all) / kSamples);
    std::lock_guard<std::mutex> lock(mutex);
    // Untouched: Fast DDS may append padding up to 4-byte alignment, never change a byte.
    ASSERT_GE(received.back().size(), sample.size());
    EXPECT_TRUE(std::equal(sample.begin(), sample.end(), received.back().begin()));
  }
  nlohmann::json stats;
  engine.stats(stats);
  EXPECT_EQ(stats["connections"][0]["conversion"], "passthrough") << stats.dump(2);
  EXPECT_EQ(stats["connections"][0]["dropped"], 0) << stats.dump(2);
  engine.stop();
}

TEST_F(FastddsPassthroughAlloc, ForwardingASampleAllocatesNothingInPolyport) {
  forward_and_count({"alloc_app.xml", 156, 157, "polyport_alloc_pose", "demo::Pose", false, 64});
}

TEST_F(FastddsPassthroughAlloc, ForwardingThroughSharedMemoryAllocatesNothingInPolyport) {
  forward_and_count({"alloc_sized_app.xml", 169, 170, "polyport_alloc_sized", "demo::Sized", true, 48});
}

}  // namespace
}  // namespace polyport
