// What polyportctl changes in a running application, below the admin socket: property values
// checked against their declared types, connections checked by the loader's own code
// (check_connection), connections added and removed while samples flow, and property changes
// handed to the component on its execution context's thread (onPropertyChanged).
#include <gtest/gtest.h>

#include <atomic>

#include <nlohmann/json.hpp>

#include "inproc_model.hpp"
#include "polyport/profile/runtime_checks.hpp"
#include "polyport/runtime/component_api.hpp"
#include "polyport/runtime/connection_timer.hpp"
#include "polyport/runtime/watchdog.hpp"
#include "polyport/runtime/engine.hpp"
#include "../support/engine_fixture.hpp"
#include "../support/eventually.hpp"

namespace polyport {
namespace {

using test::eventually;

std::string messages(const Diagnostics& diagnostics) {
  std::string out;
  for (const auto& d : diagnostics.all()) out += d.to_string() + "\n";
  return out;
}

TEST(PropertyValue, IsCheckedAgainstItsDeclaredType) {
  const PropertySpec number{"gain", "double", "1", {}};
  EXPECT_EQ(property_value_problem(number, "0.5"), "");
  EXPECT_EQ(property_value_problem(number, "1e-3"), "");
  EXPECT_EQ(property_value_problem(number, "+2"), "");
  EXPECT_EQ(property_value_problem(number, "fast"), "bad value 'fast' for property 'gain' of type 'double'");
  EXPECT_NE(property_value_problem(number, "inf"), "");
  EXPECT_NE(property_value_problem(number, ""), "");
  const PropertySpec integer{"count", "long", "1", {}};
  EXPECT_EQ(property_value_problem(integer, "-7"), "");
  EXPECT_NE(property_value_problem(integer, "1.5"), "");
  EXPECT_NE(property_value_problem(integer, "99999999999999999999"), "");
  const PropertySpec flag{"enabled", "bool", "true", {}};
  EXPECT_EQ(property_value_problem(flag, "false"), "");
  EXPECT_EQ(property_value_problem(flag, "1"), "");
  EXPECT_NE(property_value_problem(flag, "yes"), "");
  const PropertySpec free_text{"label", "string", "", {}};
  EXPECT_EQ(property_value_problem(free_text, "anything at all"), "");
  const PropertySpec untyped{"note", "", "", {}};
  EXPECT_EQ(property_value_problem(untyped, "x"), "");
}

// Event connections take the same path: their kind is the source port's, their default
// policy the loader's for events (circular), and a data port does not join an event port.
TEST(RuntimeConnectionCheck, EventConnectionsAreCheckedAsInAProfile) {
  TypeRegistry types;
  Diagnostics diagnostics;
  const auto app = load_application_profile(POLYPORT_TEST_DATA "/profiles/valid_app.xml", types,
                                            LoadOptions{{POLYPORT_TEST_DATA "/profiles/libs"}}, diagnostics);
  ASSERT_TRUE(app) << messages(diagnostics);
  Diagnostics found;
  auto busy = check_connection(*app, types, {"Joystick.busy", "Control.joystick_busy", "", ""}, found);
  ASSERT_TRUE(busy) << messages(found);
  EXPECT_EQ(busy->kind, PortKind::event);
  EXPECT_EQ(busy->policy, QueuePolicy::circular);
  EXPECT_EQ(busy->depth, 16u);
  auto status = check_connection(*app, types, {"Motor.status", "Control.status", "", ""}, found);
  ASSERT_TRUE(status) << messages(found);
  EXPECT_EQ(status->depth, 8u);  // the input port's queue_size
  EXPECT_FALSE(check_connection(*app, types, {"Joystick.joystick", "Control.joystick_busy", "", ""}, found));
  EXPECT_NE(messages(found).find("Control.joystick_busy is an event port; this is a data connection"), std::string::npos)
      << messages(found);
}

// A model that keeps the Interceptor defaults, as the foreign models (DDS, LCM, CAN) do.
class ForeignInterceptor final : public Interceptor {
 public:
  Result<void> start() override { return {}; }
  void stop() noexcept override {}
  ReturnCode command(LifecycleCommand) override { return ReturnCode::unsupported; }
  InterceptorStatus status() const override { return {"active", 0, 0}; }
  void describe(nlohmann::json&) const override {}
};

TEST(ForeignComponent, RefusesPropertyChangesAndSaysWhy) {
  ForeignInterceptor foreign;
  std::string why;
  EXPECT_EQ(foreign.set_property("rate", "5", why), ReturnCode::unsupported);
  EXPECT_EQ(why, "polyport cannot pass a property to a component of this model while it runs");
  EXPECT_EQ(foreign.properties(), nullptr);
}

// A connection removed at run time leaves the timer of the timed policies too: its watchdog
// no longer trips and hands its target no safe value.
class CountingSink : public SampleSink {
 public:
  Status on_sample(const std::byte*, const SampleMeta&) noexcept override {
    count.fetch_add(1);
    return Status::ok;
  }
  std::atomic<int> count{0};
};

TEST(RemovedConnection, LeavesTheTimer) {
  Component a{"A", "inproc"};
  Component b{"B", "inproc"};
  DataOutPort& out = a.add_port<DataOutPort>("out", PortKind::data, nullptr, 8);
  DataInPort& in = b.add_port<DataInPort>("in", PortKind::data, nullptr, 8, QueuePolicy::data, 1);
  CountingSink sink;
  in.set_sink(&sink);
  const Nanos deadline{1'000'000};
  auto watched = [&] {
    auto c = std::make_unique<Connection>(out, in, QueuePolicy::data, 1);
    c->set_watchdog(std::make_unique<ConnectionWatchdog>(out, nullptr, deadline, Nanos{}, std::vector<std::byte>(8)));
    return c;
  };
  ConnectionTimer timer;
  auto kept = watched();
  auto removed = watched();  // the same two ports: it would hand the sink a safe value too
  out.connections().add(*kept);
  in.connections().add(*kept);
  timer.add(*kept);
  timer.add(*removed);
  const std::uint64_t v = 7;
  ASSERT_EQ(out.write(&v, sizeof v), Status::ok);
  EXPECT_EQ(sink.count.load(), 1);
  timer.check(mono_now());  // the source wrote: both watchdogs go from waiting to ok
  EXPECT_EQ(removed->watchdog()->state(), WatchdogState::ok);
  timer.remove(*removed);
  // The source falls silent: the kept connection trips and hands the sink its safe value;
  // the removed one is not looked at any more.
  timer.check(mono_now() + Nanos{10 * deadline.count});
  EXPECT_EQ(kept->watchdog()->counters().trips.load(), 1u);
  EXPECT_EQ(removed->watchdog()->counters().trips.load(), 0u);
  EXPECT_EQ(removed->watchdog()->state(), WatchdogState::ok);
  EXPECT_EQ(sink.count.load(), 2);
}

class RuntimeChanges : public test::EngineFixture {
 protected:
  RuntimeChanges() : EngineFixture(POLYPORT_TEST_DATA "/engine", LoadOptions{{POLYPORT_PLUGIN_DIR}}) {
    models.add(std::make_unique<inproc::InprocModel>());
  }
  void SetUp() override {
    options.models = &models;
    auto loaded = load_application_profile(POLYPORT_TEST_DATA "/engine/runtime_app.xml", types, options, diagnostics);
    ASSERT_TRUE(loaded) << problems();
    profile = std::move(*loaded);
    ASSERT_TRUE(engine.build(profile, diagnostics)) << problems();
  }
  // check_connection's verdict: the spec, or every problem as text in `why`.
  std::optional<ConnectionSpec> check(ConnectionRequest request, std::string& why) {
    Diagnostics found;
    auto spec = check_connection(profile, types, request, found);
    why = messages(found);
    return spec;
  }
  // The latest value a probe on `port` saw (nullopt: none yet), draining what it holds.
  std::optional<std::int64_t> latest(DataInPort& probe) {
    std::optional<std::int64_t> value;
    std::int64_t v = 0;
    while (probe.read(&v, sizeof v) == Status::ok) value = v;
    return value;
  }

