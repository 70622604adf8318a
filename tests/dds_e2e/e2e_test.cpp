// polyportd between DDS applications that are programs of their own (tests/dds_peers:
// idlc-generated Cyclone DDS and fastddsgen-generated Fast DDS code), on loopback: data across
// vendors and domains, DDS <-> in-process components, services both ways with a timeout, a
// sample that does not decode, a publisher that restarts. Every process is a child of the
// test; every wait is for a line in a child's output or a file, with a deadline.
//
// Each test gets its own pair of DDS domains (the profile templates in tests/data/dds_e2e
// are filled in per test) so that tests running in parallel do not hear each other.
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

namespace polyport {
namespace {

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
 protected:
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
std::vector<Json> poses(const Child& subscriber) {
  std::vector<Json> out;
  for (const Json& j : subscriber.lines()) {
    if (j.contains("id")) out.push_back(j);
  }
  return out;
}

// Every field of a received pose against what the publisher sent as its sample i, where i
// follows from the id (id_offset: what the relay adds).
void expect_pose(const Json& got, int id_offset = 0) {
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
void expect_increasing(const std::vector<Json>& got) {
  for (std::size_t k = 1; k < got.size(); ++k) EXPECT_LT(got[k - 1]["id"].get<int>(), got[k]["id"].get<int>());
}

const Json* connection(const Json& stats, const std::string& name) {
  for (const Json& c : stats["connections"]) {
    if (c["name"] == name) return &c;
  }
  ADD_FAILURE() << "no connection " << name << " in " << stats.dump(2);
  return nullptr;
}

// Publishers below run until stopped: a subscriber's reader matches polyport's writer (the
// subscriber sees it) a moment before polyport's writer matches the reader, and samples
// written in between are not for it (volatile topics). So a test waits for enough samples,
// not for particular ones, and checks every field of each that arrived.
constexpr const char* kForever = "0";

TEST_F(DdsEndToEnd, CyclonePublisherReachesFastddsSubscriberAndBack) {
  auto polyportd = daemon(profiles("cross_vendor_app.xml", 182, 183));
  auto fast_sub = peer(FASTDDS_PEER, "fast_sub", {"sub", "183", "pose", "5", "60"});
  auto cyclone_sub = peer(CYCLONE_PEER, "cyclone_sub", {"sub", "182", "pose_back", "4", "60"});
  auto cyclone_pub = peer(CYCLONE_PEER, "cyclone_pub", {"pub", "182", "pose", kForever, "5"});
  auto fast_pub = peer(FASTDDS_PEER, "fast_pub", {"pub", "183", "pose_back", kForever, "5", "20"});

  ASSERT_EQ(fast_sub->wait(60s), 0) << "Fast DDS subscriber: " << fast_sub->errors();
  ASSERT_EQ(cyclone_sub->wait(60s), 0) << "Cyclone subscriber: " << cyclone_sub->errors();
  const auto forward = poses(*fast_sub);
  ASSERT_EQ(forward.size(), 5u);
  for (const Json& pose : forward) expect_pose(pose);
  expect_increasing(forward);
  const auto back = poses(*cyclone_sub);
  ASSERT_EQ(back.size(), 4u);
  for (const Json& pose : back) expect_pose(pose);
  expect_increasing(back);
  EXPECT_GE(back[0]["id"].get<int>(), peer_values::id(20));  // the Fast DDS publisher's

  cyclone_pub.reset();
  fast_pub.reset();
  const Json stats = stop(*polyportd);
  const Json* there = connection(stats, "cyclone.pose -> fast.pose");
  const Json* home = connection(stats, "fast.pose_back -> cyclone.pose_back");
  ASSERT_TRUE(there && home);
  EXPECT_EQ((*there)["conversion"], "passthrough");
  EXPECT_GE((*there)["delivered"].get<int>(), 5);
  EXPECT_GE((*home)["delivered"].get<int>(), 4);
  EXPECT_EQ((*there)["dropped"], 0);
  EXPECT_EQ((*home)["dropped"], 0);
}

TEST_F(DdsEndToEnd, DdsToInProcessComponentAndOnToDds) {
  // Cyclone publisher -> polyport decodes into the in-process PoseRelay -> the relay's output
  // is encoded for a Fast DDS subscriber. Both hops are checked field by field.
  auto polyportd = daemon(profiles("relay_app.xml", 186, 187));
  auto fast_sub = peer(FASTDDS_PEER, "fast_sub", {"sub", "187", "pose", "6", "60"});
  auto cyclone_pub = peer(CYCLONE_PEER, "cyclone_pub", {"pub", "186", "pose", kForever, "5"});
  ASSERT_EQ(fast_sub->wait(60s), 0) << fast_sub->errors();
  const auto got = poses(*fast_sub);
  ASSERT_EQ(got.size(), 6u);
  for (const Json& pose : got) expect_pose(pose, 100000);
  expect_increasing(got);

  cyclone_pub.reset();
  const Json stats = stop(*polyportd);
  const Json* in = connection(stats, "cyclone.pose -> relay.in");
  const Json* out = connection(stats, "relay.out -> fast.pose");
  ASSERT_TRUE(in && out);
  EXPECT_EQ((*in)["conversion"], "xcdr1 -> flat");
  EXPECT_EQ((*out)["conversion"], "flat -> xcdr1");
  EXPECT_GE((*in)["delivered"].get<int>(), 6);
  EXPECT_GE((*out)["delivered"].get<int>(), 6);
  EXPECT_EQ((*in)["dropped"], 0);
}

TEST_F(DdsEndToEnd, UndecodableSampleIsCountedAndTheConnectionGoesOn) {
  auto polyportd = daemon(profiles("relay_app.xml", 188, 189));
  auto fast_sub = peer(FASTDDS_PEER, "fast_sub", {"sub", "189", "pose", "1000", "60"});
  auto good = peer(CYCLONE_PEER, "good", {"pub", "188", "pose", kForever, "5"});
  ASSERT_TRUE(eventually([&] { return poses(*fast_sub).size() >= 3; })) << "nothing relayed";
  // Same topic, same type name, another layout: one octet where a Pose is expected. The
  // peer waits until polyport has acknowledged both samples before it exits.
  auto bad = peer(CYCLONE_BAD_PEER, "bad", {"pub", "188", "pose", "2", "5"});
  ASSERT_EQ(bad->wait(60s), 0) << bad->errors();
  const std::size_t before = poses(*fast_sub).size();
  ASSERT_TRUE(eventually([&] { return poses(*fast_sub).size() >= before + 3; })) << "nothing relayed after";
  good.reset();
  const auto got = poses(*fast_sub);
  for (const Json& pose : got) expect_pose(pose, 100000);
  expect_increasing(got);
  fast_sub.reset();

  const Json stats = stop(*polyportd);
  const Json* in = connection(stats, "cyclone.pose -> relay.in");
  ASSERT_TRUE(in);
  EXPECT_EQ((*in)["dropped_by_reason"]["decode_error"], 2) << in->dump(2);
  EXPECT_EQ((*in)["dropped"], 2) << in->dump(2);
  EXPECT_EQ((*in)["delivered"].get<int>() + 2, (*in)["received"].get<int>()) << in->dump(2);
}

TEST_F(DdsEndToEnd, PublisherThatRestartsIsPickedUpAgain) {
  auto polyportd = daemon(profiles("cross_vendor_app.xml", 190, 191));
  auto fast_sub = peer(FASTDDS_PEER, "fast_sub", {"sub", "191", "pose", "1000", "60"});
  auto first = peer(CYCLONE_PEER, "first_run", {"pub", "190", "pose", kForever, "5", "0"});
  ASSERT_TRUE(eventually([&] { return poses(*fast_sub).size() >= 2; })) << "first run not forwarded";
  first->signal(SIGKILL);  // the application goes away without saying goodbye
  EXPECT_NE(first->wait(20s), -1);
  // A new process of the same application, numbering its samples from 1000.
  auto second = peer(CYCLONE_PEER, "second_run", {"pub", "190", "pose", kForever, "5", "1000"});
  ASSERT_TRUE(eventually([&] {
    const auto got = poses(*fast_sub);
    return !got.empty() && got.back()["id"].get<int>() >= peer_values::id(1002);
  })) << "the restarted publisher was not picked up";
  second.reset();
  const auto got = poses(*fast_sub);
  for (const Json& pose : got) expect_pose(pose);
  expect_increasing(got);
  fast_sub.reset();
  stop(*polyportd);
}

TEST_F(DdsEndToEnd, DdsClientCallsAnInProcessService) {
  auto polyportd = daemon(profiles("client_app.xml", 192, 193));
  auto client = peer(CYCLONE_PEER, "client", {"call", "192", "calc", "5", "5000"});
  ASSERT_EQ(client->wait(90s), 0) << client->errors();
  int replies = 0;
  for (const Json& j : client->lines()) {
    if (!j.contains("seq")) continue;
    ++replies;
    EXPECT_EQ(j["status"], 0) << j.dump();
    EXPECT_DOUBLE_EQ(j["sum"].get<double>(), j["seq"].get<int>() + 0.5) << j.dump();
  }
  EXPECT_EQ(replies, 5);
  const Json stats = stop(*polyportd);
  ASSERT_EQ(stats["services"].size(), 1u);
  EXPECT_EQ(stats["services"][0]["ok"], 5) << stats["services"].dump(2);
}

// The in-process PeerCaller calls `add` every 20 ms with n = 1, 2, ... and publishes each sum
// it gets; traced to a file.
std::vector<double> traced_sums(const fs::path& trace) {
  std::vector<double> sums;
  std::ifstream in(trace);
  std::string text;
  while (std::getline(in, text)) {
    const Json j = Json::parse(text, nullptr, false);
    if (!j.is_discarded() && j.contains("value")) sums.push_back(j["value"]["sum"].get<double>());
  }
  return sums;
}

TEST_F(DdsEndToEnd, InProcessCallerCallsADdsServerAndTimesOutWithoutOne) {
  const fs::path trace = dir() / "sums.jsonl";
  auto polyportd = daemon(profiles("server_app.xml", 194, 195), {"--trace", "caller.sums", "--trace-file", trace.string()});
  // A server that takes requests and never answers: every call ends with the bridge's call
  // timeout (150 ms in DdsCalcServer.xml), and nothing is published.
  auto silent = peer(FASTDDS_PEER, "silent", {"serve", "195", "calc", "3", "silent"});
  ASSERT_EQ(silent->wait(60s), 0) << silent->errors();
  // An answering server: sums (n + 0.5) appear.
  auto server = peer(FASTDDS_PEER, "server", {"serve", "195", "calc", "5"});
  ASSERT_EQ(server->wait(60s), 0) << server->errors();
  ASSERT_TRUE(eventually([&] { return traced_sums(trace).size() >= 5; }, 20s)) << "no sums traced";
  const Json stats = stop(*polyportd);
  const auto sums = traced_sums(trace);
  for (double sum : sums) EXPECT_EQ(sum - std::floor(sum), 0.5) << sum;  // n + 0.5 for some n
  ASSERT_EQ(stats["services"].size(), 1u);
  const Json& calls = stats["services"][0];
  EXPECT_GE(calls["timeouts"].get<int>(), 3) << calls.dump(2);  // at least the silent server's
  EXPECT_GE(calls["ok"].get<int>(), 5) << calls.dump(2);
}

}  // namespace
}  // namespace polyport
