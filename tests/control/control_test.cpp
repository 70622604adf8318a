// A running polyportd (the in-process wheelchair) driven through polyportctl only, and the
// admin socket's defences against clients that misbehave: garbage, an over-long line, a
// client that never reads, a client of another uid. Every wait polls with a deadline.
#include <errno.h>
#include <grp.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>

#include <cmath>
#include <cstring>
#include <cstdlib>
#include <optional>

#include "../support/daemon_harness.hpp"

namespace polyport::test {
namespace {

const fs::path kProfile = POLYPORT_SOURCE_DIR "/profiles/wheelchair_inproc.xml";

using Ctl = DaemonTest::Ran;

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
    // Joystick's output is traced: what the component makes of its properties.
    std::vector<std::string> args{"--admin-socket", socket_.string(), "--trace", "Joystick.reference", "--trace-file",
                                  (dir() / "trace.jsonl").string()};
    for (const std::string& a : extra_args()) args.push_back(a);
    daemon_ = daemon(profile(), args);
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
    return run_to_end(all, 20s);
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

  // The connection's entry in the live stats (the one still connected unless `removed`).
  Json connection(const std::string& source, const std::string& target, bool removed = false) {
    const Ctl s = ctl({"--json", "stats"});
    EXPECT_EQ(s.code, 0) << s.err;
    const Json j = s.json();
    if (j.is_discarded()) return Json();
    for (const Json& c : j["connections"]) {
      if (c.value("source", "") == source && c.value("target", "") == target && c.value("removed", false) == removed &&
          !c.value("probe", false)) {
        return c;
      }
    }
    return Json();
  }
  std::uint64_t delivered(const std::string& source, const std::string& target, bool removed = false) {
    return connection(source, target, removed).value("delivered", std::uint64_t{0});
  }
  // The speed of the latest Joystick.reference sample in the trace (NaN before there is one).
  double traced_speed() {
    std::ifstream in(dir() / "trace.jsonl");
    std::string line;
    double speed = std::nan("");
    while (std::getline(in, line)) {
      const Json j = Json::parse(line, nullptr, false);
      if (!j.is_discarded() && j.value("port", "") == "Joystick.reference") speed = j["value"].value("speed_mps", speed);
    }
    return speed;
  }
  // Error code of a request sent as a raw line.
  std::string code_of(const std::string& request) {
    RawClient client(socket_);
    EXPECT_TRUE(client.connected());
    client.send_some(request + "\n");
    const auto reply = client.reply();
    if (!reply) return "(no reply)";
    return reply->value("ok", false) ? "ok" : reply->value("code", "");
  }
  virtual fs::path profile() const { return kProfile; }
  virtual std::vector<std::string> extra_args() const { return {}; }
  // Trace probes on `port` still taking samples (polyportd's own --trace is one of them).
  int open_probes(const std::string& port) {
    const Json j = ctl({"--json", "stats"}).json();
    int n = 0;
    if (j.is_discarded()) return -1;
    for (const Json& c : j["connections"]) {
      if (c.value("probe", false) && !c.value("removed", false) && c.value("source", "") == port) ++n;
    }
    return n;
  }

