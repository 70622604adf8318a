// Zero heap allocations per forwarded LCM message in polyport, on the passthrough path
// (pose_t -> pose_t) and on a converting one (pose_t decoded, mapped onto pose2_t, encoded):
// tests/data/lcm_alloc/alloc_app.xml, in a network namespace of the test's own with a
// multicast route on loopback. The test publishes with lcm-gen code and its own lcm_t and
// takes both outputs the same way. Likewise per service call, both ways
// (tests/data/lcm_alloc/services_app.xml): an in-process call to an LCM server, counted on the
// calling thread and on the thread that takes the reply, and an LCM client's call to an
// in-process provider that runs it on the thread that took the request.
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
#include <thread>
#include <vector>

#include <lcm/lcm.h>
#include <nlohmann/json.hpp>

#include "../support/engine_fixture.hpp"
#include "../support/malloc_counter.hpp"
#include "../support/multicast_namespace.hpp"
#include "lcm_model.hpp"
#include "peer_add_reply_t.h"
#include "peer_add_request_t.h"
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

// Loop prevention on the path: a channel polyport publishes what it reads from the same
// channel (tests/data/lcm_alloc/loop_app.xml). Each message the test publishes is forwarded
// once and its echo, back in polyport's subscription, is fingerprinted, found and dropped:
// two handler calls per message, no allocation by polyport in either.
TEST_F(LcmAlloc, DroppingTheEchoOfItsOwnPublishAllocatesNothingInPolyport) {
  ASSERT_TRUE(build("loop_app.xml")) << problems();
  std::vector<std::string> warnings;
  g_wrap_subscriptions = true;
  ASSERT_TRUE(engine.start(warnings)) << problems();
  g_wrap_subscriptions = false;

  lcm_t* lcm = lcm_create(nullptr);
  ASSERT_NE(lcm, nullptr);
  Received got;
  peer_pose_t_subscribe(lcm, "ALLOC_LOOP", on_same, &got);
  std::vector<double> samples{0.5, -1.0, 3.75};
  peer_pose_t sent{};
  sent.frame = const_cast<char*>("base_link");
  sent.nsamples = 3;
  sent.samples = samples.data();
  const int fd = lcm_get_fileno(lcm);
  ASSERT_GE(fd, 0);
  // The test's subscription sees each message twice: as it published it, and polyport's copy.
  auto send_and_take = [&](int count) {
    for (int i = 0; i < count; ++i) {
      const int same = got.same;
      const std::uint64_t calls = g_handler_calls.load();
      sent.id = i;
      ASSERT_EQ(peer_pose_t_publish(lcm, "ALLOC_LOOP", &sent), 0);
      for (int spins = 0; (got.same < same + 2 || g_handler_calls.load() < calls + 2) && spins < 200; ++spins) {
        pollfd p{fd, POLLIN, 0};
        if (poll(&p, 1, 10) > 0) lcm_handle(lcm);
      }
      ASSERT_EQ(got.same, same + 2) << "message " << i << " was not forwarded once";
    }
  };
  send_and_take(50);

  constexpr int kMessages = 500;
  const std::uint64_t calls_before = g_handler_calls.load();
  const std::uint64_t polyport_before = g_polyport_allocations.load();
  send_and_take(kMessages);
  const std::uint64_t polyport = g_polyport_allocations.load() - polyport_before;
  EXPECT_EQ(got.bad, 0);
  EXPECT_EQ(g_handler_calls.load() - calls_before, static_cast<std::uint64_t>(2 * kMessages));
  EXPECT_EQ(polyport, 0u) << "polyport allocated on the forwarding or the echo-dropping path";
  lcm_destroy(lcm);

  nlohmann::json stats;
  engine.stats(stats);
  const nlohmann::json& channel = stats["components"][0]["lcm"]["channels"][0];
  EXPECT_EQ(channel["loop_dropped"], 50 + kMessages) << stats.dump(2);
  EXPECT_EQ(stats["connections"][0]["delivered"], 50 + kMessages) << stats.dump(2);
  engine.stop();
}

// An LCM server of calc on its own lcm_t and thread (its handler is not polyport's: it
// subscribed while subscriptions were not wrapped): replies sum = a + b.
class CalcServer {
 public:
  CalcServer() : lcm_(lcm_create(nullptr)) {
    if (lcm_ == nullptr) return;
    peer_add_request_t_subscribe(lcm_, "ALLOC_SERVER/add/request", on_request, this);
    fd_ = lcm_get_fileno(lcm_);
    if (fd_ >= 0) thread_ = std::thread([this] { run(); });
  }
  ~CalcServer() {
    stop_ = true;
    if (thread_.joinable()) thread_.join();
    if (lcm_ != nullptr) lcm_destroy(lcm_);
  }
  bool ok() const { return thread_.joinable(); }

