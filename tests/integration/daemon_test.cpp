// The real polyportd binary on the shipped profiles: run, signals, statistics, traces,
// and the checks that refuse a broken profile.
#include <gtest/gtest.h>
#include <signal.h>
#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

extern char** environ;

namespace {

namespace fs = std::filesystem;

struct Process {
  pid_t pid = -1;
  fs::path err;
};

fs::path scratch(const std::string& name) {
  fs::path dir = fs::temp_directory_path() / ("polyport-test-" + std::to_string(getpid()));
  fs::create_directories(dir);
  return dir / name;
}

Process spawn(std::vector<std::string> args, const std::string& tag) {
  args.insert(args.begin(), POLYPORTD);
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  Process p;
  p.err = scratch(tag + ".stderr");
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 2, p.err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_addopen(&actions, 1, scratch(tag + ".stdout").c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn(&p.pid, argv[0], &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  return p;
}

int wait_exit(const Process& p) {
  int status = 0;
  waitpid(p.pid, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

std::string slurp(const fs::path& file) {
  std::ifstream in(file);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

std::vector<nlohmann::json> trace_lines(const fs::path& file) {
  std::vector<nlohmann::json> out;
  std::ifstream in(file);
  std::string line;
  while (std::getline(in, line)) {
    auto j = nlohmann::json::parse(line, nullptr, false);
    if (!j.is_discarded()) out.push_back(std::move(j));
  }
  return out;
}

const std::string kDefaultProfile = POLYPORT_SOURCE_DIR "/profiles/wheelchair_inproc.xml";

// The default application for just over 5 s of simulated time, stopped with SIGINT.
class WheelchairRun : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    stats_file = scratch("stats.json");
    trace_file = scratch("trace.jsonl");
    Process p = spawn({"run", kDefaultProfile, "--stats-json", stats_file, "--trace", "HW.wheel_speeds",
                       "--trace-file", trace_file, "--stats-interval", "1"},
                      "wheelchair");
    // Wait for the simulation clock (HW's time_s in the trace) to pass 5 s: a condition,
    // with a generous deadline for a loaded machine.
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
    double sim_time = 0;
    while (sim_time < 5.05 && std::chrono::steady_clock::now() < deadline) {
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
      auto lines = trace_lines(trace_file);
      if (!lines.empty()) sim_time = lines.back()["value"]["time_s"].get<double>();
    }
    kill(p.pid, SIGINT);
    exit_code = wait_exit(p);
    stderr_text = slurp(p.err);
    stats = nlohmann::json::parse(slurp(stats_file), nullptr, false);
    trace = trace_lines(trace_file);
  }
  static inline fs::path stats_file, trace_file;
  static inline int exit_code = -1;
  static inline std::string stderr_text;
  static inline nlohmann::json stats;
  static inline std::vector<nlohmann::json> trace;
};

TEST_F(WheelchairRun, ExitsCleanlyOnSigint) {
  EXPECT_EQ(exit_code, 0) << stderr_text;
  EXPECT_NE(stderr_text.find("stopping (Interrupt)"), std::string::npos) << stderr_text;
}

TEST_F(WheelchairRun, EveryComponentRanAtLeast400Times) {
  ASSERT_FALSE(stats.is_discarded()) << stderr_text;
  ASSERT_EQ(stats["components"].size(), 3u);
  for (const auto& c : stats["components"]) {
    EXPECT_GE(c["executions"].get<std::uint64_t>(), 400u) << c.dump();
    EXPECT_EQ(c["errors"], 0) << c.dump();
    EXPECT_EQ(c["state"], "finalized") << c.dump();
  }
}

TEST_F(WheelchairRun, EveryConnectionHasALatencyHistogramAndDroppedNothing) {
  ASSERT_FALSE(stats.is_discarded()) << stderr_text;
  int app_connections = 0;
  for (const auto& c : stats["connections"]) {
    if (c["probe"].get<bool>()) continue;
    ++app_connections;
    EXPECT_GE(c["latency_ns"]["count"].get<std::uint64_t>(), 400u) << c.dump();
    EXPECT_GT(c["latency_ns"]["p50"].get<std::int64_t>(), 0) << c.dump();
    EXPECT_EQ(c["dropped"], 0) << c.dump();
  }
  EXPECT_EQ(app_connections, 4);
}

TEST_F(WheelchairRun, TwentyDegreeTurnChangesHeadingAndSplitsWheelSpeeds) {
  ASSERT_GT(trace.size(), 400u);
  auto at = [&](double t) -> const nlohmann::json& {
    for (const auto& line : trace) {
      if (line["value"]["time_s"].get<double>() >= t) return line["value"];
    }
    return trace.back()["value"];
  };
  const auto& before = at(1.9);  // driving straight at the joystick's 0.6
  const auto& after = at(4.5);   // 2.5 s after the step to a 20 degree turn
  const double l0 = before["left_rad_s"], r0 = before["right_rad_s"];
  const double l1 = after["left_rad_s"], r1 = after["right_rad_s"];
  EXPECT_GT(l0, 1.0);
  EXPECT_NEAR(l0, r0, 0.01 * l0);
  EXPECT_GT(std::abs(l1 - r1), 0.1 * std::abs(l1 + r1) / 2) << after.dump();
  EXPECT_GT(std::abs(after["heading_deg"].get<double>() - before["heading_deg"].get<double>()), 10.0);
  EXPECT_NEAR(std::abs(after["steering_deg"].get<double>()), 20.0, 3.0) << after.dump();
}

TEST(Daemon, CheckReportsEveryProblemWithItsLocation) {
  Process p = spawn({"check", POLYPORT_TEST_DATA "/daemon/broken_app.xml"}, "check-broken");
  EXPECT_EQ(wait_exit(p), 3);
  const std::string err = slurp(p.err);
  const std::string file = fs::weakly_canonical(POLYPORT_TEST_DATA "/daemon/broken_app.xml").string();
  EXPECT_NE(err.find(file + ":18:7: /application_profile/port_connections/port_connection[1]/target: component 'Control' has no port 'refrence'"),
            std::string::npos) << err;
  EXPECT_NE(err.find(file + ":20:5: /application_profile/port_connections/port_connection[2]: type mismatch: HW.wheel_speeds is 'wheelchair::WheelSpeeds' but Control.reference is 'wheelchair::Reference'"),
            std::string::npos) << err;
  const std::string missing = fs::weakly_canonical(POLYPORT_TEST_DATA "/daemon/Missing.xml").string();
  EXPECT_NE(err.find(file + ":12:36: /application_profile/subcomponents/subcomponent[3]/reference: component profile '" +
                     missing + "' not found"),
            std::string::npos) << err;
  EXPECT_NE(err.find("3 problem(s) found"), std::string::npos) << err;
}

TEST(Daemon, RunRefusesABrokenProfile) {
  const fs::path stats = scratch("refused.json");
  Process p = spawn({"run", POLYPORT_TEST_DATA "/daemon/broken_app.xml", "--stats-json", stats}, "run-broken");
  EXPECT_EQ(wait_exit(p), 3);
  EXPECT_FALSE(fs::exists(stats));
  EXPECT_NE(slurp(p.err).find("not running"), std::string::npos);
}

TEST(Daemon, CheckPrintsTheResolvedGraph) {
  Process p = spawn({"check", kDefaultProfile}, "check-ok");
  EXPECT_EQ(wait_exit(p), 0) << slurp(p.err);
  const std::string out = slurp(scratch("check-ok.stdout"));
  EXPECT_NE(out.find("data  HW.joystick -> Joystick.position  type=wheelchair::JoystickPosition  policy=data  mode=pull"),
            std::string::npos) << out;
  EXPECT_NE(out.find("members: Joystick Control HW"), std::string::npos) << out;
}

// `polyportd check APP` (its output, which must say success) and a 0.3 s run of APP: the
// final statistics' execution contexts, each of which must have run.
struct ContextsSeen {
  std::string check_output;
  nlohmann::json contexts = nlohmann::json::array();
};
ContextsSeen check_and_run(const fs::path& app, const std::string& tag) {
  ContextsSeen seen;
  Process check = spawn({"check", app.string()}, "check-" + tag);
  EXPECT_EQ(wait_exit(check), 0) << slurp(check.err);
  seen.check_output = slurp(scratch("check-" + tag + ".stdout"));
  const fs::path stats_file = scratch(tag + "-stats.json");
  Process run = spawn({"run", app.string(), "--duration", "0.3", "--quiet", "--stats-json", stats_file.string()},
                      "run-" + tag);
  EXPECT_EQ(wait_exit(run), 0) << slurp(run.err);
  const nlohmann::json stats = nlohmann::json::parse(slurp(stats_file), nullptr, false);
  EXPECT_TRUE(stats.contains("execution_contexts")) << slurp(stats_file);
  if (stats.contains("execution_contexts")) seen.contexts = stats["execution_contexts"];
  for (const auto& context : seen.contexts) EXPECT_GT(context.value("cycles", 0), 0) << context.dump();
  return seen;
}

// The wheelchair with a 200 us spin tail on Joystick only: Joystick gets a context of its own,
// which check prints and the statistics report.
TEST(Daemon, ASpinTailGetsAContextOfItsOwnAndIsReported) {
  const std::string source_dir = POLYPORT_SOURCE_DIR;
  auto copy_with = [&](const std::string& from, const fs::path& to,
                       const std::vector<std::pair<std::string, std::string>>& replacements) {
    std::string text = slurp(from);
    for (const auto& [old_text, new_text] : replacements) {
      const auto at = text.find(old_text);
      ASSERT_NE(at, std::string::npos) << from << ": no " << old_text;
      text.replace(at, old_text.size(), new_text);
    }
    std::ofstream(to) << text;
  };
  const fs::path components = scratch("spin-components");
  fs::create_directories(components);
  copy_with(source_dir + "/profiles/components/JoystickComp.xml", components / "JoystickComp.xml",
            {{"<period>10</period>", "<period>10</period><spin_us>200</spin_us>"},
             {"../../config/types/", source_dir + "/config/types/"}});
  const fs::path app = scratch("spin_app.xml");
  copy_with(source_dir + "/profiles/wheelchair_inproc.xml", app,
            {{"components/JoystickComp.xml", (components / "JoystickComp.xml").string()},
             {"components/ControlComp.xml", source_dir + "/profiles/components/ControlComp.xml"},
             {"components/HWComp.xml", source_dir + "/profiles/components/HWComp.xml"}});

  const ContextsSeen seen = check_and_run(app, "spin");
  const std::string& out = seen.check_output;
  EXPECT_NE(out.find("ec-10000us-spin200us  period=10 ms  spin=200 us  members: Joystick\n"), std::string::npos)
      << out;
  EXPECT_NE(out.find("ec-10000us  period=10 ms  members: Control HW\n"), std::string::npos) << out;
  std::map<std::string, std::int64_t> spin;
  for (const auto& context : seen.contexts) spin[context.value("name", "")] = context.value("spin_us", -1);
  EXPECT_EQ(spin, (std::map<std::string, std::int64_t>{{"ec-10000us", 0}, {"ec-10000us-spin200us", 200}}));
}

// The wheelchair with its components on phases of their own, set by the application profile
// (each subcomponent's <execution_semantics>): one context per phase, which check prints and
// the statistics report; the component profiles stay as they are.
TEST(Daemon, SubcomponentPhasesGetContextsOfTheirOwnAndAreReported) {
  const std::string source_dir = POLYPORT_SOURCE_DIR;
  std::string text = slurp(source_dir + "/profiles/wheelchair_inproc.xml");
  for (const auto& [name, phase] : std::vector<std::pair<std::string, std::string>>{{"Joystick", "3"}, {"Control", "6.5"}}) {
    const std::string reference = "<reference>components/" + name + "Comp.xml</reference>";
    const auto at = text.find(reference);
    ASSERT_NE(at, std::string::npos) << reference;
    text.insert(at + reference.size(), "<execution_semantics><phase>" + phase + "</phase></execution_semantics>");
  }
  std::string::size_type at = 0;
  while ((at = text.find("components/", at)) != std::string::npos) {
    text.replace(at, 11, source_dir + "/profiles/components/");
    at += source_dir.size() + 21;
  }
  const fs::path app = scratch("phase_app.xml");
  std::ofstream(app) << text;

  const ContextsSeen seen = check_and_run(app, "phase");
  const std::string& out = seen.check_output;
  EXPECT_NE(out.find("ec-10000us-phase3000us  period=10 ms  phase=3 ms  members: Joystick\n"), std::string::npos) << out;
  EXPECT_NE(out.find("ec-10000us-phase6500us  period=10 ms  phase=6.5 ms  members: Control\n"), std::string::npos) << out;
  EXPECT_NE(out.find("ec-10000us  period=10 ms  members: HW\n"), std::string::npos) << out;

  std::map<std::string, nlohmann::json> phase;
  for (const auto& context : seen.contexts) phase[context.value("name", "")] = context["phase_ns"];
  EXPECT_EQ(phase, (std::map<std::string, nlohmann::json>{{"ec-10000us", nullptr},
                                                          {"ec-10000us-phase3000us", 3'000'000},
                                                          {"ec-10000us-phase6500us", 6'500'000}}));
}

TEST(Daemon, SigtermStopsGracefullyAndDurationStopsByItself) {
  Process p = spawn({"run", kDefaultProfile, "--quiet"}, "sigterm");
  // Wait until the daemon says it runs, then stop it.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (slurp(p.err).find("running") == std::string::npos && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  kill(p.pid, SIGTERM);
  EXPECT_EQ(wait_exit(p), 0) << slurp(p.err);

  Process q = spawn({"run", kDefaultProfile, "--duration", "0.3", "--quiet"}, "duration");
  EXPECT_EQ(wait_exit(q), 0) << slurp(q.err);
}

TEST(Daemon, TypesPrintsLayoutsFingerprintsAndFrames) {
  Process p = spawn({"types", POLYPORT_SOURCE_DIR "/benchmarks/types/bench.idl", POLYPORT_SOURCE_DIR "/benchmarks/types/bench.lcm",
                     POLYPORT_SOURCE_DIR "/benchmarks/types/bench.dbc"},
                    "types");
  EXPECT_EQ(wait_exit(p), 0) << slurp(p.err);
  const std::string out = slurp(scratch("types.stdout"));
  EXPECT_NE(out.find("struct bench::Wheel64  (idl, "), std::string::npos) << out;
  EXPECT_NE(out.find("struct bench::wheel64_t  (lcm, "), std::string::npos) << out;
  EXPECT_NE(out.find("  lcm fingerprint 0x"), std::string::npos) << out;
  EXPECT_NE(out.find("  frame 0x123 (standard), 8 bytes, from DRIVE"), std::string::npos) << out;
  EXPECT_NE(out.find("heading_deg              bits 55|8  motorola signed   x2 +0 [-256, 254] deg"), std::string::npos) << out;
  EXPECT_NE(out.find("      56  double                       battery_v"), std::string::npos) << out;

  // Multiplexed signals with the switch and values that select them (extended multiplexing).
  Process mux = spawn({"types", POLYPORT_TEST_DATA "/dbc/extended_mux.dbc"}, "types-mux");
  EXPECT_EQ(wait_exit(mux), 0) << slurp(mux.err);
  const std::string muxed = slurp(scratch("types-mux.stdout"));
  EXPECT_NE(muxed.find("Flag                     bits  8|1  intel    unsigned x1 +0 [0, 1]  when Page = 8, 16, 24"),
            std::string::npos)
      << muxed;
  EXPECT_NE(muxed.find("MuxB                     bits  8|8  intel    unsigned x1 +0  multiplexer  when MuxA = 2"),
            std::string::npos)
      << muxed;
  EXPECT_NE(muxed.find("Dtc                      bits  8|16 intel    unsigned x1 +0  when Service = 3"), std::string::npos)
      << muxed;

  Process broken = spawn({"types", POLYPORT_TEST_DATA "/daemon/broken_app.xml"}, "types-broken");
  EXPECT_EQ(wait_exit(broken), 3);
  EXPECT_NE(slurp(broken.err).find("unknown kind of type file"), std::string::npos);
}

TEST(Daemon, UsageErrorsAndVersion) {
  Process bad = spawn({"run"}, "usage");
  EXPECT_EQ(wait_exit(bad), 2);
  Process version = spawn({"--version"}, "version");
  EXPECT_EQ(wait_exit(version), 0);
  EXPECT_NE(slurp(scratch("version.stdout")).find("polyportd 0."), std::string::npos);
  Process missing = spawn({"check", "/nonexistent/app.xml"}, "missing");
  EXPECT_EQ(wait_exit(missing), 3);
  EXPECT_NE(slurp(missing.err).find("/nonexistent/app.xml"), std::string::npos);
}

}  // namespace

namespace polyport {
namespace {

// The shipped DDS examples load, and each joins its domains and runs (the DDS models are in
// the daemon when their SDKs were found at build time, as in CI).
TEST(ShippedDdsProfiles, CheckAndRunBriefly) {
  for (const std::string name : {"dds_bridge", "dds_inproc"}) {
    SCOPED_TRACE(name);
    const std::string profile = POLYPORT_SOURCE_DIR "/profiles/" + name + ".xml";
    const Process check = spawn({"check", profile}, name + "-check");
    EXPECT_EQ(wait_exit(check), 0) << slurp(check.err);
    const fs::path stats = scratch(name + "-stats.json");
    const Process run = spawn({"run", profile, "--duration", "1", "-q", "--stats-json", stats.string()}, name + "-run");
    ASSERT_EQ(wait_exit(run), 0) << slurp(run.err);
    const auto json = nlohmann::json::parse(slurp(stats), nullptr, false);
    ASSERT_FALSE(json.is_discarded());
    EXPECT_EQ(json["connections"].size(), name == "dds_bridge" ? 2u : 4u) << json.dump(2);
  }
}

// Every shipped application profile (profiles/*.xml) checks clean, without a warning, with
// every model built in:
// `check` opens no network, bus or participant, so it holds on any host.
TEST(ShippedProfiles, EveryOneChecksClean) {
  std::vector<fs::path> profiles;
  for (const auto& entry : fs::directory_iterator(POLYPORT_SOURCE_DIR "/profiles")) {
    if (entry.path().extension() == ".xml") profiles.push_back(entry.path());
  }
  ASSERT_GE(profiles.size(), 6u);
  for (const fs::path& profile : profiles) {
    SCOPED_TRACE(profile.string());
    const Process check = spawn({"check", profile.string()}, profile.stem().string() + "-check-all");
    EXPECT_EQ(wait_exit(check), 0) << slurp(check.err);
    EXPECT_EQ(slurp(check.err).find("warning"), std::string::npos) << slurp(check.err);
  }
}

}  // namespace
}  // namespace polyport
