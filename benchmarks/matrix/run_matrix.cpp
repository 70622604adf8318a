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
// The in-process model ("inprocess", --models): a component inside polyportd has no program of
// its own. X -> inprocess is X's ping program against the in-process pong of
// benchmarks/matrix/inproc_pingpong.cpp (a passive component answering from its
// CallbackInPort, on X's receive thread in polyportd), beside X's own pong program in the same
// run (direct X <-> X, the chunks taking turns as in run_case); there is no native relay to set
// beside it (the component lives inside the bridge), so its bar is via one-way p50 <=
// direct(X) + 2 us. inprocess -> X is the in-process ping (inproc_pingpong.cpp: it sends the
// next ping from the callback that takes the pong, and writes its percentiles to a file)
// against X's pong program, with the same bar (each chunk of the ping's series is a polyportd
// run of its own, taking turns with X's direct chunks). The in-process diagonal is the ping
// and the pong inside one polyportd, the whole
// round trip on the ping's thread (the pong answers inside the ping's write): polyport's own
// figure, with nothing to set beside it.
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
// --interfaces 35, and 45 with inprocess too. CAN <-> inprocess: the in-process ping or pong's
// ports take the IDL type (bench::Ping16 / Ping1k, the flat layout inproc_pingpong.cpp reads),
// joined to the CAN side's messages with kCanMapping, against pingpong_can's direct series.
//
//   bench_matrix OUTPUT.json [ROUNDS [WARMUP]] [options]      (scripts/bench_matrix.sh)
//     --chunks N, --placements LIST, --cpu N, --keep DIR   as the same-model runners
//                        (benchmarks/common/runner.hpp RunOptions)
//     --models LIST      cyclonedds,fastdds,lcm,inprocess,can (default: the first four; can
//                        where the SocketCAN model is built, and only with vcan interfaces,
//                        see above)
//     --sizes LIST       16,1024 (default: both)
//     --pairs all|cross|can  cross: leave out the diagonal; can: the pairs with CAN on a side
//                        and every diagonal but the in-process one (the direct figures of the
//                        second bar, from the same run: the vcan guest's figures are its own)
//                        (default: all)
//     --domain-base N    first DDS domain; each pair takes 5 (default 150)
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
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
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
  std::vector<std::string> models{"cyclonedds", "fastdds", "lcm", "inprocess"};
  std::vector<int> sizes{16, 1024};
  bool cross_only = false;
  bool can_pairs_only = false;  // --pairs can
  int domain_base = 150;
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

// The types files of an application joining a component of `a` to one of `b`, each once.
std::vector<std::string> types_files(const Model& a, const Model& b, int size) {
  std::vector<std::string> files{a.types(size)};
  if (b.types(size) != a.types(size)) files.push_back(b.types(size));
  return files;
}

