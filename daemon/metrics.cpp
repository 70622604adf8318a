#include "metrics.hpp"

#include <array>
#include <charconv>
#include <map>
#include <utility>

#include "polyport/runtime/engine.hpp"
#include "polyport/runtime/execution_context.hpp"
#include "polyport/runtime/histogram.hpp"
#include "polyport/runtime/service.hpp"

namespace polyport::daemon {
namespace {

using Json = nlohmann::json;
using Labels = std::vector<std::pair<std::string, std::string>>;

// The lifecycle states (core/runtime/lifecycle.cpp): each component has a gauge for each,
// so that a state left shows 0 rather than vanishing.
constexpr std::array<const char*, 5> kStates{"created", "inactive", "active", "error", "finalized"};
constexpr std::array<const char*, 3> kWatchdogStates{"waiting", "ok", "tripped"};

// The shortest text that reads back as the same double (std::to_chars), as Prometheus and
// its parsers take it.
std::string number(double value) {
  char buffer[64];
  const auto result = std::to_chars(buffer, buffer + sizeof buffer, value);
  return std::string(buffer, result.ptr);
}

std::string help_escape(std::string_view text) {
  std::string out;
  for (const char c : text) {
    if (c == '\\') out += "\\\\";
    else if (c == '\n') out += "\\n";
    else out += c;
  }
  return out;
}

std::string label_text(const Labels& labels) {
  if (labels.empty()) return {};
  std::string out = "{";
  for (std::size_t i = 0; i < labels.size(); ++i) {
    if (i != 0) out += ',';
    out += labels[i].first + "=\"" + escape_label_value(labels[i].second) + "\"";
  }
  return out + "}";
}

// One metric family: its HELP and TYPE lines, then its samples (the text format wants a
// family's samples together, so each family collects its own before the text is joined).
struct Family {
  std::string name;
  std::string type;
  std::string help;
  std::string samples;

  void add(const std::string& suffix, const Labels& labels, const std::string& value) {
    samples += name + suffix + label_text(labels) + " " + value + "\n";
  }
  void add(const Labels& labels, std::uint64_t value) { add("", labels, std::to_string(value)); }

  // A histogram of nanoseconds, in seconds: cumulative buckets at histogram_bounds_ns(),
  // +Inf, _sum and _count. `h` is a summary of engine.cpp's to_json with "buckets" added.
  void add_histogram(const Labels& labels, const Json& h) {
    std::uint64_t count = h.value("count", std::uint64_t{0});
    std::vector<std::pair<std::int64_t, std::uint64_t>> buckets;
    if (h.contains("buckets")) {
      count = 0;
      for (const Json& b : h["buckets"]) {
        buckets.emplace_back(b.at(0).get<std::int64_t>(), b.at(1).get<std::uint64_t>());
        count += buckets.back().second;
      }
    }
    std::size_t next = 0;
    std::uint64_t cumulative = 0;
    Labels with_le = labels;
    with_le.emplace_back("le", "");
    if (h.contains("buckets")) {
      for (const std::int64_t bound : histogram_bounds_ns()) {
        while (next < buckets.size() && buckets[next].first <= bound) cumulative += buckets[next++].second;
        with_le.back().second = number(static_cast<double>(bound) / 1e9);
        add("_bucket", with_le, std::to_string(cumulative));
      }
    }
    with_le.back().second = "+Inf";
    add("_bucket", with_le, std::to_string(count));
    // The engine keeps the exact sum; its summary carries it as the mean.
    add("_sum", labels, number(h.value("mean", 0.0) * static_cast<double>(count) / 1e9));
    add("_count", labels, std::to_string(count));
  }
};

class Exposition {
 public:
  Family& family(const std::string& name, const std::string& type, const std::string& help) {
    auto [it, added] = index_.try_emplace(name, families_.size());
    if (added) families_.push_back(Family{name, type, help, {}});
    return families_[it->second];
  }
  std::string text() const {
    std::string out;
    for (const Family& f : families_) {
      out += "# HELP " + f.name + " " + help_escape(f.help) + "\n";
      out += "# TYPE " + f.name + " " + f.type + "\n";
      out += f.samples;
    }
    return out;
  }

