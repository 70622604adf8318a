#include "inproc_model.hpp"

#include <cmath>

#include "inproc_adaptor.hpp"
#include "inproc_interceptor.hpp"
#include "plugin_library.hpp"
#include "polyport/profile/notifications.hpp"

namespace polyport::inproc {

namespace {

std::string join(const std::vector<std::string>& items) {
  std::string out;
  for (const auto& item : items) out += (out.empty() ? "" : ", ") + item;
  return out;
}

ExecutionSettings settings_for(const Subcomponent& sub) {
  const ExecutionSemantics& e = sub.profile.execution;
  ExecutionSettings settings;
  settings.period = Nanos{std::llround(e.period_ms * 1e6)};  // 8.2 ms is 8200000 ns, not 8199999
  settings.policy = e.policy;
  settings.priority = e.priority;
  settings.cpu = e.cpu;
  settings.spin = Nanos{e.spin_us * 1000};
  if (e.phase_ms) settings.phase = Nanos{std::llround(*e.phase_ms * 1e6)};
  // Shared contexts are keyed by period, policy, priority, CPU, spin tail and phase; the name
  // shows the period, the spin tail and the phase.
  const auto us = [](std::int64_t ns) { return std::to_string(ns / 1000) + "us"; };
  settings.name = e.type == ExecutionType::periodic_exclusive
                      ? sub.name
                      : "ec-" + us(settings.period.count) + (e.spin_us > 0 ? "-spin" + us(settings.spin.count) : "") +
                            (settings.phase ? "-phase" + us(settings.phase->count) : "");
  return settings;
}

}  // namespace

std::optional<Proxy> InprocModel::create_proxy(const Subcomponent& sub, ModelContext& context,
                                               Diagnostics& diagnostics) {
  const ComponentProfile& profile = sub.profile;
  const std::string library_path = "/component_profile/execution_environment/library_name";
  if (profile.library_path.empty()) {
    diagnostics.error(profile.where, library_path, "component library '" + profile.library + "' not found");
    return std::nullopt;
  }
  Result<const PluginLibrary*> library = PluginLibrary::open(profile.library_path);
  if (!library) {
    diagnostics.error(profile.where, library_path, library.error().message);
    return std::nullopt;
  }
  const ComponentFactory* factory = library.value()->find(profile.class_name);
  if (!factory) {
    diagnostics.error(profile.where, "/component_profile/execution_environment/class_name",
                      "'" + profile.library_path.string() + "' has no component class '" + profile.class_name +
                          "' (it has: " + join(library.value()->class_names()) + ")");
    return std::nullopt;
  }
  if (profile.execution.type == ExecutionType::aperiodic) {
    diagnostics.error(profile.execution.where, "/component_profile/execution_semantics/type",
                      "aperiodic (event-driven) execution is not supported yet; use periodic or passive");
    return std::nullopt;
  }

  const bool periodic = profile.execution.type == ExecutionType::periodic ||
                        profile.execution.type == ExecutionType::periodic_exclusive;
  if (periodic && profile.execution.period_ms * 1e6 < static_cast<double>(ExecutionContext::kMinPeriod.count)) {
    diagnostics.error(profile.execution.where, "/component_profile/execution_semantics/period",
                      "period " + std::to_string(profile.execution.period_ms) +
                          " ms is shorter than the shortest supported period (0.001 ms)");
    return std::nullopt;
  }

  std::unique_ptr<ComponentBase> instance = factory->create();
  std::map<std::string, std::string, std::less<>> properties;
  for (const PropertySpec& property : profile.properties) properties[property.name] = property.value;
  const bool passive = profile.execution.type == ExecutionType::passive;
  instance->set_instance(sub.name, std::move(properties), passive ? 0.0 : profile.execution.period_ms / 1000.0);
  if (const auto* notifications = dynamic_cast<const NotificationSettings*>(profile.model_settings.get())) {
    // The component did not declare this port: the profile asked for it (<notifications>).
    instance->enable_notifications(notifications->port, notifications->automatic, notifications->kind);
  }

  std::unique_ptr<InprocAdaptor> adaptor = InprocAdaptor::create(sub, context.types, *instance, passive, diagnostics);
  if (!adaptor) return std::nullopt;
  auto interceptor =
      std::make_unique<InprocInterceptor>(std::move(instance), profile.initial_state, adaptor->provided_ports());
  if (!passive) {
    const ExecutionSettings settings = settings_for(sub);
    ExecutionContext& ec = profile.execution.type == ExecutionType::periodic_exclusive
                               ? context.executors.exclusive(settings)
                               : context.executors.shared(settings);
    interceptor->attach(ec);
  }
  return Proxy{std::move(adaptor), std::move(interceptor)};
}

}  // namespace polyport::inproc
