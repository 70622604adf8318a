// The in-process component API (version kComponentApiVersion). A plugin is a shared library
// that exports `polyport_component_plugin()`, returning its PluginInfo: the API version it
// was built against and a factory per component class. A component derives from
// ComponentBase, overrides the lifecycle hooks it needs, and declares its ports as members:
//
//   class JoystickComp : public polyport::ComponentBase {
//     polyport::InPort<Position> position_{*this, "position"};
//     polyport::OutPort<Reference> reference_{*this, "reference"};
//     polyport::CallbackInPort<Stop> stop_{*this, "stop", &JoystickComp::on_stop};
//     polyport::ReturnCode onExecute() override { ... }
//     void on_stop(const Stop& stop, const polyport::SampleMeta& meta);  // as each arrives
//   };
//   POLYPORT_COMPONENTS(POLYPORT_COMPONENT(JoystickComp))
//
// The component profile names each port's IDL type; when the component is loaded the
// engine checks that every declared port exists in the profile with the same direction and
// that the C++ type has the flat layout's size and alignment (types.hpp). Port types must be
// trivially copyable structs laid out like the IDL type.
#pragma once

#include <atomic>
#include <cstdint>
#include <cstring>
#include <deque>
#include <initializer_list>
#include <map>
#include <memory>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

#include "polyport/runtime/event_condition.hpp"
#include "polyport/runtime/lifecycle.hpp"
#include "polyport/runtime/port.hpp"
#include "polyport/runtime/service.hpp"

namespace polyport {

// Raised whenever what a plugin compiles in changes layout (ComponentBase, PortDeclaration, the
// port templates): the loader then refuses a plugin built against other headers.
inline constexpr int kComponentApiVersion = 3;

class ExecutionContext;

// A component's busy / idle / refresh notifications (JOrocos's `notifying` interface): the
// flat layout of polyport::ComponentNotification (config/types/component_notification.idl),
// written on the event output port the component profile's <notifications> element adds.
enum class NotificationKind : std::int32_t { busy = 0, idle = 1, refresh = 2 };
struct ComponentNotification {
  std::int32_t kind;       // NotificationKind
  std::int64_t serial;     // 1, 2, 3, ... per component, over all kinds
  std::int64_t time_ns;    // CLOCK_MONOTONIC when raised
  char component[64];      // the instance name (string<63>)
};

enum class ReturnCode : std::uint8_t { ok, error, bad_parameter, unsupported, precondition_not_met };
std::string_view to_string(ReturnCode code) noexcept;

// What a component declares about one of its ports; the engine fills `bound`.
struct PortDeclaration {
  std::string name;
  PortKind kind = PortKind::data;
  PortDirection direction = PortDirection::input;
  std::uint32_t size = 0;   // sizeof the C++ payload type (0: none)
  std::uint32_t align = 1;
  Port** bound = nullptr;   // where the engine stores the port it binds
  // Provided services: handlers by operation name, registered by the component.
  struct Operation {
    std::string name;
    std::uint32_t request_size = 0;
    std::uint32_t reply_size = 0;
    ProvidedServicePort::Handler handler;
    ProvidedServicePort::Dispatch dispatch = ProvidedServicePort::Dispatch::own_thread;
  };
  std::vector<Operation> operations;
  // A data input port in push mode (CallbackInPort): the engine hands its samples to this
  // sink on the writer's thread instead of buffering them. Null: pull mode (InPort).
  SampleSink* sink = nullptr;
};

class ComponentBase {
 public:
  ComponentBase() = default;
  ComponentBase(const ComponentBase&) = delete;
  ComponentBase& operator=(const ComponentBase&) = delete;
  virtual ~ComponentBase();

