// The explicit registry of models: adding a model adds its folders and one line here.
#include "models.hpp"

#include "inproc_model.hpp"

namespace polyport::daemon {

void register_models(ModelRegistry& registry) {
  registry.add(std::make_unique<inproc::InprocModel>());
}

}  // namespace polyport::daemon
