// SmartSoft's query pattern across models: the in-process QueryWaiter (tests/plugins/
// query_components.cpp) calls `add` of an LCM application built with lcm-gen (tests/lcm_e2e/
// lcm_peer serve) through polyportd. A receive that does not wait says "not yet" (no_data)
// while the server has the request and has not answered, and takes each reply once it comes;
// a receive_wait or a query without a timeout on a server that never answers ends with
// `cancelled` when the component is deactivated (polyportctl) or the daemon is stopped
// (SIGTERM), long before the call's own timeout (10 minutes here), and the component waits
// again once it is activated again.
//
// Each case runs in a network namespace of its own (the test process unshares it; needs root)
// with a route for LCM's multicast group on loopback.
#include <signal.h>
#include <stdlib.h>

#include <cmath>
#include <fstream>
#include <iterator>

#include "../support/daemon_harness.hpp"
#include "../support/multicast_namespace.hpp"

namespace polyport::test {
namespace {

constexpr const char* kUrl = "udpm://239.255.76.67:7667?ttl=0";
constexpr int kCancelled = 11;  // Status::cancelled
constexpr int kNoData = 2;      // Status::no_data
constexpr int kOk = 0;

// The call timeout of the DDS and LCM servers: far beyond any wait of these tests, so a
// call that ends did not time out.
constexpr int kCallTimeoutMs = 600000;

class QueryEndToEnd : public DaemonTest {
 protected:
  QueryEndToEnd() : DaemonTest("polyport-query") {}

  void SetUp() override {
    DaemonTest::SetUp();
    socket_ = dir() / "admin.sock";
  }

  // tests/data/query's `app` with `values` filled in; the waiter's outcomes traced.
  std::unique_ptr<Child> start(const std::string& app, std::vector<std::pair<std::string, std::string>> values) {
    values.emplace_back("@TIMEOUT@", std::to_string(kCallTimeoutMs));
    values.emplace_back("@SRC@", POLYPORT_SOURCE_DIR);
    return daemon(fill_templates(POLYPORT_TEST_DATA "/query", values, app),
                  {"--admin-socket", socket_.string(), "--trace", "waiter.outcome", "--trace-file",
                   trace_file().string()});
  }
  // polyportctl's exit code (-1: it did not end within 30 s); its output in `out`.
  int ctl(const std::vector<std::string>& args, std::string* out = nullptr) {
    std::vector<std::string> all{POLYPORTCTL, "--socket", socket_.string()};
    all.insert(all.end(), args.begin(), args.end());
    const std::string tag = "ctl-" + std::to_string(++calls_);
    int code = -1;
    {
      Child child(dir(), tag, all);
      code = child.wait(30s);
    }
    if (out != nullptr) {
      std::ifstream in(dir() / (tag + ".out"));
      out->assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
    }
    return code;
  }
  // The outcomes the waiter published: {n, status, sum, not_yet}.
  std::vector<Json> outcomes() const {
    std::vector<Json> out;
    std::ifstream in(trace_file());
    std::string text;
    while (std::getline(in, text)) {
      const Json j = Json::parse(text, nullptr, false);
      if (!j.is_discarded() && j.contains("value")) out.push_back(j["value"]);
    }
    return out;
  }
  bool has_outcome(int n, int status) const {
    for (const Json& o : outcomes()) {
      if (o["n"] == n && o["status"] == status) return true;
    }
    return false;
  }
  // How many requests a server printed.
  static std::size_t request_count(const Child& server) {
    std::size_t n = 0;
    for (const Json& j : server.lines()) n += j.contains("request") ? 1 : 0;
    return n;
  }
  // The statistics' entry of the waiter's service link.
  static const Json* service(const Json& stats) {
    for (const Json& s : stats["services"]) {
      if (s["name"] == "waiter.calc -> server.calc") return &s;
    }
    ADD_FAILURE() << "no service waiter.calc in " << stats.dump(2);
    return nullptr;
  }
  // Stops the daemon with `signal`; its statistics.
  Json stop_with(Child& daemon, int signal) {
    daemon.signal(signal);
    EXPECT_EQ(daemon.wait(30s), 0) << "polyportd did not stop:\n" << daemon.errors();
    std::ifstream in(stats_file());
    Json stats = Json::parse(in, nullptr, false);
    EXPECT_FALSE(stats.is_discarded()) << "no statistics from polyportd";
    return stats;
  }
  fs::path trace_file() const { return dir() / "outcome.jsonl"; }