  virtual ReturnCode onInitialize() { return ReturnCode::ok; }
  virtual ReturnCode onActivated() { return ReturnCode::ok; }
  virtual ReturnCode onExecute() { return ReturnCode::ok; }
  virtual void onStateUpdate() {}
  virtual ReturnCode onDeactivated() { return ReturnCode::ok; }
  virtual ReturnCode onError() { return ReturnCode::ok; }
  virtual ReturnCode onReset() { return ReturnCode::ok; }
  virtual ReturnCode onFinalize() { return ReturnCode::ok; }
  // A property was changed while the application runs (polyportctl set). Called on the
  // component's own thread: its execution context's, between two cycles (or the control
  // thread while the context is not running), never at the same time as another hook; in
  // any lifecycle state. The new value is in place already (property() returns it); return
  // ok to take it, anything else to refuse it (the old value is put back and the operator
  // told the code). The default refuses with unsupported: a component that reads its
  // properties only in onInitialize would otherwise be told of a value it never uses.
  // Passive components (no thread of their own) are never called: their properties are
  // fixed while they run.
  virtual ReturnCode onPropertyChanged(std::string_view name, std::string_view value) {
    (void)name;
    (void)value;
    return ReturnCode::unsupported;
  }

  const std::string& instance_name() const noexcept { return instance_name_; }
  // The component's lifecycle state as the engine drives it (created until a Lifecycle is
  // attached). Any thread.
  LifecycleState state() const noexcept {
    const Lifecycle* lifecycle = lifecycle_.load(std::memory_order_acquire);
    return lifecycle ? lifecycle->state() : LifecycleState::created;
  }
  // The blocking mode of the component's required services (SmartSoft's blocking()): while
  // it is off no call waits; a query, receive or receive_wait under way ends at once with
  // Status::cancelled. The engine switches it off before deactivating, finalizing or
  // stopping the component, and on before activating it. Any thread. blocking() is false
  // also while the engine has switched a required port's mode off (Engine::set_blocking).
  void set_blocking(bool blocking) noexcept;
  bool blocking() const noexcept;
  // The period of the execution context running this component (0 when passive): the
  // current one, which request_period may have changed.
  double period_seconds() const noexcept;
  // Asks the execution context running this component for another period (seconds), from
  // the next cycle on; any thread. A context is shared by the components with the same
  // execution settings, unless the profile says periodic-exclusive: the change applies to
  // all of them. bad_parameter below 1 us (or not finite), below 100 us for a real-time
  // context, under twice the context's spin tail; unsupported when passive or when the
  // component owns a push timed port (its base cycle is counted in periods).
  ReturnCode request_period(double seconds) noexcept;

  // Busy / idle / refresh notifications on the port the component profile's
  // <notifications port=".."/> names (docs/PROFILES.md, "Notifications"). One thread at a
  // time, as any output port (the component's own: its context's, which raises the auto
  // ones); no allocation; not_connected (and nothing sent) when the profile gives the component no
  // such port. With <notifications auto="true"/> the execution context raises busy before
  // and idle after each onExecute on top of what the component raises itself.
  Status notify_busy() noexcept { return notify(NotificationKind::busy); }
  Status notify_idle() noexcept { return notify(NotificationKind::idle); }
  Status notify_refresh() noexcept { return notify(NotificationKind::refresh); }
  Status notify(NotificationKind kind) noexcept;
  bool notifications_enabled() const noexcept { return notifications_ != nullptr; }
  bool auto_notifications() const noexcept { return auto_notifications_; }
  std::uint64_t notifications_sent() const noexcept { return notification_sequence_.load(std::memory_order_relaxed); }

  // Properties from the component profile; `fallback` when absent or not convertible.
  bool has_property(std::string_view name) const;
  std::string property(std::string_view name, std::string_view fallback = {}) const;
  double property_double(std::string_view name, double fallback) const;
  std::int64_t property_int(std::string_view name, std::int64_t fallback) const;
  bool property_bool(std::string_view name, bool fallback) const;

