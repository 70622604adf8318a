// Push newest and push timed allocate nothing per sample after start-up: the server keeping
// the latest value, subscribers taking every Nth cycle, a stopped server's writes and its
// subscribers' reads, counted over the whole process.
#include <gtest/gtest.h>

#include "alloc_counter.hpp"
#include "polyport/runtime/component.hpp"
#include "polyport/runtime/connection.hpp"
#include "polyport/runtime/push_server.hpp"

namespace polyport {
namespace {

using test::allocations;

struct Sample {
  double values[8];
};

class NullSink final : public SampleSink {
 public:
  Status on_sample(const std::byte*, const SampleMeta&) noexcept override { return Status::ok; }
};

void run(PushPattern pattern, std::uint32_t every, std::uint32_t writes_per_cycle) {
  Component a{"A", "inproc"};
  Component b{"B", "inproc"};
  auto& out = a.add_port<DataOutPort>("out", PortKind::data, nullptr, sizeof(Sample));
  out.set_push(std::make_unique<PushServer>(out, pattern, Nanos{10'000'000}, writes_per_cycle));
  auto& pulled = b.add_port<DataInPort>("pulled", PortKind::data, nullptr, sizeof(Sample), QueuePolicy::circular, 4);
  auto& pushed = b.add_port<DataInPort>("pushed", PortKind::data, nullptr, sizeof(Sample), QueuePolicy::data, 1);
  NullSink sink;
  pushed.set_sink(&sink);
  Connection c1(out, pulled, QueuePolicy::circular, 4), c2(out, pushed, QueuePolicy::data, 1);
  if (every != 0) c1.set_subscription(every);
  for (Connection* c : {&c1, &c2}) {
    c->target().connections().add(*c);
    out.connections().add(*c);
  }
  Sample s{};
  Sample got{};
  const std::uint64_t before = allocations();
  for (int i = 0; i < 10000; ++i) {
    s.values[0] = i;
    ASSERT_EQ(out.write(&s, sizeof s), Status::ok);
    (void)pulled.read(&got, sizeof got);
  }
  out.push()->stop();
  for (int i = 0; i < 100; ++i) {
    EXPECT_EQ(out.write(&s, sizeof s), Status::not_active);
    (void)pulled.read(&got, sizeof got);
  }
  EXPECT_EQ(pulled.read(&got, sizeof got), Status::not_active);
  EXPECT_EQ(allocations() - before, 0u);
  EXPECT_GT(c1.counters().delivered.load(), 0u);
}

TEST(PushAllocations, PushNewestAllocatesNothingPerSample) { run(PushPattern::newest, 0, 1); }

TEST(PushAllocations, PushTimedAllocatesNothingPerSample) { run(PushPattern::timed, 3, 1); }

TEST(PushAllocations, AThinnedInProcessPushTimedServerAllocatesNothingPerSample) { run(PushPattern::timed, 2, 3); }

}  // namespace
}  // namespace polyport
