// polyportctl: talks to a running polyportd through its admin socket (docs/CONTROL.md).
//
// One request, one reply: connects, sends the request line, waits (poll, with a deadline)
// for the reply line, prints it as a table (or as JSON with --json). Two commands keep the
// connection: `stats --watch` asks again every interval, `trace` reads the streamed reply
// (sample lines, then a final reply) until its count or duration is reached or Ctrl-C.
//
// Exit codes (also in --help):
//   0  done
//   1  the daemon refused the command (unknown component, property or port, a bad value, a
//      lifecycle transition or a connection not allowed)
//   2  bad command line (or several daemon sockets and no --socket)
//   3  no daemon: no socket, nobody listening, access denied, no reply
#include <errno.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <map>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <tuple>
#include <vector>

#include "admin_protocol.hpp"

namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using polyport::admin::Command;

constexpr int kExitOk = 0;
constexpr int kExitRefused = 1;
constexpr int kExitUsage = 2;
constexpr int kExitNoDaemon = 3;

constexpr const char* kExitCodesHelp =
    "Exit codes:\n"
    "  0  done\n"
    "  1  the daemon refused the command (unknown component, property or port, a bad value,\n"
    "     a transition or connection not allowed)\n"
    "  2  bad command line, or several daemon sockets and no --socket\n"
    "  3  no daemon: no socket, nobody listening, access denied, or no reply\n";

struct Failure {
  int code;
  std::string message;
};

// The one daemon socket in the default folder.
// What a reload changed, one line per kind of change (reload.hpp: GraphDiff::to_json).
void print_reload(const json& result, std::ostream& out) {
  if (result.value("unchanged", false)) {
    out << "reloaded: nothing changed\n";
    return;
  }
  out << "reloaded:\n";
  for (const char* part : {"components", "connections", "composites"}) {
    for (const char* how : {"added", "removed", "changed"}) {
      const json names = result.value(part, json::object()).value(how, json::array());
      if (names.empty()) continue;
      std::string line = std::string("  ") + part + " " + how + ":";
      line.resize(std::max<std::size_t>(line.size(), 24), ' ');
      bool first = true;
      for (const auto& name : names) {
        out << (first ? line : std::string(line.size(), ' ')) << " " << name.get<std::string>() << "\n";
        first = false;
      }
    }
  }
}

std::string find_socket() {
  const std::string dir = polyport::admin::default_socket_dir();
  std::vector<std::string> found;
  std::error_code ec;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (name.rfind("polyportd-", 0) == 0 && it->path().extension() == ".sock") found.push_back(it->path().string());
  }
  if (found.empty()) throw Failure{kExitNoDaemon, "no daemon socket in " + dir + " (is polyportd running? --socket PATH)"};
  if (found.size() > 1) {
    throw Failure{kExitUsage, std::to_string(found.size()) + " daemon sockets in " + dir + "; choose one with --socket PATH"};
  }
  return found.front();
}

// A connection to the daemon, closed when it goes.
struct Connection {
  int fd = -1;
  std::string path;
  polyport::admin::LineBuffer in{64u << 20};
  Connection() = default;
  Connection(const Connection&) = delete;
  Connection& operator=(const Connection&) = delete;
  ~Connection() {
    if (fd >= 0) ::close(fd);
  }
};

void open_connection(Connection& c, const std::string& path) {
  sockaddr_un address{};
  address.sun_family = AF_UNIX;
  if (path.size() >= sizeof address.sun_path) throw Failure{kExitUsage, "socket path too long: " + path};
  std::memcpy(address.sun_path, path.c_str(), path.size() + 1);
  c.path = path;
  c.fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  const int fd = c.fd;
  if (fd < 0) throw Failure{kExitNoDaemon, std::string("socket: ") + std::strerror(errno)};
  if (::connect(fd, reinterpret_cast<sockaddr*>(&address), sizeof address) != 0) {
    const int e = errno;
    if (e == EACCES || e == EPERM) throw Failure{kExitNoDaemon, "access denied to " + path + ": " + std::strerror(e)};
    if (e == ENOENT || e == ECONNREFUSED) throw Failure{kExitNoDaemon, "no daemon listens on " + path};
    throw Failure{kExitNoDaemon, "cannot connect to " + path + ": " + std::strerror(e)};
  }
}

void send_request(Connection& c, const std::string& request) {
  // The request is small; a refused peer may have closed already, which the reply tells.
  [[maybe_unused]] ssize_t sent = ::send(c.fd, request.data(), request.size(), MSG_NOSIGNAL);
}

