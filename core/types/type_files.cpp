// TypeRegistry's type-file entry points: add_idl_*, add_lcm_*, add_dbc_* and add_type_file.
// They read a file once (by canonical path) and hand its text to the parser of its format
// (idl_parser.hpp, lcm_parser.hpp, dbc_parser.hpp). This file sits above both the registry
// and the parsers: the parsers use only the registry's public API, and the registry's own
// sources (types.cpp) know no parser.
#include <algorithm>
#include <cctype>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <string_view>
#include <system_error>

#include "polyport/types/dbc_parser.hpp"
#include "polyport/types/idl_parser.hpp"
#include "polyport/types/lcm_parser.hpp"
#include "polyport/types/types.hpp"

namespace polyport {

bool TypeRegistry::add_file(const std::filesystem::path& file, Diagnostics& diagnostics, AddText add_text) {
  const auto cannot_open = [&] {
    diagnostics.error(SourceLocation{file.string(), 0, 0}, std::string(), "cannot open file");
    return false;
  };
  std::error_code error;
  const std::filesystem::path canonical = std::filesystem::canonical(file, error);
  if (error || !std::filesystem::is_regular_file(canonical, error)) return cannot_open();
  if (std::find(loaded_files_.begin(), loaded_files_.end(), canonical) != loaded_files_.end()) return true;
  std::ifstream in(canonical, std::ios::binary);
  if (!in) return cannot_open();
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) return cannot_open();
  loaded_files_.push_back(canonical);
  return (this->*add_text)(text.str(), file.string(), diagnostics);
}

bool TypeRegistry::add_type_file(const std::filesystem::path& file, Diagnostics& diagnostics) {
  // In any case: tools on Windows write `.DBC` as often as `.dbc`.
  std::string extension = file.extension().string();
  for (char& c : extension) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (extension == ".idl") return add_idl_file(file, diagnostics);
  if (extension == ".lcm") return add_lcm_file(file, diagnostics);
  if (extension == ".dbc") return add_dbc_file(file, diagnostics);
  diagnostics.error(SourceLocation{file.string(), 0, 0}, {},
                    "unknown kind of type file (expected .idl, .lcm or .dbc)");
  return false;
}

bool TypeRegistry::add_idl_text(std::string_view text, const std::string& file_name,
                                Diagnostics& diagnostics) {
  return parse_idl(text, file_name, *this, diagnostics);
}

bool TypeRegistry::add_idl_file(const std::filesystem::path& file, Diagnostics& diagnostics) {
  return add_file(file, diagnostics, &TypeRegistry::add_idl_text);
}

bool TypeRegistry::add_lcm_text(std::string_view text, const std::string& file_name,
                                Diagnostics& diagnostics) {
  return parse_lcm(text, file_name, *this, diagnostics);
}

bool TypeRegistry::add_lcm_file(const std::filesystem::path& file, Diagnostics& diagnostics) {
  return add_file(file, diagnostics, &TypeRegistry::add_lcm_text);
}

bool TypeRegistry::add_dbc_text(std::string_view text, const std::string& file_name,
                                Diagnostics& diagnostics) {
  return parse_dbc(text, file_name, *this, diagnostics);
}

bool TypeRegistry::add_dbc_file(const std::filesystem::path& file, Diagnostics& diagnostics) {
  return add_file(file, diagnostics, &TypeRegistry::add_dbc_text);
}

}  // namespace polyport
