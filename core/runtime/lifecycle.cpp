// The shared lifecycle state machine; see lifecycle.hpp for the states and the hook names of
// each component model.
#include "polyport/runtime/lifecycle.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <string>
#include <utility>

#include "polyport/runtime/component_api.hpp"

namespace polyport {

namespace {

std::string lower(std::string_view text) {
  std::string out(text);
  std::transform(out.begin(), out.end(), out.begin(), [](unsigned char c) { return std::tolower(c); });
  return out;
}

template <class F>
ReturnCode guarded(F&& hook) noexcept {
  try {
    return hook();
  } catch (...) {
    return ReturnCode::error;
  }
}

}  // namespace

Lifecycle::Lifecycle(ComponentBase& component) noexcept : component_(component) { component.attach_lifecycle(this); }

Lifecycle::~Lifecycle() { component_.attach_lifecycle(nullptr); }

std::string_view to_string(LifecycleState state) noexcept {
  switch (state) {
    case LifecycleState::created: return "created";
    case LifecycleState::inactive: return "inactive";
    case LifecycleState::active: return "active";
    case LifecycleState::error: return "error";
    case LifecycleState::finalized: return "finalized";
  }
  return "?";
}

std::string_view to_string(LifecycleCommand command) noexcept {
  switch (command) {
    case LifecycleCommand::initialize: return "initialize";
    case LifecycleCommand::activate: return "activate";
    case LifecycleCommand::deactivate: return "deactivate";
    case LifecycleCommand::reset: return "reset";
    case LifecycleCommand::recover: return "recover";
    case LifecycleCommand::finalize: return "finalize";
  }
  return "?";
}

std::optional<LifecycleState> parse_lifecycle_state(std::string_view name) noexcept {
  static const std::array<std::pair<std::string_view, LifecycleState>, 20> kNames{{
      {"created", LifecycleState::created},        {"init", LifecycleState::created},
      {"preoperational", LifecycleState::created}, {"created_state", LifecycleState::created},
      {"opros_cs_created", LifecycleState::created},
      {"inactive", LifecycleState::inactive},      {"stopped", LifecycleState::inactive},
      {"ready", LifecycleState::inactive},         {"inactive_state", LifecycleState::inactive},
      {"active", LifecycleState::active},          {"running", LifecycleState::active},
      {"active_state", LifecycleState::active},
      {"error", LifecycleState::error},            {"runtimeerror", LifecycleState::error},
      {"exception", LifecycleState::error},        {"error_state", LifecycleState::error},
      {"finalized", LifecycleState::finalized},    {"destroyed", LifecycleState::finalized},
      {"opros_cs_destroyed", LifecycleState::finalized}, {"fatalerror", LifecycleState::error},
  }};
  const std::string key = lower(name);
  for (const auto& [text, state] : kNames) {
    if (key == text) return state;
  }
  return std::nullopt;
}

std::optional<LifecycleCommand> parse_lifecycle_command(std::string_view name) noexcept {
  static const std::array<std::pair<std::string_view, LifecycleCommand>, 27> kNames{{
      {"initialize", LifecycleCommand::initialize}, {"oninitialize", LifecycleCommand::initialize},
      {"configure", LifecycleCommand::initialize},  {"configurehook", LifecycleCommand::initialize},
      {"activate", LifecycleCommand::activate},     {"onactivated", LifecycleCommand::activate},
      {"start", LifecycleCommand::activate},        {"starthook", LifecycleCommand::activate},
      {"onstart", LifecycleCommand::activate},
      {"deactivate", LifecycleCommand::deactivate}, {"ondeactivated", LifecycleCommand::deactivate},
      {"stop", LifecycleCommand::deactivate},       {"stophook", LifecycleCommand::deactivate},
      {"onstop", LifecycleCommand::deactivate},
      {"reset", LifecycleCommand::reset},           {"onreset", LifecycleCommand::reset},
      {"recover", LifecycleCommand::recover},       {"onrecover", LifecycleCommand::recover},
      {"finalize", LifecycleCommand::finalize},     {"onfinalize", LifecycleCommand::finalize},
      {"cleanup", LifecycleCommand::finalize},      {"cleanuphook", LifecycleCommand::finalize},
      {"destroy", LifecycleCommand::finalize},      {"ondestroy", LifecycleCommand::finalize},
      {"activate_component", LifecycleCommand::activate},
      {"deactivate_component", LifecycleCommand::deactivate},
      {"reset_component", LifecycleCommand::reset},
  }};
  const std::string key = lower(name);
  for (const auto& [text, command] : kNames) {
    if (key == text) return command;
  }
  return std::nullopt;
}

ReturnCode Lifecycle::apply(LifecycleCommand command) noexcept {
  const LifecycleState now = state();
  ComponentBase& c = component_;
  switch (command) {
    case LifecycleCommand::initialize: {
      if (now != LifecycleState::created) return ReturnCode::precondition_not_met;
      const ReturnCode code = guarded([&] { return c.onInitialize(); });
      if (code == ReturnCode::ok) set(LifecycleState::inactive);
      return code;
    }
    case LifecycleCommand::activate: {
      if (now != LifecycleState::inactive) return ReturnCode::precondition_not_met;
      const ReturnCode code = guarded([&] { return c.onActivated(); });
      if (code == ReturnCode::ok) {
        set(LifecycleState::active);
        c.open_callbacks();
      } else {
        errors_.fetch_add(1, std::memory_order_relaxed);
        set(LifecycleState::error);
      }
      return code;
    }
    case LifecycleCommand::deactivate: {
      if (now != LifecycleState::active) return ReturnCode::precondition_not_met;
      c.close_callbacks();  // no CallbackInPort handler runs on while the component stops
      const ReturnCode code = guarded([&] { return c.onDeactivated(); });
      set(LifecycleState::inactive);  // a failing stop hook still stops the component
      return code;
    }
    case LifecycleCommand::reset: {
      if (now != LifecycleState::error) return ReturnCode::precondition_not_met;
      const ReturnCode code = guarded([&] { return c.onReset(); });
      if (code == ReturnCode::ok) set(LifecycleState::inactive);  // RTC: stays in error otherwise
      return code;
    }
    case LifecycleCommand::recover: {
      // Orocos recover(): RunTimeError -> Running. Reset first, then activate again.
      if (now != LifecycleState::error) return ReturnCode::precondition_not_met;
      ReturnCode code = guarded([&] { return c.onReset(); });
      if (code != ReturnCode::ok) return code;
      set(LifecycleState::inactive);
      code = guarded([&] { return c.onActivated(); });
      if (code != ReturnCode::ok) errors_.fetch_add(1, std::memory_order_relaxed);
      set(code == ReturnCode::ok ? LifecycleState::active : LifecycleState::error);
      if (code == ReturnCode::ok) c.open_callbacks();
      return code;
    }
    case LifecycleCommand::finalize: {
      if (now == LifecycleState::active || now == LifecycleState::finalized) return ReturnCode::precondition_not_met;
      const ReturnCode code = now == LifecycleState::created ? ReturnCode::ok : guarded([&] { return c.onFinalize(); });
      set(LifecycleState::finalized);
      return code;
    }
  }
  return ReturnCode::unsupported;
}

void Lifecycle::execute() noexcept {
  const LifecycleState now = state();
  if (now == LifecycleState::active) {
    executions_.fetch_add(1, std::memory_order_relaxed);
    const ReturnCode code = guarded([&] { return component_.onExecute(); });
    if (code != ReturnCode::ok) {
      errors_.fetch_add(1, std::memory_order_relaxed);
      component_.close_callbacks();
      set(LifecycleState::error);
      return;
    }
    try {
      component_.onStateUpdate();
    } catch (...) {
      errors_.fetch_add(1, std::memory_order_relaxed);
      component_.close_callbacks();
      set(LifecycleState::error);
    }
  } else if (now == LifecycleState::error) {
    guarded([&] { return component_.onError(); });
  }
}

}  // namespace polyport
