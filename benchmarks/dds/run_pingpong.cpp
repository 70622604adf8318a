// The DDS latency benchmark: for each placement, vendor and sample size, one-way latency
// (round trip / 2) between two ping-pong processes, first on one domain (direct), then on two
// domains joined by polyportd (ping A -> polyport -> B pong -> polyport -> A), plus polyport's
// own in-to-out time from its connection histograms (receive callback to the call of the other
// SDK's write; that write itself is reported apart as sdk_write_ns). A third series joins two
// domains with the vendor's own `relay` program instead of polyportd (the SDK's generated
// types, forwarding from listeners): the same four native hops without polyport, so that what
// a path through polyport costs beyond the hops can be told apart. One run, one machine;
// writes one JSON file. Nothing here asserts: the targets are computed and reported.
//
//   bench_dds_pingpong OUTPUT.json [ROUNDS [WARMUP]] [options]      (scripts/bench_dds.sh)
//     --chunks N         the measured round trips of a series are split over N ping processes,
//                        the three series taking turns (default 6): the machine is shared,
//                        and a change of its load during a case then falls on all three
//                        alike instead of on whichever ran last. Every chunk has its
//                        own warm-up of WARMUP round trips; percentiles are taken over the
//                        pooled samples of all chunks.
//     --placements LIST  unpinned,one-core (default: both). one-core pins every process of a
//                        case (pings, pongs, polyportd, relay) to --cpu: on a VM whose idle
//                        vCPUs halt, waking the other core can dominate a hop (tens of us,
//                        whenever the scheduler puts the woken thread there), and one core
//                        measures the software without that artifact.
//     --cpu N            the core of the one-core placement (default 0)
//     --vendors LIST     cyclonedds,fastdds (default: both)
//     --sizes LIST       16,1024 (default: both)
//     --domain-base N    first DDS domain used; each vendor x size takes 5 (default 170)
//     --fastdds-data-sharing auto|off
//                        Fast DDS data sharing between the ping and pong programs (default
//                        auto, Fast DDS's default; polyport's side of a hop never has it, its
//                        raw endpoints switch it off): off shows what a direct hop costs
//                        without it
//     --keep DIR         keep the generated profiles, raw samples, logs and polyport's
//                        statistics in DIR (default: a temporary directory, removed)
//
// Threads: one. Children (ping, pong, relay, polyportd) are fork/exec'd with PR_SET_PDEATHSIG, so
// none outlives the runner even when it is killed outright; SIGINT, SIGTERM and SIGHUP to the
// runner are forwarded to the live children and end the run without writing a result.
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
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;

// ---- children -----------------------------------------------------------------------------

// The live children, for the signal handler (which may only kill()). Slots are written by the
// main thread alone; 0 = free.
std::array<std::atomic<pid_t>, 8> g_children{};
volatile std::sig_atomic_t g_interrupted = 0;

extern "C" void on_signal(int) {
  g_interrupted = 1;
  for (auto& child : g_children) {
    const pid_t pid = child.load();
    if (pid > 0) kill(pid, SIGTERM);
  }
}

bool interrupted() { return g_interrupted != 0; }

struct Placement {
  std::string name;
  int cpu = -1;  // -1: unpinned
};