  LoadOptions options{{POLYPORT_PLUGIN_DIR}};
  ApplicationProfile profile;
};

TEST_F(RuntimeChanges, AConnectionIsCheckedAsTheLoaderChecksOne) {
  std::string why;
  // No policy: the input port's (collector.in is a buffer of 64), as in a profile.
  auto spec = check({"ticker.count", "collector.in", "", ""}, why);
  ASSERT_TRUE(spec) << why;
  EXPECT_EQ(spec->kind, PortKind::data);
  EXPECT_EQ(spec->policy, QueuePolicy::buffer);
  EXPECT_EQ(spec->depth, 64u);
  spec = check({"ticker.count", "collector.in", "circular", "8"}, why);
  ASSERT_TRUE(spec) << why;
  EXPECT_EQ(spec->policy, QueuePolicy::circular);
  EXPECT_EQ(spec->depth, 8u);
  // The loader's own words, for each kind of problem.
  struct Case {
    ConnectionRequest request;
    const char* says;
  };
  for (const Case& c : {
           Case{{"nobody.count", "collector.in", "", ""}, "unknown component 'nobody'"},
           Case{{"ticker.nothing", "collector.in", "", ""}, "component 'ticker' has no port 'nothing'"},
           Case{{"collector.in", "ticker.count", "", ""}, "collector.in is an input port; a data connection's source must be an output port"},
           Case{{"ticker.count", "collector.in", "fifo", ""}, "bad policy 'fifo'"},
           Case{{"ticker.count", "collector.in", "buffer", "0"}, "bad depth '0': expected an integer from 1 to 4294967295"},
           Case{{"ticker.count", "collector.in", "data", "4"}, "a depth needs a buffer or circular policy, but this connection uses the data policy"},
           Case{{"ticker.count", "caller.calc", "", ""}, "caller.calc is a service port; this is a data connection"},
           Case{{"ticker.count", "collector", "", ""}, "empty attribute 'port_name'"},
       }) {
    EXPECT_FALSE(check(c.request, why)) << c.request.source << " -> " << c.request.target;
    EXPECT_NE(why.find(c.says), std::string::npos) << why;
  }
}

TEST_F(RuntimeChanges, ConnectionsAreAddedAndRemovedWhileSamplesFlow) {
  std::vector<std::string> warnings;
  ASSERT_TRUE(engine.start(warnings));
  Result<DataInPort*> seen = engine.add_probe("collector.seen", 1024);
  ASSERT_TRUE(seen);
  std::string why;
  const auto spec = check({"ticker.count", "collector.in", "", ""}, why);
  ASSERT_TRUE(spec) << why;
  Result<Connection*> added = engine.add_connection(*spec);
  ASSERT_TRUE(added) << added.error().message;
  const Connection* connection = added.value();
  EXPECT_EQ(connection->policy(), QueuePolicy::buffer);
  // The collector republishes the ticker's count: it rises.
  std::int64_t first = 0;
  ASSERT_TRUE(eventually([&] { return (first = latest(*seen.value()).value_or(0)) > 0; }));
  ASSERT_TRUE(eventually([&] { return latest(*seen.value()).value_or(0) > first + 5; }));
  EXPECT_GT(connection->counters().delivered.load(), 0u);
  // A second, identical one is refused.
  Result<Connection*> again = engine.add_connection(*spec);
  ASSERT_FALSE(again);
  EXPECT_EQ(again.error().message, "ticker.count is already connected to collector.in");

  ASSERT_TRUE(engine.remove_connection("ticker.count", "collector.in"));
  for (const auto& c : engine.connections()) EXPECT_NE(c->name(), "ticker.count -> collector.in");
  // From now on the collector sees nothing new: the value it republishes stays, cycle after
  // cycle (50 more samples of it, at its 2 ms period).
  std::optional<std::int64_t> frozen;
  ASSERT_TRUE(eventually([&] {
    frozen = latest(*seen.value());
    return frozen.has_value();
  }));
  std::size_t same = 0;
  ASSERT_TRUE(eventually([&] {
    std::int64_t v = 0;
    while (seen.value()->read(&v, sizeof v) == Status::ok) {
      EXPECT_EQ(v, *frozen);
      ++same;
    }
    return same >= 50;
  }));
  // Connected again, it rises again: the ports took a new connection after a removal.
  ASSERT_TRUE(engine.add_connection(*spec));
  ASSERT_TRUE(eventually([&] { return latest(*seen.value()).value_or(0) > *frozen; }));

  Result<void> unknown = engine.remove_connection("ticker.count", "tunable.step");
  ASSERT_FALSE(unknown);
  EXPECT_EQ(unknown.error().message, "no connection ticker.count -> tunable.step");
  engine.stop();
}

// A service connection is removed and made again while the caller calls: in between its
// calls end not_connected, then it gets sums again (its binding is replaced whole).
TEST_F(RuntimeChanges, AServiceConnectionIsRemovedAndMadeWhileCallsGoOn) {
  std::vector<std::string> warnings;
  ASSERT_TRUE(engine.start(warnings));
  Result<DataInPort*> sums = engine.add_probe("caller.sums", 1024);
  ASSERT_TRUE(sums);
  ASSERT_TRUE(eventually([&] { return latest(*sums.value()).has_value(); })) << "no sums while bound";
  auto* calc = dynamic_cast<RequiredServicePort*>(engine.find_port("caller.calc"));
  ASSERT_NE(calc, nullptr);

  ASSERT_TRUE(engine.remove_connection("caller.calc", "adder.calc"));
  EXPECT_FALSE(calc->connected());
  const std::uint64_t refused = calc->counters().not_connected.load();
  ASSERT_TRUE(eventually([&] { return calc->counters().not_connected.load() > refused + 3; }))
      << "the caller's calls are not refused";
  (void)latest(*sums.value());  // what came before

  std::string why;
  const auto spec = check({"caller.calc", "adder.calc", "", ""}, why);
  ASSERT_TRUE(spec) << why;
  EXPECT_EQ(spec->kind, PortKind::service);
  Result<Connection*> bound = engine.add_connection(*spec);
  ASSERT_TRUE(bound) << bound.error().message;
  EXPECT_EQ(bound.value(), nullptr) << "a service connection has no data connection";
  EXPECT_TRUE(calc->connected());
  ASSERT_TRUE(eventually([&] { return latest(*sums.value()).has_value(); })) << "no sums once bound again";
  Result<Connection*> twice = engine.add_connection(*spec);
  ASSERT_FALSE(twice);
  EXPECT_EQ(twice.error().message, "caller.calc is already connected to adder.calc");
  engine.stop();
}

TEST_F(RuntimeChanges, APropertyChangeRunsOnTheComponentsOwnThread) {
  std::vector<std::string> warnings;
  ASSERT_TRUE(engine.start(warnings));
  Result<DataInPort*> step = engine.add_probe("tunable.step", 1024);
  Result<DataInPort*> hook = engine.add_probe("tunable.hook_on_ec", 1024);
  ASSERT_TRUE(step && hook);
  Interceptor* tunable = engine.find_interceptor("tunable");
  ASSERT_NE(tunable, nullptr);
  ASSERT_NE(tunable->properties(), nullptr);
  EXPECT_EQ(tunable->properties()->at("step"), "1");
  ASSERT_TRUE(eventually([&] { return latest(*step.value()) == 1; }));

  std::string why;
  EXPECT_EQ(tunable->set_property("step", "5", why), ReturnCode::ok) << why;
  EXPECT_EQ(tunable->properties()->at("step"), "5");
  ASSERT_TRUE(eventually([&] { return latest(*step.value()) == 5; }));
  // The hook ran on the thread that runs onExecute, not on this (the control) thread.
  ASSERT_TRUE(eventually([&] { return latest(*hook.value()) == 1; }));

  // The component refuses a value: the old one stays, in the component and in its map.
  EXPECT_EQ(tunable->set_property("step", "-2", why), ReturnCode::bad_parameter);
  EXPECT_NE(why.find("refused the value"), std::string::npos) << why;
  EXPECT_EQ(tunable->properties()->at("step"), "5");
  // A property the component does not take while it runs.
  EXPECT_EQ(tunable->set_property("label", "second", why), ReturnCode::unsupported);
  EXPECT_EQ(tunable->properties()->at("label"), "first");
  // A component that keeps the default hook refuses every change.
  Interceptor* ticker = engine.find_interceptor("ticker");
  EXPECT_EQ(ticker->set_property("anything", "1", why), ReturnCode::unsupported);
  EXPECT_EQ(ticker->properties()->count("anything"), 0u);
  // Five more cycles: still 5.
  std::size_t fives = 0;
  ASSERT_TRUE(eventually([&] {
    std::int64_t v = 0;
    while (step.value()->read(&v, sizeof v) == Status::ok) {
      EXPECT_EQ(v, 5);
      ++fives;
    }
    return fives >= 5;
  }));
  engine.stop();
  // With the context stopped the change runs inline, still through the hook.
  EXPECT_EQ(tunable->set_property("step", "7", why), ReturnCode::ok) << why;
  EXPECT_EQ(tunable->properties()->at("step"), "7");
}

}  // namespace
}  // namespace polyport
