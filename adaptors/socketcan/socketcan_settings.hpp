// What a SocketCAN component profile says in the model's own element (model_section.hpp):
// <socketcan> with the CAN interface and whether it carries CAN FD frames. Each port's
// message is its <data_type> (a DBC message struct), so ports have no element of their own.
// SocketCanSection reads it; the adaptor and the model read the SocketCanSettings it
// returns. SDK-free.
#pragma once

#include <memory>
#include <string>
#include <string_view>

#include "polyport/base/diagnostics.hpp"
#include "polyport/profile/model_section.hpp"
#include "polyport/profile/profile.hpp"

namespace polyport::socketcan {

inline constexpr std::string_view kDefaultInterface = "vcan0";
// IFNAMSIZ (16) less the terminating NUL.
inline constexpr std::size_t kMaxInterfaceName = 15;

struct SocketCanSettings final : ModelSettings {
  std::string interface{kDefaultInterface};
  bool fd = false;      // CAN_RAW_FD_FRAMES: the socket also reads and writes CAN FD frames
  SourceLocation where;  // the <socketcan> element; line 0 when there is none
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
