#include "lcm_adaptor.hpp"

#include <algorithm>
#include <cstring>

#include "polyport/runtime/model.hpp"
#include "polyport/runtime/port.hpp"

namespace polyport::lcm {

namespace {

constexpr std::string_view kRequestHeader = "polyport::rpc_request_header_t";
constexpr std::string_view kReplyHeader = "polyport::rpc_reply_header_t";

bool is_kind(const Field& field, TypeKind kind) { return field.type->resolved().kind == kind; }

}  // namespace

MessageCheck check_message(const LcmAdaptor::Channel& channel, const void* data, std::uint32_t size) noexcept {
  if (size < channel.fingerprint.size()) return MessageCheck::too_short;
  if (std::memcmp(data, channel.fingerprint.data(), channel.fingerprint.size()) != 0) {
    return MessageCheck::wrong_fingerprint;
  }
  if (size > channel.max_size) return MessageCheck::too_large;
  return MessageCheck::ok;
}

std::string lcm_type_name(const std::string& registry_name) {
  std::string out = registry_name.rfind("::", 0) == 0 ? registry_name.substr(2) : registry_name;
  for (std::size_t at = out.find("::"); at != std::string::npos; at = out.find("::", at)) out.replace(at, 2, ".");
  return out;
}

std::unique_ptr<LcmAdaptor> LcmAdaptor::create(const Subcomponent& subcomponent, const TypeRegistry& types,
                                               Diagnostics& diagnostics) {
  const ComponentProfile& profile = subcomponent.profile;
  auto adaptor = std::make_unique<LcmAdaptor>(subcomponent.name, profile.model);
  adaptor->settings_ = lcm_settings(profile);
  bool ok = true;
  for (const PortSpec& spec : profile.ports) {
    if (spec.kind == PortKind::service) {
      ok = adaptor->add_service_port(spec, types, diagnostics) && ok;
    } else {
      ok = adaptor->add_channel(spec, types, diagnostics) && ok;
    }
  }
  if (!ok) return nullptr;
  return adaptor;
}

bool LcmAdaptor::add_channel(const PortSpec& spec, const TypeRegistry& types, Diagnostics& diagnostics) {
  const std::string what = std::string(spec.kind == PortKind::event ? "event" : "data") + " port '" + spec.name + "'";
  if (spec.data_type.empty()) {
    diagnostics.error(spec.where, {}, what + ": an LCM channel carries a message; name its .lcm type in <data_type>");
    return false;
  }
  const Type* type = types.find(spec.data_type);
  if (type == nullptr) {
    diagnostics.error(spec.where, {}, "unknown type '" + spec.data_type + "'");
    return false;
  }
  Result<std::unique_ptr<Codec>> codec = make_lcm_codec(*type);
  if (!codec) {
    diagnostics.error(spec.where, {}, what + ": " + codec.error().message);
    return false;
  }
  const Type& resolved = type->resolved();
  const std::uint32_t limit = settings_->max_message_bytes;
  const std::uint32_t max_bytes = std::min(codec.value()->max_wire_size(resolved.size + limit), limit);

  Channel channel;
  channel.channel = settings_->channel(spec.name);
  channel.type_name = lcm_type_name(resolved.name);
  for (std::size_t i = 0; i < 8; ++i) {
    channel.fingerprint[i] = static_cast<std::byte>(resolved.lcm_fingerprint >> (56 - 8 * i));
  }
  channel.max_size = max_bytes;
  const Codec* codec_ptr = codec.value().get();
  codecs_.push_back(std::move(codec).value());
  if (spec.direction == PortDirection::output) {
    channel.out = &add_port<DataOutPort>(spec.name, spec.kind, type, max_bytes);
    channel.out->set_wire_format(WireFormat::lcm, codec_ptr);
  } else {
    // Push mode: the interceptor sets the sink; policy and depth are not used.
    channel.in = &add_port<DataInPort>(spec.name, spec.kind, type, max_bytes, QueuePolicy::data, 1U);
    channel.in->set_wire_format(WireFormat::lcm, codec_ptr);
  }
  channels_.push_back(std::move(channel));
  return true;
}

bool LcmAdaptor::add_service_port(const PortSpec& spec, const TypeRegistry& types, Diagnostics& diagnostics) {
  RpcService service;
  const bool ok = add_rpc_service(
      *this, spec, types, settings_->max_calls_in_flight, "an LCM service port", "channel",
      [&](const OperationSpec& op, bool reply, RpcLayout& layout) {
        return rpc_layout(spec, op, reply, types, diagnostics, layout);
      },
      diagnostics, service);
  if (ok) services_.push_back(std::move(service));
  return ok;
}

bool LcmAdaptor::rpc_layout(const PortSpec& spec, const OperationSpec& op, bool reply, const TypeRegistry& types,
                            Diagnostics& diagnostics, RpcLayout& layout) {
  const OperationSettings* settings = settings_->operation(spec.name, op.name);
  const std::string wire_name =
      settings == nullptr ? std::string() : reply ? settings->reply_type : settings->request_type;
  const std::string& payload_name = reply ? op.reply_type : op.request_type;
  const std::string_view header_name = reply ? kReplyHeader : kRequestHeader;
  const std::string what = "operation '" + op.name + "' of port '" + spec.name + "': " +
                           (reply ? "lcm_reply" : "lcm_request") + " '" + wire_name + "'";
  auto fail = [&](const std::string& message) {
    diagnostics.error(op.where, {}, what + " " + message);
    return false;
  };

  const Type* header = nullptr;
  const std::string wrong = check_rpc_struct(types.find(wire_name), header_name, payload_name, types,
                                             "config/types/polyport_rpc.lcm", layout, header);
  if (!wrong.empty()) return fail(wrong);
  const Type* wire = layout.type;
  // The header as polyport_rpc.lcm declares it: client id and sequence, then (replies) status.
  const std::size_t fields = reply ? 3 : 2;
  const bool header_ok = header->fields.size() == fields && is_kind(header->fields[0], TypeKind::int64) &&
                         is_kind(header->fields[1], TypeKind::int64) &&
                         (!reply || is_kind(header->fields[2], TypeKind::int32));
  if (!header_ok) {
    return fail("has a " + std::string(header_name) + " that is not the one in config/types/polyport_rpc.lcm");
  }
  const std::uint32_t header_offset = wire->fields[0].offset;
  layout.caller_offset = header_offset + header->fields[0].offset;
  layout.caller_size = 8;
  layout.sequence_offset = header_offset + header->fields[1].offset;
  if (reply) layout.status_offset = header_offset + header->fields[2].offset;
  layout.reply = reply;

  const std::string written =
      settings == nullptr ? std::string() : reply ? settings->reply_channel : settings->request_channel;
  layout.address =
      !written.empty() ? written : settings_->channel(spec.name) + "/" + op.name + (reply ? "/reply" : "/request");
  if (const std::string why = bad_channel(layout.address); !why.empty()) {
    diagnostics.error(op.where, {},
                      "operation '" + op.name + "' of port '" + spec.name + "': " + (reply ? "reply" : "request") +
                          " " + why + " (name it with " + (reply ? "lcm_reply_channel" : "lcm_request_channel") + ")");
    return false;
  }
  layout.type_name = lcm_type_name(wire->name);
  Result<std::unique_ptr<Codec>> codec = make_lcm_codec(*wire);
  if (!codec) return fail(codec.error().message);
  layout.codec = codec.value().get();
  layout.max_size = std::min(layout.codec->max_wire_size(wire->size), settings_->max_message_bytes);
  codecs_.push_back(std::move(codec).value());
  return true;
}

}  // namespace polyport::lcm
