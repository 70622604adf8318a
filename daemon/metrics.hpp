// Live metrics: the engine's statistics (the JSON of `--stats-json` and `polyportctl stats`)
// rendered in the Prometheus text exposition format (version 0.0.4), docs/CONTROL.md.
//
// Threads: add_histogram_buckets() reads the engine and runs on the engine's control thread
// (polyportd's main thread); render_prometheus() is a pure function of its JSON.
#pragma once

#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>
#include <vector>

namespace polyport {
class Engine;
}

namespace polyport::daemon {

// The `le` bounds of every histogram, in nanoseconds: the tops of the engine's histogram
// buckets (LatencyHistogram) at or just below 100 ns, 200 ns, 500 ns, 1 us, ... 10 s, so each
// cumulative count is exact (no engine bucket straddles a bound), and the same at every scrape.
const std::vector<std::int64_t>& histogram_bounds_ns();

// Adds to `stats` (what Engine::stats wrote) the non-empty buckets of each live connection's
// latency and of each execution context's wake jitter, as "buckets": [[top_ns, count], ...]
// next to the summary ("latency_ns", "wake_jitter_ns"). Removed connections have none.
void add_histogram_buckets(const Engine& engine, nlohmann::json& stats);

// The Prometheus text of `stats`: counters by drop reason, component states, latency and
// jitter histograms in seconds (metric names in docs/CONTROL.md). A histogram without
// "buckets" gets only its +Inf bucket. Removed connections are left out.
std::string render_prometheus(const nlohmann::json& stats);

// A label value as the text format quotes it: backslash, double quote and line feed escaped.
std::string escape_label_value(std::string_view value);

}  // namespace polyport::daemon