  // Engine side (used by the in-process model when loading the component).
  std::deque<PortDeclaration>& port_declarations() noexcept { return declarations_; }
  PortDeclaration& declare_port(PortDeclaration declaration);
  void set_instance(std::string name, std::map<std::string, std::string, std::less<>> properties,
                    double period_seconds);
  // Puts `value` in place and calls onPropertyChanged; restores the old value unless it
  // returns ok (a hook that throws counts as error). Only on the component's own thread
  // (see onPropertyChanged); the in-process interceptor arranges that.
  ReturnCode change_property(std::string_view name, std::string value) noexcept;
  // The current values. Read on the control thread, which is the only one that starts a
  // change and waits for it to finish.
  const std::map<std::string, std::string, std::less<>>& properties() const noexcept { return properties_; }
  // Declares the notification output port (before the engine binds the ports).
  void enable_notifications(std::string port_name, bool automatic, PortKind kind = PortKind::event);
  // The context that runs this component (ExecutionContext::add); null while passive.
  void attach_execution_context(ExecutionContext* context) noexcept { context_ = context; }
  ExecutionContext* execution_context() const noexcept { return context_; }
  // The Lifecycle that drives this component (its constructor and destructor call this).
  void attach_lifecycle(const Lifecycle* lifecycle) noexcept { lifecycle_.store(lifecycle, std::memory_order_release); }
  // CallbackInPort's gate, which the Lifecycle drives: a sample reaches a handler only while
  // it is open, from the moment onActivated has succeeded until the component leaves active
  // (deactivated, or its onExecute failed). enter / leave: any thread, no lock (a handler
  // runs between them). close_callbacks waits for the handlers already running, so that none
  // is left when onDeactivated, onReset or onFinalize begins; never call it from one of this
  // component's handlers.
  bool enter_callback() noexcept {
    callbacks_running_.fetch_add(1, std::memory_order_seq_cst);
    if (callbacks_open_.load(std::memory_order_seq_cst)) return true;
    leave_callback();
    return false;
  }
  void leave_callback() noexcept { callbacks_running_.fetch_sub(1, std::memory_order_release); }
  void open_callbacks() noexcept { callbacks_open_.store(true, std::memory_order_seq_cst); }
  void close_callbacks() noexcept;

 private:
  std::deque<PortDeclaration> declarations_;  // a deque: declarations keep their address
  std::string instance_name_;
  std::map<std::string, std::string, std::less<>> properties_;
  double period_seconds_ = 0.0;
  std::atomic<bool> blocking_{true};
  ExecutionContext* context_ = nullptr;
  std::atomic<const Lifecycle*> lifecycle_{nullptr};
  std::atomic<bool> callbacks_open_{false};
  std::atomic<std::uint32_t> callbacks_running_{0};
  Port* notifications_ = nullptr;
  bool auto_notifications_ = false;
  std::atomic<std::uint64_t> notification_sequence_{0};
};

namespace detail {
template <class T>
constexpr void check_payload() {
  static_assert(std::is_trivially_copyable_v<T>, "port payloads must be trivially copyable");
}
template <class T>
PortDeclaration make_declaration(std::string name, PortKind kind, PortDirection direction, Port** bound) {
  check_payload<T>();
  return PortDeclaration{std::move(name), kind, direction, static_cast<std::uint32_t>(sizeof(T)),
                         static_cast<std::uint32_t>(alignof(T)), bound, {}};
}
}  // namespace detail

template <class T>
class OutPort {
 public:
  OutPort(ComponentBase& owner, std::string name) {
    owner.declare_port(detail::make_declaration<T>(std::move(name), PortKind::data,
                                                   PortDirection::output, &port_));
  }
  Status write(const T& value) noexcept { return port().write(&value, sizeof(T)); }
  // The engine binds a port of the declared kind and direction (checked at load time).
  DataOutPort& port() const noexcept { return *static_cast<DataOutPort*>(port_); }

