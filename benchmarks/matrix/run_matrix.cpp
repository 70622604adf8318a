// The cross-model latency matrix: for every ordered pair A -> B of the host-runnable models
// (Cyclone DDS, Fast DDS, LCM), a ping program of model A and a pong program of model B (the
// same-model benchmarks' programs: benchmarks/dds/pingpong_{cyclone,fastdds}.cpp,
// benchmarks/lcm/pingpong_lcm.cpp), joined
//   via polyportd: A's ping topic / channel -> B's and B's pong -> A's, from profiles this
//     runner writes per case (DDS <-> LCM with a <mapping>, see below), and
//   via a native relay written with the two SDKs alone (relay_<sdk>_<sdk>.cpp, relay.hpp),
// one-way latency = round trip / 2 (median, p99, pooled over chunks that take turns), for 16 B
// and 1 KiB payloads, the CPU time per round trip of every process of the path (polyportd's
// and the relay's: two messages through the bridge per round trip), and polyport's own
// in-to-out time from its statistics. The diagonal (A = B) is the same-model benchmark's case:
// direct, via polyportd and via the SDK's own relay program (benchmarks/common/runner.hpp
// five_domain_commands), run here in the same run so that a cross pair's figures can be set
// beside both of its models' direct ones. One run, one machine, one JSON file; nothing
// asserts: the bars are computed and reported (benchmarks/matrix/report.py turns the file into
// the table and the heat map).
//
// Mapping between the models' ping types: DDS `bench::Ping16 { unsigned long long seq; octet
// pad[8]; }` (and Ping1k) and LCM `bench_lcm::ping16_t { int64_t seq; byte pad[8]; }`. pad maps
// by name (octet and byte are both unsigned 8-bit); seq is unsigned 64 on one side and signed
// 64 on the other, which is narrowing both ways, so each DDS <-> LCM connection carries
// <mapping><field target="seq" source="seq" allow_narrowing="true"/></mapping>. A narrowed
// value saturates (docs/PROFILES.md): the ping programs' sequence numbers are from 0 up, and
// the LCM ping's probes from 2^52 up (they were negative, which saturated at 0 on the way
// through a DDS pong), so none saturates. Cyclone DDS <-> Fast DDS share the IDL types: a
// passthrough, no mapping.
//
// CAN (--models can,..., inside scripts/vcan-run: the host kernel has no CAN): pingpong_can
// (benchmarks/can, raw SocketCAN) against the other models' programs: in the 16 B class
// classic 8-byte frames of pingpong.dbc (Ping 0x100, Pong 0x101, one 64-bit signal seq), in
// the 1 KiB class CAN FD 64-byte frames of pingpong_fd.dbc (the same, seq in the first 8
// bytes, the rest zero; the interfaces need the FD MTU: vcan-run --fd). Via polyport: a
// socketcan component per side; a DBC signal is a physical double, exact up to 2^53, so the
// ping programs' sequence numbers stay below (measured ones from 0, the CAN and LCM pings'
// probes from 2^52) and each CAN <-> other connection carries kCanMapping (seq narrowed into
// the integer, pad zero: no signal carries it). The native relays are relay_can_<sdk>
// (side_can.hpp: a raw CAN socket; pad not carried either). Each CAN pair takes five
// interfaces (vcanN.., a domain's N), so --pairs can with all four models needs
// --interfaces 35.
//
//   bench_matrix OUTPUT.json [ROUNDS [WARMUP]] [options]      (scripts/bench_matrix.sh)
//     --chunks N, --placements LIST, --cpu N, --keep DIR   as the same-model runners
//                        (benchmarks/common/runner.hpp RunOptions)
//     --models LIST      cyclonedds,fastdds,lcm,can (default: the first three; can where the
//                        SocketCAN model is built, and only with vcan interfaces, see above)
//     --sizes LIST       16,1024 (default: both)
//     --pairs all|cross|can  cross: leave out the diagonal; can: the pairs with CAN on a side
//                        and every diagonal (the direct figures of the second bar, from the
//                        same run: the vcan guest's figures are its own) (default: all)
//     --domain-base N    first DDS domain; each pair takes 5 (default 185)
//     --port-base N      first LCM port; each pair takes 5 (default 7800)
//     --host-network     as bench_lcm_pingpong: use the host's network (239.255.76.67 must
//                        have a route) instead of a private network namespace; with CAN
//                        pairs, the namespace scripts/vcan-run gives is used as it is, and its
//                        loopback gets the route (VCAN_RUN_IN uml or netns), unless this is given
//
// Network: as the LCM runner, a network namespace of the runner's own (needs root) with
// loopback up and 239.255.76.67 routed there; the DDS programs use the loopback
// configurations polyport's DDS models default to (config/cyclonedds-loopback.xml,
// config/fastdds-loopback.xml), as in the DDS runner.
// Threads: one (benchmarks/common/runner.hpp).
#include <net/if.h>

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

