// Placeholder until the lcm codec lands.
#include "polyport/codec.hpp"

namespace polyport {

Result<std::unique_ptr<Codec>> make_lcm_codec(const Type& type) {
  return make_error("no lcm codec yet for type '" + type.name + "'");
}

}  // namespace polyport
