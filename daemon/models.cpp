// The explicit registry of models: adding a model adds its folders and one line here.
#include "models.hpp"

#include "inproc_model.hpp"
#if defined(POLYPORT_WITH_CYCLONEDDS) || defined(POLYPORT_WITH_FASTDDS)
#include "dds_model.hpp"
#endif
#ifdef POLYPORT_WITH_CYCLONEDDS
#include "cyclonedds_domain.hpp"
#endif
#ifdef POLYPORT_WITH_FASTDDS
#include "fastdds_domain.hpp"
#endif
#ifdef POLYPORT_WITH_LCM
#include "lcm_model.hpp"
#endif
#ifdef POLYPORT_WITH_SOCKETCAN
#include "socketcan_model.hpp"
#endif

namespace polyport::daemon {

void register_models(ModelRegistry& registry, [[maybe_unused]] const ModelOptions& options) {
  registry.add(std::make_unique<inproc::InprocModel>());
#ifdef POLYPORT_WITH_CYCLONEDDS
  auto cyclone = std::make_unique<dds::DdsModel>("cyclonedds", cyclonedds::make_cyclonedds_domain,
                                                cyclonedds::default_config());
  cyclone->set_thread_config(cyclonedds::with_thread_scheduling);
  registry.add(std::move(cyclone));
#endif
#ifdef POLYPORT_WITH_FASTDDS
  registry.add(std::make_unique<dds::DdsModel>("fastdds", fastdds::make_fastdds_domain, fastdds::default_config()));
#endif
#ifdef POLYPORT_WITH_LCM
  registry.add(std::make_unique<lcm::LcmModel>());
#endif
#ifdef POLYPORT_WITH_SOCKETCAN
  const ReactorIo can_io = options.can_io == "io_uring" ? ReactorIo::io_uring
                           : options.can_io == "epoll"  ? ReactorIo::epoll
                                                        : ReactorIo::automatic;
  registry.add(std::make_unique<socketcan::SocketCanModel>(can_io));
#endif
}

}  // namespace polyport::daemon