constexpr const char* kLcmGroup = "239.255.76.67";
// A CAN frame's data bytes in a size class: classic in the 16 B one, FD in the 1 KiB one.
int can_frame_bytes(int size) { return size == 16 ? 8 : 64; }

// What the runner needs of a model: its ping-pong program, types and wire names.
struct Model {
  std::string name;
  std::string program;
  std::string types_file;
  bool lcm;
  bool can = false;  // its components are written by can_component()
  std::string type(int size) const {
    if (lcm) return size == 16 ? "bench_lcm::ping16_t" : "bench_lcm::ping1k_t";
    return size == 16 ? "bench::Ping16" : "bench::Ping1k";
  }
  std::string ping() const { return lcm ? "PING" : "ping"; }
  std::string pong() const { return lcm ? "PONG" : "pong"; }
  // The size its ping-pong program takes for a case of `size` (16 or 1024): CAN's frame.
  int program_size(int size) const { return can ? can_frame_bytes(size) : size; }
  // Its type file for a case of `size`: CAN's 1 KiB class has its FD messages in a file of its own.
  std::string types(int size) const {
#ifdef POLYPORT_BENCH_CAN
    if (can && size != 16) return POLYPORT_BENCH_DBC_FD;
#endif
    return types_file;
  }
};

const std::vector<Model>& all_models() {
  static const std::vector<Model> models{{"cyclonedds", PINGPONG_CYCLONE, POLYPORT_BENCH_IDL, false},
                                         {"fastdds", PINGPONG_FASTDDS, POLYPORT_BENCH_IDL, false},
                                         {"lcm", PINGPONG_LCM, POLYPORT_BENCH_LCM_TYPES, true},
#ifdef POLYPORT_BENCH_CAN
                                         {"can", PINGPONG_CAN, POLYPORT_BENCH_DBC, false, true},
#endif
                                         };
  return models;
}

const Model& model_named(const std::string& name) {
  const auto& models = all_models();
  return *std::find_if(models.begin(), models.end(), [&](const Model& m) { return m.name == name; });
}

// The native relay program of two different models, which both name in its file name.
std::string relay_program(const Model& a, const Model& b) {
  const auto has = [&](const char* name) { return a.name == name || b.name == name; };
#ifdef POLYPORT_BENCH_CAN
  if (has("can")) return has("cyclonedds") ? RELAY_CAN_CYCLONE : has("fastdds") ? RELAY_CAN_FASTDDS : RELAY_CAN_LCM;
#endif
  if (has("cyclonedds") && has("lcm")) return RELAY_CYCLONE_LCM;
  if (has("fastdds") && has("lcm")) return RELAY_FASTDDS_LCM;
  return RELAY_CYCLONE_FASTDDS;
}

struct Settings {
  bench::RunOptions run;
  std::vector<std::string> models{"cyclonedds", "fastdds", "lcm"};
  std::vector<int> sizes{16, 1024};
  bool cross_only = false;
  bool can_pairs_only = false;  // --pairs can
  int domain_base = 185;
  int port_base = 7800;
  bool host_network = false;
};

// The five domains (DDS domain ids, LCM ports or vcan interface numbers) of a pair's case.
struct Domains {
  int dds, lcm, can;
  int of(const Model& m, int k) const { return (m.can ? can : m.lcm ? lcm : dds) + k; }
};

// A SocketCAN component on vcanN with ports named as the other models' ("ping": pingpong.dbc's
// Ping, id 0x100; "pong": Pong, 0x101; in the 1 KiB class pingpong_fd.dbc's, on an FD socket),
// so that the connections match by port name. The ping side's bus sends Ping and polyport
// sends it Pong; the pong side's the other way round.
std::string can_component(const std::string& name, int n, int size, bool ping_side) {
  const std::string file = size == 16 ? "pingpong::" : "pingpong_fd::";
  const auto port = [&](const char* port_name, const char* message, bool bus_sends) {
    return std::string("    <data_port><name>") + port_name + "</name><data_type>" + file + message +
           "</data_type><usage>" + (bus_sends ? "output" : "input") + "</usage></data_port>\n";
  };
  return "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<component_profile>\n  <name>" + name +
         "</name>\n  <model>socketcan</model>\n  <socketcan><interface>vcan" + std::to_string(n) + "</interface>" +
         (size == 16 ? "" : "<fd>true</fd>") + "</socketcan>\n  <ports>\n" + port("ping", "Ping", ping_side) +
         port("pong", "Pong", !ping_side) + "  </ports>\n</component_profile>\n";
}

