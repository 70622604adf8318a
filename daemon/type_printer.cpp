// Placeholder until the DBC type source lands: DBC messages are listed as plain structs.
#include "type_printer.hpp"

namespace polyport::daemon {

void describe_dbc(const DbcMessage&, nlohmann::json&) {}
void print_dbc(const nlohmann::json&, std::ostream&) {}

}  // namespace polyport::daemon
