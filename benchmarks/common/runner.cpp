// The ping-pong runners' shared machinery (runner.hpp).
#include "runner.hpp"

#include <fcntl.h>
#include <poll.h>
#include <sched.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/syscall.h>
#include <sys/utsname.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <fstream>
#include <sstream>
#include <thread>

namespace bench {

namespace {

// The live children, for the signal handler (which may only kill()). Slots are written by the
// main thread alone; 0 = free.
std::array<std::atomic<pid_t>, 8> g_children{};
volatile std::sig_atomic_t g_interrupted = 0;

extern "C" void on_stop_signal(int) {
  g_interrupted = 1;
  for (auto& child : g_children) {
    const pid_t pid = child.load();
    if (pid > 0) kill(pid, SIGTERM);
  }
}

std::string cpu_model() {
  std::ifstream in("/proc/cpuinfo");
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("model name", 0) == 0) {
      const auto colon = line.find(':');
      return colon == std::string::npos ? line : line.substr(colon + 2);
    }
  }
  return "unknown";
}

// One ping process of `rounds` round trips; its samples are appended to the path's series,
// and the CPU time it and the watched processes spent on them.
void run_chunk(Path& path, int rounds, int warmup, const Placement& placement, const fs::path& dir,
               const std::string& tag) {
  Series& series = path.series;
  if (!series.error.empty()) return;
  const fs::path samples = dir / (tag + ".samples");
  const fs::path out = dir / (tag + ".out");
  std::string pids;
  for (const Watched& w : path.watched) pids += (pids.empty() ? "" : ",") + std::to_string(w.pid);
  setenv("POLYPORT_BENCH_CPU_PIDS", pids.c_str(), 1);  // read by the ping (pingpong_common.hpp)
  std::vector<std::string> args = path.ping;
  args.insert(args.end(), {std::to_string(rounds), std::to_string(warmup), samples.string()});
  const pid_t ping = spawn(args, out, placement);
  // 30 s to match, then at most a second per lost echo: generous, and only a bound on a hang.
  const int rc = finish(ping, 0, 60 + rounds / 100);
  if (rc != 0) {
    series.error = tag + ": ping exited with " + std::to_string(rc) + ": " + read_file(out.string() + ".err");
    return;
  }
  const Json line = Json::parse(read_file(out), nullptr, false);
  if (line.is_discarded() || !line.contains("one_way_ns")) {
    series.error = tag + ": unreadable ping output";
    return;
  }
  series.lost += line.value("lost", 0);
  series.chunk_p50_one_way.push_back(line["one_way_ns"].value("p50", std::int64_t{0}));
  if (series.cpu_roles.empty()) {
    series.cpu_roles.push_back("ping");
    for (const Watched& w : path.watched) series.cpu_roles.push_back(w.role);
    series.cpu_ns.assign(series.cpu_roles.size(), 0);
  }
  const Json cpu = line.value("cpu_ns", Json::array());
  for (std::size_t i = 0; i < series.cpu_ns.size(); ++i) {
    const std::int64_t spent = i < cpu.size() && cpu[i].is_number_integer() ? cpu[i].get<std::int64_t>() : -1;
    series.cpu_ns[i] = spent < 0 || series.cpu_ns[i] < 0 ? -1 : series.cpu_ns[i] + spent;
  }
  std::ifstream in(samples);
  for (std::int64_t rtt = 0, write = 0; in >> rtt >> write;) {
    series.rtt.push_back(rtt);
    series.write.push_back(write);
  }
}

// polyportd run's further arguments for an A/B run (POLYPORT_BENCH_DAEMON_ARGS, split at
// spaces; e.g. "--can-io epoll"); recorded in every result's header.
std::vector<std::string> daemon_extra_args() {
  std::vector<std::string> out;
  const char* given = std::getenv("POLYPORT_BENCH_DAEMON_ARGS");
  std::istringstream words(given != nullptr ? given : "");
  for (std::string word; words >> word;) out.push_back(word);
  return out;
}

}  // namespace

void forward_stop_signals() {
  struct sigaction action {};
  action.sa_handler = on_stop_signal;
  sigemptyset(&action.sa_mask);
  for (int sig : {SIGINT, SIGTERM, SIGHUP}) sigaction(sig, &action, nullptr);
}

