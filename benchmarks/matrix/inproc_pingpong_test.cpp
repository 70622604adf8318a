// A test of the matrix's in-process pieces, not a benchmark (no latency bound): the in-process
// pong (inproc_pingpong.cpp) inside polyportd answers the LCM ping program of the same-model
// benchmark (benchmarks/lcm/pingpong_lcm.cpp) for a few round trips, at both sizes, through an
// application like the one run_matrix.cpp writes for lcm -> inprocess, and the DDS ping
// programs (benchmarks/dds/pingpong_{cyclone,fastdds}.cpp, idlc / fastddsgen types), its
// CallbackInPort then called on the DDS vendor's receive thread; the in-process ping gets
// its pongs from the LCM pong program (inprocess -> lcm) and from the in-process pong in the same
// polyportd (the diagonal: the pong answers inside the ping's write, which the ping's trampoline
// must unwind). Each case runs in a network namespace of its own with a multicast route on
// loopback.
#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <string>
#include <vector>

#include "daemon_harness.hpp"
#include "multicast_namespace.hpp"

namespace polyport::test {
namespace {

class InprocPongTest : public DaemonTest {
 protected:
  InprocPongTest() : DaemonTest("polyport-matrix-inproc") {}
  void SetUp() override {
    // The DDS ping programs stay on loopback, with the configurations polyport's DDS models
    // default to (as run_matrix.cpp sets them).
    setenv("CYCLONEDDS_URI", "file://" POLYPORT_SOURCE_DIR "/config/cyclonedds-loopback.xml", 1);
    setenv("FASTRTPS_DEFAULT_PROFILES_FILE", POLYPORT_SOURCE_DIR "/config/fastdds-loopback.xml", 1);
    DaemonTest::SetUp();
    isolate_with_multicast_route();
  }