 private:
  Port* port_ = nullptr;
};

template <class T>
class InPort {
 public:
  InPort(ComponentBase& owner, std::string name) {
    owner.declare_port(detail::make_declaration<T>(std::move(name), PortKind::data,
                                                   PortDirection::input, &port_));
  }
  // ok: new data; old_data: the latest value again; no_data: `value` is left as it was.
  Status read(T& value) noexcept { return port().read(&value, sizeof(T)); }
  DataInPort& port() const noexcept { return *static_cast<DataInPort*>(port_); }

 private:
  Port* port_ = nullptr;
};

// An input port whose samples are handed to the component as they arrive, as RTC's
// ON_RECEIVED data listener or an OPRoS event callback does, instead of waiting in a buffer
// for the next onExecute: `on_data(sample, meta)`, a member of the component, with a copy of
// the sample (on the stack, valid during the call) and its SampleMeta (size, t_in when it
// entered polyport, the source's own stamp if its model gives one). The engine binds the port
// in push mode (DataInPort::set_sink): no buffer, no allocation, no lock of polyport's.
//
// Threading: on_data runs on the writer's thread, whichever that is: the receive thread of
// a foreign model's SDK (an LCM or DDS listener), another component's execution context (in
// the middle of its write()), or the timer thread handing over a watchdog's safe value. So:
//  - it must not block, and should be short: the writer (and, for a foreign model, its
//    receive thread) waits for it;
//  - it may run at the same time as the component's own hooks (onExecute on its context) and,
//    when several connections feed the port from several threads, at the same time as itself:
//    state it shares with them needs atomics (or its own care);
//  - it may write an OutPort (an echo answers from the callback), but DataOutPort::write is
//    one writer at a time: a port written from on_data must not also be written from
//    onExecute or from another thread at the same time;
//  - a write that comes back into this port on the same thread (an in-process loop) calls
//    on_data again, nested: a component that answers what answers it must unwind itself (a
//    trampoline: note the work, return, and let the outermost call do it). A connection with
//    a watchdog or a rate limit hands over one sample at a time (its writer may wait for the
//    timer thread's safe value to pass through on_data) and refuses one that comes back
//    through it (a sink error);
//  - it must not throw (an exception is caught and counted as the sample's sink error).
// Samples are handed over only while the component is active: from the moment onActivated
// has succeeded until deactivation begins (or onExecute fails); others are refused
// (not_active, counted by the connection as sink errors). When the component leaves active
// the engine waits for the calls under way (before onDeactivated; as soon as onExecute has
// failed), so on_data never runs before onActivated has set the component up, nor while
// onDeactivated, onError, onReset or onFinalize runs.
// The profile declares the port as any data input port (its policy and depth do not apply).
template <class T>
class CallbackInPort final : private SampleSink {
 public:
  template <class C>
  CallbackInPort(C& owner, std::string name, void (C::*on_data)(const T&, const SampleMeta&))
      : owner_(owner), on_data_(static_cast<Handler>(on_data)) {
    static_assert(std::is_base_of_v<ComponentBase, C>, "the handler must be a member of the component");
    PortDeclaration declaration =
        detail::make_declaration<T>(std::move(name), PortKind::data, PortDirection::input, &port_);
    declaration.sink = this;
    owner.declare_port(std::move(declaration));
  }
  CallbackInPort(const CallbackInPort&) = delete;
  CallbackInPort& operator=(const CallbackInPort&) = delete;

  // Its connections and settings (statistics); never read() it: it buffers nothing.
  DataInPort& port() const noexcept { return *static_cast<DataInPort*>(port_); }

 private:
  using Handler = void (ComponentBase::*)(const T&, const SampleMeta&);

