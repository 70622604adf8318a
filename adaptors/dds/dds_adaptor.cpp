#include "dds_adaptor.hpp"

#include <algorithm>

#include "polyport/runtime/model.hpp"

namespace polyport::dds {

namespace {

constexpr std::string_view kRequestHeader = "polyport::rpc::RequestHeader";
constexpr std::string_view kReplyHeader = "polyport::rpc::ReplyHeader";

const Type* struct_of(const Type* type) {
  if (type == nullptr) return nullptr;
  const Type& t = type->resolved();
  return t.kind == TypeKind::structure ? &t : nullptr;
}

}  // namespace

std::string dds_type_name(const std::string& registry_name) {
  return registry_name.rfind("::", 0) == 0 ? registry_name.substr(2) : registry_name;
}

std::unique_ptr<DdsAdaptor> DdsAdaptor::create(const Subcomponent& subcomponent, const TypeRegistry& types,
                                               Diagnostics& diagnostics) {
  const ComponentProfile& profile = subcomponent.profile;
  auto adaptor = std::make_unique<DdsAdaptor>(subcomponent.name, profile.model);
  adaptor->settings_ = dds_settings(profile);
  adaptor->max_calls_in_flight_ = adaptor->settings_->max_calls_in_flight;
  adaptor->call_timeout_ns_ = adaptor->settings_->call_timeout_ns;
  bool ok = true;
  for (const PortSpec& spec : profile.ports) {
    switch (spec.kind) {
      case PortKind::data:
        ok = adaptor->add_data_port(spec, types, diagnostics) && ok;
        break;
      case PortKind::service:
        ok = adaptor->add_service_port(spec, types, diagnostics) && ok;
        break;
      case PortKind::event:
        diagnostics.error(spec.where, {},
                          "port '" + spec.name + "': model '" + profile.model +
                              "' has no event ports (DDS has topics: use a data port)");
        ok = false;
        break;
    }
  }
  if (!ok) return nullptr;
  return adaptor;
}

const Codec* DdsAdaptor::codec_for(const Type& type, const PortSpec& spec, Diagnostics& diagnostics) {
  Result<std::unique_ptr<Codec>> codec = make_cdr_codec(type, WireFormat::xcdr1);
  if (!codec) {
    diagnostics.error(spec.where, {},
                      "port '" + spec.name + "': type '" + type.name + "' cannot be carried as XCDR1: " +
                          codec.error().message);
    return nullptr;
  }
  codecs_.push_back(std::move(codec).value());
  return codecs_.back().get();
}

bool DdsAdaptor::add_data_port(const PortSpec& spec, const TypeRegistry& types, Diagnostics& diagnostics) {
  const Type* type = types.find(spec.data_type);
  if (!type) {
    diagnostics.error(spec.where, {}, "unknown type '" + spec.data_type + "'");
    return false;
  }
  const Codec* codec = codec_for(*type, spec, diagnostics);
  if (codec == nullptr) return false;
  const std::uint32_t max_bytes = std::min(codec->max_wire_size(type->size + kTailBytes), kMaxSampleBytes);

  const PortSettings& port = settings_->port(spec.name);
  Topic topic;
  topic.topic = port.topic.empty() ? spec.name : port.topic;
  topic.type_name = dds_type_name(spec.data_type);
  topic.qos = port.qos;
  topic.max_size = max_bytes;
  topic.bounded = bounded(*type, max_bytes);
  if (spec.direction == PortDirection::output) {
    topic.out = &add_port<DataOutPort>(spec.name, spec.kind, type, max_bytes);
    topic.out->set_wire_format(WireFormat::xcdr1, codec);
  } else {
    // Push mode: the interceptor sets the sink; policy and depth are not used.
    topic.in = &add_port<DataInPort>(spec.name, spec.kind, type, max_bytes, QueuePolicy::data, 1U);
    topic.in->set_wire_format(WireFormat::xcdr1, codec);
  }
  topics_.push_back(std::move(topic));
  return true;
}

bool DdsAdaptor::add_service_port(const PortSpec& spec, const TypeRegistry& types, Diagnostics& diagnostics) {
  const PortSettings& port = settings_->port(spec.name);
  Service service;
  service.base_topic = port.topic.empty() ? spec.name : port.topic;
  service.qos = port.qos;
  const bool ok = add_rpc_service(
      *this, spec, types, max_calls_in_flight_, "a DDS service port", "topic",
      [&](const OperationSpec& op, bool reply, RpcLayout& layout) {
        return rpc_layout(spec, service.base_topic, op, reply, types, diagnostics, layout);
      },
      diagnostics, service);
  if (ok) services_.push_back(std::move(service));
  return ok;
}

bool DdsAdaptor::rpc_layout(const PortSpec& spec, const std::string& base_topic, const OperationSpec& op, bool reply,
                            const TypeRegistry& types, Diagnostics& diagnostics, RpcLayout& layout) {
  const OperationTypes* wire_types = settings_->port(spec.name).operation(op.name);
  const std::string wire_name =
      wire_types == nullptr ? std::string() : reply ? wire_types->reply_type : wire_types->request_type;
  const std::string& payload_name = reply ? op.reply_type : op.request_type;
  const std::string_view header_name = reply ? kReplyHeader : kRequestHeader;
  const std::string what = "operation '" + op.name + "' of port '" + spec.name + "': " +
                           (reply ? "dds_reply" : "dds_request") + " '" + wire_name + "'";
  auto fail = [&](const std::string& message) {
    diagnostics.error(op.where, {}, what + " " + message);
    return false;
  };

  const Type* header = nullptr;
  const std::string wrong = check_rpc_struct(types.find(wire_name), header_name, payload_name, types,
                                             "config/types/polyport_rpc.idl", layout, header);
  if (!wrong.empty()) return fail(wrong);
  const Type* wire = layout.type;
  // The header as polyport_rpc.idl declares it: SampleIdentity first, then (replies) status.
  const Type* identity = header->fields.empty() ? nullptr : struct_of(header->fields[0].type);
  const bool identity_ok = identity != nullptr && identity->fields.size() == 2 &&
                           identity->fields[0].type->size == 16 &&
                           identity->fields[1].type->resolved().kind == TypeKind::uint64;
  const bool status_ok = !reply || (header->fields.size() == 2 &&
                                    header->fields[1].type->resolved().kind == TypeKind::int32);
  if (!identity_ok || !status_ok) {
    return fail("has a " + std::string(header_name) + " that is not the one in config/types/polyport_rpc.idl");
  }
  const std::uint32_t header_offset = wire->fields[0].offset;
  const std::uint32_t identity_offset = header_offset + header->fields[0].offset;
  layout.caller_offset = identity_offset + identity->fields[0].offset;
  layout.caller_size = 16;
  layout.sequence_offset = identity_offset + identity->fields[1].offset;
  if (reply) layout.status_offset = header_offset + header->fields[1].offset;
  layout.reply = reply;

  layout.type_name = dds_type_name(wire->name);
  layout.address = base_topic + "/" + op.name + (reply ? "/reply" : "/request");
  layout.codec = codec_for(*wire, spec, diagnostics);
  if (layout.codec == nullptr) return false;
  layout.max_size = std::min(layout.codec->max_wire_size(wire->size), kMaxSampleBytes);
  return true;
}

}  // namespace polyport::dds
