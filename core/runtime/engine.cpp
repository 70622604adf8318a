// Building, starting and stopping the application graph, and its statistics. Control thread.
#include "polyport/runtime/engine.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdio>
#include <map>
#include <sstream>
#include <nlohmann/json.hpp>

#include "polyport/runtime/component_api.hpp"
#include "polyport/runtime/push_server.hpp"

namespace polyport {

namespace {

constexpr std::uint32_t kDefaultDepth = 16;
constexpr std::uint32_t kMaxDepth = 1u << 20;

nlohmann::json to_json(const LatencyHistogram::Summary& s) {
  return {{"count", s.count}, {"min", s.min}, {"mean", s.mean}, {"sd", s.sd}, {"p50", s.p50}, {"p90", s.p90},
          {"p99", s.p99},     {"p999", s.p999}, {"max", s.max}};
}

// An execution context's phase on its period's grid; null when its cycles follow its start.
nlohmann::json phase_json(const ExecutionSettings& settings) {
  return settings.phase ? nlohmann::json(settings.phase->count) : nlohmann::json(nullptr);
}

std::string join(const std::vector<std::string>& items) {
  std::string out;
  for (const auto& item : items) out += (out.empty() ? "" : ", ") + item;
  return out;
}

std::string type_name(const Port& port) { return port.type() ? port.type()->name : std::string(); }

// An event condition as check and stats show it: its activation and fields now, and what it
// let through.
nlohmann::json describe_condition(const EventCondition& condition) {
  const auto load = [](const std::atomic<std::uint64_t>& v) { return v.load(std::memory_order_relaxed); };
  const ConditionCounters& k = condition.counters();
  nlohmann::json j{{"mode", to_string(condition.mode())},
                   {"active", condition.active()},
                   {"fields", nlohmann::json::array()},
                   {"tested", load(k.tested)},
                   {"fired", load(k.fired)},
                   {"suppressed", load(k.suppressed)},
                   {"inactive", load(k.inactive)},
                   {"activations", load(k.activations)}};
  const std::vector<double> thresholds = condition.thresholds();
  for (std::size_t i = 0; i < condition.fields().size(); ++i) {
    const ConditionField& field = condition.fields()[i];
    nlohmann::json f{{"field", field.path}, {"op", to_string(field.op)}, {"value", thresholds[i]}};
    if (!field.param.empty()) f["param"] = field.param;
    j["fields"].push_back(std::move(f));
  }
  return j;
}

// A connection's policies beyond its queue, as check and stats show them.
void describe_policies(const Connection& c, nlohmann::json& j) {
  if (const ConnectionWatchdog* watchdog = c.watchdog()) {
    nlohmann::json w{{"deadline_ns", watchdog->deadline().count}, {"safe_value_bytes", watchdog->safe_size()}};
    if (watchdog->max_age().count > 0) w["max_age_ns"] = watchdog->max_age().count;
    if (watchdog->upstream()) w["upstream"] = watchdog->upstream()->full_name();
    j["watchdog"] = std::move(w);
  }
  if (c.rate_interval().count > 0) j[c.polled() ? "poll_period_ns" : "rate_limit_interval_ns"] = c.rate_interval().count;
  for (const DeadbandField& band : c.deadbands()) {
    j["deadbands"].push_back({{"field", band.path}, {"threshold", band.threshold}});
  }
  if (const EventCondition* condition = c.condition()) j["condition"] = describe_condition(*condition);
  if (const PushServer* push = c.source().push()) {
    nlohmann::json& p = j["push"];
    p["pattern"] = to_string(push->pattern());
    if (push->pattern() == PushPattern::timed) p["cycle_ns"] = push->cycle().count;
    p["active"] = push->active();
    p["primed"] = push->counters().primed.load(std::memory_order_relaxed);
    p["not_active_writes"] = push->counters().not_active.load(std::memory_order_relaxed);
  }
  if (const std::uint32_t every = c.subscription_every(); every != 0) {
    nlohmann::json& s = j["subscription"];
    s["every"] = every;
    if (const PushServer* push = c.source().push()) s["cycle_ns"] = push->cycle().count * every;
    s["subscribed"] = c.subscribed();
    s["skipped"] = c.counters().skipped.load(std::memory_order_relaxed);
  }
}

}  // namespace

Engine::Engine(const ModelRegistry& models, TypeRegistry& types) : models_(models), types_(types) {}

Engine::~Engine() { stop(); }

bool Engine::build(const ApplicationProfile& profile, Diagnostics& diagnostics) {
  name_ = profile.name;
  ModelContext context{types_, executors_};
  for (const Subcomponent& sub : profile.components) {
    Model* model = models_.find(sub.profile.model);
    if (!model) {
      diagnostics.error(sub.profile.where, "/component_profile/model",
                        "model '" + sub.profile.model + "' is not available in this build (available: " +
                            join(models_.names()) + ")");
      continue;
    }
    std::optional<Proxy> proxy = model->create_proxy(sub, context, diagnostics);
    if (!proxy) continue;
    if (auto pushed = attach_push_servers(sub, *proxy->adaptor); !pushed) {
      diagnostics.error(sub.where, {}, pushed.error().message);
      continue;
    }
    nodes_.push_back(Node{sub.name, sub.profile.model, std::move(*proxy)});
  }
  if (diagnostics.has_errors()) return false;

  for (const ConnectionSpec& spec : profile.connections) wire(spec, diagnostics);
  return !diagnostics.has_errors();
}

void Engine::wire(const ConnectionSpec& spec, Diagnostics& diagnostics) {
  Port* source = find_port(spec.source.component + "." + spec.source.port);
  Port* target = find_port(spec.target.component + "." + spec.target.port);
  if (!source || !target) {
    diagnostics.error(spec.where, {}, "connection endpoint not created by its model");
    return;
  }
  // Made whole before the ports see it: while the application runs (a reload), the source's
  // writer may enter it the moment it is published, and its policies are plain fields.
  auto connected = connect_ports(*source, *target, spec.policy, spec.depth, spec.program, /*publish=*/false);
  if (!connected) {
    diagnostics.error(spec.where, {}, connected.error().message);
    return;
  }
  Connection* connection = connected.value();
  if (connection == nullptr) return;  // a service connection
  const std::size_t errors = diagnostics.error_count();
  if (spec.watchdog) {
    auto watched = add_watchdog(*connection, *spec.watchdog);
    if (!watched) diagnostics.error(spec.watchdog->where, {}, watched.error().message);
  }
  if (spec.subscription_every) connection->set_subscription(*spec.subscription_every);
  if (auto limited = add_rate_policies(*connection, spec); !limited) {
    diagnostics.error(spec.where, {}, limited.error().message);
  }
  if (spec.condition) {
    const Type* type = connection->source().type();
    if (type == nullptr) {
      diagnostics.error(spec.condition->where, {}, "a condition needs a data type on " + connection->source().full_name());
    } else if (auto condition = make_event_condition(*type, *spec.condition); !condition) {
      diagnostics.error(spec.condition->where, {}, condition.error().message);
    } else {
      connection->set_condition(std::move(condition).value());
    }
  }
  if (diagnostics.error_count() != errors) return;  // left unpublished; the caller gives up
  connection->target().connections().add(*connection);
  connection->source().connections().add(*connection);
  if (connection->watchdog() || connection->rate_interval().count > 0) timer_.add(*connection);
}

Result<Connection*> Engine::connect_ports(Port& source, Port& target, std::optional<QueuePolicy> policy,
                                          std::optional<std::uint32_t> depth,
                                          std::shared_ptr<const MappingProgram> mapping, bool publish) {
  // A data output may feed an event input: the server's state of an event with a condition
  // (the profile loader allows it only there).
  const bool state_to_event = source.kind() == PortKind::data && target.kind() == PortKind::event;
  if (source.kind() != target.kind() && !state_to_event) {
    return make_error(source.full_name() + " is a " + std::string(to_string(source.kind())) + " port but " +
                      target.full_name() + " is a " + std::string(to_string(target.kind())) + " port");
  }
  if (source.kind() == PortKind::service) {
    // While the application runs too: the binding is published whole, callers never wait.
    auto* required = dynamic_cast<RequiredServicePort*>(&source);
    auto* provided = dynamic_cast<ProvidedServicePort*>(&target);
    if (!required || !provided) {
      return make_error("a service connection goes from a required port to a provided port");
    }
    if (!required->connect(*provided)) {
      std::string missing;
      for (const OperationInfo& op : required->operations()) {
        if (provided->find_operation(op.name) < 0) missing += (missing.empty() ? "" : ", ") + op.name;
      }
      return make_error(provided->full_name() + " does not provide operation(s) " + missing + " that " +
                        required->full_name() + " calls");
    }
    // A required port has one provider: binding it again replaces its link.
    std::erase_if(service_links_, [required](const auto& link) { return link.first == required; });
    service_links_.emplace_back(required, provided);
    return static_cast<Connection*>(nullptr);
  }
  auto* out = dynamic_cast<DataOutPort*>(&source);
  auto* in = dynamic_cast<DataInPort*>(&target);
  if (!out || !in) return make_error("a " + std::string(to_string(source.kind())) + " connection goes from an output port to an input port");
  if (!mapping && out->type() && in->type() && out->type() != in->type()) {
    return make_error("type mismatch: " + out->full_name() + " is '" + type_name(*out) + "' but " +
                      in->full_name() + " is '" + type_name(*in) + "'");
  }
  const QueuePolicy effective = policy.value_or(in->policy());
  const std::uint32_t effective_depth = depth.value_or(in->depth() ? in->depth() : kDefaultDepth);
  if (effective != QueuePolicy::data && (effective_depth == 0 || effective_depth > kMaxDepth)) {
    return make_error("queue depth " + std::to_string(effective_depth) + " is out of range (1 to " +
                      std::to_string(kMaxDepth) + ")");
  }
  try {
    connections_.push_back(std::make_unique<Connection>(*out, *in, effective, effective_depth, mapping.get()));
  } catch (const std::exception& e) {
    return make_error("cannot create the connection " + out->full_name() + " -> " + in->full_name() + ": " + e.what());
  }
  if (mapping) mappings_.push_back(std::move(mapping));
  Connection& connection = *connections_.back();
  if (publish) {
    in->connections().add(connection);
    out->connections().add(connection);
  }
  return &connection;
}

// The safe value is made once here: the profile's constants in the target's flat layout,
// encoded in the target's wire format.
Result<void> Engine::add_watchdog(Connection& connection, const WatchdogSpec& spec) {
  const DataInPort& target = connection.target();
  if (!spec.safe_program || !target.type()) return make_error("the watchdog's safe value has no type to take");
  const DataOutPort* upstream = nullptr;
  if (spec.upstream) {
    upstream = dynamic_cast<const DataOutPort*>(find_port(spec.upstream->component + "." + spec.upstream->port));
    if (!upstream) return make_error("the watchdog's upstream port was not created by its model");
  }
  const std::uint32_t flat_capacity = std::max(target.type()->size, target.max_sample_bytes());
  std::vector<std::byte> zero(target.type()->size), flat(flat_capacity);
  std::uint32_t flat_size = 0;
  if (!spec.safe_program->run(zero.data(), static_cast<std::uint32_t>(zero.size()), flat.data(), flat_capacity,
                              flat_size)) {
    return make_error("the watchdog's safe value could not be made for " + target.full_name());
  }
  flat.resize(flat_size);
  std::vector<std::byte> safe = std::move(flat);
  if (const Codec* codec = target.codec()) {
    std::vector<std::byte> wire(codec->max_wire_size(flat_size));
    const CodecResult encoded = codec->encode(safe.data(), flat_size, wire.data(), static_cast<std::uint32_t>(wire.size()));
    if (!encoded.ok()) return make_error("the watchdog's safe value cannot be encoded for " + target.full_name());
    wire.resize(encoded.size);
    safe = std::move(wire);
  }
  auto watchdog = std::make_unique<ConnectionWatchdog>(connection.source(), upstream, Nanos{spec.deadline_ns},
                                                       Nanos{spec.max_age_ns}, std::move(safe));
  if (spec.event) {
    auto events = watchdog_events(connection, *spec.event);
    if (!events) return events.error();
    watchdog->set_events(events.value(), connection.name());
  }
  connection.set_watchdog(std::move(watchdog));
  return {};
}

// An engine-owned output port ("watchdogs.<the watched connection>") connected to
// the profile's <event> port, whose type must have WatchdogEventSample's layout.
Result<DataOutPort*> Engine::watchdog_events(const Connection& watched, const ConnectionEnd& end) {
  Port* target = find_port(end.component + "." + end.port);
  if (!target) return make_error("the watchdog's event port " + end.component + "." + end.port + " was not created by its model");
  const Type* type = types_.find("polyport::WatchdogEvent");
  const auto offset = [type](std::string_view field) -> std::int64_t {
    const Field* f = type->find_field(field);
    return f ? f->offset : -1;
  };
  if (type == nullptr || type->size != sizeof(WatchdogEventSample) ||
      offset("kind") != offsetof(WatchdogEventSample, kind) || offset("trips") != offsetof(WatchdogEventSample, trips) ||
      offset("recoveries") != offsetof(WatchdogEventSample, recoveries) ||
      offset("silent_ns") != offsetof(WatchdogEventSample, silent_ns) ||
      offset("connection") != offsetof(WatchdogEventSample, connection) ||
      offset("silent_port") != offsetof(WatchdogEventSample, silent_port)) {
    return make_error("polyport::WatchdogEvent is not the type of config/types/watchdog_event.idl");
  }
  if (!watchdog_events_) watchdog_events_ = std::make_unique<Component>("watchdogs", "inproc");
  auto& out = watchdog_events_->add_port<DataOutPort>(watched.name(), target->kind(), type,
                                                      static_cast<std::uint32_t>(sizeof(WatchdogEventSample)));
  auto connected = connect_ports(out, *target, std::nullopt, std::nullopt);
  if (!connected) return connected.error();
  return &out;
}

Result<void> Engine::add_rate_policies(Connection& connection, const ConnectionSpec& spec) {
  if (spec.rate_limit_per_second) {
    connection.set_rate_limit(Nanos{static_cast<std::int64_t>(std::llround(1e9 / *spec.rate_limit_per_second))});
  }
  if (spec.poll_period_ms) connection.set_poll(Nanos{static_cast<std::int64_t>(std::llround(*spec.poll_period_ms * 1e6))});
  if (spec.deadbands.empty()) return {};
  const Type* type = connection.source().type();
  if (type == nullptr) return make_error("a deadband needs a data type on " + connection.source().full_name());
  std::vector<DeadbandField> fields;
  for (const DeadbandSpec& band : spec.deadbands) {
    const FieldPathResult found = find_field_path(*type, band.field);
    if (!found.place) return make_error("deadband field '" + band.field + "' not found in '" + type->name + "'");
    if (!is_number(found.place->type->kind)) {
      return make_error("deadband field '" + band.field + "' of '" + type->name + "' is not a number");
    }
    fields.push_back(DeadbandField{found.place->offset, found.place->type->kind, band.threshold, band.field});
  }
  connection.set_deadbands(std::move(fields));
  return {};
}

Result<Connection*> Engine::connect(const std::string& source_component, const std::string& source_port,
                                    const std::string& target_component, const std::string& target_port,
                                    std::optional<QueuePolicy> policy, std::optional<std::uint32_t> depth) {
  Port* source = find_port(source_component + "." + source_port);
  Port* target = find_port(target_component + "." + target_port);
  if (!source) return make_error("no port " + source_component + "." + source_port);
  if (!target) return make_error("no port " + target_component + "." + target_port);
  return connect_ports(*source, *target, policy, depth);
}

Result<Connection*> Engine::add_connection(const ConnectionSpec& spec) {
  const std::string source_name = spec.source.component + "." + spec.source.port;
  const std::string target_name = spec.target.component + "." + spec.target.port;
  Port* source = find_port(source_name);
  Port* target = find_port(target_name);
  if (!source) return make_error("no port " + source_name);
  if (!target) return make_error("no port " + target_name);
  for (const auto& c : connections_) {
    if (&c->source() == source && &c->target() == target) {
      return make_error(source_name + " is already connected to " + target_name);
    }
  }
  for (const auto& [required, provided] : service_links_) {
    if (required == source && provided == target) return make_error(source_name + " is already connected to " + target_name);
  }
  return connect_ports(*source, *target, spec.policy, spec.depth, spec.program);
}

Result<void> Engine::remove_connection(std::string_view source, std::string_view target) {
  for (auto it = connections_.begin(); it != connections_.end(); ++it) {
    Connection& c = **it;
    if (&c.target().owner() == probes_.get() || c.source().full_name() != source || c.target().full_name() != target) {
      continue;
    }
    unpublish(it);
    return {};
  }
  for (auto it = service_links_.begin(); it != service_links_.end(); ++it) {
    if (it->first->full_name() == source && it->second->full_name() == target) {
      // Calls made already finish with the provider they went to; new ones get not_connected.
      it->first->disconnect();
      service_links_.erase(it);
      return {};
    }
  }
  return make_error("no connection " + std::string(source) + " -> " + std::string(target));
}

void Engine::unpublish(std::vector<std::unique_ptr<Connection>>::iterator it) {
  Connection& c = **it;
  // The writer stops first, then the reader lets go of what was queued, then the timer
  // (watchdog, rate limit) stops handing it anything.
  c.source().connections().remove(c);
  c.target().connections().remove(c);
  timer_.remove(c);
  const DataOutPort* events = c.watchdog() ? c.watchdog()->events() : nullptr;
  removed_.push_back(std::move(*it));
  connections_.erase(it);
  // Its watchdog's events port says nothing more: that port's connection goes too.
  if (events == nullptr) return;
  const auto told = std::find_if(connections_.begin(), connections_.end(), [events](const auto& e) { return &e->source() == events; });
  if (told != connections_.end()) unpublish(told);
}

Result<void> Engine::apply(const Change& change, std::vector<std::string>& warnings) {
  if (!started_) return make_error("the application is not running");
  // What leaves, found in the running graph before anything changes.
  std::vector<const Component*> leaving;
  for (const std::string& name : change.components_out) {
    const Component* component = find_component(name);
    if (component == nullptr) return make_error("no component named '" + name + "'");
    leaving.push_back(component);
  }
  std::vector<const Connection*> going;
  for (const auto& ends : change.connections_out) {
    const auto it = std::find_if(connections_.begin(), connections_.end(), [&](const auto& c) {
      return c->source().full_name() == ends.first && c->target().full_name() == ends.second;
    });
    // Gone already (disconnected at run time): nothing to take away.
    if (it != connections_.end()) going.push_back(it->get());
  }
  const auto leaves = [&](const Component& owner) {
    return std::find(leaving.begin(), leaving.end(), &owner) != leaving.end();
  };
  for (const auto& c : connections_) {
    if (leaves(c->source().owner()) || leaves(c->target().owner())) going.push_back(c.get());
  }

  // Make: the new proxies first (nothing is connected to them yet), found by name from now on.
  Diagnostics diagnostics;
  ModelContext context{types_, executors_};
  for (const Subcomponent* sub : change.components_in) {
    Model* model = models_.find(sub->profile.model);
    if (!model) {
      diagnostics.error(sub->profile.where, "/component_profile/model",
                        "model '" + sub->profile.model + "' is not available in this build");
      continue;
    }
    std::optional<Proxy> proxy = model->create_proxy(*sub, context, diagnostics);
    if (proxy) {
      if (auto pushed = attach_push_servers(*sub, *proxy->adaptor); !pushed) {
        diagnostics.error(sub->where, {}, pushed.error().message);
        continue;
      }
    }
    if (proxy) staged_.push_back(Node{sub->name, sub->profile.model, std::move(*proxy)});
  }
  const auto failed = [&diagnostics](std::string_view what) {
    std::ostringstream text;
    diagnostics.print(text);
    std::string problems = std::move(text).str();
    while (!problems.empty() && problems.back() == '\n') problems.pop_back();
    return make_error(std::string(what) + ":\n" + problems);
  };
  const std::size_t first_new = connections_.size();
  links_before_ = service_links_;  // what roll_back restores, and the links the break may take
  if (diagnostics.has_errors()) {
    roll_back(first_new);
    return failed("the new components could not be made");
  }
  hidden_ = change.components_out;
  for (const ConnectionSpec* spec : change.connections_in) wire(*spec, diagnostics);
  if (diagnostics.has_errors()) {
    roll_back(first_new);
    return failed("the new connections could not be made");
  }
  // New execution contexts (in-process components added now get their own) start; running
  // ones are left as they are.
  executors_.start_all(warnings);
  std::vector<Interceptor*> started;
  for (const std::size_t index : receivers_first(staged_)) {
    Node& node = staged_[index];
    Result<void> up = node.proxy.interceptor->start();
    started.push_back(node.proxy.interceptor.get());
    if (!up) {
      const std::string why = "component '" + node.name + "' did not start: " + up.error().message;
      for (auto it = started.rbegin(); it != started.rend(); ++it) (*it)->stop();
      roll_back(first_new);
      return make_error(why);
    }
  }

  // Break: the old connections leave, then the old components stop. A service link goes when
  // the profiles no longer make it or its caller leaves; a caller that stays and was bound
  // anew above (its provider replaced) keeps the new link.
  timer_.start(notify_);
  std::erase_if(service_links_, [&](const auto& link) {
    RequiredServicePort* required = link.first;
    const ProvidedServicePort* provided = link.second;
    if (std::find(links_before_.begin(), links_before_.end(), link) == links_before_.end()) return false;  // made now
    const bool named = std::any_of(change.connections_out.begin(), change.connections_out.end(), [&](const auto& ends) {
      return ends.first == required->full_name() && ends.second == provided->full_name();
    });
    if (!named && !leaves(required->owner()) && !leaves(provided->owner())) return false;
    // The caller is bound to this provider still (not rebound by a connection made above).
    if (required->provider() == provided) required->disconnect();
    return true;
  });
  for (const Connection* c : going) {
    const auto it = std::find_if(connections_.begin(), connections_.end(), [c](const auto& p) { return p.get() == c; });
    if (it != connections_.end()) unpublish(it);
  }
  for (auto it = start_order_.rbegin(); it != start_order_.rend(); ++it) {
    const auto node = std::find_if(nodes_.begin(), nodes_.end(), [&](const Node& n) { return n.proxy.interceptor.get() == *it; });
    if (node != nodes_.end() && leaves(*node->proxy.adaptor)) (*it)->stop();
  }
  std::erase_if(start_order_, [&](Interceptor* i) {
    return std::any_of(nodes_.begin(), nodes_.end(), [&](const Node& n) {
      return n.proxy.interceptor.get() == i && leaves(*n.proxy.adaptor);
    });
  });
  std::vector<ExecutionContext*> vacated;
  for (auto it = nodes_.begin(); it != nodes_.end();) {
    if (leaves(*it->proxy.adaptor)) {
      if (ExecutionContext* ec = it->proxy.interceptor->execution_context()) vacated.push_back(ec);
      retired_.push_back(std::move(*it));
      it = nodes_.erase(it);
    } else {
      ++it;
    }
  }
  hidden_.clear();
  start_order_.insert(start_order_.end(), started.begin(), started.end());
  for (Node& node : staged_) nodes_.push_back(std::move(node));
  staged_.clear();
  retire_unused(vacated);
  return {};
}

void Engine::retire_unused(const std::vector<ExecutionContext*>& contexts) {
  for (ExecutionContext* context : contexts) {
    const bool used = std::any_of(nodes_.begin(), nodes_.end(), [context](const Node& n) {
      return n.proxy.interceptor->execution_context() == context;
    });
    if (!used && !context->retired()) context->retire();
  }
}

void Engine::roll_back(std::size_t first) {
  while (connections_.size() > first) unpublish(connections_.begin() + static_cast<std::ptrdiff_t>(first));
  // Writers of the running graph may have touched the new nodes' ports: kept, like removed_.
  std::vector<ExecutionContext*> made;
  for (Node& node : staged_) {
    if (ExecutionContext* context = node.proxy.interceptor->execution_context()) made.push_back(context);
    retired_.push_back(std::move(node));
  }
  staged_.clear();
  hidden_.clear();
  // Service links made meanwhile are undone and the earlier bindings put back.
  for (const auto& [required, provided] : service_links_) {
    const bool bound_before = std::any_of(links_before_.begin(), links_before_.end(),
                                          [required = required](const auto& link) { return link.first == required; });
    if (!bound_before) required->disconnect();
  }
  service_links_ = links_before_;
  for (const auto& [required, provided] : service_links_) {
    if (required->provider() != provided) required->connect(*provided);
  }
  // The contexts made for them (a reload never adds to a running one) go too, started or not.
  retire_unused(made);
}

Result<DataInPort*> Engine::add_probe(const std::string& port_path, std::uint32_t depth) {
  auto* out = dynamic_cast<DataOutPort*>(find_port(port_path));
  if (!out) return make_error("no output data port '" + port_path + "'");
  if (!probes_) probes_ = std::make_unique<Component>("probe", "inproc");
  auto& in = probes_->add_port<DataInPort>(port_path, out->kind(), out->type(), out->max_sample_bytes(),
                                           QueuePolicy::circular, depth);
  connections_.push_back(std::make_unique<Connection>(*out, in, QueuePolicy::circular, depth));
  in.connections().add(*connections_.back());
  out->connections().add(*connections_.back());
  return &in;
}

Result<void> Engine::start(std::vector<std::string>& warnings) {
  if (started_) return {};
  started_ = true;
  executors_.start_all(warnings);
  start_order_.clear();
  for (const std::size_t index : receivers_first(nodes_)) {
    Node& node = nodes_[index];
    Result<void> started = node.proxy.interceptor->start();
    start_order_.push_back(node.proxy.interceptor.get());
    if (!started) {
      stop();
      return make_error("component '" + node.name + "' did not start: " + started.error().message);
    }
  }
  timer_.start(notify_);
  return {};
}

std::vector<std::size_t> Engine::receivers_first(const std::vector<Node>& nodes) const {
  std::map<const Component*, std::size_t> index_of;
  for (std::size_t i = 0; i < nodes.size(); ++i) index_of[nodes[i].proxy.adaptor.get()] = i;
  // sends_to[i]: the nodes node i's data connections and calls go to (probes are not nodes).
  std::vector<std::vector<std::size_t>> sends_to(nodes.size());
  for (const auto& connection : connections_) {
    const auto source = index_of.find(&connection->source().owner());
    const auto target = index_of.find(&connection->target().owner());
    if (source == index_of.end() || target == index_of.end() || source->second == target->second) continue;
    sends_to[source->second].push_back(target->second);
  }
  // A caller's calls go to its provider, which must be accepting them first.
  for (const auto& [required, provided] : service_links_) {
    const auto caller = index_of.find(&required->owner());
    const auto provider = index_of.find(&provided->owner());
    if (caller == index_of.end() || provider == index_of.end() || caller->second == provider->second) continue;
    sends_to[caller->second].push_back(provider->second);
  }
  std::vector<bool> placed(nodes.size(), false);
  std::vector<std::size_t> order;
  while (order.size() < nodes.size()) {
    bool progress = false;
    for (std::size_t i = 0; i < nodes.size(); ++i) {
      if (placed[i]) continue;
      const bool ready = std::all_of(sends_to[i].begin(), sends_to[i].end(), [&](std::size_t t) { return placed[t]; });
      if (!ready) continue;
      placed[i] = true;
      order.push_back(i);
      progress = true;
    }
    if (progress) continue;
    // A cycle: the first remaining component in profile order goes next.
    const auto first = static_cast<std::size_t>(std::find(placed.begin(), placed.end(), false) - placed.begin());
    placed[first] = true;
    order.push_back(first);
  }
  return order;
}

void Engine::set_blocking(bool blocking) noexcept {
  for (const Node& node : nodes_) {
    for (const auto& port : node.proxy.adaptor->ports()) {
      if (auto* required = dynamic_cast<RequiredServicePort*>(port.get())) required->set_blocking(blocking);
    }
  }
}

void Engine::stop() {
  if (!started_) return;
  started_ = false;
  set_blocking(false);  // before any component stops: one may be waiting on another
  timer_.stop();  // no safe value or held sample goes to a component that is stopping
  for (auto it = start_order_.rbegin(); it != start_order_.rend(); ++it) (*it)->stop();
  start_order_.clear();
  executors_.stop_all();
}

const Engine::Node* Engine::find_node(std::string_view name) const noexcept {
  for (const Node& node : staged_) {
    if (node.name == name) return &node;
  }
  if (std::find(hidden_.begin(), hidden_.end(), name) != hidden_.end()) return nullptr;
  for (const Node& node : nodes_) {
    if (node.name == name) return &node;
  }
  return nullptr;
}

Component* Engine::find_component(std::string_view name) const noexcept {
  const Node* node = find_node(name);
  return node ? node->proxy.adaptor.get() : nullptr;
}

Interceptor* Engine::find_interceptor(std::string_view name) const noexcept {
  const Node* node = find_node(name);
  return node ? node->proxy.interceptor.get() : nullptr;
}

Port* Engine::find_port(std::string_view path) const noexcept {
  const auto dot = path.find('.');
  if (dot == std::string_view::npos) return nullptr;
  Component* component = find_component(path.substr(0, dot));
  return component ? component->find_port(path.substr(dot + 1)) : nullptr;
}

void Engine::describe(nlohmann::json& out) const {
  out["application"] = name_;
  out["components"] = nlohmann::json::array();
  for (const Node& node : nodes_) {
    nlohmann::json component{{"name", node.name}, {"model", node.model}};
    component["ports"] = nlohmann::json::array();
    for (const auto& port : node.proxy.adaptor->ports()) {
      nlohmann::json p{{"name", port->name()},
                       {"kind", to_string(port->kind())},
                       {"direction", to_string(port->direction())}};
      if (port->type()) p["type"] = port->type()->name;
      if (auto* writer = dynamic_cast<const DataOutPort*>(port.get()); writer != nullptr && writer->push() != nullptr) {
        p["push"] = to_string(writer->push()->pattern());
        if (writer->push()->pattern() == PushPattern::timed) p["push_cycle_ns"] = writer->push()->cycle().count;
      }
      if (auto* in = dynamic_cast<const DataInPort*>(port.get())) {
        p["policy"] = to_string(in->policy());
        if (in->policy() != QueuePolicy::data) p["depth"] = in->depth();
        // Handed over on arrival (an adaptor's sink, a CallbackInPort): no queue, whatever the policy says.
        if (in->sink() != nullptr) p["mode"] = "push";
      }
      if (auto* provided = dynamic_cast<const ProvidedServicePort*>(port.get())) {
        p["service_type"] = provided->service_type();
        for (const auto& op : provided->operations()) p["operations"].push_back(op.name);
      }
      if (auto* required = dynamic_cast<const RequiredServicePort*>(port.get())) {
        p["service_type"] = required->service_type();
        for (const auto& op : required->operations()) p["operations"].push_back(op.name);
      }
      component["ports"].push_back(std::move(p));
    }
    node.proxy.interceptor->describe(component);
    out["components"].push_back(std::move(component));
  }
  out["connections"] = nlohmann::json::array();
  for (const auto& c : connections_) {
    if (&c->target().owner() == probes_.get()) continue;
    nlohmann::json j{{"source", c->source().full_name()},
                     {"target", c->target().full_name()},
                     {"kind", to_string(c->source().kind())},
                     {"type", type_name(c->source())},
                     {"policy", to_string(c->policy())},
                     {"mode", c->push_mode() ? "push" : "pull"},
                     {"conversion", c->conversion()}};
    if (c->policy() != QueuePolicy::data) j["depth"] = c->depth();
    describe_policies(*c, j);
    out["connections"].push_back(std::move(j));
  }
  for (const auto& [required, provided] : service_links_) {
    out["connections"].push_back({{"source", required->full_name()},
                                  {"target", provided->full_name()},
                                  {"kind", "service"},
                                  {"service_type", provided->service_type()},
                                  {"max_in_flight", required->max_in_flight()}});
  }
  out["execution_contexts"] = nlohmann::json::array();
  bool realtime = false;
  for (const auto& context : executors_.contexts()) {
    if (context->retired()) continue;
    const SchedPolicy policy = context->settings().policy;
    nlohmann::json j{{"name", context->settings().name},
                     {"period_ns", context->settings().period.count},
                     {"spin_us", context->settings().spin.count / 1000},
                     {"phase_ns", phase_json(context->settings())},
                     {"policy", policy == SchedPolicy::fifo ? "SCHED_FIFO" : policy == SchedPolicy::rr ? "SCHED_RR" : "SCHED_OTHER"}};
    if (policy != SchedPolicy::other) {
      j["priority"] = context->settings().priority;
      realtime = true;
    }
    for (Lifecycle* member : context->members()) {
      // A member a reload replaced stays in its context, finalized, while the others run on.
      if (started_ && member->state() == LifecycleState::finalized) continue;
      j["members"].push_back(member->component().instance_name());
    }
    out["execution_contexts"].push_back(std::move(j));
  }
  // A real-time context makes the daemon lock its memory and pre-fault the context's stack.
  out["locks_memory"] = realtime;
}

void Engine::stats(nlohmann::json& out) const {
  out["application"] = name_;
  out["components"] = nlohmann::json::array();
  for (const Node& node : nodes_) {
    const InterceptorStatus status = node.proxy.interceptor->status();
    nlohmann::json component{{"name", node.name},
                             {"model", node.model},
                             {"state", status.state},
                             {"executions", status.executions},
                             {"errors", status.errors}};
    // The model's own part (e.g. a DDS component's topics: matched peers, samples received
    // and refused; its services' counters), as `check` shows it, read now.
    node.proxy.interceptor->describe(component);
    out["components"].push_back(std::move(component));
  }
  out["connections"] = nlohmann::json::array();
  // Removed ones too (remove_connection), marked: what flowed through them stays counted.
  for (const auto* list : {&connections_, &removed_}) for (const auto& c : *list) {
    const ConnectionCounters& k = c->counters();
    auto load = [](const std::atomic<std::uint64_t>& v) { return v.load(std::memory_order_relaxed); };
    nlohmann::json j{{"name", c->name()},
                     {"source", c->source().full_name()},
                     {"target", c->target().full_name()},
                     {"kind", to_string(c->source().kind())},
                     {"policy", to_string(c->policy())},
                     {"mode", c->push_mode() ? "push" : "pull"},
                     {"probe", &c->target().owner() == probes_.get()},
                     {"removed", list == &removed_},
                     {"received", load(k.received)},
                     {"delivered", load(k.delivered)},
                     {"read", load(k.read)},
                     {"overwritten", load(k.overwritten)},
                     {"dropped", k.dropped()},
                     {"dropped_by_reason",
                      {{"queue_full", load(k.dropped_queue_full)},
                       {"oldest", load(k.dropped_oldest)},
                       {"too_large", load(k.dropped_too_large)},
                       {"sink_error", load(k.dropped_sink_error)},
                       {"decode_error", load(k.dropped_decode_error)},
                       {"map_error", load(k.dropped_map_error)},
                       {"encode_error", load(k.dropped_encode_error)}}},
                     {"clamped", load(k.clamped)},
                     {"conversion", c->conversion()},
                     {"latency_ns", to_json(c->latency().summarize())}};
    if (!c->push_mode()) j["age_at_read_ns"] = to_json(c->age().summarize());
    if (c->push_mode()) j["sink_ns"] = to_json(c->sink_time().summarize());
    if (const auto transit = c->transit().summarize(); transit.count != 0) j["transit_ns"] = to_json(transit);
    describe_policies(*c, j);
    if (c->rate_interval().count > 0 || !c->deadbands().empty()) {
      j["dropped_by_reason"]["rate_limited"] = load(k.dropped_rate_limited);
      j["dropped_by_reason"]["filtered"] = load(k.dropped_filtered);
    }
    if (const ConnectionWatchdog* watchdog = c->watchdog()) {
      nlohmann::json& w = j["watchdog"];
      const WatchdogCounters& wk = watchdog->counters();
      w["state"] = to_string(watchdog->state());
      w["trips"] = load(wk.trips);
      w["recoveries"] = load(wk.recoveries);
      w["safe_values"] = load(wk.safe_values);
      w["stale"] = load(wk.stale);
      j["dropped_by_reason"]["stale"] = load(k.dropped_stale);
    }
    out["connections"].push_back(std::move(j));
  }
  out["services"] = nlohmann::json::array();
  for (const auto& [required, provided] : service_links_) {
    const auto& k = required->counters();
    auto load = [](const std::atomic<std::uint64_t>& v) { return v.load(std::memory_order_relaxed); };
    out["services"].push_back({{"name", required->full_name() + " -> " + provided->full_name()},
                               {"calls", load(k.calls)},
                               {"ok", load(k.ok)},
                               {"timeouts", load(k.timeouts)},
                               {"errors", load(k.errors)},
                               {"not_connected", load(k.not_connected)},
                               {"too_many_calls", load(k.too_many_calls)},
                               {"cancelled", load(k.cancelled)},
                               {"provider_rejected", provided->rejected()},
                               {"latency_ns", to_json(required->latency().summarize())}});
  }
  out["execution_contexts"] = nlohmann::json::array();
  for (const auto& context : executors_.contexts()) {
    if (context->retired()) continue;
    nlohmann::json j{{"name", context->settings().name},
                     {"period_ns", context->period().count},
                     {"period_changes", context->period_changes()},
                     {"cycles", context->cycles()},
                     {"overruns", context->overruns()},
                     {"missed_periods", context->missed_periods()},
                     {"realtime", context->realtime_applied()},
                     {"pinned", context->pinned()},
                     {"timer_slack_ns", context->timer_slack_ns()},
                     {"spin_us", context->settings().spin.count / 1000},
                     {"phase_ns", phase_json(context->settings())},
                     {"wake_jitter_ns", to_json(context->wake_jitter().summarize())},
                     {"cycle_time_ns", to_json(context->cycle_time().summarize())}};
    for (Lifecycle* member : context->members()) {
      // A member a reload replaced stays in its context, finalized, while the others run on.
      if (started_ && member->state() == LifecycleState::finalized) continue;
      j["members"].push_back(member->component().instance_name());
    }
    out["execution_contexts"].push_back(std::move(j));
  }
  out["memory_locked"] = executors_.memory_locked();
  out["memory_was_locked"] = executors_.memory_was_locked();
}

std::string Engine::summary_line() const {
  std::uint64_t executions = 0, received = 0, dropped = 0, overruns = 0;
  std::int64_t worst_p99 = 0;
  std::size_t active = 0;
  for (const Node& node : nodes_) {
    const InterceptorStatus status = node.proxy.interceptor->status();
    executions += status.executions;
    if (status.state == "active") ++active;
  }
  for (const auto& c : connections_) {
    received += c->counters().received.load(std::memory_order_relaxed);
    dropped += c->counters().dropped();
    worst_p99 = std::max(worst_p99, c->latency().summarize().p99);
  }
  for (const auto& context : executors_.contexts()) overruns += context->overruns();
  char line[256];
  std::snprintf(line, sizeof(line),
                "components %zu/%zu active, executions %llu | connections %zu: received %llu, dropped %llu, "
                "worst p99 %lld ns | overruns %llu",
                active, nodes_.size(), static_cast<unsigned long long>(executions), connections_.size(),
                static_cast<unsigned long long>(received), static_cast<unsigned long long>(dropped),
                static_cast<long long>(worst_p99), static_cast<unsigned long long>(overruns));
  return line;
}

Result<void> Engine::remove_probe(const DataInPort* probe) {
  for (auto it = connections_.begin(); it != connections_.end(); ++it) {
    if (&(*it)->target() != probe || &(*it)->target().owner() != probes_.get()) continue;
    unpublish(it);
    return {};
  }
  return make_error("no such probe");
}

}  // namespace polyport
