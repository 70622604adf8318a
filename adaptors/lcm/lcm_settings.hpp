// What an LCM component profile says in the LCM model's own elements (model_section.hpp):
// <lcm> (the provider URL and the largest message), and each port's <channel>. LcmSection
// reads them; the adaptor and the model read the LcmSettings it returns. SDK-free.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <string_view>

#include "polyport/base/diagnostics.hpp"
#include "polyport/profile/model_section.hpp"
#include "polyport/profile/profile.hpp"

namespace polyport::lcm {

// LCM's own default provider: UDP multicast that never leaves the host.
inline constexpr std::string_view kDefaultUrl = "udpm://239.255.76.67:7667?ttl=0";
// LCM channels are at most 63 characters (the UDP multicast provider refuses longer ones).
inline constexpr std::size_t kMaxChannelLength = 63;

struct LcmSettings final : ModelSettings {
  std::string url{kDefaultUrl};
  // The largest message a port carries, fingerprint included; larger ones are counted and
  // dropped. Messages over 64 KB travel fragmented; LCM reassembles them.
  std::uint32_t max_message_bytes = 256U << 10;
  SourceLocation where;                             // the <lcm> element; line 0 when there is none
  std::map<std::string, std::string, std::less<>> channels;  // port -> channel, when given

  // A port's channel: the profile's <channel>, else the port's name.
  std::string channel(std::string_view port) const;
};

// The LCM settings of a component profile; the defaults when it has none.
std::shared_ptr<const LcmSettings> lcm_settings(const ComponentProfile& profile);

class LcmSection final : public ModelSection {
 public:
  const ModelVocabulary& vocabulary() const noexcept override;
  std::unique_ptr<ComponentSectionReader> reader(std::string_view model) const override;
};

}  // namespace polyport::lcm
