// A composite over a foreign proxy and an in-process component, end to end: an LCM
// application built with lcm-gen (tests/lcm_e2e/lcm_peer) publishes poses on POSE_IN; the
// composite Pipeline promotes the LCM proxy's channels and the in-process PoseRelay's ports,
// and the profile's connections name only Pipeline's ports. Every pose that reaches POSE_OUT
// is checked field by field (the relay adds 100000 to the id). `polyportd check --json` and
// `polyportctl list` show what each promoted name stands for; lifecycle commands sent to the
// composite reach its members; run-time wiring takes the composite's names; a reload
// repoints a promoted name. Also: a service connection between a composite's ports (an
// lcm-gen client, the in-process PeerAdder), and a composite over three models (an idlc
// Cyclone DDS publisher as the source).
//
// Each case runs in a network namespace of its own with a multicast route on loopback (needs
// root, as tests/lcm_e2e).

#include <cstdlib>
#include <fstream>
#include <iterator>
#include <set>
#include <sstream>

#include "../dds_peers/pose_checks.hpp"
#include "../support/multicast_namespace.hpp"

namespace polyport::test {
namespace {

constexpr const char* kUrl = "udpm://239.255.76.67:7667?ttl=0";
constexpr int kRelayOffset = 100000;  // PoseRelay (tests/plugins) adds it to each id

using Ctl = DaemonTest::Ran;

class CompositeEndToEnd : public DaemonTest {
 protected:
  CompositeEndToEnd() : DaemonTest("polyport-composite") {}

  void SetUp() override {
    DaemonTest::SetUp();
    isolate_with_multicast_route();
    app_ = fill_templates(POLYPORT_TEST_DATA "/composite",
                          {{"@URL@", kUrl}, {"@CAP@", "16"}, {"@A@", "17"}, {"@SRC@", POLYPORT_SOURCE_DIR}},
                          "composite_app.xml");
    socket_ = dir() / "admin.sock";
  }

  Ctl run(const char* program, const std::vector<std::string>& args) {
    std::vector<std::string> all{program};
    all.insert(all.end(), args.begin(), args.end());
    return run_to_end(all);
  }
  Ctl ctl(std::vector<std::string> args) {
    args.insert(args.begin(), {"--socket", socket_.string()});
    return run(POLYPORTCTL, args);
  }
  std::unique_ptr<Child> start_daemon() {
    auto d = daemon(app_, {"--admin-socket", socket_.string()});
    EXPECT_TRUE(eventually([&] { return ctl({"hello"}).code == 0; }, 30s)) << d->errors();
    return d;
  }
  // The state of a component in `polyportctl --json list`.
  std::string state_of(const std::string& component) {
    const Json list = ctl({"--json", "list"}).json();
    for (const Json& c : list.value("components", Json::array())) {
      if (c.value("name", "") == component) return c.value("state", "");
    }
    return "(not listed)";
  }

