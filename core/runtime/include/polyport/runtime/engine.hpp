// The engine: builds the application graph from a loaded profile (one proxy per component,
// from its model), wires the port connections, starts and stops everything in order, and
// reports statistics. Everything here runs on the control thread; the data path is in
// port.hpp / connection.hpp and runs on the writers' threads.
#pragma once

#include <deque>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "polyport/runtime/connection.hpp"
#include "polyport/runtime/execution_context.hpp"
#include "polyport/runtime/model.hpp"
#include "polyport/runtime/connection_timer.hpp"
#include "polyport/profile/profile.hpp"
#include "polyport/base/result.hpp"
#include "polyport/types/types.hpp"

namespace polyport {

class Engine {
 public:
  Engine(const ModelRegistry& models, TypeRegistry& types);
  Engine(const Engine&) = delete;
  Engine& operator=(const Engine&) = delete;
  ~Engine();

  // Creates every proxy and connection. Reports all problems; false if there was any.
  bool build(const ApplicationProfile& profile, Diagnostics& diagnostics);
  // Starts execution contexts, then initializes and activates components, receivers before
  // senders: a component starts once every component its data and calls go to has started
  // (profile order among the rest, e.g. within a cycle), so that a foreign model's writer
  // exists before the first sample is forwarded to it and a provider accepts calls before its
  // callers start. Stopping goes the other way round.
  // Warnings (e.g. real-time priority refused) are returned for the caller to log.
  Result<void> start(std::vector<std::string>& warnings);
  // Deactivates and finalizes components in reverse order, then stops the contexts. The
  // blocking mode of every required service port goes off first (see set_blocking), so a
  // component waiting on a provider that does not answer does not hold up the stop.
  void stop();
  // The blocking mode of every component's required service ports, engine-wide (a
  // component's own is ComponentBase::set_blocking): off, every call that waits ends at
  // once with cancelled and none waits until it is on again. Control thread.
  void set_blocking(bool blocking) noexcept;

  // Connects a data or event port pair at run time (control thread).
  Result<Connection*> connect(const std::string& source_component, const std::string& source_port,
                              const std::string& target_component, const std::string& target_port,
                              std::optional<QueuePolicy> policy, std::optional<std::uint32_t> depth);
  // Run-time wiring (control thread): a data or event connection checked as the loader
  // checks a profile's (polyport/profile/runtime_checks.hpp: check_connection), and the
  // removal of one by its ends ("Component.port"). A connection already there is refused.
  // A removed connection leaves both ports' lists at once, but its memory is kept until the
  // engine is destroyed: a writer or reader may still be inside it, and the forwarding path
  // takes no lock that would tell when it has left. Samples still queued in it are dropped;
  // stats() keeps listing it, marked removed, with the counts it had.
  Result<Connection*> add_connection(const ConnectionSpec& spec);
  Result<void> remove_connection(std::string_view source, std::string_view target);
  // A reload's change to the running graph (control thread). Components in `components_in`
  // are new, or replace the running instance of the same name listed in `components_out`;
  // connections in `connections_out` ("Component.port" pairs) go, and so does every connection
  // of a component that goes; `connections_in` are made (new ones, changed ones, and the
  // connections of replaced components). Service connections too: a caller's binding is
  // replaced whole; calls made already finish with the provider they went to.
  struct Change {
    std::vector<const Subcomponent*> components_in;
    std::vector<std::string> components_out;
    std::vector<const ConnectionSpec*> connections_in;
    std::vector<std::pair<std::string, std::string>> connections_out;
  };
  // Make before break: the new proxies and connections are made and the new components
  // started while the old graph runs untouched; only then do the old connections leave and
  // the old components stop. If anything fails before that, what was made is taken back and
  // the running graph is as it was; the error says what failed (profile locations included).
  // What leaves is stopped but kept in memory until the engine is destroyed (see
  // remove_connection), and so are in-process components' execution contexts: a component
  // added while the application runs gets a context of its own.
  Result<void> apply(const Change& change, std::vector<std::string>& warnings);
  // Adds a pull-mode probe on an output port ("Component.port"): an internal input port fed
  // by a circular connection that a tracer reads from another thread.
  Result<DataInPort*> add_probe(const std::string& port_path, std::uint32_t depth);

