// The native side of an in-process proxy: the component instance, its lifecycle, and the
// execution context that runs it (none for a passive component).
#pragma once

#include <memory>
#include <vector>

#include "polyport/runtime/component_api.hpp"
#include "polyport/runtime/execution_context.hpp"
#include "polyport/runtime/model.hpp"

namespace polyport::inproc {

class InprocInterceptor final : public Interceptor {
 public:
  InprocInterceptor(std::unique_ptr<ComponentBase> instance, InitialState initial_state,
                    std::vector<ProvidedServicePort*> provided);
  ~InprocInterceptor() override;

  void attach(ExecutionContext& context);  // before start
  Lifecycle& lifecycle() noexcept { return lifecycle_; }

  Result<void> start() override;
  void stop() noexcept override;
  ReturnCode command(LifecycleCommand command) override;
  InterceptorStatus status() const override;
  void describe(nlohmann::json& out) const override;
  ReturnCode set_property(std::string_view name, const std::string& value, std::string& why) override;
  const std::map<std::string, std::string, std::less<>>* properties() const override { return &instance_->properties(); }
  ExecutionContext* execution_context() const noexcept override { return context_; }

 private:
  std::unique_ptr<ComponentBase> instance_;
  Lifecycle lifecycle_;
  InitialState initial_state_;
  std::vector<ProvidedServicePort*> provided_;
  ExecutionContext* context_ = nullptr;
};

}  // namespace polyport::inproc
