// CallbackInPort: a component's input port whose samples reach a member of the component as
// they arrive, on the writer's thread, with their meta; only while the component is active.
// First on ports bound by hand as the in-process adaptor binds them, then through the engine
// from profiles (tests/data/engine/Echo.xml, the Echo class of the test plugin).
#include <gtest/gtest.h>

#include <atomic>
#include <functional>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <thread>

#include "inproc_model.hpp"
#include "polyport/runtime/component.hpp"
#include "polyport/runtime/component_api.hpp"
#include "polyport/runtime/connection.hpp"
#include "polyport/runtime/engine.hpp"
#include "../support/engine_fixture.hpp"
#include "../support/eventually.hpp"

namespace polyport {
namespace {

using test::eventually;

struct Sample {
  std::int64_t seq;
  double value;
};

class Listener final : public ComponentBase {
 public:
  void on_sample(const Sample& sample, const SampleMeta& meta) {
    if (sample.seq < 0) throw std::runtime_error("refused");
    running = true;
    if (during) during();
    last = sample;
    last_meta = meta;
    thread = std::this_thread::get_id();
    ++count;
    running = false;
  }
  ReturnCode onExecute() override { return fail_execute ? ReturnCode::error : ReturnCode::ok; }
  ReturnCode onDeactivated() override {
    overlapped = running.load();
    deactivated = true;
    if (while_deactivating) while_deactivating();
    return ReturnCode::ok;
  }
  CallbackInPort<Sample> in{*this, "in", &Listener::on_sample};
  Sample last{};
  SampleMeta last_meta{};
  std::thread::id thread;
  int count = 0;
  std::function<void()> during;              // inside the handler
  std::function<void()> while_deactivating;  // inside onDeactivated
  std::atomic<bool> running{false};
  std::atomic<bool> deactivated{false};
  bool overlapped = false;  // a handler was running when onDeactivated began
  bool fail_execute = false;
};

// The listener's port bound as the in-process adaptor binds it (push mode when the declaration
// has a sink) and one connection into it.
struct Bound {
  Bound() {
    PortDeclaration& declaration = listener.port_declarations().front();
    in = &b.add_port<DataInPort>(declaration.name, declaration.kind, nullptr, declaration.size, QueuePolicy::data, 1);
    if (declaration.sink) in->set_sink(declaration.sink);
    *declaration.bound = in;
    connection = std::make_unique<Connection>(out, *in, QueuePolicy::data, 1);
    out.connections().add(*connection);
    in->connections().add(*connection);
  }
  Status write(std::int64_t seq, MonoTime source = {}) {
    const Sample sample{seq, 0.5 * static_cast<double>(seq)};
    return out.write(&sample, sizeof sample, source);
  }
  std::uint64_t refused() const { return connection->counters().dropped_sink_error.load(); }