// Starts `args` with stdout in `out` and stderr in `out`.err; -1 when it could not start.
pid_t spawn(const std::vector<std::string>& args, const fs::path& out, const Placement& placement) {
  const pid_t parent = getpid();
  const pid_t pid = fork();
  if (pid < 0) return -1;
  if (pid == 0) {
    // SIGTERM rather than SIGKILL: the programs then close their participants, and Fast DDS
    // removes its shared-memory segments.
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

// Sends `signal_number` (0: none), waits at most `seconds` for the exit, then kills. Returns the
// exit code, -1 when killed by a signal or when it had to be killed. Waits on a pidfd, so the
// runner does not wake up while the child runs (on the one-core placement it shares the core).
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

// ---- statistics ---------------------------------------------------------------------------


// Percentiles as the ping programs take them (pingpong_common.hpp), so their lines and these
// pooled figures agree; mean and a 1-2-5 histogram for the plot-minded.
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

// One series (direct or via polyport) of a case: the pooled round trips of its chunks.
struct Series {
  std::vector<std::int64_t> rtt;
  std::vector<std::int64_t> write;  // the ping's write call of each round trip
  std::vector<std::int64_t> chunk_p50_one_way;
  int lost = 0;
  std::string error;
  // CPU time of the measured round trips, per process of the path (cpu_roles: "ping", then
  // the processes run_chunk watched), summed over chunks; -1 once any chunk could not read it.
  std::vector<std::string> cpu_roles;
  std::vector<std::int64_t> cpu_ns;

  Json to_json(int chunks) const {
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
};

// ---- profiles -----------------------------------------------------------------------------

// A DDS component profile of `model` on `domain`: `app_publishes` is a topic the application
// publishes (polyport reads it), `polyport_publishes` one polyport writes. No <config>: the
// model's default, the shipped loopback configuration, which the peers are given too.
std::string component(const std::string& name, const std::string& model, int domain, const std::string& type,
                      const std::string& app_publishes, const std::string& polyport_publishes) {
  return R"(<?xml version="1.0" encoding="UTF-8"?>
<component_profile>
  <name>)" + name + "</name>\n  <model>" + model + "</model>\n  <dds><domain>" + std::to_string(domain) +
         R"(</domain></dds>
  <ports>
    <data_port><name>)" + app_publishes + "</name><data_type>" + type + "</data_type><usage>output</usage><topic>" +
         app_publishes + R"(</topic></data_port>
    <data_port><name>)" + polyport_publishes + "</name><data_type>" + type +
         "</data_type><usage>input</usage><topic>" + polyport_publishes + R"(</topic></data_port>
  </ports>
</component_profile>
)";
}

// The via-polyport application: ping A -> B and pong B -> A, passthrough (same type both ends).
fs::path write_profiles(const fs::path& dir, const std::string& model, const std::string& type, int a, int b) {
  std::ofstream(dir / "PingSide.xml") << component("PingSide", model, a, type, "ping", "pong");
  std::ofstream(dir / "PongSide.xml") << component("PongSide", model, b, type, "pong", "ping");
  std::ofstream(dir / "app.xml") << R"(<?xml version="1.0" encoding="UTF-8"?>
<application_profile>
  <name>dds_pingpong</name>
  <types><file>)" << POLYPORT_BENCH_IDL << R"(</file></types>
  <subcomponents>
    <subcomponent><name>a</name><reference>PingSide.xml</reference></subcomponent>
    <subcomponent><name>b</name><reference>PongSide.xml</reference></subcomponent>
  </subcomponents>
  <port_connections>
    <port_connection port_type="data"><source component_name="a" port_name="ping"/><target component_name="b" port_name="ping"/></port_connection>
    <port_connection port_type="data"><source component_name="b" port_name="pong"/><target component_name="a" port_name="pong"/></port_connection>
  </port_connections>
</application_profile>
)";
  return dir / "app.xml";
}

// ---- one case -----------------------------------------------------------------------------

struct Settings {
  int rounds = 10000;
  int warmup = 1000;
  int chunks = 6;
  int cpu = 0;
  int domain_base = 170;
  std::vector<std::string> placements{"unpinned", "one-core"};
  std::vector<std::string> vendors{"cyclonedds", "fastdds"};
  std::vector<int> sizes{16, 1024};
  std::string keep;
  std::string fastdds_data_sharing = "auto";
};

std::string program_of(const std::string& vendor) { return vendor == "cyclonedds" ? PINGPONG_CYCLONE : PINGPONG_FASTDDS; }

// One ping process of `rounds` round trips on `domain`; its samples are appended to `series`,
// and the CPU time it and the `watched` processes spent on them (roles: their names).
struct Watched {
  std::string role;
  pid_t pid;
};

