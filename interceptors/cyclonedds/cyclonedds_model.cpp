#include "cyclonedds_model.hpp"

#include "cyclonedds_adaptor.hpp"
#include "cyclonedds_interceptor.hpp"
#include "raw_topic.hpp"

namespace polyport::cyclonedds {

std::string CycloneModel::default_config() { return POLYPORT_CYCLONE_DEFAULT_CONFIG; }

std::optional<Proxy> CycloneModel::create_proxy(const Subcomponent& sub, ModelContext& context,
                                                Diagnostics& diagnostics) {
  const ComponentProfile& profile = sub.profile;
  const std::string config = profile.dds_config ? profile.dds_config->string() : default_config();
  const SourceLocation where = profile.dds_where.line != 0 ? profile.dds_where : profile.where;

  std::shared_ptr<Participant> participant;
  Domain& domain = domains_[profile.dds_domain];
  participant = domain.participant.lock();
  if (participant && domain.config != config) {
    diagnostics.error(where, "/component_profile/dds/config",
                      "DDS domain " + std::to_string(profile.dds_domain) + " is already configured with '" +
                          domain.config + "' in this process; '" + config + "' cannot be used for it too");
    return std::nullopt;
  }
  if (!participant) {
    auto created = Participant::create(profile.dds_domain, config);
    if (!created) {
      diagnostics.error(where, "/component_profile/dds",
                        "cannot join DDS domain " + std::to_string(profile.dds_domain) + ": " +
                            created.error().message);
      return std::nullopt;
    }
    participant = std::shared_ptr<Participant>(std::move(created).value());
    domain.participant = participant;
    domain.config = config;
  }

  std::unique_ptr<CycloneAdaptor> adaptor = CycloneAdaptor::create(sub, context.types, diagnostics);
  if (!adaptor) return std::nullopt;
  auto interceptor = std::make_unique<CycloneInterceptor>(*adaptor, std::move(participant), config);
  return Proxy{std::move(adaptor), std::move(interceptor)};
}

}  // namespace polyport::cyclonedds
