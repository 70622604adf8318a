// The engine with the in-process model: plugins loaded from a profile, data and service
// connections between components on different execution contexts, and the checks that
// refuse a plugin whose C++ types do not match its profile.
#include <gtest/gtest.h>

#include <chrono>
#include <nlohmann/json.hpp>
#include <thread>

#include "inproc_model.hpp"
#include "polyport/runtime/component_api.hpp"
#include "polyport/runtime/engine.hpp"
#include "polyport/types/types.hpp"
#include "../support/engine_fixture.hpp"
#include "../support/eventually.hpp"

namespace polyport {
namespace {

using test::eventually;

class EngineTest : public test::EngineFixture {
 protected:
  EngineTest() : EngineFixture(POLYPORT_TEST_DATA "/engine", LoadOptions{{POLYPORT_PLUGIN_DIR}}) {
    models.add(std::make_unique<inproc::InprocModel>());
  }
};

TEST_F(EngineTest, DataAndServiceConnectionsAcrossExecutionContexts) {
  ASSERT_TRUE(build("services_app.xml")) << problems();
  std::vector<std::string> warnings;
  ASSERT_TRUE(engine.start(warnings));
  nlohmann::json stats;
  auto service_ok = [&] {
    stats = nlohmann::json();
    engine.stats(stats);
    return stats["services"][0]["ok"].get<std::uint64_t>() >= 20 &&
           stats["connections"][0]["read"].get<std::uint64_t>() >= 20;
  };
  ASSERT_TRUE(eventually(service_ok)) << stats.dump(2);
  engine.stop();
  stats = nlohmann::json();
  engine.stats(stats);
  EXPECT_EQ(stats["services"][0]["timeouts"], 0);
  EXPECT_EQ(stats["connections"][0]["dropped"], 0);
  // Ticker, Collector, Adder and Faulty share the 2 ms context; Caller has its own.
  EXPECT_EQ(engine.executors().contexts().size(), 2u);
  for (const auto& c : stats["components"]) EXPECT_EQ(c["state"], "finalized") << c.dump();
}

TEST_F(EngineTest, ComponentInErrorIsReportedAndCanBeReset) {
  ASSERT_TRUE(build("services_app.xml")) << problems();
  std::vector<std::string> warnings;
  ASSERT_TRUE(engine.start(warnings));
  Interceptor* faulty = engine.find_interceptor("faulty");
  ASSERT_NE(faulty, nullptr);
  ASSERT_TRUE(eventually([&] { return faulty->status().state == "error"; }));
  EXPECT_EQ(faulty->status().errors, 1u);
  EXPECT_EQ(faulty->command(LifecycleCommand::activate), ReturnCode::precondition_not_met);
  EXPECT_EQ(faulty->command(LifecycleCommand::reset), ReturnCode::ok);
  EXPECT_EQ(faulty->status().state, "inactive");
  EXPECT_EQ(faulty->command(LifecycleCommand::activate), ReturnCode::ok);
  engine.stop();
}

TEST_F(EngineTest, PluginTypeThatDoesNotMatchTheProfileIsRefused) {
  EXPECT_FALSE(build("wrong_size_app.xml"));
  ASSERT_EQ(diagnostics.error_count(), 1u) << problems();
  const std::string message = diagnostics.all().front().to_string();
  EXPECT_NE(message.find("WrongSize.xml:"), std::string::npos) << message;
  EXPECT_NE(message.find("port 'count': type 'long long' has size 8 and alignment 8 but component class "
                         "'WrongSize' uses a C++ type of size 4 and alignment 4"),
            std::string::npos)
      << message;
}

TEST_F(EngineTest, DescribeListsTheResolvedGraph) {
  ASSERT_TRUE(build("services_app.xml")) << problems();
  nlohmann::json graph;
  engine.describe(graph);
  ASSERT_EQ(graph["components"].size(), 5u);
  ASSERT_EQ(graph["connections"].size(), 2u);
  EXPECT_EQ(graph["connections"][0]["policy"], "buffer");
  EXPECT_EQ(graph["connections"][0]["depth"], 64);
  EXPECT_EQ(graph["connections"][1]["kind"], "service");
}

}  // namespace
}  // namespace polyport
