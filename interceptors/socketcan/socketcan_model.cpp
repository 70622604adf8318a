#include "socketcan_model.hpp"

#include "socketcan_adaptor.hpp"
#include "socketcan_interceptor.hpp"

namespace polyport::socketcan {

std::optional<Proxy> SocketCanModel::create_proxy(const Subcomponent& sub, ModelContext& context,
                                                  Diagnostics& diagnostics) {
  std::unique_ptr<SocketCanAdaptor> adaptor = SocketCanAdaptor::create(sub, context.types, diagnostics);
  if (!adaptor) return std::nullopt;
  std::shared_ptr<CanReactor> reactor = reactor_.lock();
  if (!reactor) {
    reactor = CanReactor::create(io_, check_);
    reactor_ = reactor;
  }
  if (adaptor->settings().receive_thread) reactor->want(*adaptor->settings().receive_thread);
  auto interceptor = std::make_unique<SocketCanInterceptor>(*adaptor, std::move(reactor));
  return Proxy{std::move(adaptor), std::move(interceptor)};
}

}  // namespace polyport::socketcan
