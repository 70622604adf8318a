// Component plugins: shared libraries exporting `polyport_component_plugin`. A library is
// loaded once per process and never unloaded: component instances, their handlers and the
// engine's ports hold code and data from it until the process ends.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "polyport/runtime/component_api.hpp"
#include "polyport/base/result.hpp"

namespace polyport::inproc {

class PluginLibrary {
 public:
  static Result<const PluginLibrary*> open(const std::filesystem::path& path);

  const std::filesystem::path& path() const noexcept { return path_; }
  const ComponentFactory* find(std::string_view class_name) const noexcept;
  std::vector<std::string> class_names() const;

 private:
  std::filesystem::path path_;
  const PluginInfo* info_ = nullptr;
};

}  // namespace polyport::inproc
