// What the ping-pong benchmark runners (benchmarks/dds, benchmarks/lcm, benchmarks/can) share:
// their children (fork/exec with PR_SET_PDEATHSIG, stopped on SIGINT / SIGTERM / SIGHUP to the
// runner), the three series of a case (direct, via polyportd, via a native relay) run in chunks
// that take turns, the pooled percentiles, the CPU time per round trip the ping reads
// (pingpong_common.hpp), polyport's own in-to-out time from its statistics, and the result
// file's host fields. Each runner keeps what is its own: the programs, the profiles, the
// targets and the command line.
//
// Every ping program takes `ping DOMAIN SIZE ROUNDS WARMUP SAMPLES` and prints one JSON line
// (pingpong_common.hpp); DOMAIN is whatever keeps the series apart (a DDS domain, an LCM
// provider, a vcan interface).
//
// Threads: one, the runner's main thread; the signal handler only kill()s the live children.
#pragma once

#include <sys/types.h>

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <initializer_list>
#include <optional>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace bench {

namespace fs = std::filesystem;
using Json = nlohmann::json;

// SIGINT, SIGTERM and SIGHUP to the runner are forwarded to its live children and make
// interrupted() true.
void forward_stop_signals();
bool interrupted();

struct Placement {
  std::string name;
  int cpu = -1;  // -1: unpinned
};

// Starts `args` with stdout in `out` and stderr in `out`.err, pinned as `placement` says; -1
// when it could not start.
pid_t spawn(const std::vector<std::string>& args, const fs::path& out, const Placement& placement);

// Sends `signal_number` (0: none), waits at most `seconds` for the exit, then kills. Returns the
// exit code, -1 when killed by a signal or when it had to be killed.
int finish(pid_t pid, int signal_number, int seconds);

std::string read_file(const fs::path& file);

// n, min, mean, p50, p90, p99, p999, max and a 1-2-5 histogram (nanoseconds); percentiles as
// the ping programs take them.
Json summary(std::vector<std::int64_t> v);

// A process whose CPU time the ping reads over its measured round trips.
struct Watched {
  std::string role;  // "pong", "polyportd", "relay"
  pid_t pid;
};

// One series of a case: the pooled round trips of its chunks.
struct Series {
  std::vector<std::int64_t> rtt;
  std::vector<std::int64_t> write;  // the ping's write call of each round trip
  std::vector<std::int64_t> chunk_p50_one_way;
  int lost = 0;
  std::string error;
  // CPU time of the measured round trips, per process of the path (cpu_roles: "ping", then
  // the watched processes), summed over chunks; -1 once any chunk could not read it.
  std::vector<std::string> cpu_roles;
  std::vector<std::int64_t> cpu_ns;

  Json to_json(int chunks) const;
};

// One path of a case: its ping's command up to its size (`PROGRAM ping DOMAIN SIZE`; the
// runner adds ROUNDS WARMUP SAMPLES) and the processes on it.
struct Path {
  std::string tag;  // "direct", "via", "relay": names the chunk files
  std::vector<std::string> ping;
  std::vector<Watched> watched;
  Series series;
};

struct Chunking {
  int rounds = 10000;  // measured round trips per series, over all chunks
  int warmup = 1000;   // per chunk
  int chunks = 6;
  int per_chunk() const { return (rounds + chunks - 1) / chunks; }
};

// `chunking.chunks` ping processes per path, the paths taking turns (and turns at going
// first): a change of the machine's load during a case then falls on all of them alike.
// Files go to `dir`; stops early once interrupted().
void run_interleaved(const Chunking& chunking, const Placement& placement, const fs::path& dir,
                     std::vector<Path>& paths);

// The programs of one case. The pongs, polyportd and the relay stay up for the whole case;
// idle, they only wait on their readers.
struct CaseCommands {
  std::vector<std::string> direct_ping, via_ping, relay_ping;  // PROGRAM ping DOMAIN SIZE
  std::vector<std::string> direct_pong, via_pong, relay_pong;  // PROGRAM pong DOMAIN SIZE
  std::vector<std::string> relay;                              // e.g. PROGRAM relay DOMAIN_A DOMAIN_B SIZE
  fs::path app;                                                // polyportd's application profile
};

// The commands of a case of `program` (pingpong_common.hpp's command line) on five
// consecutive domains from `first`: direct on first, via polyportd first+1 (ping) -> first+2
// (pong), via the relay first+3 -> first+4. Sets no application profile.
CaseCommands five_domain_commands(const std::string& program, int first, int size);
// Which domain each of them is on, for the result file.
Json five_domains_json(int first);

// The via-polyport application in `dir`: component profiles PingSide.xml (the ping's side,
// text `ping_side`) and PongSide.xml (`pong_side`) as subcomponents a and b, the types of
// `types_file`, and two connections, a.`ping_port` -> b.`ping_port` and b.`pong_port` ->
// a.`pong_port`. Returns app.xml's path.
fs::path write_pingpong_app(const fs::path& dir, const std::string& name, const std::string& types_file,
                            const std::string& ping_side, const std::string& pong_side, const std::string& ping_port,
                            const std::string& pong_port);
// The same with the types of several files and `mapping` (a <mapping> element, or empty) on
// both connections: the application of two models whose types differ.
fs::path write_pingpong_app(const fs::path& dir, const std::string& name, const std::vector<std::string>& types_files,
                            const std::string& ping_side, const std::string& pong_side, const std::string& ping_port,
                            const std::string& pong_port, const std::string& mapping);

