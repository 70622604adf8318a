// The cost of one in-process connection: DataOutPort::write (stamp, deliver, hand-off into
// the policy's buffer or a push sink) plus DataInPort::read on the same thread, for each
// queue policy and for 16 B, 64 B and 1 KiB samples (items_per_second: samples per second on
// one core); and the added cost of the connection
// policies (watchdog, rate limit, deadband, an event's condition, push newest and push timed
// servers) over a plain connection.
//
// Two views of the same thing, both reported by Google Benchmark's JSON output:
//  - per repetition, the mean ns of one write+read (median and p99 over 50 repetitions:
//    the aggregates `_median` and `_p99`);
//  - per sample, the connection's own t_out - t_in histogram (counters conn_p50_ns,
//    conn_p99_ns), which includes one clock read.
// Run: ./scripts/bench.sh (writes benchmarks/results/inproc_connection-<date>.json).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <array>
#include <cstdlib>
#include <cstring>
#include <vector>

#include "polyport/runtime/component.hpp"
#include "polyport/runtime/connection.hpp"
#include "polyport/runtime/echo_table.hpp"
#include "polyport/runtime/push_server.hpp"
#include "polyport/runtime/watchdog.hpp"

namespace {

using namespace polyport;

class NullSink final : public SampleSink {
 public:
  Status on_sample(const std::byte* data, const SampleMeta&) noexcept override {
    benchmark::DoNotOptimize(data);
    return Status::ok;
  }
};

enum class Mode { data, buffer, circular, push };

void BM_InprocConnection(benchmark::State& state) {
  const auto mode = static_cast<Mode>(state.range(0));
  const auto bytes = static_cast<std::uint32_t>(state.range(1));
  Component a{"A", "inproc"};
  Component b{"B", "inproc"};
  auto& out = a.add_port<DataOutPort>("out", PortKind::data, nullptr, bytes);
  const QueuePolicy policy = mode == Mode::buffer     ? QueuePolicy::buffer
                             : mode == Mode::circular ? QueuePolicy::circular
                                                      : QueuePolicy::data;
  auto& in = b.add_port<DataInPort>("in", PortKind::data, nullptr, bytes, policy, 16);
  NullSink sink;
  if (mode == Mode::push) in.set_sink(&sink);
  Connection connection(out, in, policy, 16);
  out.connections().add(connection);
  in.connections().add(connection);
  std::vector<std::byte> sample(bytes, std::byte{1}), received(bytes);

  for (auto _ : state) {
    out.write(sample.data(), bytes);
    if (mode != Mode::push) in.read(received.data(), bytes);
    benchmark::ClobberMemory();
  }
  const auto summary = connection.latency().summarize();
  state.counters["conn_p50_ns"] = static_cast<double>(summary.p50);
  state.counters["conn_p99_ns"] = static_cast<double>(summary.p99);
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations()) * bytes);
  // One sample per iteration, on one thread: items_per_second is the forwarding throughput
  // of one core.
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations()));
  state.SetLabel(mode == Mode::push ? "push" : std::string(to_string(policy)));
}

double p99(const std::vector<double>& v) {
  std::vector<double> sorted(v);
  std::sort(sorted.begin(), sorted.end());
  return sorted[static_cast<std::size_t>(0.99 * static_cast<double>(sorted.size() - 1))];
}

// The added cost of a connection's policies (issue: each at most 50 ns at the median over the
// plain connection, same run): the same 16 B write (+ read in pull mode) with and without
// each policy, each letting every sample through, as in a running loop:
//  - watchdog: armed and fresh (push mode: with an upstream port that writes; two clock
//    comparisons and the sink's hand-over flag);
//  - rate_limit: a 1 ns interval, so every sample's turn has come (one comparison and the
//    hand-over flag);
//  - deadband: one double field that moves by more than its threshold every sample.
// Run with --benchmark_enable_random_interleaving=true so that the cases share the machine's
// moods (scripts/bench.sh does).
//  - push_newest: the source is a push newest server (keeps each sample as the latest);
//  - push_timed: the source is a push timed server, the connection a subscription of every
//    cycle (every sample counted on the forwarding path, none skipped).
enum class Policy { plain, watchdog, rate_limit, deadband, condition, push_newest, push_timed };

const char* policy_name(Policy policy) {
  switch (policy) {
    case Policy::plain: return "plain";
    case Policy::watchdog: return "watchdog";
    case Policy::rate_limit: return "rate_limit";
    case Policy::deadband: return "deadband";
    case Policy::condition: return "condition";
    case Policy::push_newest: return "push_newest";
    case Policy::push_timed: return "push_timed";
  }
  return "?";
}

