#include "cyclonedds_adaptor.hpp"

#include <algorithm>

namespace polyport::cyclonedds {

std::unique_ptr<CycloneAdaptor> CycloneAdaptor::create(const Subcomponent& subcomponent, const TypeRegistry& types,
                                                       Diagnostics& diagnostics) {
  const ComponentProfile& profile = subcomponent.profile;
  auto adaptor = std::make_unique<CycloneAdaptor>(subcomponent.name);
  const std::size_t errors_before = diagnostics.error_count();
  for (const PortSpec& spec : profile.ports) {
    if (spec.kind != PortKind::data) {
      diagnostics.error(spec.where, {},
                        "port '" + spec.name + "': model 'cyclonedds' supports data ports only (not " +
                            std::string(to_string(spec.kind)) + " ports yet)");
      continue;
    }
    const Type* type = types.find(spec.data_type);
    if (!type) {
      diagnostics.error(spec.where, {}, "unknown type '" + spec.data_type + "'");
      continue;
    }
    Result<std::unique_ptr<Codec>> codec = make_cdr_codec(*type, WireFormat::xcdr1);
    if (!codec) {
      diagnostics.error(spec.where, {},
                        "port '" + spec.name + "': type '" + spec.data_type + "' cannot be carried as XCDR1: " +
                            codec.error().message);
      continue;
    }
    const Codec* codec_ptr = codec.value().get();
    adaptor->codecs_.push_back(std::move(codec).value());
    const std::uint32_t max_bytes = std::min(codec_ptr->max_wire_size(type->size + kTailBytes), kMaxSampleBytes);

    Topic topic;
    topic.topic = spec.topic.empty() ? spec.name : spec.topic;
    topic.type_name = spec.data_type.rfind("::", 0) == 0 ? spec.data_type.substr(2) : spec.data_type;
    if (spec.direction == PortDirection::output) {
      topic.out = &adaptor->add_port<DataOutPort>(spec.name, spec.kind, type, max_bytes);
      topic.out->set_wire_format(WireFormat::xcdr1, codec_ptr);
    } else {
      // Push mode: the interceptor sets the sink; policy and depth are not used.
      topic.in = &adaptor->add_port<DataInPort>(spec.name, spec.kind, type, max_bytes, QueuePolicy::data, 1U);
      topic.in->set_wire_format(WireFormat::xcdr1, codec_ptr);
    }
    adaptor->topics_.push_back(std::move(topic));
  }
  if (diagnostics.error_count() != errors_before) return nullptr;
  return adaptor;
}

}  // namespace polyport::cyclonedds
