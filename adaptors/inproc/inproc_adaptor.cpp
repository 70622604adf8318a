#include "inproc_adaptor.hpp"

#include "polyport/runtime/model.hpp"

#include <string>

namespace polyport::inproc {

namespace {

std::string describe_declaration(const PortDeclaration& d) {
  return std::string(to_string(d.kind)) + " " + std::string(to_string(d.direction)) + " port '" + d.name + "'";
}

}  // namespace

std::unique_ptr<InprocAdaptor> InprocAdaptor::create(const Subcomponent& subcomponent, const TypeRegistry& types,
                                                     ComponentBase& instance, bool serve_on_caller_thread,
                                                     Diagnostics& diagnostics) {
  const ComponentProfile& profile = subcomponent.profile;
  auto adaptor = std::make_unique<InprocAdaptor>(subcomponent.name);
  const std::size_t errors_before = diagnostics.error_count();
  const std::string where_class = "component class '" + profile.class_name + "'";

  for (const PortSpec& spec : profile.ports) {
    const Type* type = spec.data_type.empty() ? nullptr : types.find(spec.data_type);
    if (!spec.data_type.empty() && !type) {
      diagnostics.error(spec.where, {}, "unknown type '" + spec.data_type + "'");
      continue;
    }
    if (spec.kind == PortKind::event && !type) type = types.primitive(TypeKind::int32);
    const std::uint32_t bytes = type ? type->size : 0;
    switch (spec.direction) {
      case PortDirection::output:
        adaptor->add_port<DataOutPort>(spec.name, spec.kind, type, bytes);
        break;
      case PortDirection::input: {
        const QueuePolicy policy =
            spec.policy.value_or(spec.kind == PortKind::event ? QueuePolicy::circular : QueuePolicy::data);
        adaptor->add_port<DataInPort>(spec.name, spec.kind, type, bytes, policy, spec.depth.value_or(16));
        break;
      }
      case PortDirection::provided:
        adaptor->add_port<ProvidedServicePort>(spec.name, spec.service_type, operations_of(spec, types));
        break;
      case PortDirection::required:
        adaptor->add_port<RequiredServicePort>(spec.name, spec.service_type, operations_of(spec, types));
        break;
    }
  }
  if (diagnostics.error_count() != errors_before) return nullptr;

  std::vector<const PortSpec*> bound;
  for (PortDeclaration& declaration : instance.port_declarations()) {
    const PortSpec* spec = profile.find_port(declaration.name);
    if (!spec) {
      diagnostics.error(profile.where, {}, where_class + " declares " + describe_declaration(declaration) +
                                               " that the component profile does not list");
      continue;
    }
    bound.push_back(spec);
    if (spec->kind != declaration.kind || spec->direction != declaration.direction) {
      diagnostics.error(spec->where, {}, "port '" + spec->name + "' is a " + std::string(to_string(spec->kind)) +
                                             " " + std::string(to_string(spec->direction)) + " port in the profile but " +
                                             where_class + " declares a " + describe_declaration(declaration));
      continue;
    }
    Port* port = adaptor->find_port(spec->name);
    if (port->type() && declaration.size != 0 &&
        (port->type()->size != declaration.size || port->type()->align != declaration.align)) {
      diagnostics.error(spec->where, {}, "port '" + spec->name + "': type '" + port->type()->name + "' has size " +
                                             std::to_string(port->type()->size) + " and alignment " +
                                             std::to_string(port->type()->align) + " but " + where_class +
                                             " uses a C++ type of size " + std::to_string(declaration.size) +
                                             " and alignment " + std::to_string(declaration.align));
      continue;
    }
    if (auto* provided = dynamic_cast<ProvidedServicePort*>(port)) {
      for (auto& op : declaration.operations) {
        const int index = provided->find_operation(op.name);
        if (index < 0) {
          diagnostics.error(spec->where, {}, where_class + " provides operation '" + op.name + "' on port '" +
                                                 spec->name + "' that the component profile does not list");
          continue;
        }
        const OperationInfo& info = provided->operations()[static_cast<std::size_t>(index)];
        const std::uint32_t request_size = info.request ? info.request->size : 0;
        const std::uint32_t reply_size = info.reply ? info.reply->size : 0;
        if (request_size != op.request_size || (!info.oneway && reply_size != op.reply_size)) {
          diagnostics.error(spec->where, {}, "operation '" + spec->name + "." + op.name +
                                                 "': request/reply sizes in the profile (" + std::to_string(request_size) +
                                                 "/" + std::to_string(reply_size) + ") differ from " + where_class +
                                                 " (" + std::to_string(op.request_size) + "/" +
                                                 std::to_string(op.reply_size) + ")");
          continue;
        }
        provided->set_handler(static_cast<std::uint16_t>(index), std::move(op.handler),
                              serve_on_caller_thread ? ProvidedServicePort::Dispatch::caller_thread : op.dispatch);
      }
    }
    // A CallbackInPort: push mode, set here before the engine wires the port, so that its
    // connections are made without a buffer and deliver on the writer's thread.
    if (declaration.sink != nullptr) {
      auto* in = dynamic_cast<DataInPort*>(port);
      if (in == nullptr) {
        diagnostics.error(spec->where, {}, "port '" + spec->name + "' cannot hand samples to " + where_class +
                                               " as they arrive: it is no data input port");
        continue;
      }
      in->set_sink(declaration.sink);
    }
    *declaration.bound = port;
  }
  for (const PortSpec& spec : profile.ports) {
    bool declared = false;
    for (const PortSpec* b : bound) declared = declared || b == &spec;
    if (!declared) {
      diagnostics.error(spec.where, {}, "port '" + spec.name + "' is not declared by " + where_class);
    }
  }
  if (diagnostics.error_count() != errors_before) return nullptr;
  return adaptor;
}

std::vector<ProvidedServicePort*> InprocAdaptor::provided_ports() const {
  std::vector<ProvidedServicePort*> out;
  for (const auto& port : ports()) {
    if (auto* provided = dynamic_cast<ProvidedServicePort*>(port.get())) out.push_back(provided);
  }
  return out;
}

}  // namespace polyport::inproc