void run_chunk(const std::string& vendor, int domain, int size, int rounds, int warmup, const Placement& placement,
               const fs::path& dir, const std::string& tag, const std::vector<Watched>& watched, Series& series) {
  if (!series.error.empty()) return;
  const fs::path samples = dir / (tag + ".samples");
  const fs::path out = dir / (tag + ".out");
  std::string pids;
  for (const Watched& w : watched) pids += (pids.empty() ? "" : ",") + std::to_string(w.pid);
  setenv("POLYPORT_BENCH_CPU_PIDS", pids.c_str(), 1);  // read by the ping (pingpong_common.hpp)
  const pid_t ping = spawn({program_of(vendor), "ping", std::to_string(domain), std::to_string(size),
                            std::to_string(rounds), std::to_string(warmup), samples.string()},
                           out, placement);
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
    for (const Watched& w : watched) series.cpu_roles.push_back(w.role);
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

double load_average() {
  double load[3] = {0, 0, 0};
  return getloadavg(load, 3) > 0 ? load[0] : -1;
}

Json run_case(const Settings& s, const Placement& placement, const std::string& vendor, int size, int first_domain,
              const fs::path& dir) {
  fs::create_directories(dir);
  const int direct_domain = first_domain;
  const int a = first_domain + 1;
  const int b = first_domain + 2;
  const int relay_a = first_domain + 3;
  const int relay_b = first_domain + 4;
  const std::string type = size == 16 ? "bench::Ping16" : "bench::Ping1k";
  const fs::path app = write_profiles(dir, vendor, type, a, b);
  const fs::path stats_file = dir / "polyport-stats.json";
  Json c{{"placement", placement.name},
         {"vendor", vendor},
         {"size_bytes", size},
         {"domains", {{"direct", direct_domain}, {"via_ping", a}, {"via_pong", b}, {"relay_ping", relay_a},
                      {"relay_pong", relay_b}}},
         {"loadavg1_at_start", load_average()}};

  // The pongs, polyportd and the relay stay up for the whole case; idle, they only wait on
  // their readers.
  const std::string sz = std::to_string(size);
  const pid_t direct_pong =
      spawn({program_of(vendor), "pong", std::to_string(direct_domain), sz}, dir / "pong-direct.out", placement);
  const pid_t via_pong = spawn({program_of(vendor), "pong", std::to_string(b), sz}, dir / "pong-via.out", placement);
  const pid_t relay_pong =
      spawn({program_of(vendor), "pong", std::to_string(relay_b), sz}, dir / "pong-relay.out", placement);
  const pid_t daemon =
      spawn({POLYPORTD, "run", app.string(), "-q", "--stats-json", stats_file.string()}, dir / "polyportd.out", placement);
  const pid_t relay = spawn({program_of(vendor), "relay", std::to_string(relay_a), std::to_string(relay_b), sz},
                            dir / "relay.out", placement);

  struct Kind {
    const char* tag;
    int ping_domain;
    std::vector<Watched> watched;
    Series series;
  };
  Kind kinds[3] = {{"direct", direct_domain, {{"pong", direct_pong}}, {}},
                   {"via", a, {{"polyportd", daemon}, {"pong", via_pong}}, {}},
                   {"relay", relay_a, {{"relay", relay}, {"pong", relay_pong}}, {}}};
  const int per_chunk = (s.rounds + s.chunks - 1) / s.chunks;
  for (int k = 0; k < s.chunks && !interrupted(); ++k) {
    // Taking turns at going first keeps any warming of the machine off one of the series.
    for (int j = 0; j < 3 && !interrupted(); ++j) {
      Kind& kind = kinds[(k + j) % 3];
      run_chunk(vendor, kind.ping_domain, size, per_chunk, s.warmup, placement, dir,
                std::string(kind.tag) + "-" + std::to_string(k), kind.watched, kind.series);
    }
  }
  const Series& direct = kinds[0].series;
  const Series& via = kinds[1].series;
  const Series& native = kinds[2].series;
  finish(direct_pong, SIGTERM, 10);
  finish(via_pong, SIGTERM, 10);
  finish(relay_pong, SIGTERM, 10);
  finish(relay, SIGTERM, 10);
  const int daemon_rc = finish(daemon, SIGINT, 20);
  if (interrupted()) return nullptr;

  c["direct"] = direct.to_json(s.chunks);
  c["via_polyport"] = via.to_json(s.chunks);
  c["via_native_relay"] = native.to_json(s.chunks);
  const Json stats = Json::parse(read_file(stats_file), nullptr, false);
  if (daemon_rc != 0 || stats.is_discarded() || !stats.contains("connections")) {
    c["polyport_error"] = "polyportd exited with " + std::to_string(daemon_rc) + ": " +
                          read_file(dir / "polyportd.out.err");
  } else {
    Json own = Json::array();
    for (const Json& connection : stats["connections"]) {
      own.push_back({{"connection", connection["name"]},
                     {"received", connection["received"]},
                     {"delivered", connection["delivered"]},
                     {"dropped", connection["dropped"]},
                     {"conversion", connection["conversion"]},
                     {"in_to_out_ns", connection["latency_ns"]},
                     {"sdk_write_ns", connection.value("sink_ns", Json::object())}});
    }
    c["polyport"] = own;
    c["polyport_version"] = stats.value("polyport_version", "");
  }
  if (!direct.rtt.empty() && !via.rtt.empty() && c.contains("polyport")) {
    const std::int64_t d50 = c["direct"]["one_way_ns"]["p50"].get<std::int64_t>();
    const std::int64_t v50 = c["via_polyport"]["one_way_ns"]["p50"].get<std::int64_t>();
    const std::int64_t bound = 2 * d50 + 2000;
    std::int64_t worst_p99 = 0;
    for (const Json& own : c["polyport"]) {
      worst_p99 = std::max(worst_p99, own["in_to_out_ns"].value("p99", std::int64_t{0}));
    }
    if (!native.rtt.empty()) {
      // The same bound applied to the native relay: whether the SDK's own four hops fit it.
      const std::int64_t r50 = c["via_native_relay"]["one_way_ns"]["p50"].get<std::int64_t>();
      c["against_native_relay"] = {{"relay_one_way_p50_ns", r50},
                                   {"relay_within_bound", r50 <= bound},
                                   {"via_polyport_minus_relay_p50_ns", v50 - r50}};
    }
    c["targets"] = {{"direct_one_way_p50_ns", d50},
                    {"via_one_way_p50_ns", v50},
                    {"bound_2x_direct_plus_2us_ns", bound},
                    {"via_within_bound", v50 <= bound},
                    {"via_margin_ns", bound - v50},  // < 0: by how much the bound is missed
                    {"via_minus_two_direct_hops_ns", v50 - 2 * d50},
                    {"polyport_in_to_out_p99_ns", worst_p99},
                    {"in_to_out_p99_within_1us", worst_p99 <= 1000}};
  }
  return c;
}

// ---- command line and host ----------------------------------------------------------------

std::vector<std::string> split(const std::string& list) {
  std::vector<std::string> out;
  std::stringstream in(list);
  for (std::string item; std::getline(in, item, ',');) {
    if (!item.empty()) out.push_back(item);
  }
  return out;
}

std::optional<Settings> parse(int argc, char** argv, std::string& output) {
  Settings s;
  std::vector<std::string> positional;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    const bool has_value = i + 1 < argc;
    if (arg.rfind("--", 0) != 0) {
      positional.push_back(arg);
    } else if (!has_value) {
      return std::nullopt;
    } else if (arg == "--chunks") {
      s.chunks = std::atoi(argv[++i]);
    } else if (arg == "--placements") {
      s.placements = split(argv[++i]);
    } else if (arg == "--cpu") {
      s.cpu = std::atoi(argv[++i]);
    } else if (arg == "--vendors") {
      s.vendors = split(argv[++i]);
    } else if (arg == "--sizes") {
      s.sizes.clear();
      for (const auto& v : split(argv[++i])) s.sizes.push_back(std::atoi(v.c_str()));
    } else if (arg == "--domain-base") {
      s.domain_base = std::atoi(argv[++i]);
    } else if (arg == "--fastdds-data-sharing") {
      s.fastdds_data_sharing = argv[++i];
    } else if (arg == "--keep") {
      s.keep = argv[++i];
    } else {
      return std::nullopt;
    }
  }
  if (positional.empty() || positional.size() > 3) return std::nullopt;
  output = positional[0];
  if (positional.size() > 1) s.rounds = std::atoi(positional[1].c_str());
  if (positional.size() > 2) s.warmup = std::atoi(positional[2].c_str());
  const auto known = [](const std::vector<std::string>& got, std::initializer_list<const char*> allowed) {
    return std::all_of(got.begin(), got.end(), [&](const std::string& g) {
      return std::any_of(allowed.begin(), allowed.end(), [&](const char* a) { return g == a; });
    });
  };
  const bool sizes_ok = std::all_of(s.sizes.begin(), s.sizes.end(), [](int v) { return v == 16 || v == 1024; });
  if (s.fastdds_data_sharing != "auto" && s.fastdds_data_sharing != "off") return std::nullopt;
  if (s.rounds < 1 || s.warmup < 0 || s.chunks < 1 || s.chunks > s.rounds || s.cpu < 0 || !sizes_ok ||
      !known(s.placements, {"unpinned", "one-core"}) || !known(s.vendors, {"cyclonedds", "fastdds"}) ||
      s.domain_base < 0 || s.domain_base + 5 * static_cast<int>(s.vendors.size() * s.sizes.size()) > 232) {
    return std::nullopt;
  }
  return s;
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

void print_line(const Json& c) {
  const Json t = c.value("targets", Json::object());
  const auto p50 = [&](const char* series) { return c[series].value("one_way_ns", Json::object()).value("p50", Json()); };
  const auto p99 = [&](const char* series) { return c[series].value("one_way_ns", Json::object()).value("p99", Json()); };
  std::string own;
  for (const Json& p : c.value("polyport", Json::array())) {
    own += " " + std::to_string(p["in_to_out_ns"].value("p50", 0)) + "/" + std::to_string(p["in_to_out_ns"].value("p99", 0));
  }
  const auto cpu = [&](const char* series) {
    return ns_to_us(c[series].value("cpu_per_round_trip_ns", Json::object()).value("all", Json()));
  };
  std::fprintf(stderr,
               "%-9s %-10s %5d B  direct %6s/%6s  via polyport %6s/%6s  via relay %6s/%6s us  bound %6s %-4s  "
               "in-to-out p50/p99 ns:%s %s  cpu per round trip us: %s %s %s\n",
               c["placement"].get<std::string>().c_str(), c["vendor"].get<std::string>().c_str(), c["size_bytes"].get<int>(),
               ns_to_us(p50("direct")).c_str(), ns_to_us(p99("direct")).c_str(), ns_to_us(p50("via_polyport")).c_str(),
               ns_to_us(p99("via_polyport")).c_str(), ns_to_us(p50("via_native_relay")).c_str(),
               ns_to_us(p99("via_native_relay")).c_str(), ns_to_us(t.value("bound_2x_direct_plus_2us_ns", Json())).c_str(),
               t.empty() ? "n/a" : (t["via_within_bound"].get<bool>() ? "ok" : "MISS"), own.c_str(),
               t.empty() ? "" : (t["in_to_out_p99_within_1us"].get<bool>() ? "ok" : "MISS"), cpu("direct").c_str(),
               cpu("via_polyport").c_str(), cpu("via_native_relay").c_str());
}

}  // namespace

