// The model boundary. A model (inproc, cyclonedds, fastdds, lcm, socketcan) turns each
// component profile of its kind into a Proxy: an adaptor (a Component: the component's face
// in the application, with the same typed ports) and an interceptor (the native side: SDK
// endpoints, sockets, or the in-process execution context). The engine wires adaptors to
// each other and never sees a model's SDK. Models are listed explicitly in a ModelRegistry
// by the daemon (no static-initialiser registration).
#pragma once

#include <map>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "polyport/runtime/component.hpp"
#include "polyport/base/diagnostics.hpp"
#include "polyport/runtime/execution_context.hpp"
#include "polyport/profile/model_section.hpp"
#include "polyport/profile/profile.hpp"
#include "polyport/base/result.hpp"

#include <nlohmann/json_fwd.hpp>

namespace polyport {

class TypeRegistry;
struct OperationInfo;

// A service port's operations with their types looked up (null: no payload); for adaptors.
std::vector<OperationInfo> operations_of(const PortSpec& spec, const TypeRegistry& types);

// What a lifecycle-aware interceptor reports about one of its components.
struct InterceptorStatus {
  std::string state;        // lifecycle state name
  std::uint64_t executions = 0;
  std::uint64_t errors = 0;
};

class Interceptor {
 public:
  virtual ~Interceptor() = default;
  // initialize + activate as the profile asks; stop deactivates and finalizes. Both run on
  // the control thread; start happens after every connection is in place.
  virtual Result<void> start() = 0;
  virtual void stop() noexcept = 0;
  // Lifecycle commands from the control path (polyportctl, tests).
  virtual ReturnCode command(LifecycleCommand command) = 0;
  virtual InterceptorStatus status() const = 0;
  // Anything model-specific for `polyportd check` and the statistics.
  virtual void describe(nlohmann::json& out) const = 0;
  // Run-time property changes (polyportctl set), control thread; the value is checked
  // against the component profile already. A model that can tell its component passes the
  // value on (in-process: onPropertyChanged on the component's own thread) and returns the
  // component's answer; `why` says more when it is not ok. The default: unsupported, for
  // models whose components polyport cannot reach (a DDS or LCM application).
  virtual ReturnCode set_property(std::string_view name, const std::string& value, std::string& why);
  // The component's current property values, when the model holds them (in-process); null
  // otherwise (the profile's values are what is known).
  virtual const std::map<std::string, std::string, std::less<>>* properties() const { return nullptr; }
  // The execution context that runs the component, when polyport runs it (in-process); null
  // otherwise. The engine retires a context whose components all left (a reload).
  virtual ExecutionContext* execution_context() const noexcept { return nullptr; }
};

// The lifecycle commands of a foreign component that has none of its own (a DDS or LCM
// application): initialize and activate start the interceptor, deactivate and finalize stop
// it, reset and recover are unsupported.
ReturnCode start_stop_command(Interceptor& interceptor, LifecycleCommand command);

struct Proxy {
  std::unique_ptr<Component> adaptor;
  std::unique_ptr<Interceptor> interceptor;
};

// What a model may use from the engine while it builds proxies.
struct ModelContext {
  TypeRegistry& types;
  ExecutionContextPool& executors;
};

class Model {
 public:
  virtual ~Model() = default;
  virtual std::string_view name() const noexcept = 0;
  // The model's own profile elements and their reader (model_section.hpp); null when the
  // model has none. What the reader returns arrives in create_proxy as the component
  // profile's model_settings.
  virtual const ModelSection* profile_section() const noexcept { return nullptr; }
  // Problems go to diagnostics with the profile's locations; nullopt when there was one.
  virtual std::optional<Proxy> create_proxy(const Subcomponent& subcomponent, ModelContext& context,
                                            Diagnostics& diagnostics) = 0;
};

// Also what the profile loader knows of models (LoadOptions::models): their sections.
class ModelRegistry final : public ModelSections {
 public:
  void add(std::unique_ptr<Model> model);
  Model* find(std::string_view name) const noexcept;
  std::vector<std::string> names() const;
  std::vector<std::pair<std::string_view, const ModelSection*>> sections() const override;

 private:
  std::vector<std::unique_ptr<Model>> models_;
};

}  // namespace polyport