  fs::path socket_;
  int calls_ = 0;
};

class QueryOverLcm : public QueryEndToEnd {
 protected:
  void SetUp() override {
    QueryEndToEnd::SetUp();
    isolate_with_multicast_route();
  }
  // The waiter in `mode`, calling an LCM server.
  std::unique_ptr<Child> start(const std::string& mode) {
    return QueryEndToEnd::start("lcm_query_app.xml", {{"@URL@", kUrl},
                                                      {"@MODE@", mode},
                                                      {"@LIFECYCLE@", "start"},
                                                      {"@ARGS@", "peer::add_args_t"},
                                                      {"@RESULT@", "peer::add_result_t"}});
  }
  // An LCM server on the default channels; `silent`: it never answers.
  std::unique_ptr<Child> server(bool silent) {
    std::vector<std::string> args{"serve", kUrl, "calc/add/request", "calc/add/reply", "0"};
    if (silent) args.push_back("silent");
    auto child = peer(LCM_PEER, silent ? "silent" : "server", args);
    EXPECT_TRUE(eventually([&] { return child->saw_event("serving"); }, 30s)) << child->errors();
    return child;
  }
  // The requests the server printed, add(n, 0.5) each: the n.
  static std::vector<int> requests(const Child& server) {
    std::vector<int> ns;
    for (const Json& j : server.lines()) {
      if (j.contains("request")) ns.push_back(static_cast<int>(j["a"].get<double>()));
    }
    return ns;
  }
};

class QueryOverDds : public QueryEndToEnd {
 protected:
  void SetUp() override {
    if (std::string(CYCLONE_PEER).empty()) GTEST_SKIP() << "the Cyclone DDS test peer was not built";
    setenv("CYCLONEDDS_URI", "file://" POLYPORT_SOURCE_DIR "/config/cyclonedds-loopback.xml", 1);
    QueryEndToEnd::SetUp();
  }
  // Whether the server's service port has found the DDS application's request reader and
  // reply writer (the live statistics).
  bool matched() {
    std::string out;
    if (ctl({"--json", "stats"}, &out) != 0) return false;
    const Json stats = Json::parse(out, nullptr, false);
    if (stats.is_discarded()) return false;
    for (const Json& c : stats.value("components", Json::array())) {
      if (c.value("name", "") != "server" || !c.contains("dds")) continue;
      for (const Json& s : c["dds"].value("services", Json::array())) {
        for (const Json& op : s.value("operations", Json::array())) {
          if (op.value("matched_servers", 0) > 0 && op.value("matched_reply_writers", 0) > 0) return true;
        }
      }
    }
    return false;
  }
  static constexpr const char* kDomain = "87";
};

// receive_wait on a server that never answers: deactivate ends it (cancelled) while the
// call's own timeout is 10 minutes away; activated again, the waiter makes its next call and
// waits again; SIGTERM ends that one and the daemon.
TEST_F(QueryOverLcm, DeactivateAndSigtermEndAReceiveWaitOnASilentServer) {
  auto silent = server(true);
  auto daemon = start("wait");
  ASSERT_TRUE(eventually([&] { return requests(*silent).size() >= 1; }, 30s)) << daemon->errors();
  EXPECT_TRUE(outcomes().empty()) << "receive_wait returned without a reply";
  ASSERT_EQ(ctl({"deactivate", "waiter"}), 0) << daemon->errors();
  ASSERT_TRUE(eventually([&] { return has_outcome(1, kCancelled); }, 30s)) << Json(outcomes()).dump();
  ASSERT_EQ(ctl({"activate", "waiter"}), 0) << daemon->errors();
  ASSERT_TRUE(eventually([&] { return requests(*silent).size() >= 2; }, 30s)) << daemon->errors();
  EXPECT_EQ(requests(*silent), (std::vector<int>{1, 2})) << "one call at a time, each waiting";
  const Json stats = stop_with(*daemon, SIGTERM);
  EXPECT_TRUE(has_outcome(2, kCancelled)) << Json(outcomes()).dump();
  for (const Json& o : outcomes()) EXPECT_EQ(o["status"], kCancelled) << o.dump();
  const Json* link = service(stats);
  ASSERT_NE(link, nullptr);
  EXPECT_EQ((*link)["calls"], 2) << link->dump(2);
  EXPECT_EQ((*link)["cancelled"], 2) << link->dump(2);
  EXPECT_EQ((*link)["ok"], 0) << link->dump(2);
  EXPECT_EQ((*link)["timeouts"], 0) << link->dump(2);
}

// A query without a timeout on a server that never answers: SIGTERM ends it and the daemon.
TEST_F(QueryOverLcm, SigtermEndsAQueryWithoutTimeoutOnASilentServer) {
  auto silent = server(true);
  auto daemon = start("query");
  ASSERT_TRUE(eventually([&] { return requests(*silent).size() >= 1; }, 30s)) << daemon->errors();
  const Json stats = stop_with(*daemon, SIGTERM);
  EXPECT_EQ(requests(*silent), (std::vector<int>{1}));
  EXPECT_TRUE(has_outcome(1, kCancelled)) << Json(outcomes()).dump();
  const Json* link = service(stats);
  ASSERT_NE(link, nullptr);
  EXPECT_EQ((*link)["cancelled"], 1) << link->dump(2);
  EXPECT_EQ((*link)["timeouts"], 0) << link->dump(2);
}

// A receive that does not wait, once per cycle, on a call the server has (it printed the
// request) but never answers: "not yet" (no_data) again and again; the call stays in flight.
TEST_F(QueryOverLcm, ReceiveSaysNotYetWhileTheServerHasNotAnswered) {
  auto silent = server(true);
  auto daemon = start("poll");
  ASSERT_TRUE(eventually([&] { return requests(*silent).size() >= 1; }, 30s)) << daemon->errors();
  ASSERT_TRUE(eventually([&] {
    const auto all = outcomes();
    return !all.empty() && all.back()["not_yet"].get<int>() >= 10;
  }, 30s)) << Json(outcomes()).dump();
  const Json stats = stop_with(*daemon, SIGTERM);
  EXPECT_EQ(requests(*silent), (std::vector<int>{1})) << "one call, still in flight";
  int expected_not_yet = 0;
  for (const Json& o : outcomes()) {
    EXPECT_EQ(o["n"], 1) << o.dump();
    EXPECT_EQ(o["status"], kNoData) << o.dump();
    EXPECT_EQ(o["not_yet"], ++expected_not_yet) << o.dump();
  }
  const Json* link = service(stats);
  ASSERT_NE(link, nullptr);
  EXPECT_EQ((*link)["calls"], 1) << link->dump(2);
  EXPECT_EQ((*link)["ok"], 0) << link->dump(2);
  EXPECT_EQ((*link)["timeouts"], 0) << link->dump(2);
}

// The same receive, on a server that answers: each call's reply is taken (sum n + 0.5), one
// call after another.
TEST_F(QueryOverLcm, ReceiveTakesEachReplyOfAnAnsweringServer) {
  auto answering = server(false);
  auto daemon = start("poll");
  const auto oks = [&] {
    std::vector<Json> out;
    for (const Json& o : outcomes()) {
      if (o["status"] == kOk) out.push_back(o);
    }
    return out;
  };
  ASSERT_TRUE(eventually([&] { return oks().size() >= 5; }, 30s)) << Json(outcomes()).dump() << daemon->errors();
  const Json stats = stop_with(*daemon, SIGTERM);
  int n = 0;
  for (const Json& o : oks()) {
    EXPECT_EQ(o["n"], ++n) << o.dump();
    EXPECT_EQ(o["sum"].get<double>(), n + 0.5) << o.dump();
  }
  for (const Json& o : outcomes()) {
    EXPECT_TRUE(o["status"] == kOk || o["status"] == kNoData) << o.dump();
  }
  const Json* link = service(stats);
  ASSERT_NE(link, nullptr);
  EXPECT_GE((*link)["ok"].get<int>(), 5) << link->dump(2);
  EXPECT_EQ((*link)["timeouts"], 0) << link->dump(2);
  EXPECT_EQ((*link)["errors"], 0) << link->dump(2);
  EXPECT_EQ((*link)["cancelled"], 0) << link->dump(2);
}

// receive_wait on a Cyclone DDS server (idlc) that takes every request and never answers:
// SIGTERM ends it with cancelled and the daemon stops, the call's own timeout 10 minutes away.
TEST_F(QueryOverDds, SigtermEndsAReceiveWaitOnASilentServer) {
  auto silent = peer(CYCLONE_PEER, "silent", {"serve", kDomain, "calc", "1000", "silent"});
  ASSERT_TRUE(eventually([&] { return silent->saw_event("ready"); }, 30s)) << silent->errors();
  auto daemon = start("dds_query_app.xml", {{"@DOMAIN@", kDomain},
                                            {"@MODE@", "wait"},
                                            {"@LIFECYCLE@", "stop"},
                                            {"@ARGS@", "peer::AddArgs"},
                                            {"@RESULT@", "peer::AddResult"}});
  // The waiter makes one call only: it starts once polyport's request writer has found the
  // server's reader (a request written before is not for it) and its reply reader the
  // server's writer.
  ASSERT_TRUE(eventually([&] { return matched(); }, 30s)) << daemon->errors() << silent->errors();
  ASSERT_EQ(ctl({"activate", "waiter"}), 0) << daemon->errors();
  ASSERT_TRUE(eventually([&] { return request_count(*silent) >= 1; }, 30s)) << daemon->errors() << silent->errors();
  EXPECT_TRUE(outcomes().empty()) << "receive_wait returned without a reply";
  const Json stats = stop_with(*daemon, SIGTERM);
  EXPECT_EQ(request_count(*silent), 1u) << "one call, waiting";
  EXPECT_TRUE(has_outcome(1, kCancelled)) << Json(outcomes()).dump();
  const Json* link = service(stats);
  ASSERT_NE(link, nullptr);
  EXPECT_EQ((*link)["cancelled"], 1) << link->dump(2);
  EXPECT_EQ((*link)["timeouts"], 0) << link->dump(2);
}

}  // namespace
}  // namespace polyport::test