// polyportd's application of a case: A's ping side on `a`, B's pong side on `b`.
fs::path write_profiles(const fs::path& dir, const Model& from, const Model& to, int size, int a, int b) {
  const std::vector<std::string> files = types_files(from, to, size);
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

constexpr const char* kInprocess = "inprocess";

// The model whose type the in-process ping or pong takes on its ports when it talks to `x`:
// x's own, so that nothing maps, except CAN's, whose messages carry doubles (a DBC signal) where
// the in-process layout has a 64-bit integer and padding: there the IDL type, with kCanMapping.
const Model& inproc_side(const Model& x) { return x.can ? model_named("cyclonedds") : x; }

// The mapping of the connections between `x`'s component and an in-process one that takes
// inproc_side(x)'s type.
std::string inproc_mapping(const Model& x) { return x.can ? kCanMapping : ""; }

// The in-process pong's component profile, its ports of `side`'s type (so that polyport
// converts between side's wire format and the flat sample, and nothing maps).
std::string inproc_pong_component(const Model& side, int size) {
  const auto port = [&](const char* name, const char* usage) {
    return std::string("    <data_port><name>") + name + "</name><data_type>" + side.type(size) + "</data_type><usage>" +
           usage + "</usage></data_port>\n";
  };
  return "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<component_profile>\n  <name>InprocPong</name>\n"
         "  <model>inproc</model>\n  <execution_environment><library_type>so</library_type><library_name>" INPROC_PINGPONG
         "</library_name><class_name>" +
         std::string(size == 16 ? "Pong16" : "Pong1k") +
         "</class_name></execution_environment>\n  <execution_semantics><type>passive</type></execution_semantics>\n"
         "  <ports>\n" +
         port("ping", "input") + port("pong", "output") + "  </ports>\n</component_profile>\n";
}

// X -> inprocess: X's ping program on domain 1 through polyportd to the in-process pong, and
// X's own ping and pong programs on domain 0 (direct), the two series' chunks taking turns.
Json run_into_inprocess(const Settings& s, const Placement& placement, const Model& from, int size,
                        const Domains& d, const fs::path& dir) {
  fs::create_directories(dir);
  Json c{{"placement", placement.name},
         {"from", from.name},
         {"to", kInprocess},
         {"size_bytes", size},
         {"loadavg1_at_start", bench::load_average()},
         {"domains", {{"direct", d.of(from, 0)}, {"via_ping", d.of(from, 1)}}},
         {"pong", std::string("in-process component ") + (size == 16 ? "Pong16" : "Pong1k") +
                      " (benchmarks/matrix/inproc_pingpong.cpp): passive, answers from its CallbackInPort on " +
                      from.name + "'s receive thread in polyportd"},
         {"native_relay", "none: an in-process component lives inside the bridge; the comparison is direct " +
                              from.name + " <-> " + from.name + " (its own ping and pong programs), in this run"}};
  if (from.can) c["can_frame_bytes"] = can_frame_bytes(size);
  const std::string sz = std::to_string(from.program_size(size));
  const auto at = [&](int k) { return std::to_string(d.of(from, k)); };
  const fs::path app = bench::write_pingpong_app(dir, "matrix_inprocess", types_files(from, inproc_side(from), size),
                                                 component("PingSide", from, d.of(from, 1), size, true),
                                                 inproc_pong_component(inproc_side(from), size), "ping", "pong",
                                                 inproc_mapping(from));
  const fs::path stats_file = dir / "polyport-stats.json";
  const pid_t direct_pong = bench::spawn({from.program, "pong", at(0), sz}, dir / "pong-direct.out", placement);
  const pid_t daemon = bench::spawn({POLYPORTD, "run", app.string(), "-q", "--stats-json", stats_file.string()},
                                    dir / "polyportd.out", placement);
  std::vector<bench::Path> paths{{"direct", {from.program, "ping", at(0), sz}, {{"pong", direct_pong}}, {}},
                                 {"via", {from.program, "ping", at(1), sz}, {{"polyportd", daemon}}, {}}};
  bench::run_interleaved(s.run.chunking, placement, dir, paths);
  bench::finish(direct_pong, SIGTERM, 10);
  const int daemon_rc = bench::finish(daemon, SIGINT, 20);
  if (bench::interrupted()) return nullptr;
  c["direct"] = paths[0].series.to_json(s.run.chunking.chunks);
  c["via_polyport"] = paths[1].series.to_json(s.run.chunking.chunks);
  const std::int64_t worst = bench::read_polyport_stats(stats_file, daemon_rc, dir / "polyportd.out.err", c);
  const auto has = [&](const char* series) { return c[series].contains("one_way_ns"); };
  if (worst < 0 || !has("direct") || !has("via_polyport")) return c;  // no targets: the case failed
  const std::int64_t v50 = c["via_polyport"]["one_way_ns"]["p50"].get<std::int64_t>();
  const std::int64_t d50 = c["direct"]["one_way_ns"]["p50"].get<std::int64_t>();
  c["targets"] = {{"via_one_way_p50_ns", v50},
                  {"direct_one_way_p50_ns", d50},
                  {"bound_direct_plus_2us_ns", d50 + 2000},
                  {"via_within_direct_plus_2us", v50 <= d50 + 2000},
                  {"via_margin_ns", d50 + 2000 - v50},
                  {"polyport_in_to_out_p99_ns", worst},
                  {"in_to_out_p99_within_1us", worst <= 1000}};
  return c;
}

// The in-process ping's component profile: periodic (10 ms: it only starts the run and gives
// lost rounds up), its ports of `side`'s type; it writes its report and samples into `dir`.
std::string inproc_ping_component(const Model& side, int size, const bench::Chunking& chunking, const fs::path& dir) {
  const auto port = [&](const char* name, const char* usage) {
    return std::string("    <data_port><name>") + name + "</name><data_type>" + side.type(size) + "</data_type><usage>" +
           usage + "</usage></data_port>\n";
  };
  const auto property = [](const char* name, const std::string& value) {
    return std::string("    <property name=\"") + name + "\">" + value + "</property>\n";
  };
  return "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<component_profile>\n  <name>InprocPing</name>\n"
         "  <model>inproc</model>\n  <execution_environment><library_type>so</library_type><library_name>" INPROC_PINGPONG
         "</library_name><class_name>" +
         std::string(size == 16 ? "Ping16Comp" : "Ping1kComp") +
         "</class_name></execution_environment>\n"
         "  <execution_semantics><type>periodic</type><period>10</period></execution_semantics>\n  <properties>\n" +
         property("rounds", std::to_string(chunking.rounds)) + property("warmup", std::to_string(chunking.warmup)) +
         property("report", (dir / "ping-via.json").string()) + property("samples", (dir / "ping-via.samples").string()) +
         "  </properties>\n  <ports>\n" + port("ping", "output") + port("pong", "input") + "  </ports>\n</component_profile>\n";
}

// One run of the in-process ping (a polyportd of its own, in `dir`): its samples, lost rounds
// and CPU times added to `via`. The daemon's exit code, or -1 when the ping wrote no report.
int run_inproc_ping(const fs::path& app, const fs::path& dir, const Placement& placement, pid_t pong, int rounds,
                    int warmup, bench::Series& via) {
  // The ping's CPU clocks: polyportd's own (the ping runs there), then the pong program's.
  if (pong > 0) setenv("POLYPORT_BENCH_CPU_PIDS", std::to_string(pong).c_str(), 1);
  const fs::path stats_file = dir / "polyport-stats.json";
  const pid_t daemon = bench::spawn({POLYPORTD, "run", app.string(), "-q", "--stats-json", stats_file.string()},
                                    dir / "polyportd.out", placement);
  unsetenv("POLYPORT_BENCH_CPU_PIDS");
  // The run ends when the ping has written its report; a lost pong costs it a second.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60 + (rounds + warmup) / 100);
  while (!fs::exists(dir / "ping-via.json") && std::chrono::steady_clock::now() < deadline && !bench::interrupted()) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(50));  // the file is written whole, then closed
  const int daemon_rc = bench::finish(daemon, SIGINT, 20);
  const Json report = Json::parse(bench::read_file(dir / "ping-via.json"), nullptr, false);
  if (report.is_discarded() || !report.contains("one_way_ns")) {
    if (via.error.empty()) {
      via.error = "the in-process ping wrote no report (polyportd: " + bench::read_file(dir / "polyportd.out.err") + ")";
    }
    return -1;
  }
  std::istringstream samples(bench::read_file(dir / "ping-via.samples"));
  for (std::int64_t rtt = 0, write = 0; samples >> rtt >> write;) via.rtt.push_back(rtt);
  via.write.assign(via.rtt.size(), 0);
  via.lost += report.value("lost", 0);
  via.chunk_p50_one_way.push_back(report["one_way_ns"].value("p50", std::int64_t{0}));
  if (via.cpu_roles.empty()) {
    via.cpu_roles = pong > 0 ? std::vector<std::string>{"polyportd", "pong"} : std::vector<std::string>{"polyportd"};
    via.cpu_ns.assign(via.cpu_roles.size(), 0);
  }
  const Json cpu = report.value("cpu_ns", Json::array());
  for (std::size_t i = 0; i < via.cpu_ns.size(); ++i) {
    const std::int64_t spent = i < cpu.size() && cpu[i].is_number_integer() ? cpu[i].get<std::int64_t>() : -1;
    via.cpu_ns[i] = spent < 0 || via.cpu_ns[i] < 0 ? -1 : via.cpu_ns[i] + spent;
  }
  return daemon_rc;
}