// CAN <-> another model: pingpong.dbc's one signal seq (a double) <-> seq (unsigned or signed 64):
// narrowing into the integer (the ping programs' sequence numbers, probes included, stay below
// 2^53, where a double is exact); pad has no signal, so the other model's pad is zero
// (by_name="false") and is dropped on the way to CAN.
constexpr const char* kCanMapping =
    R"(<mapping by_name="false"><field target="seq" source="seq" allow_narrowing="true"/></mapping>)";

std::string component(const std::string& name, const Model& m, int domain, int size, bool ping_side) {
  if (m.can) return can_component(name, domain, size, ping_side);
  const std::string section = m.lcm ? "<lcm><url>udpm://" + std::string(kLcmGroup) + ":" + std::to_string(domain) +
                                          "?ttl=0</url></lcm>"
                                    : "<dds><domain>" + std::to_string(domain) + "</domain></dds>";
  return bench::pingpong_component(name, m.name, section, m.type(size), m.lcm ? "channel" : "topic",
                                   ping_side ? m.ping() : m.pong(), ping_side ? m.pong() : m.ping());
}

// polyportd's application of a case: A's ping side on `a`, B's pong side on `b`.
fs::path write_profiles(const fs::path& dir, const Model& from, const Model& to, int size, int a, int b) {
  std::vector<std::string> files{from.types(size)};
  if (to.types(size) != from.types(size)) files.push_back(to.types(size));
  const std::string mapping =
      from.can != to.can ? kCanMapping
      : from.lcm != to.lcm ? R"(<mapping><field target="seq" source="seq" allow_narrowing="true"/></mapping>)"
                           : "";
  return bench::write_pingpong_app(dir, "matrix_pingpong", files, component("PingSide", from, a, size, true),
                                   component("PongSide", to, b, size, false), "ping", "pong", mapping);
}

// The commands of a cross case: via polyportd on domains 0 (A) and 1 (B), via the relay on 2
// (A) and 3 (B); no direct path.
bench::CaseCommands cross_commands(const Model& from, const Model& to, const Domains& d, int size) {
  const std::string sz = std::to_string(size);
  const auto at = [&](const Model& m, int k) { return std::to_string(d.of(m, k)); };
  bench::CaseCommands commands;
  const std::string from_sz = std::to_string(from.program_size(size));
  const std::string to_sz = std::to_string(to.program_size(size));
  commands.via_ping = {from.program, "ping", at(from, 0), from_sz};
  commands.via_pong = {to.program, "pong", at(to, 1), to_sz};
  commands.relay_ping = {from.program, "ping", at(from, 2), from_sz};
  commands.relay_pong = {to.program, "pong", at(to, 3), to_sz};
  commands.relay = {relay_program(from, to), from.name, at(from, 2), at(to, 3), sz};
  return commands;
}

Json run_pair(const Settings& s, const Placement& placement, const Model& from, const Model& to, int size,
              const Domains& d, const fs::path& dir) {
  fs::create_directories(dir);
  const bool same = from.name == to.name;
  Json c{{"placement", placement.name},
         {"from", from.name},
         {"to", to.name},
         {"size_bytes", size},
         {"loadavg1_at_start", bench::load_average()}};
  if (from.can || to.can) c["can_frame_bytes"] = can_frame_bytes(size);
  bench::CaseCommands commands;
  if (same) {
    commands = bench::five_domain_commands(from.program, d.of(from, 0), from.program_size(size));
    commands.app = write_profiles(dir, from, to, size, d.of(from, 1), d.of(to, 2));
    c["domains"] = bench::five_domains_json(d.of(from, 0));
  } else {
    commands = cross_commands(from, to, d, size);
    commands.app = write_profiles(dir, from, to, size, d.of(from, 0), d.of(to, 1));
    c["domains"] = {{"via_ping", d.of(from, 0)}, {"via_pong", d.of(to, 1)}, {"relay_ping", d.of(from, 2)},
                    {"relay_pong", d.of(to, 3)}};
    c["relay_program"] = fs::path(commands.relay[0]).filename().string();
  }
  const std::optional<std::int64_t> worst = bench::run_case(s.run.chunking, placement, dir, commands, c);
  if (!worst) return nullptr;
  const Json targets = bench::relay_targets(c, *worst);
  if (!targets.is_null()) c["targets"] = targets;
  return c;
}