  fs::path socket_;
  std::unique_ptr<Child> daemon_;
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

TEST_F(Control, ASetPropertyIsUsedByTheComponent) {
  const Ctl all = ctl({"get", "Joystick"});
  EXPECT_EQ(all.code, 0) << all.err;
  EXPECT_NE(all.out.find("max_speed  double  1.5    1.5"), std::string::npos) << all.out;
  std::cout << all.out;  // the README's sample
  const Json before = ctl({"--json", "get", "Joystick", "max_speed"}).json();
  EXPECT_EQ(before["settable"], true);
  ASSERT_EQ(before["properties"].size(), 1u) << before.dump();
  EXPECT_EQ(before["properties"][0]["value"], 1.5);
  EXPECT_EQ(before["properties"][0]["type"], "double");
  // The scripted stick is at 60 % from 0.5 s: 0.6 * 1.5 m/s.
  ASSERT_TRUE(eventually([&] { return std::abs(traced_speed() - 0.9) < 1e-9; }, 20s)) << traced_speed();

  const Ctl set = ctl({"set", "Joystick", "max_speed", "0.5"});
  EXPECT_EQ(set.code, 0) << set.err;
  EXPECT_EQ(set.out, "Joystick.max_speed = 0.5 (was 1.5)\n");
  // The component uses it: 0.6 * 0.5 m/s from its next cycle on.
  EXPECT_TRUE(eventually([&] { return std::abs(traced_speed() - 0.3) < 1e-9; }, 20s)) << traced_speed();
  const Ctl one = ctl({"get", "Joystick", "max_speed"});
  EXPECT_EQ(one.code, 0) << one.err;
  EXPECT_EQ(one.out, "0.5\n");
  const Json after = ctl({"--json", "get", "Joystick", "max_speed"}).json();
  EXPECT_EQ(after["properties"][0]["value"], 0.5);
  EXPECT_EQ(after["properties"][0]["profile_value"], 1.5);
  EXPECT_NE(daemon_->errors().find("admin: set Joystick.max_speed = 0.5 (was 1.5)"), std::string::npos);
}

TEST_F(Control, BadPropertyRequestsAreRefusedWithAReason) {
  struct Case {
    std::vector<std::string> args;
    const char* says;
  };
  for (const Case& c : {
           Case{{"set", "Joystick", "max_speed", "fast"}, "bad value 'fast' for property 'max_speed' of type 'double'"},
           Case{{"set", "Joystick", "max_speed", "--", "-1"},
                "cannot set Joystick.max_speed = -1: the component refused the value (onPropertyChanged returned bad_parameter)"},
           Case{{"set", "Joystick", "nothing", "1"}, "Joystick has no property 'nothing' (properties: max_speed)"},
           Case{{"get", "Joystick", "nothing"}, "Joystick has no property 'nothing' (properties: max_speed)"},
           Case{{"set", "Control", "kp", "7"},
                "cannot set Control.kp = 7: the component does not take changes of this property while it runs (inproc component)"},
           Case{{"set", "Nobody", "kp", "7"}, "no component named 'Nobody' (components: Joystick, Control, HW)"},
           Case{{"get", "Nobody"}, "no component named 'Nobody'"},
       }) {
    const Ctl r = ctl(c.args);
    EXPECT_EQ(r.code, 1) << c.args[0] << " " << c.args[1] << ": " << r.err;
    EXPECT_NE(r.err.find(c.says), std::string::npos) << r.err;
  }
  // Nothing changed.
  EXPECT_EQ(ctl({"get", "Joystick", "max_speed"}).out, "1.5\n");
  EXPECT_EQ(ctl({"set", "Joystick"}).code, 2);
  EXPECT_EQ(ctl({"get"}).code, 2);
  // Each refusal with its code.
  EXPECT_EQ(code_of(R"({"v":1,"cmd":"set","component":"Joystick","property":"max_speed","value":"x"})"), "bad_value");
  EXPECT_EQ(code_of(R"({"v":1,"cmd":"set","component":"Joystick","property":"max_speed","value":-1})"), "refused");
  EXPECT_EQ(code_of(R"({"v":1,"cmd":"set","component":"Joystick","property":"nope","value":1})"), "unknown_property");
  EXPECT_EQ(code_of(R"({"v":1,"cmd":"set","component":"Control","property":"kp","value":7})"), "unsupported");
  EXPECT_EQ(code_of(R"({"v":1,"cmd":"set","component":"Nobody","property":"kp","value":7})"), "unknown_component");
  EXPECT_EQ(code_of(R"({"v":1,"cmd":"set","component":"Joystick","property":"max_speed","value":0.7})"), "ok");
  EXPECT_EQ(ctl({"get", "Joystick", "max_speed"}).out, "0.7\n");
  expect_still_forwarding();
}

// The wheelchair with a spare, unconnected joystick handler: ports wired while it runs.
class Wiring : public Control {
 public:
  fs::path profile() const override { return POLYPORT_SOURCE_DIR "/tests/control/wheelchair_spare.xml"; }
};

TEST_F(Wiring, AConnectionMadeAtRunTimeCarriesSamplesUntilItIsRemoved) {
  const std::string hw = "HW.joystick";
  const std::string spare = "Spare.position";
  const Ctl connect = ctl({"connect", hw, spare, "--policy", "buffer", "--depth", "8"});
  ASSERT_EQ(connect.code, 0) << connect.err;
  EXPECT_EQ(connect.out, "connected HW.joystick -> Spare.position (buffer/8, passthrough)\n");
  EXPECT_NE(daemon_->errors().find("admin: connected HW.joystick -> Spare.position (buffer/8, passthrough)"),
            std::string::npos) << daemon_->errors();
  // `list` shows it, made at run time.
  const Json graph = ctl({"--json", "list"}).json();
  bool listed = false;
  for (const Json& c : graph["connections"]) {
    if (c["source"] == hw && c["target"] == spare) {
      listed = true;
      EXPECT_EQ(c["origin"], "run time");
      EXPECT_EQ(c["policy"], "buffer");
      EXPECT_EQ(c["depth"], 8);
    } else {
      EXPECT_EQ(c["origin"], "profile") << c.dump();
    }
  }
  EXPECT_TRUE(listed) << graph.dump();
  const Ctl human = ctl({"list"});
  EXPECT_NE(human.out.find("HW.joystick -> Spare.position"), std::string::npos) << human.out;
  std::cout << human.out;  // the README's sample
  // Samples flow: the delivered counter rises.
  const std::uint64_t first = delivered(hw, spare);
  EXPECT_TRUE(eventually([&] { return delivered(hw, spare) > first + 10; }, 20s)) << first;
  EXPECT_EQ(connection(hw, spare).value("dropped", std::uint64_t{1}), 0u);

  const Ctl disconnect = ctl({"disconnect", hw, spare});
  ASSERT_EQ(disconnect.code, 0) << disconnect.err;
  EXPECT_EQ(disconnect.out, "disconnected HW.joystick -> Spare.position\n");
  Json remaining = ctl({"--json", "list"}).json();  // the loop's range must outlive the loop
  for (const Json& c : remaining["connections"]) {
    EXPECT_FALSE(c["source"] == hw && c["target"] == spare) << c.dump();
  }
  // It stops: once HW has written twice more (any write that had the connection in hand is
  // over), its count stays while HW goes on writing to Joystick.
  const std::uint64_t profile_before = delivered(hw, "Joystick.position");
  ASSERT_TRUE(eventually([&] { return delivered(hw, "Joystick.position") >= profile_before + 2; }, 20s));
  ASSERT_FALSE(connection(hw, spare, true).is_null()) << "the removed connection is not in stats";
  const std::uint64_t stopped = delivered(hw, spare, true);
  EXPECT_GT(stopped, first + 10);
  const std::uint64_t profile_now = delivered(hw, "Joystick.position");
  ASSERT_TRUE(eventually([&] { return delivered(hw, "Joystick.position") >= profile_now + 20; }, 20s));
  EXPECT_EQ(delivered(hw, spare, true), stopped);
  EXPECT_TRUE(connection(hw, spare).is_null()) << "a removed connection is still connected";

  // Connected again (the input port's own policy this time), samples flow again.
  const Ctl again = ctl({"connect", hw, spare});
  ASSERT_EQ(again.code, 0) << again.err;
  EXPECT_EQ(again.out, "connected HW.joystick -> Spare.position (data, passthrough)\n");
  EXPECT_TRUE(eventually([&] { return delivered(hw, spare) > 10; }, 20s));
}

TEST_F(Wiring, AConnectionFromTheProfileCanBeRemovedAndMadeAgain) {
  const std::string hw = "HW.wheel_speeds";
  const std::string control = "Control.wheel_speeds";
  const Ctl disconnect = ctl({"--json", "disconnect", hw, control});
  ASSERT_EQ(disconnect.code, 0) << disconnect.err;
  EXPECT_EQ(disconnect.json()["origin"], "profile");
  EXPECT_EQ(ctl({"--json", "list"}).json()["connections"].size(), 3u);
  const Ctl connect = ctl({"--json", "connect", hw, control, "--policy", "circular", "--depth", "4"});
  ASSERT_EQ(connect.code, 0) << connect.err;
  const Json made = connect.json();
  EXPECT_EQ(made["origin"], "run time");
  EXPECT_EQ(made["policy"], "circular");
  EXPECT_EQ(made["depth"], 4);
  EXPECT_EQ(made["conversion"], "passthrough");
  EXPECT_TRUE(eventually([&] { return delivered(hw, control) > 10; }, 20s));
}

TEST_F(Wiring, BadConnectionsAreRefusedInTheLoadersWords) {
  struct Case {
    std::vector<std::string> args;
    const char* says;
  };
  for (const Case& c : {
           Case{{"connect", "HW.joystick", "Nobody.position"}, "unknown component 'Nobody'"},
           Case{{"connect", "HW.joystick", "Spare.nothing"}, "component 'Spare' has no port 'nothing'"},
           Case{{"connect", "Spare.position", "Spare.reference"},
                "Spare.position is an input port; a data connection's source must be an output port"},
           Case{{"connect", "HW.wheel_speeds", "Spare.position"}, "type mismatch"},
           Case{{"connect", "HW.joystick", "Spare.position", "--policy", "fifo"}, "bad policy 'fifo'"},
           Case{{"connect", "HW.joystick", "Spare.position", "--depth", "0", "--policy", "buffer"},
                "bad depth '0': expected an integer from 1 to 4294967295"},
           Case{{"connect", "HW.joystick", "Spare.position", "--policy", "data", "--depth", "4"},
                "a depth needs a buffer or circular policy"},
           Case{{"connect", "HW.joystick", "Joystick.position"}, "HW.joystick is already connected to Joystick.position"},
           Case{{"disconnect", "HW.joystick", "Spare.position"}, "no connection HW.joystick -> Spare.position"},
       }) {
    const Ctl r = ctl(c.args);
    EXPECT_EQ(r.code, 1) << c.args[1] << " " << c.args[2] << ": " << r.err;
    EXPECT_NE(r.err.find(c.says), std::string::npos) << r.err;
  }
  EXPECT_EQ(ctl({"connect", "HW.joystick", "Spare"}).code, 2);
  EXPECT_EQ(ctl({"connect", "HW.joystick"}).code, 2);
  EXPECT_EQ(ctl({"disconnect", ".x", "Spare.position"}).code, 2);
  EXPECT_EQ(code_of(R"({"v":1,"cmd":"connect","source":"HW.joystick","target":"Nobody.position"})"), "invalid_connection");
  EXPECT_EQ(code_of(R"({"v":1,"cmd":"connect","source":"HW.joystick","target":"Joystick.position"})"), "refused");
  EXPECT_EQ(code_of(R"({"v":1,"cmd":"disconnect","source":"HW.joystick","target":"Spare.position"})"), "unknown_connection");
  EXPECT_EQ(code_of(R"({"v":1,"cmd":"connect","source":"HW","target":"Spare.position"})"), "bad_request");
  // The graph is as the profile made it.
  EXPECT_EQ(ctl({"--json", "list"}).json()["connections"].size(), 4u);
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
    return run_to_end(args, 20s);
  }

