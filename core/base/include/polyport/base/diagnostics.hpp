// Problems found while loading profiles and type files. Every problem carries where it
// was found, so a user reads `file:line:col: element path: message` and can jump to it.
#pragma once

#include <cstdint>
#include <iosfwd>
#include <string>
#include <vector>

namespace polyport {

struct SourceLocation {
  std::string file;
  std::uint32_t line = 0;    // 1-based; 0 when unknown
  std::uint32_t column = 0;  // 1-based; 0 when unknown
};

enum class Severity : std::uint8_t { error, warning };

struct Diagnostic {
  Severity severity = Severity::error;
  SourceLocation where;
  std::string path;  // element path in a profile (`/application_profile/...`), or empty
  std::string message;

  // `file:line:col: path: message`, with `warning: ` before the message for warnings.
  std::string to_string() const;
};

// Collects every problem instead of stopping at the first one.
class Diagnostics {
 public:
  void error(SourceLocation where, std::string path, std::string message);
  void warning(SourceLocation where, std::string path, std::string message);
  void add(Diagnostic diagnostic);

  bool has_errors() const noexcept { return error_count_ > 0; }
  std::size_t error_count() const noexcept { return error_count_; }
  const std::vector<Diagnostic>& all() const noexcept { return items_; }
  void print(std::ostream& out) const;

 private:
  std::vector<Diagnostic> items_;
  std::size_t error_count_ = 0;
};

}  // namespace polyport