void BM_ConnectionPolicy(benchmark::State& state) {
  const bool push = state.range(0) != 0;
  const auto policy = static_cast<Policy>(state.range(1));
  constexpr std::uint32_t kBytes = 16;
  Component a{"A", "inproc"};
  Component b{"B", "inproc"};
  Component up{"Up", "inproc"};
  auto& out = a.add_port<DataOutPort>("out", PortKind::data, nullptr, kBytes);
  auto& upstream = up.add_port<DataOutPort>("out", PortKind::data, nullptr, kBytes);
  auto& in = b.add_port<DataInPort>("in", PortKind::data, nullptr, kBytes, QueuePolicy::data, 1);
  NullSink sink;
  if (push) in.set_sink(&sink);
  Connection connection(out, in, QueuePolicy::data, 1);
  switch (policy) {
    case Policy::plain: break;
    case Policy::watchdog:
      connection.set_watchdog(std::make_unique<ConnectionWatchdog>(out, push ? &upstream : nullptr,
                                                                   Nanos{3'600'000'000'000}, Nanos{},
                                                                   std::vector<std::byte>(kBytes)));
      break;
    case Policy::rate_limit: connection.set_rate_limit(Nanos{1}); break;
    case Policy::deadband:
      connection.set_deadbands({DeadbandField{0, TypeKind::float64, 0.5, "x"}});
      break;
    case Policy::condition:  // an event with a condition that holds for every sample
      connection.set_condition(std::make_unique<EventCondition>(
          std::vector<ConditionField>{{0, TypeKind::float64, ConditionOp::gt, 0.0, "level", "x"}}, EventMode::continuous,
          true));
      break;
    case Policy::push_newest:
      out.set_push(std::make_unique<PushServer>(out, PushPattern::newest, Nanos{0}));
      break;
    case Policy::push_timed:
      out.set_push(std::make_unique<PushServer>(out, PushPattern::timed, Nanos{10'000'000}));
      connection.set_subscription(1);
      break;
  }
  out.connections().add(connection);
  in.connections().add(connection);
  std::vector<std::byte> sample(kBytes, std::byte{0}), received(kBytes);
  upstream.write(sample.data(), kBytes);

  double x = 0.0;
  for (auto _ : state) {
    x += 1.0;  // moves past the deadband every sample
    std::memcpy(sample.data(), &x, sizeof x);
    out.write(sample.data(), kBytes);
    if (!push) in.read(received.data(), kBytes);
    benchmark::ClobberMemory();
  }
  const ConnectionCounters& k = connection.counters();
  if (k.dropped() != 0 || k.delivered.load() != k.received.load()) state.SkipWithError("the policy held samples back");
  if (const ConnectionWatchdog* watchdog = connection.watchdog()) {
    if (watchdog->counters().safe_values.load() != 0) state.SkipWithError("the watchdog replaced samples");
  }
  const auto summary = connection.latency().summarize();
  state.counters["conn_p50_ns"] = static_cast<double>(summary.p50);
  state.counters["conn_p99_ns"] = static_cast<double>(summary.p99);
  state.SetLabel(std::string(push ? "push " : "pull ") + policy_name(policy));
}

BENCHMARK(BM_ConnectionPolicy)
    ->ArgNames({"push", "policy"})
    ->ArgsProduct({{0, 1},
                   {static_cast<int>(Policy::plain), static_cast<int>(Policy::watchdog),
                    static_cast<int>(Policy::rate_limit), static_cast<int>(Policy::deadband),
                    static_cast<int>(Policy::condition), static_cast<int>(Policy::push_newest),
                    static_cast<int>(Policy::push_timed)}})
    ->Repetitions(50)
    ->ComputeStatistics("p99", p99)
    ->ReportAggregatesOnly(true);

// Loop prevention's cost per message on the LCM and CAN paths (EchoTable): `own` = 0, a
// foreign 16-byte message checked on receive (fingerprint, a miss in the table); `own` = 1, a
// message polyport publishes on a channel it also reads (fingerprint and record on the send
// side, fingerprint and drop of the echo on the receive side). The paths already hold a clock
// stamp, passed in; Cyclone DDS needs no check (it never delivers polyport's own samples),
// Fast DDS compares the sample's writer GUID with a few slots.
void BM_LoopPrevention(benchmark::State& state) {
  const bool own = state.range(0) != 0;
  EchoTable table;
  std::array<std::uint8_t, 16> message{};
  const MonoTime now = mono_now();
  std::uint64_t n = 0, dropped = 0;
  for (auto _ : state) {
    ++n;
    std::memcpy(message.data(), &n, sizeof n);  // a new message each time
    if (own) table.expect(message_fingerprint(message.data(), message.size()), 1, now);
    dropped += table.consume(message_fingerprint(message.data(), message.size()), now) ? 1 : 0;
    benchmark::DoNotOptimize(dropped);
  }
  if (dropped != (own ? n : 0)) state.SkipWithError("an echo was missed or a foreign message dropped");
  state.SetLabel(own ? "own message: recorded, echo dropped" : "foreign message checked");
}

BENCHMARK(BM_LoopPrevention)->ArgName("own")->Arg(0)->Arg(1)->Repetitions(50)->ComputeStatistics("p99", p99)->ReportAggregatesOnly(true);

BENCHMARK(BM_InprocConnection)
    ->ArgNames({"mode", "bytes"})
    ->ArgsProduct({{static_cast<int>(Mode::data), static_cast<int>(Mode::buffer), static_cast<int>(Mode::circular),
                    static_cast<int>(Mode::push)},
                   {16, 64, 1024}})
    ->Repetitions(50)
    ->ComputeStatistics("p99", p99)
    ->ReportAggregatesOnly(true);

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (const char* revision = std::getenv("POLYPORT_GIT_REVISION")) benchmark::AddCustomContext("git_revision", revision);
  benchmark::AddCustomContext("benchmark", "in-process connection: write + read, same thread");
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
