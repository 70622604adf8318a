// A SocketCAN component's bus events reach an in-process component (label vm, a guest with
// vcan0): an error frame with CAN_ERR_BUSOFF put on the bus by cansend becomes a
// polyport::CanBusEvent on the CAN component's event port, the in-process BusWatcher
// (tests/socketcan/can_components.cpp) takes it on its own event port and counts it.
#include <gtest/gtest.h>

#include <cstdint>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "../support/engine_fixture.hpp"
#include "../support/eventually.hpp"
#include "can_peer.hpp"
#include "inproc_model.hpp"
#include "socketcan_model.hpp"

namespace polyport {
namespace {

using test::cansend;

class CanEventsInproc : public test::EngineFixture {
 protected:
  CanEventsInproc() : EngineFixture(POLYPORT_TEST_DATA "/socketcan", LoadOptions{{POLYPORT_PLUGIN_DIR}}) {
    models.add(std::make_unique<inproc::InprocModel>());
    models.add(std::make_unique<socketcan::SocketCanModel>());
  }
};

TEST_F(CanEventsInproc, AnInProcessComponentCountsBusOffEvents) {
  ASSERT_TRUE(build("watcher_app.xml")) << problems();
  auto probe = engine.add_probe("watcher.bus_offs", 4);
  ASSERT_TRUE(probe) << probe.error().message;
  std::vector<std::string> warnings;
  auto started = engine.start(warnings);
  ASSERT_TRUE(started) << started.error().message;

  std::int64_t count = -1;
  const auto count_is = [&](std::int64_t want) {
    return test::eventually(
        [&] {
          std::int64_t value = 0;
          if (probe.value()->read(&value, sizeof value) == Status::ok) count = value;
          return count == want;
        },
        std::chrono::seconds(5));
  };
  ASSERT_TRUE(count_is(0)) << "the watcher did not run; last count " << count;
  ASSERT_EQ(cansend("vcan0", "20000040#0000000000000000"), "");  // CAN_ERR_BUSOFF
  EXPECT_TRUE(count_is(1)) << "the watcher counted " << count << " bus-off events";
  // A warning is no bus-off: once the CAN thread has written it as an event and the watcher
  // has run twice since, the count must still be 1.
  ASSERT_EQ(cansend("vcan0", "20000004#0008000000006000"), "");
  const auto warnings_seen = [&] {
    nlohmann::json out;
    engine.find_interceptor("bus0")->describe(out);
    return out["socketcan"]["bus"]["kinds"]["error_warning"] == 1;
  };
  ASSERT_TRUE(test::eventually(warnings_seen, std::chrono::seconds(5))) << "the warning frame did not arrive";
  const std::uint64_t runs = engine.find_interceptor("watcher")->status().executions;
  ASSERT_TRUE(test::eventually(
      [&] { return engine.find_interceptor("watcher")->status().executions >= runs + 2; }, std::chrono::seconds(5)))
      << "the watcher stopped running";
  EXPECT_TRUE(count_is(1)) << "the watcher counted " << count << " bus-off events after a warning";
  ASSERT_EQ(cansend("vcan0", "20000040#0000000000000000"), "");
  EXPECT_TRUE(count_is(2)) << "the watcher counted " << count << " bus-off events";
  engine.stop();
}

}  // namespace
}  // namespace polyport
