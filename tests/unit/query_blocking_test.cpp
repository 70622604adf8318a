// SmartSoft's query client on a required service port: request, receive without waiting
// (no_data: not yet), receive_wait, query without a timeout, discard, and the blocking mode
// that, switched off, ends every wait at once with cancelled and lets no new call wait.
#include <gtest/gtest.h>

#include <sys/syscall.h>
#include <unistd.h>

#include <atomic>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "polyport/runtime/component.hpp"
#include "polyport/runtime/component_api.hpp"
#include "polyport/runtime/service.hpp"
#include "polyport/types/types.hpp"
#include "../support/eventually.hpp"

namespace polyport {
namespace {

using test::eventually;

struct Pair {
  std::int32_t a, b;
};
struct Sum {
  std::int32_t value;
};

// A thread's state letter in /proc ('S': asleep). A caller that has said it is about to
// wait and then sleeps is in its wait: nothing else on its way sleeps.
char thread_state(pid_t tid) {
  std::ifstream in("/proc/self/task/" + std::to_string(tid) + "/stat");
  std::string stat((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const auto close = stat.rfind(')');
  return close == std::string::npos || close + 2 >= stat.size() ? '?' : stat[close + 2];
}

// A caller on a thread of its own: runs `call` and keeps its status.
class Waiter {
 public:
  template <class F>
  explicit Waiter(F call)
      : thread_([this, call]() mutable {
          tid_.store(static_cast<pid_t>(::syscall(SYS_gettid)));
          status_.store(call());
          done_.store(true);
        }) {}
  ~Waiter() {
    if (thread_.joinable()) thread_.join();
  }
  // Until the thread sleeps in its wait (or has already ended).
  bool waiting() const {
    return eventually([&] { return done_.load() || (tid_.load() != 0 && thread_state(tid_.load()) == 'S'); });
  }
  Status join() {
    thread_.join();
    return status_.load();
  }
  bool done() const { return done_.load(); }

 private:
  std::atomic<pid_t> tid_{0};
  std::atomic<Status> status_{Status::ok};
  std::atomic<bool> done_{false};
  std::thread thread_;
};

class QueryClient : public ::testing::Test {
 protected:
  void SetUp() override {
    Diagnostics d;
    ASSERT_TRUE(types.add_idl_text("module t { struct Pair { long a; long b; }; struct Sum { long value; }; };", "t.idl", d));
    const Type* pair = types.find("t::Pair");
    const Type* sum = types.find("t::Sum");
    ASSERT_TRUE(pair && sum);
    std::vector<OperationInfo> ops{{"add", pair, sum, false}};
    provided = &server.add_port<ProvidedServicePort>("calc", "Calc", ops, 8);
    required = &client.add_port<RequiredServicePort>("calc", "Calc", ops, 3);
    provided->set_accepting(true);
    // Served on the provider's own thread: a call waits in its queue until serve_queued(),
    // which the test calls when it wants the reply to come.
    provided->set_handler(0, [](const std::byte* req, std::uint32_t, std::byte* rep, std::uint32_t& size) {
      Pair p;
      std::memcpy(&p, req, sizeof p);
      const Sum s{p.a + p.b};
      std::memcpy(rep, &s, sizeof s);
      size = sizeof s;
      return Status::ok;
    }, ProvidedServicePort::Dispatch::own_thread);
    ASSERT_TRUE(required->connect(*provided));
  }

  CallHandle request(std::int32_t a) {
    const Pair p{a, 1};
    return required->request("add", &p, sizeof p);
  }

  TypeRegistry types;
  Component server{"Server", "inproc"};
  Component client{"Client", "inproc"};
  ProvidedServicePort* provided = nullptr;
  RequiredServicePort* required = nullptr;
};

TEST_F(QueryClient, ReceiveWithoutWaitingSaysNotYetThenTakesTheReply) {
  CallHandle handle = request(41);
  ASSERT_TRUE(handle);
  Sum s{};
  EXPECT_EQ(required->try_receive(handle, &s, sizeof s), Status::no_data);
  EXPECT_EQ(required->try_receive(handle, &s, sizeof s), Status::no_data);
  EXPECT_TRUE(handle) << "a call not answered yet stays in flight";
  EXPECT_EQ(provided->serve_queued(), 1u);
  std::uint32_t size = 0;
  ASSERT_EQ(required->try_receive(handle, &s, sizeof s, &size), Status::ok);
  EXPECT_EQ(s.value, 42);
  EXPECT_EQ(size, sizeof s);
  EXPECT_FALSE(handle) << "the reply taken ends the call";
  EXPECT_EQ(required->try_receive(handle, &s, sizeof s), Status::no_data) << "nothing more to receive";
  // "Not yet" is no outcome: one call, one ok, nothing else counted.
  EXPECT_EQ(required->counters().calls.load(), 1u);
  EXPECT_EQ(required->counters().ok.load(), 1u);
  EXPECT_EQ(required->counters().timeouts.load(), 0u);
  EXPECT_EQ(required->counters().cancelled.load(), 0u);
  EXPECT_EQ(required->latency().summarize().count, 1u);
}

TEST_F(QueryClient, ReceiveWaitWaitsUntilTheReplyComes) {
  CallHandle handle = request(1);
  ASSERT_TRUE(handle);
  Sum s{};
  Waiter waiter([&] { return required->receive_wait(handle, &s, sizeof s); });
  ASSERT_TRUE(waiter.waiting());
  EXPECT_FALSE(waiter.done());
  EXPECT_EQ(provided->serve_queued(), 1u);
  EXPECT_EQ(waiter.join(), Status::ok);
  EXPECT_EQ(s.value, 2);
  EXPECT_EQ(required->counters().ok.load(), 1u);
}

TEST_F(QueryClient, BlockingOffReleasesAWaitingReceiveWaitWithCancelledAndTheCallStaysInFlight) {
  CallHandle handle = request(9);
  ASSERT_TRUE(handle);
  Sum s{};
  Waiter waiter([&] { return required->receive_wait(handle, &s, sizeof s); });
  ASSERT_TRUE(waiter.waiting());
  EXPECT_FALSE(waiter.done()) << "nobody answers: receive_wait has no timeout";
  required->set_blocking(false);
  EXPECT_EQ(waiter.join(), Status::cancelled);
  EXPECT_EQ(required->counters().cancelled.load(), 1u);
  EXPECT_EQ(required->counters().timeouts.load(), 0u);
  // Still in flight: the reply that comes later is taken whatever the mode.
  ASSERT_TRUE(handle);
  EXPECT_EQ(provided->serve_queued(), 1u);
  ASSERT_EQ(required->try_receive(handle, &s, sizeof s), Status::ok);
  EXPECT_EQ(s.value, 10);
}

TEST_F(QueryClient, BlockingOffReleasesAQueryWithoutTimeoutAndItsSlotComesBack) {
  Sum s{};
  const Pair p{1, 2};
  Waiter waiter([&] { return required->query("add", &p, sizeof p, &s, sizeof s, kWaitForever); });
  ASSERT_TRUE(waiter.waiting());
  EXPECT_FALSE(waiter.done());
  required->set_blocking(false);
  EXPECT_EQ(waiter.join(), Status::cancelled);
  // The query gave its call up; the provider's late completion frees the slot, so all three
  // slots serve again.
  EXPECT_EQ(provided->serve_queued(), 1u);
  required->set_blocking(true);
  std::vector<CallHandle> handles;
  for (int i = 0; i < 3; ++i) handles.push_back(request(i));
  for (const CallHandle& h : handles) EXPECT_TRUE(h) << to_string(h.status);
  EXPECT_EQ(provided->serve_queued(), 3u);
  for (int i = 0; i < 3; ++i) {
    ASSERT_EQ(required->receive_wait(handles[static_cast<std::size_t>(i)], &s, sizeof s), Status::ok);
    EXPECT_EQ(s.value, i + 1);
  }
}

TEST_F(QueryClient, WhileBlockingIsOffNoCallWaitsAndAQueryIsNotMade) {
  required->set_blocking(false);
  EXPECT_FALSE(required->blocking());
  Sum s{};
  const Pair p{1, 2};
  EXPECT_EQ(required->query("add", &p, sizeof p, &s, sizeof s, kWaitForever), Status::cancelled);
  EXPECT_EQ(required->query("add", &p, sizeof p, &s, sizeof s, Nanos{5'000'000'000}), Status::cancelled);
  EXPECT_EQ(provided->calls(), 0u) << "a query that may not wait never reaches the provider";
  // request() does not wait, so it is made; every receive that would wait returns at once.
  CallHandle handle = request(5);
  ASSERT_TRUE(handle);
  EXPECT_EQ(required->receive(handle, &s, sizeof s, Nanos{5'000'000'000}), Status::cancelled);
  EXPECT_EQ(required->receive_wait(handle, &s, sizeof s), Status::cancelled);
  EXPECT_EQ(required->try_receive(handle, &s, sizeof s), Status::no_data);
  EXPECT_EQ(required->counters().cancelled.load(), 4u);
  required->set_blocking(true);
  EXPECT_EQ(provided->serve_queued(), 1u);
  ASSERT_EQ(required->receive_wait(handle, &s, sizeof s), Status::ok);
  EXPECT_EQ(s.value, 6);
}

TEST_F(QueryClient, DiscardGivesTheCallUpAndItsSlotComesBack) {
  std::vector<CallHandle> handles;
  for (int i = 0; i < 3; ++i) handles.push_back(request(i));
  EXPECT_EQ(request(9).status, Status::too_many_calls) << "three slots";
  for (CallHandle& h : handles) required->cancel(h);
  Sum s{};
  EXPECT_EQ(required->try_receive(handles[0], &s, sizeof s), Status::cancelled);
  EXPECT_EQ(required->receive_wait(handles[0], &s, sizeof s), Status::cancelled);
  // The provider completes the abandoned calls; that frees their slots.
  EXPECT_EQ(provided->serve_queued(), 3u);
  for (int i = 0; i < 3; ++i) EXPECT_TRUE(request(i)) << "slot " << i;
}

TEST_F(QueryClient, AProviderThatStopsEndsAReceiveWait) {
  CallHandle handle = request(1);
  Sum s{};
  Waiter waiter([&] { return required->receive_wait(handle, &s, sizeof s); });
  ASSERT_TRUE(waiter.waiting());
  provided->set_accepting(false);
  EXPECT_EQ(provided->cancel_queued(Status::not_active), 1u);  // as the provider's stop does
  EXPECT_EQ(waiter.join(), Status::not_active);
}

// Waits that start at any moment around the switch, before or after it: each ends with
// cancelled (a lost wake-up would hang the case until ctest's timeout).
TEST_F(QueryClient, EveryWaiterEndsWhateverMomentBlockingGoesOff) {
  for (int round = 0; round < 300; ++round) {
    required->set_blocking(true);
    CallHandle a = request(round);
    CallHandle b = request(round);
    ASSERT_TRUE(a && b);
    Sum sa{}, sb{};
    Waiter first([&] { return required->receive_wait(a, &sa, sizeof sa); });
    Waiter second([&] { return required->receive(b, &sb, sizeof sb, kWaitForever); });
    if (round % 3 == 0) std::this_thread::yield();
    required->set_blocking(false);
    EXPECT_EQ(first.join(), Status::cancelled);
    EXPECT_EQ(second.join(), Status::cancelled);
    required->cancel(a);
    required->cancel(b);
    provided->serve_queued();
  }
  EXPECT_EQ(required->counters().cancelled.load(), 600u);
}

TEST_F(QueryClient, ReceiveWithATimeoutStillTimesOut) {
  CallHandle handle = request(1);
  Sum s{};
  EXPECT_EQ(required->receive(handle, &s, sizeof s, Nanos{10'000'000}), Status::timeout);
  EXPECT_EQ(required->counters().timeouts.load(), 1u);
  EXPECT_EQ(provided->serve_queued(), 1u);
  EXPECT_EQ(required->receive(handle, &s, sizeof s, Nanos{10'000'000}), Status::ok);
}

// The component's switch reaches each of its required service ports.
class TwoClients final : public ComponentBase {
 public:
  RequiredService first{*this, "first"};
  RequiredService second{*this, "second"};
};

TEST_F(QueryClient, AComponentsBlockingModeIsThatOfItsRequiredPorts) {
  TwoClients component;
  auto& other = client.add_port<RequiredServicePort>("other", "Calc", required->operations(), 1);
  for (PortDeclaration& declaration : component.port_declarations()) {
    *declaration.bound = declaration.name == "first" ? static_cast<Port*>(required) : &other;
  }
  EXPECT_TRUE(component.blocking());
  CallHandle handle = request(3);
  Sum s{};
  Waiter waiter([&] { return component.first.receive_wait(handle, s); });
  ASSERT_TRUE(waiter.waiting());
  component.set_blocking(false);
  EXPECT_EQ(waiter.join(), Status::cancelled);
  EXPECT_FALSE(component.blocking());
  EXPECT_FALSE(required->blocking());
  EXPECT_FALSE(other.blocking());
  const Pair p{1, 1};
  EXPECT_EQ(component.first.query("add", p, s), Status::cancelled);
  component.set_blocking(true);
  EXPECT_TRUE(required->blocking());
  EXPECT_TRUE(other.blocking());
  // The engine-wide switch sets the ports' modes: the component sees it too.
  other.set_blocking(false);
  EXPECT_FALSE(component.blocking());
  other.set_blocking(true);
  EXPECT_TRUE(component.blocking());
  EXPECT_EQ(component.first.receive(handle, s), Status::no_data);
  EXPECT_EQ(provided->serve_queued(), 1u);
  EXPECT_EQ(component.first.receive(handle, s), Status::ok);
  EXPECT_EQ(s.value, 4);
}

}  // namespace
}  // namespace polyport
