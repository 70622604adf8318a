// Zero heap allocations per forwarded LCM message in polyport, on the passthrough path
// (pose_t -> pose_t) and on a converting one (pose_t decoded, mapped onto pose2_t, encoded):
// tests/data/lcm_alloc/alloc_app.xml, in a network namespace of the test's own with a
// multicast route on loopback. The test publishes with lcm-gen code and its own lcm_t and
// takes both outputs the same way.
//
// This binary interposes malloc (tests/support/malloc_counter.hpp) and two LCM entry points:
// lcm_subscribe, whose handlers it wraps while the engine starts, so a thread counts from
// entering polyport's subscription handler to its end; and lcm_publish, during which it does
// not count (LCM's own send). The SDK's allocations are counted apart and reported.
#include <gtest/gtest.h>
#include <dlfcn.h>
#include <poll.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include <lcm/lcm.h>
#include <nlohmann/json.hpp>

#include "../support/engine_fixture.hpp"
#include "../support/malloc_counter.hpp"
#include "../support/multicast_namespace.hpp"
#include "lcm_model.hpp"
#include "peer_pose2_t.h"
#include "peer_pose_t.h"

namespace polyport::test {
namespace {

std::atomic<bool> g_wrap_subscriptions{false};
std::atomic<std::uint64_t> g_handler_calls{0};

struct Wrapped {
  lcm_msg_handler_t handler;
  void* user;
};

void counting_handler(const lcm_recv_buf_t* buffer, const char* channel, void* user) {
  const auto* wrapped = static_cast<const Wrapped*>(user);
  Scope polyport(true);
  g_handler_calls.fetch_add(1, std::memory_order_relaxed);
  wrapped->handler(buffer, channel, wrapped->user);
}

}  // namespace
}  // namespace polyport::test

extern "C" {
lcm_subscription_t* lcm_subscribe(lcm_t* lcm, const char* channel, lcm_msg_handler_t handler, void* user) {
  using Subscribe = lcm_subscription_t* (*)(lcm_t*, const char*, lcm_msg_handler_t, void*);
  static const auto real = reinterpret_cast<Subscribe>(dlsym(RTLD_NEXT, "lcm_subscribe"));
  if (!polyport::test::g_wrap_subscriptions.load()) return real(lcm, channel, handler, user);
  // Made while the engine starts, kept for the process: not on the path being counted.
  auto* wrapped = new polyport::test::Wrapped{handler, user};
  return real(lcm, channel, polyport::test::counting_handler, wrapped);
}
int lcm_publish(lcm_t* lcm, const char* channel, const void* data, unsigned int size) {
  using Publish = int (*)(lcm_t*, const char*, const void*, unsigned int);
  static const auto real = reinterpret_cast<Publish>(dlsym(RTLD_NEXT, "lcm_publish"));
  polyport::test::Scope sdk(false);
  return real(lcm, channel, data, size);
}
}

namespace polyport::test {
namespace {

struct Received {
  int same = 0;
  int other = 0;
  int bad = 0;
};

void on_same(const lcm_recv_buf_t*, const char*, const peer_pose_t* pose, void* user) {
  auto* got = static_cast<Received*>(user);
  ++got->same;
  if (pose->nsamples != 3 || pose->samples[2] != 3.75 || std::strcmp(pose->frame, "base_link") != 0) ++got->bad;
}
void on_other(const lcm_recv_buf_t*, const char*, const peer_pose2_t* pose, void* user) {
  auto* got = static_cast<Received*>(user);
  ++got->other;
  if (pose->nsamples != 3 || pose->samples[2] != 3.75 || std::strcmp(pose->frame, "base_link") != 0) ++got->bad;
}

class LcmAlloc : public EngineFixture {
 protected:
  LcmAlloc() : EngineFixture(POLYPORT_TEST_DATA "/lcm_alloc", LoadOptions{}) {
    models.add(std::make_unique<lcm::LcmModel>());
  }
  void SetUp() override {
    isolate_with_multicast_route();
  }
};

TEST_F(LcmAlloc, ForwardingAMessageAllocatesNothingInPolyport) {
  ASSERT_TRUE(build("alloc_app.xml")) << problems();
  std::vector<std::string> warnings;
  g_wrap_subscriptions = true;
  ASSERT_TRUE(engine.start(warnings)) << problems();
  g_wrap_subscriptions = false;

  lcm_t* lcm = lcm_create(nullptr);  // LCM's default provider, as the profile's
  ASSERT_NE(lcm, nullptr);
  Received got;
  peer_pose_t_subscribe(lcm, "ALLOC_SAME", on_same, &got);
  peer_pose2_t_subscribe(lcm, "ALLOC_OTHER", on_other, &got);
  std::vector<double> samples{0.5, -1.0, 3.75};
  std::int16_t quad[4] = {1, 2, 3, 4};
  peer_pose_t sent{};
  sent.frame = const_cast<char*>("base_link");
  sent.nsamples = 3;
  sent.samples = samples.data();
  std::memcpy(sent.quad, quad, sizeof quad);
  const int fd = lcm_get_fileno(lcm);
  ASSERT_GE(fd, 0);
  // One message at a time, each waited for on both outputs, so LCM's queues never drop one.
  auto send_and_take = [&](int count) {
    for (int i = 0; i < count; ++i) {
      const int same = got.same;
      const int other = got.other;
      sent.id = i;
      ASSERT_EQ(peer_pose_t_publish(lcm, "ALLOC_IN", &sent), 0);
      for (int spins = 0; (got.same == same || got.other == other) && spins < 200; ++spins) {
        pollfd p{fd, POLLIN, 0};
        if (poll(&p, 1, 10) > 0) lcm_handle(lcm);
      }
      ASSERT_GT(got.same, same) << "message " << i << " did not arrive on ALLOC_SAME";
      ASSERT_GT(got.other, other) << "message " << i << " did not arrive on ALLOC_OTHER";
    }
  };
  send_and_take(50);  // warm-up: first-use allocations (histogram pages, LCM's buffers)

  constexpr int kMessages = 500;
  const std::uint64_t calls_before = g_handler_calls.load();
  const std::uint64_t polyport_before = g_polyport_allocations.load();
  const std::uint64_t all_before = g_all_allocations.load();
  send_and_take(kMessages);
  const std::uint64_t polyport = g_polyport_allocations.load() - polyport_before;
  const std::uint64_t all = g_all_allocations.load() - all_before;
  EXPECT_EQ(got.bad, 0);
  EXPECT_EQ(g_handler_calls.load() - calls_before, static_cast<std::uint64_t>(kMessages));
  EXPECT_EQ(polyport, 0u) << "polyport allocated on the forwarding path";
  RecordProperty("allocations_per_message_outside_polyport", std::to_string(static_cast<double>(all) / kMessages));
  std::printf("allocations per forwarded message (two outputs): polyport %.3f, whole process %.3f\n",
              static_cast<double>(polyport) / kMessages, static_cast<double>(all) / kMessages);
  lcm_destroy(lcm);

  nlohmann::json stats;
  engine.stats(stats);
  EXPECT_EQ(stats["connections"][0]["conversion"], "passthrough") << stats.dump(2);
  EXPECT_EQ(stats["connections"][1]["conversion"], "lcm -> flat -> map -> lcm") << stats.dump(2);
  EXPECT_EQ(stats["connections"][0]["dropped"], 0) << stats.dump(2);
  EXPECT_EQ(stats["connections"][1]["dropped"], 0) << stats.dump(2);
  engine.stop();
}

}  // namespace
}  // namespace polyport::test
