// Events with conditions allocate nothing per state sample once started: LCM state samples
// decoded into the connection's scratch and tested (then forwarded as they came, or not), a
// converting connection (XCDR1 -> LCM) whose single-shot activation is renewed, and a client
// thread that activates with parameters and deactivates meanwhile. Counted over every thread
// of the process.
#include <gtest/gtest.h>

#include <atomic>
#include <thread>
#include <vector>

#include "alloc_counter.hpp"
#include "polyport/codecs/codec.hpp"
#include "polyport/codecs/mapping.hpp"
#include "polyport/runtime/component.hpp"
#include "polyport/runtime/connection.hpp"
#include "polyport/runtime/event_condition.hpp"
#include "polyport/types/types.hpp"

namespace polyport {
namespace {

using test::allocations;

class CountingSink final : public SampleSink {
 public:
  Status on_sample(const std::byte*, const SampleMeta&) noexcept override {
    count.fetch_add(1, std::memory_order_relaxed);
    return Status::ok;
  }
  std::atomic<std::uint64_t> count{0};
};

ConditionSpec battery_below(double level, EventMode mode) {
  ConditionSpec spec;
  spec.mode = mode;
  spec.fields.push_back(ConditionFieldSpec{"battery_v", ConditionOp::lt, level, "level", {}, {}});
  spec.fields.push_back(ConditionFieldSpec{"heading_deg", ConditionOp::ge, 0.0, {}, {}, {}});
  return spec;
}

TEST(ConditionAllocations, TestedStatesAndActivationsAllocateNothing) {
  TypeRegistry types;
  Diagnostics d;
  types.add_type_file(POLYPORT_SOURCE_DIR "/benchmarks/types/bench.idl", d);
  types.add_type_file(POLYPORT_SOURCE_DIR "/benchmarks/types/bench.lcm", d);
  for (const auto& p : d.all()) ADD_FAILURE() << p.to_string();
  const Type* idl = types.find("bench::Wheel64");
  const Type* lcm = types.find("bench::wheel64_t");
  ASSERT_TRUE(idl && lcm);
  auto lcm_codec = make_codec(WireFormat::lcm, *lcm);
  auto cdr_codec = make_codec(WireFormat::xcdr1, *idl);
  ASSERT_TRUE(lcm_codec && cdr_codec);
  auto mapping = MappingProgram::compile(*idl, *lcm, MappingSpec{}, d);
  ASSERT_TRUE(mapping);

  Component server{"Server", "lcm"};
  Component dds_server{"DdsServer", "cyclonedds"};
  Component client{"Client", "lcm"};
  auto& state = server.add_port<DataOutPort>("state", PortKind::event, lcm, 512);
  auto& dds_state = dds_server.add_port<DataOutPort>("state", PortKind::event, idl, 512);
  auto& low = client.add_port<DataInPort>("low", PortKind::event, lcm, 512, QueuePolicy::buffer, 16);
  auto& once = client.add_port<DataInPort>("once", PortKind::event, lcm, 512, QueuePolicy::buffer, 16);
  state.set_wire_format(WireFormat::lcm, lcm_codec.value().get());
  dds_state.set_wire_format(WireFormat::xcdr1, cdr_codec.value().get());
  low.set_wire_format(WireFormat::lcm, lcm_codec.value().get());
  once.set_wire_format(WireFormat::lcm, lcm_codec.value().get());
  CountingSink low_sink;
  CountingSink once_sink;
  low.set_sink(&low_sink);
  once.set_sink(&once_sink);
  Connection passthrough(state, low, QueuePolicy::buffer, 16);
  Connection converting(dds_state, once, QueuePolicy::buffer, 16, mapping.get());
  auto continuous = make_event_condition(*lcm, battery_below(20.0, EventMode::continuous));
  auto single = make_event_condition(*idl, battery_below(20.0, EventMode::single));
  ASSERT_TRUE(continuous && single);
  passthrough.set_condition(std::move(continuous).value());
  converting.set_condition(std::move(single).value());
  for (Connection* c : {&passthrough, &converting}) {
    c->source().connections().add(*c);
    c->target().connections().add(*c);
  }

  // The states, encoded once: battery 0 .. 39 V, so half of them are below 20.
  std::vector<std::vector<std::byte>> lcm_states;
  std::vector<std::vector<std::byte>> cdr_states;
  const auto encode = [](const Codec& codec, const double (&values)[8]) {
    std::vector<std::byte> wire(codec.max_wire_size(sizeof values));
    const CodecResult encoded = codec.encode(reinterpret_cast<const std::byte*>(values), sizeof values, wire.data(),
                                             static_cast<std::uint32_t>(wire.size()));
    EXPECT_TRUE(encoded.ok());
    wire.resize(encoded.size);
    return wire;
  };
  for (int v = 0; v < 40; ++v) {
    const double values[8] = {1, 2, 3, 4, 5, 6, 7, static_cast<double>(v)};
    lcm_states.push_back(encode(*lcm_codec.value(), values));
    cdr_states.push_back(encode(*cdr_codec.value(), values));
  }

  std::atomic<bool> stop{false};
  std::atomic<std::uint64_t> activations{0};
  // The client: new levels for its continuous event, now and then off and on again.
  std::thread activator([&] {
    for (int k = 0; !stop.load(std::memory_order_relaxed); ++k) {
      const ConditionParameter level[] = {{"level", 10.0 + k % 20}};
      if (k % 7 == 0) {
        deactivate_conditions(low);
      } else if (activate_conditions(low, EventMode::continuous, level) == Status::ok) {
        activations.fetch_add(1, std::memory_order_relaxed);
      }
      std::this_thread::yield();
    }
  });
  // From the client's first activation on, its thread runs (its start and first call allocated)
  // and every buffer is made. Halfway through, the states wait for another activation, so that
  // activations certainly happen while states are tested, however the threads are scheduled.
  const auto next_activation = [&](std::uint64_t seen) {
    while (activations.load(std::memory_order_relaxed) <= seen) std::this_thread::yield();
  };
  next_activation(0);
  const std::uint64_t before = allocations();
  for (int i = 0; i < 20'000; ++i) {
    if (i == 10'000) next_activation(activations.load(std::memory_order_relaxed));
    const auto& s = lcm_states[i % 40];
    state.write(s.data(), static_cast<std::uint32_t>(s.size()));
    const auto& c = cdr_states[i % 40];
    dds_state.write(c.data(), static_cast<std::uint32_t>(c.size()));
    // The single-shot event renewed by its client after each round of 40 states.
    if (i % 40 == 39) converting.condition()->activate(EventMode::single);
  }
  const std::uint64_t during = allocations() - before;
  stop = true;
  activator.join();
  EXPECT_EQ(during, 0u);

  const ConditionCounters& k = passthrough.condition()->counters();
  EXPECT_EQ(k.tested.load() + k.inactive.load(), 20'000u);
  EXPECT_EQ(low_sink.count.load(), k.fired.load());
  // Which of those states the client's thread had active depends on the scheduling; one more
  // round with an activation of this thread's own fires for some states and not for others.
  const std::uint64_t fired = k.fired.load();
  const std::uint64_t suppressed = k.suppressed.load();
  const ConditionParameter level[] = {{"level", 20.0}};
  ASSERT_EQ(activate_conditions(low, EventMode::continuous, level), Status::ok);
  for (const auto& s : lcm_states) state.write(s.data(), static_cast<std::uint32_t>(s.size()));
  EXPECT_GT(k.fired.load(), fired);
  EXPECT_GT(k.suppressed.load(), suppressed);
  EXPECT_EQ(low_sink.count.load(), k.fired.load());
  EXPECT_GT(activations.load(), 0u);
  EXPECT_EQ(passthrough.counters().dropped(), 0u);
  // One event per round of 40 states (20'000 / 40 rounds).
  EXPECT_EQ(converting.condition()->counters().fired.load(), 500u);
  EXPECT_EQ(once_sink.count.load(), 500u);
  EXPECT_EQ(converting.counters().dropped(), 0u);
}

}  // namespace
}  // namespace polyport
