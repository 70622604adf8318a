// The cost of a converting connection: one sample of a 64-byte struct (eight doubles)
// written on a source port in one wire format and handed to a push sink in another,
// through Connection::deliver: decode + map + encode. Cases:
//   cdr_to_lcm  XCDR1 (DDS) -> flat -> by-name mapping -> LCM
//   dbc_to_cdr  CAN frame (DBC) -> flat -> by-name mapping -> XCDR1
//   cdr_to_cdr  same format and type: passthrough (the floor)
// Median and p99 over 50 repetitions (Google Benchmark aggregates), plus the connection's
// own per-sample t_out - t_in histogram (conn_p50_ns, conn_p99_ns).
// Run: ./scripts/bench.sh (writes benchmarks/results/*.json).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cstdlib>
#include <stdexcept>
#include <vector>

#include "polyport/codecs/codec.hpp"
#include "polyport/runtime/component.hpp"
#include "polyport/runtime/connection.hpp"
#include "polyport/codecs/mapping.hpp"
#include "polyport/types/types.hpp"

namespace {

using namespace polyport;

class NullSink final : public SampleSink {
 public:
  Status on_sample(const std::byte* data, const SampleMeta&) noexcept override {
    benchmark::DoNotOptimize(data);
    return Status::ok;
  }
};

struct Formats {
  TypeRegistry types;
  const Type* idl = nullptr;
  const Type* lcm = nullptr;
  const Type* dbc = nullptr;
  Formats() {
    Diagnostics d;
    types.add_type_file(POLYPORT_BENCH_TYPES "/bench.idl", d);
    types.add_type_file(POLYPORT_BENCH_TYPES "/bench.lcm", d);
    types.add_type_file(POLYPORT_BENCH_TYPES "/bench.dbc", d);
    idl = types.find("bench::Wheel64");
    lcm = types.find("bench::wheel64_t");
    for (const Type* t : types.declared()) {
      if (t->origin == TypeOrigin::dbc && t->name.ends_with("::Wheel64Frame")) dbc = t;
    }
    if (!idl || !lcm || !dbc) {
      std::string problems;
      for (const auto& p : d.all()) problems += p.to_string() + "\n";
      throw std::runtime_error("benchmark types did not load\n" + problems);
    }
  }
};

Formats& formats() {
  static Formats f;
  return f;
}

std::unique_ptr<Codec> codec(WireFormat format, const Type& type) {
  auto made = make_codec(format, type);
  if (!made) throw std::runtime_error(made.error().message);
  return std::move(made).value();
}

// A sample in the source's wire format, made by encoding flat values with its codec.
std::vector<std::byte> wire_sample(const Codec& source) {
  const double values[8] = {12.5, 12.0, 3.25, 3.5, 18.0, 18.125, 40.0, 24.2};
  std::vector<std::byte> wire(source.max_wire_size(sizeof values));
  const CodecResult r = source.encode(reinterpret_cast<const std::byte*>(values), sizeof values, wire.data(),
                                      static_cast<std::uint32_t>(wire.size()));
  if (!r.ok()) throw std::runtime_error("encode failed: " + std::string(to_string(r.error)));
  wire.resize(r.size);
  return wire;
}

void run_case(benchmark::State& state, WireFormat from_format, const Type& from, WireFormat to_format, const Type& to) {
  auto source_codec = codec(from_format, from);
  auto target_codec = codec(to_format, to);
  std::unique_ptr<MappingProgram> mapping;
  if (&from != &to) {
    Diagnostics d;
    mapping = MappingProgram::compile(from, to, MappingSpec{}, d);
    if (!mapping) throw std::runtime_error("mapping did not compile");
  }
  Component a{"A", "src"};
  Component b{"B", "dst"};
  const std::uint32_t room = 512;
  auto& out = a.add_port<DataOutPort>("out", PortKind::data, &from, room);
  auto& in = b.add_port<DataInPort>("in", PortKind::data, &to, room, QueuePolicy::data, 1);
  out.set_wire_format(from_format, source_codec.get());
  in.set_wire_format(to_format, target_codec.get());
  NullSink sink;
  in.set_sink(&sink);
  Connection connection(out, in, QueuePolicy::data, 1, mapping.get());
  out.connections().add(connection);
  in.connections().add(connection);
  const std::vector<std::byte> sample = wire_sample(*source_codec);

  for (auto _ : state) {
    out.write(sample.data(), static_cast<std::uint32_t>(sample.size()));
    benchmark::ClobberMemory();
  }
  if (connection.counters().dropped() != 0) state.SkipWithError("samples were dropped");
  const auto summary = connection.latency().summarize();
  state.counters["conn_p50_ns"] = static_cast<double>(summary.p50);
  state.counters["conn_p99_ns"] = static_cast<double>(summary.p99);
  state.SetLabel(connection.conversion());
}

void BM_cdr_to_lcm(benchmark::State& s) {
  run_case(s, WireFormat::xcdr1, *formats().idl, WireFormat::lcm, *formats().lcm);
}
void BM_dbc_to_cdr(benchmark::State& s) {
  run_case(s, WireFormat::dbc, *formats().dbc, WireFormat::xcdr1, *formats().idl);
}
void BM_cdr_to_cdr_passthrough(benchmark::State& s) {
  run_case(s, WireFormat::xcdr1, *formats().idl, WireFormat::xcdr1, *formats().idl);
}

double p99(const std::vector<double>& v) {
  std::vector<double> sorted(v);
  std::sort(sorted.begin(), sorted.end());
  return sorted[static_cast<std::size_t>(0.99 * static_cast<double>(sorted.size() - 1))];
}

BENCHMARK(BM_cdr_to_lcm)->Repetitions(50)->ComputeStatistics("p99", p99)->ReportAggregatesOnly(true);
BENCHMARK(BM_dbc_to_cdr)->Repetitions(50)->ComputeStatistics("p99", p99)->ReportAggregatesOnly(true);
BENCHMARK(BM_cdr_to_cdr_passthrough)->Repetitions(50)->ComputeStatistics("p99", p99)->ReportAggregatesOnly(true);

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (const char* revision = std::getenv("POLYPORT_GIT_REVISION")) benchmark::AddCustomContext("git_revision", revision);
  benchmark::AddCustomContext("benchmark", "converting connection: decode + map + encode of a 64-byte struct");
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
