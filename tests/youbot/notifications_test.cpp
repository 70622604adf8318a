// Unit tests of what the youBot case needs from the runtime: a component's busy / idle /
// refresh notifications (ComponentBase::notify_*, <notifications auto>) and an execution
// context whose period changes while it runs (ExecutionContext::set_period,
// ComponentBase::request_period).
#include <gtest/gtest.h>

#include <atomic>
#include <cstring>
#include <limits>
#include <mutex>
#include <vector>

#include "polyport/runtime/component.hpp"
#include "polyport/runtime/component_api.hpp"
#include "polyport/runtime/connection.hpp"
#include "polyport/runtime/execution_context.hpp"
#include "polyport/runtime/lifecycle.hpp"
#include "../support/eventually.hpp"

namespace polyport {
namespace {

using test::eventually;

ExecutionSettings settings_of(const char* name, Nanos period) {
  ExecutionSettings settings;
  settings.name = name;
  settings.period = period;
  return settings;
}

// The notification port as the in-process model binds it: a DataOutPort of the engine's
// component, with a queue behind it to read what was raised.
struct NotificationWiring {
  Component owner{"Driver", "inproc"};
  Component reader{"Monitor", "inproc"};
  DataOutPort* out = nullptr;
  DataInPort* in = nullptr;
  std::unique_ptr<Connection> connection;

