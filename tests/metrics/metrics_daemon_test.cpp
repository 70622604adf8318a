// polyportd's Prometheus endpoint on the running in-process wheelchair: scraped while the
// application runs (it keeps forwarding), then, with every component deactivated and the
// counters still, parsed by the Python client's own text parser (Debian's
// python3-prometheus-client, in check_metrics.py) and compared with `polyportctl stats`.
// A port that cannot be bound stops the daemon with exit code 1.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>

#include <cstring>

#include "../support/daemon_harness.hpp"

namespace polyport::test {
namespace {

const fs::path kProfile = POLYPORT_SOURCE_DIR "/profiles/wheelchair_inproc.xml";
constexpr const char* kPython = "/usr/bin/python3";

using Outcome = DaemonTest::Ran;

// One HTTP GET of `path` on 127.0.0.1:port, written by hand here so that the test does not
// share the server's library: the status line and the body.
std::pair<std::string, std::string> http_get(int port, const std::string& path) {
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_port = htons(static_cast<std::uint16_t>(port));
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  std::string reply;
  if (::connect(fd, reinterpret_cast<sockaddr*>(&address), sizeof address) == 0) {
    const std::string request = "GET " + path + " HTTP/1.1\r\nHost: localhost\r\nConnection: close\r\n\r\n";
    if (::send(fd, request.data(), request.size(), MSG_NOSIGNAL) == static_cast<ssize_t>(request.size())) {
      char buffer[65536];
      for (ssize_t n; (n = ::recv(fd, buffer, sizeof buffer, 0)) > 0;) reply.append(buffer, static_cast<std::size_t>(n));
    }
  }
  ::close(fd);
  const auto head_end = reply.find("\r\n\r\n");
  if (head_end == std::string::npos) return {};
  return {reply.substr(0, reply.find("\r\n")), reply.substr(head_end + 4)};
}

class Metrics : public DaemonTest {
 public:
  Metrics() : DaemonTest("polyport-metrics") {}

  Outcome run(const std::string& program, std::vector<std::string> args) {
    args.insert(args.begin(), program);
    return run_to_end(args);
  }
  Outcome ctl(std::vector<std::string> args) {
    args.insert(args.begin(), {"--socket", socket().string()});
    return run(POLYPORTCTL, std::move(args));
  }
  Json stats() {
    const Outcome s = ctl({"--json", "stats"});
    EXPECT_EQ(s.code, 0) << s.err;
    return Json::parse(s.out, nullptr, false);
  }
  // The delivered and latency counts of every connection, to see when they stop moving.
  std::vector<std::uint64_t> counts() {
    std::vector<std::uint64_t> out;
    const Json j = stats();
    if (j.is_discarded()) return out;
    for (const Json& c : j["connections"]) {
      out.push_back(c.value("delivered", std::uint64_t{0}));
      out.push_back(c["latency_ns"].value("count", std::uint64_t{0}));
    }
    return out;
  }
  std::uint64_t delivered(const std::string& source) {
    const Json j = stats();
    if (j.is_discarded()) return 0;
    for (const Json& c : j["connections"]) {
      if (c.value("source", "") == source) return c.value("delivered", std::uint64_t{0});
    }
    ADD_FAILURE() << "no connection from " << source;
    return 0;
  }
  fs::path socket() const { return dir() / "admin.sock"; }

