// polyportd between LCM applications built with lcm-gen (tests/lcm_e2e/lcm_peer), and between
// LCM and DDS applications built with idlc and fastddsgen (tests/dds_peers): every
// field checked where it arrives, wrong and cut-short messages counted and dropped, a message
// of 200 KB (fragmented on the wire) carried intact, a restarted publisher picked up, and a
// host without a multicast route told which route to add. Services both ways: an LCM client
// calling the in-process PeerAdder (its malformed requests counted and dropped), the
// in-process PeerCaller calling an LCM server (a silent one ending each call with a timeout,
// a full table of calls in flight refusing calls).
//
// Each case runs in a network namespace of its own (the test process unshares it; ctest runs
// each case as a process of its own) with loopback up and a route for LCM's group on it, so
// the fixture adds the route it needs and the route goes with the namespace. That needs root
// (CAP_SYS_ADMIN); without it the cases fail and say so.

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <optional>
#include <set>
#include <sstream>

#include "../support/multicast_namespace.hpp"
#include "pose_checks.hpp"

namespace polyport::test {
namespace {

constexpr const char* kUrl = "udpm://239.255.76.67:7667?ttl=0";
// A second LCM network (another port of the same group, so the same route) for bridges
// between two networks.
constexpr const char* kUrlB = "udpm://239.255.76.67:7668?ttl=0";

class LcmEndToEnd : public DaemonTest {
 protected:
  LcmEndToEnd() : DaemonTest("polyport-lcm-e2e") {}

  void SetUp() override {
    DaemonTest::SetUp();
    isolate_with_multicast_route();
  }

