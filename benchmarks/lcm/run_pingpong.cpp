// The LCM latency benchmark: for each placement and message size, one-way latency (round trip
// / 2) between two LCM ping-pong processes (pingpong_lcm, lcm-gen C types), first on one
// provider (direct), then on two providers joined by polyportd (ping A -> polyport -> B pong
// -> polyport -> A, an LCM -> LCM passthrough both ways), plus polyport's own in-to-out time
// from its connection histograms; and on two providers joined by pingpong_lcm's own `relay`
// (lcm-gen types and liblcm alone): the same four LCM hops without polyport. Each path has
// providers of its own (udpm://239.255.76.67:PORT?ttl=0, one port each). One run, one machine,
// one JSON file; nothing asserts: the targets (issue 10) are computed and reported.
//
//   bench_lcm_pingpong OUTPUT.json [ROUNDS [WARMUP]] [options]      (scripts/bench_lcm.sh)
//     --chunks N         the measured round trips of a series are split over N ping processes,
//                        the three series taking turns (default 6), as in the DDS benchmark
//     --placements LIST  unpinned,one-core (default: both); one-core pins every process of a
//                        case to --cpu
//     --cpu N            the core of the one-core placement (default 0)
//     --sizes LIST       16,1024 (default: both)
//     --port-base N      first UDP port; each size takes 5 (default 7700)
//     --host-network     use the host's network as it is (239.255.76.67 must have a route)
//                        instead of a private network namespace with loopback's own route
//     --keep DIR         keep the generated profiles, raw samples, logs and polyport's
//                        statistics in DIR (default: a temporary directory, removed)
//
// Network: by default the runner moves itself into a network namespace of its own (needs
// root), brings loopback up with multicast and routes 239.255.76.67 there; every child
// inherits it, and it disappears with the runner, so nothing is added to the host.
// Threads: one (benchmarks/common/runner.hpp).
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <optional>
#include <string>
#include <vector>

#include "runner.hpp"

namespace {

namespace fs = bench::fs;
using bench::Json;
using bench::Placement;

constexpr const char* kGroup = "239.255.76.67";

struct Settings {
  bench::RunOptions run;
  int port_base = 7700;
  bool host_network = false;
  std::vector<int> sizes{16, 1024};
};

std::string url_of(int port) { return std::string("udpm://") + kGroup + ":" + std::to_string(port) + "?ttl=0"; }

// An LCM component on `port`: `app_publishes` is the channel the application publishes
// (polyport subscribes), `polyport_publishes` the one polyport publishes.
std::string component(const std::string& name, int port, const std::string& type, const std::string& app_publishes,
                      const std::string& polyport_publishes) {
  return bench::pingpong_component(name, "lcm", "<lcm><url>" + url_of(port) + "</url></lcm>", type, "channel",
                                   app_publishes, polyport_publishes);
}

// The via-polyport application: PING A -> B and PONG B -> A, passthrough (same type both ends).
fs::path write_profiles(const fs::path& dir, const std::string& type, int a, int b) {
  return bench::write_pingpong_app(dir, "lcm_pingpong", POLYPORT_BENCH_LCM_TYPES,
                                   component("PingSide", a, type, "PING", "PONG"),
                                   component("PongSide", b, type, "PONG", "PING"), "ping", "pong");
}

Json run_lcm_case(const Settings& s, const Placement& placement, int size, int first_port, const fs::path& dir) {
  fs::create_directories(dir);
  Json c{{"placement", placement.name},
         {"size_bytes", size},
         {"ports", bench::five_domains_json(first_port)},
         {"loadavg1_at_start", bench::load_average()}};
  bench::CaseCommands commands = bench::five_domain_commands(PINGPONG_LCM, first_port, size);
  commands.app = write_profiles(dir, size == 16 ? "bench_lcm::ping16_t" : "bench_lcm::ping1k_t", first_port + 1,
                                first_port + 2);
  const std::optional<std::int64_t> worst = bench::run_case(s.run.chunking, placement, dir, commands, c);
  if (!worst) return nullptr;
  const Json targets = bench::relay_targets(c, *worst);
  if (!targets.is_null()) c["targets"] = targets;
  return c;
}

std::optional<Settings> parse(int argc, char** argv) {
  Settings s;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (s.run.take(argc, argv, i)) continue;
    if (arg == "--host-network") {
      s.host_network = true;
    } else if (i + 1 >= argc) {
      return std::nullopt;
    } else if (arg == "--sizes") {
      s.sizes.clear();
      for (const auto& v : bench::split(argv[++i])) s.sizes.push_back(std::atoi(v.c_str()));
    } else if (arg == "--port-base") {
      s.port_base = std::atoi(argv[++i]);
    } else {
      return std::nullopt;
    }
  }
  const bool sizes_ok = std::all_of(s.sizes.begin(), s.sizes.end(), [](int v) { return v == 16 || v == 1024; });
  if (!s.run.finish() || !sizes_ok || s.port_base < 1024 || s.port_base + 5 * static_cast<int>(s.sizes.size()) > 65535) {
    return std::nullopt;
  }
  return s;
}

}  // namespace

int main(int argc, char** argv) {
  const std::optional<Settings> parsed = parse(argc, argv);
  if (!parsed) {
    std::fprintf(stderr,
                 "usage: %s OUTPUT.json [ROUNDS [WARMUP]] [--chunks N] [--placements unpinned,one-core] [--cpu N]\n"
                 "       [--sizes 16,1024] [--port-base N] [--host-network] [--keep DIR]\n",
                 argv[0]);
    return 2;
  }
  const Settings& s = *parsed;
  if (!s.host_network && !bench::private_network(std::string(kGroup) + "/32")) return 1;
  bench::forward_stop_signals();
  const fs::path dir = bench::work_dir(s.run.keep, "lcm");

  const auto t_start = std::chrono::steady_clock::now();
  Json result = bench::result_header("lcm_pingpong");
  Json settings = bench::shared_settings(s.run);
  settings.update({{"sizes_bytes", s.sizes},
                   {"provider", url_of(s.port_base) + " and the next ports, one per path end"},
                   {"network", s.host_network ? "the host's" : "a private namespace, loopback routes the group"},
                   {"pong", "echoes from its generated handler, lcm_handle() after poll() on the main thread"},
                   {"native_relay", "pingpong_lcm relay (lcm-gen C types, liblcm) in polyportd's place: same hops, "
                                    "decodes and publishes again as a program written with the SDK does"},
                   {"targets", "via one-way p50 <= relay one-way p50 + 2 us; polyport in-to-out p99 <= 1 us (worse "
                               "of the two connections); polyportd CPU per round trip <= the relay's"}});
  result["settings"] = settings;
  result["cases"] = Json::array();

  bool all_ok = true;
  for (const std::string& placement_name : s.run.placements) {
    const Placement placement = s.run.placement(placement_name);
    int port = s.port_base;
    for (const int size : s.sizes) {
      if (bench::interrupted()) break;
      std::fprintf(stderr, "%s lcm %d B ...\n", placement.name.c_str(), size);
      Json c = run_lcm_case(s, placement, size, port, dir / (placement.name + "-" + std::to_string(size)));
      port += 5;
      if (c.is_null()) break;
      all_ok = all_ok && c.contains("targets");
      bench::print_case(c, "lcm", bench::relay_verdicts(c));
      result["cases"].push_back(std::move(c));
    }
  }
  return bench::end_run(result, s.run.output, dir, !s.run.keep.empty(), all_ok, t_start);
}
