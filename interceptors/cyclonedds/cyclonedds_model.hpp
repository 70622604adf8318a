// The Cyclone DDS model: a component profile with <model>cyclonedds</model> is a DDS
// application whose data ports are topics. One Participant per domain id is shared by every
// proxy of the model (the interceptors hold it; it goes when the last of them does).
#pragma once

#include <map>
#include <memory>
#include <string>

#include "polyport/model.hpp"

namespace polyport::cyclonedds {

class Participant;

class CycloneModel final : public Model {
 public:
  std::string_view name() const noexcept override { return "cyclonedds"; }
  std::optional<Proxy> create_proxy(const Subcomponent& subcomponent, ModelContext& context,
                                    Diagnostics& diagnostics) override;

  // The configuration used when a profile names none (config/cyclonedds-loopback.xml).
  static std::string default_config();

 private:
  struct Domain {
    std::weak_ptr<Participant> participant;
    std::string config;
  };
  std::map<std::uint32_t, Domain> domains_;
};

}  // namespace polyport::cyclonedds