 private:
  static void on_request(const lcm_recv_buf_t*, const char*, const peer_add_request_t* request, void* user) {
    auto* self = static_cast<CalcServer*>(user);
    peer_add_reply_t reply{};
    reply.header.client_id = request->header.client_id;
    reply.header.sequence = request->header.sequence;
    reply.reply.sum = request->request.a + request->request.b;
    peer_add_reply_t_publish(self->lcm_, "ALLOC_SERVER/add/reply", &reply);
  }
  void run() {
    while (!stop_) {
      pollfd p{fd_, POLLIN, 0};
      if (poll(&p, 1, 10) > 0) lcm_handle(lcm_);
    }
  }
  lcm_t* lcm_;
  int fd_ = -1;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

struct ClientReplies {
  std::int64_t sequence = 0;
  bool got = false;
  double sum = 0;
};

void on_client_reply(const lcm_recv_buf_t*, const char*, const peer_add_reply_t* reply, void* user) {
  auto* replies = static_cast<ClientReplies*>(user);
  if (reply->header.sequence != replies->sequence || reply->header.status != 0) return;
  replies->got = true;
  replies->sum = reply->reply.sum;
}

struct Pair {
  double a;
  double b;
};

TEST_F(LcmAlloc, ServiceCallsAllocateNothingInPolyport) {
  ASSERT_TRUE(build("services_app.xml")) << problems();
  // The test's own in-process ends: a caller of the LCM server, a provider for the LCM client
  // that adds on the thread that took the request.
  auto* server_port = dynamic_cast<ProvidedServicePort*>(engine.find_port("server.calc"));
  auto* client_port = dynamic_cast<RequiredServicePort*>(engine.find_port("client.calc"));
  ASSERT_TRUE(server_port != nullptr && client_port != nullptr);
  Component test("test", "inproc");
  RequiredServicePort caller(test, "calc", "peer::Calc", server_port->operations(), 4);
  ASSERT_TRUE(caller.connect(*server_port));
  ProvidedServicePort adder(test, "calc", "peer::Calc", client_port->operations());
  adder.set_handler(
      0,
      [](const std::byte* request, std::uint32_t, std::byte* reply, std::uint32_t& reply_size) {
        Pair pair;
        std::memcpy(&pair, request, sizeof pair);
        const double sum = pair.a + pair.b;
        std::memcpy(reply, &sum, sizeof sum);
        reply_size = sizeof sum;
        return Status::ok;
      },
      ProvidedServicePort::Dispatch::caller_thread);
  adder.set_accepting(true);
  ASSERT_TRUE(client_port->connect(adder));

  std::vector<std::string> warnings;
  g_wrap_subscriptions = true;
  ASSERT_TRUE(engine.start(warnings)) << problems();
  g_wrap_subscriptions = false;
  CalcServer server;
  ASSERT_TRUE(server.ok()) << "the test's LCM server did not start";

  lcm_t* lcm = lcm_create(nullptr);
  ASSERT_NE(lcm, nullptr);
  ClientReplies replies;
  peer_add_reply_t_subscribe(lcm, "ALLOC_CLIENT/add/reply", on_client_reply, &replies);
  const int fd = lcm_get_fileno(lcm);
  ASSERT_GE(fd, 0);

  // In-process -> LCM server: the calling thread counts from the call to its return.
  auto call_server = [&](int count) {
    for (int i = 0; i < count; ++i) {
      const Pair pair{static_cast<double>(i), 0.5};
      double sum = 0;
      Status status;
      {
        Scope polyport(true);
        status = caller.query("add", &pair, sizeof pair, &sum, sizeof sum, Nanos{2'000'000'000});
      }
      ASSERT_EQ(status, Status::ok) << "call " << i;
      ASSERT_EQ(sum, i + 0.5) << "call " << i;
    }
  };
  // LCM client -> in-process: one request at a time, its reply waited for.
  auto call_client = [&](int count) {
    for (int i = 0; i < count; ++i) {
      peer_add_request_t request{};
      request.header.client_id = 7;
      request.header.sequence = ++replies.sequence;
      request.request.a = i;
      request.request.b = 0.5;
      replies.got = false;
      ASSERT_EQ(peer_add_request_t_publish(lcm, "ALLOC_CLIENT/add/request", &request), 0);
      for (int spins = 0; !replies.got && spins < 200; ++spins) {
        pollfd p{fd, POLLIN, 0};
        if (poll(&p, 1, 10) > 0) lcm_handle(lcm);
      }
      ASSERT_TRUE(replies.got) << "request " << i << " got no reply";
      ASSERT_EQ(replies.sum, i + 0.5) << "request " << i;
    }
  };
  call_server(50);  // warm-up: first-use allocations
  call_client(50);

  constexpr int kCalls = 300;
  const std::uint64_t handled_before = g_handler_calls.load();
  const std::uint64_t polyport_before = g_polyport_allocations.load();
  call_server(kCalls);
  call_client(kCalls);
  const std::uint64_t polyport = g_polyport_allocations.load() - polyport_before;
  // Every reply to polyport's requests and every request to polyport went through a counted handler.
  EXPECT_EQ(g_handler_calls.load() - handled_before, static_cast<std::uint64_t>(2 * kCalls));
  EXPECT_EQ(polyport, 0u) << "polyport allocated on a service call path";
  std::printf("allocations per service call in polyport: %.3f\n", static_cast<double>(polyport) / (2 * kCalls));
  lcm_destroy(lcm);

  engine.stop();
  EXPECT_EQ(caller.counters().ok.load(), static_cast<std::uint64_t>(50 + kCalls));
}

}  // namespace
}  // namespace polyport::test