  // A port of the LCM types, or of the IDL ones when `dds`; `wire` is its LCM channel (DDS
  // topic), none for an in-process port.
  static std::string data_port(int size, const std::string& name, const char* usage, const std::string& wire,
                               bool dds = false) {
    const std::string type = dds ? (size == 16 ? "bench::Ping16" : "bench::Ping1k")
                                 : (size == 16 ? "bench_lcm::ping16_t" : "bench_lcm::ping1k_t");
    const char* tag = dds ? "topic" : "channel";
    return "<data_port><name>" + name + "</name><data_type>" + type + "</data_type><usage>" + usage + "</usage>" +
           (wire.empty() ? "" : "<" + std::string(tag) + ">" + wire + "</" + tag + ">") + "</data_port>\n";
  }
  // The DDS ping program's side on `domain` of `model` (cyclonedds, fastdds): it publishes
  // "ping", polyport "pong".
  void write_dds_side(const std::string& model, int domain, int size) const {
    std::ofstream(dir() / "DdsSide.xml")
        << "<?xml version=\"1.0\"?>\n<component_profile><name>DdsSide</name><model>" << model
        << "</model>\n<dds><domain>" << domain << "</domain></dds>\n<ports>\n"
        << data_port(size, "ping", "output", "ping", true) << data_port(size, "pong", "input", "pong", true)
        << "</ports></component_profile>\n";
  }
  // An LCM component on udpm port `port`: the program on the other side publishes
  // `app_publishes` (polyport's output port) and polyport the other one.
  void write_lcm_side(int port, int size, const char* app_publishes) const {
    const bool ping_program = std::string(app_publishes) == "PING";
    std::ofstream(dir() / "LcmSide.xml")
        << "<?xml version=\"1.0\"?>\n<component_profile><name>LcmSide</name><model>lcm</model>\n"
           "<lcm><url>udpm://239.255.76.67:"
        << port << "?ttl=0</url></lcm>\n<ports>\n"
        << data_port(size, "ping", ping_program ? "output" : "input", "PING")
        << data_port(size, "pong", ping_program ? "input" : "output", "PONG") << "</ports></component_profile>\n";
  }
  void write_inproc_pong(int size, bool dds = false) const {
    std::ofstream(dir() / "InprocPong.xml")
        << "<?xml version=\"1.0\"?>\n<component_profile><name>InprocPong</name><model>inproc</model>\n"
           "<execution_environment><library_type>so</library_type><library_name>" INPROC_PINGPONG
           "</library_name><class_name>"
        << (size == 16 ? "Pong16" : "Pong1k")
        << "</class_name></execution_environment>\n"
           "<execution_semantics><type>passive</type></execution_semantics>\n<ports>\n"
        << data_port(size, "ping", "input", "", dds) << data_port(size, "pong", "output", "", dds)
        << "</ports></component_profile>\n";
  }
  void write_inproc_ping(int size, int rounds, int warmup) const {
    std::ofstream(dir() / "InprocPing.xml")
        << "<?xml version=\"1.0\"?>\n<component_profile><name>InprocPing</name><model>inproc</model>\n"
           "<execution_environment><library_type>so</library_type><library_name>" INPROC_PINGPONG
           "</library_name><class_name>"
        << (size == 16 ? "Ping16Comp" : "Ping1kComp")
        << "</class_name></execution_environment>\n"
           "<execution_semantics><type>periodic</type><period>10</period></execution_semantics>\n<properties>"
           "<property name=\"rounds\">"
        << rounds << "</property><property name=\"warmup\">" << warmup
        << "</property><property name=\"start_ms\">200</property><property name=\"report\">"
        << (dir() / "ping.json").string() << "</property></properties>\n<ports>\n"
        << data_port(size, "ping", "output", "") << data_port(size, "pong", "input", "")
        << "</ports></component_profile>\n";
  }
  // Subcomponents a (the ping side) and b (the pong side), a.ping -> b.ping, b.pong -> a.pong.
  fs::path write_app(const std::string& ping_side, const std::string& pong_side,
                     const char* types = POLYPORT_BENCH_LCM_TYPES) const {
    std::ofstream(dir() / "app.xml")
        << "<?xml version=\"1.0\"?>\n<application_profile><name>inproc_pingpong</name>\n"
           "<types><file>"
        << types
        << "</file></types>\n"
           "<subcomponents><subcomponent><name>a</name><reference>"
        << ping_side << "</reference></subcomponent><subcomponent><name>b</name><reference>" << pong_side
        << "</reference></subcomponent></subcomponents>\n"
           "<port_connections>\n"
           "<port_connection port_type=\"data\"><source component_name=\"a\" port_name=\"ping\"/>"
           "<target component_name=\"b\" port_name=\"ping\"/></port_connection>\n"
           "<port_connection port_type=\"data\"><source component_name=\"b\" port_name=\"pong\"/>"
           "<target component_name=\"a\" port_name=\"pong\"/></port_connection>\n"
           "</port_connections></application_profile>\n";
    return dir() / "app.xml";
  }
  fs::path write_app(int port, int size) const {
    write_lcm_side(port, size, "PING");
    write_inproc_pong(size);
    return write_app("LcmSide.xml", "InprocPong.xml");
  }

  // The in-process ping's report once it has written it (the daemon still running).
  void expect_ping_report(Child& daemon, int rounds) {
    const fs::path report = dir() / "ping.json";
    ASSERT_TRUE(eventually([&] { return fs::exists(report) && !read_file(report).empty(); }))
        << "no report from the in-process ping:\n" << daemon.errors();
    const Json j = Json::parse(read_file(report), nullptr, false);
    ASSERT_FALSE(j.is_discarded()) << read_file(report);
    EXPECT_EQ(j["lost"], 0) << j.dump();
    EXPECT_EQ(j["rtt_ns"]["n"], rounds) << j.dump();
    EXPECT_LE(j["rtt_ns"]["min"].get<std::int64_t>(), j["rtt_ns"]["max"].get<std::int64_t>()) << j.dump();
    // One ping write at a time, never one inside another (a pong answered inside the write).
    EXPECT_EQ(j["max_send_depth"], 1) << j.dump();
  }

