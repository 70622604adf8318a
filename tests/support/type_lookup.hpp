// Looking types and fields up in tests: a miss fails the test and returns a harmless
// stand-in, so one missing name does not crash the rest of the test.
#pragma once

#include <gtest/gtest.h>

#include <string_view>

#include "polyport/types/types.hpp"

namespace polyport::test {

inline const Type& type_or_fail(const TypeRegistry& registry, std::string_view name) {
  const Type* type = registry.find(name);
  if (type == nullptr) {
    ADD_FAILURE() << "type " << name << " not found";
    return *registry.primitive(TypeKind::octet);
  }
  return *type;
}

inline const Field& field_or_fail(const Type& type, std::string_view name) {
  const Field* found = type.find_field(name);
  if (found == nullptr) {
    ADD_FAILURE() << "no field " << name << " in " << type.name;
    static const Field kNone;
    return kNone;
  }
  return *found;
}

}  // namespace polyport::test
