// Events with conditions (SmartSoft's event pattern): the condition on its own (operators,
// single-shot and continuous activations, parameters, counters), every problem of a
// <condition> in a profile at its place, and in-process components through the engine: a
// battery server's state to clients that activate their events with parameters, and one
// whose condition never holds.
#include <gtest/gtest.h>

#include <atomic>
#include <cstring>
#include <nlohmann/json.hpp>
#include <thread>
#include <vector>

#include <filesystem>
#include <fstream>
#include <unistd.h>

#include "inproc_model.hpp"
#include "reload.hpp"
#include "polyport/runtime/event_condition.hpp"
#include "polyport/runtime/engine.hpp"
#include "../support/engine_fixture.hpp"
#include "../support/eventually.hpp"

namespace polyport {
namespace {

using test::eventually;

struct State {
  double charge;
  std::int32_t cycle;
};

ConditionField field(std::uint32_t offset, TypeKind kind, ConditionOp op, double value, std::string param = {}) {
  return ConditionField{offset, kind, op, value, std::move(param), "f"};
}

bool admits(EventCondition& condition, double charge, std::int32_t cycle = 0) {
  State state{charge, cycle};
  std::byte flat[sizeof(State)];
  std::memcpy(flat, &state, sizeof state);
  return condition.admits(flat);
}

TEST(EventCondition, EachOperatorComparesTheFieldWithItsThreshold) {
  const struct {
    ConditionOp op;
    bool below, at, above;
  } cases[] = {
      {ConditionOp::lt, true, false, false}, {ConditionOp::le, true, true, false},
      {ConditionOp::gt, false, false, true}, {ConditionOp::ge, false, true, true},
      {ConditionOp::eq, false, true, false}, {ConditionOp::ne, true, false, true},
  };
  for (const auto& c : cases) {
    EventCondition condition({field(0, TypeKind::float64, c.op, 20.0)}, EventMode::continuous, true);
    EXPECT_EQ(admits(condition, 19.5), c.below) << to_string(c.op);
    EXPECT_EQ(admits(condition, 20.0), c.at) << to_string(c.op);
    EXPECT_EQ(admits(condition, 20.5), c.above) << to_string(c.op);
  }
  // An integer field, read at its offset in its own width.
  EventCondition cycle({field(offsetof(State, cycle), TypeKind::int32, ConditionOp::ge, 3.0)}, EventMode::continuous,
                       true);
  EXPECT_FALSE(admits(cycle, 0.0, 2));
  EXPECT_TRUE(admits(cycle, 0.0, 3));
}

TEST(EventCondition, AllFieldsMustHold) {
  EventCondition condition({field(0, TypeKind::float64, ConditionOp::lt, 20.0),
                            field(offsetof(State, cycle), TypeKind::int32, ConditionOp::gt, 10.0)},
                           EventMode::continuous, true);
  EXPECT_FALSE(admits(condition, 10.0, 5));
  EXPECT_FALSE(admits(condition, 30.0, 50));
  EXPECT_TRUE(admits(condition, 10.0, 50));
  EXPECT_EQ(condition.counters().tested.load(), 3u);
  EXPECT_EQ(condition.counters().fired.load(), 1u);
  EXPECT_EQ(condition.counters().suppressed.load(), 2u);
}

TEST(EventCondition, SingleShotFiresOnceUntilActivatedAgain) {
  EventCondition condition({field(0, TypeKind::float64, ConditionOp::lt, 20.0)}, EventMode::single, true);
  EXPECT_TRUE(condition.active());
  EXPECT_FALSE(admits(condition, 50.0));  // does not hold: still armed
  EXPECT_TRUE(admits(condition, 10.0));
  EXPECT_FALSE(condition.active());
  EXPECT_FALSE(admits(condition, 5.0));  // spent
  EXPECT_EQ(condition.counters().fired.load(), 1u);
  EXPECT_EQ(condition.counters().inactive.load(), 1u);
  ASSERT_EQ(condition.activate(EventMode::single), Status::ok);
  EXPECT_TRUE(admits(condition, 5.0));
  EXPECT_FALSE(admits(condition, 4.0));
  EXPECT_EQ(condition.counters().fired.load(), 2u);
  EXPECT_EQ(condition.counters().activations.load(), 2u);  // the profile's and this one
}

TEST(EventCondition, ContinuousFiresEachTimeUntilDeactivated) {
  EventCondition condition({field(0, TypeKind::float64, ConditionOp::lt, 20.0)}, EventMode::continuous, false);
  EXPECT_FALSE(condition.active());
  EXPECT_FALSE(admits(condition, 10.0));
  EXPECT_EQ(condition.counters().inactive.load(), 1u);
  EXPECT_EQ(condition.counters().tested.load(), 0u);
  ASSERT_EQ(condition.activate(EventMode::continuous), Status::ok);
  for (int i = 0; i < 5; ++i) EXPECT_TRUE(admits(condition, 10.0 - i));
  condition.deactivate();
  EXPECT_FALSE(admits(condition, 1.0));
  EXPECT_EQ(condition.counters().fired.load(), 5u);
  EXPECT_EQ(condition.counters().inactive.load(), 2u);
}

TEST(EventCondition, ParametersOverrideTheThresholdsThatNameThem) {
  EventCondition condition({field(0, TypeKind::float64, ConditionOp::lt, 20.0, "level"),
                            field(offsetof(State, cycle), TypeKind::int32, ConditionOp::ge, 0.0)},
                           EventMode::continuous, true);
  EXPECT_FALSE(admits(condition, 25.0));
  const ConditionParameter level[] = {{"level", 30.0}};
  ASSERT_EQ(condition.activate(EventMode::continuous, level), Status::ok);
  EXPECT_TRUE(admits(condition, 25.0));
  EXPECT_EQ(condition.thresholds(), (std::vector<double>{30.0, 0.0}));
  // A name that no field uses: refused, nothing changes.
  const ConditionParameter unknown[] = {{"level", 5.0}, {"voltage", 1.0}};
  EXPECT_EQ(condition.activate(EventMode::single, unknown), Status::error);
  EXPECT_EQ(condition.thresholds(), (std::vector<double>{30.0, 0.0}));
  EXPECT_EQ(condition.mode(), EventMode::continuous);
  // Without parameters: the profile's values again.
  ASSERT_EQ(condition.activate(EventMode::continuous), Status::ok);
  EXPECT_EQ(condition.thresholds(), (std::vector<double>{20.0, 0.0}));
}

TEST(EventCondition, NeverHoldingIsVisibleInTheCounters) {
  EventCondition condition({field(0, TypeKind::float64, ConditionOp::gt, 100.0)}, EventMode::continuous, true);
  for (int i = 0; i <= 100; ++i) EXPECT_FALSE(admits(condition, i));
  EXPECT_EQ(condition.counters().tested.load(), 101u);
  EXPECT_EQ(condition.counters().suppressed.load(), 101u);
  EXPECT_EQ(condition.counters().fired.load(), 0u);
}

// The writer tests while another thread activates with ever new levels: every sample it lets
// through holds for a level that was published whole (the two fields' thresholds of one
// activation: charge < level and cycle <= level, so a sample at exactly the level of another
// activation would pass only if the writer mixed two of them).
TEST(EventCondition, ActivationsWhileTheWriterTestsArePublishedWhole) {
  EventCondition condition({field(0, TypeKind::float64, ConditionOp::lt, 0.0, "level"),
                            field(offsetof(State, cycle), TypeKind::int32, ConditionOp::ge, 0.0, "floor")},
                           EventMode::continuous, true);
  std::atomic<bool> stop{false};
  std::thread activator([&] {
    for (int k = 1; !stop.load(); k = k % 1000 + 1) {
      // Level k and floor k together: a sample (charge k - 0.5, cycle k) holds for this
      // activation only.
      const ConditionParameter parameters[] = {{"level", static_cast<double>(k)}, {"floor", static_cast<double>(k)}};
      ASSERT_EQ(condition.activate(EventMode::continuous, parameters), Status::ok);
    }
  });
  std::uint64_t fired = 0;
  for (int i = 0; i < 200000; ++i) {
    const int k = i % 1000 + 1;
    if (admits(condition, k - 0.5, k)) {
      ++fired;
    }
    // A torn read could hold for charge < level(new) with cycle >= floor(old): a sample of a
    // lower k than both, which the pair (k, k) never admits. Test one such sample too.
    EXPECT_FALSE(admits(condition, k + 0.5, k)) << k;
  }
  stop = true;
  activator.join();
  EXPECT_EQ(condition.counters().fired.load(), fired);
}

class ConditionProfiles : public test::EngineFixture {
 protected:
  ConditionProfiles() : EngineFixture(POLYPORT_TEST_DATA "/condevents", LoadOptions{{POLYPORT_PLUGIN_DIR}}) {
    models.add(std::make_unique<inproc::InprocModel>());
  }
  std::vector<std::string> messages() const {
    std::vector<std::string> out;
    for (const auto& d : diagnostics.all()) {
      std::string text = d.to_string();
      // From the test data folder on, so that the expectations do not depend on the checkout.
      const auto at = text.find("data/condevents/");
      if (at != std::string::npos) text = text.substr(at + std::strlen("data/condevents/"));
      out.push_back(text);
    }
    return out;
  }
};

TEST_F(ConditionProfiles, EveryProblemOfAConditionAtItsPlace) {
  EXPECT_FALSE(build("bad_conditions_app.xml"));
  const std::string file = "bad_conditions_app.xml:";
  const std::string connection = "/application_profile/port_connections/port_connection";
  EXPECT_EQ(messages(), (std::vector<std::string>{
      // Reading.
      file + "17:24: " + connection + "[1]/condition/@mode: bad mode 'once' (accepted: single, continuous)",
      file + "17:38: " + connection + "[1]/condition/@active: bad active 'yes' (accepted: true, false, 1, 0)",
      file + "18:34: " + connection + "[1]/condition/field[1]/@op: bad op 'below' (accepted: lt, le, gt, ge, eq, ne)",
      file + "19:45: " + connection + "[1]/condition/field[2]/@value: bad value 'twenty': expected a number",
      file + "20:9: " + connection + "[1]/condition/field[3]: missing attribute 'value' (the threshold, also when an "
      "activation may give 'param')",
      file + "29:56: " + connection + "[2]/condition/field[3]/@param: empty attribute 'param'",
      file + "40:7: " + connection + "[4]/condition: a condition needs at least one <field name op value>",
      // Against the graph and the source's type.
      file + "27:9: " + connection + "[2]/condition/field[1]: field 'voltage' not found in 'cond::BatteryState' of "
      "battery.state (fields: charge, cycle, note)",
      file + "28:9: " + connection + "[2]/condition/field[2]: a condition compares numbers; 'note' of battery.state "
      "is 'string<15>'",
      file + "35:7: " + connection + "[3]/condition: a condition applies only to event connections "
      "(port_type=\"event\"): the source's state, tested for the target's event input",
  })) << problems();
}

TEST_F(ConditionProfiles, ConditionsAreReadAsWritten) {
  LoadOptions options{{POLYPORT_PLUGIN_DIR}};
  options.models = &models;
  const auto app = load_application_profile(POLYPORT_TEST_DATA "/condevents/inproc_app.xml", types, options, diagnostics);
  ASSERT_TRUE(app.has_value()) << problems();
  ASSERT_EQ(app->connections.size(), 3u);
  const ConditionSpec& continuous = *app->connections[0].condition;
  EXPECT_EQ(continuous.mode, EventMode::continuous);
  EXPECT_FALSE(continuous.active);
  ASSERT_EQ(continuous.fields.size(), 1u);
  EXPECT_EQ(continuous.fields[0].field, "charge");
  EXPECT_EQ(continuous.fields[0].op, ConditionOp::lt);
  EXPECT_EQ(continuous.fields[0].value, 20.0);
  EXPECT_EQ(continuous.fields[0].param, "level");
  const ConditionSpec& single = *app->connections[1].condition;
  EXPECT_EQ(single.mode, EventMode::single);
  ASSERT_EQ(single.fields.size(), 2u);
  EXPECT_EQ(single.fields[1].op, ConditionOp::ge);
  EXPECT_TRUE(single.fields[1].param.empty());
  const ConditionSpec& never = *app->connections[2].condition;
  EXPECT_EQ(never.mode, EventMode::continuous);  // the defaults
  EXPECT_TRUE(never.active);
}

const nlohmann::json* find_connection(const nlohmann::json& stats, const std::string& name) {
  for (const auto& c : stats["connections"]) {
    // Stats name a connection; describe gives its ends.
    if (c.value("name", c.value("source", "") + " -> " + c.value("target", "")) == name) return &c;
  }
  return nullptr;
}

// In-process server and clients: each client activates its own event with its own level; the
// client checks every event it takes against that level (it goes to error otherwise).
TEST_F(ConditionProfiles, InProcessClientsActivateTheirEventsWithParameters) {
  ASSERT_TRUE(build("inproc_app.xml")) << problems();
  std::vector<std::string> warnings;
  ASSERT_TRUE(engine.start(warnings));
  nlohmann::json stats;
  const auto condition = [&](const std::string& client) -> nlohmann::json {
    const nlohmann::json* c = find_connection(stats, "battery.state -> " + client + ".low");
    return c ? (*c)["condition"] : nlohmann::json();
  };
  // Two full discharges (101 states each) after every client activated.
  ASSERT_TRUE(eventually([&] {
    stats = nlohmann::json();
    engine.stats(stats);
    // The single-shot one is spent after its event: the states after it come as inactive.
    return condition("continuous").value("tested", 0) >= 250 && condition("single").value("inactive", 0) >= 250 &&
           condition("never").value("tested", 0) >= 250;
  })) << stats.dump(2);
  engine.stop();
  stats = nlohmann::json();
  engine.stats(stats);
  for (const auto& c : stats["components"]) EXPECT_NE(c["state"], "error") << c.dump();

  // Continuous, level 30 from the client (the profile's 20 and inactive until then).
  const nlohmann::json continuous = condition("continuous");
  EXPECT_EQ(continuous["fields"][0]["value"], 30.0) << continuous.dump();
  EXPECT_EQ(continuous["fields"][0]["param"], "level");
  EXPECT_EQ(continuous["active"], true);
  EXPECT_GE(continuous["activations"].get<long long>(), 1);
  EXPECT_EQ(continuous["tested"].get<long long>(),
            continuous["fired"].get<long long>() + continuous["suppressed"].get<long long>());
  // 30 of every 101 states are below 30: about 30 %, from two discharges on.
  EXPECT_GE(continuous["fired"].get<long long>(), 2 * 30 - 30) << continuous.dump();
  EXPECT_GT(continuous["suppressed"].get<long long>(), continuous["fired"].get<long long>()) << continuous.dump();
  const nlohmann::json* to_continuous = find_connection(stats, "battery.state -> continuous.low");
  EXPECT_EQ((*to_continuous)["delivered"], continuous["fired"]);
  EXPECT_EQ((*to_continuous)["received"].get<long long>(),
            continuous["tested"].get<long long>() + continuous["inactive"].get<long long>());

  // Single, level 50: one event, then spent (every later state counted as inactive).
  const nlohmann::json single = condition("single");
  EXPECT_EQ(single["fired"], 1) << single.dump();
  EXPECT_EQ(single["active"], false);
  EXPECT_GE(single["inactive"].get<long long>(), 250) << single.dump();
  EXPECT_EQ(single["tested"].get<long long>(), single["suppressed"].get<long long>() + 1) << single.dump();
  EXPECT_EQ(single["fields"][0]["value"], 50.0);
  EXPECT_EQ((*find_connection(stats, "battery.state -> single.low"))["delivered"], 1);

  // Never: tested every time, fired never.
  const nlohmann::json never = condition("never");
  EXPECT_EQ(never["fired"], 0) << never.dump();
  EXPECT_EQ(never["suppressed"], never["tested"]);
  EXPECT_EQ(never["inactive"], 0);
  EXPECT_EQ((*find_connection(stats, "battery.state -> never.low"))["delivered"], 0);
}

TEST_F(ConditionProfiles, DescribeShowsTheCondition) {
  ASSERT_TRUE(build("inproc_app.xml")) << problems();
  nlohmann::json graph;
  engine.describe(graph);
  const nlohmann::json* c = find_connection(graph, "battery.state -> single.low");
  ASSERT_NE(c, nullptr) << graph.dump(2);
  const nlohmann::json& condition = (*c)["condition"];
  EXPECT_EQ(condition["mode"], "single");
  EXPECT_EQ(condition["active"], false);
  ASSERT_EQ(condition["fields"].size(), 2u);
  EXPECT_EQ(condition["fields"][0]["field"], "charge");
  EXPECT_EQ(condition["fields"][0]["op"], "lt");
  EXPECT_EQ(condition["fields"][0]["value"], 20.0);
  EXPECT_EQ(condition["fields"][1]["field"], "cycle");
  EXPECT_EQ(condition["fields"][1]["op"], "ge");
}

// A reload compares the whole <port_connection>: a changed condition makes the connection
// again with it, and the rest runs on.
TEST_F(ConditionProfiles, AChangedConditionIsMadeAgainOnReload) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / ("polyport-condevents-reload-" + std::to_string(getpid()));
  fs::create_directories(dir);
  const fs::path file = dir / "app.xml";
  const auto write = [&](const std::string& value) {
    std::ofstream(file) << "<?xml version=\"1.0\"?>\n<application_profile><name>reloaded</name><subcomponents>"
                           "<subcomponent><name>battery</name><reference>" POLYPORT_TEST_DATA
                           "/condevents/BatteryServer.xml</reference></subcomponent>"
                           "<subcomponent><name>never</name><reference>" POLYPORT_TEST_DATA
                           "/condevents/ConditionClient.xml</reference></subcomponent></subcomponents>"
                           "<port_connections><port_connection port_type=\"event\">"
                           "<source component_name=\"battery\" port_name=\"state\"/>"
                           "<target component_name=\"never\" port_name=\"low\"/>"
                           "<condition><field name=\"charge\" op=\"gt\" value=\""
                        << value << "\"/></condition></port_connection></port_connections></application_profile>\n";
  };
  LoadOptions options{{POLYPORT_PLUGIN_DIR}};
  options.models = &models;
  daemon::ProfileReader read = [&](TypeRegistry& into, Diagnostics& found) {
    return load_application_profile(file, into, options, found);
  };
  write("100");
  auto loaded = read(types, diagnostics);
  ASSERT_TRUE(loaded) << problems();
  ApplicationProfile application = std::move(*loaded);
  ASSERT_TRUE(engine.build(application, diagnostics)) << problems();
  std::vector<std::string> warnings;
  ASSERT_TRUE(engine.start(warnings));
  ASSERT_EQ(engine.connections().size(), 1u);
  const EventCondition* before = engine.connections().front()->condition();
  ASSERT_NE(before, nullptr);
  EXPECT_EQ(before->thresholds(), std::vector<double>{100.0});

  write("50");
  const Result<nlohmann::json> done = daemon::reload(engine, types, application, read, {}, warnings);
  ASSERT_TRUE(done) << done.error().message;
  EXPECT_EQ(done.value()["connections"]["changed"], nlohmann::json::array({"battery.state -> never.low"}));
  ASSERT_EQ(engine.connections().size(), 1u);
  const EventCondition* after = engine.connections().front()->condition();
  ASSERT_NE(after, nullptr);
  EXPECT_EQ(after->thresholds(), std::vector<double>{50.0});
  // The new condition holds for half of the states: it fires while the application runs.
  EXPECT_TRUE(eventually([&] { return after->counters().fired.load() > 0; }));
  engine.stop();
  fs::remove_all(dir);
}

}  // namespace
}  // namespace polyport
