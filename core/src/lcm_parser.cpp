// Placeholder until the lcm type source lands: every file is refused with a clear error.
#include "polyport/types.hpp"

namespace polyport {

bool TypeRegistry::add_lcm_file(const std::filesystem::path& file, Diagnostics& diagnostics) {
  diagnostics.error(SourceLocation{file.string(), 0, 0}, {}, "lcm type files are not supported yet");
  return false;
}

bool TypeRegistry::add_lcm_text(std::string_view, const std::string& file_name, Diagnostics& diagnostics) {
  diagnostics.error(SourceLocation{file_name, 0, 0}, {}, "lcm type files are not supported yet");
  return false;
}

}  // namespace polyport
