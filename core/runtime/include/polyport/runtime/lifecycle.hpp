// The one lifecycle that RTC, Orocos and OPRoS components all fit:
//
//   created --initialize--> inactive --activate--> active --deactivate--> inactive
//   active --(onExecute fails or throws)--> error;  error --reset--> inactive
//   error --recover--> active;  inactive/created/error --finalize--> finalized
//
// Hooks (ComponentBase) keep the RTC names; Orocos and OPRoS names map onto them:
//   onInitialize  = configureHook  = OPRoS onInitialize
//   onActivated   = startHook      = OPRoS onStart
//   onExecute     = updateHook     = OPRoS onExecute     (then onStateUpdate = onUpdated)
//   onDeactivated = stopHook       = OPRoS onStop
//   onError       = errorHook      = OPRoS onError       (each cycle while in error)
//   onReset       = (recover)      = OPRoS onReset / onRecover
//   onFinalize    = cleanupHook    = OPRoS onDestroy
// A Lifecycle is driven by one thread at a time: its execution context's thread while that
// runs, the control thread otherwise (ExecutionContext::command arranges this).
#pragma once

#include <atomic>
#include <cstdint>
#include <optional>
#include <string_view>

namespace polyport {

class ComponentBase;
enum class ReturnCode : std::uint8_t;

enum class LifecycleState : std::uint8_t { created, inactive, active, error, finalized };
enum class LifecycleCommand : std::uint8_t { initialize, activate, deactivate, reset, recover, finalize };

std::string_view to_string(LifecycleState state) noexcept;
std::string_view to_string(LifecycleCommand command) noexcept;
// Accepts the state names of all three models ("Running", "ACTIVE", "Stopped", "READY",
// "PreOperational", "RunTimeError", ...), case-insensitively.
std::optional<LifecycleState> parse_lifecycle_state(std::string_view name) noexcept;
// Accepts canonical, Orocos and OPRoS command and hook names ("start", "startHook",
// "onStart", "activate", "configure", "cleanup", "destroy", ...).
std::optional<LifecycleCommand> parse_lifecycle_command(std::string_view name) noexcept;

class Lifecycle {
 public:
  // Tells `component` of itself (ComponentBase::state), until destroyed.
  explicit Lifecycle(ComponentBase& component) noexcept;
  ~Lifecycle();
  Lifecycle(const Lifecycle&) = delete;
  Lifecycle& operator=(const Lifecycle&) = delete;

  LifecycleState state() const noexcept { return state_.load(std::memory_order_acquire); }
  // Applies a command; returns precondition_not_met when the state does not allow it, or the
  // hook's own code. A hook that throws counts as error.
  ReturnCode apply(LifecycleCommand command) noexcept;
  // One cycle: onExecute + onStateUpdate while active, onError while in error.
  void execute() noexcept;

  std::uint64_t executions() const noexcept { return executions_.load(std::memory_order_relaxed); }
  std::uint64_t errors() const noexcept { return errors_.load(std::memory_order_relaxed); }
  ComponentBase& component() const noexcept { return component_; }

 private:
  void set(LifecycleState state) noexcept { state_.store(state, std::memory_order_release); }

  ComponentBase& component_;
  std::atomic<LifecycleState> state_{LifecycleState::created};
  std::atomic<std::uint64_t> executions_{0};
  std::atomic<std::uint64_t> errors_{0};
};

}  // namespace polyport
