// Fuzzes the IDL parser, then renders a zeroed sample of every type it declared: no input
// may crash, hang or leak, and every declared type must have a consistent layout.
#include <cstddef>
#include <cstdint>
#include <string_view>
#include <vector>

#include "polyport/types/types.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  polyport::TypeRegistry registry;
  polyport::Diagnostics diagnostics;
  registry.add_idl_text(std::string_view(reinterpret_cast<const char*>(data), size), "fuzz.idl", diagnostics);
  for (const polyport::Type* type : registry.declared()) {
    const polyport::Type& real = type->resolved();
    if (real.size > (1u << 16)) continue;
    if (real.align == 0 || (real.size % real.align) != 0) __builtin_trap();
    std::vector<std::byte> sample(real.size);
    (void)polyport::sample_to_json(real, sample.data(), sample.size());
  }
  return 0;
}
