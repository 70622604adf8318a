#include "dds_model.hpp"

#include "dds_adaptor.hpp"
#include "dds_interceptor.hpp"
#include "polyport/runtime/thread_scheduling.hpp"

namespace polyport::dds {

std::optional<Proxy> DdsModel::create_proxy(const Subcomponent& sub, ModelContext& context,
                                             Diagnostics& diagnostics) {
  const ComponentProfile& profile = sub.profile;
  const std::shared_ptr<const DdsSettings> settings = dds_settings(profile);
  std::string config = settings->config ? settings->config->string() : default_config_;
  const SourceLocation where = settings->where.line != 0 ? settings->where : profile.where;
  // A domain's threads are the SDK's, set up with the domain: part of its configuration. The
  // SDK fails to start a thread it may not give the priority, so that is checked first.
  if (settings->receive_threads && thread_config_) {
    if (const std::string refusal = realtime_refusal(*settings->receive_threads); refusal.empty()) {
      config = thread_config_(config, *settings->receive_threads);
    } else {
      diagnostics.warning(where, "/component_profile/dds/receive_thread",
                          name_ + " receive threads: " + refusal + "; they run with SCHED_OTHER");
    }
  }

  // Ports first: a profile with bad ports does not join a domain.
  std::unique_ptr<DdsAdaptor> adaptor = DdsAdaptor::create(sub, context.types, diagnostics);
  if (!adaptor) return std::nullopt;

  DomainEntry& entry = domains_[settings->domain];
  std::shared_ptr<Domain> domain = entry.domain.lock();
  if (domain && entry.config != config) {
    diagnostics.error(where, "/component_profile/dds/config",
                      "DDS domain " + std::to_string(settings->domain) + " of model '" + name_ +
                          "' is already configured with '" + entry.config + "' in this process; '" + config +
                          "' cannot be used for it too");
    return std::nullopt;
  }
  if (!domain) {
    auto created = factory_(settings->domain, config);
    if (!created) {
      diagnostics.error(where, "/component_profile/dds",
                        "cannot join DDS domain " + std::to_string(settings->domain) + " (" + name_ +
                            "): " + created.error().message);
      return std::nullopt;
    }
    domain = std::shared_ptr<Domain>(std::move(created).value());
    entry.domain = domain;
    entry.config = config;
  }
  auto interceptor = std::make_unique<DdsInterceptor>(*adaptor, std::move(domain), config);
  return Proxy{std::move(adaptor), std::move(interceptor)};
}

}  // namespace polyport::dds