// The direct one-way p50 of `model` at `size` and `placement` from the diagonal cases of this
// run, or null.
Json direct_p50(const Json& cases, const std::string& placement, const std::string& model, int size) {
  for (const Json& c : cases) {
    if (c["placement"] == placement && c["from"] == model && c["to"] == model && c["size_bytes"] == size &&
        c.contains("direct") && c["direct"].contains("one_way_ns")) {
      return c["direct"]["one_way_ns"]["p50"];
    }
  }
  return nullptr;
}

// The second bar (issue 11, "Decisions from the DDS round"): via <= 2 x direct + 2 us for
// Cyclone DDS, LCM and CAN. On the diagonal, direct is the case's own; for a cross pair, whose
// one-way path is one hop of each model, "2 x direct" becomes direct(A) + direct(B), both from
// this run's diagonal. A bar where both models are among those three; for a pair with Fast
// DDS, reported beside the first bar but not a bar.
void add_direct_bar(Json& c, const Json& cases) {
  if (!c.contains("targets")) return;
  Json& t = c["targets"];
  const auto text = [&](const char* key) { return c[key].get<std::string>(); };
  const int size = c["size_bytes"].get<int>();
  const Json a = direct_p50(cases, text("placement"), text("from"), size);
  const Json b = direct_p50(cases, text("placement"), text("to"), size);
  if (!a.is_number() || !b.is_number()) {
    t["direct_bar"] = nullptr;
    return;
  }
  const std::int64_t bound = a.get<std::int64_t>() + b.get<std::int64_t>() + 2000;
  const std::int64_t v50 = t["via_one_way_p50_ns"].get<std::int64_t>();
  const auto bar_model = [&](const char* key) {
    return text(key) == "cyclonedds" || text(key) == "lcm" || text(key) == "can";
  };
  t["direct_bar"] = {{"from_direct_one_way_p50_ns", a},
                     {"to_direct_one_way_p50_ns", b},
                     {"bound_ns", bound},
                     {"via_within", v50 <= bound},
                     {"margin_ns", bound - v50},
                     {"is_a_bar", bar_model("from") && bar_model("to")}};
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
    } else if (arg == "--models") {
      s.models = bench::split(argv[++i]);
    } else if (arg == "--sizes") {
      s.sizes.clear();
      for (const auto& v : bench::split(argv[++i])) s.sizes.push_back(std::atoi(v.c_str()));
    } else if (arg == "--pairs") {
      const std::string pairs = argv[++i];
      if (pairs != "all" && pairs != "cross" && pairs != "can") return std::nullopt;
      s.cross_only = pairs == "cross";
      s.can_pairs_only = pairs == "can";
    } else if (arg == "--domain-base") {
      s.domain_base = std::atoi(argv[++i]);
    } else if (arg == "--port-base") {
      s.port_base = std::atoi(argv[++i]);
    } else {
      return std::nullopt;
    }
  }
  const bool sizes_ok = std::all_of(s.sizes.begin(), s.sizes.end(), [](int v) { return v == 16 || v == 1024; });
  const int pairs = static_cast<int>(s.models.size() * s.models.size());
  const bool models_ok = std::all_of(s.models.begin(), s.models.end(), [](const std::string& m) {
    const auto& all = all_models();
    return std::any_of(all.begin(), all.end(), [&](const Model& known) { return known.name == m; });
  });
  if (!s.run.finish() || !sizes_ok || s.models.empty() || !models_ok ||
      s.domain_base < 0 || s.domain_base + 5 * pairs > 232 || s.port_base < 1024 || s.port_base + 5 * pairs > 65535) {
    return std::nullopt;
  }
  return s;
}

// The pairs polyport speaks but this runner cannot measure on the host, and why.
Json not_measured() {
  return Json::array(
      {{{"pairs", "inprocess <-> every model"},
        {"reason", "an in-process component lives inside polyportd: there is no stand-alone ping or pong program of "
                   "that model, nor a native relay to set beside it; and components run periodically (onExecute), so "
                   "an in-process echo would measure its period (benchmarks/bench_inproc_connection measures the "
                   "in-process connection alone)"}}});
}

