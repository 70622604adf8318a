// The explicit registry of models: adding a model adds its folders and one line here.
#include "models.hpp"

#include "inproc_model.hpp"
#ifdef POLYPORT_WITH_CYCLONEDDS
#include "cyclonedds_model.hpp"
#endif

namespace polyport::daemon {

void register_models(ModelRegistry& registry) {
  registry.add(std::make_unique<inproc::InprocModel>());
#ifdef POLYPORT_WITH_CYCLONEDDS
  registry.add(std::make_unique<cyclonedds::CycloneModel>());
#endif
}

}  // namespace polyport::daemon
