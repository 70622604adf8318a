// The application-side face of an in-process component: the ports its component profile
// lists, typed from the registry, bound to the ports the component's C++ class declares.
// Binding checks that both sides agree (name, kind, direction, payload size and alignment),
// so a plugin built against other types is refused at load time, not at the first sample.
// A port the class declares as a CallbackInPort is put in push mode here, before wiring.
#pragma once

#include <memory>

#include "polyport/runtime/component.hpp"
#include "polyport/runtime/component_api.hpp"
#include "polyport/base/diagnostics.hpp"
#include "polyport/profile/profile.hpp"
#include "polyport/types/types.hpp"

namespace polyport::inproc {

class InprocAdaptor final : public Component {
 public:
  InprocAdaptor(std::string name) : Component(std::move(name), "inproc") {}

  // Creates the profile's ports and binds the instance's declarations to them. Problems
  // are reported at the profile's locations; returns null when there was one.
  // `serve_on_caller_thread`: run provided operations on the caller's thread (a passive
  // component has no thread of its own to run them).
  static std::unique_ptr<InprocAdaptor> create(const Subcomponent& subcomponent, const TypeRegistry& types,
                                               ComponentBase& instance, bool serve_on_caller_thread,
                                               Diagnostics& diagnostics);

  // Provided ports, for the execution context that serves their queued calls.
  std::vector<ProvidedServicePort*> provided_ports() const;
};

}  // namespace polyport::inproc
