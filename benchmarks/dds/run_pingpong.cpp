// The DDS latency benchmark: for each vendor and sample size, one-way latency (round trip /
// 2) between two ping-pong processes, first on one domain (direct), then on two domains
// joined by polyportd (ping A -> polyport -> B pong -> polyport -> A), plus polyport's own
// in-to-out time from its connection histograms (receive callback to the SDK's write call;
// the SDK's write itself is reported apart as sink_ns). One run, one machine; writes one
// JSON file. Nothing here asserts: the targets are computed and reported.
//
//   bench_dds_pingpong OUTPUT.json [ROUNDS [WARMUP]]
#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/utsname.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

extern char** environ;

namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;

pid_t spawn(const std::vector<std::string>& args, const fs::path& out) {
  std::vector<char*> argv;
  for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 1, out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  const fs::path err = out.string() + ".err";
  posix_spawn_file_actions_addopen(&actions, 2, err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  pid_t pid = -1;
  if (posix_spawn(&pid, argv[0], &actions, nullptr, argv.data(), environ) != 0) pid = -1;
  posix_spawn_file_actions_destroy(&actions);
  return pid;
}

int finish(pid_t pid, int signal_number, int seconds) {
  if (signal_number != 0) kill(pid, signal_number);
  for (int i = 0; i < seconds * 100; ++i) {
    int status = 0;
    if (waitpid(pid, &status, WNOHANG) == pid) return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  kill(pid, SIGKILL);
  waitpid(pid, nullptr, 0);
  return -1;
}

std::string read_file(const fs::path& file) {
  std::ifstream in(file);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// A DDS component profile of `model` on `domain`: `out_topic` published by the application
// (polyport reads it), `in_topic` published by polyport.
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

// Runs pong then ping; returns ping's JSON line (null on failure).
Json pingpong(const std::string& program, int ping_domain, int pong_domain, int size, int rounds, int warmup,
              const fs::path& dir) {
  const pid_t pong = spawn({program, "pong", std::to_string(pong_domain), std::to_string(size)}, dir / "pong.out");
  const pid_t ping = spawn({program, "ping", std::to_string(ping_domain), std::to_string(size), std::to_string(rounds),
                            std::to_string(warmup)},
                           dir / "ping.out");
  const int rc = finish(ping, 0, 300);
  finish(pong, SIGTERM, 10);
  if (rc != 0) {
    std::fprintf(stderr, "ping failed (%d): %s\n", rc, read_file(dir / "ping.out.err").c_str());
    return nullptr;
  }
  return Json::parse(read_file(dir / "ping.out"), nullptr, false);
}

std::string git_revision() {
  const char* rev = std::getenv("POLYPORT_GIT_REVISION");
  return rev ? rev : "unknown";
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: %s OUTPUT.json [ROUNDS [WARMUP]]\n", argv[0]);
    return 2;
  }
  const int rounds = argc > 2 ? std::atoi(argv[2]) : 10000;
  const int warmup = argc > 3 ? std::atoi(argv[3]) : 1000;
  setenv("CYCLONEDDS_URI", "file://" POLYPORT_SOURCE_DIR "/config/cyclonedds-loopback.xml", 1);
  setenv("FASTRTPS_DEFAULT_PROFILES_FILE", POLYPORT_SOURCE_DIR "/config/fastdds-loopback.xml", 1);
  const fs::path dir = fs::temp_directory_path() / ("polyport-bench-dds-" + std::to_string(getpid()));
  fs::create_directories(dir);

  utsname host{};
  uname(&host);
  double load[3] = {0, 0, 0};
  getloadavg(load, 3);
  Json result{{"benchmark", "dds_pingpong"},
              {"git_revision", git_revision()},
              {"host", {{"nproc", std::thread::hardware_concurrency()},
                        {"uname", std::string(host.sysname) + " " + host.release + " " + host.machine},
                        {"loadavg_at_start", {load[0], load[1], load[2]}}}},
              {"settings", {{"round_trips", rounds}, {"warmup", warmup}, {"one_way", "round trip / 2"},
                            {"qos", "reliable, keep_last 10, volatile"}, {"transports", "shipped loopback configs"}}},
              {"cases", Json::array()}};

  struct Vendor {
    std::string model;
    std::string program;
  };
  const Vendor vendors[] = {{"cyclonedds", PINGPONG_CYCLONE}, {"fastdds", PINGPONG_FASTDDS}};
  int domain = 60;
  for (const Vendor& vendor : vendors) {
    for (const int size : {16, 1024}) {
      const std::string type = size == 16 ? "bench::Ping16" : "bench::Ping1k";
      std::fprintf(stderr, "%s %d B: direct...\n", vendor.model.c_str(), size);
      const Json direct = pingpong(vendor.program, domain, domain, size, rounds, warmup, dir);
      std::fprintf(stderr, "%s %d B: via polyport...\n", vendor.model.c_str(), size);
      const fs::path app = write_profiles(dir, vendor.model, type, domain + 1, domain + 2);
      const fs::path stats_file = dir / "stats.json";
      fs::remove(stats_file);
      const pid_t daemon = spawn({POLYPORTD, "run", app.string(), "-q", "--stats-json", stats_file.string()},
                                 dir / "polyportd.out");
      const Json via = pingpong(vendor.program, domain + 1, domain + 2, size, rounds, warmup, dir);
      const int daemon_rc = finish(daemon, SIGINT, 20);
      const Json stats = Json::parse(read_file(stats_file), nullptr, false);
      domain += 3;

      Json c{{"vendor", vendor.model}, {"size_bytes", size}, {"direct", direct}, {"via_polyport", via}};
      if (daemon_rc != 0 || stats.is_discarded()) {
        c["polyport_error"] = read_file(dir / "polyportd.out.err");
      } else {
        Json own = Json::array();
        for (const Json& connection : stats["connections"]) {
          own.push_back({{"connection", connection["name"]},
                         {"delivered", connection["delivered"]},
                         {"dropped", connection["dropped"]},
                         {"in_to_out_ns", connection["latency_ns"]},
                         {"sdk_write_ns", connection["sink_ns"]}});
        }
        c["polyport"] = own;
      }
      if (!direct.is_null() && !via.is_null() && c.contains("polyport")) {
        const double d50 = direct["one_way_ns"]["p50"].get<double>();
        const double v50 = via["one_way_ns"]["p50"].get<double>();
        std::int64_t worst_p99 = 0;
        for (const Json& own : c["polyport"]) worst_p99 = std::max(worst_p99, own["in_to_out_ns"]["p99"].get<std::int64_t>());
        c["targets"] = {{"via_median_ns", v50},
                        {"bound_2x_direct_plus_2us_ns", 2 * d50 + 2000},
                        {"via_within_bound", v50 <= 2 * d50 + 2000},
                        {"polyport_in_to_out_p99_ns", worst_p99},
                        {"in_to_out_p99_within_1us", worst_p99 <= 1000}};
      }
      result["cases"].push_back(c);
      std::fprintf(stderr, "%s\n", c.dump().c_str());
    }
  }
  std::ofstream(argv[1]) << result.dump(2) << "\n";
  fs::remove_all(dir);
  std::fprintf(stderr, "results: %s\n", argv[1]);
  return 0;
}
