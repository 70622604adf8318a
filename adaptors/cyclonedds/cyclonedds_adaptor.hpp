// The application-side face of a Cyclone DDS component: one data port per topic of its
// component profile, typed from the registry, speaking XCDR1 (the bytes on the DDS wire,
// encapsulation header included), so a connection to another DDS port of the same type is
// a passthrough and one to an in-process port decodes/encodes on the forwarding path.
//
// Ownership: the adaptor owns its ports and the CDR codec of each port (ports keep a raw
// pointer to it). Directions are the DDS application's view: an `output` port carries what
// the application publishes (the interceptor's reader writes it), an `input` port what
// polyport publishes for it (the interceptor's writer is the port's sink).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "polyport/codec.hpp"
#include "polyport/component.hpp"
#include "polyport/diagnostics.hpp"
#include "polyport/profile.hpp"
#include "polyport/types.hpp"

namespace polyport::cyclonedds {

class CycloneAdaptor final : public Component {
 public:
  // One DDS topic of the component.
  struct Topic {
    std::string topic;      // DDS topic name
    std::string type_name;  // DDS type name, as idlc spells it ("module::Struct")
    DataOutPort* out = nullptr;  // set for `output` ports (the application publishes)
    DataInPort* in = nullptr;    // set for `input` ports (polyport publishes)
  };

  // Samples larger than this (encoded) are not carried.
  static constexpr std::uint32_t kMaxSampleBytes = 1U << 20;
  // Room for unbounded strings and sequences beyond a type's fixed part.
  static constexpr std::uint32_t kTailBytes = 64U << 10;

  explicit CycloneAdaptor(std::string name) : Component(std::move(name), "cyclonedds") {}

  // Creates the profile's ports with their codecs. Problems are reported at the profile's
  // locations; returns null when there was one.
  static std::unique_ptr<CycloneAdaptor> create(const Subcomponent& subcomponent, const TypeRegistry& types,
                                                Diagnostics& diagnostics);

  const std::vector<Topic>& topics() const noexcept { return topics_; }

 private:
  std::vector<Topic> topics_;
  std::vector<std::unique_ptr<Codec>> codecs_;
};

}  // namespace polyport::cyclonedds
