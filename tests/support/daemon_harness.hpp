// The harness of end-to-end tests that run polyportd as an operator would, with peer
// programs as child processes: output in files, every wait for a line or a file with a
// deadline, statistics read back when the daemon stops.
#pragma once

#include <gtest/gtest.h>
#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <optional>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

extern char** environ;

namespace polyport::test {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using Json = nlohmann::json;

// A child process whose stdout and stderr go to files; killed when the handle goes.
class Child {
 public:
  Child(const fs::path& dir, const std::string& tag, std::vector<std::string> args)
      : out_(dir / (tag + ".out")), err_(dir / (tag + ".err")) {
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, 1, out_.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    posix_spawn_file_actions_addopen(&actions, 2, err_.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (posix_spawn(&pid_, argv[0], &actions, nullptr, argv.data(), environ) != 0) pid_ = -1;
    posix_spawn_file_actions_destroy(&actions);
  }
  // Asks the child to end (SIGTERM: the peers then leave their domain properly), and kills it
  // if it has not within a few seconds.
  ~Child() {
    if (pid_ > 0 && !exited_) {
      kill(pid_, SIGTERM);
      if (wait(5s) == -1) {
        kill(pid_, SIGKILL);
        waitpid(pid_, nullptr, 0);
      }
    }
  }
  Child(const Child&) = delete;
  Child& operator=(const Child&) = delete;

  bool started() const { return pid_ > 0; }
  pid_t pid() const { return pid_; }
  void signal(int number) const {
    if (pid_ > 0 && !exited_) kill(pid_, number);
  }
  // The exit status, or -1 if the child did not end within `limit`.
  int wait(std::chrono::milliseconds limit) {
    const auto deadline = std::chrono::steady_clock::now() + limit;
    while (!exited_) {
      int status = 0;
      if (waitpid(pid_, &status, WNOHANG) == pid_) {
        exited_ = true;
        code_ = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
        break;
      }
      if (std::chrono::steady_clock::now() > deadline) return -1;
      std::this_thread::sleep_for(5ms);
    }
    return code_;
  }
  // The JSON lines written so far (lines that are not JSON are skipped).
  std::vector<Json> lines() const {
    std::vector<Json> out;
    std::ifstream in(out_);
    std::string text;
    while (std::getline(in, text)) {
      Json j = Json::parse(text, nullptr, false);
      if (!j.is_discarded()) out.push_back(std::move(j));
    }
    return out;
  }
  bool saw_event(const std::string& event) const {
    for (const Json& j : lines()) {
      if (j.value("event", "") == event) return true;
    }
    return false;
  }
  std::string errors() const {
    std::ifstream in(err_);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
  }

 private:
  fs::path out_, err_;
  pid_t pid_ = -1;
  bool exited_ = false;
  int code_ = -1;
};

// A whole file as text ("" when it cannot be read): logs, traces, statistics files.
inline std::string read_file(const fs::path& file) {
  std::ifstream in(file);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// The /proc/PID/task/TID folders of a process's threads named `name` (their comm).
inline std::vector<fs::path> threads_named(pid_t pid, const std::string& name) {
  std::vector<fs::path> out;
  std::error_code ec;
  for (const auto& task : fs::directory_iterator("/proc/" + std::to_string(pid) + "/task", ec)) {
    std::ifstream comm(task.path() / "comm");
    std::string comm_name;
    std::getline(comm, comm_name);
    if (comm_name == name) out.push_back(task.path());
  }
  return out;
}

// The scheduling of a process's thread named `name`, from /proc/PID/task/TID/stat:
// {real-time priority (field 40), policy (field 41: 0 SCHED_OTHER, 1 SCHED_FIFO, 2 SCHED_RR)};
// nullopt when no thread has that name.
inline std::optional<std::pair<int, int>> thread_scheduling(pid_t pid, const std::string& name) {
  for (const fs::path& task : threads_named(pid, name)) {
    std::ifstream stat(task / "stat");
    const std::string text((std::istreambuf_iterator<char>(stat)), std::istreambuf_iterator<char>());
    std::istringstream fields(text.substr(text.rfind(')') + 2));  // from field 3 on
    const std::vector<std::string> f{std::istream_iterator<std::string>(fields), std::istream_iterator<std::string>()};
    if (f.size() < 39) return std::nullopt;
    return std::pair{std::stoi(f[37]), std::stoi(f[38])};
  }
  return std::nullopt;
}

// Polls (every 10 ms: the conditions read the peers' output files) until `condition` holds
// or `limit` passes.
template <class F>
bool eventually(F&& condition, std::chrono::milliseconds limit = 30s) {
  const auto deadline = std::chrono::steady_clock::now() + limit;
  while (!condition()) {
    if (std::chrono::steady_clock::now() > deadline) return false;
    std::this_thread::sleep_for(10ms);
  }
  return true;
}

// A test with its own folder (kept when the test fails), polyportd (POLYPORTD) and peers.
class DaemonTest : public ::testing::Test {
 public:
  // `prefix` names the test's folder: <tmp>/<prefix>-<pid>-<test name>.
  explicit DaemonTest(std::string prefix) : prefix_(std::move(prefix)) {}

  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() / (prefix_ + "-" + std::to_string(getpid()) + "-" + info->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override {
    if (!HasFailure()) fs::remove_all(dir_);
  }

  std::unique_ptr<Child> daemon(const fs::path& app, std::vector<std::string> extra = {}) {
    std::vector<std::string> args{POLYPORTD, "run", app.string(), "-q", "--stats-json", stats_file().string()};
    args.insert(args.end(), extra.begin(), extra.end());
    auto child = std::make_unique<Child>(dir_, "polyportd", args);
    EXPECT_TRUE(child->started());
    // Peers start once every component runs ("running" is logged after the engine started
    // them all), or once the daemon has ended (a test of a refused start): a sample sent
    // while a receiver is still starting would be dropped, which is not what a test checks.
    EXPECT_TRUE(eventually([&] { return child->errors().find(" running ") != std::string::npos || child->wait(0ms) != -1; }))
        << "polyportd neither ran nor ended:\n" << child->errors();
    return child;
  }
  // Stops the daemon (SIGINT) and returns its statistics.
  Json stop(Child& daemon) {
    daemon.signal(SIGINT);
    EXPECT_EQ(daemon.wait(20s), 0) << daemon.errors();
    std::ifstream in(stats_file());
    Json stats = Json::parse(in, nullptr, false);
    EXPECT_FALSE(stats.is_discarded()) << "no statistics from polyportd";
    return stats;
  }
  std::unique_ptr<Child> peer(const char* program, const std::string& tag, std::vector<std::string> args) {
    args.insert(args.begin(), program);
    auto child = std::make_unique<Child>(dir_, tag, args);
    EXPECT_TRUE(child->started()) << program;
    return child;
  }
  // Copies every file of `folder` into the test's folder with each key of `values` (such as
  // "@SRC@") replaced by its value; returns the copy of `app`.
  fs::path fill_templates(const fs::path& folder, const std::vector<std::pair<std::string, std::string>>& values,
                          const std::string& app) const {
    for (const auto& entry : fs::directory_iterator(folder)) {
      if (!entry.is_regular_file()) continue;
      std::ifstream in(entry.path());
      std::stringstream text;
      text << in.rdbuf();
      std::string s = text.str();
      for (const auto& [key, value] : values) {
        for (std::size_t at = s.find(key); at != std::string::npos; at = s.find(key, at)) s.replace(at, key.size(), value);
      }
      std::ofstream(dir_ / entry.path().filename()) << s;
    }
    return dir_ / app;
  }
  // An application of one component `rt` of `model` with one output port `reference` of
  // `type` (declared in `type_file`) and the model's element `section`, in the test's
  // folder; returns the application file.
  fs::path one_component_app(const std::string& model, const std::string& section, const std::string& type_file,
                             const std::string& type) const {
    std::ofstream(dir_ / "Rt.xml") << "<?xml version=\"1.0\"?>\n<component_profile><name>Rt</name><model>" << model
                                   << "</model>\n  " << section << "\n  <types><file>" << type_file
                                   << "</file></types>\n  <ports><data_port><name>reference</name><data_type>" << type
                                   << "</data_type><usage>output</usage></data_port></ports>\n</component_profile>\n";
    std::ofstream(dir_ / "rt_app.xml") << "<?xml version=\"1.0\"?>\n<application_profile><name>rt</name>\n"
                                          "  <subcomponents><subcomponent><name>rt</name><reference>Rt.xml</reference>"
                                          "</subcomponent></subcomponents>\n</application_profile>\n";
    return dir_ / "rt_app.xml";
  }
  fs::path stats_file() const { return dir_ / "stats.json"; }
  const fs::path& dir() const { return dir_; }

  // What a program run to its end in the test's folder gave: its exit code (-1: still
  // running after `limit`), stdout and stderr (kept there as run-N.out / run-N.err).
  struct Ran {
    int code = -1;
    std::string out, err;
    Json json() const { return Json::parse(out, nullptr, false); }
  };
  Ran run_to_end(const std::vector<std::string>& argv, std::chrono::milliseconds limit = 30s) {
    const std::string tag = "run-" + std::to_string(++runs_);
    Ran result;
    {
      Child child(dir_, tag, argv);
      result.code = child.wait(limit);
    }
    result.out = read_file(dir_ / (tag + ".out"));
    result.err = read_file(dir_ / (tag + ".err"));
    return result;
  }

 private:
  std::string prefix_;
  fs::path dir_;
  int runs_ = 0;
};

// The sums the in-process PeerCaller (tests/plugins) publishes, traced to a file by
// `polyportd run --trace caller.sums --trace-file FILE`: it calls `add` every 20 ms with n =
// 1, 2, ... and publishes each sum it gets (DDS and LCM service tests).
inline std::vector<double> traced_sums(const fs::path& trace) {
  std::vector<double> sums;
  std::ifstream in(trace);
  std::string text;
  while (std::getline(in, text)) {
    const Json j = Json::parse(text, nullptr, false);
    if (!j.is_discarded() && j.contains("value")) sums.push_back(j["value"]["sum"].get<double>());
  }
  return sums;
}

// The replies a `call` peer (tests/dds_peers, tests/lcm_e2e/lcm_peer) printed, each checked:
// status ok and the sum of (seq, 0.5). Adds up in `requests` the requests they took (a peer
// sends a request again when its reply is late).
inline int checked_replies(const Child& client, int& requests) {
  int replies = 0;
  for (const Json& j : client.lines()) {
    if (!j.contains("seq")) continue;
    ++replies;
    requests += j["attempts"].get<int>();
    EXPECT_EQ(j["status"], 0) << j.dump();
    EXPECT_DOUBLE_EQ(j["sum"].get<double>(), j["seq"].get<int>() + 0.5) << j.dump();
  }
  return replies;
}

}  // namespace polyport::test
