#include "polyport/runtime/component.hpp"

#include <algorithm>
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstring>
#include <cstdlib>
#include <thread>
#include <utility>

#include "polyport/runtime/component_api.hpp"
#include "polyport/runtime/execution_context.hpp"
#include "polyport/runtime/push_server.hpp"

namespace polyport {

Component::Component(std::string name, std::string model) : name_(std::move(name)), model_(std::move(model)) {}

Component::~Component() = default;

Port* Component::find_port(std::string_view port_name) const noexcept {
  for (const auto& port : ports_) {
    if (port->name() == port_name) return port.get();
  }
  return nullptr;
}

ComponentBase::~ComponentBase() = default;

void ComponentBase::close_callbacks() noexcept {
  callbacks_open_.store(false, std::memory_order_seq_cst);
  // A handler that entered before the store is still counted: its writer's thread finishes
  // it. Past a few yields, sleep: a real-time context's yield would not let a writer of lower
  // priority on the same CPU run.
  for (int spins = 0; callbacks_running_.load(std::memory_order_seq_cst) != 0; ++spins) {
    if (spins < 100) {
      std::this_thread::yield();
    } else {
      std::this_thread::sleep_for(std::chrono::microseconds(100));
    }
  }
}

std::string_view to_string(ReturnCode code) noexcept {
  switch (code) {
    case ReturnCode::ok: return "ok";
    case ReturnCode::error: return "error";
    case ReturnCode::bad_parameter: return "bad_parameter";
    case ReturnCode::unsupported: return "unsupported";
    case ReturnCode::precondition_not_met: return "precondition_not_met";
  }
  return "?";
}

void ComponentBase::set_blocking(bool blocking) noexcept {
  blocking_.store(blocking, std::memory_order_release);
  for (const PortDeclaration& declaration : declarations_) {
    if (declaration.kind != PortKind::service || declaration.direction != PortDirection::required) continue;
    if (declaration.bound != nullptr && *declaration.bound != nullptr) {
      static_cast<RequiredServicePort*>(*declaration.bound)->set_blocking(blocking);
    }
  }
}

bool ComponentBase::blocking() const noexcept {
  if (!blocking_.load(std::memory_order_acquire)) return false;
  for (const PortDeclaration& declaration : declarations_) {
    if (declaration.kind != PortKind::service || declaration.direction != PortDirection::required) continue;
    if (declaration.bound != nullptr && *declaration.bound != nullptr &&
        !static_cast<const RequiredServicePort*>(*declaration.bound)->blocking()) {
      return false;
    }
  }
  return true;
}

PortDeclaration& ComponentBase::declare_port(PortDeclaration declaration) {
  declarations_.push_back(std::move(declaration));
  return declarations_.back();
}

void ComponentBase::set_instance(std::string name, std::map<std::string, std::string, std::less<>> properties,
                                 double period_seconds) {
  instance_name_ = std::move(name);
  properties_ = std::move(properties);
  period_seconds_ = period_seconds;
}

double ComponentBase::period_seconds() const noexcept {
  return context_ ? static_cast<double>(context_->period().count) / 1e9 : period_seconds_;
}

ReturnCode ComponentBase::request_period(double seconds) noexcept {
  if (context_ == nullptr) return ReturnCode::unsupported;
  if (!std::isfinite(seconds) || seconds * 1e9 < static_cast<double>(ExecutionContext::kMinPeriod.count) ||
      seconds > 3600.0) {
    return ReturnCode::bad_parameter;
  }
  // A push timed port's base cycle is a count of this component's periods (fixed at load):
  // another period would change every subscriber's cycle behind the profile's back.
  for (const PortDeclaration& declaration : declarations_) {
    if (declaration.kind != PortKind::data || declaration.direction != PortDirection::output) continue;
    if (declaration.bound == nullptr || *declaration.bound == nullptr) continue;
    const PushServer* push = static_cast<const DataOutPort*>(*declaration.bound)->push();
    if (push != nullptr && push->pattern() == PushPattern::timed) return ReturnCode::unsupported;
  }
  return context_->set_period(Nanos{std::llround(seconds * 1e9)}) ? ReturnCode::ok : ReturnCode::bad_parameter;
}

void ComponentBase::enable_notifications(std::string port_name, bool automatic, PortKind kind) {
  auto_notifications_ = automatic;
  declare_port(detail::make_declaration<ComponentNotification>(std::move(port_name), kind,
                                                               PortDirection::output, &notifications_));
}

// The sample is built on the stack and copied by the port: no allocation, no lock. One thread
// at a time, as any output port is written (port.hpp); the serial number orders the
// notifications of the threads that take turns (a context's and a passive caller's).
Status ComponentBase::notify(NotificationKind kind) noexcept {
  if (notifications_ == nullptr) return Status::not_connected;
  ComponentNotification sample;
  std::memset(&sample, 0, sizeof sample);  // padding too: the sample is copied whole
  sample.kind = static_cast<std::int32_t>(kind);
  sample.serial = static_cast<std::int64_t>(notification_sequence_.fetch_add(1, std::memory_order_relaxed) + 1);
  sample.time_ns = mono_now().ns;
  const std::size_t length = std::min(instance_name_.size(), sizeof sample.component - 1);
  std::memcpy(sample.component, instance_name_.data(), length);
  return static_cast<DataOutPort*>(notifications_)->write(&sample, sizeof sample);
}

ReturnCode ComponentBase::change_property(std::string_view name, std::string value) noexcept {
  try {
    auto it = properties_.find(name);
    const bool added = it == properties_.end();
    if (added) it = properties_.emplace(std::string(name), std::string()).first;
    std::string old = std::exchange(it->second, std::move(value));
    ReturnCode code = ReturnCode::error;
    try {
      code = onPropertyChanged(it->first, it->second);
    } catch (...) {
      code = ReturnCode::error;
    }
    if (code != ReturnCode::ok) {
      if (added) properties_.erase(it);
      else it->second = std::move(old);
    }
    return code;
  } catch (...) {  // allocation failed
    return ReturnCode::error;
  }
}

bool ComponentBase::has_property(std::string_view name) const { return properties_.find(name) != properties_.end(); }

std::string ComponentBase::property(std::string_view name, std::string_view fallback) const {
  auto it = properties_.find(name);
  return it == properties_.end() ? std::string(fallback) : it->second;
}

double ComponentBase::property_double(std::string_view name, double fallback) const {
  auto it = properties_.find(name);
  if (it == properties_.end()) return fallback;
  char* end = nullptr;
  const double value = std::strtod(it->second.c_str(), &end);
  return (end == it->second.c_str() || *end != '\0') ? fallback : value;
}

std::int64_t ComponentBase::property_int(std::string_view name, std::int64_t fallback) const {
  auto it = properties_.find(name);
  if (it == properties_.end()) return fallback;
  std::int64_t value = 0;
  const char* first = it->second.data();
  const char* last = first + it->second.size();
  auto [ptr, ec] = std::from_chars(first, last, value);
  return (ec != std::errc() || ptr != last) ? fallback : value;
}

bool ComponentBase::property_bool(std::string_view name, bool fallback) const {
  auto it = properties_.find(name);
  if (it == properties_.end()) return fallback;
  const std::string& v = it->second;
  if (v == "true" || v == "1" || v == "yes" || v == "on") return true;
  if (v == "false" || v == "0" || v == "no" || v == "off") return false;
  return fallback;
}

}  // namespace polyport
