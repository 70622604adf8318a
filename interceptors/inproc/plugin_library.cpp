#include "plugin_library.hpp"

#include <dlfcn.h>

#include <map>
#include <memory>
#include <mutex>

namespace polyport::inproc {

Result<const PluginLibrary*> PluginLibrary::open(const std::filesystem::path& path) {
  static std::mutex mutex;
  static std::map<std::filesystem::path, std::unique_ptr<PluginLibrary>> loaded;
  std::lock_guard<std::mutex> lock(mutex);
  if (auto it = loaded.find(path); it != loaded.end()) return static_cast<const PluginLibrary*>(it->second.get());

  void* handle = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (!handle) return make_error("cannot load component library '" + path.string() + "': " + dlerror());
  using EntryPoint = const PluginInfo* (*)();
  auto entry = reinterpret_cast<EntryPoint>(dlsym(handle, "polyport_component_plugin"));
  if (!entry) {
    return make_error("'" + path.string() +
                      "' is not a polyport component library (no polyport_component_plugin symbol)");
  }
  const PluginInfo* info = entry();
  if (!info || info->api_version != kComponentApiVersion) {
    return make_error("'" + path.string() + "' was built for component API version " +
                      std::to_string(info ? info->api_version : -1) + "; this polyport supports version " +
                      std::to_string(kComponentApiVersion));
  }
  auto library = std::make_unique<PluginLibrary>();
  library->path_ = path;
  library->info_ = info;
  const PluginLibrary* result = library.get();
  loaded.emplace(path, std::move(library));
  return result;
}

const ComponentFactory* PluginLibrary::find(std::string_view class_name) const noexcept {
  for (std::size_t i = 0; i < info_->factory_count; ++i) {
    if (class_name == info_->factories[i].class_name) return &info_->factories[i];
  }
  return nullptr;
}

std::vector<std::string> PluginLibrary::class_names() const {
  std::vector<std::string> out;
  for (std::size_t i = 0; i < info_->factory_count; ++i) out.emplace_back(info_->factories[i].class_name);
  return out;
}

}  // namespace polyport::inproc
