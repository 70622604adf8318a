// The Prometheus renderer (daemon/metrics.cpp) on hand-made statistics: HELP and TYPE lines,
// label escaping, cumulative buckets at exact engine bucket tops, +Inf == _count, counters by
// drop reason, state gauges. The output of a running daemon is checked with the Python
// client's parser in metrics_daemon_test.cpp.
#include <gtest/gtest.h>

#include <map>
#include <sstream>

#include "metrics.hpp"
#include "polyport/runtime/histogram.hpp"

namespace polyport::daemon {
namespace {

using Json = nlohmann::json;

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> out;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) out.push_back(line);
  return out;
}

// The lines that start with `prefix`, in order.
std::vector<std::string> starting(const std::string& text, const std::string& prefix) {
  std::vector<std::string> out;
  for (const std::string& line : lines_of(text)) {
    if (line.rfind(prefix, 0) == 0) out.push_back(line);
  }
  return out;
}

// A histogram summary as engine.cpp writes it, with buckets as add_histogram_buckets adds
// them: from real LatencyHistogram records.
Json histogram_of(const std::vector<std::int64_t>& values_ns) {
  LatencyHistogram h;
  for (const std::int64_t v : values_ns) h.record(v);
  const LatencyHistogram::Summary s = h.summarize();
  Json j{{"count", s.count}, {"mean", s.mean}, {"p50", s.p50}, {"max", s.max}};
  j["buckets"] = Json::array();
  for (const auto& [top, n] : h.buckets()) j["buckets"].push_back({top, n});
  return j;
}

Json stats_with(const Json& connection) {
  return Json{{"application", "app"},
              {"polyport_version", "0.1.0"},
              {"components", Json::array()},
              {"connections", Json::array({connection})},
              {"execution_contexts", Json::array()}};
}