  Status on_sample(const std::byte* data, const SampleMeta& meta) noexcept override {
    if (meta.size < sizeof(T)) return Status::bad_size;
    if (!owner_.enter_callback()) return Status::not_active;
    T sample;  // aligned for T, whatever the wire left the bytes at
    std::memcpy(&sample, data, sizeof(T));
    Status status = Status::ok;
    try {
      (owner_.*on_data_)(static_cast<const T&>(sample), meta);
    } catch (...) {
      status = Status::error;
    }
    owner_.leave_callback();
    return status;
  }

  ComponentBase& owner_;
  Handler on_data_;
  Port* port_ = nullptr;
};

// Events: a small payload (an int32 code by default) queued for the receiver.
template <class T = std::int32_t>
class EventOutPort {
 public:
  EventOutPort(ComponentBase& owner, std::string name) {
    owner.declare_port(detail::make_declaration<T>(std::move(name), PortKind::event,
                                                   PortDirection::output, &port_));
  }
  Status raise(const T& event) noexcept { return static_cast<DataOutPort*>(port_)->write(&event, sizeof(T)); }

 private:
  Port* port_ = nullptr;
};

template <class T = std::int32_t>
class EventInPort {
 public:
  EventInPort(ComponentBase& owner, std::string name) {
    owner.declare_port(detail::make_declaration<T>(std::move(name), PortKind::event,
                                                   PortDirection::input, &port_));
  }
  // ok with the next event, or no_data (`event` is then left as it was).
  Status take(T& event) noexcept {
    T next;
    const Status status = static_cast<DataInPort*>(port_)->read(&next, sizeof(T));
    if (status != Status::ok) return status == Status::old_data ? Status::no_data : status;
    event = next;
    return Status::ok;
  }

  // An event with a condition (the connection's <condition>): from now on the server's state
  // changes for which the condition holds come as events, once (single) or each time
  // (continuous). Parameters override the thresholds of the fields that name them
  // (param="level"); the others keep the profile's values. not_connected: no connection into
  // this port has a condition; error: a parameter that no field names (nothing changed).
  // Any thread; never blocks the server's writer.
  Status activate(EventMode mode, std::initializer_list<ConditionParameter> parameters = {}) noexcept {
    return activate_conditions(*static_cast<DataInPort*>(port_), mode,
                               std::span<const ConditionParameter>(parameters.begin(), parameters.size()));
  }
  // No events until activated again (but for one state the server's thread may be testing
  // against the activation before, at this moment).
  Status deactivate() noexcept { return deactivate_conditions(*static_cast<DataInPort*>(port_)); }

 private:
  Port* port_ = nullptr;
};

// A provided service: operations with typed request and reply, registered by name.
class ProvidedService {
 public:
  using Dispatch = ProvidedServicePort::Dispatch;
  ProvidedService(ComponentBase& owner, std::string name)
      : declaration_(&owner.declare_port(PortDeclaration{std::move(name), PortKind::service,
                                                         PortDirection::provided, 0, 1,
                                                         &port_, {}})) {}

  // fn(const Req&, Rep&) -> ReturnCode
  template <class Req, class Rep, class F>
  void provide(std::string operation, F fn, Dispatch dispatch = Dispatch::own_thread) {
    detail::check_payload<Req>();
    detail::check_payload<Rep>();
    declaration_->operations.push_back(
        {std::move(operation), sizeof(Req), sizeof(Rep),
         [fn = std::move(fn)](const std::byte* request, std::uint32_t request_size, std::byte* reply,
                              std::uint32_t& reply_size) mutable -> Status {
           if (request_size != sizeof(Req) || reply_size < sizeof(Rep)) return Status::bad_size;
           Req req;
           std::memcpy(&req, request, sizeof(Req));
           Rep rep{};
           ReturnCode code = fn(static_cast<const Req&>(req), rep);
           std::memcpy(reply, &rep, sizeof(Rep));
           reply_size = sizeof(Rep);
           return code == ReturnCode::ok ? Status::ok : Status::error;
         },
         dispatch});
  }
  // fn(const Req&): a one-way operation.
  template <class Req, class F>
  void provide_oneway(std::string operation, F fn, Dispatch dispatch = Dispatch::own_thread) {
    detail::check_payload<Req>();
    declaration_->operations.push_back(
        {std::move(operation), sizeof(Req), 0,
         [fn = std::move(fn)](const std::byte* request, std::uint32_t request_size, std::byte*,
                              std::uint32_t& reply_size) mutable -> Status {
           if (request_size != sizeof(Req)) return Status::bad_size;
           Req req;
           std::memcpy(&req, request, sizeof(Req));
           fn(static_cast<const Req&>(req));
           reply_size = 0;
           return Status::ok;
         },
         dispatch});
  }
  ProvidedServicePort& port() const noexcept { return *static_cast<ProvidedServicePort*>(port_); }

