#pragma once

#include "polyport/runtime/model.hpp"

namespace polyport::daemon {

// Every model this build has, one line each (see models.cpp).
void register_models(ModelRegistry& registry);

}  // namespace polyport::daemon
