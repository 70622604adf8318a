#pragma once

#include <string>
#include <vector>

namespace polyport::daemon {

// `polyportd types FILE...`: what IDL, .lcm and DBC files define, with flat layouts, LCM
// fingerprints and DBC frame layouts. Returns the exit code.
int run_types(const std::vector<std::string>& files, bool json);

}  // namespace polyport::daemon
