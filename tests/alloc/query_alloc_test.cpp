// The query client's calls allocate nothing after start-up, as the rest of the service path:
// request, receive without waiting, receive with a timeout, receive_wait (waiting for a
// provider on another thread), query without a timeout, discard, and the blocking mode
// switched off and on with calls ending in cancelled. Counted over every thread.
#include <gtest/gtest.h>

#include <atomic>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <thread>
#include <vector>

#include "alloc_counter.hpp"
#include "polyport/runtime/component.hpp"
#include "polyport/runtime/service.hpp"
#include "polyport/types/types.hpp"

namespace polyport {
namespace {

using test::allocations;

struct Pair {
  std::int32_t a, b;
};
struct Sum {
  std::int32_t value;
};

Status add(const std::byte* req, std::uint32_t, std::byte* rep, std::uint32_t& size) {
  Pair p;
  std::memcpy(&p, req, sizeof p);
  const Sum s{p.a + p.b};
  std::memcpy(rep, &s, sizeof s);
  size = sizeof s;
  return Status::ok;
}

TEST(QueryAllocations, EveryQueryClientCallAndTheBlockingModeAllocateNothing) {
  TypeRegistry types;
  Diagnostics d;
  ASSERT_TRUE(types.add_idl_text("module t { struct Pair { long a; long b; }; struct Sum { long value; }; };", "t.idl", d));
  const std::vector<OperationInfo> ops{{"add", types.find("t::Pair"), types.find("t::Sum"), false}};
  Component server{"Server", "inproc"};
  Component client{"Client", "inproc"};
  // `queued`: served by a thread of the provider's own; `held`: served only when this test
  // says (serve_queued here); `direct`: on the caller's thread.
  auto& queued = server.add_port<ProvidedServicePort>("queued", "Calc", ops, 8);
  auto& held = server.add_port<ProvidedServicePort>("held", "Calc", ops, 8);
  auto& direct = server.add_port<ProvidedServicePort>("direct", "Calc", ops, 8);
  queued.set_handler(0, add, ProvidedServicePort::Dispatch::own_thread);
  held.set_handler(0, add, ProvidedServicePort::Dispatch::own_thread);
  direct.set_handler(0, add, ProvidedServicePort::Dispatch::caller_thread);
  for (ProvidedServicePort* port : {&queued, &held, &direct}) port->set_accepting(true);
  auto& to_queued = client.add_port<RequiredServicePort>("a", "Calc", ops, 4);
  auto& to_held = client.add_port<RequiredServicePort>("b", "Calc", ops, 4);
  auto& to_direct = client.add_port<RequiredServicePort>("c", "Calc", ops, 4);
  ASSERT_TRUE(to_queued.connect(queued));
  ASSERT_TRUE(to_held.connect(held));
  ASSERT_TRUE(to_direct.connect(direct));
  std::atomic<bool> stop{false};
  std::thread server_thread([&] {
    while (!stop.load()) {
      queued.serve_queued();
      std::this_thread::yield();
    }
  });

  int failures = 0;
  const auto round = [&](std::int32_t i) {
    const Pair p{i, 1};
    Sum s{};
    // Not yet, then the reply (served here, between the two receives).
    CallHandle h = to_held.request("add", &p, sizeof p);
    failures += to_held.try_receive(h, &s, sizeof s) != Status::no_data;
    held.serve_queued();
    failures += to_held.try_receive(h, &s, sizeof s) != Status::ok || s.value != i + 1;
    // receive_wait waiting for the provider's thread.
    h = to_queued.request("add", &p, sizeof p);
    failures += to_queued.receive_wait(h, &s, sizeof s) != Status::ok || s.value != i + 1;
    h = to_queued.request("add", &p, sizeof p);
    failures += to_queued.receive(h, &s, sizeof s, Nanos{5'000'000'000}) != Status::ok;
    failures += to_queued.query("add", &p, sizeof p, &s, sizeof s, kWaitForever) != Status::ok;
    failures += to_direct.query("add", &p, sizeof p, &s, sizeof s, kWaitForever) != Status::ok;
    // Blocking off: a call in flight is not waited for, a query not made; discard.
    h = to_held.request("add", &p, sizeof p);
    to_held.set_blocking(false);
    failures += to_held.receive_wait(h, &s, sizeof s) != Status::cancelled;
    failures += to_held.query("add", &p, sizeof p, &s, sizeof s, kWaitForever) != Status::cancelled;
    to_held.cancel(h);
    held.serve_queued();  // completes the discarded call: its slot comes back
    to_held.set_blocking(true);
  };

  for (std::int32_t i = 0; i < 50; ++i) round(i);  // warm-up: first-use allocations (histogram pages)
  const std::uint64_t before = allocations();
  constexpr std::int32_t kRounds = 1000;
  for (std::int32_t i = 0; i < kRounds; ++i) round(i);
  const std::uint64_t during = allocations() - before;
  stop.store(true);
  server_thread.join();
  EXPECT_EQ(failures, 0);
  EXPECT_EQ(during, 0u) << "allocations in " << kRounds << " rounds of 8 calls";
  std::printf("allocations per query client call: %.3f\n", static_cast<double>(during) / (8.0 * kRounds));
  // Per round: three calls ok on `a`, one on `c`; on `b` one ok, then one discarded after a
  // cancelled receive_wait and one query not made (cancelled).
  constexpr std::uint64_t kAll = kRounds + 50;
  EXPECT_EQ(to_queued.counters().ok.load(), 3u * kAll);
  EXPECT_EQ(to_direct.counters().ok.load(), kAll);
  EXPECT_EQ(to_held.counters().ok.load(), kAll);
  EXPECT_EQ(to_held.counters().cancelled.load(), 2u * kAll);
  EXPECT_EQ(to_held.counters().timeouts.load() + to_queued.counters().timeouts.load(), 0u);
  EXPECT_EQ(to_queued.latency().summarize().count, 3u * kAll);
  EXPECT_EQ(to_held.latency().summarize().count, kAll);
}

}  // namespace
}  // namespace polyport
