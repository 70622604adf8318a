// polyportd: loads application profiles, builds the graph, runs it until SIGINT/SIGTERM.
//
// Exit codes (also in --help):
//   0  ran and stopped cleanly, or `check` found no problem
//   1  a run-time failure (a component did not start, a file could not be written)
//   2  bad command line
//   3  a profile has problems (each printed as file:line:col: element path: message)
#include <malloc.h>
#include <poll.h>
#include <signal.h>
#include <sys/signalfd.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <chrono>
#include <cstring>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>
#include <sstream>

#include "admin_protocol.hpp"
#include "admin_server.hpp"
#include "composites.hpp"
#include "control_requests.hpp"
#include "metrics.hpp"
#include "metrics_server.hpp"
#include "models.hpp"
#include "polyport/base/clock.hpp"
#include "polyport/runtime/component_api.hpp"
#include "polyport/runtime/engine.hpp"
#include "polyport/profile/profile.hpp"
#include "polyport/types/types.hpp"
#include "sd_notify.hpp"
#include "tracer.hpp"
#ifdef POLYPORT_WITH_RECORDER
#include "recorder.hpp"
#endif
#include "types_command.hpp"

namespace {

using namespace polyport;

constexpr int kExitOk = 0;
constexpr int kExitRuntime = 1;
constexpr int kExitUsage = 2;
constexpr int kExitProfile = 3;

constexpr const char* kExitCodesHelp =
    "Exit codes:\n"
    "  0  ran and stopped cleanly (run), or no problem found (check)\n"
    "  1  run-time failure: a component did not start, an output file could not be written\n"
    "  2  bad command line\n"
    "  3  a profile (or a type file, for `types`) has problems, each printed as\n"
    "     file:line:col: element path: message\n";

struct Options {
  std::vector<std::string> profiles;
  std::vector<std::string> library_path;
  std::string stats_json;
  double stats_interval_s = 5.0;
  double duration_s = 0.0;
  bool quiet = false;
  bool json = false;
  std::string log_level = "info";
  std::vector<std::string> trace_ports;
  std::string trace_file = "polyport-trace.jsonl";
  std::uint32_t trace_depth = 4096;
  std::string admin_socket;  // empty: the default path; "none": no admin socket
  std::string admin_group;   // empty: none; else a group (name or gid) whose members may connect
  int metrics_port = -1;     // -1: no metrics endpoint; 0: a port the kernel picks
  std::string metrics_address = "127.0.0.1";
  std::string record_file;   // empty: no recording
  std::vector<std::string> record_connections;  // empty: every data connection
  std::uint32_t record_depth = 1024;
  std::string clock = "auto";  // auto, system, tsc: the clock of the forwarding path's stamps
  std::string can_io = "auto";  // auto, io_uring, epoll: how the CAN receive thread waits
};

// The shipped plugins' folder: the build's lib/ for the binary of the build tree; for an
// installed binary, the installation's plugin folder found from the binary's own place, so an
// installed tree works under any prefix (cmake --install --prefix DIR, the .deb's /usr).
std::filesystem::path shipped_plugin_dir() {
  std::error_code ec;
  const std::filesystem::path exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (ec) return POLYPORT_PLUGIN_DIR;
  const std::filesystem::path bin = exe.parent_path();
  if (std::filesystem::equivalent(bin, POLYPORT_BUILD_BIN_DIR, ec)) return POLYPORT_PLUGIN_DIR;
  return (bin / POLYPORT_INSTALLED_PLUGIN_DIR).lexically_normal();
}

std::vector<std::filesystem::path> library_path(const Options& options) {
  std::vector<std::filesystem::path> out(options.library_path.begin(), options.library_path.end());
  if (const char* env = std::getenv("POLYPORT_LIBRARY_PATH")) {
    std::stringstream list(env);
    std::string entry;
    while (std::getline(list, entry, ':')) {
      if (!entry.empty()) out.emplace_back(entry);
    }
  }
  out.emplace_back(shipped_plugin_dir());
  return out;
}

// Reads every profile into `types` as one application (components and connections of all
// of them); problems go to `diagnostics`. Nullopt when a profile could not be read.
std::optional<ApplicationProfile> read_profiles(const Options& options, const ModelRegistry& models, TypeRegistry& types,
                                                Diagnostics& diagnostics) {
  LoadOptions load_options{library_path(options)};
  load_options.models = &models;
  ApplicationProfile application;
  bool ok = true;
  for (const std::string& file : options.profiles) {
    std::optional<ApplicationProfile> profile = load_application_profile(file, types, load_options, diagnostics);
    if (!profile) {
      ok = false;
      continue;
    }
    if (application.name.empty()) {
      application.name = profile->name;
      application.file = profile->file;
      application.description = profile->description;
    }
    for (Subcomponent& c : profile->components) application.components.push_back(std::move(c));
    for (ConnectionSpec& c : profile->connections) application.connections.push_back(std::move(c));
    for (CompositeSpec& c : profile->composites) application.composites.push_back(std::move(c));
  }
  // Each profile checks its own names; across profiles a composite must not take a name
  // another profile gives a component or a composite (connections name both alike).
  for (std::size_t i = 0; i < application.composites.size(); ++i) {
    const CompositeSpec& c = application.composites[i];
    const Subcomponent* component = application.find_component(c.name);
    const CompositeSpec* first = application.find_composite(c.name);
    if (component == nullptr && first == &c) continue;
    const SourceLocation& other = component != nullptr ? component->where : first->where;
    diagnostics.error(c.where, "", "composite name '" + c.name + "' is already used at " + other.file + ":" +
                                       std::to_string(other.line) + ":" + std::to_string(other.column));
    ok = false;
  }
  if (!ok) return std::nullopt;
  return application;
}

// Loads every profile and builds the engine; prints every problem. False on any error.
// `application`, when given, receives every profile's components and connections (what the
// admin socket checks run-time changes against, and what a reload compares with).
bool load(const Options& options, const ModelRegistry& models, Engine& engine, TypeRegistry& types,
          ApplicationProfile* application = nullptr) {
  Diagnostics diagnostics;
  std::optional<ApplicationProfile> profiles = read_profiles(options, models, types, diagnostics);
  const bool ok = profiles && engine.build(*profiles, diagnostics);
  diagnostics.print(std::cerr);
  if (!ok || diagnostics.has_errors()) {
    std::cerr << diagnostics.error_count() << " problem(s) found\n";
    return false;
  }
  if (application != nullptr) *application = std::move(*profiles);
  return true;
}

std::string histogram_text(const nlohmann::json& h) {
  std::ostringstream out;
  out << "p50 " << h.value("p50", 0) << " ns, p99 " << h.value("p99", 0) << " ns, max " << h.value("max", 0)
      << " ns (n=" << h.value("count", 0) << ")";
  return out.str();
}

// Where a port lives in its model, from the model's part of the component's description
// (describe(): lists of endpoints with the port they serve): " topic=...", " channel=..." or
// " can_id=..." (with " cycle_ms=..." when periodic), or the SocketCAN bus event port; for a
// service port, each operation's request and reply topics or channels with their types
// (" add: request_channel=calc/add/request [peer.add_request_t] ...").
std::string native_endpoint(const nlohmann::json& component, const std::string& port) {
  for (const auto& [key, part] : component.items()) {
    if (!part.is_object()) continue;
    // The SocketCAN model names its bus event port on its own.
    if (part.value("bus_events", nlohmann::json()) == port) return "  can_bus_events";
    for (const auto& [list_key, list] : part.items()) {
      if (!list.is_array()) continue;
      for (const auto& endpoint : list) {
        if (!endpoint.is_object() || endpoint.value("port", "") != port) continue;
        if (endpoint.contains("operations")) {
          std::string text;
          for (const auto& op : endpoint["operations"]) {
            text += "  " + op.value("operation", "") + ":";
            for (const char* way : {"request", "reply"}) {
              for (const char* name : {"topic", "channel"}) {
                const std::string address = std::string(way) + "_" + name;
                if (!op.contains(address)) continue;
                text += " " + address + "=" + op[address].get<std::string>() + " [" +
                        op.value(std::string(way) + "_type", "") + "]";
              }
            }
          }
          return text;
        }
        for (const char* name : {"topic", "channel", "can_id"}) {
          if (!endpoint.contains(name)) continue;
          std::string text = "  " + std::string(name) + "=" + endpoint[name].get<std::string>();
          // A CAN message the broadcast manager sends periodically.
          if (endpoint.value("cycle_ms", 0) != 0) text += "  cycle_ms=" + std::to_string(endpoint.value("cycle_ms", 0));
          return text;
        }
      }
    }
  }
  return {};
}

void print_graph(const nlohmann::json& graph, std::ostream& out) {
  out << "application " << graph.value("application", "") << "\n";
  out << "components:\n";
  for (const auto& c : graph["components"]) {
    out << "  " << c.value("name", "") << "  model=" << c.value("model", "");
    if (c.contains("execution_context")) out << "  execution_context=" << c["execution_context"].get<std::string>();
    for (const char* model : {"lcm", "socketcan"}) {
      if (c.contains(model) && c[model].contains("receive_thread")) {
        out << "  receive_thread=" << c[model]["receive_thread"].value("asked", "");
      }
    }
    out << "\n";
    for (const auto& p : c["ports"]) {
      out << "    " << p.value("direction", "") << " " << p.value("kind", "") << " " << p.value("name", "");
      if (p.contains("type")) out << "  type=" << p["type"].get<std::string>();
      if (p.contains("service_type")) out << "  service=" << p["service_type"].get<std::string>();
      if (p.contains("policy")) out << "  policy=" << p["policy"].get<std::string>();
      if (p.contains("depth")) out << "  depth=" << p["depth"];
      if (p.contains("mode")) out << "  mode=" << p["mode"].get<std::string>();
      if (p.contains("push")) out << "  push=" << p["push"].get<std::string>();
      if (p.contains("push_cycle_ns")) out << " cycle=" << p["push_cycle_ns"].get<double>() / 1e6 << " ms";
      out << native_endpoint(c, p.value("name", "")) << "\n";
    }
  }
  out << "connections:\n";
  for (const auto& c : graph["connections"]) {
    out << "  " << c.value("kind", "") << "  " << c.value("source", "") << " -> " << c.value("target", "");
    if (c.contains("source_promoted") || c.contains("target_promoted")) {
      out << "  (as " << c.value("source_promoted", c.value("source", "")) << " -> "
          << c.value("target_promoted", c.value("target", "")) << ")";
    }
    if (c.contains("type")) out << "  type=" << c["type"].get<std::string>();
    if (c.contains("policy")) out << "  policy=" << c["policy"].get<std::string>();
    if (c.contains("depth")) out << "  depth=" << c["depth"];
    if (c.contains("mode")) out << "  mode=" << c["mode"].get<std::string>();
    if (c.contains("conversion")) out << "  conversion=" << c["conversion"].get<std::string>();
    if (c.contains("max_in_flight")) out << "  max_in_flight=" << c["max_in_flight"];
    if (c.contains("watchdog")) {
      const auto& w = c["watchdog"];
      out << "  watchdog=" << w.value("deadline_ns", 0) / 1e6 << " ms";
      if (w.contains("max_age_ns")) out << " max_age=" << w.value("max_age_ns", 0) / 1e6 << " ms";
      if (w.contains("upstream")) out << " upstream=" << w["upstream"].get<std::string>();
    }
    if (c.contains("poll_period_ns")) out << "  poll=" << c["poll_period_ns"].get<double>() / 1e6 << " ms";
    if (c.contains("rate_limit_interval_ns")) {
      out << "  rate_limit=" << 1e9 / c["rate_limit_interval_ns"].get<double>() << "/s";
    }
    for (const auto& band : c.value("deadbands", nlohmann::json::array())) {
      out << "  deadband=" << band.value("field", "") << ":" << band.value("threshold", 0.0);
    }
    if (c.contains("condition")) {
      const auto& k = c["condition"];
      out << "  condition=" << k.value("mode", "") << (k.value("active", false) ? "" : "(inactive)");
      for (const auto& f : k.value("fields", nlohmann::json::array())) {
        out << " " << f.value("field", "") << " " << f.value("op", "") << " " << f.value("value", 0.0);
        if (f.contains("param")) out << " (" << f["param"].get<std::string>() << ")";
      }
      out << " tested=" << k.value("tested", 0) << " fired=" << k.value("fired", 0)
          << " suppressed=" << k.value("suppressed", 0) << " inactive=" << k.value("inactive", 0);
    }
    if (c.contains("subscription")) out << "  subscription=every " << c["subscription"].value("every", 0);
    out << "\n";
  }
  if (!graph.value("composites", nlohmann::json::array()).empty()) {
    out << "composites:\n";
    for (const auto& c : graph["composites"]) {
      out << "  " << c.value("name", "") << "  members:";
      for (const auto& m : c["members"]) out << " " << m.get<std::string>();
      out << "\n";
      for (const auto& p : c["ports"]) {
        out << "    " << p.value("direction", "") << " " << p.value("kind", "") << " " << p.value("name", "") << " = "
            << p.value("member", "");
        if (p.contains("type")) out << "  type=" << p["type"].get<std::string>();
        if (p.contains("service_type")) out << "  service=" << p["service_type"].get<std::string>();
        out << "\n";
      }
    }
  }
  out << "execution contexts:\n";
  for (const auto& e : graph["execution_contexts"]) {
    out << "  " << e.value("name", "") << "  period=" << e.value("period_ns", 0) / 1e6 << " ms";
    if (e.value("spin_us", 0) > 0) out << "  spin=" << e.value("spin_us", 0) << " us";
    if (e.contains("phase_ns") && e["phase_ns"].is_number()) out << "  phase=" << e["phase_ns"].get<double>() / 1e6 << " ms";
    if (e.contains("priority")) out << "  " << e.value("policy", "") << " priority=" << e.value("priority", 0);
    out << "  members:";
    for (const auto& m : e["members"]) out << " " << m.get<std::string>();
    out << "\n";
  }
  if (graph.value("locks_memory", false)) {
    out << "  (a real-time context: the daemon locks its memory and pre-faults the context's stack)\n";
  }
}

int run_check(const Options& options) {
  TypeRegistry types;
  ModelRegistry models;
  daemon::register_models(models);
  Engine engine(models, types);
  ApplicationProfile application;
  if (!load(options, models, engine, types, &application)) return kExitProfile;
  nlohmann::json graph;
  engine.describe(graph);
  daemon::describe_composites(application, graph);
  if (options.json) {
    std::cout << graph.dump(2) << "\n";
  } else {
    print_graph(graph, std::cout);
    std::cout << "ok: no problems found\n";
  }
  return kExitOk;
}

void print_final_stats(const nlohmann::json& stats) {
  spdlog::info("final statistics:");
  for (const auto& c : stats["components"]) {
    spdlog::info("  component {} ({}): state {}, {} executions, {} errors", c.value("name", ""), c.value("model", ""),
                 c.value("state", ""), c.value("executions", 0), c.value("errors", 0));
    if (c.contains("lcm")) {
      for (const auto& ch : c["lcm"].value("channels", nlohmann::json::array())) {
        if (ch.value("polyport", "") == "subscribes") {
          spdlog::info("    LCM channel {}: {} received, {} of another type, {} too short, {} too large, "
                       "{} of polyport's own dropped",
                       ch.value("channel", ""), ch.value("received", 0), ch.value("wrong_fingerprint", 0),
                       ch.value("too_short", 0), ch.value("too_large", 0), ch.value("loop_dropped", 0));
        } else {
          spdlog::info("    LCM channel {}: {} published, {} failed", ch.value("channel", ""), ch.value("published", 0),
                       ch.value("failed", 0));
        }
      }
    }
    for (const char* model : {"lcm", "dds"}) {
      if (!c.contains(model)) continue;
      for (const auto& sv : c[model].value("services", nlohmann::json::array())) {
        const nlohmann::json counters = sv.value("counters", nlohmann::json::object());
        spdlog::info("    service port {} (polyport {}): {} calls, {} replies, {} errors ({} timeouts, {} refused), "
                     "{} malformed, {} unmatched",
                     sv.value("port", ""), sv.value("polyport", ""), counters.value("calls", 0),
                     counters.value("replies", 0), counters.value("errors", 0), counters.value("timeouts", 0),
                     counters.value("refused", 0), counters.value("malformed", 0), counters.value("unmatched", 0));
      }
    }
    if (c.contains("socketcan")) {
      const auto& can = c["socketcan"];
      const auto bus = can.value("bus", nlohmann::json::object());
      spdlog::info("    CAN interface {}: {}, {} losses, {} returns; bus {}, {} error frames ({} bus-off); "
                   "{} frames of polyport's own dropped",
                   can.value("interface", ""), can.value("link", ""), can.value("losses", 0),
                   can.value("recoveries", 0), bus.value("state", ""), bus.value("error_frames", 0),
                   bus.value("kinds", nlohmann::json::object()).value("bus_off", 0), can.value("loop_dropped", 0));
      for (const auto& p : can.value("ports", nlohmann::json::array())) {
        if (p.value("polyport", "") == "receives") {
          spdlog::info("    CAN id {} ({}): {} received, {} of another length", p.value("can_id", ""),
                       p.value("message", ""), p.value("received", 0), p.value("bad_length", 0));
        } else {
          spdlog::info("    CAN id {} ({}): {} sent, {} failed{}", p.value("can_id", ""), p.value("message", ""),
                       p.value("sent", 0), p.value("send_failed", 0),
                       p.value("cycle_ms", 0) != 0 ? ", every " + std::to_string(p.value("cycle_ms", 0)) + " ms" : "");
        }
      }
    }
    if (!c.contains("dds")) continue;
    for (const auto& t : c["dds"].value("topics", nlohmann::json::array())) {
      if (t.value("polyport", "") == "reads") {
        spdlog::info("    DDS topic {}: {} received, {} refused, {} of polyport's own dropped", t.value("topic", ""),
                     t.value("received", 0), t.value("refused", 0), t.value("loop_dropped", 0));
      } else if (t.contains("matched_readers")) {
        spdlog::info("    DDS topic {}: {} readers matched", t.value("topic", ""), t.value("matched_readers", 0));
      }
    }
  }
  for (const auto& c : stats["connections"]) {
    spdlog::info("  {}: received {}, delivered {}, dropped {}; latency {}", c.value("name", ""), c.value("received", 0),
                 c.value("delivered", 0), c.value("dropped", 0), histogram_text(c["latency_ns"]));
    if (c.contains("watchdog")) {
      const auto& w = c["watchdog"];
      spdlog::info("    watchdog: {}, {} trips, {} recoveries, {} safe values, {} stale", w.value("state", ""),
                   w.value("trips", 0), w.value("recoveries", 0), w.value("safe_values", 0), w.value("stale", 0));
    }
  }
  for (const auto& s : stats["services"]) {
    spdlog::info("  {}: calls {}, ok {}, timeouts {}, errors {}, cancelled {}", s.value("name", ""),
                 s.value("calls", 0), s.value("ok", 0), s.value("timeouts", 0), s.value("errors", 0),
                 s.value("cancelled", 0));
  }
  if (stats.contains("recording")) {
    for (const auto& r : stats["recording"]["connections"]) {
      spdlog::info("  recording {} on channel {} ({}): recorded {}, dropped {}", r.value("connection", ""),
                   r.value("channel", ""), r.value("encoding", ""), r.value("recorded", 0), r.value("dropped", 0));
    }
  }
  for (const auto& e : stats["execution_contexts"]) {
    spdlog::info("  execution context {}: {} cycles, {} overruns; wake jitter {}", e.value("name", ""),
                 e.value("cycles", 0), e.value("overruns", 0), histogram_text(e["wake_jitter_ns"]));
  }
}

#ifdef POLYPORT_WITH_RECORDER
// The recording of this run, for collect_stats (control thread only); null: none.
const daemon::Recorder* g_recorder = nullptr;
#endif

// The statistics of --stats-json, also what the admin socket's `stats` answers.
nlohmann::json collect_stats(const Engine& engine, const Options& options, std::chrono::steady_clock::time_point t_start) {
  nlohmann::json stats;
  engine.stats(stats);
#ifdef POLYPORT_WITH_RECORDER
  if (g_recorder != nullptr) g_recorder->stats(stats);
#endif
  stats["polyport_version"] = POLYPORT_VERSION;
  stats["profiles"] = options.profiles;
  stats["run_seconds"] = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  const ClockStats clock = clock_stats();
  stats["clock"] = {{"source", clock.tsc && !clock.given_up ? "tsc" : "system"}};
  if (clock.tsc)
    stats["clock"].update({{"tsc_ghz", clock.tsc_ghz}, {"calibrations", clock.calibrations}, {"steps", clock.steps},
                           {"skipped", clock.skipped}, {"last_error_ns", clock.last_error_ns},
                           {"max_abs_error_ns", clock.max_abs_error_ns}, {"wall_checks", clock.wall_checks},
                           {"wall_error_mean_ns", clock.wall_error_mean_ns}, {"wall_error_min_ns", clock.wall_error_min_ns},
                           {"wall_error_max_ns", clock.wall_error_max_ns}});
  if (clock.given_up) stats["clock"]["tsc_given_up"] = clock.why_given_up;
  return stats;
}

// Answers an admin request; runs on the engine's control thread (this main thread).
std::string answer(const admin::Request& request, std::uint64_t client, Engine& engine,
                   daemon::ControlRequests& control, daemon::TraceStreams& traces, const daemon::ProfileReader& read,
                   const Options& options, std::chrono::steady_clock::time_point t_start,
                   const daemon::MetricsServer& metrics) {
  using admin::Command;
  switch (request.command) {
    case Command::trace: {
      // Streamed: samples follow as the main loop drains the probe (TraceStreams::drain).
      std::optional<std::string> refused =
          traces.open(engine, client, request.id, control.member_path(request.port), request.count, request.duration_s);
      return refused ? *refused : daemon::AdminServer::kStreaming;
    }
    case Command::hello: {
      nlohmann::json graph;
      engine.describe(graph);
      return admin::ok_reply(request.id, {{"protocol", admin::kProtocolVersion},
                                          {"daemon", "polyportd"},
                                          {"version", POLYPORT_VERSION},
                                          {"pid", getpid()},
                                          {"application", graph.value("application", "")},
                                          {"profiles", options.profiles},
                                          {"metrics", metrics.url()}});
    }
    case Command::list: {
      // The graph of `check --json`, with each component's lifecycle state now.
      nlohmann::json graph;
      engine.describe(graph);
      for (auto& c : graph["components"]) {
        if (const Interceptor* i = engine.find_interceptor(c.value("name", ""))) c["state"] = i->status().state;
      }
      control.annotate(graph);
      return admin::ok_reply(request.id, graph);
    }
    case Command::get:
      return control.get(request);
    case Command::set:
      return control.set(request);
    case Command::connect:
      return control.connect(request);
    case Command::disconnect:
      return control.disconnect(request);
    case Command::condition:
      return control.condition(request);
    case Command::reload:
      return control.reload(request, read);
    case Command::stats:
      return admin::ok_reply(request.id, collect_stats(engine, options, t_start));
    case Command::activate:
    case Command::deactivate:
    case Command::reset: {
      const LifecycleCommand command = request.command == Command::activate     ? LifecycleCommand::activate
                                       : request.command == Command::deactivate ? LifecycleCommand::deactivate
                                                                                : LifecycleCommand::reset;
      Interceptor* interceptor = engine.find_interceptor(request.component);
      if (interceptor == nullptr) {
        if (auto reply = control.composite_command(request, command)) return *reply;
        nlohmann::json graph;
        engine.describe(graph);
        std::string names;
        for (const auto& c : graph["components"]) names += (names.empty() ? "" : ", ") + c.value("name", "");
        return admin::error_reply(request.id, admin::kUnknownComponent,
                                  "no component named '" + request.component + "' (components: " + names + ")");
      }
      const ReturnCode code = interceptor->command(command);
      const std::string state = interceptor->status().state;
      if (code != ReturnCode::ok) {
        return admin::error_reply(request.id, admin::kRefused,
                                  std::string(to_string(command)) + " " + request.component + ": " +
                                      std::string(to_string(code)) + " (state " + state + ")");
      }
      spdlog::info("admin: {} {}: now {}", to_string(command), request.component, state);
      return admin::ok_reply(request.id, {{"component", request.component}, {"state", state}});
    }
  }
  return admin::error_reply(request.id, admin::kUnknownCommand, "unknown command");
}

int run_daemon(const Options& options) {
  // Signals are taken synchronously by this thread; every other thread inherits the mask.
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGINT);
  sigaddset(&signals, SIGTERM);
  sigaddset(&signals, SIGHUP);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);

  // Before anything stamps: every stamp of the run is on one clock.
  const ClockChoice choice = options.clock == "system" ? ClockChoice::system
                             : options.clock == "tsc"  ? ClockChoice::tsc
                                                       : ClockChoice::automatic;
  const Result<ClockInfo> clock = use_clock(choice);
  if (!clock) {
    spdlog::error("--clock tsc: {}", clock.error().message);
    return kExitUsage;
  }
  if (clock.value().tsc)
    spdlog::info("stamps from the TSC clock ({:.6f} GHz, kept on CLOCK_MONOTONIC every 250 ms): {}",
                 clock.value().tsc_ghz, clock.value().why);
  else
    spdlog::debug("stamps from clock_gettime: {}", clock.value().why);

  TypeRegistry types;
  ModelRegistry models;
  daemon::register_models(models, daemon::ModelOptions{options.can_io});
  Engine engine(models, types);
  ApplicationProfile application;
  if (!load(options, models, engine, types, &application)) {
    spdlog::error("not running: the profile has problems");
    return kExitProfile;
  }
  daemon::ControlRequests control(engine, types, std::move(application));
  const daemon::ProfileReader read = [&](TypeRegistry& into, Diagnostics& diagnostics) {
    return read_profiles(options, models, into, diagnostics);
  };

  daemon::Tracer tracer;
  if (!options.trace_ports.empty()) {
    if (auto opened = tracer.open(options.trace_file); !opened) {
      spdlog::error("{}", opened.error().message);
      return kExitRuntime;
    }
    for (const std::string& port : options.trace_ports) {
      if (auto added = tracer.add(engine, port, options.trace_depth); !added) {
        spdlog::error("--trace {}: {}", port, added.error().message);
        return kExitUsage;
      }
    }
    spdlog::info("tracing {} port(s) to {}", options.trace_ports.size(), options.trace_file);
  }