// inprocess -> X (X's pong program on domain 1, X's direct series on domain 0) and inprocess ->
// inprocess (`to` null: the in-process pong, same polyportd). The in-process ping is not a
// program: each chunk of its series is one polyportd run (ping warm-up, then its share of the
// round trips), taking turns with the direct series' chunks as run_case's series do.
// polyport's own figures are the last chunk's polyportd's.
Json run_from_inprocess(const Settings& s, const Placement& placement, const Model* to, int size, const Domains& d,
                        const fs::path& dir) {
  fs::create_directories(dir);
  // The in-process ping's type: the diagonal's (and CAN's partner's) is the IDL type.
  const Model& side = to ? inproc_side(*to) : model_named("cyclonedds");
  const bench::Chunking& chunking = s.run.chunking;
  const bench::Chunking one_chunk{chunking.per_chunk(), chunking.warmup, 1};
  Json c{{"placement", placement.name},
         {"from", kInprocess},
         {"to", to ? to->name : kInprocess},
         {"size_bytes", size},
         {"loadavg1_at_start", bench::load_average()},
         {"ping", std::string("in-process component ") + (size == 16 ? "Ping16Comp" : "Ping1kComp") +
                      " (benchmarks/matrix/inproc_pingpong.cpp), one polyportd run per chunk"},
         {"native_relay", "none: an in-process component lives inside the bridge"},
         {"polyport_figures", "the last chunk's polyportd"}};
  const std::string sz = std::to_string(to ? to->program_size(size) : size);
  const auto at = [&](int k) { return std::to_string(d.of(to ? *to : side, k)); };
  if (to && to->can) c["can_frame_bytes"] = can_frame_bytes(size);
  if (to) {
    c["domains"] = {{"direct", d.of(*to, 0)}, {"via_pong", d.of(*to, 1)}};
    c["comparison"] = "direct " + to->name + " <-> " + to->name + " (its own ping and pong programs), this case";
  } else {
    c["comparison"] = "none: ping and pong are both inside polyportd";
  }
  const pid_t direct_pong = to ? bench::spawn({to->program, "pong", at(0), sz}, dir / "pong-direct.out", placement) : -1;
  const pid_t via_pong = to ? bench::spawn({to->program, "pong", at(1), sz}, dir / "pong-via.out", placement) : -1;
  std::vector<bench::Path> direct;
  if (to) direct.push_back({"direct", {to->program, "ping", at(0), sz}, {{"pong", direct_pong}}, {}});
  bench::Series via;
  int daemon_rc = -1;
  fs::path last_chunk;
  for (int k = 0; k < chunking.chunks && !bench::interrupted(); ++k) {
    last_chunk = dir / ("chunk-" + std::to_string(k));
    fs::create_directories(last_chunk);
    const std::string ping_side = inproc_ping_component(side, size, one_chunk, last_chunk);
    const fs::path app =
        to ? bench::write_pingpong_app(last_chunk, "matrix_inprocess", types_files(*to, side, size), ping_side,
                                       component("PongSide", *to, d.of(*to, 1), size, false), "ping", "pong",
                                       inproc_mapping(*to))
           : bench::write_pingpong_app(last_chunk, "matrix_inprocess", side.types_file, ping_side,
                                       inproc_pong_component(side, size), "ping", "pong");
    // Taking turns at going first, as run_interleaved does.
    if (k % 2 == 1 && to) bench::run_interleaved(one_chunk, placement, last_chunk, direct);
    daemon_rc = run_inproc_ping(app, last_chunk, placement, via_pong, one_chunk.rounds, one_chunk.warmup, via);
    if (k % 2 == 0 && to) bench::run_interleaved(one_chunk, placement, last_chunk, direct);
  }
  for (const pid_t pid : {direct_pong, via_pong}) {
    if (pid > 0) bench::finish(pid, SIGTERM, 10);
  }
  if (bench::interrupted()) return nullptr;

  if (to) c["direct"] = direct[0].series.to_json(chunking.chunks);
  c["via_polyport"] = via.to_json(chunking.chunks);
  c["via_polyport"].erase("ping_write_ns");  // the in-process ping's write holds an in-process pong's answer
  const std::int64_t worst =
      bench::read_polyport_stats(last_chunk / "polyport-stats.json", daemon_rc, last_chunk / "polyportd.out.err", c);
  if (worst < 0 || !c["via_polyport"].contains("one_way_ns")) return c;  // no targets: the case failed
  const std::int64_t v50 = c["via_polyport"]["one_way_ns"]["p50"].get<std::int64_t>();
  c["targets"] = {{"via_one_way_p50_ns", v50},
                  {"polyport_in_to_out_p99_ns", worst},
                  {"in_to_out_p99_within_1us", worst <= 1000}};
  if (to && c["direct"].contains("one_way_ns")) {
    const std::int64_t d50 = c["direct"]["one_way_ns"]["p50"].get<std::int64_t>();
    c["targets"].update({{"direct_one_way_p50_ns", d50},
                         {"bound_direct_plus_2us_ns", d50 + 2000},
                         {"via_within_direct_plus_2us", v50 <= d50 + 2000},
                         {"via_margin_ns", d50 + 2000 - v50}});
  }
  return c;
}