// The CAN pairs' entries of "not_measured" for a run of `s`.
Json can_not_measured(const Settings& s) {
  const bool can = std::find(s.models.begin(), s.models.end(), "can") != s.models.end();
  Json out = Json::array();
  if (!can) {
    out.push_back({{"pairs", "can <-> every model"},
                   {"reason", "the host kernel has no CAN: the CAN pairs run in the vcan guest (scripts/vcan-run), "
                              "a run of their own (scripts/bench_matrix.sh --part vcan: bench_matrix --models "
                              "can,... --pairs can), whose file report.py sets into the same table"}});
  }
  return out;
}

// The CAN pairs keep the network namespace they start in: scripts/vcan-run's guest (or private
// namespace on a kernel with vcan), where the interfaces are; moving to a new one would leave
// them behind. That namespace is the run's own, so its loopback gets the LCM group's route
// here. Elsewhere the caller gives the route and passes --host-network.
bool vcan_network() {
  const char* where = std::getenv("VCAN_RUN_IN");
  if (where == nullptr || (std::string(where) != "uml" && std::string(where) != "netns")) {
    std::fprintf(stderr,
                 "the CAN pairs run inside scripts/vcan-run (its guest or private namespace); elsewhere give %s a "
                 "route on loopback and pass --host-network\n",
                 kLcmGroup);
    return false;
  }
  const std::string setup =
      std::string("ip link set lo up && ip link set lo multicast on && ip route replace ") + kLcmGroup + "/32 dev lo";
  if (std::system(setup.c_str()) != 0) {
    std::fprintf(stderr, "cannot give loopback a multicast route (%s)\n", setup.c_str());
    return false;
  }
  return true;
}

// What a run with CAN pairs adds to the settings (over the host run's wording where it differs).
Json can_settings() {
  const char* where = std::getenv("VCAN_RUN_IN");
  const std::string in = where != nullptr ? where : "";
  return {{"where", in == "uml" ? "the vcan guest: user-mode Linux (scripts/vcan-run), one CPU, where every system "
                                  "call (each clock read too, ~15 us) is a round trip through the guest kernel "
                                  "process: all figures are inflated; compare a pair with its relay from this run"
                                : "scripts/vcan-run (" + in + ")"},
          {"vcan_run", in},
          {"network", "the namespace scripts/vcan-run gives (the guest's own), loopback routes the LCM group"},
          {"can", "pingpong_can (benchmarks/can, raw SocketCAN): in the 16 B class classic frames of 8 data bytes "
                  "(pingpong.dbc: Ping 0x100, Pong 0x101, one 64-bit signal seq), in the 1 KiB class CAN FD frames "
                  "of 64 (pingpong_fd.dbc: the same ids, seq, the rest zero); the other model's pad is not carried "
                  "(dropped on the way to CAN, zero from it), by polyport nor by the relays; sizes_bytes names the "
                  "class, can_frame_bytes the frame"},
          {"can_mapping", "CAN <-> other model: seq (a DBC double) <-> seq (64-bit integer) with allow_narrowing, "
                          "by_name=\"false\" (pad zero); the ping programs' sequence numbers, probes from 2^52 "
                          "included, are exact in a double"},
          {"can_native_relay", "relay_can_<sdk> (side_can.hpp: a raw CAN socket; the SDK's generated types)"}};
}

// Whether the run measures the pair a -> b at `size`: --pairs cross leaves out the diagonal;
// --pairs can keeps the pairs with CAN on a side and every diagonal (their direct series give
// the second bar's figures from the same run).
bool measures(const Settings& s, const std::string& a, const std::string& b) {
  const bool can = a == "can" || b == "can";
  if (s.cross_only && a == b) return false;
  return !(s.can_pairs_only && !can && a != b);
}

// The vcan interfaces a run uses: five per pair with CAN on a side (vcan0 up).
int can_interfaces(const Settings& s) {
  int n = 0;
  for (const std::string& a : s.models) {
    for (const std::string& b : s.models) {
      if ((a == "can" || b == "can") && measures(s, a, b)) n += 5;
    }
  }
  return n;
}

}  // namespace

