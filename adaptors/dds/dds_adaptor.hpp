// The application-side face of a DDS component, for both DDS models (cyclonedds, fastdds):
// the bytes on the DDS wire are the same XCDR1 whichever SDK carries them, so one adaptor
// serves both and a connection between two DDS ports of one type is a passthrough, across
// vendors and domains alike.
//
//  - data ports: one per topic, typed from the registry, speaking XCDR1 (encapsulation header
//    included); a connection to an in-process port decodes/encodes on the forwarding path.
//  - service ports: one per service, with a request and a reply topic per operation
//    (`<topic>/<operation>/request` and `.../reply`) whose structs put a correlation header
//    (config/types/polyport_rpc.idl) before the payload. The adaptor checks those structs and
//    records where the header fields and the payload sit; core's service bridges
//    (polyport/runtime/service_bridge.hpp) do the calls over the interceptor's topics.
//
// Ownership: the adaptor owns its ports and codecs (ports keep raw pointers to them).
// Directions are the DDS application's view: an `output` port carries what the application
// publishes (the interceptor's reader writes it), an `input` port what polyport publishes for
// it (the interceptor's writer is the port's sink); a `provided` service port is served by the
// DDS application, a `required` one calls into the application.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "dds_settings.hpp"
#include "polyport/codecs/codec.hpp"
#include "polyport/runtime/component.hpp"
#include "polyport/base/diagnostics.hpp"
#include "polyport/profile/profile.hpp"
#include "polyport/runtime/service_bridge.hpp"
#include "polyport/types/types.hpp"

namespace polyport::dds {

class DdsAdaptor final : public Component {
 public:
  // One DDS topic of a data port.
  struct Topic {
    std::string topic;      // DDS topic name
    std::string type_name;  // DDS type name, as idlc / fastddsgen spell it ("module::Struct")
    DdsQos qos;
    std::uint32_t max_size = 0;  // largest encoded sample, header included
    bool bounded = false;        // no unbounded member: max_size is the type's own bound
    DataOutPort* out = nullptr;  // set for `output` ports (the application publishes)
    DataInPort* in = nullptr;    // set for `input` ports (polyport publishes)
  };

  // The request / reply structs of an operation (config/types/polyport_rpc.idl); the
  // address is the topic, the caller the request writer's GUID (octet[16]).
  using RpcLayout = polyport::RpcLayout;
  using Operation = RpcOperation;

  struct Service : RpcService {
    std::string base_topic;
    DdsQos qos;
  };

  // Samples larger than this (encoded) are not carried.
  static constexpr std::uint32_t kMaxSampleBytes = 1U << 20;
  // Room for unbounded strings and sequences beyond a type's fixed part.
  static constexpr std::uint32_t kTailBytes = 64U << 10;
  // Whether `max_size` is the type's own largest encoding (no unbounded string or sequence,
  // not capped at kMaxSampleBytes): what EndpointSpec::bounded says.
  static bool bounded(const Type& type, std::uint32_t max_size) noexcept {
    return !has_unbounded(type) && max_size < kMaxSampleBytes;
  }

  DdsAdaptor(std::string name, std::string model) : Component(std::move(name), std::move(model)) {}

  // Creates the profile's ports with their codecs. Problems are reported at the profile's
  // locations; returns null when there was one.
  static std::unique_ptr<DdsAdaptor> create(const Subcomponent& subcomponent, const TypeRegistry& types,
                                            Diagnostics& diagnostics);

  const std::vector<Topic>& topics() const noexcept { return topics_; }
  const std::vector<Service>& services() const noexcept { return services_; }
  std::uint32_t max_calls_in_flight() const noexcept { return max_calls_in_flight_; }
  std::int64_t call_timeout_ns() const noexcept { return call_timeout_ns_; }
  const DdsSettings& settings() const noexcept { return *settings_; }

 private:
  bool add_data_port(const PortSpec& spec, const TypeRegistry& types, Diagnostics& diagnostics);
  bool add_service_port(const PortSpec& spec, const TypeRegistry& types, Diagnostics& diagnostics);
  // Checks one request/reply struct against the convention and fills `layout`.
  bool rpc_layout(const PortSpec& spec, const std::string& base_topic, const OperationSpec& operation, bool reply,
                  const TypeRegistry& types, Diagnostics& diagnostics, RpcLayout& layout);
  const Codec* codec_for(const Type& type, const PortSpec& spec, Diagnostics& diagnostics);

  std::shared_ptr<const DdsSettings> settings_;
  std::vector<Topic> topics_;
  std::vector<Service> services_;
  std::vector<std::unique_ptr<Codec>> codecs_;
  std::uint32_t max_calls_in_flight_ = 16;
  std::int64_t call_timeout_ns_ = 1'000'000'000;
};

// The DDS type name for a registry name: without a leading "::".
std::string dds_type_name(const std::string& registry_name);

}  // namespace polyport::dds