bool interrupted() { return g_interrupted != 0; }

pid_t spawn(const std::vector<std::string>& args, const fs::path& out, const Placement& placement) {
  const pid_t parent = getpid();
  const pid_t pid = fork();
  if (pid < 0) return -1;
  if (pid == 0) {
    // SIGTERM rather than SIGKILL: the programs then close their endpoints (Fast DDS removes
    // its shared-memory segments).
    prctl(PR_SET_PDEATHSIG, SIGTERM);
    if (getppid() != parent) _exit(127);  // the runner died before prctl took effect
    if (placement.cpu >= 0) {
      cpu_set_t set;
      CPU_ZERO(&set);
      CPU_SET(placement.cpu, &set);
      if (sched_setaffinity(0, sizeof set, &set) != 0) _exit(126);
    }
    const int fd_out = open(out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    const int fd_err = open((out.string() + ".err").c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (fd_out < 0 || fd_err < 0 || dup2(fd_out, 1) < 0 || dup2(fd_err, 2) < 0) _exit(125);
    std::vector<char*> argv;
    for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    execv(argv[0], argv.data());
    _exit(124);
  }
  for (auto& child : g_children) {
    pid_t free_slot = 0;
    if (child.compare_exchange_strong(free_slot, pid)) break;
  }
  return pid;
}

// Waits on a pidfd, so the runner does not wake up while the child runs (on the one-core
// placement it shares the core).
int finish(pid_t pid, int signal_number, int seconds) {
  if (pid <= 0) return -1;
  if (signal_number != 0) kill(pid, signal_number);
  const int pidfd = static_cast<int>(syscall(SYS_pidfd_open, pid, 0));
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(seconds);
  int status = 0;
  bool exited = false;
  while (!exited) {
    if (waitpid(pid, &status, WNOHANG) == pid) {
      exited = true;
      break;
    }
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    if (left.count() <= 0) break;
    if (pidfd >= 0) {
      pollfd p{pidfd, POLLIN, 0};
      poll(&p, 1, static_cast<int>(std::min<std::int64_t>(left.count(), 1000)));  // EINTR: look again
    } else {
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
  }
  if (pidfd >= 0) close(pidfd);
  if (!exited) {
    kill(pid, SIGKILL);
    waitpid(pid, &status, 0);
  }
  for (auto& child : g_children) {
    pid_t mine = pid;
    child.compare_exchange_strong(mine, 0);
  }
  if (!exited) return -1;
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

std::string read_file(const fs::path& file) {
  std::ifstream in(file);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

Json summary(std::vector<std::int64_t> v) {
  if (v.empty()) return Json::object();
  std::sort(v.begin(), v.end());
  auto at = [&](double q) { return v[std::min(v.size() - 1, static_cast<std::size_t>(q * static_cast<double>(v.size())))]; };
  double sum = 0;
  for (std::int64_t x : v) sum += static_cast<double>(x);
  Json histogram = Json::array();
  std::size_t i = 0;
  for (std::int64_t decade = 1000; decade <= 100'000'000; decade *= 10) {
    for (std::int64_t step : {1, 2, 5}) {
      const std::int64_t edge = decade * step;
      std::size_t n = 0;
      while (i < v.size() && v[i] <= edge) ++i, ++n;
      histogram.push_back({{"le_ns", edge}, {"count", n}});
    }
  }
  histogram.push_back({{"le_ns", nullptr}, {"count", v.size() - i}});
  return {{"n", v.size()},       {"min", v.front()},   {"mean", sum / static_cast<double>(v.size())},
          {"p50", at(0.5)},      {"p90", at(0.9)},     {"p99", at(0.99)},
          {"p999", at(0.999)},   {"max", v.back()},    {"histogram", histogram}};
}

Json Series::to_json(int chunks) const {
  Json j{{"chunks", chunks}, {"lost", lost}};
  if (!error.empty()) j["error"] = error;
  if (rtt.empty()) return j;
  std::vector<std::int64_t> one_way;
  for (std::int64_t r : rtt) one_way.push_back(r / 2);
  j["rtt_ns"] = summary(rtt);
  j["one_way_ns"] = summary(one_way);
  j["one_way_p50_per_chunk_ns"] = chunk_p50_one_way;
  j["ping_write_ns"] = summary(write);
  j["ping_write_ns"].erase("histogram");
  Json cpu = Json::object();
  std::int64_t all = 0;
  for (std::size_t i = 0; i < cpu_roles.size() && i < cpu_ns.size(); ++i) {
    if (cpu_ns[i] < 0 || all < 0) {
      all = -1;
      continue;
    }
    cpu[cpu_roles[i]] = cpu_ns[i] / static_cast<std::int64_t>(rtt.size());
    all += cpu_ns[i];
  }
  if (all >= 0 && !cpu.empty()) cpu["all"] = all / static_cast<std::int64_t>(rtt.size());
  j["cpu_per_round_trip_ns"] = cpu;
  return j;
}

void run_interleaved(const Chunking& chunking, const Placement& placement, const fs::path& dir,
                     std::vector<Path>& paths) {
  const int n = static_cast<int>(paths.size());
  for (int k = 0; k < chunking.chunks && !interrupted(); ++k) {
    // Taking turns at going first keeps any warming of the machine off one of the series.
    for (int j = 0; j < n && !interrupted(); ++j) {
      Path& path = paths[static_cast<std::size_t>((k + j) % n)];
      run_chunk(path, chunking.per_chunk(), chunking.warmup, placement, dir, path.tag + "-" + std::to_string(k));
    }
  }
}

CaseCommands five_domain_commands(const std::string& program, int first, int size) {
  const auto d = [&](int k) { return std::to_string(first + k); };
  const std::string sz = std::to_string(size);
  CaseCommands commands;
  commands.direct_ping = {program, "ping", d(0), sz};
  commands.direct_pong = {program, "pong", d(0), sz};
  commands.via_ping = {program, "ping", d(1), sz};
  commands.via_pong = {program, "pong", d(2), sz};
  commands.relay_ping = {program, "ping", d(3), sz};
  commands.relay_pong = {program, "pong", d(4), sz};
  commands.relay = {program, "relay", d(3), d(4), sz};
  return commands;
}

Json five_domains_json(int first) {
  return {{"direct", first}, {"via_ping", first + 1}, {"via_pong", first + 2}, {"relay_ping", first + 3},
          {"relay_pong", first + 4}};
}

fs::path write_pingpong_app(const fs::path& dir, const std::string& name, const std::string& types_file,
                            const std::string& ping_side, const std::string& pong_side, const std::string& ping_port,
                            const std::string& pong_port) {
  return write_pingpong_app(dir, name, std::vector<std::string>{types_file}, ping_side, pong_side, ping_port, pong_port,
                            "");
}

fs::path write_pingpong_app(const fs::path& dir, const std::string& name, const std::vector<std::string>& types_files,
                            const std::string& ping_side, const std::string& pong_side, const std::string& ping_port,
                            const std::string& pong_port, const std::string& mapping) {
  std::ofstream(dir / "PingSide.xml") << ping_side;
  std::ofstream(dir / "PongSide.xml") << pong_side;
  const auto connection = [&](const char* from, const char* to, const std::string& port) {
    return std::string(R"(    <port_connection port_type="data"><source component_name=")") + from + R"(" port_name=")" +
           port + R"("/><target component_name=")" + to + R"(" port_name=")" + port + "\"/>" + mapping +
           "</port_connection>\n";
  };
  std::string files;
  for (const std::string& file : types_files) files += "<file>" + file + "</file>";
  std::ofstream(dir / "app.xml") << R"(<?xml version="1.0" encoding="UTF-8"?>
<application_profile>
  <name>)" << name << R"(</name>
  <types>)" << files << R"(</types>
  <subcomponents>
    <subcomponent><name>a</name><reference>PingSide.xml</reference></subcomponent>
    <subcomponent><name>b</name><reference>PongSide.xml</reference></subcomponent>
  </subcomponents>
  <port_connections>
)" << connection("a", "b", ping_port) << connection("b", "a", pong_port) << R"(  </port_connections>
</application_profile>
)";
  return dir / "app.xml";
}

std::string pingpong_component(const std::string& name, const std::string& model, const std::string& section,
                               const std::string& type, const std::string& wire, const std::string& app_publishes,
                               const std::string& polyport_publishes) {
  const auto data_port = [&](const std::string& on, const char* usage) {
    std::string port = on;
    std::transform(port.begin(), port.end(), port.begin(), [](unsigned char c) { return std::tolower(c); });
    return "    <data_port><name>" + port + "</name><data_type>" + type + "</data_type><usage>" + usage + "</usage><" +
           wire + ">" + on + "</" + wire + "></data_port>\n";
  };
  return "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<component_profile>\n  <name>" + name + "</name>\n  <model>" +
         model + "</model>\n  " + section + "\n  <ports>\n" + data_port(app_publishes, "output") +
         data_port(polyport_publishes, "input") + "  </ports>\n</component_profile>\n";
}

bool private_network(const std::string& group) {
  if (unshare(CLONE_NEWNET) != 0) {
    std::fprintf(stderr,
                 "a private network namespace needs root (CAP_SYS_ADMIN): %s\n"
                 "run as root, or give %s a route yourself and pass --host-network:\n"
                 "  ip link set lo multicast on && ip route add %s dev lo\n",
                 std::strerror(errno), group.c_str(), group.c_str());
    return false;
  }
  const std::string setup = "ip link set lo up && ip link set lo multicast on && ip route add " + group + " dev lo";
  if (std::system(setup.c_str()) != 0) {
    std::fprintf(stderr, "cannot give loopback a multicast route (%s)\n", setup.c_str());
    return false;
  }
  return true;
}

std::optional<std::int64_t> run_case(const Chunking& chunking, const Placement& placement, const fs::path& dir,
                                     const CaseCommands& commands, Json& c) {
  const fs::path stats_file = dir / "polyport-stats.json";
  const bool direct = !commands.direct_ping.empty();
  const pid_t direct_pong = direct ? spawn(commands.direct_pong, dir / "pong-direct.out", placement) : -1;
  const pid_t via_pong = spawn(commands.via_pong, dir / "pong-via.out", placement);
  const pid_t relay_pong = spawn(commands.relay_pong, dir / "pong-relay.out", placement);
  std::vector<std::string> daemon_args{POLYPORTD, "run", commands.app.string(), "-q", "--stats-json", stats_file.string()};
  for (const std::string& arg : daemon_extra_args()) daemon_args.push_back(arg);
  const pid_t daemon = spawn(daemon_args, dir / "polyportd.out", placement);
  const pid_t relay = spawn(commands.relay, dir / "relay.out", placement);

  std::vector<Path> paths{{"via", commands.via_ping, {{"polyportd", daemon}, {"pong", via_pong}}, {}},
                          {"relay", commands.relay_ping, {{"relay", relay}, {"pong", relay_pong}}, {}}};
  if (direct) paths.insert(paths.begin(), Path{"direct", commands.direct_ping, {{"pong", direct_pong}}, {}});
  run_interleaved(chunking, placement, dir, paths);
  for (pid_t pid : {direct_pong, via_pong, relay_pong, relay}) finish(pid, SIGTERM, 10);
  const int daemon_rc = finish(daemon, SIGINT, 20);
  if (interrupted()) return std::nullopt;

  const std::size_t via = direct ? 1 : 0;
  if (direct) c["direct"] = paths[0].series.to_json(chunking.chunks);
  c["via_polyport"] = paths[via].series.to_json(chunking.chunks);
  c["via_native_relay"] = paths[via + 1].series.to_json(chunking.chunks);
  return read_polyport_stats(stats_file, daemon_rc, dir / "polyportd.out.err", c);
}

std::int64_t read_polyport_stats(const fs::path& stats_file, int daemon_rc, const fs::path& daemon_err, Json& c) {
  const Json stats = Json::parse(read_file(stats_file), nullptr, false);
  if (daemon_rc != 0 || stats.is_discarded() || !stats.contains("connections")) {
    c["polyport_error"] = "polyportd exited with " + std::to_string(daemon_rc) + ": " + read_file(daemon_err);
    return -1;
  }
  Json own = Json::array();
  std::int64_t worst_p99 = 0;
  for (const Json& connection : stats["connections"]) {
    own.push_back({{"connection", connection["name"]},
                   {"received", connection["received"]},
                   {"delivered", connection["delivered"]},
                   {"dropped", connection["dropped"]},
                   {"conversion", connection["conversion"]},
                   {"in_to_out_ns", connection["latency_ns"]},
                   {"sdk_write_ns", connection.value("sink_ns", Json::object())}});
    worst_p99 = std::max(worst_p99, connection["latency_ns"].value("p99", std::int64_t{0}));
  }
  c["polyport"] = own;
  c["polyport_version"] = stats.value("polyport_version", "");
  return worst_p99;
}

Json paired_chunks(const Json& via, const Json& relay, std::int64_t allowance_ns) {
  const Json v = via.value("one_way_p50_per_chunk_ns", Json::array());
  const Json r = relay.value("one_way_p50_per_chunk_ns", Json::array());
  if (v.empty() || v.size() != r.size()) return nullptr;
  std::vector<std::int64_t> d;
  for (std::size_t i = 0; i < v.size(); ++i) d.push_back(v[i].get<std::int64_t>() - r[i].get<std::int64_t>());
  std::sort(d.begin(), d.end());
  const int n = static_cast<int>(d.size());
  // P(Bin(n, 1/2) <= j) for j = 0, 1, ...: the sign test's tail.
  std::vector<double> tail;
  double term = std::pow(0.5, n);  // P(X = 0)
  double sum = 0;
  for (int j = 0; j <= n; ++j) {
    sum += term;
    tail.push_back(sum);
    term = term * (n - j) / (j + 1);
  }
  int k = 1;
  while (k + 1 <= (n + 1) / 2 && 2 * tail[static_cast<std::size_t>(k)] <= 0.05) ++k;
  const std::int64_t low = d[static_cast<std::size_t>(k - 1)];
  const std::int64_t high = d[static_cast<std::size_t>(n - k)];
  const std::int64_t median = n % 2 == 1 ? d[static_cast<std::size_t>(n / 2)]
                                         : (d[static_cast<std::size_t>(n / 2 - 1)] + d[static_cast<std::size_t>(n / 2)]) / 2;
  const char* verdict = high <= allowance_ns ? "holds" : low > allowance_ns ? "misses" : "undecided";
  return {{"chunks", n},
          {"via_minus_relay_p50_ns", median},
          {"interval_ns", {low, high}},
          {"confidence", 1 - 2 * tail[static_cast<std::size_t>(k - 1)]},
          {"allowance_ns", allowance_ns},
          {"verdict", verdict}};
}

Json relay_targets(const Json& c, std::int64_t worst_in_to_out_p99) {
  const auto has = [&](const char* series) { return c.contains(series) && c[series].contains("one_way_ns"); };
  if (!has("via_polyport") || !has("via_native_relay") || worst_in_to_out_p99 < 0) return nullptr;
  const std::int64_t v50 = c["via_polyport"]["one_way_ns"]["p50"].get<std::int64_t>();
  const std::int64_t r50 = c["via_native_relay"]["one_way_ns"]["p50"].get<std::int64_t>();
  const std::int64_t bound = r50 + 2000;
  Json t{{"via_one_way_p50_ns", v50},
         {"relay_one_way_p50_ns", r50},
         {"bound_relay_plus_2us_ns", bound},
         {"via_within_relay_plus_2us", v50 <= bound},
         {"via_margin_ns", bound - v50},  // < 0: by how much the bound is missed
         {"via_minus_relay_paired_chunks", paired_chunks(c["via_polyport"], c["via_native_relay"], 2000)},
         {"polyport_in_to_out_p99_ns", worst_in_to_out_p99},
         {"in_to_out_p99_within_1us", worst_in_to_out_p99 <= 1000}};
  if (has("direct")) t["direct_one_way_p50_ns"] = c["direct"]["one_way_ns"]["p50"];
  const Json daemon_cpu = c["via_polyport"].value("cpu_per_round_trip_ns", Json::object()).value("polyportd", Json());
  const Json relay_cpu = c["via_native_relay"].value("cpu_per_round_trip_ns", Json::object()).value("relay", Json());
  if (daemon_cpu.is_number() && relay_cpu.is_number()) {
    t["polyportd_cpu_per_round_trip_ns"] = daemon_cpu;
    t["relay_cpu_per_round_trip_ns"] = relay_cpu;
    t["polyportd_cpu_within_relay"] = daemon_cpu.get<std::int64_t>() <= relay_cpu.get<std::int64_t>();
  } else {
    t["polyportd_cpu_within_relay"] = nullptr;  // a CPU-time clock could not be read
  }
  return t;
}

bool RunOptions::take(int argc, char** argv, int& i) {
  const std::string arg = argv[i];
  if (arg.rfind("--", 0) != 0) {
    positional.push_back(arg);
    return true;
  }
  if (i + 1 >= argc) return false;
  const char* value = argv[i + 1];
  if (arg == "--chunks") {
    chunking.chunks = std::atoi(value);
  } else if (arg == "--placements") {
    placements = split(value);
  } else if (arg == "--cpu") {
    cpu = std::atoi(value);
  } else if (arg == "--keep") {
    keep = value;
  } else {
    return false;
  }
  ++i;
  return true;
}

bool RunOptions::finish() {
  if (positional.empty() || positional.size() > 3) return false;
  output = positional[0];
  if (positional.size() > 1) chunking.rounds = std::atoi(positional[1].c_str());
  if (positional.size() > 2) chunking.warmup = std::atoi(positional[2].c_str());
  return chunking.rounds >= 1 && chunking.warmup >= 0 && chunking.chunks >= 1 && chunking.chunks <= chunking.rounds &&
         cpu >= 0 && all_known(placements, {"unpinned", "one-core"});
}

double load_average() {
  double load[3] = {0, 0, 0};
  return getloadavg(load, 3) > 0 ? load[0] : -1;
}

std::vector<std::string> split(const std::string& list) {
  std::vector<std::string> out;
  std::stringstream in(list);
  for (std::string item; std::getline(in, item, ',');) {
    if (!item.empty()) out.push_back(item);
  }
  return out;
}

bool all_known(const std::vector<std::string>& got, std::initializer_list<const char*> allowed) {
  return std::all_of(got.begin(), got.end(), [&](const std::string& g) {
    return std::any_of(allowed.begin(), allowed.end(), [&](const char* a) { return g == a; });
  });
}

std::string utc_now() {
  const std::time_t t = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char text[32];
  std::strftime(text, sizeof text, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return text;
}

std::string ns_to_us(const Json& v) {
  if (!v.is_number()) return "-";
  char text[32];
  std::snprintf(text, sizeof text, "%.1f", v.get<double>() / 1000.0);
  return text;
}

Json result_header(const std::string& benchmark) {
  utsname host{};
  uname(&host);
  double load[3] = {0, 0, 0};
  getloadavg(load, 3);
  const char* revision = std::getenv("POLYPORT_GIT_REVISION");
  Json header{{"benchmark", benchmark},
              {"started_utc", utc_now()},
              {"git_revision", revision != nullptr ? revision : "unknown"},
              {"host", {{"nproc", std::thread::hardware_concurrency()},
                        {"cpu", cpu_model()},
                        {"uname", std::string(host.sysname) + " " + host.release + " " + host.version + " " + host.machine},
                        {"loadavg_at_start", {load[0], load[1], load[2]}}}}};
  // In a guest (the vcan guest), the machine that runs it, as scripts/bench_pingpong.sh saw it.
  if (const char* outer = std::getenv("POLYPORT_BENCH_OUTER_HOST")) header["host"]["outer_host_at_start"] = outer;
  header["polyportd_extra_args"] = daemon_extra_args();
  return header;
}

Json shared_settings(const RunOptions& run) {
  const Chunking& chunking = run.chunking;
  return {{"placements", run.placements},
          {"one_core_cpu", run.cpu},
          {"round_trips", chunking.rounds},
          {"warmup_per_chunk", chunking.warmup},
          {"chunks", chunking.chunks},
          {"round_trips_per_chunk", chunking.per_chunk()},
          {"one_way", "round trip / 2, CLOCK_MONOTONIC in the ping process"},
          {"polyport_histograms", "every sample polyportd forwarded in the case, warm-ups included"},
          {"cpu_per_round_trip_ns",
           "CPU time per measured round trip of each process of the path (ping, polyportd or "
           "relay, pong; all = their sum), from their CPU-time clocks read by the ping before "
           "and after its measured round trips; on one core a round trip cannot cost less than "
           "'all'"}};
}

void print_case(const Json& c, const std::string& label, const std::string& verdicts) {
  const auto figure = [&](const char* series, const char* q) {
    return ns_to_us(c.value(series, Json::object()).value("one_way_ns", Json::object()).value(q, Json()));
  };
  const auto cpu = [&](const char* series) {
    return ns_to_us(c.value(series, Json::object()).value("cpu_per_round_trip_ns", Json::object()).value("all", Json()));
  };
  std::string own;
  for (const Json& p : c.value("polyport", Json::array())) {
    own += " " + std::to_string(p["in_to_out_ns"].value("p50", 0)) + "/" + std::to_string(p["in_to_out_ns"].value("p99", 0));
  }
  std::fprintf(stderr,
               "%-9s %-10s %5d B  direct %6s/%6s  via polyport %6s/%6s  via relay %6s/%6s us  %s  "
               "in-to-out p50/p99 ns:%s  cpu per round trip us: %s %s %s\n",
               c.value("placement", "").c_str(), label.c_str(), c.value("size_bytes", 0), figure("direct", "p50").c_str(),
               figure("direct", "p99").c_str(), figure("via_polyport", "p50").c_str(), figure("via_polyport", "p99").c_str(),
               figure("via_native_relay", "p50").c_str(), figure("via_native_relay", "p99").c_str(), verdicts.c_str(),
               own.c_str(), cpu("direct").c_str(), cpu("via_polyport").c_str(), cpu("via_native_relay").c_str());
}

std::string relay_verdicts(const Json& c) {
  const Json t = c.value("targets", Json::object());
  if (t.empty()) return "targets n/a";
  const auto verdict = [&](const char* key) {
    return t[key].is_boolean() ? (t[key].get<bool>() ? "ok" : "MISS") : "n/a";
  };
  std::string paired;
  if (const Json p = t.value("via_minus_relay_paired_chunks", Json()); p.is_object()) {
    char text[96];
    std::snprintf(text, sizeof text, " (chunks paired: %+.1f us, [%+.1f, %+.1f] at %.0f %%: %s)",
                  p["via_minus_relay_p50_ns"].get<double>() / 1000, p["interval_ns"][0].get<double>() / 1000,
                  p["interval_ns"][1].get<double>() / 1000, 100 * p["confidence"].get<double>(),
                  p["verdict"].get<std::string>().c_str());
    paired = text;
  }
  return std::string("via <= relay + 2 us ") + verdict("via_within_relay_plus_2us") + paired + "  in-to-out p99 <= 1 us " +
         verdict("in_to_out_p99_within_1us") + "  cpu <= relay " + verdict("polyportd_cpu_within_relay");
}

fs::path work_dir(const std::string& keep, const std::string& benchmark) {
  const std::string name = "polyport-bench-" + benchmark + "-" + std::to_string(getpid());
  const fs::path dir = keep.empty() ? fs::temp_directory_path() / name : fs::path(keep);
  fs::create_directories(dir);
  return dir;
}

int end_run(Json& result, const std::string& output, const fs::path& dir, bool keep, bool all_cases_have_targets,
            std::chrono::steady_clock::time_point started) {
  const auto clean = [&] {
    if (!keep) fs::remove_all(dir);
  };
  if (interrupted()) {
    std::fprintf(stderr, "interrupted: no result written\n");
    clean();
    return 130;
  }
  double load[3] = {0, 0, 0};
  getloadavg(load, 3);
  result["host"]["loadavg_at_end"] = {load[0], load[1], load[2]};
  result["duration_s"] = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  std::ofstream out(output);
  out << result.dump(2) << "\n";
  out.close();
  clean();
  if (!out) {
    std::fprintf(stderr, "cannot write %s\n", output.c_str());
    return 1;
  }
  std::fprintf(stderr, "results: %s\n", output.c_str());
  return all_cases_have_targets ? 0 : 1;
}

}  // namespace bench
