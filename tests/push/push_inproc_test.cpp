// Push timed between in-process components in polyportd (tests/push/push_components.cpp):
// the ticker counts every 10 ms on a port with a base cycle of 20 ms, so every other count
// goes out; `profiled` takes every 3rd cycle as its <subscription> says (counts 1, 7, 13, …),
// `client` subscribes itself every 2nd cycle on its first cycle (then counts 4 apart). The
// ticker is told of each subscribe, and stops at count 61: both watchers then read
// not_active.
#include <fstream>

#include "../support/daemon_harness.hpp"

namespace polyport::test {
namespace {

class PushInproc : public DaemonTest {
 protected:
  PushInproc() : DaemonTest("polyport-push-inproc") {}
};

// What the trace file holds of `port`, in order.
std::vector<Json> traced(const fs::path& file, const std::string& port) {
  std::vector<Json> out;
  std::ifstream in(file);
  std::string text;
  while (std::getline(in, text)) {
    const Json j = Json::parse(text, nullptr, false);
    if (!j.is_discarded() && j.value("port", "") == port) out.push_back(j["value"]);
  }
  return out;
}

TEST_F(PushInproc, SubscribersTakeTheirMultipleOfTheBaseCycleUntilTheServerStops) {
  const fs::path app = fill_templates(POLYPORT_SOURCE_DIR "/tests/push/data", {}, "inproc_app.xml");
  const fs::path trace = dir() / "trace.jsonl";
  auto daemon = this->daemon(app, {"--trace", "profiled.seen", "--trace", "client.seen", "--trace-file", trace.string()});
  // Count 61 comes after 600 ms; both watchers then say not_active (n = -1).
  ASSERT_TRUE(eventually([&] {
    const auto a = traced(trace, "profiled.seen");
    const auto b = traced(trace, "client.seen");
    return !a.empty() && a.back()["n"] == -1 && !b.empty() && b.back()["n"] == -1;
  }, 30s)) << daemon->errors();
  const Json stats = stop(*daemon);

  std::vector<Json> profiled = traced(trace, "profiled.seen");
  profiled.pop_back();  // the not_active mark
  ASSERT_GE(profiled.size(), 5u);
  EXPECT_EQ(profiled.front()["n"].get<long long>() % 6, 1) << profiled.front().dump();  // 1, 7, 13, ...
  for (std::size_t i = 1; i < profiled.size(); ++i) {
    EXPECT_EQ(profiled[i]["n"].get<long long>() - profiled[i - 1]["n"].get<long long>(), 6) << profiled[i].dump();
  }
  EXPECT_LT(profiled.back()["n"].get<long long>(), 61);
  std::vector<Json> client = traced(trace, "client.seen");
  client.pop_back();
  ASSERT_GE(client.size(), 6u);
  // Each count once; 2 apart (every cycle) before the client's subscribe(2), 4 apart after.
  for (std::size_t i = 1; i < client.size(); ++i) {
    const long long step = client[i]["n"].get<long long>() - client[i - 1]["n"].get<long long>();
    EXPECT_TRUE(step == 2 || step == 4) << client[i].dump();
  }
  for (std::size_t i = client.size() - 3; i < client.size(); ++i) {
    EXPECT_EQ(client[i]["n"].get<long long>() - client[i - 1]["n"].get<long long>(), 4) << client[i].dump();
  }
  // The ticker was told of both connections and of the client's own subscribe.
  EXPECT_EQ(client.back()["subscribes"], 3) << client.back().dump();
  EXPECT_EQ(client.back()["unsubscribes"], 0) << client.back().dump();

  const Json* link = nullptr;
  for (const Json& c : stats["connections"]) {
    if (c.value("name", "") == "ticker.ticks -> profiled.ticks") link = &c;
  }
  ASSERT_NE(link, nullptr) << stats.dump(2);
  EXPECT_EQ((*link)["subscription"]["every"], 3) << link->dump(2);
  EXPECT_EQ((*link)["subscription"]["cycle_ns"], 60'000'000) << link->dump(2);
  EXPECT_EQ((*link)["push"]["active"], false) << link->dump(2);
  EXPECT_GT((*link)["push"]["not_active_writes"].get<long long>(), 0) << link->dump(2);
  EXPECT_EQ((*link)["delivered"].get<long long>() + (*link)["subscription"]["skipped"].get<long long>(),
            (*link)["received"].get<long long>())
      << link->dump(2);
}

}  // namespace
}  // namespace polyport::test
