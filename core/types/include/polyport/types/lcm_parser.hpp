// The LCM type source (`.lcm` files): reads LCM type text and registers its structs and
// constants in a TypeRegistry, through the registry's public API only.
// TypeRegistry::add_lcm_file and add_lcm_text (type_files.cpp) call it.
#pragma once

#include <string>
#include <string_view>

#include "polyport/base/diagnostics.hpp"
#include "polyport/types/types.hpp"

namespace polyport {

// Parses LCM type text (from `file_name`, for the locations) and registers each struct as
// `package::name` with origin `lcm` and lcm-gen's fingerprint. Every problem goes to
// diagnostics as file:line:col; returns false if there was any error (structs without one
// may still be registered).
bool parse_lcm(std::string_view text, const std::string& file_name, TypeRegistry& registry,
               Diagnostics& diagnostics);

}  // namespace polyport
