#include "polyport/runtime/model.hpp"

#include "polyport/runtime/component_api.hpp"
#include "polyport/runtime/service.hpp"
#include "polyport/types/types.hpp"

namespace polyport {

std::vector<OperationInfo> operations_of(const PortSpec& spec, const TypeRegistry& types) {
  std::vector<OperationInfo> out;
  for (const OperationSpec& op : spec.operations) {
    out.push_back(OperationInfo{op.name, op.request_type.empty() ? nullptr : types.find(op.request_type),
                                op.reply_type.empty() ? nullptr : types.find(op.reply_type), op.oneway});
  }
  return out;
}

ReturnCode Interceptor::set_property(std::string_view, const std::string&, std::string& why) {
  why = "polyport cannot pass a property to a component of this model while it runs";
  return ReturnCode::unsupported;
}

ReturnCode start_stop_command(Interceptor& interceptor, LifecycleCommand command) {
  switch (command) {
    case LifecycleCommand::initialize:
    case LifecycleCommand::activate:
      return interceptor.start() ? ReturnCode::ok : ReturnCode::error;
    case LifecycleCommand::deactivate:
    case LifecycleCommand::finalize:
      interceptor.stop();
      return ReturnCode::ok;
    case LifecycleCommand::reset:
    case LifecycleCommand::recover:
      return ReturnCode::unsupported;
  }
  return ReturnCode::unsupported;
}

void ModelRegistry::add(std::unique_ptr<Model> model) { models_.push_back(std::move(model)); }

Model* ModelRegistry::find(std::string_view name) const noexcept {
  for (const auto& model : models_) {
    if (model->name() == name) return model.get();
  }
  return nullptr;
}

std::vector<std::string> ModelRegistry::names() const {
  std::vector<std::string> out;
  for (const auto& model : models_) out.emplace_back(model->name());
  return out;
}

std::vector<std::pair<std::string_view, const ModelSection*>> ModelRegistry::sections() const {
  std::vector<std::pair<std::string_view, const ModelSection*>> out;
  for (const auto& model : models_) {
    if (const ModelSection* section = model->profile_section()) out.emplace_back(model->name(), section);
  }
  return out;
}

}  // namespace polyport