// The next reply line; without `limit`, waits as long as it takes.
json next_reply(Connection& c, std::optional<std::chrono::milliseconds> limit) {
  std::string line;
  char buffer[65536];
  const auto deadline = std::chrono::steady_clock::now() + limit.value_or(std::chrono::milliseconds(0));
  for (;;) {
    if (c.in.next(line) == polyport::admin::LineBuffer::Next::line) break;
    int wait_ms = -1;
    if (limit) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
      if (left.count() <= 0) {
        throw Failure{kExitNoDaemon, "no reply from " + c.path + " within " + std::to_string(limit->count()) + " ms"};
      }
      wait_ms = static_cast<int>(left.count());
    }
    pollfd p{c.fd, POLLIN, 0};
    if (::poll(&p, 1, wait_ms) < 0 && errno != EINTR) {
      throw Failure{kExitNoDaemon, std::string("poll: ") + std::strerror(errno)};
    }
    if (p.revents == 0) continue;
    const ssize_t n = ::recv(c.fd, buffer, sizeof buffer, 0);
    if (n > 0) {
      c.in.append(buffer, static_cast<std::size_t>(n));
    } else if (n == 0 || (errno != EINTR && errno != EAGAIN)) {
      throw Failure{kExitNoDaemon, "the daemon closed the connection on " + c.path + " without a reply"};
    }
  }
  json reply = json::parse(line, nullptr, false);
  if (reply.is_discarded() || !reply.is_object()) throw Failure{kExitNoDaemon, "the reply is not JSON: " + line.substr(0, 200)};
  return reply;
}

json call(const std::string& path, const std::string& request, std::chrono::milliseconds limit) {
  Connection c;
  open_connection(c, path);
  send_request(c, request);
  return next_reply(c, limit);
}

std::string text(const json& j, const char* key) {
  auto it = j.find(key);
  if (it == j.end() || it->is_null()) return "-";
  return it->is_string() ? it->get<std::string>() : it->dump();
}

// Prints rows with every column as wide as its widest cell.
void table(std::ostream& out, const std::vector<std::vector<std::string>>& rows) {
  std::vector<std::size_t> width;
  for (const auto& r : rows) {
    width.resize(std::max(width.size(), r.size()));
    for (std::size_t i = 0; i < r.size(); ++i) width[i] = std::max(width[i], r[i].size());
  }
  for (const auto& r : rows) {
    std::string line;
    for (std::size_t i = 0; i < r.size(); ++i) {
      line += r[i];
      if (i + 1 < r.size()) line += std::string(width[i] - r[i].size() + 2, ' ');
    }
    out << line << "\n";
  }
}

void print_list(const json& g, std::ostream& out) {
  out << "application " << text(g, "application") << "\n\n";
  std::vector<std::vector<std::string>> rows{{"COMPONENT", "MODEL", "STATE"}};
  for (const auto& c : g.value("components", json::array())) rows.push_back({text(c, "name"), text(c, "model"), text(c, "state")});
  table(out, rows);
  out << "\n";
  rows = {{"PORT", "KIND", "DIRECTION", "TYPE"}};
  for (const auto& c : g.value("components", json::array())) {
    for (const auto& p : c.value("ports", json::array())) {
      rows.push_back({text(c, "name") + "." + text(p, "name"), text(p, "kind"), text(p, "direction"),
                      p.contains("type") ? text(p, "type") : text(p, "service_type")});
    }
  }
  table(out, rows);
  out << "\n";
  rows = {{"CONNECTION", "KIND", "POLICY", "MODE", "CONVERSION", "ORIGIN"}};
  for (const auto& c : g.value("connections", json::array())) {
    std::string policy = text(c, "policy");
    if (c.contains("depth")) policy += "/" + text(c, "depth");
    rows.push_back({text(c, "source") + " -> " + text(c, "target"), text(c, "kind"), policy, text(c, "mode"),
                    text(c, "conversion"), text(c, "origin")});
  }
  table(out, rows);
  // A composite's names stand for its members' ports; the connections above are those ports'.
  if (g.value("composites", json::array()).empty()) return;
  out << "\n";
  rows = {{"COMPOSITE PORT", "MEMBER PORT", "KIND", "DIRECTION"}};
  for (const auto& c : g["composites"]) {
    for (const auto& p : c.value("ports", json::array())) {
      rows.push_back({text(c, "name") + "." + text(p, "name"), text(p, "member"), text(p, "kind"), text(p, "direction")});
    }
  }
  table(out, rows);
}

