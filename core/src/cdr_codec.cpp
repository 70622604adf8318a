// Placeholder until the cdr codec lands.
#include "polyport/codec.hpp"

namespace polyport {

Result<std::unique_ptr<Codec>> make_cdr_codec(const Type& type, WireFormat) {
  return make_error("no cdr codec yet for type '" + type.name + "'");
}

}  // namespace polyport