  fs::path app_;
  fs::path socket_;
};

// What each of Pipeline's names stands for, as check --json and list --json show it.
void expect_pipeline(const Json& graph) {
  ASSERT_TRUE(graph.contains("composites")) << graph.dump(2);
  ASSERT_EQ(graph["composites"].size(), 1u) << graph.dump(2);
  const Json& pipeline = graph["composites"][0];
  EXPECT_EQ(pipeline["name"], "Pipeline");
  EXPECT_EQ(pipeline["members"], Json({"source", "relay", "sink"}));
  const Json expected = Json::parse(R"([
    {"name": "raw", "member": "source.pose", "kind": "data", "direction": "output", "type": "peer::pose_t"},
    {"name": "input", "member": "relay.in", "kind": "data", "direction": "input", "type": "peer::Pose"},
    {"name": "relayed", "member": "relay.out", "kind": "data", "direction": "output", "type": "peer::Pose"},
    {"name": "output", "member": "sink.pose", "kind": "data", "direction": "input", "type": "peer::pose_t"}
  ])");
  EXPECT_EQ(pipeline["ports"], expected) << pipeline.dump(2);
  // The connections are the member ports'; the names the profile wrote come with them.
  std::set<std::string> seen;
  for (const Json& c : graph["connections"]) {
    seen.insert(c.value("source", "") + " -> " + c.value("target", "") + " as " + c.value("source_promoted", "") +
                " -> " + c.value("target_promoted", ""));
  }
  EXPECT_EQ(seen, (std::set<std::string>{"source.pose -> relay.in as Pipeline.raw -> Pipeline.input",
                                         "relay.out -> sink.pose as Pipeline.relayed -> Pipeline.output"}))
      << graph.dump(2);
}

TEST_F(CompositeEndToEnd, CheckShowsWhatEachPromotedNameStandsFor) {
  const Ctl json = run(POLYPORTD, {"check", app_.string(), "--json"});
  ASSERT_EQ(json.code, 0) << json.err;
  const Json graph = json.json();
  ASSERT_FALSE(graph.is_discarded()) << json.out;
  expect_pipeline(graph);

  const Ctl text = run(POLYPORTD, {"check", app_.string()});
  ASSERT_EQ(text.code, 0) << text.err;
  EXPECT_NE(text.out.find("composites:\n  Pipeline  members: source relay sink\n"), std::string::npos) << text.out;
  EXPECT_NE(text.out.find("    output data raw = source.pose  type=peer::pose_t\n"), std::string::npos) << text.out;
  EXPECT_NE(text.out.find("source.pose -> relay.in  (as Pipeline.raw -> Pipeline.input)"), std::string::npos)
      << text.out;

  // The issue's failure case: a promoted port that does not exist, at its place.
  std::string broken = read_file(app_);
  const std::string good = R"(port_name="out" as="relayed")";
  ASSERT_NE(broken.find(good), std::string::npos);
  broken.replace(broken.find(good), good.size(), R"(port_name="output" as="relayed")");
  std::ofstream(dir() / "broken_app.xml") << broken;
  const Ctl refused = run(POLYPORTD, {"check", (dir() / "broken_app.xml").string()});
  EXPECT_NE(refused.code, 0);
  EXPECT_NE(refused.err.find((dir() / "broken_app.xml").string() +
                             ":24:7: /application_profile/composites/composite/promote[3]: component 'relay' has no "
                             "port 'output' (ports: in, out)"),
            std::string::npos)
      << refused.err;

  // Across profiles given together, a composite's name must not be another profile's component.
  std::ofstream(dir() / "other_app.xml")
      << "<?xml version=\"1.0\"?>\n<application_profile><name>other</name>\n  <types><file>" POLYPORT_SOURCE_DIR
         "/config/types/polyport_rpc.idl</file><file>" POLYPORT_SOURCE_DIR "/tests/dds_peers/peer.idl</file></types>\n"
         "  <subcomponents><subcomponent><name>Pipeline</name><reference>PoseRelay.xml</reference></subcomponent>"
         "</subcomponents>\n</application_profile>\n";
  const Ctl clash = run(POLYPORTD, {"check", app_.string(), (dir() / "other_app.xml").string()});
  EXPECT_NE(clash.code, 0);
  EXPECT_NE(clash.err.find(app_.string() + ":19:5: composite name 'Pipeline' is already used at " +
                           (dir() / "other_app.xml").string() + ":4:18"),
            std::string::npos)
      << clash.err;
}

TEST_F(CompositeEndToEnd, ConnectionsNamingTheCompositeDeliverEveryField) {
  auto sub = peer(LCM_PEER, "sub", {"sub", kUrl, "POSE_OUT"});
  auto daemon = start_daemon();
  auto pub = peer(LCM_PEER, "pub", {"pub", kUrl, "POSE_IN", "10"});
  ASSERT_TRUE(eventually([&] { return poses(*sub).size() >= 20; }, 30s))
      << "sub: " << poses(*sub).size() << " poses\n" << daemon->errors() << sub->errors();
  std::vector<Json> got = poses(*sub);
  for (const Json& pose : got) expect_pose(pose, kRelayOffset);
  expect_increasing(got);

  const Json list = ctl({"--json", "list"}).json();
  expect_pipeline(list);
  const Ctl human = ctl({"list"});
  EXPECT_NE(human.out.find("Pipeline.raw"), std::string::npos) << human.out;

  // Deactivating the composite deactivates its members, the later ones first; activating it
  // brings them back, and poses flow again.
  const Ctl off = ctl({"--json", "deactivate", "Pipeline"});
  ASSERT_EQ(off.code, 0) << off.out << off.err;
  const Json off_reply = off.json();
  ASSERT_EQ(off_reply["members"].size(), 3u) << off.out;
  EXPECT_EQ(off_reply["members"][0]["component"], "sink");
  EXPECT_EQ(off_reply["members"][2]["component"], "source");
  for (const std::string member : {"source", "relay", "sink"}) EXPECT_EQ(state_of(member), "inactive") << member;
  const Ctl again = ctl({"--json", "deactivate", "Pipeline"});
  ASSERT_EQ(again.code, 0) << again.out << again.err;
  EXPECT_EQ(again.json()["members"][0]["outcome"], "already inactive") << again.out;
  const Ctl on = ctl({"activate", "Pipeline"});
  ASSERT_EQ(on.code, 0) << on.out << on.err;
  for (const std::string member : {"source", "relay", "sink"}) EXPECT_EQ(state_of(member), "active") << member;
  const std::size_t before = poses(*sub).size();
  ASSERT_TRUE(eventually([&] { return poses(*sub).size() >= before + 10; }, 30s))
      << "no poses after activating the composite\n" << daemon->errors();

  // Run-time wiring by the composite's names: the connection is the member ports'.
  const Ctl cut = ctl({"--json", "disconnect", "Pipeline.relayed", "Pipeline.output"});
  ASSERT_EQ(cut.code, 0) << cut.out << cut.err;
  EXPECT_EQ(cut.json()["source"], "relay.out") << cut.out;
  EXPECT_EQ(cut.json()["target"], "sink.pose") << cut.out;
  const Ctl wired = ctl({"--json", "connect", "Pipeline.relayed", "Pipeline.output"});
  ASSERT_EQ(wired.code, 0) << wired.out << wired.err;
  bool listed = false;
  const Json relisted = ctl({"--json", "list"}).json();
  for (const Json& c : relisted["connections"]) {
    listed = listed || (c["source"] == "relay.out" && c["target"] == "sink.pose" && c["origin"] == "run time");
  }
  EXPECT_TRUE(listed);
  const Ctl unknown = ctl({"connect", "Pipeline.relayed", "Pipeline.nothing"});
  EXPECT_NE(unknown.code, 0);
  EXPECT_NE(unknown.err.find("composite 'Pipeline' promotes no port 'nothing'"), std::string::npos) << unknown.err;
  const std::size_t rewired = poses(*sub).size();
  ASSERT_TRUE(eventually([&] { return poses(*sub).size() >= rewired + 10; }, 30s))
      << "no poses after connecting Pipeline.relayed -> Pipeline.output again\n" << daemon->errors();

  pub.reset();
  got = poses(*sub);
  for (const Json& pose : got) expect_pose(pose, kRelayOffset);
  const Json stats = stop(*daemon);
  // Statistics stay per real port: the connections are named by the member ports.
  const Json* in = connection(stats, "source.pose -> relay.in");
  ASSERT_NE(in, nullptr);
  EXPECT_GE((*in)["delivered"].get<long long>(), 20) << in->dump(2);
  const Json* out = connection(stats, "relay.out -> sink.pose");
  ASSERT_NE(out, nullptr);
  EXPECT_GE((*out)["delivered"].get<long long>(), 10) << out->dump(2);
}

// A reload of a profile whose composite now promotes another port: the connection that names
// Pipeline.relayed leaves the relay's output and joins the LCM source's, make before break, and
// the poses on POSE_OUT are the publisher's own from then on, every field as sent.
TEST_F(CompositeEndToEnd, AReloadRepointsTheConnectionsOfAChangedComposite) {
  auto sub = peer(LCM_PEER, "sub", {"sub", kUrl, "POSE_OUT"});
  auto daemon = start_daemon();
  auto pub = peer(LCM_PEER, "pub", {"pub", kUrl, "POSE_IN", "10"});
  ASSERT_TRUE(eventually([&] { return poses(*sub).size() >= 5; }, 30s)) << daemon->errors();
  for (const Json& pose : poses(*sub)) expect_pose(pose, kRelayOffset);

  std::string text = read_file(app_);
  const std::string relayed = R"(<promote component_name="relay" port_name="out" as="relayed"/>)";
  ASSERT_NE(text.find(relayed), std::string::npos);
  text.replace(text.find(relayed), relayed.size(), R"(<promote component_name="source" port_name="pose" as="relayed"/>)");
  std::ofstream(app_) << text;
  const Ctl reload = ctl({"--json", "reload"});
  ASSERT_EQ(reload.code, 0) << reload.out << reload.err;
  const Json diff = reload.json();
  EXPECT_EQ(diff["composites"]["changed"], Json({"Pipeline"})) << diff.dump(2);
  EXPECT_EQ(diff["connections"]["removed"], Json({"relay.out -> sink.pose"})) << diff.dump(2);
  EXPECT_EQ(diff["connections"]["added"], Json({"source.pose -> sink.pose"})) << diff.dump(2);
  EXPECT_EQ(diff["components"]["changed"], Json::array()) << diff.dump(2);

  // Poses straight from the publisher: ids without the relay's offset.
  const auto direct = [&] {
    std::vector<Json> out;
    for (const Json& pose : poses(*sub)) {
      if (pose["id"].get<int>() < kRelayOffset) out.push_back(pose);
    }
    return out;
  };
  ASSERT_TRUE(eventually([&] { return direct().size() >= 10; }, 30s)) << daemon->errors();
  for (const Json& pose : direct()) expect_pose(pose);
  const Json list = ctl({"--json", "list"}).json();
  ASSERT_EQ(list["composites"].size(), 1u);
  EXPECT_EQ(list["composites"][0]["ports"][2]["member"], "source.pose") << list["composites"].dump(2);
  pub.reset();
  const Json stats = stop(*daemon);
  const Json* link = connection(stats, "source.pose -> sink.pose");
  ASSERT_NE(link, nullptr);
  EXPECT_EQ((*link)["conversion"], "passthrough") << link->dump(2);
}

// A service connection between a composite's promoted ports: an LCM client built with lcm-gen
// calls add through Calc.caller -> Calc.provider, the in-process PeerAdder answers each call.
TEST_F(CompositeEndToEnd, AServiceConnectionNamingTheCompositeAnswersEveryCall) {
  const fs::path service_app = dir() / "service_app.xml";
  const Ctl check = run(POLYPORTD, {"check", service_app.string(), "--json"});
  ASSERT_EQ(check.code, 0) << check.err;
  const Json graph = check.json();
  ASSERT_EQ(graph["composites"].size(), 1u) << check.out;
  EXPECT_EQ(graph["composites"][0]["ports"][0]["direction"], "required") << check.out;
  EXPECT_EQ(graph["composites"][0]["ports"][1]["member"], "adder.calc") << check.out;
  EXPECT_EQ(graph["composites"][0]["ports"][1]["service_type"], "peer::Calc") << check.out;

  auto daemon = this->daemon(service_app);
  auto client = peer(LCM_PEER, "client", {"call", kUrl, "CALC_ADD_REQUEST", "CALC_ADD_REPLY", "5", "5000"});
  ASSERT_EQ(client->wait(60s), 0) << client->errors() << daemon->errors();
  int requests = 0;
  EXPECT_EQ(checked_replies(*client, requests), 5);
  const Json stats = stop(*daemon);
  bool served = false;
  for (const Json& c : stats["components"]) {
    if (c["name"] != "client" || !c.contains("lcm") || c["lcm"]["services"].empty()) continue;
    const Json& counters = c["lcm"]["services"][0]["counters"];
    EXPECT_GE(counters["calls"].get<int>(), 5) << counters.dump();
    EXPECT_EQ(counters["replies"], counters["calls"]) << counters.dump();
    EXPECT_EQ(counters["errors"], 0) << counters.dump();
    served = true;
  }
  EXPECT_TRUE(served) << stats.dump(2);
}

// Three models behind one composite: a Cyclone DDS application built with idlc publishes
// poses in domain 17, the composite's connections take them through the in-process relay to
// the LCM channel POSE_OUT, where an lcm-gen subscriber checks every field.
TEST_F(CompositeEndToEnd, ACompositeOverThreeModelsDeliversEveryField) {
  if (std::string(CYCLONE_PEER).empty()) FAIL() << "cyclone_peer was not built (the Cyclone DDS model is needed)";
  // The peer speaks on loopback, as polyport's Cyclone model does by default.
  setenv("CYCLONEDDS_URI", "file://" POLYPORT_SOURCE_DIR "/config/cyclonedds-loopback.xml", 1);
  auto sub = peer(LCM_PEER, "sub", {"sub", kUrl, "POSE_OUT"});
  auto daemon = this->daemon(dir() / "dds_app.xml");
  auto pub = peer(CYCLONE_PEER, "dds_pub", {"pub", "17", "pose", "0", "10"} /* COUNT 0: until stopped */);
  ASSERT_TRUE(eventually([&] { return poses(*sub).size() >= 10; }, 60s))
      << "sub: " << poses(*sub).size() << " poses\n" << daemon->errors() << pub->errors();
  const std::vector<Json> got = poses(*sub);
  for (const Json& pose : got) expect_pose(pose, kRelayOffset);
  expect_increasing(got);
  pub.reset();
  const Json stats = stop(*daemon);
  const Json* in = connection(stats, "source.pose -> relay.in");
  ASSERT_NE(in, nullptr);
  EXPECT_NE((*in)["conversion"], "passthrough") << in->dump(2);  // DDS decoded for the in-process relay
}

}  // namespace
}  // namespace polyport::test