std::string inprocess_verdicts(const Json& c) {
  const Json t = c.value("targets", Json::object());
  if (t.empty()) return "targets n/a";
  const auto verdict = [&](const char* key) {
    return t.contains(key) && t[key].is_boolean() ? (t[key].get<bool>() ? "ok" : "MISS") : "n/a";
  };
  return std::string("via <= direct + 2 us ") + verdict("via_within_direct_plus_2us") + "  in-to-out p99 <= 1 us " +
         verdict("in_to_out_p99_within_1us");
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
    return m == kInprocess || std::any_of(all.begin(), all.end(), [&](const Model& known) { return known.name == m; });
  });
  if (!s.run.finish() || !sizes_ok || s.models.empty() || !models_ok ||
      s.domain_base < 0 || s.domain_base + 5 * pairs > 232 || s.port_base < 1024 || s.port_base + 5 * pairs > 65535) {
    return std::nullopt;
  }
  return s;
}


// The pairs polyport speaks but a run of `s` does not measure, and why: the CAN pairs on the
// host.
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
// --pairs can keeps the pairs with CAN on a side and every diagonal but the in-process one
// (their direct series give the second bar's figures from the same run).
bool measures(const Settings& s, const std::string& a, const std::string& b) {
  const bool can = a == "can" || b == "can";
  if (s.cross_only && a == b) return false;
  // --pairs can: the in-process diagonal has no direct series to give (and is the host's).
  if (s.can_pairs_only && a == kInprocess && b == kInprocess) return false;
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
                 "       [--models cyclonedds,fastdds,lcm,inprocess,can] [--sizes 16,1024] [--pairs all|cross|can]\n"
                 "       [--domain-base N] [--port-base N] [--host-network] [--keep DIR]\n",
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
                "reported for Fast DDS; X -> inprocess and inprocess -> X: via one-way p50 <= direct(X) + 2 us (same "
                "case); inprocess -> inprocess: none (polyport's own figure)"}});
  if (interfaces > 0) settings.update(can_settings());
  result["settings"] = settings;
  result["not_measured"] = can_not_measured(s);
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
          const bool inprocess = a == kInprocess || b == kInprocess;
          Json c = a == kInprocess ? run_from_inprocess(s, placement, b == kInprocess ? nullptr : &model_named(b), size, d,
                                                        dir / name)
                   : b == kInprocess ? run_into_inprocess(s, placement, model_named(a), size, d, dir / name)
                                     : run_pair(s, placement, model_named(a), model_named(b), size, d, dir / name);
          if (c.is_null()) break;
          all_ok = all_ok && c.contains("targets");
          bench::print_case(c, a + "->" + b, inprocess ? inprocess_verdicts(c) : bench::relay_verdicts(c));
          result["cases"].push_back(std::move(c));
        }
      }
    }
  }
  for (Json& c : result["cases"]) {
    if (c["from"] != kInprocess && c["to"] != kInprocess) add_direct_bar(c, result["cases"]);  // inprocess: its own
  }
  return bench::end_run(result, s.run.output, dir, !s.run.keep.empty(), all_ok, t_start);
}
