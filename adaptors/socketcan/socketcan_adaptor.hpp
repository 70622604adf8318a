// The application-side face of a SocketCAN component: one typed port per DBC message, whose
// wire format is the frame's data bytes (WireFormat::dbc) with the message's codec. A
// connection between two CAN ports of the same message is a passthrough (the frame's bytes
// as they are); to an in-process or another model's port it decodes / encodes the signals.
//
// Directions are the CAN node's view: an `output` port carries the frames the bus sends with
// the message's id (the interceptor receives them and writes the port), an `input` port the
// frames polyport sends with that id (the interceptor writes them from the port's sink).
//
// An optional output event port of type polyport::CanBusEvent (config/types/can_bus_event.idl,
// flat layout: CanBusEventSample below) carries the bus's error frames and the interface's
// losses and returns; the interceptor writes it on the reactor thread.
//
// Ownership: the adaptor owns its ports and codecs; the DbcMessage belongs to the type
// registry; the interceptor keeps raw pointers to the ports for as long as the proxy lives.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "polyport/base/clock.hpp"
#include "polyport/base/diagnostics.hpp"
#include "polyport/codecs/codec.hpp"
#include "polyport/profile/profile.hpp"
#include "polyport/runtime/component.hpp"
#include "polyport/types/dbc.hpp"
#include "polyport/types/types.hpp"
#include "socketcan_settings.hpp"

namespace polyport::socketcan {

// The flat sample of polyport::CanBusEvent; create() checks that the registered type has
// exactly this layout.
struct CanBusEventSample {
  std::int32_t kind = 0;   // polyport::CanBusEventKind
  std::int32_t state = 0;  // polyport::CanBusState
  std::uint32_t error_class = 0;
  std::uint8_t controller = 0;
  std::uint8_t protocol = 0;
  std::uint8_t tx_errors = 0;
  std::uint8_t rx_errors = 0;
};
static_assert(sizeof(CanBusEventSample) == 16);
inline constexpr const char* kCanBusEventType = "polyport::CanBusEvent";

// The enumerators of polyport::CanBusEventKind and polyport::CanBusState, in IDL order.
enum class CanBusEventKind : std::int32_t {
  error_frame, error_warning, error_passive, bus_off, restarted, error_active,
  interface_missing, interface_back, interface_down, interface_up,
};
enum class CanBusState : std::int32_t { active, warning, passive, bus_off, down, missing };

// What an error frame says (linux/can/error.h): its event and the bus state after it. `data`
// is the frame's 8 data bytes; `state` the state before, kept by a frame that changes none.
struct ErrorFrameMeaning {
  CanBusEventKind kind = CanBusEventKind::error_frame;
  CanBusState state = CanBusState::active;
};
ErrorFrameMeaning classify_error_frame(std::uint32_t error_class, const std::uint8_t* data, CanBusState state) noexcept;
// The event of an error frame or of the interface (`data` null: no frame) as its port carries it.
CanBusEventSample bus_event(CanBusEventKind kind, CanBusState state, std::uint32_t error_class,
                            const std::uint8_t* data) noexcept;

class SocketCanAdaptor final : public Component {
 public:
  // One port's message.
  struct Message {
    const DbcMessage* dbc = nullptr;  // frame id, length, FD or not
    std::string name;                 // the registry's name of its struct ("vehicle::EngineData")
    std::uint32_t can_id = 0;         // canid_t: CAN_EFF_FLAG for 29-bit ids
    DataOutPort* out = nullptr;       // `output`: frames received from the bus
    DataInPort* in = nullptr;         // `input`: frames polyport sends
    // `input` only: the broadcast manager sends the last sample every cycle_ms (the
    // profile's <cycle_ms>, else the DBC's GenMsgCycleTime); 0: each sample once.
    std::uint32_t cycle_ms = 0;
  };

  SocketCanAdaptor(std::string name, std::string model) : Component(std::move(name), std::move(model)) {}

  // Creates the profile's ports with their codecs; problems at the profile's locations,
  // null when there was one.
  static std::unique_ptr<SocketCanAdaptor> create(const Subcomponent& subcomponent, const TypeRegistry& types,
                                                  Diagnostics& diagnostics);

  const std::vector<Message>& messages() const noexcept { return messages_; }
  const SocketCanSettings& settings() const noexcept { return *settings_; }
  // The polyport::CanBusEvent port; null when the profile has none.
  DataOutPort* bus_events() const noexcept { return bus_events_; }

  // What became of a data frame from the bus (error frames go to classify_error_frame).
  enum class Arrival : std::uint8_t { delivered, unknown_id, bad_length };
  struct Received {
    Arrival arrival = Arrival::unknown_id;
    std::uint32_t message = 0;  // its index in messages(), unless unknown_id
  };
  // Finds the output port of `can_id` (11 or 29 bits, CAN_EFF_FLAG for 29; the RTR and error
  // bits are ignored), checks the frame's length against its DBC message and writes the data
  // bytes into the port. The receive thread; no allocation, no lock. The live decode path:
  // tests/fuzz/fuzz_can_receive.cpp.
  Received receive(std::uint32_t can_id, const std::uint8_t* data, std::uint8_t length,
                   MonoTime t_source) const noexcept;
  // The output ports' (can_id, index in messages()), sorted by id: what the kernel's
  // filters pass.
  const std::vector<std::pair<std::uint32_t, std::uint32_t>>& received_ids() const noexcept { return by_can_id_; }

 private:
  bool add_message(const PortSpec& spec, const TypeRegistry& types, Diagnostics& diagnostics);
  bool add_bus_events(const PortSpec& spec, const Type& type, Diagnostics& diagnostics);

  std::shared_ptr<const SocketCanSettings> settings_;
  std::vector<Message> messages_;
  DataOutPort* bus_events_ = nullptr;
  std::vector<std::unique_ptr<Codec>> codecs_;
  std::vector<std::pair<std::uint32_t, std::uint32_t>> by_can_id_;
};

}  // namespace polyport::socketcan