  fs::path runtime_;
  std::optional<std::string> saved_;
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

// Runs polyportctl as uid/gid 65534 (nobody), with `groups` as its supplementary groups; its
// exit code and stderr.
Ctl as_nobody(const fs::path& dir, const fs::path& socket, const std::vector<gid_t>& groups = {}) {
  const fs::path err = dir / "nobody.err";
  const int err_fd = ::open(err.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  const pid_t pid = ::fork();
  if (pid == 0) {
    ::dup2(err_fd, 2);
    if (::setgroups(groups.size(), groups.data()) != 0 || ::setgid(65534) != 0 || ::setuid(65534) != 0) ::_exit(100);
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

// stats --watch with its output in a file (not a terminal): one table after another, the
// counts rising; once the daemon goes, it says so and exits 3.
TEST_F(Control, StatsWatchPrintsATableEachIntervalWithRisingCounts) {
  Child watch(dir(), "watch", {POLYPORTCTL, "--socket", socket_.string(), "stats", "--watch", "--interval", "0.2"});
  ASSERT_TRUE(watch.started());
  // The DELIVERED column of HW.wheel_speeds -> Control.wheel_speeds in each table so far.
  const auto delivered_column = [&] {
    std::vector<std::uint64_t> values;
    std::istringstream in(read_file(dir() / "watch.out"));
    std::string line;
    while (std::getline(in, line)) {
      if (line.rfind("HW.wheel_speeds -> Control.wheel_speeds  ", 0) != 0) continue;
      std::istringstream cells(line.substr(std::string("HW.wheel_speeds -> Control.wheel_speeds").size()));
      std::uint64_t received = 0, delivered = 0;
      cells >> received >> delivered;
      values.push_back(delivered);
    }
    return values;
  };
  ASSERT_TRUE(eventually([&] { return delivered_column().size() >= 3; }, 20s)) << read_file(dir() / "watch.out");
  const std::vector<std::uint64_t> values = delivered_column();
  EXPECT_LT(values[0], values[1]);
  EXPECT_LT(values[1], values[2]);
  const std::string out = read_file(dir() / "watch.out");
  EXPECT_NE(out.find("CONNECTION"), std::string::npos);
  EXPECT_NE(out.find("DLV/S"), std::string::npos);
  EXPECT_EQ(out.find("\033["), std::string::npos) << "no screen control when stdout is not a terminal";
  EXPECT_EQ(out.find("probe."), std::string::npos) << "trace probes are not listed";
  std::cout << out.substr(0, out.find("\n\n")) << "\n";  // the README's sample

  stop(*daemon_);
  daemon_.reset();
  EXPECT_EQ(watch.wait(20s), 3);
  EXPECT_NE(watch.errors().find("the daemon went away"), std::string::npos) << watch.errors();
}

TEST_F(Control, TracePrintsDecodedSamplesOfAPort) {
  const Ctl json = ctl({"--json", "trace", "Joystick.reference", "--count", "5"});
  ASSERT_EQ(json.code, 0) << json.err;
  std::vector<Json> samples;
  std::istringstream in(json.out);
  std::string line;
  while (std::getline(in, line)) samples.push_back(Json::parse(line, nullptr, false));
  ASSERT_EQ(samples.size(), 5u) << json.out;
  std::int64_t last = 0;
  for (const Json& sample : samples) {
    ASSERT_FALSE(sample.is_discarded()) << json.out;
    EXPECT_EQ(sample.value("port", ""), "Joystick.reference");
    EXPECT_GT(sample.value("t_ns", std::int64_t{0}), last);
    last = sample.value("t_ns", std::int64_t{0});
    // wheelchair::Reference, decoded.
    ASSERT_TRUE(sample["value"].contains("direction_deg")) << sample.dump();
    EXPECT_TRUE(sample["value"]["speed_mps"].is_number()) << sample.dump();
  }
  const Ctl human = ctl({"trace", "Joystick.reference", "--count", "3"});
  EXPECT_EQ(human.code, 0) << human.err;
  EXPECT_EQ(std::count(human.out.begin(), human.out.end(), '\n'), 3) << human.out;
  EXPECT_NE(human.out.find("  Joystick.reference  {\"direction_deg\":"), std::string::npos) << human.out;
  EXPECT_NE(human.err.find("3 sample(s) of Joystick.reference, 0 lost (count reached)"), std::string::npos) << human.err;
  std::cout << human.out;  // the README's sample
  const Ctl timed = ctl({"--json", "trace", "Joystick.reference", "--duration", "0.5"});
  EXPECT_EQ(timed.code, 0) << timed.err;
  EXPECT_GT(std::count(timed.out.begin(), timed.out.end(), '\n'), 0) << timed.out;
  // Each trace's probe leaves with it: only polyportd's own --trace remains.
  EXPECT_TRUE(eventually([&] { return open_probes("Joystick.reference") == 1; }, 10s));

  // A trace without an end, stopped by its user (SIGTERM, as Ctrl-C): the probe goes too.
  {
    Child endless(dir(), "endless", {POLYPORTCTL, "--socket", socket_.string(), "trace", "Joystick.reference"});
    ASSERT_TRUE(eventually([&] { return read_file(dir() / "endless.out").find("speed_mps") != std::string::npos; }, 20s))
        << endless.errors();
    EXPECT_EQ(open_probes("Joystick.reference"), 2);
  }
  EXPECT_TRUE(eventually([&] { return open_probes("Joystick.reference") == 1; }, 10s));
  EXPECT_TRUE(eventually([&] { return daemon_->errors().find("trace of Joystick.reference ended: its client left") != std::string::npos; }, 10s))
      << daemon_->errors();

  const Ctl unknown = ctl({"trace", "Joystick.position"});
  EXPECT_EQ(unknown.code, 1);
  EXPECT_NE(unknown.err.find("no output data port 'Joystick.position' (output data ports: Joystick.reference,"),
            std::string::npos) << unknown.err;
  EXPECT_EQ(ctl({"trace", "Joystick"}).code, 2);
  EXPECT_EQ(ctl({"trace", "Joystick.reference", "--count", "0"}).code, 2);
  EXPECT_EQ(code_of(R"({"v":1,"cmd":"trace","port":"Joystick.nothing"})"), "unknown_port");
  EXPECT_EQ(code_of(R"({"v":1,"cmd":"trace","port":"Joystick.reference","count":0})"), "bad_request");
  expect_still_forwarding();
}

// The wheelchair with a joystick handler at 1 kHz, whose trace fills a socket quickly.
class FastTrace : public Control {
 public:
  fs::path profile() const override { return POLYPORT_SOURCE_DIR "/tests/control/wheelchair_fast.xml"; }
};

TEST_F(FastTrace, ATraceClientThatNeverReadsIsCutOffAndForwardingGoesOn) {
  RawClient client(socket_);
  ASSERT_TRUE(client.connected());
  client.send_some(R"({"v":1,"id":1,"cmd":"trace","port":"Fast.reference"})" "\n");
  ASSERT_TRUE(eventually([&] { return open_probes("Fast.reference") == 1; }, 10s));
  // It never reads: the samples pile up past the daemon's bound (1 MiB) and it is cut off.
  const bool cut = eventually(
      [&] {
        pollfd p{client.fd(), 0, 0};
        ::poll(&p, 1, 0);
        return (p.revents & POLLHUP) != 0;
      },
      90s);
  EXPECT_TRUE(cut) << "the daemon kept a trace client that never reads";
  EXPECT_TRUE(eventually([&] { return daemon_->errors().find("bytes of replies unread; cut off") != std::string::npos; }, 10s))
      << daemon_->errors();
  EXPECT_TRUE(eventually([&] { return daemon_->errors().find("trace of Fast.reference ended: its client left") != std::string::npos; }, 10s))
      << daemon_->errors();
  EXPECT_TRUE(eventually([&] { return open_probes("Fast.reference") == 0; }, 10s));
  expect_still_forwarding();
  // The next trace client is served as usual.
  const Ctl again = ctl({"--json", "trace", "Fast.reference", "--count", "3"});
  EXPECT_EQ(again.code, 0) << again.err;
}

// polyportd run --admin-group: the socket belongs to the group (mode 0660) and a peer whose
// groups include it is admitted; a gid with no name is taken as it is.
constexpr gid_t kGroup = 60123;
class AdminGroup : public Control {
 public:
  std::vector<std::string> extra_args() const override { return {"--admin-group", std::to_string(kGroup)}; }
};

TEST_F(AdminGroup, AMemberOfTheGroupIsAdmittedAnotherUserIsRefused) {
  struct stat st{};
  ASSERT_EQ(::stat(socket_.c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0660u);
  EXPECT_EQ(st.st_gid, kGroup);
  if (::geteuid() != 0) GTEST_SKIP() << "running a client under another uid needs root (setuid); this test runs as uid "
                                     << ::geteuid();
  if (!nobody_can(POLYPORTCTL, X_OK) || !nobody_can(dir(), X_OK)) {
    GTEST_SKIP() << "uid 65534 cannot run " << POLYPORTCTL << " or reach " << dir()
                 << " (a folder on the way is closed to others)";
  }
  const Ctl member = as_nobody(dir(), socket_, {kGroup});
  EXPECT_EQ(member.code, 0) << member.err;
  // Not in the group: the socket file's mode stops it first, then the credentials check.
  const Ctl blocked = as_nobody(dir(), socket_, {kGroup + 1});
  EXPECT_EQ(blocked.code, 3) << blocked.err;
  EXPECT_NE(blocked.err.find("access denied"), std::string::npos) << blocked.err;
  ASSERT_EQ(::chmod(socket_.c_str(), 0666), 0);
  const Ctl refused = as_nobody(dir(), socket_, {kGroup + 1});
  EXPECT_EQ(refused.code, 3) << refused.err;
  EXPECT_NE(refused.err.find("nor root, and not in the allowed group (gid 60123)"), std::string::npos) << refused.err;
  EXPECT_EQ(as_nobody(dir(), socket_, {kGroup}).code, 0);
  expect_still_forwarding();
}

TEST(AdminGroupOption, AnUnknownGroupIsABadCommandLine) {
  const fs::path dir = fs::temp_directory_path() / ("polyport-control-group-" + std::to_string(::getpid()));
  fs::create_directories(dir);
  Child d(dir, "polyportd", {POLYPORTD, "run", kProfile.string(), "--admin-socket", (dir / "a.sock").string(),
                             "--admin-group", "no-such-group-here"});
  EXPECT_EQ(d.wait(20s), 2);
  EXPECT_NE(d.errors().find("no group named 'no-such-group-here'"), std::string::npos) << d.errors();
  fs::remove_all(dir);
}

}  // namespace
}  // namespace polyport::test
