// The harness of the DDS end-to-end tests (e2e_test.cpp, vendor_mirror_test.cpp): child
// processes with their output in files, the profile templates of tests/data/dds_e2e filled in
// with a test's own domains, polyportd started and stopped as an operator would, and checks
// of what the peers printed. Every wait is for a line or a file, with a deadline.
#pragma once

#include <gtest/gtest.h>
#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "pose_values.hpp"

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

template <class F>
bool eventually(F&& condition, std::chrono::milliseconds limit = 30s) {
  const auto deadline = std::chrono::steady_clock::now() + limit;
  while (!condition()) {
    if (std::chrono::steady_clock::now() > deadline) return false;
    std::this_thread::sleep_for(10ms);
  }
  return true;
}

class DdsEndToEnd : public ::testing::Test {
 public:  // the scenarios (e2e_scenarios.hpp) drive a test through these
  void SetUp() override {
    if (std::string(CYCLONE_PEER).empty() || std::string(FASTDDS_PEER).empty()) {
      GTEST_SKIP() << "the test peers were not built: " << POLYPORT_PEERS_MISSING;
    }
    // Both SDKs of every child stay on loopback, with the configurations polyport ships.
    setenv("CYCLONEDDS_URI", "file://" POLYPORT_SOURCE_DIR "/config/cyclonedds-loopback.xml", 1);
    setenv("FASTRTPS_DEFAULT_PROFILES_FILE", POLYPORT_SOURCE_DIR "/config/fastdds-loopback.xml", 1);
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() / ("polyport-dds-e2e-" + std::to_string(getpid()) + "-" + info->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override {
    if (!HasFailure()) fs::remove_all(dir_);
  }

  // Fills in the profile templates with this test's domains; returns the application file.
  fs::path profiles(const std::string& app, int domain_a, int domain_b) {
    for (const auto& entry : fs::directory_iterator(POLYPORT_TEST_DATA "/dds_e2e")) {
      std::ifstream in(entry.path());
      std::stringstream text;
      text << in.rdbuf();
      std::string s = text.str();
      for (const auto& [key, value] : {std::pair<std::string, std::string>{"@A@", std::to_string(domain_a)},
                                       {"@B@", std::to_string(domain_b)},
                                       {"@SRC@", POLYPORT_SOURCE_DIR}}) {
        for (std::size_t at = s.find(key); at != std::string::npos; at = s.find(key, at)) s.replace(at, key.size(), value);
      }
      std::ofstream(dir_ / entry.path().filename()) << s;
    }
    return dir_ / app;
  }

  std::unique_ptr<Child> daemon(const fs::path& app, std::vector<std::string> extra = {}) {
    std::vector<std::string> args{POLYPORTD, "run", app.string(), "-q", "--stats-json", stats_file().string()};
    args.insert(args.end(), extra.begin(), extra.end());
    auto child = std::make_unique<Child>(dir_, "polyportd", args);
    EXPECT_TRUE(child->started());
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
  fs::path stats_file() const { return dir_ / "stats.json"; }
  const fs::path& dir() const { return dir_; }

 private:
  fs::path dir_;
};

// The Poses a subscriber printed.
inline std::vector<Json> poses(const Child& subscriber) {
  std::vector<Json> out;
  for (const Json& j : subscriber.lines()) {
    if (j.contains("id")) out.push_back(j);
  }
  return out;
}

// Every field of a received pose against what the publisher sent as its sample i, where i
// follows from the id (id_offset: what the relay adds).
inline void expect_pose(const Json& got, int id_offset = 0) {
  SCOPED_TRACE("pose " + got.dump());
  const int i = got["id"].get<int>() - id_offset - peer_values::id(0);
  EXPECT_EQ(got["id"].get<int>(), peer_values::id(i) + id_offset);
  EXPECT_DOUBLE_EQ(got["x"].get<double>(), peer_values::x(i));
  EXPECT_FLOAT_EQ(got["heading"].get<float>(), peer_values::heading(i));
  EXPECT_EQ(got["valid"].get<bool>(), peer_values::valid(i));
  EXPECT_EQ(got["frame"].get<std::string>(), peer_values::frame(i));
  ASSERT_EQ(got["samples"].size(), peer_values::sample_count(i));
  for (std::size_t k = 0; k < got["samples"].size(); ++k) {
    EXPECT_DOUBLE_EQ(got["samples"][k].get<double>(), peer_values::sample(i, static_cast<int>(k)));
  }
  for (int k = 0; k < 4; ++k) EXPECT_EQ(got["quad"][k].get<int>(), peer_values::quad(i, k));
}

// Received poses come in publication order, without repeats.
inline void expect_increasing(const std::vector<Json>& got) {
  for (std::size_t k = 1; k < got.size(); ++k) EXPECT_LT(got[k - 1]["id"].get<int>(), got[k]["id"].get<int>());
}

inline const Json* connection(const Json& stats, const std::string& name) {
  for (const Json& c : stats["connections"]) {
    if (c["name"] == name) return &c;
  }
  ADD_FAILURE() << "no connection " << name << " in " << stats.dump(2);
  return nullptr;
}

// The DDS topic polyport reads for a connection's source port ("component.port"), as the
// component's entry in the statistics has it.
inline const Json* source_topic(const Json& stats, const Json& link) {
  const std::string source = link["source"];
  const auto dot = source.find('.');
  for (const Json& c : stats["components"]) {
    if (c["name"] != source.substr(0, dot) || !c.contains("dds")) continue;
    for (const Json& topic : c["dds"]["topics"]) {
      if (topic["port"] == source.substr(dot + 1) && topic["polyport"] == "reads") return &topic;
    }
  }
  ADD_FAILURE() << "no DDS topic read for " << source << " in " << stats.dump(2);
  return nullptr;
}

// Publishers below run until stopped: a subscriber's reader matches polyport's writer (the
// subscriber sees it) a moment before polyport's writer matches the reader, and samples
// written in between are not for it (volatile topics). So a test waits for enough samples,
// not for particular ones, and checks every field of each that arrived.
inline constexpr const char* kForever = "0";
// What tests/plugins PoseRelay adds to every id it relays.
inline constexpr int kRelayOffset = 100000;

// The in-process PeerCaller calls `add` every 20 ms with n = 1, 2, ... and publishes each sum
// it gets; traced to a file.
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

}  // namespace polyport::test
