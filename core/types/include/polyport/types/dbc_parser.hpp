// The DBC type source: reads a DBC file's text and registers one struct per CAN message in a
// TypeRegistry, with its frame layout (dbc.hpp), through the registry's public API only.
// TypeRegistry::add_dbc_file and add_dbc_text (type_files.cpp) call it.
#pragma once

#include <string>
#include <string_view>

#include "polyport/base/diagnostics.hpp"
#include "polyport/types/types.hpp"

namespace polyport {

// Parses DBC text (from `file_name`: its stem names the types' namespace) and registers
// every message without problems as "<db>::<Message>"; the registry keeps the DbcDatabase
// alive. A message with a problem of its own is a warning and is declared unusable (a
// profile naming it fails with the reason); ignored statements are one warning per kind.
// Text that is not UTF-8 is read as Windows-1252. Problems go to diagnostics as
// file:line:col, sorted by position (warnings too); returns false if there was any error
// (a syntax error: the file is not DBC as any tool writes it).
bool parse_dbc(std::string_view text, const std::string& file_name, TypeRegistry& registry,
               Diagnostics& diagnostics);

}  // namespace polyport