#ifdef POLYPORT_WITH_RECORDER
  daemon::Recorder recorder;
  if (!options.record_file.empty()) {
    if (auto opened = recorder.open(engine, options.record_file, options.record_connections, options.record_depth);
        !opened) {
      spdlog::error("--record: {}", opened.error().message);
      return kExitUsage;
    }
    g_recorder = &recorder;
    spdlog::info("recording {} to {}",
                 options.record_connections.empty() ? std::string("every data connection")
                                                    : std::to_string(options.record_connections.size()) + " connection(s)",
                 options.record_file);
  }
#else
  if (!options.record_file.empty()) {
    spdlog::error("--record: this polyportd was built without LCM, whose log format recordings use");
    return kExitUsage;
  }
#endif

  // Before the engine's threads start: creating the socket sets the process's umask briefly.
  daemon::AdminServer admin;
  daemon::TraceStreams traces;
  std::optional<gid_t> admin_group;
  if (!options.admin_group.empty()) {
    Result<gid_t> group = daemon::admin_group(options.admin_group);
    if (!group) {
      spdlog::error("{}", group.error().message);
      return kExitUsage;
    }
    admin_group = group.value();
  }
  if (options.admin_socket != "none") {
    std::string path = options.admin_socket;
    // The default place may be out of reach (no /run/polyport for a user without
    // XDG_RUNTIME_DIR): the daemon then runs without a socket and says so. A path given on
    // the command line must work.
    const bool chosen = !path.empty();
    if (!chosen) {
      Result<std::string> fallback = daemon::default_admin_socket();
      if (fallback) path = fallback.value();
      else spdlog::warn("no admin socket: {}", fallback.error().message);
    }
    if (!path.empty()) {
      if (auto listening = admin.start(path, admin_group); !listening) {
        if (chosen) {
          spdlog::error("{} (--admin-socket none runs without one)", listening.error().message);
          return kExitRuntime;
        }
        spdlog::warn("no admin socket: {} (--admin-socket PATH chooses another place)", listening.error().message);
      }
    }
  }

  // Bound before the engine starts: a port in use is an error, as a chosen admin socket is.
  daemon::MetricsServer metrics;
  if (options.metrics_port >= 0) {
    if (auto listening = metrics.start(options.metrics_address, options.metrics_port); !listening) {
      spdlog::error("{} (--metrics-port chooses another port, 0 one the kernel picks)", listening.error().message);
      return kExitRuntime;
    }
  }

  std::vector<std::string> warnings;
  engine.set_notifier([](const std::string& message, bool problem) {
    if (problem) {
      spdlog::warn("{}", message);
    } else {
      spdlog::info("{}", message);
    }
  });
