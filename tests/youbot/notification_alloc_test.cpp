// Notifications allocate nothing after start-up: notify_* from the component's code, and the
// busy / idle an execution context raises around each cycle (<notifications auto="true">),
// counted over every thread of the process (alloc_counter.cpp replaces operator new).
#include <gtest/gtest.h>

#include <atomic>

#include "../alloc/alloc_counter.hpp"
#include "../support/eventually.hpp"
#include "polyport/runtime/component.hpp"
#include "polyport/runtime/component_api.hpp"
#include "polyport/runtime/connection.hpp"
#include "polyport/runtime/execution_context.hpp"
#include "polyport/runtime/lifecycle.hpp"

namespace polyport {
namespace {

using test::allocations;
using test::eventually;

ExecutionSettings settings_of(const char* name, Nanos period) {
  ExecutionSettings settings;
  settings.name = name;
  settings.period = period;
  return settings;
}

class Notifier final : public ComponentBase {
 public:
  ReturnCode onExecute() override {
    notify_refresh();
    cycles.fetch_add(1, std::memory_order_relaxed);
    return ReturnCode::ok;
  }
  std::atomic<std::uint64_t> cycles{0};
};

// The notification port bound as the in-process model binds it, with a circular queue behind.
struct Wiring {
  Component owner{"Driver", "inproc"};
  Component reader{"Monitor", "inproc"};
  DataOutPort* out;
  DataInPort* in;
  std::unique_ptr<Connection> connection;
  explicit Wiring(ComponentBase& component, bool automatic) {
    component.set_instance("Driver", {}, 0.0);
    component.enable_notifications("notifications", automatic);
    out = &owner.add_port<DataOutPort>("notifications", PortKind::event, nullptr, sizeof(ComponentNotification));
    in = &reader.add_port<DataInPort>("notifications", PortKind::event, nullptr, sizeof(ComponentNotification),
                                      QueuePolicy::circular, 64);
    *component.port_declarations().back().bound = out;
    connection = std::make_unique<Connection>(*out, *in, QueuePolicy::circular, 64);
    out->connections().add(*connection);
    in->connections().add(*connection);
  }
};

TEST(NotificationAllocations, NotifyAllocatesNothing) {
  Notifier component;
  Wiring wiring(component, false);
  component.notify_busy();  // first use
  ComponentNotification n{};
  const std::uint64_t before = allocations();
  for (int i = 0; i < 10'000; ++i) {
    ASSERT_EQ(component.notify_busy(), Status::ok);
    ASSERT_EQ(component.notify_refresh(), Status::ok);
    ASSERT_EQ(component.notify_idle(), Status::ok);
    if (i % 7 == 0) wiring.in->read(&n, sizeof n);  // the queue fills and wraps
  }
  EXPECT_EQ(allocations() - before, 0u);
  EXPECT_EQ(component.notifications_sent(), 30'001u);
}

TEST(NotificationAllocations, AutoNotificationsOfARunningContextAllocateNothing) {
  Notifier component;
  Wiring wiring(component, true);
  Lifecycle lifecycle(component);
  ExecutionContext context(settings_of("alloc", Nanos{200'000}));
  context.add(lifecycle);
  std::vector<std::string> warnings;
  context.start(warnings);
  ASSERT_EQ(context.command(lifecycle, LifecycleCommand::initialize), ReturnCode::ok);
  ASSERT_EQ(context.command(lifecycle, LifecycleCommand::activate), ReturnCode::ok);
  ASSERT_TRUE(eventually([&] { return component.cycles.load() >= 20; }));  // start-up is over
  const std::uint64_t before = allocations();
  const std::uint64_t sent_before = component.notifications_sent();
  ASSERT_TRUE(eventually([&] { return component.notifications_sent() >= sent_before + 3000; }));
  const std::uint64_t allocated = allocations() - before;
  context.command(lifecycle, LifecycleCommand::deactivate);
  context.stop();
  EXPECT_EQ(allocated, 0u);
}

}  // namespace
}  // namespace polyport
