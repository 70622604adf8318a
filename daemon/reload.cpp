#include "reload.hpp"

#include <map>
#include <set>
#include <sstream>

#include "polyport/types/dbc.hpp"
#include "type_printer.hpp"

namespace polyport::daemon {
namespace {

std::string key_of(const ConnectionSpec& c) {
  return c.source.component + "." + c.source.port + " -> " + c.target.component + "." + c.target.port;
}

// The components a connection names: its ends, and its watchdog's upstream and event ports.
std::vector<std::string> named_components(const ConnectionSpec& c) {
  std::vector<std::string> names{c.source.component, c.target.component};
  if (c.watchdog) {
    if (c.watchdog->upstream) names.push_back(c.watchdog->upstream->component);
    if (c.watchdog->event) names.push_back(c.watchdog->event->component);
  }
  return names;
}

// A DBC message's frame layout as `polyportd types --json` shows it, without where it is.
nlohmann::json frame_of(const DbcMessage& message) {
  nlohmann::json out;
  describe_dbc(message, out);
  out.erase("where");
  return out;
}

bool same_shape(const Type& a, const Type& b, int depth = 0) {
  if (depth > 64) return true;  // types are acyclic; this only bounds the walk
  if (a.kind != b.kind || a.name != b.name || a.size != b.size || a.align != b.align || a.bound != b.bound ||
      a.extensibility != b.extensibility || a.lcm_fingerprint != b.lcm_fingerprint ||
      a.fields.size() != b.fields.size() || a.enumerators.size() != b.enumerators.size() ||
      (a.element == nullptr) != (b.element == nullptr) || (a.dbc == nullptr) != (b.dbc == nullptr)) {
    return false;
  }
  if (a.element && !same_shape(*a.element, *b.element, depth + 1)) return false;
  for (std::size_t i = 0; i < a.fields.size(); ++i) {
    const Field& fa = a.fields[i];
    const Field& fb = b.fields[i];
    if (fa.name != fb.name || fa.offset != fb.offset || fa.length_fields != fb.length_fields ||
        (fa.type == nullptr) != (fb.type == nullptr) || (fa.type && !same_shape(*fa.type, *fb.type, depth + 1))) {
      return false;
    }
  }
  for (std::size_t i = 0; i < a.enumerators.size(); ++i) {
    if (a.enumerators[i].name != b.enumerators[i].name || a.enumerators[i].value != b.enumerators[i].value) return false;
  }
  return a.dbc == nullptr || frame_of(*a.dbc) == frame_of(*b.dbc);
}

// Every problem, one per line, as file:line:col: element path: message.
std::string problems(const Diagnostics& diagnostics) {
  std::ostringstream text;
  diagnostics.print(text);
  std::string out = std::move(text).str();
  while (!out.empty() && out.back() == '\n') out.pop_back();
  return out;
}

}  // namespace

bool GraphDiff::graph_unchanged() const noexcept {
  return components_added.empty() && components_removed.empty() && components_changed.empty() &&
         connections_added.empty() && connections_removed.empty() && connections_changed.empty();
}

bool GraphDiff::empty() const noexcept {
  return graph_unchanged() && composites_added.empty() && composites_removed.empty() && composites_changed.empty();
}

nlohmann::json GraphDiff::to_json() const {
  return {{"components", {{"added", components_added}, {"removed", components_removed}, {"changed", components_changed}}},
          {"connections",
           {{"added", connections_added}, {"removed", connections_removed}, {"changed", connections_changed}}},
          {"composites", {{"added", composites_added}, {"removed", composites_removed}, {"changed", composites_changed}}}};
}

Result<GraphDiff> diff(const ApplicationProfile& running, const ApplicationProfile& next) {
  GraphDiff out;
  std::map<std::string, const Subcomponent*, std::less<>> before, after;
  for (const Subcomponent& c : running.components) before[c.name] = &c;
  for (const Subcomponent& c : next.components) after[c.name] = &c;
  std::set<std::string, std::less<>> replaced;  // changed or removed: the running instance goes
  for (const Subcomponent& c : next.components) {
    const auto old = before.find(c.name);
    if (old == before.end()) {
      out.components_added.push_back(c.name);
      out.change.components_in.push_back(&c);
    } else if (old->second->definition != c.definition) {
      out.components_changed.push_back(c.name);
      out.change.components_in.push_back(&c);
      out.change.components_out.push_back(c.name);
      replaced.insert(c.name);
    }
  }
  for (const Subcomponent& c : running.components) {
    if (after.count(c.name) != 0) continue;
    out.components_removed.push_back(c.name);
    out.change.components_out.push_back(c.name);
    replaced.insert(c.name);
  }
  const auto touched = [&](const ConnectionSpec& c) {
    for (const std::string& name : named_components(c)) {
      if (replaced.count(name) != 0) return true;
    }
    return false;
  };

  std::map<std::string, const ConnectionSpec*, std::less<>> old_connections;
  std::set<std::string, std::less<>> new_keys;
  for (const ConnectionSpec& c : running.connections) old_connections[key_of(c)] = &c;
  for (const ConnectionSpec& c : next.connections) {
    const std::string key = key_of(c);
    new_keys.insert(key);
    const auto old = old_connections.find(key);
    const bool added = old == old_connections.end();
    const bool changed = !added && (old->second->definition != c.definition || touched(c));
    if (!added && !changed) continue;
    if (added) {
      out.connections_added.push_back(key);
    } else {
      out.connections_changed.push_back(key);
      out.change.connections_out.emplace_back(c.source.component + "." + c.source.port,
                                              c.target.component + "." + c.target.port);
    }
    out.change.connections_in.push_back(&c);
  }
  for (const ConnectionSpec& c : running.connections) {
    const std::string key = key_of(c);
    if (new_keys.count(key) != 0) continue;
    out.connections_removed.push_back(key);
    out.change.connections_out.emplace_back(c.source.component + "." + c.source.port,
                                            c.target.component + "." + c.target.port);
  }
  // Connections are keyed by the member ports their ends resolve to, so a composite that now
  // promotes another port already shows above as a connection removed and one added.
  for (const CompositeSpec& c : next.composites) {
    const CompositeSpec* old = running.find_composite(c.name);
    if (old == nullptr) {
      out.composites_added.push_back(c.name);
    } else if (old->definition != c.definition) {
      out.composites_changed.push_back(c.name);
    }
  }
  for (const CompositeSpec& c : running.composites) {
    if (next.find_composite(c.name) == nullptr) out.composites_removed.push_back(c.name);
  }
  return out;
}

std::optional<std::string> changed_type(const TypeRegistry& live, const TypeRegistry& fresh) {
  std::set<std::string, std::less<>> read_files;  // the files the daemon read its types from
  for (const Type* type : live.declared()) read_files.insert(type->where.file);
  for (const Type* type : fresh.declared()) {
    const std::string where = type->where.file.empty() ? std::string()
                                                       : type->where.file + ":" + std::to_string(type->where.line) + ":" +
                                                             std::to_string(type->where.column) + ": ";
    const Type* running = live.find(type->name);
    if (running == nullptr) {
      if (read_files.count(type->where.file) == 0) continue;  // a new file: read at the reload
      return where + "type '" + type->name +
             "' is new in a file the daemon read at start: type files are read once per run (restart the daemon, or "
             "declare it in a new file)";
    }
    if (same_shape(*running, *type)) continue;
    return where + "type '" + type->name +
           "' differs from the one the daemon runs with: types are read once per run (restart the daemon to change them)";
  }
  return std::nullopt;
}

Result<nlohmann::json> reload(Engine& engine, TypeRegistry& types, ApplicationProfile& application,
                              const ProfileReader& read, const std::set<std::pair<std::string, std::string>>& run_time,
                              std::vector<std::string>& warnings) {
  // Validated on their own first: nothing of a broken profile reaches the running registry.
  TypeRegistry fresh;
  Diagnostics checked;
  std::optional<ApplicationProfile> candidate = read(fresh, checked);
  if (!candidate || checked.has_errors()) {
    return make_error(std::to_string(checked.error_count()) + " problem(s) in the profiles:\n" + problems(checked));
  }
  if (auto changed = changed_type(types, fresh)) return make_error(*changed);
  Diagnostics bound_problems;
  std::optional<ApplicationProfile> next = read(types, bound_problems);
  if (!next || bound_problems.has_errors()) {
    return make_error(std::to_string(bound_problems.error_count()) + " problem(s) in the profiles:\n" +
                      problems(bound_problems));
  }
  Result<GraphDiff> difference = diff(application, *next);
  if (!difference) return difference.error();
  Engine::Change& change = difference.value().change;
  for (const ConnectionSpec* c : change.connections_in) {
    std::pair<std::string, std::string> ends{c->source.component + "." + c->source.port,
                                             c->target.component + "." + c->target.port};
    if (run_time.count(ends) != 0) change.connections_out.push_back(std::move(ends));
  }
  nlohmann::json summary = difference.value().to_json();
  if (!difference.value().graph_unchanged()) {
    if (auto applied = engine.apply(difference.value().change, warnings); !applied) return applied.error();
  }
  summary["unchanged"] = difference.value().empty();
  application = std::move(*next);
  return summary;
}

}  // namespace polyport::daemon
