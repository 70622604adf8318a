#include "lcm_adaptor.hpp"

#include <algorithm>
#include <cstring>

#include "polyport/runtime/port.hpp"

namespace polyport::lcm {

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
      diagnostics.error(spec.where, {},
                        "service port '" + spec.name + "': model '" + profile.model +
                            "' has no service ports yet (planned: a request and a reply channel per operation)");
      ok = false;
      continue;
    }
    ok = adaptor->add_channel(spec, types, diagnostics) && ok;
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

}  // namespace polyport::lcm