// A component profile of the ping-pong benchmarks: `model` with its section `section` (e.g.
// <dds><domain>3</domain></dds>) and two data ports of `type` on the topics or channels
// (`wire`: "topic" or "channel") `app_publishes` (an output: the application publishes,
// polyport reads) and `polyport_publishes` (an input). Each port is named after its topic or
// channel in lower case ("PING": ping), so that two models' components connect by port name.
std::string pingpong_component(const std::string& name, const std::string& model, const std::string& section,
                               const std::string& type, const std::string& wire, const std::string& app_publishes,
                               const std::string& polyport_publishes);

// Moves the runner into a network namespace of its own (needs root) with loopback up and
// multicast routed there for `group` (an address or a prefix such as 224.0.0.0/4); its
// children inherit it, and it disappears with the runner. False (after saying why) when it
// cannot.
bool private_network(const std::string& group);

// Runs a case in `dir`: the three series interleaved, then polyportd stopped (SIGINT) for its
// statistics. Fills c["direct"], c["via_polyport"], c["via_native_relay"] and polyport's own
// figures (read_polyport_stats); returns the worst in-to-out p99 (-1 without statistics), or
// nullopt when interrupted. Without direct_ping (two models: no direct path) there is no
// direct series and no c["direct"].
std::optional<std::int64_t> run_case(const Chunking& chunking, const Placement& placement, const fs::path& dir,
                                     const CaseCommands& commands, Json& c);

// Fills c["polyport"] (per connection: counts, in_to_out_ns = its latency histogram,
// sdk_write_ns = its sink time) and c["polyport_version"] from polyportd's --stats-json file,
// or c["polyport_error"] when polyportd did not exit cleanly (`daemon_rc`, its stderr in
// `daemon_err`). Returns the worst in-to-out p99 over the connections, -1 without statistics.
std::int64_t read_polyport_stats(const fs::path& stats_file, int daemon_rc, const fs::path& daemon_err, Json& c);

// The targets of the LCM and CAN benchmarks (issue 10), from a case holding "direct",
// "via_polyport", "via_native_relay" (Series::to_json) and "polyport": via polyport one-way
// p50 <= relay one-way p50 + 2 us; polyport's in-to-out p99 <= 1 us; polyportd's CPU time
// per round trip <= the relay's. Null when a series or the statistics are missing.
Json relay_targets(const Json& c, std::int64_t worst_in_to_out_p99);

// Whether one run decides "via <= relay + allowance at the median". The chunks of the via
// and relay series alternate (run_interleaved), chunk i of each side by side in time, so
// d_i = via p50 - relay p50 of chunk i (one_way_p50_per_chunk_ns) leaves out what moves the
// whole machine between chunks. Returns their median and a distribution-free interval for
// it: the sign test's d_(k) .. d_(n+1-k) of the sorted d, k the largest with
// 2 P(Bin(n, 1/2) < k) <= 5 % (at least 95 % confidence), or k = 1 below six chunks (then
// the confidence is 1 - 2^(1-n), reported as it is). The verdict: "holds" when the interval
// lies at or under `allowance_ns`, "misses" when it lies above, else "undecided" (more chunks
// or rounds would decide it). Null when either series has no chunks or their counts differ.
Json paired_chunks(const Json& via, const Json& relay, std::int64_t allowance_ns);

// The command line every runner takes: OUTPUT.json [ROUNDS [WARMUP]], and the options
// --chunks N, --placements LIST (unpinned,one-core), --cpu N (one-core's core), --keep DIR.
struct RunOptions {
  std::string output;
  Chunking chunking;
  std::vector<std::string> placements{"unpinned", "one-core"};
  int cpu = 0;
  std::string keep;
  std::vector<std::string> positional;

  // Takes argv[i] (and its value, advancing i) when it is one of the options above or a
  // positional argument; false when it is not (the runner's own option, or a missing value).
  bool take(int argc, char** argv, int& i);
  // Checks what was taken and sets output, rounds and warmup; false when something is wrong.
  bool finish();
  Placement placement(const std::string& name) const { return {name, name == "one-core" ? cpu : -1}; }
};

// The settings every runner reports: the chunking, the placements, and what one-way, the CPU
// time per round trip and polyport's histograms mean.
Json shared_settings(const RunOptions& run);

double load_average();
std::vector<std::string> split(const std::string& list);
// Every item of `got` is one of `allowed`.
bool all_known(const std::vector<std::string>& got, std::initializer_list<const char*> allowed);
std::string utc_now();
std::string ns_to_us(const Json& v);

// "benchmark", "started_utc", "git_revision" (POLYPORT_GIT_REVISION) and "host" (nproc, cpu,
// uname, load averages; in a guest also POLYPORT_BENCH_OUTER_HOST, the machine it runs on) of a
// result file.
Json result_header(const std::string& benchmark);


// One line on stderr per case: p50/p99 one-way of the three series, polyport's in-to-out
// p50/p99 per connection, CPU per round trip of each series, `verdicts` (the runner's targets).
void print_case(const Json& c, const std::string& label, const std::string& verdicts);

// relay_targets' verdicts as print_case shows them ("n/a" without targets).
std::string relay_verdicts(const Json& c);

// The directory of a run's files: `keep`, else a fresh one under the temporary directory.
fs::path work_dir(const std::string& keep, const std::string& benchmark);

// Ends a run: when interrupted, writes nothing (130); else adds the end load and the duration,
// writes `result` to `output` and says where (1 when it cannot). Removes `dir` unless kept.
// 0 when every case has its targets, else 1.
int end_run(Json& result, const std::string& output, const fs::path& dir, bool keep, bool all_cases_have_targets,
            std::chrono::steady_clock::time_point started);

}  // namespace bench