  Component* find_component(std::string_view name) const noexcept;
  Interceptor* find_interceptor(std::string_view name) const noexcept;
  Port* find_port(std::string_view path) const noexcept;  // "Component.port"
  const std::vector<std::unique_ptr<Connection>>& connections() const noexcept { return connections_; }
  // Every service link, in the order stats lists them under "services".
  const std::vector<std::pair<RequiredServicePort*, ProvidedServicePort*>>& service_links() const noexcept {
    return service_links_;
  }
  const ExecutionContextPool& executors() const noexcept { return executors_; }
  TypeRegistry& types() noexcept { return types_; }

  // The resolved graph (components, models, ports, connections with policies) as JSON.
  void describe(nlohmann::json& out) const;
  // Statistics: per connection counters and histograms, per component lifecycle, per
  // execution context jitter and overruns, per service port call counters.
  void stats(nlohmann::json& out) const;
  // Where watchdog state changes are told (from the connection timer thread); set before start().
  void set_notifier(ConnectionTimer::Notify notify) { notify_ = std::move(notify); }

  // One line for the periodic summary on stderr.
  std::string summary_line() const;

  // Takes a probe of add_probe() off its output port (a trace that ended): the forwarding
  // path stops feeding it. Its memory is kept, as a removed connection's is.
  Result<void> remove_probe(const DataInPort* probe);

 private:
  struct Node {
    std::string name;
    std::string model;
    Proxy proxy;
  };

  // By instance name: staged nodes first, then running ones not hidden (see apply()).
  const Node* find_node(std::string_view name) const noexcept;
  // Indexes into `nodes` in start order (see start()).
  std::vector<std::size_t> receivers_first(const std::vector<Node>& nodes) const;
  // Makes a profile connection with its policies; problems go to diagnostics.
  void wire(const ConnectionSpec& spec, Diagnostics& diagnostics);
  // Takes a connection off both ports and the timer; its memory moves to removed_.
  void unpublish(std::vector<std::unique_ptr<Connection>>::iterator connection);
  // Takes back what apply() made: connections from index `first` on, and the staged nodes.
  void roll_back(std::size_t first);
  // Retires those of `contexts` no running node uses any more.
  void retire_unused(const std::vector<ExecutionContext*>& contexts);
  // `publish` false: made, but not yet in the ports' lists (the caller adds it when whole).
  Result<Connection*> connect_ports(Port& source, Port& target, std::optional<QueuePolicy> policy,
                                    std::optional<std::uint32_t> depth,
                                    std::shared_ptr<const MappingProgram> mapping = nullptr, bool publish = true);
  Result<void> add_watchdog(Connection& connection, const WatchdogSpec& spec);
  Result<void> add_rate_policies(Connection& connection, const ConnectionSpec& spec);
  Result<DataOutPort*> watchdog_events(const Connection& watched, const ConnectionEnd& end);

  const ModelRegistry& models_;
  TypeRegistry& types_;
  ExecutionContextPool executors_;
  std::vector<Node> nodes_;
  // During apply(): the new nodes (found first by name), and the running ones they replace
  // (found no more by name).
  std::vector<Node> staged_;
  std::vector<std::string> hidden_;
  std::vector<Node> retired_;  // stopped by apply(), kept like removed_ connections
  std::vector<std::unique_ptr<Connection>> connections_;
  std::vector<std::unique_ptr<Connection>> removed_;  // see remove_connection
  std::vector<std::shared_ptr<const MappingProgram>> mappings_;  // used by connections_
  std::vector<std::pair<RequiredServicePort*, ProvidedServicePort*>> service_links_;
  std::vector<std::pair<RequiredServicePort*, ProvidedServicePort*>> links_before_;  // during apply()
  std::string name_;
  std::unique_ptr<Component> probes_;
  std::unique_ptr<Component> watchdog_events_;  // the watchdogs' event ports (<watchdog><event>)
  bool started_ = false;
  std::vector<Interceptor*> start_order_;  // the order started
  ConnectionTimer timer_;  // watchdogs and rate limits
  ConnectionTimer::Notify notify_;
};

}  // namespace polyport
