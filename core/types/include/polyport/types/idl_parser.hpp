// The OMG IDL type source: reads IDL text and registers what it declares in a TypeRegistry,
// through the registry's public building API only. TypeRegistry::add_idl_file and
// add_idl_text (type_files.cpp) call it.
#pragma once

#include <string>
#include <string_view>

#include "polyport/base/diagnostics.hpp"
#include "polyport/types/types.hpp"

namespace polyport {

// Parses IDL text (from `file_name`, for the locations) and registers its modules, structs,
// enums, typedefs and constants. Every problem goes to diagnostics as file:line:col, in
// source order; returns false if there was any error (what parsed cleanly may still be
// registered).
bool parse_idl(std::string_view text, const std::string& file_name, TypeRegistry& registry,
               Diagnostics& diagnostics);

}  // namespace polyport