#ifdef POLYPORT_WITH_RECORDER
  recorder.start();
#endif
  Result<void> started = engine.start(warnings);
  for (const std::string& warning : warnings) spdlog::warn("{}", warning);
  if (!started) {
    spdlog::error("{}", started.error().message);
    return kExitRuntime;
  }
  spdlog::info("running {} (pid {}); SIGINT or SIGTERM stops", options.profiles.front(), getpid());
  if (!admin.path().empty()) spdlog::info("admin socket {}", admin.path());
  if (metrics.port() != 0) spdlog::info("metrics at {}", metrics.url());
  const int signal_fd = signalfd(-1, &signals, SFD_NONBLOCK | SFD_CLOEXEC);
  if (signal_fd < 0) {
    spdlog::error("signalfd: {}", strerror(errno));
    engine.stop();
    return kExitRuntime;
  }

  using Clock = std::chrono::steady_clock;
  const auto t_start = Clock::now();
  auto next_summary = t_start + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(options.stats_interval_s));
  const bool summaries = !options.quiet && options.stats_interval_s > 0;
  daemon::ServiceNotifier systemd;  // under a Type=notify unit: READY, WATCHDOG, STOPPING
  systemd.ready("running " + options.profiles.front());
  int stop_signal = 0;
  bool clock_given_up_logged = false;
  while (stop_signal == 0) {
    // Wake often enough to drain traces and ping systemd's watchdog; otherwise sleep until
    // the next summary. Admin requests and scrapes wake it at once (poll skips the fd of one
    // not running: -1).
    pollfd fds[3] = {{signal_fd, POLLIN, 0}, {admin.request_fd(), POLLIN, 0}, {metrics.request_fd(), POLLIN, 0}};
    const auto wait = systemd.wait_at_most(Clock::now(), std::chrono::milliseconds(tracer.active() || traces.active() ? 100 : 500));
    ::poll(fds, 3, static_cast<int>(wait.count()));
    signalfd_siginfo info{};
    while (::read(signal_fd, &info, sizeof info) == static_cast<ssize_t>(sizeof info)) {
      const int signal = static_cast<int>(info.ssi_signo);
      if (signal == SIGINT || signal == SIGTERM) {
        stop_signal = signal;
      } else if (signal == SIGHUP) {
        spdlog::info("SIGHUP: reloading {}", options.profiles.front());
        std::vector<std::string> reload_warnings;
        Result<nlohmann::json> reloaded = control.reload(read, reload_warnings);
        for (const std::string& warning : reload_warnings) spdlog::warn("reload: {}", warning);
        if (reloaded) {
          spdlog::info("reload: {}", reloaded.value().dump());
        } else {
          spdlog::error("reload refused, the running graph is unchanged: {}", reloaded.error().message);
        }
      }
    }
    if (admin.request_fd() >= 0 && (fds[1].revents & POLLIN)) {
      admin.serve(
          [&](const admin::Request& request, std::uint64_t client) {
            return answer(request, client, engine, control, traces, read, options, t_start, metrics);
          },
          [&](std::uint64_t client) { traces.close(engine, client); });
    }
    if (metrics.request_fd() >= 0 && (fds[2].revents & POLLIN)) {
      metrics.serve([&] {
        nlohmann::json stats = collect_stats(engine, options, t_start);
        daemon::add_histogram_buckets(engine, stats);
        return daemon::render_prometheus(stats);
      });
    }
    if ((fds[1].revents | fds[2].revents) & POLLIN) {
      // The statistics JSON and the metrics text of a request are large and short-lived; the
      // free memory they leave behind (here and in the server threads' malloc arenas) goes
      // back to the system, so a daemon polled for months keeps a flat RSS.
      malloc_trim(0);
    }
    if (tracer.active()) tracer.drain();
    if (traces.active()) {
      traces.drain(engine, [&](std::uint64_t client, std::string lines, bool last) {
        admin.send(client, std::move(lines), last);
      });
    }
    if (clock.value().tsc && !clock_given_up_logged) {
      if (const ClockStats stats = clock_stats(); stats.given_up) {
        spdlog::error("the TSC clock is given up, stamps come from clock_gettime again: {}", stats.why_given_up);
        clock_given_up_logged = true;
      }
    }
    const auto now = Clock::now();
    systemd.ping_if_due(now);
    if (summaries && now >= next_summary) {
      spdlog::info("{}", engine.summary_line());
      next_summary += std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(options.stats_interval_s));
    }
    if (options.duration_s > 0 && now - t_start >= std::chrono::duration<double>(options.duration_s)) break;
  }
  spdlog::info("stopping ({})", stop_signal ? strsignal(stop_signal) : "duration reached");
  systemd.stopping(stop_signal ? std::string("stopping: ") + strsignal(stop_signal) : "stopping: duration reached");
  ::close(signal_fd);
  metrics.stop();
  admin.stop();
  engine.stop();
