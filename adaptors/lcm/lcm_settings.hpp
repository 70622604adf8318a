// What an LCM component profile says in the LCM model's own elements (model_section.hpp):
// <lcm> (the provider URL, the largest message, the service limits), each port's <channel>,
// and each service operation's lcm_request / lcm_reply structs and optional
// lcm_request_channel / lcm_reply_channel. LcmSection reads them; the adaptor and the model
// read the LcmSettings it returns. SDK-free.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <string_view>

#include "polyport/base/diagnostics.hpp"
#include "polyport/profile/call_limits.hpp"
#include "polyport/profile/model_section.hpp"
#include "polyport/profile/profile.hpp"
#include "polyport/profile/thread_settings.hpp"

namespace polyport::lcm {

// LCM's own default provider: UDP multicast that never leaves the host.
inline constexpr std::string_view kDefaultUrl = "udpm://239.255.76.67:7667?ttl=0";
// LCM channels are at most 63 characters (the UDP multicast provider refuses longer ones).
inline constexpr std::size_t kMaxChannelLength = 63;

// The messages of one service operation (a correlation header, then the payload; see
// docs/PROFILES.md, "Services over LCM") and the channels they travel on.
struct OperationSettings {
  std::string request_type;
  std::string reply_type;       // empty for a oneway operation
  std::string request_channel;  // empty: <port channel>/<operation>/request
  std::string reply_channel;    // empty: <port channel>/<operation>/reply
};

// CallLimits: per service port, both directions; call_timeout_ns bounds an LCM server's reply.
struct LcmSettings final : ModelSettings, CallLimits {
  std::string url{kDefaultUrl};
  // The largest message a port carries, fingerprint included; larger ones are counted and
  // dropped. Messages over 64 KB travel fragmented; LCM reassembles them.
  std::uint32_t max_message_bytes = 256U << 10;
  SourceLocation where;                             // the <lcm> element; line 0 when there is none
  std::optional<ThreadScheduling> receive_thread;   // <receive_thread>: the instance's receive thread
  std::map<std::string, std::string, std::less<>> channels;  // port -> channel, when given
  // Service ports: port -> operation -> its messages and channels.
  std::map<std::string, std::map<std::string, OperationSettings, std::less<>>, std::less<>> operations;

  // A port's channel: the profile's <channel>, else the port's name.
  std::string channel(std::string_view port) const;
  // An operation's settings; null when the profile gives none.
  const OperationSettings* operation(std::string_view port, std::string_view operation) const;
};

// What is wrong with `channel` as an LCM channel ("" when nothing): empty, longer than
// kMaxChannelLength, or with a blank or control character.
std::string bad_channel(std::string_view channel);

// The LCM settings of a component profile; the defaults when it has none.
std::shared_ptr<const LcmSettings> lcm_settings(const ComponentProfile& profile);

class LcmSection final : public ModelSection {
 public:
  const ModelVocabulary& vocabulary() const noexcept override;
  std::unique_ptr<ComponentSectionReader> reader(std::string_view model) const override;
};

}  // namespace polyport::lcm
