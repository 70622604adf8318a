#include "polyport/model.hpp"

namespace polyport {

void ModelRegistry::add(std::unique_ptr<Model> model) { models_.push_back(std::move(model)); }

Model* ModelRegistry::find(std::string_view name) const noexcept {
  for (const auto& model : models_) {
    if (model->name() == name) return model.get();
  }
  return nullptr;
}

std::vector<std::string> ModelRegistry::names() const {
  std::vector<std::string> out;
  for (const auto& model : models_) out.emplace_back(model->name());
  return out;
}

}  // namespace polyport