 private:
  PortDeclaration* declaration_;  // stable: ComponentBase keeps declarations in a deque
  Port* port_ = nullptr;
};

// A required service: SmartSoft's query client. query() is the synchronous call; request()
// starts an asynchronous one, receive() takes its reply if it is there (no_data: not yet),
// receive(timeout) waits at most that long, receive_wait() as long as it takes, discard()
// gives it up. Every wait ends at once with Status::cancelled when the component's blocking
// mode goes off (ComponentBase::set_blocking); the call then stays in flight until received
// or discarded (a query gives its call up itself).
class RequiredService {
 public:
  RequiredService(ComponentBase& owner, std::string name) {
    owner.declare_port(PortDeclaration{std::move(name), PortKind::service, PortDirection::required,
                                       0, 1, &port_, {}});
  }
  template <class Req, class Rep>
  Status query(std::string_view operation, const Req& request, Rep& reply, Nanos timeout = kWaitForever) {
    return port().query(operation, &request, sizeof(Req), &reply, sizeof(Rep), timeout);
  }
  template <class Req>
  CallHandle request(std::string_view operation, const Req& request) {
    return port().request(operation, &request, sizeof(Req));
  }
  template <class Rep>
  Status receive(CallHandle& handle, Rep& reply) noexcept {
    return port().try_receive(handle, &reply, sizeof(Rep));
  }
  template <class Rep>
  Status receive(CallHandle& handle, Rep& reply, Nanos timeout) {
    return port().receive(handle, &reply, sizeof(Rep), timeout);
  }
  template <class Rep>
  Status receive_wait(CallHandle& handle, Rep& reply) {
    return port().receive_wait(handle, &reply, sizeof(Rep));
  }
  void discard(CallHandle& handle) noexcept { port().cancel(handle); }
  template <class Req>
  Status send(std::string_view operation, const Req& request) {
    return port().send(operation, &request, sizeof(Req));
  }
  bool connected() const noexcept { return port().connected(); }
  RequiredServicePort& port() const noexcept { return *static_cast<RequiredServicePort*>(port_); }

 private:
  Port* port_ = nullptr;
};

// The plugin's table of component classes.
struct ComponentFactory {
  const char* class_name;
  std::unique_ptr<ComponentBase> (*create)();
};
struct PluginInfo {
  int api_version;
  const ComponentFactory* factories;
  std::size_t factory_count;
};

}  // namespace polyport

#define POLYPORT_COMPONENT(Class) \
  ::polyport::ComponentFactory { #Class, []() -> std::unique_ptr<::polyport::ComponentBase> { return std::make_unique<Class>(); } }

#define POLYPORT_COMPONENTS(...)                                                           \
  extern "C" __attribute__((visibility("default"))) const ::polyport::PluginInfo*          \
  polyport_component_plugin() {                                                            \
    static const ::polyport::ComponentFactory factories[] = {__VA_ARGS__};                \
    static const ::polyport::PluginInfo info{::polyport::kComponentApiVersion, factories, \
                                             sizeof(factories) / sizeof(factories[0])};    \
    return &info;                                                                          \
  }
