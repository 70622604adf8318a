#pragma once

#include "polyport/runtime/model.hpp"

namespace polyport::inproc {

// The in-process model: components from shared libraries, run on execution contexts.
class InprocModel final : public Model {
 public:
  std::string_view name() const noexcept override { return "inproc"; }
  std::optional<Proxy> create_proxy(const Subcomponent& subcomponent, ModelContext& context,
                                    Diagnostics& diagnostics) override;
};

}  // namespace polyport::inproc
