// The SocketCAN model (`socketcan`): a component profile with <model>socketcan</model> is a
// CAN node on one Linux CAN interface whose data ports are DBC messages. One CanReactor (the
// receive thread for every CAN socket) is shared by every proxy of the daemon (the
// interceptors hold it; it goes with the last of them).
#pragma once

#include <memory>

#include "can_reactor.hpp"
#include "polyport/runtime/model.hpp"
#include "socketcan_settings.hpp"

namespace polyport::socketcan {

class SocketCanModel final : public Model {
 public:
  // `io`: how the CAN receive thread waits (polyportd --can-io; FdReactor).
  explicit SocketCanModel(ReactorIo io = ReactorIo::automatic) : io_(io) {}
  std::string_view name() const noexcept override { return "socketcan"; }
  const ModelSection* profile_section() const noexcept override { return &section_; }
  std::optional<Proxy> create_proxy(const Subcomponent& subcomponent, ModelContext& context,
                                    Diagnostics& diagnostics) override;

 private:
  ReactorIo io_;
  SocketCanSection section_;
  std::weak_ptr<CanReactor> reactor_;
};

}  // namespace polyport::socketcan