int main(int argc, char** argv) {
  const std::optional<Settings> parsed = parse(argc, argv);
  if (!parsed) {
    std::fprintf(stderr,
                 "usage: %s OUTPUT.json [ROUNDS [WARMUP]] [--chunks N] [--placements unpinned,one-core] [--cpu N]\n"
                 "       [--models cyclonedds,fastdds,lcm,can] [--sizes 16,1024] [--pairs all|cross|can] [--domain-base N]\n"
                 "       [--port-base N] [--host-network] [--keep DIR]\n",
                 argv[0]);
    return 2;
  }
  const Settings& s = *parsed;
  const int interfaces = can_interfaces(s);
  if (interfaces > 0 && if_nametoindex(("vcan" + std::to_string(interfaces - 1)).c_str()) == 0) {
    std::fprintf(stderr, "vcan%d does not exist: the CAN pairs run through scripts/vcan-run --interfaces %d\n",
                 interfaces - 1, interfaces);
    return 1;
  }
  if (interfaces > 0 && std::find(s.sizes.begin(), s.sizes.end(), 1024) != s.sizes.end() &&
      bench::read_file("/sys/class/net/vcan0/mtu").rfind("72", 0) != 0) {
    std::fprintf(stderr, "the CAN pairs of 1 KiB send CAN FD frames: run through scripts/vcan-run --fd\n");
    return 1;
  }
  if (!s.host_network &&
      !(interfaces > 0 ? vcan_network() : bench::private_network(std::string(kLcmGroup) + "/32"))) {
    return 1;
  }
  bench::forward_stop_signals();
  setenv("CYCLONEDDS_URI", "file://" POLYPORT_SOURCE_DIR "/config/cyclonedds-loopback.xml", 1);
  setenv("FASTRTPS_DEFAULT_PROFILES_FILE", POLYPORT_SOURCE_DIR "/config/fastdds-loopback.xml", 1);
  const fs::path dir = bench::work_dir(s.run.keep, "matrix");

  const auto t_start = std::chrono::steady_clock::now();
  Json result = bench::result_header("matrix");
  Json settings = bench::shared_settings(s.run);
  settings.update(
      {{"sizes_bytes", s.sizes},
       {"models", s.models},
       {"pairs", s.cross_only ? "cross" : s.can_pairs_only ? "can" : "all"},
       {"ping_pong_programs", "the same-model benchmarks' (benchmarks/dds, benchmarks/lcm): ping of the row's model, "
                              "pong of the column's"},
       {"native_relay", "diagonal: the SDK's own relay program; cross: relay_<sdk>_<sdk> (both SDKs, their generated "
                        "types, field by field)"},
       {"mapping", "DDS <-> LCM: seq unsigned 64 <-> signed 64 with allow_narrowing; pad by name"},
       {"network", s.host_network ? "the host's" : "a private namespace, loopback routes the LCM group"},
       {"cpu_per_message", "the bridging process's CPU per round trip / 2 (each round trip passes it twice)"},
       {"bars", "via one-way p50 <= relay one-way p50 + 2 us (every pair, same case); via one-way p50 <= "
                "direct(A) + direct(B) + 2 us (2 x direct on the diagonal) for pairs of Cyclone DDS, LCM and CAN, "
                "reported for Fast DDS"}});
  if (interfaces > 0) settings.update(can_settings());
  result["settings"] = settings;
  result["not_measured"] = not_measured();
  for (Json& entry : can_not_measured(s)) result["not_measured"].push_back(std::move(entry));
  result["cases"] = Json::array();

  bool all_ok = true;
  for (const std::string& placement_name : s.run.placements) {
    const Placement placement = s.run.placement(placement_name);
    int pair = 0;
    int can_pair = 0;
    for (const std::string& a : s.models) {
      for (const std::string& b : s.models) {
        const bool can = (a == "can" || b == "can") && measures(s, a, b);
        const Domains d{s.domain_base + 5 * pair, s.port_base + 5 * pair, can ? 5 * can_pair++ : 0};
        ++pair;
        for (const int size : s.sizes) {
          if (!measures(s, a, b)) continue;
          if (bench::interrupted()) break;
          std::fprintf(stderr, "%s %s -> %s %d B ...\n", placement.name.c_str(), a.c_str(), b.c_str(), size);
          const std::string name = placement.name + "-" + a + "-" + b + "-" + std::to_string(size);
          Json c = run_pair(s, placement, model_named(a), model_named(b), size, d, dir / name);
          if (c.is_null()) break;
          all_ok = all_ok && c.contains("targets");
          bench::print_case(c, a + "->" + b, bench::relay_verdicts(c));
          result["cases"].push_back(std::move(c));
        }
      }
    }
  }
  for (Json& c : result["cases"]) add_direct_bar(c, result["cases"]);
  return bench::end_run(result, s.run.output, dir, !s.run.keep.empty(), all_ok, t_start);
}
