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
// runner are forwarded to the live children and end the run without writing a result. The
// machinery is the one the LCM and CAN runners share (benchmarks/common/runner.hpp).
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

using bench::Json;
using bench::Placement;
namespace fs = bench::fs;
using bench::interrupted;
using bench::load_average;
using bench::split;

// ---- profiles -----------------------------------------------------------------------------

// A DDS component profile of `model` on `domain`: `app_publishes` is a topic the application
// publishes (polyport reads it), `polyport_publishes` one polyport writes. No <config>: the
// model's default, the shipped loopback configuration, which the peers are given too.
std::string component(const std::string& name, const std::string& model, int domain, const std::string& type,
                      const std::string& app_publishes, const std::string& polyport_publishes) {
  return bench::pingpong_component(name, model, "<dds><domain>" + std::to_string(domain) + "</domain></dds>", type,
                                   "topic", app_publishes, polyport_publishes);
}

// The via-polyport application: ping A -> B and pong B -> A, passthrough (same type both ends).
fs::path write_profiles(const fs::path& dir, const std::string& model, const std::string& type, int a, int b) {
  return bench::write_pingpong_app(dir, "dds_pingpong", POLYPORT_BENCH_IDL,
                                   component("PingSide", model, a, type, "ping", "pong"),
                                   component("PongSide", model, b, type, "pong", "ping"), "ping", "pong");
}

// ---- one case -----------------------------------------------------------------------------

struct Settings {
  bench::RunOptions run;
  int domain_base = 170;
  std::vector<std::string> vendors{"cyclonedds", "fastdds"};
  std::vector<int> sizes{16, 1024};
  std::string fastdds_data_sharing = "auto";
};

std::string program_of(const std::string& vendor) { return vendor == "cyclonedds" ? PINGPONG_CYCLONE : PINGPONG_FASTDDS; }