 private:
};

TEST_F(Metrics, HistogramCountsEqualTheStatsAndScrapesDoNotDisturbForwarding) {
  // Port 0: the kernel picks a free one; `polyportctl hello` tells which.
  auto daemon = this->daemon(kProfile, {"--admin-socket", socket().string(), "--metrics-port", "0"});
  ASSERT_TRUE(eventually([&] { return ctl({"hello"}).code == 0; }, 30s)) << daemon->errors();
  const Outcome hello = ctl({"--json", "hello"});
  const std::string url = Json::parse(hello.out, nullptr, false).value("metrics", "");
  ASSERT_EQ(url.rfind("http://127.0.0.1:", 0), 0u) << hello.out;
  const int port = std::stoi(url.substr(std::strlen("http://127.0.0.1:")));
  EXPECT_NE(daemon->errors().find("metrics at " + url), std::string::npos) << daemon->errors();

  // Scrapes while the wheelchair runs: each answered, and forwarding goes on.
  const std::uint64_t before = delivered("HW.wheel_speeds");
  for (int i = 0; i < 20; ++i) {
    const auto [status, body] = http_get(port, "/metrics");
    ASSERT_EQ(status, "HTTP/1.1 200 OK") << body;
    ASSERT_NE(body.find("# TYPE polyport_connection_latency_seconds histogram"), std::string::npos) << body;
  }
  EXPECT_TRUE(eventually([&] { return delivered("HW.wheel_speeds") > before + 10; }, 20s))
      << "forwarding stalled at " << before;
  EXPECT_EQ(http_get(port, "/nothing").first, "HTTP/1.1 404 Not Found");

  // Traffic stopped: every component deactivated, then the counters still for a while.
  for (const char* component : {"Joystick", "Control", "HW"}) {
    const Outcome r = ctl({"deactivate", component});
    EXPECT_EQ(r.code, 0) << component << ": " << r.err;
  }
  std::vector<std::uint64_t> last = counts();
  int still = 0;
  ASSERT_TRUE(eventually([&] {
    const std::vector<std::uint64_t> now = counts();
    still = now == last ? still + 1 : 0;
    last = now;
    return still >= 3;
  }, 30s)) << "the counters kept moving with every component inactive";

  const Outcome s = ctl({"--json", "stats"});
  ASSERT_EQ(s.code, 0) << s.err;
  std::ofstream(dir() / "stats.now.json") << s.out;
  const Outcome check = run(kPython, {POLYPORT_CHECK_METRICS, url, (dir() / "stats.now.json").string()});
  ASSERT_EQ(check.code, 0) << check.err << check.out;
  const Json compared = Json::parse(check.out, nullptr, false);
  ASSERT_FALSE(compared.is_discarded()) << check.out;
  // Every connection of the wheelchair was compared, and traffic had flowed through them.
  const Json stats = Json::parse(s.out);
  std::size_t live = 0;
  for (const Json& c : stats["connections"]) live += !c.value("removed", false);
  ASSERT_EQ(compared["compared"].size(), live);
  for (const Json& c : compared["compared"]) EXPECT_GT(c["stats_count"].get<std::uint64_t>(), 0u) << c.dump();
  for (const char* family : {"polyport_connection_latency_seconds", "polyport_connection_dropped",
                             "polyport_component_state", "polyport_execution_context_wake_jitter_seconds",
                             "polyport_execution_context_overruns", "polyport_watchdog_trips"}) {
    EXPECT_NE(std::find(compared["families"].begin(), compared["families"].end(), family), compared["families"].end())
        << family << " missing from " << compared["families"].dump();
  }
  stop(*daemon);
}

// Opens a TCP connection to 127.0.0.1:port; -1 when it cannot.
int connect_to(int port) {
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_port = htons(static_cast<std::uint16_t>(port));
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (::connect(fd, reinterpret_cast<sockaddr*>(&address), sizeof address) != 0) {
    ::close(fd);
    return -1;
  }
  return fd;
}

TEST_F(Metrics, ClientsThatStallDoNotStallTheDaemon) {
  auto daemon = this->daemon(kProfile, {"--admin-socket", socket().string(), "--metrics-port", "0"});
  ASSERT_TRUE(eventually([&] { return ctl({"hello"}).code == 0; }, 30s)) << daemon->errors();
  const std::string url = Json::parse(ctl({"--json", "hello"}).out, nullptr, false).value("metrics", "");
  ASSERT_EQ(url.rfind("http://127.0.0.1:", 0), 0u) << url;
  const int port = std::stoi(url.substr(std::strlen("http://127.0.0.1:")));

  // More stalled clients than the server has workers: half a request each, and scrapes
  // whose replies are never read, with a receive buffer as small as the kernel allows.
  std::vector<int> stalled;
  for (int i = 0; i < 4; ++i) {
    const int fd = connect_to(port);
    ASSERT_GE(fd, 0);
    const int small = 1;
    ::setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &small, sizeof small);
    const std::string request = i % 2 == 0 ? "GET /metr" : "GET /metrics HTTP/1.1\r\nHost: x\r\n\r\n";
    ASSERT_EQ(::send(fd, request.data(), request.size(), MSG_NOSIGNAL), static_cast<ssize_t>(request.size()));
    stalled.push_back(fd);
  }
  // The main thread still answers the admin socket, and forwarding goes on.
  const std::uint64_t before = delivered("HW.wheel_speeds");
  EXPECT_EQ(ctl({"hello"}).code, 0);
  EXPECT_TRUE(eventually([&] { return delivered("HW.wheel_speeds") > before + 10; }, 20s))
      << "forwarding stalled at " << before;
  for (const int fd : stalled) ::close(fd);
  // Once they are gone (or dropped by the server's timeouts), scrapes are answered again.
  EXPECT_TRUE(eventually([&] { return http_get(port, "/metrics").first == "HTTP/1.1 200 OK"; }, 30s));
  stop(*daemon);
}

TEST_F(Metrics, APortInUseIsAnError) {
  // A port held by this test: polyportd cannot listen on it.
  const int holder = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ASSERT_EQ(::bind(holder, reinterpret_cast<sockaddr*>(&address), sizeof address), 0) << std::strerror(errno);
  ASSERT_EQ(::listen(holder, 1), 0);
  socklen_t size = sizeof address;
  ::getsockname(holder, reinterpret_cast<sockaddr*>(&address), &size);
  const std::string port = std::to_string(ntohs(address.sin_port));

  const Outcome r = run(POLYPORTD, {"run", kProfile.string(), "-q", "--admin-socket", "none", "--metrics-port", port});
  ::close(holder);
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_NE(r.err.find("cannot listen for metrics on 127.0.0.1 port " + port), std::string::npos) << r.err;
}

}  // namespace
}  // namespace polyport::test