  explicit NotificationWiring(ComponentBase& component, bool automatic = false) {
    component.set_instance("Driver", {}, 0.0);
    component.enable_notifications("notifications", automatic);
    PortDeclaration& d = component.port_declarations().back();
    EXPECT_EQ(d.kind, PortKind::event);
    EXPECT_EQ(d.direction, PortDirection::output);
    EXPECT_EQ(d.size, sizeof(ComponentNotification));
    out = &owner.add_port<DataOutPort>("notifications", PortKind::event, nullptr, sizeof(ComponentNotification));
    in = &reader.add_port<DataInPort>("notifications", PortKind::event, nullptr, sizeof(ComponentNotification),
                                      QueuePolicy::circular, 256);
    *d.bound = out;
    connection = std::make_unique<Connection>(*out, *in, QueuePolicy::circular, 256);
    out->connections().add(*connection);
    in->connections().add(*connection);
  }
  std::vector<ComponentNotification> take_all() {
    std::vector<ComponentNotification> all;
    ComponentNotification n{};
    while (in->read(&n, sizeof n) == Status::ok) all.push_back(n);
    return all;
  }
};

class Quiet final : public ComponentBase {};

TEST(Notifications, CarryKindSequenceTimeAndInstanceName) {
  Quiet component;
  NotificationWiring wiring(component);
  EXPECT_TRUE(component.notifications_enabled());
  const std::int64_t before = mono_now().ns;
  EXPECT_EQ(component.notify_busy(), Status::ok);
  EXPECT_EQ(component.notify_refresh(), Status::ok);
  EXPECT_EQ(component.notify_idle(), Status::ok);
  const std::int64_t after = mono_now().ns;
  const auto all = wiring.take_all();
  ASSERT_EQ(all.size(), 3u);
  const std::int32_t kinds[] = {0, 2, 1};  // busy, refresh, idle as in component_notification.idl
  for (std::size_t i = 0; i < all.size(); ++i) {
    EXPECT_EQ(all[i].kind, kinds[i]);
    EXPECT_EQ(all[i].serial, static_cast<std::int64_t>(i + 1));
    EXPECT_GE(all[i].time_ns, before);
    EXPECT_LE(all[i].time_ns, after);
    EXPECT_STREQ(all[i].component, "Driver");
  }
  EXPECT_EQ(component.notifications_sent(), 3u);
}

TEST(Notifications, WithoutTheProfileElementNothingIsSent) {
  Quiet component;
  EXPECT_FALSE(component.notifications_enabled());
  EXPECT_EQ(component.notify_busy(), Status::not_connected);
  EXPECT_EQ(component.notifications_sent(), 0u);
}

TEST(Notifications, ALongInstanceNameIsCutToTheField) {
  Quiet component;
  NotificationWiring wiring(component);
  component.set_instance(std::string(100, 'x'), {}, 0.0);
  component.notify_refresh();
  const auto all = wiring.take_all();
  ASSERT_EQ(all.size(), 1u);
  EXPECT_EQ(std::strlen(all[0].component), sizeof all[0].component - 1);
}

// Each onExecute raises refresh itself; with auto, the context adds busy before and idle after.
class Refresher final : public ComponentBase {
 public:
  ReturnCode onExecute() override {
    notify_refresh();
    executions.fetch_add(1);
    return ReturnCode::ok;
  }
  std::atomic<int> executions{0};
};

TEST(Notifications, AutoRaisesBusyBeforeAndIdleAfterEachCycle) {
  Refresher component;
  NotificationWiring wiring(component, true);
  Lifecycle lifecycle(component);
  ExecutionContext context(settings_of("auto", Nanos{1'000'000}));
  context.add(lifecycle);
  std::vector<std::string> warnings;
  context.start(warnings);
  ASSERT_EQ(context.command(lifecycle, LifecycleCommand::initialize), ReturnCode::ok);
  ASSERT_EQ(context.command(lifecycle, LifecycleCommand::activate), ReturnCode::ok);
  ASSERT_TRUE(eventually([&] { return component.executions.load() >= 10; }));
  context.command(lifecycle, LifecycleCommand::deactivate);
  context.stop();
  const auto all = wiring.take_all();
  ASSERT_GE(all.size(), 30u);
  ASSERT_EQ(all.size() % 3, 0u);
  for (std::size_t i = 0; i < all.size(); ++i) {
    const std::int32_t expected = i % 3 == 0 ? 0 : i % 3 == 1 ? 2 : 1;  // busy, refresh, idle
    EXPECT_EQ(all[i].kind, expected) << "notification " << i;
    EXPECT_EQ(all[i].serial, static_cast<std::int64_t>(i + 1));
  }
}

// Records the period it sees each cycle and asks for another one at a given cycle.
class PeriodChanger final : public ComponentBase {
 public:
  ReturnCode onExecute() override {
    const int n = cycles.fetch_add(1) + 1;
    {
      std::lock_guard<std::mutex> lock(mutex);
      seen.push_back(period_seconds());
    }
    if (n == change_at) answer = request_period(new_period);
    return ReturnCode::ok;
  }
  std::atomic<int> cycles{0};
  int change_at = 5;
  double new_period = 0.002;
  std::atomic<ReturnCode> answer{ReturnCode::error};
  std::mutex mutex;
  std::vector<double> seen;
};

TEST(PeriodChange, AComponentChangesItsContextsPeriodFromTheNextCycleOn) {
  PeriodChanger component;
  component.set_instance("Changer", {}, 0.001);
  Lifecycle lifecycle(component);
  ExecutionContext context(settings_of("changer", Nanos{1'000'000}));
  context.add(lifecycle);
  EXPECT_EQ(component.execution_context(), &context);
  std::vector<std::string> warnings;
  context.start(warnings);
  ASSERT_EQ(context.command(lifecycle, LifecycleCommand::initialize), ReturnCode::ok);
  ASSERT_EQ(context.command(lifecycle, LifecycleCommand::activate), ReturnCode::ok);
  ASSERT_TRUE(eventually([&] { return component.cycles.load() >= 10; }));
  context.stop();
  EXPECT_EQ(component.answer.load(), ReturnCode::ok);
  EXPECT_EQ(context.period().count, 2'000'000);
  EXPECT_EQ(context.settings().period.count, 1'000'000);  // what the profile asked for stays
  EXPECT_EQ(context.period_changes(), 1u);
  std::lock_guard<std::mutex> lock(component.mutex);
  ASSERT_GE(component.seen.size(), 10u);
  for (std::size_t i = 0; i < component.seen.size(); ++i) {
    // Cycle 5 asked; cycles 1-5 saw the old period, later ones the new.
    EXPECT_DOUBLE_EQ(component.seen[i], i < 5 ? 0.001 : 0.002) << "cycle " << i + 1;
  }
}

TEST(PeriodChange, BadPeriodsAreRefusedAndChangeNothing) {
  Quiet component;
  component.set_instance("Q", {}, 0.01);
  Lifecycle lifecycle(component);
  ExecutionContext context(settings_of("q", Nanos{10'000'000}));
  context.add(lifecycle);
  for (double bad : {0.0, -0.01, 1e-7, std::numeric_limits<double>::quiet_NaN(),
                     std::numeric_limits<double>::infinity()}) {
    EXPECT_EQ(component.request_period(bad), ReturnCode::bad_parameter) << bad;
  }
  EXPECT_FALSE(context.set_period(Nanos{0}));
  EXPECT_FALSE(context.set_period(Nanos{-5}));
  EXPECT_EQ(context.period().count, 10'000'000);
  EXPECT_EQ(context.period_changes(), 0u);
  EXPECT_DOUBLE_EQ(component.period_seconds(), 0.01);
  EXPECT_EQ(component.request_period(0.02), ReturnCode::ok);  // not running: applies at start
  EXPECT_DOUBLE_EQ(component.period_seconds(), 0.02);
}

// A run-time change keeps a sleep in every period: not under twice the spin tail, and a
// real-time context not under 100 us (the thread would otherwise spin or overrun at real-time
// priority forever).
TEST(PeriodChange, AChangeThatWouldLeaveNoSleepIsRefused) {
  ExecutionSettings spinning = settings_of("spin", Nanos{1'000'000});
  spinning.spin = Nanos{300'000};
  ExecutionContext with_spin(spinning);
  EXPECT_FALSE(with_spin.set_period(Nanos{599'999}));
  EXPECT_FALSE(with_spin.set_period(Nanos{300'000}));
  EXPECT_EQ(with_spin.period().count, 1'000'000);
  EXPECT_TRUE(with_spin.set_period(Nanos{600'000}));
  EXPECT_EQ(with_spin.period().count, 600'000);

  ExecutionSettings fifo = settings_of("fifo", Nanos{1'000'000});
  fifo.policy = SchedPolicy::fifo;
  fifo.priority = 10;
  ExecutionContext real_time(fifo);
  EXPECT_FALSE(real_time.set_period(Nanos{99'999}));
  EXPECT_FALSE(real_time.set_period(ExecutionContext::kMinPeriod));
  EXPECT_EQ(real_time.period_changes(), 0u);
  EXPECT_TRUE(real_time.set_period(Nanos{100'000}));
  EXPECT_EQ(real_time.period().count, 100'000);

  ExecutionContext ordinary(settings_of("plain", Nanos{1'000'000}));  // no spin, SCHED_OTHER
  EXPECT_TRUE(ordinary.set_period(Nanos{50'000}));
}

TEST(PeriodChange, APassiveComponentHasNoPeriodToChange) {
  Quiet component;
  component.set_instance("P", {}, 0.0);
  EXPECT_EQ(component.request_period(0.01), ReturnCode::unsupported);
  EXPECT_EQ(component.period_seconds(), 0.0);
}

// A real-time context takes the change the same way (where the system grants SCHED_FIFO;
// otherwise the context runs without it, which this test does not need).
TEST(PeriodChange, ARealTimeContextTakesTheChangeToo) {
  PeriodChanger component;
  component.change_at = 3;
  component.new_period = 0.0005;
  component.set_instance("Rt", {}, 0.001);
  Lifecycle lifecycle(component);
  ExecutionSettings settings = settings_of("rt", Nanos{1'000'000});
  settings.policy = SchedPolicy::fifo;
  settings.priority = 10;
  ExecutionContext context(settings);
  context.add(lifecycle);
  std::vector<std::string> warnings;
  context.start(warnings);
  ASSERT_EQ(context.command(lifecycle, LifecycleCommand::initialize), ReturnCode::ok);
  ASSERT_EQ(context.command(lifecycle, LifecycleCommand::activate), ReturnCode::ok);
  ASSERT_TRUE(eventually([&] { return component.cycles.load() >= 6; }));
  context.stop();
  EXPECT_EQ(context.period().count, 500'000);
  std::lock_guard<std::mutex> lock(component.mutex);
  EXPECT_DOUBLE_EQ(component.seen.back(), 0.0005);
}

}  // namespace
}  // namespace polyport
