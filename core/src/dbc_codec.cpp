// Placeholder until the dbc codec lands.
#include "polyport/codec.hpp"

namespace polyport {

Result<std::unique_ptr<Codec>> make_dbc_codec(const Type& type) {
  return make_error("no dbc codec yet for type '" + type.name + "'");
}

}  // namespace polyport
