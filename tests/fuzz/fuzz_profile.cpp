// Fuzzes the profile loader with arbitrary XML as an application profile (whose references
// and type files will mostly not exist): every input gets diagnostics, never a crash.
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <string>

#include "polyport/profile/profile.hpp"
#include "polyport/types/types.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const std::string path = "/tmp/polyport-fuzz-profile-" + std::to_string(getpid()) + ".xml";
  std::FILE* file = std::fopen(path.c_str(), "wb");
  if (!file) return 0;
  std::fwrite(data, 1, size, file);
  std::fclose(file);
  polyport::TypeRegistry registry;
  polyport::Diagnostics diagnostics;
  auto profile = polyport::load_application_profile(path, registry, polyport::LoadOptions{}, diagnostics);
  if (profile && diagnostics.has_errors()) __builtin_trap();  // a profile is returned only without errors
  return 0;
}
