#include "polyport/base/diagnostics.hpp"

#include <ostream>
#include <utility>

namespace polyport {

std::string Diagnostic::to_string() const {
  std::string out;
  // Unknown parts of the location are left out rather than printed as 0, so a file that
  // could not be opened reads `path: cannot open file`, not `path:0:0: ...`.
  if (!where.file.empty() || where.line > 0) {
    out += where.file.empty() ? std::string("<input>") : where.file;
    if (where.line > 0) {
      out += ':';
      out += std::to_string(where.line);
      if (where.column > 0) {
        out += ':';
        out += std::to_string(where.column);
      }
    }
    out += ": ";
  }
  if (!path.empty()) {
    out += path;
    out += ": ";
  }
  if (severity == Severity::warning) out += "warning: ";
  out += message;
  return out;
}

void Diagnostics::error(SourceLocation where, std::string path, std::string message) {
  add(Diagnostic{Severity::error, std::move(where), std::move(path), std::move(message)});
}

void Diagnostics::warning(SourceLocation where, std::string path, std::string message) {
  add(Diagnostic{Severity::warning, std::move(where), std::move(path), std::move(message)});
}

void Diagnostics::add(Diagnostic diagnostic) {
  if (diagnostic.severity == Severity::error) ++error_count_;
  items_.push_back(std::move(diagnostic));
}

void Diagnostics::print(std::ostream& out) const {
  for (const Diagnostic& item : items_) out << item.to_string() << '\n';
}

}  // namespace polyport
