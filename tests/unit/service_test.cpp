// Service ports: synchronous, asynchronous and one-way calls, timeouts, unconnected ports,
// the cap on calls in flight and a provider that is full or stopped.
#include <gtest/gtest.h>

#include <atomic>
#include <cstdint>
#include <climits>
#include <cstring>
#include <thread>

#include "polyport/runtime/component.hpp"
#include "polyport/runtime/service.hpp"
#include "polyport/types/types.hpp"

namespace polyport {
namespace {

struct Pair {
  std::int32_t a, b;
};
struct Sum {
  std::int32_t value;
};

constexpr Nanos kShort{20'000'000};   // a reply that cannot come: the call times out
constexpr Nanos kLong{5'000'000'000};  // a reply that will come

class Services : public ::testing::Test {
 protected:
  void SetUp() override {
    Diagnostics d;
    ASSERT_TRUE(types.add_idl_text("module t { struct Pair { long a; long b; }; struct Sum { long value; }; };", "t.idl", d));
    const Type* pair = types.find("t::Pair");
    const Type* sum = types.find("t::Sum");
    ASSERT_TRUE(pair && sum);
    std::vector<OperationInfo> ops{{"add", pair, sum, false}, {"note", pair, nullptr, true}};
    provided = &server.add_port<ProvidedServicePort>("calc", "Calc", ops, 2);
    required = &client.add_port<RequiredServicePort>("calc", "Calc", ops, 3);
    provided->set_accepting(true);  // as its component's start does
  }

  void provide(ProvidedServicePort::Dispatch dispatch) {
    provided->set_handler(0, [](const std::byte* req, std::uint32_t, std::byte* rep, std::uint32_t& size) {
      Pair p;
      std::memcpy(&p, req, sizeof p);
      Sum s{p.a + p.b};
      std::memcpy(rep, &s, sizeof s);
      size = sizeof s;
      return Status::ok;
    }, dispatch);
    provided->set_handler(1, [this](const std::byte* req, std::uint32_t, std::byte*, std::uint32_t& size) {
      Pair p;
      std::memcpy(&p, req, sizeof p);
      notes.fetch_add(p.a);
      size = 0;
      return Status::ok;
    }, dispatch);
  }

  // Serves queued calls on another thread, as the provider's execution context would.
  void serve_in_background() {
    server_thread = std::thread([this] {
      while (!stop.load()) {
        provided->serve_queued();
        std::this_thread::yield();
      }
    });
  }
  void TearDown() override {
    stop.store(true);
    if (server_thread.joinable()) server_thread.join();
  }

  TypeRegistry types;
  Component server{"Server", "inproc"};
  Component client{"Client", "inproc"};
  ProvidedServicePort* provided = nullptr;
  RequiredServicePort* required = nullptr;
  std::atomic<bool> stop{false};
  std::atomic<int> notes{0};
  std::thread server_thread;
};

TEST_F(Services, UnconnectedRequiredPortSaysSoAtOnce) {
  Pair p{1, 2};
  Sum s{};
  EXPECT_EQ(required->query("add", &p, sizeof p, &s, sizeof s, kLong), Status::not_connected);
  EXPECT_EQ(required->send("note", &p, sizeof p), Status::not_connected);
  EXPECT_FALSE(required->request("add", &p, sizeof p));
  EXPECT_EQ(required->counters().not_connected.load(), 3u);
}

TEST_F(Services, SynchronousCallOnTheCallersThread) {
  provide(ProvidedServicePort::Dispatch::caller_thread);
  ASSERT_TRUE(required->connect(*provided));
  Pair p{40, 2};
  Sum s{};
  ASSERT_EQ(required->query("add", &p, sizeof p, &s, sizeof s, kLong), Status::ok);
  EXPECT_EQ(s.value, 42);
  EXPECT_EQ(required->counters().ok.load(), 1u);
  EXPECT_EQ(required->latency().summarize().count, 1u);
}

TEST_F(Services, SynchronousCallServedByTheProvidersThread) {
  provide(ProvidedServicePort::Dispatch::own_thread);
  ASSERT_TRUE(required->connect(*provided));
  serve_in_background();
  for (int i = 0; i < 50; ++i) {
    Pair p{i, 1};
    Sum s{};
    ASSERT_EQ(required->query("add", &p, sizeof p, &s, sizeof s, kLong), Status::ok);
    EXPECT_EQ(s.value, i + 1);
  }
}

TEST_F(Services, CallTimesOutWhenNobodyServesAndTheSlotComesBack) {
  provide(ProvidedServicePort::Dispatch::own_thread);
  ASSERT_TRUE(required->connect(*provided));
  Pair p{1, 1};
  Sum s{};
  EXPECT_EQ(required->query("add", &p, sizeof p, &s, sizeof s, kShort), Status::timeout);
  EXPECT_EQ(required->counters().timeouts.load(), 1u);
  // The provider runs the abandoned call late; that frees its slot.
  EXPECT_EQ(provided->serve_queued(), 1u);
  serve_in_background();
  ASSERT_EQ(required->query("add", &p, sizeof p, &s, sizeof s, kLong), Status::ok);
  EXPECT_EQ(s.value, 2);
}

TEST_F(Services, CapOnCallsInFlight) {
  provide(ProvidedServicePort::Dispatch::own_thread);
  ASSERT_TRUE(required->connect(*provided));
  Pair p{1, 1};
  CallHandle a = required->request("add", &p, sizeof p);
  CallHandle b = required->request("add", &p, sizeof p);
  ASSERT_TRUE(a && b);
  // Provider queue depth is 2: a third call is refused by the provider...
  CallHandle c = required->request("add", &p, sizeof p);
  ASSERT_TRUE(c);
  Sum s{};
  EXPECT_EQ(required->receive(c, &s, sizeof s, kLong), Status::queue_full);
  // ...and with three slots, two in flight plus one more leaves none for a fourth.
  CallHandle d = required->request("add", &p, sizeof p);
  CallHandle e = required->request("add", &p, sizeof p);
  EXPECT_TRUE(d);  // refused by the full provider queue, but it holds a slot until received
  EXPECT_FALSE(e);
  EXPECT_EQ(e.status, Status::too_many_calls);
  EXPECT_EQ(required->receive(d, &s, sizeof s, kLong), Status::queue_full);
  EXPECT_EQ(provided->serve_queued(), 2u);
  EXPECT_EQ(required->receive(a, &s, sizeof s, kLong), Status::ok);
  EXPECT_EQ(required->receive(b, &s, sizeof s, kLong), Status::ok);
  EXPECT_EQ(s.value, 2);
}

TEST_F(Services, AsynchronousRequestAndReceive) {
  provide(ProvidedServicePort::Dispatch::own_thread);
  ASSERT_TRUE(required->connect(*provided));
  Pair p{20, 22};
  CallHandle h = required->request("add", &p, sizeof p);
  ASSERT_TRUE(h);
  Sum s{};
  EXPECT_EQ(required->receive(h, &s, sizeof s, kShort), Status::timeout);  // not served yet
  ASSERT_TRUE(h);  // still in flight: receive may be called again
  serve_in_background();
  ASSERT_EQ(required->receive(h, &s, sizeof s, kLong), Status::ok);
  EXPECT_EQ(s.value, 42);
  EXPECT_FALSE(h);
}

TEST_F(Services, OneWaySendDoesNotWait) {
  provide(ProvidedServicePort::Dispatch::own_thread);
  ASSERT_TRUE(required->connect(*provided));
  Pair p{5, 0};
  for (int i = 0; i < 2; ++i) EXPECT_EQ(required->send("note", &p, sizeof p), Status::ok);
  EXPECT_EQ(notes.load(), 0);
  EXPECT_EQ(provided->serve_queued(), 2u);
  EXPECT_EQ(notes.load(), 10);
  // The slots came back: three more sends fit again.
  for (int i = 0; i < 2; ++i) EXPECT_EQ(required->send("note", &p, sizeof p), Status::ok);
}

TEST_F(Services, WrongOperationSizeOrStoppedProvider) {
  provide(ProvidedServicePort::Dispatch::caller_thread);
  ASSERT_TRUE(required->connect(*provided));
  Pair p{1, 2};
  Sum s{};
  EXPECT_EQ(required->query("mul", &p, sizeof p, &s, sizeof s, kLong), Status::unknown_operation);
  EXPECT_EQ(required->query("add", &p, 3, &s, sizeof s, kLong), Status::bad_size);
  provided->set_accepting(false);
  EXPECT_EQ(required->query("add", &p, sizeof p, &s, sizeof s, kLong), Status::not_active);
  EXPECT_EQ(required->send("note", &p, sizeof p), Status::not_active);  // refused, and said so
}

TEST_F(Services, CallsQueuedBeforeTheProviderStopsAreRefusedNotRun) {
  provide(ProvidedServicePort::Dispatch::own_thread);
  ASSERT_TRUE(required->connect(*provided));
  Pair p{1, 1};
  CallHandle h = required->request("add", &p, sizeof p);
  ASSERT_TRUE(h);
  provided->set_accepting(false);  // the provider stops with the call still queued
  EXPECT_EQ(provided->serve_queued(), 1u);
  Sum s{};
  EXPECT_EQ(required->receive(h, &s, sizeof s, kLong), Status::not_active);
}

TEST_F(Services, AVeryLongTimeoutDoesNotOverflow) {
  provide(ProvidedServicePort::Dispatch::own_thread);
  ASSERT_TRUE(required->connect(*provided));
  serve_in_background();
  Pair p{2, 3};
  Sum s{};
  EXPECT_EQ(required->query("add", &p, sizeof p, &s, sizeof s, Nanos{INT64_MAX}), Status::ok);
  EXPECT_EQ(s.value, 5);
}

TEST_F(Services, ConnectFailsWhenTheProviderLacksAnOperation) {
  Component other{"Other", "inproc"};
  auto& partial = other.add_port<ProvidedServicePort>(
      "calc", "Calc", std::vector<OperationInfo>{{"add", types.find("t::Pair"), types.find("t::Sum"), false}});
  EXPECT_FALSE(required->connect(partial));
  EXPECT_FALSE(required->connected());
}

TEST_F(Services, HandlerWithoutRegistrationIsAnUnknownOperation) {
  ASSERT_TRUE(required->connect(*provided));  // no handlers set
  Pair p{1, 2};
  Sum s{};
  EXPECT_EQ(required->query("add", &p, sizeof p, &s, sizeof s, kLong), Status::unknown_operation);
}

}  // namespace
}  // namespace polyport
