// A running polyportd (the in-process wheelchair) driven through polyportctl only, and the
// admin socket's defences against clients that misbehave: garbage, an over-long line, a
// client that never reads, a client of another uid. Every wait polls with a deadline.
#include <errno.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>

#include <cstring>
#include <cstdlib>
#include <optional>

#include "../support/daemon_harness.hpp"

namespace polyport::test {
namespace {

const fs::path kProfile = POLYPORT_SOURCE_DIR "/profiles/wheelchair_inproc.xml";

struct Ctl {
  int code = -1;
  std::string out;
  std::string err;
  Json json() const { return Json::parse(out, nullptr, false); }
};

std::string read_file(const fs::path& file) {
  std::ifstream in(file);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// A connected raw client of the admin socket.
class RawClient {
 public:
  explicit RawClient(const fs::path& path) {
    fd_ = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
    sockaddr_un address{};
    address.sun_family = AF_UNIX;
    std::strncpy(address.sun_path, path.c_str(), sizeof address.sun_path - 1);
    connected_ = ::connect(fd_, reinterpret_cast<sockaddr*>(&address), sizeof address) == 0;
  }
  ~RawClient() { ::close(fd_); }
  bool connected() const { return connected_; }
  int fd() const { return fd_; }
  // Sends what the socket takes without blocking; the bytes sent (stops at an error).
  std::size_t send_some(const std::string& data) {
    std::size_t sent = 0;
    while (sent < data.size()) {
      const ssize_t n = ::send(fd_, data.data() + sent, data.size() - sent, MSG_NOSIGNAL | MSG_DONTWAIT);
      if (n <= 0) break;
      sent += static_cast<std::size_t>(n);
    }
    return sent;
  }
  // The next reply line, or nullopt when the connection ended or `limit` passed first.
  std::optional<Json> reply(std::chrono::milliseconds limit = 10s) {
    const auto deadline = std::chrono::steady_clock::now() + limit;
    for (;;) {
      if (const auto at = pending_.find('\n'); at != std::string::npos) {
        Json j = Json::parse(pending_.substr(0, at), nullptr, false);
        pending_.erase(0, at + 1);
        return j;
      }
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
      if (left.count() <= 0) return std::nullopt;
      pollfd p{fd_, POLLIN, 0};
      if (::poll(&p, 1, static_cast<int>(left.count())) <= 0) continue;
      char buffer[65536];
      const ssize_t n = ::recv(fd_, buffer, sizeof buffer, 0);
      if (n <= 0) return std::nullopt;
      pending_.append(buffer, static_cast<std::size_t>(n));
    }
  }
  // True once the daemon closed the connection (read until EOF or a reset), within `limit`.
  bool closed_by_daemon(std::chrono::milliseconds limit = 10s) {
    const auto deadline = std::chrono::steady_clock::now() + limit;
    char buffer[65536];
    while (std::chrono::steady_clock::now() < deadline) {
      pollfd p{fd_, POLLIN, 0};
      if (::poll(&p, 1, 50) <= 0) continue;
      const ssize_t n = ::recv(fd_, buffer, sizeof buffer, MSG_DONTWAIT);
      if (n == 0 || (n < 0 && errno != EAGAIN && errno != EINTR)) return true;
    }
    return false;
  }

 private:
  int fd_ = -1;
  bool connected_ = false;
  std::string pending_;
};

class Control : public DaemonTest {
 public:
  Control() : DaemonTest("polyport-control") {}

  void SetUp() override {
    DaemonTest::SetUp();
    socket_ = dir() / "admin.sock";
    daemon_ = daemon(kProfile, {"--admin-socket", socket_.string()});
    // The socket appears once the daemon listens; then the engine starts.
    ASSERT_TRUE(eventually([&] { return ctl({"hello"}).code == 0; }, 30s)) << daemon_->errors();
  }
  void TearDown() override {
    if (daemon_) {
      stop(*daemon_);
      EXPECT_FALSE(fs::exists(socket_)) << "the admin socket is removed at exit";
    }
    DaemonTest::TearDown();
  }

  Ctl ctl(std::vector<std::string> args, bool with_socket = true) {
    std::vector<std::string> all{POLYPORTCTL};
    if (with_socket) all.insert(all.end(), {"--socket", socket_.string()});
    all.insert(all.end(), args.begin(), args.end());
    const std::string tag = "ctl-" + std::to_string(++calls_);
    Ctl result;
    {
      Child child(dir(), tag, all);
      result.code = child.wait(20s);
    }
    result.out = read_file(dir() / (tag + ".out"));
    result.err = read_file(dir() / (tag + ".err"));
    return result;
  }
  // The delivered counter of the connection from HW.wheel_speeds, read through polyportctl.
  std::uint64_t delivered() {
    const Ctl s = ctl({"--json", "stats"});
    EXPECT_EQ(s.code, 0) << s.err;
    const Json j = s.json();
    if (j.is_discarded()) return 0;
    for (const Json& c : j["connections"]) {
      if (c.value("source", "") == "HW.wheel_speeds") return c.value("delivered", std::uint64_t{0});
    }
    ADD_FAILURE() << "no connection from HW.wheel_speeds in " << s.out;
    return 0;
  }
  // Forwarding goes on: the counter passes its value now.
  void expect_still_forwarding() {
    const std::uint64_t before = delivered();
    EXPECT_TRUE(eventually([&] { return delivered() > before; }, 10s)) << "delivered stuck at " << before;
  }
  std::string state_of(const std::string& component) {
    const Ctl l = ctl({"--json", "list"});
    EXPECT_EQ(l.code, 0) << l.err;
    const Json graph = l.json();
    for (const Json& c : graph["components"]) {
      if (c.value("name", "") == component) return c.value("state", "");
    }
    return "";
  }

  fs::path socket_;
  std::unique_ptr<Child> daemon_;
  int calls_ = 0;
};

TEST_F(Control, HelloNamesTheDaemonAndItsApplication) {
  const Ctl human = ctl({"hello"});
  EXPECT_EQ(human.code, 0) << human.err;
  EXPECT_NE(human.out.find("application wheelchair_inproc"), std::string::npos) << human.out;
  const Json j = ctl({"--json", "hello"}).json();
  EXPECT_EQ(j["protocol"], 1);
  EXPECT_EQ(j["daemon"], "polyportd");
  EXPECT_GT(j["pid"].get<int>(), 0);
  EXPECT_EQ(j["profiles"][0], kProfile.string());
}

TEST_F(Control, SocketIsPrivateToTheDaemonsUser) {
  struct stat st{};
  ASSERT_EQ(::stat(socket_.c_str(), &st), 0);
  EXPECT_TRUE(S_ISSOCK(st.st_mode));
  EXPECT_EQ(st.st_mode & 0777, 0600u);
  EXPECT_EQ(st.st_uid, ::geteuid());
}

TEST_F(Control, ListShowsComponentsPortsAndConnections) {
  const Ctl l = ctl({"--json", "list"});
  ASSERT_EQ(l.code, 0) << l.err;
  const Json g = l.json();
  std::vector<std::string> names;
  for (const Json& c : g["components"]) {
    names.push_back(c["name"]);
    EXPECT_EQ(c["model"], "inproc");
    EXPECT_EQ(c["state"], "active") << c.dump();
    EXPECT_FALSE(c["ports"].empty());
  }
  EXPECT_EQ(names, (std::vector<std::string>{"Joystick", "Control", "HW"}));
  ASSERT_EQ(g["connections"].size(), 4u);
  bool found = false;
  for (const Json& c : g["connections"]) {
    EXPECT_TRUE(c.contains("policy") && c.contains("conversion")) << c.dump();
    found = found || (c["source"] == "Joystick.reference" && c["target"] == "Control.reference");
  }
  EXPECT_TRUE(found) << g["connections"].dump();
  const Ctl human = ctl({"list"});
  EXPECT_EQ(human.code, 0);
  EXPECT_NE(human.out.find("Joystick.reference -> Control.reference"), std::string::npos) << human.out;
  std::cout << human.out;  // the README's sample
}

TEST_F(Control, StatsAreLive) {
  const Ctl human = ctl({"stats"});
  EXPECT_EQ(human.code, 0) << human.err;
  EXPECT_NE(human.out.find("DELIVERED"), std::string::npos) << human.out;
  expect_still_forwarding();
}

TEST_F(Control, DeactivateAndActivateAComponent) {
  EXPECT_EQ(state_of("Control"), "active");
  const Ctl off = ctl({"deactivate", "Control"});
  EXPECT_EQ(off.code, 0) << off.err;
  EXPECT_EQ(off.out, "Control: inactive\n");
  EXPECT_EQ(state_of("Control"), "inactive");
  // Deactivating twice is a transition the lifecycle does not allow: refused, exit code 1.
  const Ctl again = ctl({"deactivate", "Control"});
  EXPECT_EQ(again.code, 1);
  EXPECT_NE(again.err.find("state inactive"), std::string::npos) << again.err;
  const Ctl on = ctl({"activate", "Control"});
  EXPECT_EQ(on.code, 0) << on.err;
  EXPECT_EQ(state_of("Control"), "active");
}

// The wheelchair fails safe (profiles/wheelchair_inproc.xml): with the Joystick component
// stopped, its reference goes silent and, 20 ms later, the watchdog on Control.voltages -> HW
// hands HW zero volts; once the Joystick runs again, Control's command passes again.
TEST_F(Control, StoppedJoystickTripsTheMotorWatchdogAndItsReturnRecovers) {
  const auto watchdog = [&]() -> Json {
    const Ctl s = ctl({"--json", "stats"});
    EXPECT_EQ(s.code, 0) << s.err;
    const Json j = s.json();
    if (!j.is_discarded()) {
      for (const Json& c : j["connections"]) {
        if (c.value("target", "") == "HW.voltages" && c.contains("watchdog")) return c["watchdog"];
      }
    }
    ADD_FAILURE() << "no watchdog on the connection to HW.voltages in " << s.out;
    return Json::object();
  };
  ASSERT_TRUE(eventually([&] { return watchdog().value("state", "") == "ok"; }, 10s)) << watchdog().dump();
  EXPECT_EQ(watchdog().value("upstream", ""), "Joystick.reference");
  const std::uint64_t trips = watchdog().value("trips", std::uint64_t{0});

  ASSERT_EQ(ctl({"deactivate", "Joystick"}).code, 0);
  ASSERT_TRUE(eventually([&] { return watchdog().value("state", "") == "tripped"; }, 10s)) << watchdog().dump();
  const Json tripped = watchdog();
  EXPECT_EQ(tripped.value("trips", std::uint64_t{0}), trips + 1) << tripped.dump();
  // HW reads every period: the safe value, new once.
  ASSERT_TRUE(eventually([&] { return watchdog().value("safe_values", 0) > 0; }, 10s)) << watchdog().dump();
  EXPECT_NE(daemon_->errors().find("watchdog Control.voltages -> HW.voltages: tripped, Joystick.reference silent"),
            std::string::npos)
      << daemon_->errors();

  ASSERT_EQ(ctl({"activate", "Joystick"}).code, 0);
  ASSERT_TRUE(eventually([&] { return watchdog().value("state", "") == "ok"; }, 10s)) << watchdog().dump();
  EXPECT_EQ(watchdog().value("recoveries", std::uint64_t{0}), watchdog().value("trips", std::uint64_t{0}));
  EXPECT_NE(daemon_->errors().find("watchdog Control.voltages -> HW.voltages: recovered"), std::string::npos)
      << daemon_->errors();
}

TEST_F(Control, UnknownComponentAndUsageErrors) {
  const Ctl unknown = ctl({"activate", "Nobody"});
  EXPECT_EQ(unknown.code, 1);
  EXPECT_NE(unknown.err.find("no component named 'Nobody' (components: Joystick, Control, HW)"), std::string::npos)
      << unknown.err;
  EXPECT_EQ(ctl({"activate"}).code, 2);
  EXPECT_EQ(ctl({"frobnicate"}).code, 2);
  const Ctl nobody = ctl({"--socket", (dir() / "nothing.sock").string(), "hello"}, false);
  EXPECT_EQ(nobody.code, 3);
  EXPECT_NE(nobody.err.find("no daemon listens on"), std::string::npos) << nobody.err;
}

TEST_F(Control, GarbageGetsAnErrorReplyAndForwardingGoesOn) {
  RawClient client(socket_);
  ASSERT_TRUE(client.connected());
  client.send_some("this is not JSON\n{\"v\":1,\"id\":4,\"cmd\":\"hello\"}\n");
  const auto error = client.reply();
  ASSERT_TRUE(error);
  EXPECT_EQ((*error)["ok"], false);
  EXPECT_EQ((*error)["code"], "bad_request");
  // The same connection still serves the next request.
  const auto hello = client.reply();
  ASSERT_TRUE(hello);
  EXPECT_EQ((*hello)["ok"], true);
  EXPECT_EQ((*hello)["id"], 4);
  expect_still_forwarding();
}

TEST_F(Control, AMegabyteLineIsCutOffAndForwardingGoesOn) {
  RawClient client(socket_);
  ASSERT_TRUE(client.connected());
  const std::string huge(1 << 20, 'x');
  std::size_t sent = 0;
  // Sends while the daemon reads; it stops reading (and closes) past 64 KiB.
  const auto deadline = std::chrono::steady_clock::now() + 10s;
  while (sent < huge.size() && std::chrono::steady_clock::now() < deadline) {
    const std::size_t n = client.send_some(huge.substr(sent, 65536));
    sent += n;
    if (n == 0) {
      pollfd p{client.fd(), POLLOUT, 0};
      ::poll(&p, 1, 50);
      if (p.revents & (POLLHUP | POLLERR)) break;
    }
  }
  EXPECT_LT(sent, huge.size()) << "the daemon read the whole megabyte";
  const auto reply = client.reply();
  if (reply) {
    EXPECT_EQ((*reply)["code"], "too_long") << reply->dump();
  }
  EXPECT_TRUE(client.closed_by_daemon());
  EXPECT_TRUE(eventually([&] { return daemon_->errors().find("request line over 65536 bytes; cut off") != std::string::npos; }, 10s))
      << daemon_->errors();
  expect_still_forwarding();
}

TEST_F(Control, AClientThatNeverReadsIsCutOff) {
  RawClient client(socket_);
  ASSERT_TRUE(client.connected());
  std::string requests;
  for (int i = 0; i < 200; ++i) requests += "{\"v\":1,\"id\":" + std::to_string(i) + ",\"cmd\":\"stats\"}\n";
  // Keeps asking, never reads: the replies pile up past the daemon's bound.
  const bool cut = eventually(
      [&] {
        client.send_some(requests);
        pollfd p{client.fd(), 0, 0};
        ::poll(&p, 1, 0);
        return (p.revents & POLLHUP) != 0;
      },
      30s);
  EXPECT_TRUE(cut) << "the daemon kept a client that never reads";
  EXPECT_TRUE(eventually([&] { return daemon_->errors().find("bytes of replies unread; cut off") != std::string::npos; }, 10s))
      << daemon_->errors();
  expect_still_forwarding();
}

// Without --admin-socket the daemon uses $XDG_RUNTIME_DIR/polyport/polyportd-<pid>.sock (the
// folder created 0700), and polyportctl without --socket finds it when it is the only one.
class DefaultSocket : public DaemonTest {
 public:
  DefaultSocket() : DaemonTest("polyport-control-default") {}
  void SetUp() override {
    DaemonTest::SetUp();
    const char* old = std::getenv("XDG_RUNTIME_DIR");
    if (old != nullptr) saved_ = old;
    runtime_ = dir() / "xdg";
    fs::create_directories(runtime_);
    ::setenv("XDG_RUNTIME_DIR", runtime_.c_str(), 1);  // inherited by polyportd and polyportctl
  }
  void TearDown() override {
    if (saved_) ::setenv("XDG_RUNTIME_DIR", saved_->c_str(), 1);
    else ::unsetenv("XDG_RUNTIME_DIR");
    DaemonTest::TearDown();
  }
  Ctl ctl(std::vector<std::string> args) {
    args.insert(args.begin(), POLYPORTCTL);
    const std::string tag = "ctl-" + std::to_string(++calls_);
    Ctl result;
    {
      Child child(dir(), tag, args);
      result.code = child.wait(20s);
    }
    result.out = read_file(dir() / (tag + ".out"));
    result.err = read_file(dir() / (tag + ".err"));
    return result;
  }

  fs::path runtime_;
  std::optional<std::string> saved_;
  int calls_ = 0;
};

TEST_F(DefaultSocket, DaemonAndCtlMeetInTheRuntimeFolder) {
  const Ctl none = ctl({"hello"});
  EXPECT_EQ(none.code, 3);
  EXPECT_NE(none.err.find("no daemon socket in " + (runtime_ / "polyport").string()), std::string::npos) << none.err;

  auto d = daemon(kProfile);
  ASSERT_TRUE(eventually([&] { return ctl({"hello"}).code == 0; }, 30s)) << d->errors();
  const Json hello = ctl({"--json", "hello"}).json();
  const fs::path socket = runtime_ / "polyport" / ("polyportd-" + std::to_string(hello["pid"].get<int>()) + ".sock");
  EXPECT_TRUE(fs::exists(socket)) << socket;
  struct stat st{};
  ASSERT_EQ(::stat((runtime_ / "polyport").c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0700u);

  // A second socket (another daemon): polyportctl asks which one.
  { std::ofstream(runtime_ / "polyport" / "polyportd-1.sock") << ""; }
  const Ctl two = ctl({"hello"});
  EXPECT_EQ(two.code, 2);
  EXPECT_NE(two.err.find("2 daemon sockets"), std::string::npos) << two.err;
  EXPECT_EQ(ctl({"--socket", socket.string(), "hello"}).code, 0);
  fs::remove(runtime_ / "polyport" / "polyportd-1.sock");

  stop(*d);
  EXPECT_FALSE(fs::exists(socket)) << "the admin socket is removed at exit";
}

// Runs polyportctl as uid/gid 65534 (nobody); its exit code and stderr.
Ctl as_nobody(const fs::path& dir, const fs::path& socket) {
  const fs::path err = dir / "nobody.err";
  const int err_fd = ::open(err.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  const pid_t pid = ::fork();
  if (pid == 0) {
    ::dup2(err_fd, 2);
    if (::setgid(65534) != 0 || ::setuid(65534) != 0) ::_exit(100);
    execl(POLYPORTCTL, POLYPORTCTL, "--socket", socket.c_str(), "hello", static_cast<char*>(nullptr));
    ::_exit(101);
  }
  ::close(err_fd);
  Ctl result;
  int status = 0;
  const bool ended = eventually([&] { return ::waitpid(pid, &status, WNOHANG) == pid; }, 20s);
  if (!ended) {
    ::kill(pid, SIGKILL);
    ::waitpid(pid, &status, 0);
  }
  result.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  result.err = read_file(err);
  return result;
}

// Whether uid 65534 may `access(path, mode)` (every folder on the way searchable).
bool nobody_can(const fs::path& path, int mode) {
  const pid_t pid = ::fork();
  if (pid == 0) {
    if (::setgid(65534) != 0 || ::setuid(65534) != 0) ::_exit(2);
    ::_exit(::access(path.c_str(), mode) == 0 ? 0 : 1);
  }
  int status = 0;
  ::waitpid(pid, &status, 0);
  return WIFEXITED(status) && WEXITSTATUS(status) == 0;
}

TEST_F(Control, AnotherUserIsRefused) {
  if (::geteuid() != 0) GTEST_SKIP() << "running a client under another uid needs root (setuid); this test runs as uid "
                                     << ::geteuid();
  if (!nobody_can(POLYPORTCTL, X_OK) || !nobody_can(dir(), X_OK)) {
    GTEST_SKIP() << "uid 65534 cannot run " << POLYPORTCTL << " or reach " << dir()
                 << " (a folder on the way is closed to others)";
  }
  // The socket file's mode (0600) stops it first.
  const Ctl blocked = as_nobody(dir(), socket_);
  EXPECT_EQ(blocked.code, 3) << blocked.err;
  EXPECT_NE(blocked.err.find("access denied"), std::string::npos) << blocked.err;
  // With the file opened up, the peer credentials check refuses it, with a reason.
  fs::permissions(dir(), fs::perms::owner_all | fs::perms::others_exec | fs::perms::group_exec);
  ASSERT_EQ(::chmod(socket_.c_str(), 0666), 0);
  const Ctl refused = as_nobody(dir(), socket_);
  EXPECT_EQ(refused.code, 3) << refused.err;
  EXPECT_NE(refused.err.find("access denied: uid 65534 is neither the daemon's uid"), std::string::npos) << refused.err;
  EXPECT_NE(daemon_->errors().find("refused a connection from uid 65534"), std::string::npos) << daemon_->errors();
  expect_still_forwarding();
}

}  // namespace
}  // namespace polyport::test
