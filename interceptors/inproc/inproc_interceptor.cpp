#include "inproc_interceptor.hpp"

#include <nlohmann/json.hpp>

namespace polyport::inproc {

InprocInterceptor::InprocInterceptor(std::unique_ptr<ComponentBase> instance, InitialState initial_state,
                                     std::vector<ProvidedServicePort*> provided)
    : instance_(std::move(instance)), lifecycle_(*instance_), initial_state_(initial_state), provided_(std::move(provided)) {}

InprocInterceptor::~InprocInterceptor() { stop(); }

void InprocInterceptor::attach(ExecutionContext& context) {
  context_ = &context;
  context.add(lifecycle_, provided_);
}

ReturnCode InprocInterceptor::command(LifecycleCommand command) {
  // A component stopping may be waiting on a provider that does not answer (a foreign peer
  // that is gone): its blocking mode goes off first, so that the wait ends (cancelled) and
  // the command, which runs between two cycles, is not held up behind it.
  // Activating switches it on again, before onActivated, which may call.
  if (command == LifecycleCommand::deactivate || command == LifecycleCommand::finalize) {
    instance_->set_blocking(false);
  } else if (command == LifecycleCommand::activate) {
    instance_->set_blocking(true);
  }
  const ReturnCode code = context_ ? context_->command(lifecycle_, command) : lifecycle_.apply(command);
  // A deactivate that did not happen (refused in this state): the component runs on as before.
  if (lifecycle_.state() == LifecycleState::active) instance_->set_blocking(true);
  return code;
}

Result<void> InprocInterceptor::start() {
  ReturnCode code = command(LifecycleCommand::initialize);
  if (code != ReturnCode::ok) return make_error("onInitialize returned " + std::string(to_string(code)));
  // Handlers may run from here on: the component is initialized.
  for (ProvidedServicePort* port : provided_) port->set_accepting(true);
  if (initial_state_ == InitialState::active) {
    code = command(LifecycleCommand::activate);
    if (code != ReturnCode::ok) return make_error("onActivated returned " + std::string(to_string(code)));
  }
  return {};
}

void InprocInterceptor::stop() noexcept {
  instance_->set_blocking(false);  // no call of the component waits from here on
  // Refusing waits for handlers still running on callers' threads; queued calls are refused
  // by the execution context from now on, so none runs after onDeactivated / onFinalize.
  for (ProvidedServicePort* port : provided_) port->set_accepting(false);
  if (lifecycle_.state() == LifecycleState::active) command(LifecycleCommand::deactivate);
  if (lifecycle_.state() != LifecycleState::finalized) command(LifecycleCommand::finalize);
  for (ProvidedServicePort* port : provided_) port->cancel_queued(Status::not_active);
}

ReturnCode InprocInterceptor::set_property(std::string_view name, const std::string& value, std::string& why) {
  if (context_ == nullptr) {
    // A passive component runs on its callers' threads, which read its properties without a
    // lock: there is no thread of its own to make the change on.
    why = "a passive component's properties are fixed while it runs";
    return ReturnCode::unsupported;
  }
  const ReturnCode code = context_->call([&] { return instance_->change_property(name, value); });
  if (code == ReturnCode::unsupported) why = "the component does not take changes of this property while it runs";
  else if (code != ReturnCode::ok) why = "the component refused the value (onPropertyChanged returned " + std::string(to_string(code)) + ")";
  return code;
}

InterceptorStatus InprocInterceptor::status() const {
  return InterceptorStatus{std::string(to_string(lifecycle_.state())), lifecycle_.executions(), lifecycle_.errors()};
}

void InprocInterceptor::describe(nlohmann::json& out) const {
  out["execution_context"] = context_ ? nlohmann::json(context_->settings().name) : nlohmann::json("passive");
  if (context_) out["period_ns"] = context_->period().count;
}

}  // namespace polyport::inproc
