#include "socketcan_adaptor.hpp"

#include <algorithm>
#include <cstdio>

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
  return adaptor;
}

bool SocketCanAdaptor::add_message(const PortSpec& spec, const TypeRegistry& types, Diagnostics& diagnostics) {
  const std::string what = std::string(spec.kind == PortKind::event ? "event" : "data") + " port '" + spec.name + "'";
  if (spec.data_type.empty()) {
    diagnostics.error(spec.where, {},
                      what + ": a CAN port carries the frames of one DBC message; name it in <data_type> "
                             "(events without a payload, e.g. bus-off, are planned)");
    return false;
  }
  const Type* type = types.find(spec.data_type);
  if (type == nullptr) {
    diagnostics.error(spec.where, {}, "unknown type '" + spec.data_type + "'");
    return false;
  }
  const Type& resolved = type->resolved();
  const DbcMessage* dbc = resolved.dbc;
  if (dbc == nullptr) {
    diagnostics.error(spec.where, {},
                      what + ": type '" + spec.data_type +
                          "' is not a DBC message; a CAN port's <data_type> is a message of a .dbc file in <types>");
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
  }
  messages_.push_back(std::move(message));
  return true;
}

}  // namespace polyport::socketcan
