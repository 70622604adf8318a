// An in-process component of the SocketCAN tests, loaded through the in-process model like
// any plugin: it reacts to the bus events of a SocketCAN component (polyport::CanBusEvent,
// config/types/can_bus_event.idl) on an event port.
#include <cstdint>

#include "polyport/runtime/component_api.hpp"

namespace polyport::test {

// The flat layout of polyport::CanBusEvent.
struct CanBusEvent {
  std::int32_t kind;   // polyport::CanBusEventKind
  std::int32_t state;  // polyport::CanBusState
  std::uint32_t error_class;
  std::uint8_t controller;
  std::uint8_t protocol;
  std::uint8_t tx_errors;
  std::uint8_t rx_errors;
};
constexpr std::int32_t kCanBusOff = 3;  // CAN_BUS_OFF

// Counts the bus-off events it takes and publishes the count every cycle.
class BusWatcher final : public ComponentBase {
 public:
  ReturnCode onExecute() override {
    CanBusEvent event{};
    while (events_.take(event) == Status::ok) {
      if (event.kind == kCanBusOff) ++bus_offs_;
    }
    count_.write(bus_offs_);
    return ReturnCode::ok;
  }

 private:
  EventInPort<CanBusEvent> events_{*this, "bus"};
  OutPort<std::int64_t> count_{*this, "bus_offs"};
  std::int64_t bus_offs_ = 0;
};

POLYPORT_COMPONENTS(POLYPORT_COMPONENT(BusWatcher));

}  // namespace polyport::test