#ifdef POLYPORT_WITH_RECORDER
  recorder.stop();
#endif
  if (tracer.active()) {
    tracer.drain();
    if (tracer.lost() > 0) spdlog::warn("trace lost {} sample(s): raise --trace-depth", tracer.lost());
  }

  const nlohmann::json stats = collect_stats(engine, options, t_start);
  if (!options.quiet) print_final_stats(stats);
  if (!options.stats_json.empty()) {
    std::ofstream out(options.stats_json);
    out << stats.dump(2) << "\n";
    if (!out) {
      spdlog::error("cannot write statistics to '{}'", options.stats_json);
      return kExitRuntime;
    }
    spdlog::info("statistics written to {}", options.stats_json);
  }
  return kExitOk;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"polyportd: runs robot components of different middlewares as one application"};
  app.footer(kExitCodesHelp);
  app.set_version_flag("--version", std::string("polyportd ") + POLYPORT_VERSION);
  app.require_subcommand(1);
  Options options;
  app.add_option("--log-level", options.log_level, "trace, debug, info, warn, error, off")
      ->check(CLI::IsMember({"trace", "debug", "info", "warn", "error", "off"}))
      ->capture_default_str();
  app.add_option("-L,--library-path", options.library_path,
                 "extra folder to look for component libraries in (also POLYPORT_LIBRARY_PATH)");

  CLI::App* run = app.add_subcommand("run", "load PROFILE(s) and run until SIGINT or SIGTERM");
  run->add_option("profiles", options.profiles, "application profile(s)")->required();
  run->add_option("--stats-json", options.stats_json, "write the final statistics as JSON to FILE");
  run->add_option("--stats-interval", options.stats_interval_s, "seconds between summary lines on stderr (0: none)")
      ->capture_default_str()->check(CLI::NonNegativeNumber);
  run->add_flag("-q,--quiet", options.quiet, "no periodic summary or final statistics on stderr");
  run->add_option("--duration", options.duration_s, "stop by itself after this many seconds (0: run until signalled)")
      ->check(CLI::NonNegativeNumber);
  run->add_option("--trace", options.trace_ports, "trace an output port (Component.port) as JSON lines; repeatable");
  run->add_option("--trace-file", options.trace_file, "where --trace writes")->capture_default_str();
  run->add_option("--trace-depth", options.trace_depth, "samples buffered per traced port between drains")
      ->capture_default_str()->check(CLI::Range(1u, 1u << 20));
  run->add_option("--record", options.record_file, "record the bridged traffic as an LCM event log to FILE");
  run->add_option("--record-connection", options.record_connections,
                  "record this data connection (\"Src.port->Dst.port\"); repeatable; none: every data connection");
  run->add_option("--record-depth", options.record_depth, "samples held per recorded source between the writer's turns")
      ->capture_default_str();
  run->add_option("--admin-socket", options.admin_socket,
                  "Unix socket for polyportctl (mode 0600; default $XDG_RUNTIME_DIR/polyport/polyportd-<pid>.sock, "
                  "or /run/polyport/... without XDG_RUNTIME_DIR; 'none': no socket); see docs/CONTROL.md");
  run->add_option("--admin-group", options.admin_group,
                  "also admit members of GROUP (a name or a gid) to the admin socket (then mode 0660, owned by GROUP)");
  run->add_option("--metrics-port", options.metrics_port,
                  "serve Prometheus metrics at http://ADDRESS:PORT/metrics (0: a free port, logged and in "
                  "`polyportctl hello`); see docs/CONTROL.md")
      ->check(CLI::Range(0, 65535));
  run->add_option("--clock", options.clock,
                  "the clock of the forwarding path's stamps: system (clock_gettime), tsc (the CPU's invariant TSC "
                  "kept on CLOCK_MONOTONIC), auto (tsc where a clock_gettime is a system call); see docs/ARCHITECTURE.md")
      ->check(CLI::IsMember({"auto", "system", "tsc"}))
      ->capture_default_str();
  run->add_option("--can-io", options.can_io,
                  "how the CAN receive thread waits: io_uring (a frame forwarded CAN -> CAN goes out with the "
                  "thread's next wait, one system call for both), epoll, auto (io_uring where the kernel gives it); "
                  "see docs/ARCHITECTURE.md")
      ->check(CLI::IsMember({"auto", "io_uring", "epoll"}))
      ->capture_default_str();
  run->add_option("--metrics-address", options.metrics_address, "the address --metrics-port listens on")
      ->capture_default_str();

  CLI::App* check = app.add_subcommand("check", "validate PROFILE(s) and print the resolved graph");
  check->add_option("profiles", options.profiles, "application profile(s)")->required();
  check->add_flag("--json", options.json, "print the resolved graph as JSON");

  CLI::App* types = app.add_subcommand("types", "print what IDL, .lcm and DBC files define (layouts, fingerprints, frames)");
  types->add_option("files", options.profiles, "type files (.idl, .lcm, .dbc)")->required();
  types->add_flag("--json", options.json, "print as JSON");

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    return code == 0 ? kExitOk : kExitUsage;
  }

  auto logger = spdlog::stderr_color_mt("polyportd");
  spdlog::set_default_logger(logger);
  spdlog::set_level(spdlog::level::from_str(options.log_level));
  spdlog::set_pattern("%Y-%m-%dT%H:%M:%S.%e %^%l%$ %v");

  if (check->parsed()) return run_check(options);
  if (types->parsed()) return daemon::run_types(options.profiles, options.json);
  return run_daemon(options);
}