int main(int argc, char** argv) {
  std::string output;
  const std::optional<Settings> parsed = parse(argc, argv, output);
  if (!parsed) {
    std::fprintf(stderr,
                 "usage: %s OUTPUT.json [ROUNDS [WARMUP]] [--chunks N] [--placements unpinned,one-core] [--cpu N]\n"
                 "       [--vendors cyclonedds,fastdds] [--sizes 16,1024] [--domain-base N]\n"
                 "       [--fastdds-data-sharing auto|off] [--keep DIR]\n",
                 argv[0]);
    return 2;
  }
  const Settings& s = *parsed;
  struct sigaction action {};
  action.sa_handler = on_signal;
  sigemptyset(&action.sa_mask);
  for (int sig : {SIGINT, SIGTERM, SIGHUP}) sigaction(sig, &action, nullptr);

  // The peers get the configurations polyport's DDS models default to.
  setenv("CYCLONEDDS_URI", "file://" POLYPORT_SOURCE_DIR "/config/cyclonedds-loopback.xml", 1);
  setenv("FASTRTPS_DEFAULT_PROFILES_FILE", POLYPORT_SOURCE_DIR "/config/fastdds-loopback.xml", 1);
  setenv("POLYPORT_BENCH_FASTDDS_DATA_SHARING", s.fastdds_data_sharing.c_str(), 1);
  const fs::path dir = s.keep.empty() ? fs::temp_directory_path() / ("polyport-bench-dds-" + std::to_string(getpid()))
                                      : fs::path(s.keep);
  fs::create_directories(dir);

  utsname host{};
  uname(&host);
  double load[3] = {0, 0, 0};
  getloadavg(load, 3);
  const char* revision = std::getenv("POLYPORT_GIT_REVISION");
  const auto t_start = std::chrono::steady_clock::now();
  Json result{{"benchmark", "dds_pingpong"},
              {"started_utc", utc_now()},
              {"git_revision", revision != nullptr ? revision : "unknown"},
              {"host", {{"nproc", std::thread::hardware_concurrency()},
                        {"cpu", cpu_model()},
                        {"uname", std::string(host.sysname) + " " + host.release + " " + host.version + " " + host.machine},
                        {"loadavg_at_start", {load[0], load[1], load[2]}}}},
              {"settings", {{"round_trips", s.rounds},
                            {"warmup_per_chunk", s.warmup},
                            {"chunks", s.chunks},
                            {"round_trips_per_chunk", (s.rounds + s.chunks - 1) / s.chunks},
                            {"sizes_bytes", s.sizes},
                            {"vendors", s.vendors},
                            {"placements", s.placements},
                            {"one_core_cpu", s.cpu},
                            {"one_way", "round trip / 2, CLOCK_MONOTONIC in the ping process"},
                            {"qos", "reliable, keep_last 10, volatile"},
                            {"pong", "echoes from a data-available listener (the SDK's receive thread)"},
                            {"fastdds_data_sharing_between_peers", s.fastdds_data_sharing},
                            {"transports", "config/cyclonedds-loopback.xml, config/fastdds-loopback.xml"},
                            {"polyport_histograms", "every sample polyportd forwarded in the case, warm-ups included"},
                            {"native_relay", "the vendor's relay program in polyportd's place: same hops, no polyport"},
                            {"cpu_per_round_trip_ns",
                             "CPU time per measured round trip of each process of the path (ping, polyportd or "
                             "relay, pong; all = their sum), from their CPU-time clocks read by the ping before "
                             "and after its measured round trips; on one core a round trip cannot cost less than "
                             "'all'"},
                            {"targets", "via one-way p50 <= 2 x direct one-way p50 + 2 us; "
                                        "polyport in-to-out p99 <= 1 us (worse of the two connections)"}}},
              {"cases", Json::array()}};

  bool all_ok = true;
  for (const std::string& placement_name : s.placements) {
    const Placement placement{placement_name, placement_name == "one-core" ? s.cpu : -1};
    int domain = s.domain_base;
    for (const std::string& vendor : s.vendors) {
      for (const int size : s.sizes) {
        if (interrupted()) break;
        std::fprintf(stderr, "%s %s %d B ...\n", placement.name.c_str(), vendor.c_str(), size);
        const std::string name = placement.name + "-" + vendor + "-" + std::to_string(size);
        Json c = run_case(s, placement, vendor, size, domain, dir / name);
        domain += 5;
        if (c.is_null()) break;
        all_ok = all_ok && c.contains("targets");
        print_line(c);
        result["cases"].push_back(std::move(c));
      }
    }
  }
  if (interrupted()) {
    std::fprintf(stderr, "interrupted: no result written\n");
    if (s.keep.empty()) fs::remove_all(dir);
    return 130;
  }
  getloadavg(load, 3);
  result["host"]["loadavg_at_end"] = {load[0], load[1], load[2]};
  result["duration_s"] = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  std::ofstream out(output);
  out << result.dump(2) << "\n";
  out.close();
  if (s.keep.empty()) fs::remove_all(dir);
  if (!out) {
    std::fprintf(stderr, "cannot write %s\n", output.c_str());
    return 1;
  }
  std::fprintf(stderr, "results: %s\n", output.c_str());
  return all_ok ? 0 : 1;
}
