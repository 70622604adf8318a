// DBC frame layouts for `polyportd types` (type_printer.cpp).
#pragma once

#include <nlohmann/json.hpp>
#include <ostream>

#include "polyport/types/types.hpp"

namespace polyport::daemon {

void describe_dbc(const DbcMessage& message, nlohmann::json& out);
void print_dbc(const nlohmann::json& type, std::ostream& out);

}  // namespace polyport::daemon