Json run_dds_case(const Settings& s, const Placement& placement, const std::string& vendor, int size, int first_domain,
                  const fs::path& dir) {
  fs::create_directories(dir);
  const std::string type = size == 16 ? "bench::Ping16" : "bench::Ping1k";
  Json c{{"placement", placement.name},
         {"vendor", vendor},
         {"size_bytes", size},
         {"domains", bench::five_domains_json(first_domain)},
         {"loadavg1_at_start", load_average()}};
  bench::CaseCommands commands = bench::five_domain_commands(program_of(vendor), first_domain, size);
  commands.app = write_profiles(dir, vendor, type, first_domain + 1, first_domain + 2);
  const std::optional<std::int64_t> worst = bench::run_case(s.run.chunking, placement, dir, commands, c);
  if (!worst) return nullptr;
  const std::int64_t worst_p99 = *worst;
  const bool direct_ok = c["direct"].contains("one_way_ns");
  const bool via_ok = c["via_polyport"].contains("one_way_ns");
  const bool native_ok = c["via_native_relay"].contains("one_way_ns");
  if (direct_ok && via_ok && c.contains("polyport")) {
    const std::int64_t d50 = c["direct"]["one_way_ns"]["p50"].get<std::int64_t>();
    const std::int64_t v50 = c["via_polyport"]["one_way_ns"]["p50"].get<std::int64_t>();
    const std::int64_t bound = 2 * d50 + 2000;
    if (native_ok) {
      // The same bound applied to the native relay: whether the SDK's own four hops fit it.
      const std::int64_t r50 = c["via_native_relay"]["one_way_ns"]["p50"].get<std::int64_t>();
      c["against_native_relay"] = {{"relay_one_way_p50_ns", r50},
                                   {"relay_within_bound", r50 <= bound},
                                   {"via_polyport_minus_relay_p50_ns", v50 - r50},
                                   {"via_minus_relay_paired_chunks",
                                    bench::paired_chunks(c["via_polyport"], c["via_native_relay"], 2000)}};
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

std::optional<Settings> parse(int argc, char** argv) {
  Settings s;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (s.run.take(argc, argv, i)) continue;
    if (i + 1 >= argc) return std::nullopt;
    if (arg == "--vendors") {
      s.vendors = split(argv[++i]);
    } else if (arg == "--sizes") {
      s.sizes.clear();
      for (const auto& v : split(argv[++i])) s.sizes.push_back(std::atoi(v.c_str()));
    } else if (arg == "--domain-base") {
      s.domain_base = std::atoi(argv[++i]);
    } else if (arg == "--fastdds-data-sharing") {
      s.fastdds_data_sharing = argv[++i];
    } else {
      return std::nullopt;
    }
  }
  const bool sizes_ok = std::all_of(s.sizes.begin(), s.sizes.end(), [](int v) { return v == 16 || v == 1024; });
  if (s.fastdds_data_sharing != "auto" && s.fastdds_data_sharing != "off") return std::nullopt;
  if (!s.run.finish() || !sizes_ok || !bench::all_known(s.vendors, {"cyclonedds", "fastdds"}) || s.domain_base < 0 ||
      s.domain_base + 5 * static_cast<int>(s.vendors.size() * s.sizes.size()) > 232) {
    return std::nullopt;
  }
  return s;
}

// The figures of a case on stderr, its targets' verdicts with them.
void print_line(const Json& c) {
  const Json t = c.value("targets", Json::object());
  std::string verdicts = "bound n/a";
  if (!t.empty()) {
    verdicts = "bound " + bench::ns_to_us(t["bound_2x_direct_plus_2us_ns"]) +
               (t["via_within_bound"].get<bool>() ? " ok" : " MISS") +
               "  in-to-out p99 <= 1 us " + (t["in_to_out_p99_within_1us"].get<bool>() ? "ok" : "MISS");
  }
  bench::print_case(c, c["vendor"].get<std::string>(), verdicts);
}

}  // namespace

int main(int argc, char** argv) {
  const std::optional<Settings> parsed = parse(argc, argv);
  if (!parsed) {
    std::fprintf(stderr,
                 "usage: %s OUTPUT.json [ROUNDS [WARMUP]] [--chunks N] [--placements unpinned,one-core] [--cpu N]\n"
                 "       [--vendors cyclonedds,fastdds] [--sizes 16,1024] [--domain-base N]\n"
                 "       [--fastdds-data-sharing auto|off] [--keep DIR]\n",
                 argv[0]);
    return 2;
  }
  const Settings& s = *parsed;
  bench::forward_stop_signals();

  // The peers get the configurations polyport's DDS models default to.
  setenv("CYCLONEDDS_URI", "file://" POLYPORT_SOURCE_DIR "/config/cyclonedds-loopback.xml", 1);
  setenv("FASTRTPS_DEFAULT_PROFILES_FILE", POLYPORT_SOURCE_DIR "/config/fastdds-loopback.xml", 1);
  setenv("POLYPORT_BENCH_FASTDDS_DATA_SHARING", s.fastdds_data_sharing.c_str(), 1);
  const fs::path dir = bench::work_dir(s.run.keep, "dds");

  const auto t_start = std::chrono::steady_clock::now();
  Json result = bench::result_header("dds_pingpong");
  Json settings = bench::shared_settings(s.run);
  settings.update({{"sizes_bytes", s.sizes},
                   {"vendors", s.vendors},
                   {"qos", "reliable, keep_last 10, volatile"},
                   {"pong", "echoes from a data-available listener (the SDK's receive thread)"},
                   {"fastdds_data_sharing_between_peers", s.fastdds_data_sharing},
                   {"transports", "config/cyclonedds-loopback.xml, config/fastdds-loopback.xml"},
                   {"native_relay", "the vendor's relay program in polyportd's place: same hops, no polyport"},
                   {"targets", "via one-way p50 <= 2 x direct one-way p50 + 2 us; "
                               "polyport in-to-out p99 <= 1 us (worse of the two connections)"}});
  result["settings"] = settings;
  result["cases"] = Json::array();

  bool all_ok = true;
  for (const std::string& placement_name : s.run.placements) {
    const Placement placement = s.run.placement(placement_name);
    int domain = s.domain_base;
    for (const std::string& vendor : s.vendors) {
      for (const int size : s.sizes) {
        if (interrupted()) break;
        std::fprintf(stderr, "%s %s %d B ...\n", placement.name.c_str(), vendor.c_str(), size);
        const std::string name = placement.name + "-" + vendor + "-" + std::to_string(size);
        Json c = run_dds_case(s, placement, vendor, size, domain, dir / name);
        domain += 5;
        if (c.is_null()) break;
        all_ok = all_ok && c.contains("targets");
        print_line(c);
        result["cases"].push_back(std::move(c));
      }
    }
  }
  return bench::end_run(result, s.run.output, dir, !s.run.keep.empty(), all_ok, t_start);
}
