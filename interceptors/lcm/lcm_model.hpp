// The LCM model (`lcm`): a component profile with <model>lcm</model> is an LCM process whose
// data ports are channels, typed by .lcm structs. One Instance per provider URL is shared by
// every proxy that names it (the interceptors hold it; it goes with the last of them).
#pragma once

#include <map>
#include <memory>
#include <string>

#include "lcm_instance.hpp"
#include "lcm_settings.hpp"
#include "polyport/runtime/model.hpp"

namespace polyport::lcm {

class LcmModel final : public Model {
 public:
  std::string_view name() const noexcept override { return "lcm"; }
  const ModelSection* profile_section() const noexcept override { return &section_; }
  std::optional<Proxy> create_proxy(const Subcomponent& subcomponent, ModelContext& context,
                                    Diagnostics& diagnostics) override;

 private:
  LcmSection section_;
  std::map<std::string, std::weak_ptr<Instance>> instances_;  // by URL
  std::weak_ptr<FdReactor> reactor_;
};

}  // namespace polyport::lcm