  // The ping program `ping` (its arguments but rounds and warm-up) through `app` to the
  // in-process pong: every measured round trip answered, and every ping and pong handed on by
  // polyport, b.ping a push-mode (CallbackInPort) port. `lost_in_warmup` is how many warm-up
  // pings may go unanswered (a DDS ping starts once its own endpoints match, which does not
  // mean polyport's have matched them: a sample written in between is dropped by the volatile
  // endpoints on either side).
  void answers_the_ping(const fs::path& app, std::vector<std::string> ping, int lost_in_warmup) {
    constexpr int kRounds = 20;
    constexpr int kWarmup = 5;
    const Ran checked = run_to_end({POLYPORTD, "check", app.string()});
    ASSERT_EQ(checked.code, 0) << checked.out << checked.err;
    auto daemon = this->daemon(app);
    ping.push_back(std::to_string(kRounds));
    ping.push_back(std::to_string(kWarmup));
    const Ran pinged = run_to_end(ping);
    ASSERT_EQ(pinged.code, 0) << pinged.out << pinged.err;
    const Json report = pinged.json();
    ASSERT_FALSE(report.is_discarded()) << pinged.out;
    EXPECT_LE(report["lost"].get<int>(), lost_in_warmup) << report.dump();
    EXPECT_EQ(report["rtt_ns"]["n"], kRounds) << report.dump();
    // Every answered ping went through both connections (an unanswered one may have been lost
    // on either side of polyport).
    const int answered = kRounds + kWarmup - report["lost"].get<int>();
    const Json stats = stop(*daemon);
    bool pushed = false;
    for (const Json& c : stats["connections"]) {
      EXPECT_EQ(c["dropped"], 0) << c.dump(2);
      EXPECT_GE(c["delivered"].get<int>(), answered) << c.dump(2);
      if (c["target"] == "b.ping") pushed = c["mode"] == "push";
    }
    EXPECT_TRUE(pushed) << "b.ping is no push-mode (CallbackInPort) port: " << stats["connections"].dump(2);
  }

  void answers_the_lcm_ping(int size) {
    answers_the_ping(write_app(7960, size), {PINGPONG_LCM, "ping", "7960", std::to_string(size)}, 0);
  }

  // `program` is the vendor's ping program, `model` polyport's model of that vendor.
  void answers_the_dds_ping(const char* program, const std::string& model, int domain, int size) {
    write_dds_side(model, domain, size);
    write_inproc_pong(size, true);
    answers_the_ping(write_app("DdsSide.xml", "InprocPong.xml", POLYPORT_BENCH_IDL),
                     {program, "ping", std::to_string(domain), std::to_string(size)}, 2);  // one a side
  }
};

TEST_F(InprocPongTest, AnswersTheLcmPing16) { answers_the_lcm_ping(16); }
TEST_F(InprocPongTest, AnswersTheLcmPing1k) { answers_the_lcm_ping(1024); }
TEST_F(InprocPongTest, AnswersTheCycloneDdsPing16) { answers_the_dds_ping(PINGPONG_CYCLONE, "cyclonedds", 171, 16); }
TEST_F(InprocPongTest, AnswersTheFastDdsPing1k) { answers_the_dds_ping(PINGPONG_FASTDDS, "fastdds", 172, 1024); }

TEST_F(InprocPongTest, InprocessPingGetsItsPongsFromTheLcmPongProgram) {
  constexpr int kRounds = 30;
  auto pong = peer(PINGPONG_LCM, "pong", {"pong", "7962", "16"});
  write_lcm_side(7962, 16, "PONG");
  write_inproc_ping(16, kRounds, 5);
  auto daemon = this->daemon(write_app("InprocPing.xml", "LcmSide.xml"));
  expect_ping_report(*daemon, kRounds);
  const Json stats = stop(*daemon);
  bool pushed = false;
  for (const Json& c : stats["connections"]) {
    if (c["target"] == "a.pong") pushed = c["mode"] == "push";
  }
  EXPECT_TRUE(pushed) << "a.pong is no push-mode (CallbackInPort) port: " << stats["connections"].dump(2);
}

// The pong answers inside the ping's write, on the ping's thread: the ping's trampoline sends
// each next ping after that write has returned, so 1000 round trips do not nest 1000 deep
// (the report's max_send_depth stays 1).
TEST_F(InprocPongTest, InprocessPingGetsItsPongsFromTheInprocessPongInTheSameDaemon) {
  constexpr int kRounds = 1000;
  write_inproc_ping(1024, kRounds, 10);
  write_inproc_pong(1024);
  auto daemon = this->daemon(write_app("InprocPing.xml", "InprocPong.xml"));
  expect_ping_report(*daemon, kRounds);
  const Json stats = stop(*daemon);
  for (const Json& c : stats["connections"]) {
    EXPECT_EQ(c["mode"], "push") << c.dump(2);
    EXPECT_EQ(c["delivered"], kRounds + 10) << c.dump(2);
    EXPECT_EQ(c["dropped"], 0) << c.dump(2);
  }
}

}  // namespace
}  // namespace polyport::test
