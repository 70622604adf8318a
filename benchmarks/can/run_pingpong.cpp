// The CAN latency benchmark, run where vcan interfaces exist (scripts/bench_can.sh runs it in
// the vcan guest, scripts/vcan-run --interfaces 5): one-way latency (round trip / 2) of
// classic 8-byte frames between two raw-socket ping-pong processes (pingpong_can), first on
// one interface (direct), then on two interfaces joined by polyportd (ping on A -> polyport ->
// B pong -> polyport -> A, a CAN -> CAN passthrough both ways), plus polyport's own in-to-out
// time from its connection histograms; and on two interfaces joined by pingpong_can's own
// `relay` (raw sockets alone): the same four vcan hops without polyport. Each path has
// interfaces of its own: direct vcanF, via vcanF+1 -> vcanF+2, relay vcanF+3 -> vcanF+4. One
// run, one machine, one JSON file; nothing asserts: the targets (issue 10) are computed and
// reported.
//
//   bench_can_pingpong OUTPUT.json [ROUNDS [WARMUP]] [options]
//     --chunks N         the measured round trips of a series are split over N ping processes,
//                        the three series taking turns (default 6), as in the DDS benchmark
//     --placements LIST  unpinned,one-core (default: unpinned: user-mode Linux, the guest
//                        vcan-run boots where the host has no vcan, has one CPU)
//     --cpu N            the core of the one-core placement (default 0)
//     --first-interface F  the interfaces used are vcanF..vcanF+4 (default 0)
//     --keep DIR         keep the generated profiles, raw samples, logs and polyport's
//                        statistics in DIR (default: a temporary directory, removed)
//
// Threads: one (benchmarks/common/runner.hpp).
#include <net/if.h>

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

constexpr int kFrameBytes = 8;

struct Settings {
  bench::RunOptions run;
  int first_interface = 0;
};

std::string interface_of(int n) { return "vcan" + std::to_string(n); }

// A SocketCAN component on vcanN: `bus_sends` is the message the CAN node sends (polyport
// receives it), `polyport_sends` the one polyport sends. Each port is named after its message.
std::string component(const std::string& name, int n, const std::string& bus_sends, const std::string& polyport_sends) {
  const auto data_port = [&](const std::string& message, const char* usage) {
    return "    <data_port><name>" + message + "</name><data_type>pingpong::" + message + "</data_type><usage>" +
           usage + "</usage></data_port>\n";
  };
  return "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<component_profile>\n  <name>" + name +
         "</name>\n  <model>socketcan</model>\n  <socketcan><interface>" + interface_of(n) +
         "</interface></socketcan>\n  <ports>\n" + data_port(bus_sends, "output") + data_port(polyport_sends, "input") +
         "  </ports>\n</component_profile>\n";
}

Json run_can_case(const Settings& s, const bench::Placement& placement, const fs::path& dir) {
  fs::create_directories(dir);
  const int first = s.first_interface;
  Json c{{"placement", placement.name},
         {"size_bytes", kFrameBytes},
         {"interfaces", bench::five_domains_json(first)},
         {"loadavg1_at_start", bench::load_average()}};
  bench::CaseCommands commands = bench::five_domain_commands(PINGPONG_CAN, first, kFrameBytes);
  commands.app = bench::write_pingpong_app(dir, "can_pingpong", POLYPORT_BENCH_DBC,
                                           component("PingSide", first + 1, "Ping", "Pong"),
                                           component("PongSide", first + 2, "Pong", "Ping"), "Ping", "Pong");
  const std::optional<std::int64_t> worst = bench::run_case(s.run.chunking, placement, dir, commands, c);
  if (!worst) return nullptr;
  const Json targets = bench::relay_targets(c, *worst);
  if (!targets.is_null()) c["targets"] = targets;
  return c;
}

std::optional<Settings> parse(int argc, char** argv) {
  Settings s;
  s.run.placements = {"unpinned"};
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (s.run.take(argc, argv, i)) continue;
    if (arg == "--first-interface" && i + 1 < argc) {
      s.first_interface = std::atoi(argv[++i]);
    } else {
      return std::nullopt;
    }
  }
  if (!s.run.finish() || s.first_interface < 0) return std::nullopt;
  return s;
}

}  // namespace

int main(int argc, char** argv) {
  const std::optional<Settings> parsed = parse(argc, argv);
  if (!parsed) {
    std::fprintf(stderr,
                 "usage: %s OUTPUT.json [ROUNDS [WARMUP]] [--chunks N] [--placements unpinned,one-core] [--cpu N]\n"
                 "       [--first-interface F] [--keep DIR]\n",
                 argv[0]);
    return 2;
  }
  const Settings& s = *parsed;
  for (int k = 0; k < 5; ++k) {
    const std::string name = interface_of(s.first_interface + k);
    if (if_nametoindex(name.c_str()) == 0) {
      std::fprintf(stderr, "%s does not exist: run through scripts/vcan-run --interfaces %d (scripts/bench_can.sh)\n",
                   name.c_str(), s.first_interface + 5);
      return 1;
    }
  }
  bench::forward_stop_signals();
  const fs::path dir = bench::work_dir(s.run.keep, "can");

  const auto t_start = std::chrono::steady_clock::now();
  Json result = bench::result_header("can_pingpong");
  Json settings = bench::shared_settings(s.run);
  const char* where = std::getenv("VCAN_RUN_IN");
  settings.update({{"frame", "classic CAN, 8 data bytes (pingpong.dbc: Ping 0x100, Pong 0x101)"},
                   {"interfaces", interface_of(s.first_interface) + ".." + interface_of(s.first_interface + 4)},
                   {"vcan_run", where != nullptr ? where : "not under scripts/vcan-run"},
                   {"pong", "raw socket, kernel filter on its id, answers after poll() on the main thread"},
                   {"native_relay", "pingpong_can relay (raw sockets) in polyportd's place: same hops"},
                   {"targets", "via one-way p50 <= relay one-way p50 + 2 us; polyport in-to-out p99 <= 1 us (worse "
                               "of the two connections); polyportd CPU per round trip <= the relay's"}});
  result["settings"] = settings;
  result["cases"] = Json::array();

  bool all_ok = true;
  for (const std::string& placement_name : s.run.placements) {
    if (bench::interrupted()) break;
    const bench::Placement placement = s.run.placement(placement_name);
    std::fprintf(stderr, "%s can %d B ...\n", placement.name.c_str(), kFrameBytes);
    Json c = run_can_case(s, placement, dir / placement.name);
    if (c.is_null()) break;
    all_ok = all_ok && c.contains("targets");
    bench::print_case(c, "socketcan", bench::relay_verdicts(c));
    result["cases"].push_back(std::move(c));
  }
  return bench::end_run(result, s.run.output, dir, !s.run.keep.empty(), all_ok, t_start);
}
