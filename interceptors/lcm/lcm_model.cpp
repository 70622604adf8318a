#include "lcm_model.hpp"

#include "lcm_adaptor.hpp"
#include "lcm_interceptor.hpp"

namespace polyport::lcm {

std::optional<Proxy> LcmModel::create_proxy(const Subcomponent& sub, ModelContext& context,
                                            Diagnostics& diagnostics) {
  const ComponentProfile& profile = sub.profile;
  const std::shared_ptr<const LcmSettings> settings = lcm_settings(profile);
  std::unique_ptr<LcmAdaptor> adaptor = LcmAdaptor::create(sub, context.types, diagnostics);
  if (!adaptor) return std::nullopt;

  std::shared_ptr<FdReactor> reactor = reactor_.lock();
  if (!reactor) {
    reactor = Instance::create_reactor();
    reactor_ = reactor;
  }
  std::shared_ptr<Instance> instance = instances_[settings->url].lock();
  if (!instance) {
    instance = Instance::create(settings->url, std::move(reactor));
    instances_[settings->url] = instance;
  }
  if (settings->receive_thread) instance->want(*settings->receive_thread);
  auto interceptor = std::make_unique<LcmInterceptor>(*adaptor, std::move(instance));
  return Proxy{std::move(adaptor), std::move(interceptor)};
}

}  // namespace polyport::lcm