  // `dds_model`: the model of the DDS end in the *_dds_app.xml templates.
  fs::path app(const std::string& name, const std::string& dds_model = "cyclonedds") {
    return fill_templates(POLYPORT_TEST_DATA "/lcm_e2e",
                          {{"@URL@", kUrl},
                           {"@URL_B@", kUrlB},
                           {"@DDS_MODEL@", dds_model},
                           {"@SOURCE_CHANNEL@", "POSE_IN"},
                           {"@SINK_CHANNEL@", "POSE_OUT"},
                           {"@A@", "17"},
                           {"@CAP@", std::to_string(cap_)},
                           {"@TIMEOUT@", std::to_string(timeout_ms_)},
                           {"@SRC@", POLYPORT_SOURCE_DIR}},
                          name);
  }
  // The service profiles' cap on calls in flight and call timeout.
  int cap_ = 16;
  int timeout_ms_ = 150;
  std::unique_ptr<Child> lcm_peer(const std::string& tag, std::vector<std::string> args) {
    return peer(LCM_PEER, tag, std::move(args));
  }
  // A DDS application (`program`, of model `dds_model`) publishes pose; the LCM peer takes
  // every pose polyport maps onto pose_t, field by field, nothing dropped.
  void dds_to_lcm(const char* program, const std::string& dds_model) {
    auto sub = lcm_peer("sub", {"sub", kUrl, "POSE_OUT"});
    auto daemon = this->daemon(app("from_dds_app.xml", dds_model));
    auto pub = peer(program, "dds_pub", {"pub", "17", "pose", "0", "10"}  /* COUNT 0: until stopped */);
    // The LCM peer decodes with lcm-gen code: nsamples must match the samples polyport wrote.
    ASSERT_TRUE(eventually([&] { return poses(*sub).size() >= 10; }, 60s))
        << "LCM sub: " << poses(*sub).size() << " poses\n" << daemon->errors() << pub->errors();
    for (const Json& pose : poses(*sub)) expect_pose(pose);
    expect_increasing(poses(*sub));
    pub.reset();
    const Json stats = stop(*daemon);
    const Json* link = connection(stats, "dds.pose -> lcm.pose");
    ASSERT_NE(link, nullptr);
    EXPECT_EQ((*link)["dropped"], 0) << link->dump(2);
  }
};

// The statistics' entry of an LCM channel of a component.
const Json* lcm_channel(const Json& stats, const std::string& component, const std::string& port) {
  for (const Json& c : stats["components"]) {
    if (c["name"] != component || !c.contains("lcm")) continue;
    for (const Json& channel : c["lcm"]["channels"]) {
      if (channel["port"] == port) return &channel;
    }
  }
  ADD_FAILURE() << "no LCM channel " << component << "." << port << " in " << stats.dump(2);
  return nullptr;
}

// The statistics' entry of an LCM service port of a component.
const Json* lcm_service(const Json& stats, const std::string& component) {
  for (const Json& c : stats["components"]) {
    if (c["name"] == component && c.contains("lcm") && !c["lcm"]["services"].empty()) return &c["lcm"]["services"][0];
  }
  ADD_FAILURE() << "no LCM service of " << component << " in " << stats.dump(2);
  return nullptr;
}

// The requests a `serve` peer printed, each checked: add(n, 0.5) for a whole n.
std::vector<Json> checked_requests(const Child& server) {
  std::vector<Json> out;
  for (const Json& j : server.lines()) {
    if (!j.contains("request")) continue;
    const double a = j["a"].get<double>();
    EXPECT_EQ(a, std::floor(a)) << j.dump();
    EXPECT_EQ(j["b"].get<double>(), 0.5) << j.dump();
    EXPECT_NE(j["client"].get<long long>(), 0) << j.dump();
    out.push_back(j);
  }
  return out;
}

std::vector<Json> blobs(const Child& subscriber) {
  std::vector<Json> out;
  for (const Json& j : subscriber.lines()) {
    if (j.contains("blob") && !j.contains("event")) out.push_back(j);
  }
  return out;
}

TEST_F(LcmEndToEnd, LcmToLcmPassesEveryFieldThrough) {
  auto sub = lcm_peer("sub", {"sub", kUrl, "POSE_OUT"});
  auto daemon = this->daemon(app("passthrough_app.xml"));
  auto pub = lcm_peer("pub", {"pub", kUrl, "POSE_IN", "10"});
  ASSERT_TRUE(eventually([&] { return poses(*sub).size() >= 20; }, 30s))
      << "sub: " << poses(*sub).size() << " poses\n" << daemon->errors() << sub->errors();
  const std::vector<Json> got = poses(*sub);
  for (const Json& pose : got) expect_pose(pose);
  expect_increasing(got);
  pub.reset();
  const Json stats = stop(*daemon);
  const Json* link = connection(stats, "source.pose -> sink.pose");
  ASSERT_NE(link, nullptr);
  EXPECT_EQ((*link)["conversion"], "passthrough");
  const Json* in = lcm_channel(stats, "source", "pose");
  ASSERT_NE(in, nullptr);
  EXPECT_GE((*in)["received"].get<int>(), 20);
  EXPECT_EQ((*in)["wrong_fingerprint"], 0);
  const Json* out = lcm_channel(stats, "sink", "pose");
  ASSERT_NE(out, nullptr);
  EXPECT_GE((*out)["published"].get<int>(), 20);
  EXPECT_EQ((*out)["failed"], 0);
}

// Connection policies between applications built with lcm-gen, on passthrough connections
// (the deadband decodes the LCM bytes to compare, and forwards them as they came): a deadband
// lets every third pose through (x steps by 0.5, the threshold is 1.2), and a rate limit of 20
// per second on a 200 per second publisher delivers the newest pose once the publisher stops,
// and so does polling every 40 ms.
TEST_F(LcmEndToEnd, DeadbandAndRateLimitBetweenLcmApplications) {
  auto sub = lcm_peer("sub", {"sub", kUrl, "POSE_OUT"});
  auto limited = lcm_peer("limited", {"sub", kUrl, "POSE_LIMITED"});
  auto polled = lcm_peer("polled", {"sub", kUrl, "POSE_POLLED"});
  auto daemon = this->daemon(app("policies_app.xml"));
  auto pub = lcm_peer("pub", {"pub", kUrl, "POSE_IN", "5"});
  ASSERT_TRUE(eventually([&] { return poses(*sub).size() >= 10 && poses(*limited).size() >= 3; }, 30s))
      << "sub: " << poses(*sub).size() << ", limited: " << poses(*limited).size() << "\n" << daemon->errors();
  pub->signal(SIGTERM);
  ASSERT_EQ(pub->wait(10s), 0) << pub->errors();
  long long last_published = -1;
  for (const Json& j : pub->lines()) {
    if (j.value("event", "") == "published") last_published = j["id"].get<long long>();
  }
  ASSERT_GE(last_published, 0);
  // Newest wins: the last pose, held for its turn, goes out once its turn comes.
  ASSERT_TRUE(eventually([&] {
    const auto got = poses(*limited);
    return !got.empty() && got.back()["id"].get<long long>() == last_published;
  }, 10s)) << "limited got " << poses(*limited).size() << " poses, the last published was " << last_published;
  // Polling: the newest pose at each tick, the last one too.
  ASSERT_TRUE(eventually([&] {
    const auto got = poses(*polled);
    return !got.empty() && got.back()["id"].get<long long>() == last_published;
  }, 10s)) << "polled got " << poses(*polled).size() << " poses, the last published was " << last_published;
  const std::vector<Json> sampled = poses(*polled);
  for (const Json& pose : sampled) expect_pose(pose);
  expect_increasing(sampled);

  const std::vector<Json> banded = poses(*sub);
  for (const Json& pose : banded) expect_pose(pose);
  for (std::size_t i = 1; i < banded.size(); ++i) {
    EXPECT_EQ(banded[i]["id"].get<long long>() - banded[i - 1]["id"].get<long long>(), 3) << banded[i].dump();
  }
  const std::vector<Json> rated = poses(*limited);
  for (const Json& pose : rated) expect_pose(pose);
  expect_increasing(rated);

  const Json stats = stop(*daemon);
  const Json* band = connection(stats, "source.pose -> sink.pose");
  ASSERT_NE(band, nullptr);
  EXPECT_EQ((*band)["conversion"], "passthrough");
  EXPECT_GT((*band)["dropped_by_reason"]["filtered"].get<long long>(), 0) << band->dump(2);
  EXPECT_EQ((*band)["delivered"].get<long long>() + (*band)["dropped_by_reason"]["filtered"].get<long long>(),
            (*band)["received"].get<long long>())
      << band->dump(2);
  EXPECT_EQ((*band)["deadbands"][0]["field"], "x") << band->dump(2);
  const Json* rate = connection(stats, "source.pose -> limited.pose");
  ASSERT_NE(rate, nullptr);
  EXPECT_EQ((*rate)["rate_limit_interval_ns"], 50'000'000) << rate->dump(2);
  const long long received = (*rate)["received"].get<long long>();
  const long long delivered = (*rate)["delivered"].get<long long>();
  EXPECT_EQ(delivered + (*rate)["dropped_by_reason"]["rate_limited"].get<long long>(), received) << rate->dump(2);
  EXPECT_LT(delivered, received) << rate->dump(2);
  EXPECT_EQ(delivered, static_cast<long long>(rated.size())) << rate->dump(2);
  const Json* poll = connection(stats, "source.pose -> polled.pose");
  ASSERT_NE(poll, nullptr);
  EXPECT_EQ((*poll)["poll_period_ns"], 40'000'000) << poll->dump(2);
  EXPECT_LT((*poll)["delivered"].get<long long>(), (*poll)["received"].get<long long>()) << poll->dump(2);
  EXPECT_EQ((*poll)["delivered"].get<long long>(), static_cast<long long>(sampled.size())) << poll->dump(2);
}

TEST_F(LcmEndToEnd, WrongAndCutShortMessagesAreCountedAndDropped) {
  if (std::string(CYCLONE_PEER).empty()) FAIL() << "cyclone_peer was not built (the Cyclone DDS model is needed)";
  setenv("CYCLONEDDS_URI", "file://" POLYPORT_SOURCE_DIR "/config/cyclonedds-loopback.xml", 1);
  auto sub = peer(CYCLONE_PEER, "dds_sub", {"sub", "17", "pose", "10", "60"});
  auto daemon = this->daemon(app("to_dds_app.xml"));
  // Each round: an other_t (wrong fingerprint), a pose cut short, then a good pose.
  auto bad = lcm_peer("bad", {"bad", kUrl, "POSE_IN", "20"});
  ASSERT_TRUE(eventually([&] { return poses(*sub).size() >= 10; }, 60s))
      << "DDS sub: " << poses(*sub).size() << " poses\n" << daemon->errors() << sub->errors();
  for (const Json& pose : poses(*sub)) expect_pose(pose);
  bad.reset();
  const Json stats = stop(*daemon);
  const Json* channel = lcm_channel(stats, "lcm", "pose");
  ASSERT_NE(channel, nullptr);
  EXPECT_GE((*channel)["wrong_fingerprint"].get<int>(), 10);
  const Json* link = connection(stats, "lcm.pose -> dds.pose");
  ASSERT_NE(link, nullptr);
  EXPECT_NE((*link)["conversion"], "passthrough");
  EXPECT_GE((*link)["dropped_by_reason"]["decode_error"].get<int>(), 10) << link->dump(2);
  EXPECT_GE((*link)["delivered"].get<int>(), 10) << link->dump(2);
}

TEST_F(LcmEndToEnd, DdsToLcmCarriesEveryFieldWithItsLengthMember) {
  if (std::string(CYCLONE_PEER).empty()) FAIL() << "cyclone_peer was not built (the Cyclone DDS model is needed)";
  setenv("CYCLONEDDS_URI", "file://" POLYPORT_SOURCE_DIR "/config/cyclonedds-loopback.xml", 1);
  dds_to_lcm(CYCLONE_PEER, "cyclonedds");
}

TEST_F(LcmEndToEnd, AMessageOf200KilobytesArrivesIntact) {
  auto sub = lcm_peer("blob_sub", {"blob-sub", kUrl, "POSE_OUT"});
  auto daemon = this->daemon(app("blob_app.xml"));
  auto pub = lcm_peer("blob_pub", {"blob-pub", kUrl, "POSE_IN", "200000", "50"});
  ASSERT_TRUE(eventually([&] { return blobs(*sub).size() >= 3; }, 30s))
      << "blob sub: " << blobs(*sub).size() << "\n" << daemon->errors() << sub->errors();
  for (const Json& blob : blobs(*sub)) {
    EXPECT_EQ(blob["size"], 200000) << blob.dump();
    EXPECT_TRUE(blob["ok"].get<bool>()) << blob.dump();
  }
  pub.reset();
  const Json stats = stop(*daemon);
  const Json* in = lcm_channel(stats, "source", "blob");
  ASSERT_NE(in, nullptr);
  EXPECT_EQ((*in)["too_large"], 0);
}

TEST_F(LcmEndToEnd, ARestartedPublisherIsPickedUpAgain) {
  auto sub = lcm_peer("sub", {"sub", kUrl, "POSE_OUT"});
  auto daemon = this->daemon(app("passthrough_app.xml"));
  auto pub = lcm_peer("pub", {"pub", kUrl, "POSE_IN", "10", "0"});
  ASSERT_TRUE(eventually([&] { return poses(*sub).size() >= 5; }, 30s)) << daemon->errors();
  pub.reset();  // SIGTERM: the publisher exits
  auto again = lcm_peer("pub_again", {"pub", kUrl, "POSE_IN", "10", "500"});
  ASSERT_TRUE(eventually(
      [&] {
        const auto got = poses(*sub);
        return !got.empty() && got.back()["id"].get<int>() >= peer_values::id(505);
      },
      30s))
      << daemon->errors();
  for (const Json& pose : poses(*sub)) expect_pose(pose);
  again.reset();
  stop(*daemon);
}

// The shipped profiles/lcm_inproc.xml as it is: an LCM teleop (lcm-gen, wheelchair.lcm) asks
// for 1 m/s straight ahead; the in-process control drives the simulated chair, whose wheel
// speeds come back on LCM, mapped from the IDL types.
TEST_F(LcmEndToEnd, TheShippedLcmWheelchairProfileDrivesTheChair) {
  auto teleop = lcm_peer("teleop", {"teleop", kUrl, "1.0"});
  auto daemon = this->daemon(POLYPORT_SOURCE_DIR "/profiles/lcm_inproc.xml");
  const auto speeds = [&] {
    std::vector<Json> out;
    for (const Json& j : teleop->lines()) {
      if (j.contains("left")) out.push_back(j);
    }
    return out;
  };
  // 1 m/s needs a few hundred ms of 10 ms periods to reach; wait for the wheels to turn.
  ASSERT_TRUE(eventually(
      [&] {
        const auto got = speeds();
        return got.size() >= 50 && got.back()["left"].get<double>() > 1.0 && got.back()["right"].get<double>() > 1.0;
      },
      30s))
      << speeds().size() << " wheel speed messages\n" << daemon->errors() << teleop->errors();
  const auto got = speeds();
  for (std::size_t k = 1; k < got.size(); ++k) {
    EXPECT_GE(got[k]["time"].get<double>(), got[k - 1]["time"].get<double>()) << "the plant's clock went back";
  }
  // Straight ahead: both wheels alike and the heading stays put.
  EXPECT_NEAR(got.back()["left"].get<double>(), got.back()["right"].get<double>(), 1e-6);
  EXPECT_NEAR(got.back()["heading"].get<double>(), 0.0, 1e-6);
  teleop.reset();
  const Json stats = stop(*daemon);
  const Json* link = connection(stats, "Teleop.reference -> Control.reference");
  ASSERT_NE(link, nullptr);
  EXPECT_EQ((*link)["conversion"], "lcm -> flat -> map");
  EXPECT_EQ((*link)["dropped"], 0);
}

// An LCM client (lcm-gen C) calls add(i, 0.5) five times on the in-process PeerAdder, on the
// channels its profile names.
TEST_F(LcmEndToEnd, AnLcmClientCallsAnInProcessProvider) {
  auto daemon = this->daemon(app("lcm_client_app.xml"));
  auto client = lcm_peer("client", {"call", kUrl, "CALC_ADD_REQUEST", "CALC_ADD_REPLY", "5", "5000"});
  ASSERT_EQ(client->wait(60s), 0) << client->errors() << daemon->errors();
  int requests = 0;
  EXPECT_EQ(checked_replies(*client, requests), 5);
  const Json stats = stop(*daemon);
  const Json* service = lcm_service(stats, "client");
  ASSERT_NE(service, nullptr);
  EXPECT_EQ((*service)["polyport"], "serves");
  EXPECT_EQ((*service)["operations"][0]["request_channel"], "CALC_ADD_REQUEST");
  EXPECT_EQ((*service)["operations"][0]["reply_channel"], "CALC_ADD_REPLY");
  EXPECT_EQ((*service)["operations"][0]["request_type"], "peer.add_request_t");
  // Every request that reached polyport was answered (the client's first ones may go out
  // before polyport has subscribed: LCM has no matching to wait for).
  const int calls = (*service)["counters"]["calls"].get<int>();
  EXPECT_GE(calls, 5) << service->dump(2);
  EXPECT_LE(calls, requests) << service->dump(2);
  EXPECT_EQ((*service)["counters"]["replies"], calls) << service->dump(2);
  EXPECT_EQ((*service)["counters"]["errors"], 0) << service->dump(2);
  EXPECT_EQ((*service)["counters"]["malformed"], 0) << service->dump(2);
}

// Before each request the client sends an other_t and a request cut short on the request
// channel: each is counted as malformed and dropped, and every call still gets its sum.
TEST_F(LcmEndToEnd, MalformedRequestsAreCountedAndDropped) {
  auto daemon = this->daemon(app("lcm_client_app.xml"));
  auto client = lcm_peer("client", {"call", kUrl, "CALC_ADD_REQUEST", "CALC_ADD_REPLY", "3", "5000", "bad"});
  ASSERT_EQ(client->wait(60s), 0) << client->errors() << daemon->errors();
  int requests = 0;
  EXPECT_EQ(checked_replies(*client, requests), 3);
  const Json stats = stop(*daemon);
  const Json* service = lcm_service(stats, "client");
  ASSERT_NE(service, nullptr);
  const Json& counters = (*service)["counters"];
  // Two bad messages before each request; all of them once polyport has subscribed.
  const int calls = counters["calls"].get<int>();
  EXPECT_GE(calls, 3) << service->dump(2);
  EXPECT_LE(calls, requests) << service->dump(2);
  EXPECT_GE(counters["malformed"].get<int>(), 2 * (calls - 1)) << service->dump(2);
  EXPECT_LE(counters["malformed"].get<int>(), 2 * requests) << service->dump(2);
  EXPECT_EQ(counters["replies"], calls) << service->dump(2);
  EXPECT_EQ(counters["errors"], 0) << service->dump(2);
}

// The in-process PeerCaller calls an LCM server (lcm-gen C) on the default channels: a
// silent one first (every call ends with the 150 ms call timeout, no sum is published), then
// an answering one, whose sums arrive.
TEST_F(LcmEndToEnd, AnInProcessCallerCallsAnLcmServerAndASilentOneTimesOut) {
  const fs::path trace = dir() / "sums.jsonl";
  auto daemon = this->daemon(app("lcm_server_app.xml"), {"--trace", "caller.sums", "--trace-file", trace.string()});
  auto silent = lcm_peer("silent", {"serve", kUrl, "calc/add/request", "calc/add/reply", "3", "silent"});
  ASSERT_EQ(silent->wait(60s), 0) << silent->errors() << daemon->errors();
  EXPECT_EQ(checked_requests(*silent).size(), 3u);
  EXPECT_TRUE(traced_sums(trace).empty()) << "a sum without an answering server";
  auto server = lcm_peer("server", {"serve", kUrl, "calc/add/request", "calc/add/reply", "20"});
  ASSERT_EQ(server->wait(60s), 0) << server->errors() << daemon->errors();
  ASSERT_TRUE(eventually([&] { return traced_sums(trace).size() >= 5; }, 20s)) << "no sums traced";
  const auto requests = checked_requests(*server);
  const Json stats = stop(*daemon);
  const auto sums = traced_sums(trace);
  for (double sum : sums) EXPECT_EQ(sum - std::floor(sum), 0.5) << sum;  // n + 0.5 for some n
  const Json* service = lcm_service(stats, "server");
  ASSERT_NE(service, nullptr);
  EXPECT_EQ((*service)["polyport"], "calls");
  EXPECT_EQ((*service)["operations"][0]["request_channel"], "calc/add/request");
  EXPECT_EQ((*service)["operations"][0]["reply_channel"], "calc/add/reply");
  const Json& counters = (*service)["counters"];
  EXPECT_GE(counters["timeouts"].get<int>(), 3) << service->dump(2);  // at least the silent server's
  // Every sum published came from a reply (one answered after the caller gave up is not).
  EXPECT_GE(counters["replies"].get<std::size_t>(), sums.size()) << service->dump(2);
  EXPECT_LE(counters["replies"].get<std::size_t>(), requests.size()) << service->dump(2);
  EXPECT_EQ(counters["malformed"], 0) << service->dump(2);
}

// Two calls in flight at most and a 5 s call timeout, against a silent server: PeerCaller
// gives up on each call after 500 ms, but the bridge keeps its slot until the call times out,
// so from the third call on calls are refused (too_many_calls) until a slot frees; the third
// request reaches the server only then.
TEST_F(LcmEndToEnd, AFullTableOfCallsRefusesCalls) {
  cap_ = 2;
  timeout_ms_ = 5000;
  auto silent = lcm_peer("silent", {"serve", kUrl, "calc/add/request", "calc/add/reply", "0", "silent"});
  auto daemon = this->daemon(app("lcm_server_app.xml"));
  ASSERT_TRUE(eventually([&] { return checked_requests(*silent).size() >= 3; }, 60s))
      << daemon->errors() << silent->errors();
  const Json stats = stop(*daemon);
  const Json* service = lcm_service(stats, "server");
  ASSERT_NE(service, nullptr);
  EXPECT_EQ((*service)["max_calls_in_flight"], 2);
  const Json& counters = (*service)["counters"];
  EXPECT_GE(counters["refused"].get<int>(), 1) << service->dump(2);
  EXPECT_GE(counters["timeouts"].get<int>(), 1) << service->dump(2);
  EXPECT_EQ(counters["replies"], 0) << service->dump(2);
}

// `polyportd check` shows each operation's request and reply channels with their types: the
// defaults (port name / operation / request, reply) and the ones a profile names.
TEST_F(LcmEndToEnd, CheckShowsEachOperationsChannels) {
  const auto checked = [&](const std::string& profile) {
    auto check = peer(POLYPORTD, "check_" + profile, {"check", app(profile).string()});
    EXPECT_EQ(check->wait(20s), 0) << check->errors();
    std::ifstream in(dir() / ("check_" + profile + ".out"));
    std::stringstream text;
    text << in.rdbuf();
    return text.str();
  };
  const std::string server = checked("lcm_server_app.xml");
  EXPECT_NE(server.find("provided service calc  service=peer::Calc  add: request_channel=calc/add/request "
                        "[peer.add_request_t] reply_channel=calc/add/reply [peer.add_reply_t]\n"),
            std::string::npos)
      << server;
  const std::string client = checked("lcm_client_app.xml");
  EXPECT_NE(client.find("required service calc  service=peer::Calc  add: request_channel=CALC_ADD_REQUEST "
                        "[peer.add_request_t] reply_channel=CALC_ADD_REPLY [peer.add_reply_t]\n"),
            std::string::npos)
      << client;
}

TEST_F(LcmEndToEnd, NoMulticastRouteIsAClearError) {
  // A namespace of its own again, where loopback is down and nothing is routed.
  const fs::path profile = app("passthrough_app.xml");
  auto daemon = peer("/usr/bin/unshare", "polyportd", {"-n", POLYPORTD, "run", profile.string()});
  ASSERT_EQ(daemon->wait(20s), 1) << daemon->errors();
  const std::string errors = daemon->errors();
  EXPECT_NE(errors.find("no route to multicast group 239.255.76.67"), std::string::npos) << errors;
  EXPECT_NE(errors.find("ip route add 239.255.76.67/32 dev lo"), std::string::npos) << errors;
}

// Fast DDS at the other end: the same mapping both ways as with Cyclone DDS above, against
// a fastddsgen program (tests/dds_peers/fastdds_peer).
class LcmFastDds : public LcmEndToEnd {
 protected:
  void SetUp() override {
    LcmEndToEnd::SetUp();
    if (std::string(FASTDDS_PEER).empty()) FAIL() << "fastdds_peer was not built (the Fast DDS model and fastddsgen are needed)";
    setenv("FASTRTPS_DEFAULT_PROFILES_FILE", POLYPORT_SOURCE_DIR "/config/fastdds-loopback.xml", 1);
  }
};

TEST_F(LcmFastDds, LcmToFastDdsCarriesEveryField) {
  auto sub = peer(FASTDDS_PEER, "fast_sub", {"sub", "17", "pose", "10", "60"});
  auto daemon = this->daemon(app("to_dds_app.xml", "fastdds"));
  auto pub = lcm_peer("pub", {"pub", kUrl, "POSE_IN", "10"});
  ASSERT_TRUE(eventually([&] { return poses(*sub).size() >= 10; }, 60s))
      << "Fast DDS sub: " << poses(*sub).size() << " poses\n" << daemon->errors() << sub->errors();
  for (const Json& pose : poses(*sub)) expect_pose(pose);
  expect_increasing(poses(*sub));
  pub.reset();
  const Json stats = stop(*daemon);
  const Json* link = connection(stats, "lcm.pose -> dds.pose");
  ASSERT_NE(link, nullptr);
  EXPECT_NE((*link)["conversion"], "passthrough");
  EXPECT_GE((*link)["delivered"].get<int>(), 10) << link->dump(2);
}

TEST_F(LcmFastDds, FastDdsToLcmCarriesEveryFieldWithItsLengthMember) {
  dds_to_lcm(FASTDDS_PEER, "fastdds");
}

// The receive thread runs with the scheduling <lcm><receive_thread> asks for: SCHED_FIFO 20
// on CPU 0, seen in /proc; where the process may not (not root), one warning says so.
TEST_F(LcmEndToEnd, TheReceiveThreadRunsWithTheProfilesScheduling) {
  const fs::path app = one_component_app(
      "lcm", "<lcm><url>" + std::string(kUrl) + R"(</url><receive_thread policy="SCHED_FIFO" priority="20" cpu="0"/></lcm>)",
      POLYPORT_SOURCE_DIR "/config/types/wheelchair.lcm", "wheelchair_lcm::reference_t");
  auto daemon = this->daemon(app);
  const auto receive_thread = [&] { return thread_scheduling(daemon->pid(), "pp-lcm-recv"); };
  ASSERT_TRUE(eventually([&] { return receive_thread().has_value(); })) << daemon->errors();
  const bool allowed = geteuid() == 0;
  if (allowed) {
    EXPECT_EQ(receive_thread()->second, 1) << "SCHED_FIFO";
    EXPECT_EQ(receive_thread()->first, 20);
  } else {
    EXPECT_NE(daemon->errors().find("the LCM receive thread: real-time priority 20 refused"),
              std::string::npos) << daemon->errors();
  }
  const Json stats = stop(*daemon);
  const Json thread = stats["components"][0]["lcm"]["receive_thread"];
  EXPECT_EQ(thread.value("asked", ""), "SCHED_FIFO 20 on CPU 0") << stats.dump(2);
  EXPECT_EQ(thread.value("realtime", !allowed), allowed);
  EXPECT_TRUE(thread.value("pinned", false));
}

// Loop prevention: channel LOOP bridged both ways between two LCM networks
// (tests/data/lcm_e2e/loop_app.xml), lcm-gen publishers and subscribers on both. A udpm
// subscriber receives its own lcm_t's datagrams, so every message polyport publishes on a side
// comes back to polyport's subscription of that side; without loop prevention it would be
// forwarded back to the other side, and so on for as long as the daemon runs (each subscriber
// would see every message again and again). With it, every message a peer published reaches the
// other side once, and each side's subscription drops exactly the echoes of what polyport
// published there (`loop_dropped` = the other connection's `delivered`). Both instances are
// served by the daemon's one LCM receive thread.
TEST_F(LcmEndToEnd, ChannelBridgedBothWaysForwardsEachMessageOnce) {
  const fs::path socket = dir() / "admin.sock";
  auto sub_a = lcm_peer("sub_a", {"sub", kUrl, "LOOP"});
  auto sub_b = lcm_peer("sub_b", {"sub", kUrlB, "LOOP"});
  auto daemon = this->daemon(app("loop_app.xml"), {"--admin-socket", socket.string()});
  auto pub_a = lcm_peer("pub_a", {"pub", kUrl, "LOOP", "5", "0"});
  auto pub_b = lcm_peer("pub_b", {"pub", kUrlB, "LOOP", "5", "1000"});
  auto published = [](const Child& pub) {
    std::set<long long> ids;
    for (const Json& j : pub.lines()) {
      if (j.value("event", "") == "published") ids.insert(j["id"].get<long long>());
    }
    return ids;
  };
  ASSERT_TRUE(eventually([&] { return published(*pub_a).size() >= 30 && published(*pub_b).size() >= 30; }, 30s))
      << daemon->errors();
  for (auto* pub : {&pub_a, &pub_b}) {
    (*pub)->signal(SIGTERM);
    ASSERT_EQ((*pub)->wait(10s), 0) << (*pub)->errors();
  }
  // Two LCM instances (one per URL), one receive thread for both.
  EXPECT_EQ(threads_named(daemon->pid(), "pp-lcm-recv").size(), 1U);
  const std::set<long long> from_a = published(*pub_a);
  const std::set<long long> from_b = published(*pub_b);
  // Each subscriber gets its own side's publisher directly and the other side's through
  // polyport: all of them, once.
  auto ids = [](const Child& sub) {
    std::multiset<long long> out;
    for (const Json& pose : poses(sub)) out.insert(pose["id"].get<long long>());
    return out;
  };
  ASSERT_TRUE(eventually([&] {
    return ids(*sub_a).size() >= from_a.size() + from_b.size() && ids(*sub_b).size() >= from_a.size() + from_b.size();
  }, 30s)) << "a: " << ids(*sub_a).size() << ", b: " << ids(*sub_b).size() << " of " << from_a.size() + from_b.size();
  for (const auto* sub : {&sub_a, &sub_b}) {
    const auto got = ids(**sub);
    for (const Json& pose : poses(**sub)) expect_pose(pose);
    std::set<long long> expected(from_a);
    expected.insert(from_b.begin(), from_b.end());
    EXPECT_EQ(std::set<long long>(got.begin(), got.end()), expected);
    ASSERT_EQ(got.size(), expected.size()) << "a subscriber saw a message more than once";
  }
  // Every echo of polyport's own publishes has reached polyport too (the same datagrams).
  auto live = [&] {
    Child ctl(dir(), "ctl", {POLYPORTCTL, "--socket", socket.string(), "--json", "stats"});
    EXPECT_EQ(ctl.wait(20s), 0) << ctl.errors();
    std::ifstream out(dir() / "ctl.out");
    const Json s = Json::parse(out, nullptr, false);
    return s.is_discarded() ? Json::object() : s;
  };
  ASSERT_TRUE(eventually([&] {
    const Json s = live();
    if (!s.contains("connections") || !s.contains("components")) return false;
    const Json* there = connection(s, "a.from_lcm -> b.to_lcm");
    const Json* back = connection(s, "b.from_lcm -> a.to_lcm");
    const Json* in_a = lcm_channel(s, "a", "from_lcm");
    const Json* in_b = lcm_channel(s, "b", "from_lcm");
    return there && back && in_a && in_b && (*in_b)["loop_dropped"] == (*there)["delivered"] &&
           (*in_a)["loop_dropped"] == (*back)["delivered"];
  }, 20s)) << live().dump(2);
  const Json stats = stop(*daemon);
  const Json* there = connection(stats, "a.from_lcm -> b.to_lcm");
  const Json* back = connection(stats, "b.from_lcm -> a.to_lcm");
  const Json* in_a = lcm_channel(stats, "a", "from_lcm");
  const Json* in_b = lcm_channel(stats, "b", "from_lcm");
  ASSERT_TRUE(there && back && in_a && in_b);
  EXPECT_EQ((*there)["conversion"], "passthrough");
  EXPECT_EQ((*there)["delivered"].get<std::size_t>(), from_a.size()) << there->dump(2);
  EXPECT_EQ((*back)["delivered"].get<std::size_t>(), from_b.size()) << back->dump(2);
  EXPECT_EQ((*in_b)["loop_dropped"], (*there)["delivered"]) << in_b->dump(2);
  EXPECT_EQ((*in_a)["loop_dropped"], (*back)["delivered"]) << in_a->dump(2);
  // What a subscription received: its peer's messages and the echoes of polyport's.
  EXPECT_EQ((*in_a)["received"].get<std::size_t>(), from_a.size() + from_b.size()) << in_a->dump(2);
  EXPECT_EQ((*in_b)["received"].get<std::size_t>(), from_a.size() + from_b.size()) << in_b->dump(2);
}

// A log replayed through a file:// provider: every message of the log arrives, and at its end
// the receive thread stops watching the provider (liblcm's file provider then leaves its
// descriptor readable and fails every lcm_handle at once: watched, the thread would spin on
// it) and the statistics say the log ended. The thread's CPU time over a second after the
// replay is the check: spinning it would take nearly all of that second.
TEST_F(LcmEndToEnd, AReplayedLogEndsWithoutKeepingTheReceiveThreadBusy) {
  const fs::path log = dir() / "poses.log";
  std::size_t logged = 0;
  {
    auto writer = lcm_peer("writer", {"pub", "file://" + log.string() + "?mode=w", "POSE", "1"});
    ASSERT_TRUE(eventually([&] { return writer->lines().size() >= 20; }, 30s)) << writer->errors();
    writer->signal(SIGTERM);
    ASSERT_EQ(writer->wait(10s), 0) << writer->errors();
    for (const Json& j : writer->lines()) logged += j.value("event", "") == "published" ? 1 : 0;
  }
  ASSERT_GE(logged, 20U);
  std::ofstream(dir() / "LogSource.xml")
      << "<?xml version=\"1.0\"?>\n<component_profile><name>LogSource</name><model>lcm</model>\n"
         "  <lcm><url>file://" << log.string() << "?mode=r&amp;speed=0</url></lcm>\n"
         "  <types><file>" POLYPORT_SOURCE_DIR "/tests/lcm_e2e/lcm/peer.lcm</file></types>\n"
         "  <ports><data_port><name>pose</name><data_type>peer::pose_t</data_type><usage>output</usage>"
         "<channel>POSE</channel></data_port></ports>\n</component_profile>\n";
  std::ofstream(dir() / "log_app.xml")
      << "<?xml version=\"1.0\"?>\n<application_profile><name>log</name>\n  <subcomponents><subcomponent>"
         "<name>log</name><reference>LogSource.xml</reference></subcomponent></subcomponents>\n"
         "</application_profile>\n";
  auto daemon = this->daemon(dir() / "log_app.xml");
  ASSERT_TRUE(eventually([&] { return threads_named(daemon->pid(), "pp-lcm-recv").size() == 1; })) << daemon->errors();
  const fs::path thread = threads_named(daemon->pid(), "pp-lcm-recv").front();
  const auto cpu_ticks = [&] {  // utime + stime (fields 14 and 15) of the thread
    const std::string text = read_file(thread / "stat");
    std::istringstream fields(text.substr(text.rfind(')') + 2));  // from field 3 on
    const std::vector<std::string> f{std::istream_iterator<std::string>(fields), std::istream_iterator<std::string>()};
    return f.size() > 12 ? std::stoll(f[11]) + std::stoll(f[12]) : -1LL;
  };
  const long long before = cpu_ticks();
  std::this_thread::sleep_for(1s);  // the measured window
  const long long after = cpu_ticks();
  ASSERT_GE(before, 0);
  EXPECT_LT(after - before, sysconf(_SC_CLK_TCK) / 5) << "receive thread CPU ticks in 1 s: " << after - before;
  const Json stats = stop(*daemon);
  const Json& lcm = stats["components"][0]["lcm"];
  EXPECT_TRUE(lcm.value("log_ended", false)) << stats.dump(2);
  EXPECT_EQ(lcm["channels"][0].value("received", 0ULL), logged) << stats.dump(2);
}

}  // namespace
}  // namespace polyport::test