TEST(MetricsRender, BoundsAreExactEngineBucketTopsInAscendingOrder) {
  const auto& bounds = histogram_bounds_ns();
  ASSERT_FALSE(bounds.empty());
  for (std::size_t i = 0; i < bounds.size(); ++i) {
    const int index = LatencyHistogram::bucket_index(bounds[i]);
    EXPECT_EQ(LatencyHistogram::bucket_upper(index), bounds[i]) << "bound " << bounds[i] << " is inside a bucket";
    if (i > 0) {
      EXPECT_LT(bounds[i - 1], bounds[i]);
    }
  }
  EXPECT_LE(bounds.front(), 100);
  EXPECT_GT(bounds.back(), 9'000'000'000);
  EXPECT_LE(bounds.back(), 10'000'000'000);
}

TEST(MetricsRender, EveryFamilyHasOneHelpAndOneTypeLineBeforeItsSamples) {
  Json stats = stats_with({{"name", "A.out -> B.in"},
                           {"received", 5},
                           {"delivered", 4},
                           {"dropped_by_reason", {{"queue_full", 1}, {"sink_error", 0}}},
                           {"latency_ns", histogram_of({1000, 2000})}});
  stats["components"] = Json::array({{{"name", "A"}, {"model", "inproc"}, {"state", "active"}, {"executions", 7}, {"errors", 0}}});
  stats["execution_contexts"] = Json::array(
      {{{"name", "ctx"}, {"cycles", 9}, {"overruns", 2}, {"wake_jitter_ns", histogram_of({50'000})}}});
  const std::string text = render_prometheus(stats);
  std::map<std::string, int> helps, types;
  std::string current;
  for (const std::string& line : lines_of(text)) {
    ASSERT_FALSE(line.empty());
    std::istringstream words(line);
    std::string first, second, name;
    words >> first;
    if (first == "#") {
      words >> second >> name;
      ASSERT_TRUE(second == "HELP" || second == "TYPE") << line;
      (second == "HELP" ? helps : types)[name]++;
      if (second == "HELP") {
        EXPECT_EQ(types.count(name), 0u) << "HELP after TYPE: " << line;
      }
      current = name;
      continue;
    }
    // A sample belongs to the family announced last (a histogram's with its suffixes).
    const std::string sample = first.substr(0, first.find('{'));
    EXPECT_EQ(sample.rfind(current, 0), 0u) << line << " outside its family " << current;
    EXPECT_EQ(sample.rfind("polyport_", 0), 0u) << line;
  }
  for (const auto& [name, n] : helps) EXPECT_EQ(n, 1) << name;
  for (const auto& [name, n] : types) EXPECT_EQ(n, 1) << name;
  EXPECT_EQ(starting(text, "# TYPE polyport_connection_latency_seconds ")[0],
            "# TYPE polyport_connection_latency_seconds histogram");
  EXPECT_EQ(starting(text, "# TYPE polyport_connection_received_total ")[0],
            "# TYPE polyport_connection_received_total counter");
  EXPECT_EQ(starting(text, "# TYPE polyport_component_state ")[0], "# TYPE polyport_component_state gauge");
  EXPECT_EQ(starting(text, "# TYPE polyport_execution_context_wake_jitter_seconds ")[0],
            "# TYPE polyport_execution_context_wake_jitter_seconds histogram");
  EXPECT_EQ(starting(text, "polyport_execution_context_overruns_total{")[0],
            "polyport_execution_context_overruns_total{execution_context=\"ctx\"} 2");
  EXPECT_EQ(starting(text, "polyport_component_executions_total{")[0],
            "polyport_component_executions_total{component=\"A\",model=\"inproc\"} 7");
  EXPECT_EQ(starting(text, "polyport_connection_dropped_total{")[0],
            "polyport_connection_dropped_total{connection=\"A.out -> B.in\",reason=\"queue_full\"} 1");
}

TEST(MetricsRender, LabelValuesEscapeBackslashQuoteAndLineFeed) {
  EXPECT_EQ(escape_label_value("plain"), "plain");
  EXPECT_EQ(escape_label_value("a\\b\"c\nd"), "a\\\\b\\\"c\\nd");
  const Json stats = stats_with({{"name", "odd \"name\"\\\n"}, {"received", 1}, {"delivered", 1},
                                 {"latency_ns", histogram_of({10})}});
  const auto received = starting(render_prometheus(stats), "polyport_connection_received_total{");
  ASSERT_EQ(received.size(), 1u);
  EXPECT_EQ(received[0], "polyport_connection_received_total{connection=\"odd \\\"name\\\"\\\\\\n\"} 1");
}

TEST(MetricsRender, BucketsAreCumulativeAndInfEqualsCount) {
  // 3 samples at 1 us or below, 2 at 3 ms, 1 at 20 s (beyond the last bound).
  const Json h = histogram_of({200, 900, 990, 3'000'000, 3'000'000, 20'000'000'000});
  const std::string text = render_prometheus(stats_with({{"name", "c"}, {"latency_ns", h}}));
  const auto buckets = starting(text, "polyport_connection_latency_seconds_bucket{");
  ASSERT_EQ(buckets.size(), histogram_bounds_ns().size() + 1);
  std::uint64_t previous = 0;
  for (std::size_t i = 0; i < buckets.size(); ++i) {
    const std::string& line = buckets[i];
    const std::uint64_t value = std::stoull(line.substr(line.rfind(' ') + 1));
    EXPECT_GE(value, previous) << line;
    previous = value;
    // Each bound counts exactly the values at or below it.
    if (i < histogram_bounds_ns().size()) {
      const std::int64_t bound = histogram_bounds_ns()[i];
      std::uint64_t expected = 0;
      for (const std::int64_t v : {200LL, 900LL, 990LL, 3'000'000LL, 3'000'000LL, 20'000'000'000LL}) expected += v <= bound;
      EXPECT_EQ(value, expected) << line;
    }
  }
  EXPECT_EQ(buckets.back(), "polyport_connection_latency_seconds_bucket{connection=\"c\",le=\"+Inf\"} 6");
  EXPECT_EQ(starting(text, "polyport_connection_latency_seconds_count{")[0],
            "polyport_connection_latency_seconds_count{connection=\"c\"} 6");
  // The sum in seconds: the engine's mean times the count.
  const std::string sum = starting(text, "polyport_connection_latency_seconds_sum{")[0];
  EXPECT_NEAR(std::stod(sum.substr(sum.rfind(' ') + 1)), h["mean"].get<double>() * 6 / 1e9, 1e-9);
  // Each le reads back as its bound in seconds.
  for (std::size_t i = 0; i < histogram_bounds_ns().size(); ++i) {
    const std::string le = buckets[i].substr(buckets[i].find("le=\"") + 4);
    EXPECT_EQ(std::stod(le.substr(0, le.find('"'))), static_cast<double>(histogram_bounds_ns()[i]) / 1e9) << buckets[i];
  }
}

TEST(MetricsRender, HistogramWithoutBucketsHasOnlyInf) {
  const Json stats = stats_with({{"name", "c"}, {"latency_ns", {{"count", 3}, {"mean", 1000.0}}}});
  const std::string text = render_prometheus(stats);
  const auto buckets = starting(text, "polyport_connection_latency_seconds_bucket{");
  ASSERT_EQ(buckets.size(), 1u);
  EXPECT_EQ(buckets[0], "polyport_connection_latency_seconds_bucket{connection=\"c\",le=\"+Inf\"} 3");
}

TEST(MetricsRender, OneStateGaugeAtOnePerComponent) {
  Json stats = stats_with({{"name", "c"}, {"latency_ns", Json::object()}});
  stats["components"] = Json::array({{{"name", "A"}, {"model", "lcm"}, {"state", "inactive"}},
                                     {{"name", "B"}, {"model", "inproc"}, {"state", "degraded"}}});
  const auto states = starting(render_prometheus(stats), "polyport_component_state{");
  std::map<std::string, std::vector<std::string>> at_one;
  for (const std::string& line : states) {
    if (line.substr(line.rfind(' ') + 1) != "1") continue;
    const auto component = line.substr(line.find("component=\"") + 11);
    const auto state = line.substr(line.find("state=\"") + 7);
    at_one[component.substr(0, component.find('"'))].push_back(state.substr(0, state.find('"')));
  }
  EXPECT_EQ(at_one["A"], std::vector<std::string>{"inactive"});
  EXPECT_EQ(at_one["B"], std::vector<std::string>{"degraded"});  // a state beyond the lifecycle's
  EXPECT_EQ(states.size(), 5u + 6u);  // every lifecycle state for both, and B's own
}

TEST(MetricsRender, RemovedConnectionsAndWatchdogs) {
  Json removed{{"name", "gone"}, {"removed", true}, {"received", 1}, {"latency_ns", Json::object()}};
  Json watched{{"name", "w"},
               {"received", 1},
               {"latency_ns", Json::object()},
               {"watchdog", {{"state", "tripped"}, {"trips", 3}, {"recoveries", 2}, {"safe_values", 40}}}};
  Json stats = stats_with(watched);
  stats["connections"].push_back(removed);
  const std::string text = render_prometheus(stats);
  EXPECT_EQ(text.find("\"gone\""), std::string::npos) << "a removed connection is left out";
  EXPECT_EQ(starting(text, "polyport_watchdog_trips_total{")[0], "polyport_watchdog_trips_total{connection=\"w\"} 3");
  EXPECT_EQ(starting(text, "polyport_watchdog_state{connection=\"w\",state=\"tripped\"}")[0],
            "polyport_watchdog_state{connection=\"w\",state=\"tripped\"} 1");
}

TEST(MetricsRender, ConditionPushSubscriptionAndServiceCounters) {
  Json conditioned{{"name", "c"},
                   {"received", 9},
                   {"latency_ns", Json::object()},
                   {"condition", {{"active", true}, {"fired", 4}, {"suppressed", 3}, {"inactive", 2}, {"activations", 1}}},
                   {"push", {{"active", false}, {"primed", 6}, {"not_active_writes", 5}}},
                   {"subscription", {{"subscribed", true}, {"skipped", 7}}}};
  Json stats = stats_with(conditioned);
  stats["services"] = Json::array({{{"name", "A.svc -> B.svc"},
                                    {"calls", 21},
                                    {"ok", 10},
                                    {"timeouts", 1},
                                    {"errors", 2},
                                    {"not_connected", 3},
                                    {"too_many_calls", 4},
                                    {"cancelled", 1},
                                    {"provider_rejected", 8},
                                    {"latency_ns", histogram_of({3000, 4000})}}});
  const std::string text = render_prometheus(stats);
  EXPECT_EQ(starting(text, "polyport_condition_events_total{"),
            (std::vector<std::string>{"polyport_condition_events_total{connection=\"c\",outcome=\"fired\"} 4",
                                      "polyport_condition_events_total{connection=\"c\",outcome=\"suppressed\"} 3",
                                      "polyport_condition_events_total{connection=\"c\",outcome=\"inactive\"} 2"}));
  EXPECT_EQ(starting(text, "polyport_condition_active{")[0], "polyport_condition_active{connection=\"c\"} 1");
  EXPECT_EQ(starting(text, "polyport_condition_activations_total{")[0],
            "polyport_condition_activations_total{connection=\"c\"} 1");
  EXPECT_EQ(starting(text, "polyport_push_active{")[0], "polyport_push_active{connection=\"c\"} 0");
  EXPECT_EQ(starting(text, "polyport_push_primed_total{")[0], "polyport_push_primed_total{connection=\"c\"} 6");
  EXPECT_EQ(starting(text, "polyport_push_not_active_writes_total{")[0],
            "polyport_push_not_active_writes_total{connection=\"c\"} 5");
  EXPECT_EQ(starting(text, "polyport_subscription_subscribed{")[0], "polyport_subscription_subscribed{connection=\"c\"} 1");
  EXPECT_EQ(starting(text, "polyport_subscription_skipped_total{")[0],
            "polyport_subscription_skipped_total{connection=\"c\"} 7");
  const std::vector<std::string> calls = starting(text, "polyport_service_calls_total{");
  ASSERT_EQ(calls.size(), 6u);
  EXPECT_EQ(calls[0], "polyport_service_calls_total{service=\"A.svc -> B.svc\",outcome=\"ok\"} 10");
  EXPECT_EQ(calls[5], "polyport_service_calls_total{service=\"A.svc -> B.svc\",outcome=\"cancelled\"} 1");
  EXPECT_EQ(starting(text, "polyport_service_provider_rejected_total{")[0],
            "polyport_service_provider_rejected_total{service=\"A.svc -> B.svc\"} 8");
  EXPECT_EQ(starting(text, "polyport_service_latency_seconds_count{")[0],
            "polyport_service_latency_seconds_count{service=\"A.svc -> B.svc\"} 2");
  // A plain connection has none of them.
  const std::string plain = render_prometheus(stats_with({{"name", "p"}, {"received", 1}, {"latency_ns", Json::object()}}));
  EXPECT_EQ(plain.find("polyport_condition_"), std::string::npos);
  EXPECT_EQ(plain.find("polyport_push_"), std::string::npos);
  EXPECT_EQ(plain.find("polyport_service_"), std::string::npos);
}

}  // namespace
}  // namespace polyport::daemon
