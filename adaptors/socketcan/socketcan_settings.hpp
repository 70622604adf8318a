// What a SocketCAN component profile says in the model's own element (model_section.hpp):
// <socketcan> with the CAN interface and whether it carries CAN FD frames. Each port's
// message is its <data_type> (a DBC message struct); a port polyport sends may say
// <cycle_ms> (sent periodically by the broadcast manager, overriding the DBC's
// GenMsgCycleTime; 0 sends each sample once).
// SocketCanSection reads it; the adaptor and the model read the SocketCanSettings it
// returns. SDK-free.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <string_view>

#include "polyport/base/diagnostics.hpp"
#include "polyport/profile/model_section.hpp"
#include "polyport/profile/profile.hpp"
#include "polyport/profile/thread_settings.hpp"

namespace polyport::socketcan {

inline constexpr std::string_view kDefaultInterface = "vcan0";
// IFNAMSIZ (16) less the terminating NUL.
inline constexpr std::size_t kMaxInterfaceName = 15;
// The longest <cycle_ms> (one hour).
inline constexpr std::uint32_t kMaxCycleMs = 3'600'000;

struct SocketCanSettings final : ModelSettings {
  std::string interface{kDefaultInterface};
  bool fd = false;      // CAN_RAW_FD_FRAMES: the socket also reads and writes CAN FD frames
  SourceLocation where;  // the <socketcan> element; line 0 when there is none
  // <receive_thread>: the daemon's one CAN receive thread (the strongest request applies).
  std::optional<ThreadScheduling> receive_thread;
  std::map<std::string, std::uint32_t, std::less<>> cycle_ms;  // port -> <cycle_ms>, when given

  // A port's <cycle_ms>; nullopt when the profile says none (the DBC's cycle time applies).
  std::optional<std::uint32_t> cycle(std::string_view port) const {
    const auto it = cycle_ms.find(port);
    return it != cycle_ms.end() ? std::optional<std::uint32_t>(it->second) : std::nullopt;
  }
};

// The SocketCAN settings of a component profile; the defaults when it has none.
std::shared_ptr<const SocketCanSettings> socketcan_settings(const ComponentProfile& profile);

// Why `name` cannot be a network interface name (empty when it can).
std::string bad_interface_name(std::string_view name);

class SocketCanSection final : public ModelSection {
 public:
  const ModelVocabulary& vocabulary() const noexcept override;
  std::unique_ptr<ComponentSectionReader> reader(std::string_view model) const override;
};

}  // namespace polyport::socketcan