void print_properties(const json& r, bool one, std::ostream& out) {
  const json properties = r.value("properties", json::array());
  if (one && properties.size() == 1) {
    out << text(properties[0], "value") << "\n";
    return;
  }
  std::vector<std::vector<std::string>> rows{{"PROPERTY", "TYPE", "VALUE", "PROFILE"}};
  for (const auto& p : properties) {
    rows.push_back({text(p, "name"), text(p, "type"), text(p, "value"), text(p, "profile_value")});
  }
  table(out, rows);
  if (!r.value("settable", false)) {
    out << "(" << text(r, "component") << " is a " << text(r, "model")
        << " component whose properties cannot be set while it runs)\n";
  }
}

void print_stats(const json& s, std::ostream& out) {
  out << "application " << text(s, "application") << ", running " << std::fixed << std::setprecision(1)
      << s.value("run_seconds", 0.0) << " s\n\n";
  std::vector<std::vector<std::string>> rows{{"COMPONENT", "MODEL", "STATE", "EXECUTIONS", "ERRORS"}};
  for (const auto& c : s.value("components", json::array())) {
    rows.push_back({text(c, "name"), text(c, "model"), text(c, "state"), text(c, "executions"), text(c, "errors")});
  }
  table(out, rows);
  out << "\n";
  rows = {{"CONNECTION", "RECEIVED", "DELIVERED", "DROPPED", "P50_NS", "P99_NS", "MAX_NS"}};
  for (const auto& c : s.value("connections", json::array())) {
    const json h = c.value("latency_ns", json::object());
    rows.push_back({text(c, "name") + (c.value("removed", false) ? " (removed)" : ""), text(c, "received"),
                    text(c, "delivered"), text(c, "dropped"), text(h, "p50"),
                    text(h, "p99"), text(h, "max")});
  }
  table(out, rows);
  if (!s.value("services", json::array()).empty()) {
    out << "\n";
    rows = {{"SERVICE", "CALLS", "OK", "TIMEOUTS", "ERRORS", "TOO_MANY", "CANCELLED"}};
    for (const auto& c : s["services"]) {
      rows.push_back({text(c, "name"), text(c, "calls"), text(c, "ok"), text(c, "timeouts"), text(c, "errors"),
                      text(c, "too_many_calls"), text(c, "cancelled")});
    }
    table(out, rows);
  }
}

// `stats --watch`: one compact table per interval over one connection, the screen cleared
// before each on a terminal; otherwise the tables follow one another (a log, or a test).
// Rates are per second of the daemon's run time between two samples.
int watch_stats(const std::string& path, double interval_s, std::chrono::milliseconds limit) {
  const bool terminal = ::isatty(STDOUT_FILENO) == 1;
  Connection c;
  open_connection(c, path);
  struct Seen {
    std::uint64_t received;
    std::uint64_t delivered;
  };
  std::map<std::string, Seen> previous;
  double previous_t = 0;
  const auto interval = std::chrono::duration_cast<std::chrono::steady_clock::duration>(std::chrono::duration<double>(interval_s));
  auto next = std::chrono::steady_clock::now();
  for (std::int64_t n = 1;; ++n) {
    json reply;
    try {
      send_request(c, polyport::admin::request_line(n, Command::stats));
      reply = next_reply(c, limit);
    } catch (const Failure& f) {
      throw Failure{kExitNoDaemon, "the daemon went away (" + f.message + ")"};
    }
    if (!reply.value("ok", false)) {
      throw Failure{reply.value("code", "") == polyport::admin::kAccessDenied ? kExitNoDaemon : kExitRefused,
                    reply.value("error", "the daemon refused the request")};
    }
    const json& s = reply["result"];
    const double t = s.value("run_seconds", 0.0);
    const double dt = t - previous_t;
    std::ostringstream out;
    out << "application " << text(s, "application") << ", running " << std::fixed << std::setprecision(1) << t
        << " s, every " << std::setprecision(1) << interval_s << " s" << (terminal ? " (Ctrl-C stops)" : "") << "\n";
    std::vector<std::vector<std::string>> rows{
        {"CONNECTION", "RECEIVED", "DELIVERED", "DROPS", "RX/S", "DLV/S", "P50_NS", "P99_NS", "MAX_NS"}};
    std::map<std::string, Seen> seen;
    for (const auto& k : s.value("connections", json::array())) {
      if (k.value("probe", false)) continue;  // trace probes are the daemon's own
      const bool removed = k.value("removed", false);
      const std::string name = text(k, "name") + (removed ? " (removed)" : "");
      const Seen now{k.value("received", std::uint64_t{0}), k.value("delivered", std::uint64_t{0})};
      seen[name] = now;
      std::string rx = "-", dlv = "-";
      if (const auto it = previous.find(name); it != previous.end() && dt > 0) {
        std::ostringstream a, b;
        a << std::fixed << std::setprecision(1) << static_cast<double>(now.received - it->second.received) / dt;
        b << std::fixed << std::setprecision(1) << static_cast<double>(now.delivered - it->second.delivered) / dt;
        rx = a.str();
        dlv = b.str();
      }
      const json h = k.value("latency_ns", json::object());
      rows.push_back({name, std::to_string(now.received), std::to_string(now.delivered), text(k, "dropped"), rx, dlv,
                      text(h, "p50"), text(h, "p99"), text(h, "max")});
    }
    table(out, rows);
    previous = std::move(seen);
    previous_t = t;
    if (terminal) std::cout << "\033[H\033[2J";
    std::cout << out.str();
    if (!terminal) std::cout << "\n";
    std::cout << std::flush;
    next += interval;
    const auto now = std::chrono::steady_clock::now();
    if (next < now) next = now;  // a slow reply: no burst to catch up
    std::this_thread::sleep_until(next);
  }
}