  Listener listener;
  Lifecycle lifecycle{listener};
  Component a{"A", "inproc"};
  Component b{"B", "inproc"};
  DataOutPort& out = a.add_port<DataOutPort>("out", PortKind::data, nullptr, sizeof(Sample));
  DataInPort* in = nullptr;
  std::unique_ptr<Connection> connection;
};

TEST(CallbackInPort, DeclaresADataInputPortWithASink) {
  Listener listener;
  ASSERT_EQ(listener.port_declarations().size(), 1u);
  const PortDeclaration& declaration = listener.port_declarations().front();
  EXPECT_EQ(declaration.name, "in");
  EXPECT_EQ(declaration.kind, PortKind::data);
  EXPECT_EQ(declaration.direction, PortDirection::input);
  EXPECT_EQ(declaration.size, sizeof(Sample));
  EXPECT_EQ(declaration.align, alignof(Sample));
  EXPECT_NE(declaration.sink, nullptr);
}

TEST(CallbackInPort, PlainInPortDeclaresNoSink) {
  struct Reader final : ComponentBase {
    InPort<Sample> in{*this, "in"};
  } reader;
  EXPECT_EQ(reader.port_declarations().front().sink, nullptr);
}

TEST(CallbackInPort, DeliversEachSampleWithItsMetaOnTheWritersThread) {
  Bound bound;
  ASSERT_EQ(bound.lifecycle.apply(LifecycleCommand::initialize), ReturnCode::ok);
  ASSERT_EQ(bound.lifecycle.apply(LifecycleCommand::activate), ReturnCode::ok);
  EXPECT_TRUE(bound.connection->push_mode());
  const MonoTime stamped = mono_now();
  std::thread::id writer;
  std::thread thread([&] {
    writer = std::this_thread::get_id();
    for (std::int64_t seq = 1; seq <= 3; ++seq) ASSERT_EQ(bound.write(seq, stamped), Status::ok);
  });
  thread.join();
  // Delivered before write() returned: nothing waits in a buffer.
  EXPECT_EQ(bound.listener.count, 3);
  EXPECT_EQ(bound.listener.last.seq, 3);
  EXPECT_EQ(bound.listener.last.value, 1.5);
  EXPECT_EQ(bound.listener.thread, writer);
  EXPECT_EQ(bound.listener.last_meta.size, sizeof(Sample));
  EXPECT_GE(bound.listener.last_meta.t_in.ns, stamped.ns);
  EXPECT_EQ(bound.listener.last_meta.t_source.ns, stamped.ns);
  EXPECT_EQ(bound.connection->counters().delivered.load(), 3u);
  EXPECT_EQ(bound.refused(), 0u);
}

TEST(CallbackInPort, RefusesSamplesWhileTheComponentIsNotActive) {
  Bound bound;
  bound.write(1);  // created
  ASSERT_EQ(bound.lifecycle.apply(LifecycleCommand::initialize), ReturnCode::ok);
  bound.write(2);  // inactive
  EXPECT_EQ(bound.listener.count, 0);
  EXPECT_EQ(bound.refused(), 2u);
  ASSERT_EQ(bound.lifecycle.apply(LifecycleCommand::activate), ReturnCode::ok);
  bound.write(3);
  EXPECT_EQ(bound.listener.count, 1);
  ASSERT_EQ(bound.lifecycle.apply(LifecycleCommand::deactivate), ReturnCode::ok);
  bound.write(4);
  EXPECT_EQ(bound.listener.count, 1);
  EXPECT_EQ(bound.listener.last.seq, 3);
  EXPECT_EQ(bound.refused(), 3u);
}

// A handler under way on a writer's thread when the deactivation begins ends before
// onDeactivated does: the handler holds on until onDeactivated has run (it never should while
// the handler runs) or a deadline has passed.
TEST(CallbackInPort, HandlerUnderWayEndsBeforeOnDeactivatedBegins) {
  Bound bound;
  ASSERT_EQ(bound.lifecycle.apply(LifecycleCommand::initialize), ReturnCode::ok);
  ASSERT_EQ(bound.lifecycle.apply(LifecycleCommand::activate), ReturnCode::ok);
  std::atomic<bool> in_handler{false};
  std::atomic<bool> deactivating{false};
  bound.listener.during = [&] {
    in_handler = true;
    while (!deactivating) std::this_thread::yield();
    (void)eventually([&] { return bound.listener.deactivated.load(); }, std::chrono::milliseconds(300));
  };
  std::thread writer([&] { bound.write(1); });
  const bool entered = eventually([&] { return in_handler.load(); });
  deactivating = true;
  const ReturnCode deactivated = bound.lifecycle.apply(LifecycleCommand::deactivate);
  writer.join();
  ASSERT_TRUE(entered);
  EXPECT_EQ(deactivated, ReturnCode::ok);
  EXPECT_FALSE(bound.listener.overlapped) << "onDeactivated began while the handler was running";
  EXPECT_EQ(bound.listener.count, 1);
}

// onDeactivated may still write what loops back into the port: refused, as once it returned.
TEST(CallbackInPort, SampleWrittenWhileOnDeactivatedRunsIsRefused) {
  Bound bound;
  ASSERT_EQ(bound.lifecycle.apply(LifecycleCommand::initialize), ReturnCode::ok);
  ASSERT_EQ(bound.lifecycle.apply(LifecycleCommand::activate), ReturnCode::ok);
  bound.write(1);
  bound.listener.while_deactivating = [&] { bound.write(2); };
  ASSERT_EQ(bound.lifecycle.apply(LifecycleCommand::deactivate), ReturnCode::ok);
  EXPECT_EQ(bound.listener.count, 1);
  EXPECT_EQ(bound.listener.last.seq, 1);
  EXPECT_EQ(bound.refused(), 1u);
}

// A failed onExecute stops the handing over; recover starts it again.
TEST(CallbackInPort, ErrorStopsTheSamplesAndRecoverResumesThem) {
  Bound bound;
  ASSERT_EQ(bound.lifecycle.apply(LifecycleCommand::initialize), ReturnCode::ok);
  ASSERT_EQ(bound.lifecycle.apply(LifecycleCommand::activate), ReturnCode::ok);
  bound.listener.fail_execute = true;
  bound.lifecycle.execute();
  ASSERT_EQ(bound.lifecycle.state(), LifecycleState::error);
  bound.write(1);
  EXPECT_EQ(bound.listener.count, 0);
  EXPECT_EQ(bound.refused(), 1u);
  bound.listener.fail_execute = false;
  ASSERT_EQ(bound.lifecycle.apply(LifecycleCommand::recover), ReturnCode::ok);
  bound.write(2);
  EXPECT_EQ(bound.listener.count, 1);
  EXPECT_EQ(bound.listener.last.seq, 2);
}

TEST(CallbackInPort, ShortSampleAndThrowingHandlerAreSinkErrors) {
  Bound bound;
  ASSERT_EQ(bound.lifecycle.apply(LifecycleCommand::initialize), ReturnCode::ok);
  ASSERT_EQ(bound.lifecycle.apply(LifecycleCommand::activate), ReturnCode::ok);
  const std::int32_t short_sample = 7;
  bound.out.write(&short_sample, sizeof short_sample);
  bound.write(-1);  // the handler throws
  EXPECT_EQ(bound.listener.count, 0);
  EXPECT_EQ(bound.refused(), 2u);
  bound.write(5);
  EXPECT_EQ(bound.listener.count, 1);
}

class CallbackInPortEngine : public test::EngineFixture {
 protected:
  CallbackInPortEngine() : EngineFixture(POLYPORT_TEST_DATA "/engine", LoadOptions{{POLYPORT_PLUGIN_DIR}}) {
    models.add(std::make_unique<inproc::InprocModel>());
  }
};

const nlohmann::json* connection_named(const nlohmann::json& stats, const std::string& name) {
  for (const auto& c : stats["connections"]) {
    if (c["name"] == name) return &c;
  }
  return nullptr;
}

TEST_F(CallbackInPortEngine, BindsThePortInPushModeAndTheComponentAnswersFromTheCallback) {
  ASSERT_TRUE(build("callback_app.xml")) << problems();
  nlohmann::json graph;
  engine.describe(graph);
  for (const auto& c : graph["connections"]) {
    // Echo's input is push mode (no buffer); Collector's, an InPort, stays pull.
    EXPECT_EQ(c["mode"], c["target"] == "echo.in" ? "push" : "pull") << c.dump();
  }
  for (const auto& component : graph["components"]) {
    for (const auto& port : component["ports"]) {
      const bool callback = component["name"] == "echo" && port["name"] == "in";
      EXPECT_EQ(port.value("mode", ""), callback ? "push" : "") << component["name"] << ": " << port.dump();
    }
  }
  std::vector<std::string> warnings;
  ASSERT_TRUE(engine.start(warnings));
  nlohmann::json stats;
  const auto answered = [&] {
    stats = nlohmann::json();
    engine.stats(stats);
    const nlohmann::json* in = connection_named(stats, "ticker.count -> echo.in");
    const nlohmann::json* out = connection_named(stats, "echo.out -> collector.in");
    return in != nullptr && out != nullptr && (*in)["delivered"].get<std::uint64_t>() >= 20 &&
           (*out)["read"].get<std::uint64_t>() >= 10;
  };
  ASSERT_TRUE(eventually(answered)) << stats.dump(2);
  engine.stop();
  stats = nlohmann::json();
  engine.stats(stats);
  const nlohmann::json& in = *connection_named(stats, "ticker.count -> echo.in");
  const nlohmann::json& out = *connection_named(stats, "echo.out -> collector.in");
  const nlohmann::json& meta_ok = *connection_named(stats, "echo.meta_ok -> checks.in");
  EXPECT_EQ(in["mode"], "push");
  // Every sample Echo took went out again, from the callback. (Samples written while Echo was
  // not active yet or any more were refused: counted as sink errors, not delivered.)
  EXPECT_EQ(out["received"], in["delivered"]) << stats.dump(2);
  // And each came with its size and time of entry in its meta.
  EXPECT_EQ(meta_ok["received"], in["delivered"]) << stats.dump(2);
  EXPECT_EQ(in["received"].get<std::uint64_t>(),
            in["delivered"].get<std::uint64_t>() + in["dropped_by_reason"]["sink_error"].get<std::uint64_t>());
}

TEST_F(CallbackInPortEngine, PortThatTheProfileDeclaresAsAnEventPortIsRefused) {
  EXPECT_FALSE(build("callback_as_event_app.xml"));
  ASSERT_EQ(diagnostics.error_count(), 1u) << problems();
  const std::string message = diagnostics.all().front().to_string();
  EXPECT_NE(message.find("EchoAsEvent.xml:"), std::string::npos) << message;
  EXPECT_NE(message.find("port 'in' is a event input port in the profile but component class 'Echo' declares a "
                         "data input port 'in'"),
            std::string::npos)
      << message;
}

}  // namespace
}  // namespace polyport