 private:
  std::vector<Family> families_;
  std::map<std::string, std::size_t> index_;
};

std::uint64_t count_of(const Json& j, const char* key) { return j.value(key, std::uint64_t{0}); }

Json buckets_json(const LatencyHistogram& histogram) {
  Json out = Json::array();
  for (const auto& [top, count] : histogram.buckets()) out.push_back({top, count});
  return out;
}

// One sample per counter of `j` named in `outcomes`, labelled outcome="<its name>".
void add_by_outcome(Family& family, const Labels& labels, const Json& j, std::initializer_list<const char*> outcomes) {
  for (const char* outcome : outcomes) {
    Labels with_outcome = labels;
    with_outcome.emplace_back("outcome", outcome);
    family.add(with_outcome, count_of(j, outcome));
  }
}

}  // namespace

const std::vector<std::int64_t>& histogram_bounds_ns() {
  static const std::vector<std::int64_t> bounds = [] {
    std::vector<std::int64_t> out;
    for (std::int64_t decade = 100; decade <= 10'000'000'000; decade *= 10) {
      for (const std::int64_t step : {1, 2, 5}) {
        const std::int64_t wanted = decade * step;
        if (wanted > 10'000'000'000) break;
        int index = LatencyHistogram::bucket_index(wanted);
        if (LatencyHistogram::bucket_upper(index) > wanted) --index;
        out.push_back(LatencyHistogram::bucket_upper(index));
      }
    }
    return out;
  }();
  return bounds;
}

std::string escape_label_value(std::string_view value) {
  std::string out;
  out.reserve(value.size());
  for (const char c : value) {
    if (c == '\\') out += "\\\\";
    else if (c == '"') out += "\\\"";
    else if (c == '\n') out += "\\n";
    else out += c;
  }
  return out;
}

void add_histogram_buckets(const Engine& engine, Json& stats) {
  // Engine::stats lists the live connections first, in engine.connections() order, then the
  // removed ones; the names are checked all the same.
  const auto& connections = engine.connections();
  Json& listed = stats["connections"];
  for (std::size_t i = 0; i < connections.size() && i < listed.size(); ++i) {
    if (listed[i].value("removed", false) || listed[i].value("name", "") != connections[i]->name()) continue;
    listed[i]["latency_ns"]["buckets"] = buckets_json(connections[i]->latency());
  }
  const auto& links = engine.service_links();
  Json& services = stats["services"];
  for (std::size_t i = 0; i < links.size() && i < services.size(); ++i) {
    if (services[i].value("name", "") != links[i].first->full_name() + " -> " + links[i].second->full_name()) continue;
    services[i]["latency_ns"]["buckets"] = buckets_json(links[i].first->latency());
  }
  const auto& contexts = engine.executors().contexts();
  Json& executions = stats["execution_contexts"];
  for (std::size_t i = 0; i < contexts.size() && i < executions.size(); ++i) {
    if (executions[i].value("name", "") != contexts[i]->settings().name) continue;
    executions[i]["wake_jitter_ns"]["buckets"] = buckets_json(contexts[i]->wake_jitter());
  }
}

std::string render_prometheus(const Json& stats) {
  Exposition e;
  e.family("polyport_info", "gauge", "The running application and polyport's version (always 1).")
      .add({{"application", stats.value("application", "")}, {"version", stats.value("polyport_version", "")}}, 1);

  const Json none = Json::array();
  for (const Json& c : stats.value("components", none)) {
    const Labels labels{{"component", c.value("name", "")}, {"model", c.value("model", "")}};
    const std::string state = c.value("state", "");
    Family& states = e.family("polyport_component_state", "gauge",
                              "1 for the component's lifecycle state now, 0 for the other states.");
    bool known = false;
    for (const char* s : kStates) {
      Labels with_state = labels;
      with_state.emplace_back("state", s);
      states.add(with_state, state == s ? 1 : 0);
      known = known || state == s;
    }
    if (!known) {  // a state some model reports beyond the lifecycle's own
      Labels with_state = labels;
      with_state.emplace_back("state", state);
      states.add(with_state, 1);
    }
    e.family("polyport_component_executions_total", "counter", "Executions of the component's step (its execution context's cycles).")
        .add(labels, count_of(c, "executions"));
    e.family("polyport_component_errors_total", "counter", "Errors the component's step returned.")
        .add(labels, count_of(c, "errors"));
  }

  for (const Json& c : stats.value("connections", none)) {
    if (c.value("removed", false)) continue;
    const Labels labels{{"connection", c.value("name", "")}};
    e.family("polyport_connection_received_total", "counter", "Samples the connection took from its source port.")
        .add(labels, count_of(c, "received"));
    e.family("polyport_connection_delivered_total", "counter", "Samples the connection handed to its target port.")
        .add(labels, count_of(c, "delivered"));
    Family& dropped = e.family("polyport_connection_dropped_total", "counter",
                               "Samples the connection dropped, by reason (docs/CONTROL.md).");
    const Json reasons = c.value("dropped_by_reason", Json::object());
    for (const auto& [reason, value] : reasons.items()) {
      Labels with_reason = labels;
      with_reason.emplace_back("reason", reason);
      dropped.add(with_reason, value.get<std::uint64_t>());
    }
    e.family("polyport_connection_latency_seconds", "histogram",
             "Time from the source's write to the target's delivery (push) or read (pull).")
        .add_histogram(labels, c.value("latency_ns", Json::object()));
    if (c.contains("watchdog")) {
      const Json& w = c["watchdog"];
      e.family("polyport_watchdog_trips_total", "counter", "Times the connection's watchdog tripped (a watched port went silent).")
          .add(labels, count_of(w, "trips"));
      e.family("polyport_watchdog_recoveries_total", "counter", "Times the connection's watchdog recovered.")
          .add(labels, count_of(w, "recoveries"));
      e.family("polyport_watchdog_safe_values_total", "counter", "Safe values the watchdog handed to the target.")
          .add(labels, count_of(w, "safe_values"));
      Family& state = e.family("polyport_watchdog_state", "gauge", "1 for the watchdog's state now, 0 for the others.");
      for (const char* s : kWatchdogStates) {
        Labels with_state = labels;
        with_state.emplace_back("state", s);
        state.add(with_state, w.value("state", "") == s ? 1 : 0);
      }
    }
    if (c.contains("condition")) {
      const Json& k = c["condition"];
      Family& events = e.family("polyport_condition_events_total", "counter",
                                "Events an event condition saw, by what became of them (docs/PROFILES.md).");
      add_by_outcome(events, labels, k, {"fired", "suppressed", "inactive"});
      e.family("polyport_condition_activations_total", "counter", "Activations of the condition: the profile's initial one, the client's, polyportctl's.")
          .add(labels, count_of(k, "activations"));
      e.family("polyport_condition_active", "gauge", "1 while the condition is active.")
          .add(labels, k.value("active", false) ? 1 : 0);
    }
    if (c.contains("push")) {
      const Json& p = c["push"];
      e.family("polyport_push_active", "gauge", "1 while the push server is active (clients read not active otherwise).")
          .add(labels, p.value("active", false) ? 1 : 0);
      e.family("polyport_push_primed_total", "counter", "Late subscribers primed with the latest value.")
          .add(labels, count_of(p, "primed"));
      e.family("polyport_push_not_active_writes_total", "counter", "Writes of the server while it was not active.")
          .add(labels, count_of(p, "not_active_writes"));
    }
    if (c.contains("subscription")) {
      const Json& sub = c["subscription"];
      e.family("polyport_subscription_subscribed", "gauge", "1 while the connection's client is subscribed.")
          .add(labels, sub.value("subscribed", false) ? 1 : 0);
      e.family("polyport_subscription_skipped_total", "counter", "Samples skipped to keep the client's every-Nth cycle.")
          .add(labels, count_of(sub, "skipped"));
    }
  }

  for (const Json& c : stats.value("services", none)) {
    const Labels labels{{"service", c.value("name", "")}};
    Family& calls = e.family("polyport_service_calls_total", "counter",
                             "Calls over a service link, by outcome (docs/CONTROL.md).");
    add_by_outcome(calls, labels, c, {"ok", "timeouts", "errors", "not_connected", "too_many_calls", "cancelled"});
    e.family("polyport_service_provider_rejected_total", "counter", "Calls the provider refused.")
        .add(labels, count_of(c, "provider_rejected"));
    e.family("polyport_service_latency_seconds", "histogram", "Time from a call to its reply, for calls a reply ended.")
        .add_histogram(labels, c.value("latency_ns", Json::object()));
  }

  for (const Json& x : stats.value("execution_contexts", none)) {
    const Labels labels{{"execution_context", x.value("name", "")}};
    e.family("polyport_execution_context_cycles_total", "counter", "Cycles the execution context ran.")
        .add(labels, count_of(x, "cycles"));
    e.family("polyport_execution_context_overruns_total", "counter", "Cycles that took longer than the period.")
        .add(labels, count_of(x, "overruns"));
    e.family("polyport_execution_context_wake_jitter_seconds", "histogram",
             "How late the execution context woke after each period's deadline.")
        .add_histogram(labels, x.value("wake_jitter_ns", Json::object()));
  }
  return e.text();
}

}  // namespace polyport::daemon
