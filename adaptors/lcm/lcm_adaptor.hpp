// The application-side face of an LCM component: one typed port per channel, speaking LCM's
// wire format (8-byte fingerprint, then the big-endian fields, as lcm-gen code writes them)
// with the codec of the port's .lcm struct. A connection between two LCM ports of one type
// is a passthrough; to an in-process or DDS port it decodes / encodes on the forwarding path.
//
// Service ports: one per service, with a request and a reply channel per operation
// (`<channel>/<operation>/request` and `.../reply` unless the operation names its own)
// whose .lcm structs put a correlation header (config/types/polyport_rpc.lcm: client id,
// sequence number, and a status in replies) before the payload. The adaptor checks those
// structs and records where the header fields and the payload sit; core's service bridges
// (polyport/runtime/service_bridge.hpp) do the calls over the interceptor's channels.
//
// Directions are the LCM application's view: an `output` port carries what the application
// publishes on its channel (the interceptor's subscription writes it), an `input` port what
// polyport publishes for it (the interceptor publishes from the port's sink); a `provided`
// service port is served by the LCM application, a `required` one calls into the application.
//
// Ownership: the adaptor owns its ports and codecs; the interceptor keeps raw pointers to the
// ports for as long as the proxy lives.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "lcm_settings.hpp"
#include "polyport/base/diagnostics.hpp"
#include "polyport/codecs/codec.hpp"
#include "polyport/profile/profile.hpp"
#include "polyport/runtime/component.hpp"
#include "polyport/runtime/service_bridge.hpp"
#include "polyport/types/types.hpp"

namespace polyport::lcm {

class LcmAdaptor final : public Component {
 public:
  // One channel of a data (or event) port.
  struct Channel {
    std::string channel;
    std::string type_name;                  // the .lcm struct ("package.name" as LCM writes it)
    std::array<std::byte, 8> fingerprint{};  // big-endian, as the message starts
    std::uint32_t max_size = 0;             // largest message carried, fingerprint included
    DataOutPort* out = nullptr;             // `output`: the application publishes
    DataInPort* in = nullptr;               // `input`: polyport publishes
  };

  LcmAdaptor(std::string name, std::string model) : Component(std::move(name), std::move(model)) {}

  // Creates the profile's ports with their codecs; problems at the profile's locations,
  // null when there was one.
  static std::unique_ptr<LcmAdaptor> create(const Subcomponent& subcomponent, const TypeRegistry& types,
                                            Diagnostics& diagnostics);

  const std::vector<Channel>& channels() const noexcept { return channels_; }
  // Service ports: the address of a layout is its channel, the caller an int64 client id.
  const std::vector<RpcService>& services() const noexcept { return services_; }
  const LcmSettings& settings() const noexcept { return *settings_; }

 private:
  bool add_channel(const PortSpec& spec, const TypeRegistry& types, Diagnostics& diagnostics);
  bool add_service_port(const PortSpec& spec, const TypeRegistry& types, Diagnostics& diagnostics);
  // Checks one request/reply struct against the convention and fills `layout`.
  bool rpc_layout(const PortSpec& spec, const OperationSpec& operation, bool reply, const TypeRegistry& types,
                  Diagnostics& diagnostics, RpcLayout& layout);

  std::shared_ptr<const LcmSettings> settings_;
  std::vector<Channel> channels_;
  std::vector<RpcService> services_;
  std::vector<std::unique_ptr<Codec>> codecs_;
};

// What the receive path makes of a message on a channel, before anything decodes it.
enum class MessageCheck : std::uint8_t {
  ok,
  too_short,          // shorter than a fingerprint
  wrong_fingerprint,  // a message of another type (or another version of it)
  too_large,          // over the channel's max_size
};
// Checks `size` bytes received on `channel`: no allocation, any thread.
MessageCheck check_message(const LcmAdaptor::Channel& channel, const void* data, std::uint32_t size) noexcept;

// The type name LCM tools show for a registry name ("demo::pose_t" -> "demo.pose_t").
std::string lcm_type_name(const std::string& registry_name);

}  // namespace polyport::lcm
