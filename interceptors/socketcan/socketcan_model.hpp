// The SocketCAN model (`socketcan`): a component profile with <model>socketcan</model> is a
// CAN node on one Linux CAN interface whose data ports are DBC messages. One CanReactor (the
// receive thread for every CAN socket) is shared by every proxy of the daemon (the
// interceptors hold it; it goes with the last of them).
#pragma once

#include <chrono>
#include <memory>

#include "can_reactor.hpp"
#include "polyport/runtime/model.hpp"
#include "socketcan_settings.hpp"

namespace polyport::socketcan {

class SocketCanModel final : public Model {
 public:
  // `io`: how the CAN receive thread waits (polyportd --can-io; FdReactor). `check`: how often
  // the supervision looks the interfaces up besides the kernel's link notifications (tests
  // lengthen it to show that the notifications alone find a change).
  explicit SocketCanModel(ReactorIo io = ReactorIo::automatic,
                          std::chrono::milliseconds check = CanReactor::kTickInterval)
      : io_(io), check_(check) {}
  std::string_view name() const noexcept override { return "socketcan"; }
  const ModelSection* profile_section() const noexcept override { return &section_; }
  std::optional<Proxy> create_proxy(const Subcomponent& subcomponent, ModelContext& context,
                                    Diagnostics& diagnostics) override;

 private:
  ReactorIo io_;
  std::chrono::milliseconds check_;
  SocketCanSection section_;
  std::weak_ptr<CanReactor> reactor_;
};

}  // namespace polyport::socketcan