// `trace`: prints each sample of the streamed reply as it comes, until the final reply.
int trace(const std::string& path, const std::string& request, bool as_json) {
  Connection c;
  open_connection(c, path);
  send_request(c, request);
  for (;;) {
    json reply;
    try {
      reply = next_reply(c, std::nullopt);
    } catch (const Failure& f) {
      throw Failure{f.code, "the daemon went away (" + f.message + ")"};
    }
    if (!reply.value("ok", false)) {
      std::cerr << "polyportctl: " << reply.value("error", "the daemon refused the request") << "\n";
      return reply.value("code", "") == polyport::admin::kAccessDenied ? kExitNoDaemon : kExitRefused;
    }
    if (const auto sample = reply.find("sample"); sample != reply.end()) {
      if (as_json) {
        std::cout << sample->dump() << "\n";
      } else {
        std::cout << std::fixed << std::setprecision(6) << sample->value("t_ns", std::int64_t{0}) / 1e9 << "  "
                  << text(*sample, "port") << "  " << sample->value("value", json()).dump() << "\n";
      }
      std::cout << std::flush;
      continue;
    }
    const json& result = reply["result"];
    if (!as_json) {
      std::cerr << "polyportctl: " << text(result, "samples") << " sample(s) of " << text(result, "port") << ", "
                << text(result, "lost") << " lost (" << text(result, "end") << " reached)\n";
    }
    return kExitOk;
  }
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"polyportctl: looks into and commands a running polyportd through its admin socket"};
  app.footer(kExitCodesHelp);
  app.require_subcommand(1);
  std::string socket_path;
  bool as_json = false;
  double timeout_s = 10.0;
  polyport::admin::Request request;
  request.id = 1;
  app.add_option("--socket", socket_path,
                 "the daemon's admin socket (default: the only polyportd-*.sock in $XDG_RUNTIME_DIR/polyport, "
                 "or /run/polyport without XDG_RUNTIME_DIR)");
  app.add_flag("--json", as_json, "print the reply's result as JSON");
  app.add_option("--timeout", timeout_s, "seconds to wait for the reply")->capture_default_str()->check(CLI::PositiveNumber);
  std::vector<std::pair<CLI::App*, Command>> commands;
  commands.emplace_back(app.add_subcommand("hello", "the daemon's version, pid, application and profiles"), Command::hello);
  commands.emplace_back(app.add_subcommand("list", "components (model, state), ports, connections (policy, conversion)"),
                        Command::list);
  CLI::App* stats = app.add_subcommand("stats", "the live statistics (the JSON of polyportd run --stats-json)");
  bool watch = false;
  double interval_s = 1.0;
  stats->add_flag("--watch", watch,
                  "redraw a table of every connection's counts, rates, p50 / p99 / max each interval until Ctrl-C "
                  "(one table after another when stdout is not a terminal)");
  stats->add_option("--interval", interval_s, "seconds between two tables of --watch")
      ->capture_default_str()
      ->check(CLI::Range(0.1, 86400.0));
  commands.emplace_back(stats, Command::stats);
  for (auto [name, command, help] : {std::tuple{"activate", Command::activate, "activate COMPONENT (a composite: its members)"},
                                     std::tuple{"deactivate", Command::deactivate, "deactivate COMPONENT (a composite: its members)"},
                                     std::tuple{"reset", Command::reset, "reset COMPONENT (from its error state)"}}) {
    CLI::App* sub = app.add_subcommand(name, help);
    sub->add_option("component", request.component, "component name")->required();
    commands.emplace_back(sub, command);
  }
  CLI::App* get = app.add_subcommand("get", "a component's properties (or one of them): type, value now, profile value");
  get->add_option("component", request.component, "component name")->required();
  get->add_option("property", request.property, "property name (default: all)");
  commands.emplace_back(get, Command::get);
  CLI::App* set = app.add_subcommand("set", "change a component's property while it runs (checked against its type)");
  set->add_option("component", request.component, "component name")->required();
  set->add_option("property", request.property, "property name")->required();
  set->add_option("value", request.value, "the new value")->required();
  commands.emplace_back(set, Command::set);
  const CLI::Validator port_path(
      [](std::string& path) {
        const auto dot = path.find('.');
        return dot == std::string::npos || dot == 0 || dot + 1 == path.size()
                   ? "'" + path + "' is not a port: COMPONENT.PORT expected"
                   : std::string();
      },
      "COMPONENT.PORT");
  CLI::App* connect = app.add_subcommand("connect", "connect two data or event ports while the application runs");
  connect->add_option("source", request.source, "output port, COMPONENT.PORT")->required()->check(port_path);
  connect->add_option("target", request.target, "input port, COMPONENT.PORT")->required()->check(port_path);
  connect->add_option("--policy", request.policy, "data, buffer or circular (default: the input port's)");
  std::int64_t depth = 0;
  CLI::Option* depth_option = connect->add_option("--depth", depth, "queue depth of a buffer or circular policy");
  commands.emplace_back(connect, Command::connect);
  CLI::App* disconnect = app.add_subcommand("disconnect", "remove a data or event connection while the application runs");
  disconnect->add_option("source", request.source, "output port, COMPONENT.PORT")->required()->check(port_path);
  disconnect->add_option("target", request.target, "input port, COMPONENT.PORT")->required()->check(port_path);
  commands.emplace_back(disconnect, Command::disconnect);
  commands.emplace_back(app.add_subcommand("reload", "re-read the daemon's profiles and apply what changed (docs/CONTROL.md)"),
                        Command::reload);
  CLI::App* trace_command =
      app.add_subcommand("trace", "print an output port's samples, decoded, as they pass (until --count, --duration or Ctrl-C)");
  trace_command->add_option("port", request.port, "output data port, COMPONENT.PORT")->required()->check(port_path);
  std::int64_t count = 0;
  double duration_s = 0;
  CLI::Option* count_option =
      trace_command->add_option("--count", count, "stop after N samples")->check(CLI::Range(std::int64_t{1}, INT64_MAX));
  CLI::Option* duration_option =
      trace_command->add_option("--duration", duration_s, "stop after SEC seconds")->check(CLI::Range(0.001, 1e9));
  commands.emplace_back(trace_command, Command::trace);
  CLI::App* condition_command = app.add_subcommand(
      "condition", "switch on or off the conditions on the event connections into a client's event input");
  condition_command->add_option("port", request.port, "the client's event input port, COMPONENT.PORT")
      ->required()
      ->check(port_path);
  std::string state;
  condition_command->add_option("state", state, "on or off")->required()->check(CLI::IsMember({"on", "off"}));
  bool single = false;
  condition_command->add_flag("--single", single, "fire once, then stay off until switched on again (default: continuous)");
  std::vector<std::string> parameter_texts;
  condition_command->add_option("--param", parameter_texts, "NAME=VALUE: the threshold of the fields whose param is NAME")
      ->check(CLI::Validator(
          [](std::string& text) {
            const auto equals = text.find('=');
            char* end = nullptr;
            if (equals == std::string::npos || equals == 0) return "'" + text + "' is not NAME=VALUE";
            const std::string value = text.substr(equals + 1);
            const double number = std::strtod(value.c_str(), &end);
            return end == value.c_str() || *end != '\0' || !std::isfinite(number)
                       ? "'" + value + "' in '" + text + "' is not a finite number"
                       : std::string();
          },
          "NAME=VALUE"));
  commands.emplace_back(condition_command, Command::condition);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    return code == 0 ? kExitOk : kExitUsage;
  }
  Command command = Command::hello;
  for (const auto& [sub, c] : commands) {
    if (sub->parsed()) command = c;
  }
  request.command = command;
  if (depth_option->count() > 0) request.depth = depth;
  if (count_option->count() > 0) request.count = count;
  if (duration_option->count() > 0) request.duration_s = duration_s;
  if (command == Command::condition) {
    request.active = state == "on";
    if (!request.active && (single || !parameter_texts.empty())) {
      std::cerr << "polyportctl: --single and --param go with 'on' only\n";
      return kExitUsage;
    }
    if (request.active) request.mode = single ? "single" : "continuous";
    for (const std::string& text : parameter_texts) {
      const auto equals = text.find('=');
      request.parameters.emplace_back(text.substr(0, equals), std::strtod(text.c_str() + equals + 1, nullptr));
    }
  }
  try {
    if (socket_path.empty()) socket_path = find_socket();
    const auto limit = std::chrono::milliseconds(static_cast<long>(timeout_s * 1000));
    if (command == Command::stats && watch) return watch_stats(socket_path, interval_s, limit);
    if (command == Command::trace) return trace(socket_path, polyport::admin::request_line(request), as_json);
    const json reply = call(socket_path, polyport::admin::request_line(request), limit);
    if (!reply.value("ok", false)) {
      const std::string code = reply.value("code", "");
      std::cerr << "polyportctl: " << reply.value("error", "the daemon refused the request") << "\n";
      return code == polyport::admin::kAccessDenied ? kExitNoDaemon : kExitRefused;
    }
    const json& result = reply["result"];
    if (as_json) {
      std::cout << result.dump(2) << "\n";
      return kExitOk;
    }
    switch (command) {
      case Command::hello:
        std::cout << text(result, "daemon") << " " << text(result, "version") << ", pid " << text(result, "pid")
                  << ", protocol " << text(result, "protocol") << "\napplication " << text(result, "application")
                  << "\nprofiles:";
        for (const auto& p : result.value("profiles", json::array())) std::cout << " " << p.get<std::string>();
        std::cout << "\n";
        break;
      case Command::list:
        print_list(result, std::cout);
        break;
      case Command::stats:
        print_stats(result, std::cout);
        break;
      case Command::get:
        print_properties(result, !request.property.empty(), std::cout);
        break;
      case Command::set:
        std::cout << text(result, "component") << "." << text(result, "property") << " = " << text(result, "value")
                  << " (was " << text(result, "previous") << ")\n";
        break;
      case Command::connect: {
        std::string policy = text(result, "policy");
        if (result.contains("depth")) policy += "/" + text(result, "depth");
        std::cout << "connected " << text(result, "source") << " -> " << text(result, "target") << " (" << policy
                  << ", " << text(result, "conversion") << ")\n";
        break;
      }
      case Command::disconnect:
        std::cout << "disconnected " << text(result, "source") << " -> " << text(result, "target") << "\n";
        break;
      case Command::condition:
        for (const auto& c : result.value("conditions", json::array())) {
          std::cout << text(c, "connection") << ": " << (result.value("active", false) ? text(result, "mode") : "off");
          for (const auto& f : c.value("fields", json::array())) {
            std::cout << (result.value("active", false) ? ", " : ", when on: ") << text(f, "field") << " "
                      << text(f, "op") << " " << f.value("value", 0.0);  // as check writes it: 2, 1e+09
          }
          std::cout << "\n";
        }
        break;
      case Command::reload:
        print_reload(result, std::cout);
        break;
      default:
        if (result.contains("composite")) {  // a composite's members, in the order they were told
          std::cout << text(result, "composite") << ":";
          for (const auto& m : result.value("members", json::array())) {
            std::cout << " " << text(m, "component") << " " << text(m, "state");
            if (text(m, "outcome") != "done") std::cout << " (" << text(m, "outcome") << ")";
            std::cout << ";";
          }
          std::cout << "\n";
          break;
        }
        std::cout << text(result, "component") << ": " << text(result, "state") << "\n";
    }
    return kExitOk;
  } catch (const Failure& f) {
    std::cerr << "polyportctl: " << f.message << "\n";
    return f.code;
  }
}
