// The connection policies' paths allocate nothing: a watchdog's samples replaced on the
// forwarding path (silent upstream, too old), the safe value taken by a pulling reader, and
// the timer thread's pass that trips, writes the safe value to a push-mode sink and sees the
// recovery; a rate limit's held samples and their release; a deadband's comparisons. Counted
// over every thread of the process.
#include <gtest/gtest.h>

#include <cstring>
#include <vector>

#include "alloc_counter.hpp"
#include "polyport/runtime/component.hpp"
#include "polyport/runtime/connection.hpp"
#include "polyport/runtime/connection_timer.hpp"
#include "polyport/runtime/watchdog.hpp"

namespace polyport {
namespace {

using test::allocations;

struct Sample {
  double values[8];
};

class CountingSink final : public SampleSink {
 public:
  Status on_sample(const std::byte*, const SampleMeta&) noexcept override {
    ++count;
    return Status::ok;
  }
  std::uint64_t count = 0;
};

constexpr Nanos kDeadline{1'000'000'000};

std::unique_ptr<ConnectionWatchdog> watchdog_for(const DataOutPort& source, const DataOutPort* upstream,
                                                 Nanos max_age = {}) {
  return std::make_unique<ConnectionWatchdog>(source, upstream, kDeadline, max_age,
                                              std::vector<std::byte>(sizeof(Sample)));
}

TEST(WatchdogAllocations, ReplacedSamplesSafeReadsAndTripsAllocateNothing) {
  Component a{"A", "inproc"};
  Component up{"Up", "inproc"};
  Component b{"B", "adaptor"};
  Component c{"C", "inproc"};
  auto& out = a.add_port<DataOutPort>("out", PortKind::data, nullptr, sizeof(Sample));
  auto& upstream = up.add_port<DataOutPort>("out", PortKind::data, nullptr, sizeof(Sample));
  auto& pushed = b.add_port<DataInPort>("in", PortKind::data, nullptr, sizeof(Sample), QueuePolicy::data, 1);
  auto& pulled = c.add_port<DataInPort>("in", PortKind::data, nullptr, sizeof(Sample), QueuePolicy::data, 1);
  CountingSink sink;
  pushed.set_sink(&sink);
  Connection push(out, pushed, QueuePolicy::data, 1);
  Connection pull(out, pulled, QueuePolicy::data, 1);
  push.set_watchdog(watchdog_for(out, &upstream, Nanos{50'000'000}));
  pull.set_watchdog(watchdog_for(out, nullptr));
  for (Connection* connection : {&push, &pull}) {
    out.connections().add(*connection);
    connection->target().connections().add(*connection);
  }
  ConnectionTimer monitor;
  monitor.add(push);
  monitor.add(pull);

  Sample s{};
  const std::uint64_t before = allocations();
  for (int i = 0; i < 1000; ++i) {
    s.values[0] = i;
    out.write(&s, sizeof s);                                   // push: upstream silent, replaced
    out.write(&s, sizeof s, mono_now() + Nanos{-60'000'000});  // push: too old, replaced
    pulled.read(&s, sizeof s);                                 // pull: passes
    const MonoTime now = mono_now();
    monitor.check(now + Nanos{2 * kDeadline.count});  // pull trips; push gets the safe value once
    monitor.check(now);                               // pull recovers
  }
  const std::uint64_t during = allocations() - before;
  EXPECT_EQ(during, 0u);
  const WatchdogCounters& pushing = push.watchdog()->counters();
  const WatchdogCounters& pulling = pull.watchdog()->counters();
  EXPECT_EQ(pushing.stale.load(), 1000u);
  EXPECT_EQ(pushing.safe_values.load(), 2001u);  // every sample, and the watchdog thread's once
  EXPECT_EQ(sink.count, 2001u);
  EXPECT_EQ(push.watchdog()->state(), WatchdogState::waiting);  // the upstream never spoke
  EXPECT_EQ(pulling.trips.load(), 999u);  // the first pass armed it
  EXPECT_EQ(pulling.recoveries.load(), 999u);
  EXPECT_EQ(pull.counters().read.load(), 1000u);
}

// A reader pulling while its source is silent gets the safe value without allocating.
TEST(WatchdogAllocations, SafeValueForAPullingReaderAllocatesNothing) {
  Component a{"A", "inproc"};
  Component c{"C", "inproc"};
  auto& out = a.add_port<DataOutPort>("out", PortKind::data, nullptr, sizeof(Sample));
  auto& in = c.add_port<DataInPort>("in", PortKind::data, nullptr, sizeof(Sample), QueuePolicy::data, 1);
  Connection connection(out, in, QueuePolicy::data, 1);
  connection.set_watchdog(watchdog_for(out, nullptr));  // never written: every read is safe
  out.connections().add(connection);
  in.connections().add(connection);
  Sample s{};
  const std::uint64_t before = allocations();
  for (int i = 0; i < 1000; ++i) in.read(&s, sizeof s);
  EXPECT_EQ(allocations() - before, 0u);
  EXPECT_EQ(connection.watchdog()->counters().safe_values.load(), 1u);  // new once, then old
}

TEST(PolicyAllocations, RateLimitAndDeadbandAllocateNothing) {
  Component a{"A", "inproc"};
  Component b{"B", "adaptor"};
  auto& out = a.add_port<DataOutPort>("out", PortKind::data, nullptr, sizeof(Sample));
  auto& in = b.add_port<DataInPort>("in", PortKind::data, nullptr, sizeof(Sample), QueuePolicy::data, 1);
  CountingSink sink;
  in.set_sink(&sink);
  Connection connection(out, in, QueuePolicy::data, 1);
  connection.set_rate_limit(Nanos{1'000'000'000});
  connection.set_deadbands({DeadbandField{0, TypeKind::float64, 0.5, "values[0]"}});
  out.connections().add(connection);
  in.connections().add(connection);
  ConnectionTimer timer;
  timer.add(connection);
  Sample s{};
  const std::uint64_t before = allocations();
  for (int i = 0; i < 1000; ++i) {
    s.values[0] = i;  // moves by 1: passes the deadband
    out.write(&s, sizeof s);
    s.values[0] = i + 0.25;  // within it: filtered
    out.write(&s, sizeof s);
    timer.check(connection.held_due());  // the held sample goes at its turn
  }
  EXPECT_EQ(allocations() - before, 0u);
  EXPECT_EQ(connection.counters().dropped_filtered.load(), 1000u);
  EXPECT_EQ(sink.count, 1000u);  // the first directly, then each held one at its turn
}

}  // namespace
}  // namespace polyport
