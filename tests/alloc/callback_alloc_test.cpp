// A CallbackInPort allocates nothing per sample: counted over every thread of the process,
// first on ports bound by hand (the handler answering on an OutPort, as an echo does), then
// in a running application whose Echo component answers a periodic Ticker from its callback
// (tests/data/engine/callback_app.xml).
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "alloc_counter.hpp"
#include "inproc_model.hpp"
#include "polyport/runtime/component.hpp"
#include "polyport/runtime/component_api.hpp"
#include "polyport/runtime/connection.hpp"
#include "polyport/runtime/engine.hpp"
#include "polyport/types/types.hpp"
#include "../support/eventually.hpp"

namespace polyport {
namespace {

using test::allocations;
using test::eventually;

struct Ping {
  std::uint64_t seq;
  std::uint8_t pad[1016];
};

class Answering final : public ComponentBase {
 public:
  void on_ping(const Ping& sample, const SampleMeta&) {
    ++seen;
    pong.write(sample);
  }
  CallbackInPort<Ping> ping{*this, "ping", &Answering::on_ping};
  OutPort<Ping> pong{*this, "pong"};
  std::uint64_t seen = 0;
};

class NullSink final : public SampleSink {
 public:
  Status on_sample(const std::byte*, const SampleMeta&) noexcept override { return Status::ok; }
};

TEST(CallbackAllocations, HandlerThatAnswersOnAnOutPortAllocatesNothingPerSample) {
  Answering answering;
  Lifecycle lifecycle(answering);
  Component writer{"W", "inproc"};
  Component bound{"A", "inproc"};
  Component reader{"R", "adaptor"};
  auto& out = writer.add_port<DataOutPort>("out", PortKind::data, nullptr, sizeof(Ping));
  DataInPort* in = nullptr;
  DataOutPort* pong = nullptr;
  for (PortDeclaration& d : answering.port_declarations()) {
    if (d.direction == PortDirection::input) {
      in = &bound.add_port<DataInPort>(d.name, d.kind, nullptr, d.size, QueuePolicy::data, 1);
      in->set_sink(d.sink);
      *d.bound = in;
    } else {
      pong = &bound.add_port<DataOutPort>(d.name, d.kind, nullptr, d.size);
      *d.bound = pong;
    }
  }
  ASSERT_NE(in, nullptr);
  ASSERT_NE(pong, nullptr);
  auto& back = reader.add_port<DataInPort>("in", PortKind::data, nullptr, sizeof(Ping), QueuePolicy::data, 1);
  NullSink sink;
  back.set_sink(&sink);
  Connection to_answering(out, *in, QueuePolicy::data, 1), to_reader(*pong, back, QueuePolicy::data, 1);
  for (Connection* c : {&to_answering, &to_reader}) {
    c->source().connections().add(*c);
    c->target().connections().add(*c);
  }
  ASSERT_EQ(lifecycle.apply(LifecycleCommand::initialize), ReturnCode::ok);
  ASSERT_EQ(lifecycle.apply(LifecycleCommand::activate), ReturnCode::ok);

  Ping ping{};
  const std::uint64_t before = allocations();
  for (std::uint64_t i = 0; i < 10'000; ++i) {
    ping.seq = i;
    ASSERT_EQ(out.write(&ping, sizeof ping), Status::ok);
  }
  EXPECT_EQ(allocations() - before, 0u);
  EXPECT_EQ(answering.seen, 10'000u);
  EXPECT_EQ(to_reader.counters().delivered.load(), 10'000u);
}

TEST(CallbackAllocations, RunningApplicationWithAnEchoComponentAllocatesNothingAfterStartUp) {
  TypeRegistry types;
  ModelRegistry models;
  models.add(std::make_unique<inproc::InprocModel>());
  Diagnostics diagnostics;
  LoadOptions options{{POLYPORT_PLUGIN_DIR}};
  options.models = &models;
  auto profile = load_application_profile(POLYPORT_SOURCE_DIR "/tests/data/engine/callback_app.xml", types, options,
                                          diagnostics);
  ASSERT_TRUE(profile) << (diagnostics.all().empty() ? "" : diagnostics.all().front().to_string());
  Engine engine(models, types);
  ASSERT_TRUE(engine.build(*profile, diagnostics));
  std::vector<std::string> warnings;
  ASSERT_TRUE(engine.start(warnings));
  const ExecutionContext& ec = *engine.executors().contexts().front();
  ASSERT_TRUE(eventually([&] { return ec.cycles() >= 20; }));  // start-up is over

  const auto echoed = [&] {
    std::uint64_t n = 0;
    for (const auto& c : engine.connections()) {
      if (c->push_mode()) n += c->counters().delivered.load();
    }
    return n;
  };
  const std::uint64_t echoed_before = echoed();
  const std::uint64_t before = allocations();
  const std::uint64_t cycles = ec.cycles();
  ASSERT_TRUE(eventually([&] { return ec.cycles() >= cycles + 100; }));
  const std::uint64_t during = allocations() - before;
  const std::uint64_t echoed_during = echoed() - echoed_before;
  engine.stop();
  EXPECT_EQ(during, 0u) << "allocations during 100 cycles of the running application";
  EXPECT_GE(echoed_during, 50u);
}

}  // namespace
}  // namespace polyport
