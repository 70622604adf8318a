// The in-process forwarding path allocates nothing after start-up: counted over every
// thread of the process, first for each connection policy and push mode, then for the
// whole wheelchair application running on its execution context.
#include <gtest/gtest.h>

#include <chrono>
#include <thread>

#include "alloc_counter.hpp"
#include "inproc_model.hpp"
#include "polyport/runtime/component.hpp"
#include "polyport/runtime/connection.hpp"
#include "polyport/runtime/engine.hpp"
#include "polyport/types/types.hpp"
#include "../support/eventually.hpp"

namespace polyport {
namespace {

using test::eventually;

using test::allocations;

struct Sample {
  double values[8];
};

class NullSink final : public SampleSink {
 public:
  Status on_sample(const std::byte*, const SampleMeta&) noexcept override { return Status::ok; }
};

TEST(ForwardingAllocations, EveryPolicyAndPushModeAllocateNothingPerSample) {
  Component a{"A", "inproc"};
  Component b{"B", "inproc"};
  auto& out = a.add_port<DataOutPort>("out", PortKind::data, nullptr, sizeof(Sample));
  auto& in_data = b.add_port<DataInPort>("d", PortKind::data, nullptr, sizeof(Sample), QueuePolicy::data, 1);
  auto& in_buffer = b.add_port<DataInPort>("b", PortKind::data, nullptr, sizeof(Sample), QueuePolicy::buffer, 4);
  auto& in_circular = b.add_port<DataInPort>("c", PortKind::data, nullptr, sizeof(Sample), QueuePolicy::circular, 4);
  auto& in_push = b.add_port<DataInPort>("p", PortKind::data, nullptr, sizeof(Sample), QueuePolicy::data, 1);
  NullSink sink;
  in_push.set_sink(&sink);
  Connection c1(out, in_data, QueuePolicy::data, 1), c2(out, in_buffer, QueuePolicy::buffer, 4),
      c3(out, in_circular, QueuePolicy::circular, 4), c4(out, in_push, QueuePolicy::data, 1);
  for (Connection* c : {&c1, &c2, &c3, &c4}) {
    out.connections().add(*c);
    c->target().connections().add(*c);
  }
  Sample s{};
  const std::uint64_t before = allocations();
  for (int i = 0; i < 10'000; ++i) {
    s.values[0] = i;
    ASSERT_EQ(out.write(&s, sizeof s), Status::ok);
    if (i % 3 == 0) {  // a slower reader: queues fill, drop and wrap
      in_data.read(&s, sizeof s);
      in_buffer.read(&s, sizeof s);
      in_circular.read(&s, sizeof s);
    }
  }
  EXPECT_EQ(allocations() - before, 0u);
  EXPECT_EQ(c4.counters().delivered.load(), 10'000u);
  EXPECT_GT(c2.counters().dropped_queue_full.load(), 0u);
  EXPECT_GT(c3.counters().dropped_oldest.load(), 0u);
}

TEST(ForwardingAllocations, RunningWheelchairApplicationAllocatesNothingAfterStartUp) {
  TypeRegistry types;
  ModelRegistry models;
  models.add(std::make_unique<inproc::InprocModel>());
  Diagnostics diagnostics;
  auto profile = load_application_profile(POLYPORT_SOURCE_DIR "/profiles/wheelchair_inproc.xml", types,
                                          LoadOptions{{POLYPORT_PLUGIN_DIR}}, diagnostics);
  ASSERT_TRUE(profile) << (diagnostics.all().empty() ? "" : diagnostics.all().front().to_string());
  Engine engine(models, types);
  ASSERT_TRUE(engine.build(*profile, diagnostics));
  std::vector<std::string> warnings;
  ASSERT_TRUE(engine.start(warnings));
  const ExecutionContext& ec = *engine.executors().contexts().front();
  ASSERT_TRUE(eventually([&] { return ec.cycles() >= 20; }));  // start-up is over

  const std::uint64_t before = allocations();
  const std::uint64_t cycles = ec.cycles();
  ASSERT_TRUE(eventually([&] { return ec.cycles() >= cycles + 100; }));
  const std::uint64_t during = allocations() - before;
  engine.stop();
  EXPECT_EQ(during, 0u) << "allocations during 100 cycles of the running application";
  std::uint64_t received = 0;
  for (const auto& c : engine.connections()) received += c->counters().received.load();
  EXPECT_GE(received, 4u * 100u);
}

}  // namespace
}  // namespace polyport
