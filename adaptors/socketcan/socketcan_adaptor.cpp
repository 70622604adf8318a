#include "socketcan_adaptor.hpp"

#include <linux/can.h>
#include <linux/can/error.h>

#include <algorithm>
#include <cstddef>
#include <cstdio>
#include <iterator>

#include "polyport/runtime/port.hpp"

namespace polyport::socketcan {

namespace {

std::string hex_id(std::uint32_t can_id) {
  char text[16];
  std::snprintf(text, sizeof text, "0x%X", can_id & kCanExtendedIdMask);
  return text;
}

}  // namespace

std::unique_ptr<SocketCanAdaptor> SocketCanAdaptor::create(const Subcomponent& subcomponent, const TypeRegistry& types,
                                                           Diagnostics& diagnostics) {
  const ComponentProfile& profile = subcomponent.profile;
  auto adaptor = std::make_unique<SocketCanAdaptor>(subcomponent.name, profile.model);
  adaptor->settings_ = socketcan_settings(profile);
  bool ok = true;
  for (const PortSpec& spec : profile.ports) {
    if (spec.kind == PortKind::service) {
      diagnostics.error(spec.where, {},
                        "service port '" + spec.name + "': model '" + profile.model +
                            "' has no service ports yet (planned: a request and a response message per operation)");
      ok = false;
      continue;
    }
    ok = adaptor->add_message(spec, types, diagnostics) && ok;
  }
  if (!ok) return nullptr;
  for (std::uint32_t i = 0; i < adaptor->messages_.size(); ++i) {
    if (adaptor->messages_[i].out != nullptr) adaptor->by_can_id_.emplace_back(adaptor->messages_[i].can_id, i);
  }
  std::sort(adaptor->by_can_id_.begin(), adaptor->by_can_id_.end());
  return adaptor;
}

SocketCanAdaptor::Received SocketCanAdaptor::receive(std::uint32_t can_id, const std::uint8_t* data,
                                                     std::uint8_t length, MonoTime t_source) const noexcept {
  // The id as the table spells it: 11 or 29 bits, CAN_EFF_FLAG for 29-bit ids.
  const std::uint32_t key =
      (can_id & CAN_EFF_FLAG) != 0 ? (can_id & (CAN_EFF_FLAG | CAN_EFF_MASK)) : (can_id & CAN_SFF_MASK);
  const auto found = std::lower_bound(by_can_id_.begin(), by_can_id_.end(), std::pair<std::uint32_t, std::uint32_t>{key, 0});
  if (found == by_can_id_.end() || found->first != key) return {Arrival::unknown_id, 0};
  const Message& message = messages_[found->second];
  if (length != message.dbc->length) return {Arrival::bad_length, found->second};
  (void)message.out->write(data, length, t_source);
  return {Arrival::delivered, found->second};
}

ErrorFrameMeaning classify_error_frame(std::uint32_t error_class, const std::uint8_t* data, CanBusState state) noexcept {
  ErrorFrameMeaning meaning{CanBusEventKind::error_frame, state};
  const std::uint8_t controller = data[1];
  if ((error_class & CAN_ERR_CRTL) != 0) {
    if ((controller & (CAN_ERR_CRTL_RX_PASSIVE | CAN_ERR_CRTL_TX_PASSIVE)) != 0) {
      meaning = {CanBusEventKind::error_passive, CanBusState::passive};
    } else if ((controller & (CAN_ERR_CRTL_RX_WARNING | CAN_ERR_CRTL_TX_WARNING)) != 0) {
      meaning = {CanBusEventKind::error_warning, CanBusState::warning};
    } else if ((controller & CAN_ERR_CRTL_ACTIVE) != 0) {
      meaning = {CanBusEventKind::error_active, CanBusState::active};
    }
  }
  if ((error_class & CAN_ERR_RESTARTED) != 0) meaning = {CanBusEventKind::restarted, CanBusState::active};
  if ((error_class & CAN_ERR_BUSOFF) != 0) meaning = {CanBusEventKind::bus_off, CanBusState::bus_off};
  return meaning;
}

CanBusEventSample bus_event(CanBusEventKind kind, CanBusState state, std::uint32_t error_class,
                            const std::uint8_t* data) noexcept {
  CanBusEventSample event;
  event.kind = static_cast<std::int32_t>(kind);
  event.state = static_cast<std::int32_t>(state);
  event.error_class = error_class;
  if (data != nullptr) {
    event.controller = data[1];
    event.protocol = data[2];
    event.tx_errors = data[6];
    event.rx_errors = data[7];
  }
  return event;
}

bool SocketCanAdaptor::add_message(const PortSpec& spec, const TypeRegistry& types, Diagnostics& diagnostics) {
  const std::string what = std::string(spec.kind == PortKind::event ? "event" : "data") + " port '" + spec.name + "'";
  if (spec.data_type.empty()) {
    diagnostics.error(spec.where, {},
                      what + ": a CAN port carries the frames of one DBC message; name it in <data_type> "
                             "(or polyport::CanBusEvent for the bus's errors, config/types/can_bus_event.idl)");
    return false;
  }
  const Type* type = types.find(spec.data_type);
  if (type == nullptr) {
    diagnostics.error(spec.where, {}, "unknown type '" + spec.data_type + "'");
    return false;
  }
  const Type& resolved = type->resolved();
  if (resolved.name == kCanBusEventType) return add_bus_events(spec, *type, diagnostics);
  const DbcMessage* dbc = resolved.dbc;
  if (dbc == nullptr) {
    diagnostics.error(spec.where, {},
                      what + ": type '" + spec.data_type +
                          "' is not a DBC message; a CAN port's <data_type> is a message of a .dbc file in <types> "
                          "(or polyport::CanBusEvent for the bus's errors, config/types/can_bus_event.idl)");
    return false;
  }
  if (dbc->fd && !settings_->fd) {
    diagnostics.error(spec.where, {},
                      what + ": message '" + resolved.name + "' (" + std::to_string(dbc->length) +
                          " bytes) is a CAN FD frame; say <socketcan><fd>true</fd></socketcan>");
    return false;
  }
  if (spec.direction == PortDirection::output) {
    for (const Message& other : messages_) {
      if (other.out != nullptr && other.can_id == dbc->can_id()) {
        diagnostics.error(spec.where, {},
                          what + ": id " + hex_id(dbc->can_id()) + " is already received by port '" +
                              other.out->name() + "'; one output port per message");
        return false;
      }
    }
  }
  Result<std::unique_ptr<Codec>> codec = make_dbc_codec(*type);
  if (!codec) {
    diagnostics.error(spec.where, {}, what + ": " + codec.error().message);
    return false;
  }
  // The wire sample is the frame's data (at most 64 bytes). The port's bound also holds the
  // decoded flat struct, because a probe or tracer on an output port takes the decoded
  // sample with the port's size.
  const std::uint32_t max_bytes = std::max<std::uint32_t>(dbc->length, resolved.size);

  Message message;
  message.dbc = dbc;
  message.name = resolved.name;
  message.can_id = dbc->can_id();
  const Codec* codec_ptr = codec.value().get();
  codecs_.push_back(std::move(codec).value());
  if (spec.direction == PortDirection::output) {
    message.out = &add_port<DataOutPort>(spec.name, spec.kind, type, max_bytes);
    message.out->set_wire_format(WireFormat::dbc, codec_ptr);
  } else {
    // Push mode: the interceptor sets the sink; policy and depth are not used.
    message.in = &add_port<DataInPort>(spec.name, spec.kind, type, max_bytes, QueuePolicy::data, 1U);
    message.in->set_wire_format(WireFormat::dbc, codec_ptr);
    message.cycle_ms = settings_->cycle(spec.name).value_or(dbc->cycle_time_ms);
  }
  messages_.push_back(std::move(message));
  return true;
}

bool SocketCanAdaptor::add_bus_events(const PortSpec& spec, const Type& type, Diagnostics& diagnostics) {
  const std::string what = std::string(spec.kind == PortKind::event ? "event" : "data") + " port '" + spec.name +
                           "' of type " + kCanBusEventType;
  if (spec.direction != PortDirection::output) {
    diagnostics.error(spec.where, {}, what + ": the bus's events come from the bus; say <usage>output</usage>");
    return false;
  }
  if (bus_events_ != nullptr) {
    diagnostics.error(spec.where, {}, what + ": port '" + bus_events_->name() + "' already carries them; one per component");
    return false;
  }
  // The layout CanBusEventSample mirrors (config/types/can_bus_event.idl).
  struct Expected {
    const char* name;
    std::uint32_t offset;
    std::uint32_t size;
  };
  constexpr Expected kFields[] = {
      {"kind", offsetof(CanBusEventSample, kind), 4},
      {"state", offsetof(CanBusEventSample, state), 4},
      {"error_class", offsetof(CanBusEventSample, error_class), 4},
      {"controller", offsetof(CanBusEventSample, controller), 1},
      {"protocol", offsetof(CanBusEventSample, protocol), 1},
      {"tx_errors", offsetof(CanBusEventSample, tx_errors), 1},
      {"rx_errors", offsetof(CanBusEventSample, rx_errors), 1},
  };
  const Type& resolved = type.resolved();
  bool same = resolved.kind == TypeKind::structure && resolved.size == sizeof(CanBusEventSample) &&
              resolved.fields.size() == std::size(kFields);
  for (const Expected& field : kFields) {
    const Field* found = same ? resolved.find_field(field.name) : nullptr;
    same = same && found != nullptr && found->offset == field.offset && found->type->resolved().size == field.size;
  }
  if (!same) {
    diagnostics.error(spec.where, {},
                      what + ": the type does not have the layout of config/types/can_bus_event.idl; "
                             "name that file in <types>");
    return false;
  }
  bus_events_ = &add_port<DataOutPort>(spec.name, spec.kind, &type, static_cast<std::uint32_t>(sizeof(CanBusEventSample)));
  return true;
}

}  // namespace polyport::socketcan
