#pragma once

#include <string>

#include "polyport/runtime/model.hpp"

namespace polyport::daemon {

// What the daemon's command line sets in its models.
struct ModelOptions {
  std::string can_io = "auto";  // --can-io: auto, io_uring, epoll (how the CAN receive thread waits)
};

// Every model this build has, one line each (see models.cpp).
void register_models(ModelRegistry& registry, const ModelOptions& options = {});

}  // namespace polyport::daemon
