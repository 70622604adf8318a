// The cost of a converting connection: one sample of a 64-byte struct (eight doubles)
// written on a source port in one wire format and handed to a push sink in another,
// through Connection::deliver: decode + map + encode. Cases:
//   cdr_to_lcm  XCDR1 (DDS) -> flat -> by-name mapping -> LCM
//   dbc_to_cdr  CAN frame (DBC) -> flat -> by-name mapping -> XCDR1
//   cdr_to_cdr  same format and type: passthrough (the floor)
//   lcm_can     the cross-model matrix's CAN <-> LCM connections (benchmarks/matrix): its
//               ping-pong types (16 B: classic frame, 1 KiB: FD frame), only seq mapped
// Where clock_gettime is a system call (the vcan guest: scripts/vcan-run -- build/bin/bench_conversion)
// the connection's stamps read the TSC clock, as polyportd's do ("clock" in the context).
// Median and p99 over 50 repetitions (Google Benchmark aggregates), plus the connection's
// own per-sample t_out - t_in histogram (conn_p50_ns, conn_p99_ns).
// BM_ColdPath: the wheelchair's DDS -> in-process hop once per iteration with cold caches
// (see there).
// Run: ./scripts/bench.sh (writes benchmarks/results/*.json); the cold path alone:
//   build/bin/bench_conversion --benchmark_filter=ColdPath
#include <benchmark/benchmark.h>

#include <sys/mman.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <functional>
#include <semaphore>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "polyport/base/clock.hpp"
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

// What a case's source sample holds: the Wheel64 types' eight doubles, or the ping-pong
// types' sequence number in the first field (an int64, or a DBC signal's double), rest zero.
enum class Sample { wheel64, seq };

// A sample in the source's wire format, made by encoding flat values with its codec.
std::vector<std::byte> wire_sample(const Codec& source, Sample sample) {
  std::vector<std::byte> flat(source.type().size);
  if (sample == Sample::wheel64) {
    const double values[8] = {12.5, 12.0, 3.25, 3.5, 18.0, 18.125, 40.0, 24.2};
    std::memcpy(flat.data(), values, sizeof values);
  } else if (source.format() == WireFormat::dbc) {
    const double seq = 123456.0;
    std::memcpy(flat.data(), &seq, sizeof seq);
  } else {
    const std::int64_t seq = 123456;
    std::memcpy(flat.data(), &seq, sizeof seq);
  }
  std::vector<std::byte> wire(source.max_wire_size(static_cast<std::uint32_t>(flat.size())));
  const CodecResult r = source.encode(flat.data(), static_cast<std::uint32_t>(flat.size()), wire.data(),
                                      static_cast<std::uint32_t>(wire.size()));
  if (!r.ok()) throw std::runtime_error("encode failed: " + std::string(to_string(r.error)));
  wire.resize(r.size);
  return wire;
}

void run_case(benchmark::State& state, WireFormat from_format, const Type& from, WireFormat to_format, const Type& to,
              Sample sample = Sample::wheel64, const MappingSpec& spec = {}, std::uint32_t room = 512) {
  auto source_codec = codec(from_format, from);
  auto target_codec = codec(to_format, to);
  std::unique_ptr<MappingProgram> mapping;
  if (&from != &to) {
    Diagnostics d;
    mapping = MappingProgram::compile(from, to, spec, d);
    if (!mapping) throw std::runtime_error("mapping did not compile");
  }
  Component a{"A", "src"};
  Component b{"B", "dst"};
  auto& out = a.add_port<DataOutPort>("out", PortKind::data, &from, room);
  auto& in = b.add_port<DataInPort>("in", PortKind::data, &to, room, QueuePolicy::data, 1);
  out.set_wire_format(from_format, source_codec.get());
  in.set_wire_format(to_format, target_codec.get());
  NullSink sink;
  in.set_sink(&sink);
  Connection connection(out, in, QueuePolicy::data, 1, mapping.get());
  out.connections().add(connection);
  in.connections().add(connection);
  const std::vector<std::byte> wire = wire_sample(*source_codec, sample);

  for (auto _ : state) {
    out.write(wire.data(), static_cast<std::uint32_t>(wire.size()));
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
// The cross-model matrix's CAN <-> LCM connections (benchmarks/matrix): bench_lcm::ping16_t
// (seq + 8-byte pad) and the classic Ping frame of pingpong.dbc, ping1k_t (seq + 1016-byte
// pad) and pingpong_fd.dbc's 64-byte FD frame; only seq is mapped, narrowed as there.
struct PingFormats {
  TypeRegistry types;
  const Type* lcm16 = nullptr;
  const Type* lcm1k = nullptr;
  const Type* can8 = nullptr;
  const Type* can64 = nullptr;
  MappingSpec seq_only;
  PingFormats() {
    Diagnostics d;
    types.add_type_file(POLYPORT_BENCH_PINGPONG_LCM, d);
    lcm16 = types.find("bench_lcm::ping16_t");
    lcm1k = types.find("bench_lcm::ping1k_t");
    can8 = dbc_ping(POLYPORT_BENCH_PINGPONG_DBC, d);
    can64 = dbc_ping(POLYPORT_BENCH_PINGPONG_FD_DBC, d);
    if (!lcm16 || !lcm1k || !can8 || !can64) throw std::runtime_error("ping-pong types did not load");
    seq_only.by_name = false;
    MappingRule seq;
    seq.target = "seq";
    seq.source = "seq";
    seq.allow_narrowing = true;
    seq_only.rules.push_back(seq);
  }
  // The Ping message of a DBC file (its types are named after the file).
  const Type* dbc_ping(const char* file, Diagnostics& d) {
    const std::size_t before = types.declared().size();
    types.add_type_file(file, d);
    for (std::size_t i = before; i < types.declared().size(); ++i) {
      const Type* t = types.declared()[i];
      if (t->origin == TypeOrigin::dbc && t->name.ends_with("::Ping")) return t;
    }
    return nullptr;
  }
};

PingFormats& ping_formats() {
  static PingFormats f;
  return f;
}

// Args: the LCM type's size (16 or 1024: a classic or an FD frame on the CAN side) and the
// direction (0: LCM -> CAN, 1: CAN -> LCM).
void BM_lcm_can(benchmark::State& s) {
  auto& f = ping_formats();
  const Type& lcm = s.range(0) == 16 ? *f.lcm16 : *f.lcm1k;
  const Type& can = s.range(0) == 16 ? *f.can8 : *f.can64;
  if (s.range(1) == 0) {
    run_case(s, WireFormat::lcm, lcm, WireFormat::dbc, can, Sample::seq, f.seq_only, 2048);
  } else {
    run_case(s, WireFormat::dbc, can, WireFormat::lcm, lcm, Sample::seq, f.seq_only, 2048);
  }
}

void BM_cdr_to_cdr_passthrough(benchmark::State& s) {
  run_case(s, WireFormat::xcdr1, *formats().idl, WireFormat::xcdr1, *formats().idl);
}

double p99(const std::vector<double>& v) {
  std::vector<double> sorted(v);
  std::sort(sorted.begin(), sorted.end());
  return sorted[static_cast<std::size_t>(0.99 * static_cast<double>(sorted.size() - 1))];
}

// ---- The cold path ---------------------------------------------------------------------
//
// The wheelchair's host_mixed hop (profiles/wheelchair_can_mixed.xml): a Cyclone DDS Joystick
// publishes a wheelchair::Reference every 10 ms; polyport's XCDR1 output port hands it over a
// pull `data` connection (xcdr1 -> flat) to the in-process Control, which reads it on a thread
// of its own. Hot, the hop takes ~100-200 ns; every 10 ms it takes microseconds, because
// between two samples the lines and pages it touches leave the caches and TLBs. This runs the
// same objects (ports, codec, connection, triple buffer) once per iteration, after one of:
//   hot     nothing: back to back (the reader takes each sample on the same thread)
//   sleep   10 ms asleep, as between two real samples (the CPU idles or runs others)
//   evict   a walk over 3x the last-level cache in 4 KiB pages: caches and TLBs cold
//   tlb     one line in each of 8192 pages, all at one page offset: the data TLB cold, few
//           cache lines gone (tells pages from lines)
//   lines   a walk over 3x the last-level cache in 2 MiB pages (where THP is `madvise` or
//           `always`): caches cold, few TLB entries gone
// In every mode but hot, a reader thread takes the sample after each iteration (as Control
// does), so the triple buffer's shared line moves between CPUs as in the daemon; and the wire
// sample is read just before the write, as the DDS reader has just copied it in.
// Stages, what is timed:
//   path    DataOutPort::write: the connection's own t_out - t_in histogram (conn_mean_ns,
//           conn_p50_ns, conn_p99_ns: polyport's share as polyportd reports it) and the write
//           as seen from outside, both clock reads included (p50_ns, p99_ns, mean_ns)
//   clock   two clock reads in a row (the clock's own cold cost)
//   decode  the XCDR1 codec's decode of the sample alone, into a scratch of the benchmark's
//   push    a triple buffer's push of the flat sample alone (a buffer of the benchmark's)
// p50_ns, p99_ns and mean_ns are exact, over the iterations (default 300; environment
// POLYPORT_COLD_ITERATIONS). Objects are allocated here in one go, so they lie closer together
// than in a daemon that loaded a whole profile: if anything, this understates the cold cost.
enum class Cold { hot, sleep, evict, tlb, lines };
enum class Stage { path, clock, decode, push };

const char* cold_name(Cold cold) {
  switch (cold) {
    case Cold::hot: return "hot";
    case Cold::sleep: return "sleep";
    case Cold::evict: return "evict";
    case Cold::tlb: return "tlb";
    case Cold::lines: return "lines";
  }
  return "?";
}

const char* stage_name(Stage stage) {
  switch (stage) {
    case Stage::path: return "path";
    case Stage::clock: return "clock";
    case Stage::decode: return "decode";
    case Stage::push: return "push";
  }
  return "?";
}

std::size_t last_level_cache_bytes() {
  std::ifstream f("/sys/devices/system/cpu/cpu0/cache/index3/size");
  std::string text;
  if (f >> text && !text.empty()) {
    std::size_t n = std::strtoull(text.c_str(), nullptr, 10);
    if (text.back() == 'K') n <<= 10;
    if (text.back() == 'M') n <<= 20;
    if (n != 0) return n;
  }
  return std::size_t{32} << 20;
}

// Memory to walk, mapped and touched once at start-up.
class Evictor {
 public:
  static constexpr std::size_t kPage = 4096;
  static constexpr std::size_t kHuge = std::size_t{2} << 20;
  static constexpr std::size_t kTlbPages = 8192;

  Evictor() : bytes_(3 * last_level_cache_bytes()) {
    small_ = map(bytes_, false);
    huge_ = map(bytes_, true);
    tlb_ = map(kTlbPages * kPage, false);
  }
  ~Evictor() {
    munmap(small_.base, small_.size);
    munmap(huge_.base, huge_.size);
    munmap(tlb_.base, tlb_.size);
  }
  Evictor(const Evictor&) = delete;
  Evictor& operator=(const Evictor&) = delete;

  void run(Cold cold) {
    switch (cold) {
      case Cold::hot: break;
      case Cold::sleep: std::this_thread::sleep_for(std::chrono::milliseconds(10)); break;
      case Cold::evict: walk(small_.data, bytes_, 64); break;
      case Cold::tlb: walk(tlb_.data, kTlbPages * kPage, kPage); break;
      case Cold::lines: walk(huge_.data, bytes_, 64); break;
    }
  }

 private:
  struct Mapping {
    void* base = nullptr;
    std::size_t size = 0;
    std::byte* data = nullptr;
  };
  static Mapping map(std::size_t bytes, bool huge) {
    Mapping m;
    m.size = bytes + (huge ? kHuge : 0);
    m.base = mmap(nullptr, m.size, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    if (m.base == MAP_FAILED) throw std::runtime_error("mmap failed");
    const auto addr = reinterpret_cast<std::uintptr_t>(m.base);
    m.data = static_cast<std::byte*>(m.base) + (huge ? (kHuge - addr % kHuge) % kHuge : 0);
    madvise(m.data, bytes, huge ? MADV_HUGEPAGE : MADV_NOHUGEPAGE);
    std::memset(m.data, 1, bytes);
    return m;
  }
  void walk(const std::byte* p, std::size_t n, std::size_t step) {
    std::uint64_t sum = 0;
    for (std::size_t i = 0; i < n; i += step) sum += static_cast<std::uint64_t>(p[i]);
    benchmark::DoNotOptimize(sum);
  }
  std::size_t bytes_;
  Mapping small_, huge_, tlb_;
};

Evictor& evictor() {
  static Evictor e;
  return e;
}

// The hop's objects, as the profile makes them: Joystick's XCDR1 output port with its codec,
// Control's flat input port, a pull `data` connection between them.
struct WheelchairHop {
  TypeRegistry types;
  const Type* reference = nullptr;
  std::unique_ptr<Codec> codec;
  Component joystick{"Joystick", "cyclonedds"};
  Component control{"Control", "inproc"};
  DataOutPort* out = nullptr;
  DataInPort* in = nullptr;
  std::unique_ptr<Connection> connection;
  std::vector<std::byte> wire;

  WheelchairHop() {
    Diagnostics d;
    types.add_type_file(POLYPORT_CONFIG_TYPES "/wheelchair.idl", d);
    reference = types.find("wheelchair::Reference");
    if (!reference) throw std::runtime_error("wheelchair::Reference did not load");
    auto made = make_codec(WireFormat::xcdr1, *reference);
    if (!made) throw std::runtime_error(made.error().message);
    codec = std::move(made).value();
    out = &joystick.add_port<DataOutPort>("reference", PortKind::data, reference,
                                          codec->max_wire_size(reference->size + (64U << 10)));
    out->set_wire_format(WireFormat::xcdr1, codec.get());
    in = &control.add_port<DataInPort>("reference", PortKind::data, reference, reference->size, QueuePolicy::data, 1);
    connection = std::make_unique<Connection>(*out, *in, QueuePolicy::data, 1);
    out->connections().add(*connection);
    in->connections().add(*connection);
    const double values[2] = {12.5, 0.8};
    wire.resize(codec->max_wire_size(sizeof values));
    const CodecResult r = codec->encode(reinterpret_cast<const std::byte*>(values), sizeof values, wire.data(),
                                        static_cast<std::uint32_t>(wire.size()));
    if (!r.ok()) throw std::runtime_error("encode failed");
    wire.resize(r.size);
  }
};

// Takes samples on a thread of its own when asked, as Control's execution context does.
class Reader {
 public:
  explicit Reader(std::function<void()> take) : take_(std::move(take)), thread_([this] { run(); }) {}
  ~Reader() {
    stop_ = true;
    go_.release();
    thread_.join();
  }
  Reader(const Reader&) = delete;
  Reader& operator=(const Reader&) = delete;
  void take_now() {
    go_.release();
    done_.acquire();
  }

 private:
  void run() {
    for (;;) {
      go_.acquire();
      if (stop_) return;
      take_();
      done_.release();
    }
  }
  std::function<void()> take_;
  std::binary_semaphore go_{0};
  std::binary_semaphore done_{0};
  bool stop_ = false;
  std::thread thread_;
};

double exact_percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[static_cast<std::size_t>(p / 100.0 * static_cast<double>(v.size() - 1))];
}

void BM_ColdPath(benchmark::State& state) {
  const auto cold = static_cast<Cold>(state.range(0));
  const auto stage = static_cast<Stage>(state.range(1));
  Evictor& evict = evictor();
  WheelchairHop hop;
  const auto wire_size = static_cast<std::uint32_t>(hop.wire.size());
  std::vector<std::byte> flat(hop.reference->size + 64);
  std::vector<std::byte> taken(hop.reference->size);
  LatestValueBuffer buffer(hop.reference->size);
  std::vector<std::byte> decoded(hop.reference->size);
  (void)hop.codec->decode(hop.wire.data(), wire_size, decoded.data(), static_cast<std::uint32_t>(decoded.size()));
  const auto take = [&] {
    SampleMeta meta;
    if (stage == Stage::path) (void)hop.in->read(taken.data(), static_cast<std::uint32_t>(taken.size()), &meta);
    if (stage == Stage::push) (void)buffer.pop(taken.data(), static_cast<std::uint32_t>(taken.size()), meta);
  };
  std::unique_ptr<Reader> reader;
  if (cold != Cold::hot) reader = std::make_unique<Reader>(take);
  std::vector<double> times;
  times.reserve(static_cast<std::size_t>(state.max_iterations));
  const std::vector<std::byte> pristine = hop.wire;
  std::size_t copy_size = pristine.size();
  benchmark::DoNotOptimize(copy_size);  // a real memcpy call, not an inlined move

  for (auto _ : state) {
    evict.run(cold);
    // The DDS reader has just copied the sample in (with libc's memcpy, as Cyclone does).
    std::memcpy(hop.wire.data(), pristine.data(), copy_size);
    benchmark::ClobberMemory();
    const MonoTime t0 = mono_now();
    switch (stage) {
      case Stage::path: (void)hop.out->write(hop.wire.data(), wire_size); break;
      case Stage::clock: break;
      case Stage::decode:
        (void)hop.codec->decode(hop.wire.data(), wire_size, flat.data(), static_cast<std::uint32_t>(flat.size()));
        break;
      case Stage::push: (void)buffer.push(decoded.data(), SampleMeta{hop.reference->size, t0, {}}); break;
    }
    const MonoTime t1 = mono_now();
    times.push_back(static_cast<double>((t1 - t0).count));
    if (reader) {
      reader->take_now();
    } else {
      take();
    }
    benchmark::ClobberMemory();
  }
  const ConnectionCounters& k = hop.connection->counters();
  if (stage == Stage::path && k.delivered.load() != static_cast<std::uint64_t>(state.iterations())) {
    state.SkipWithError("samples were dropped");
  }
  double sum = 0.0;
  for (double t : times) sum += t;
  state.counters["p50_ns"] = exact_percentile(times, 50.0);
  state.counters["p99_ns"] = exact_percentile(times, 99.0);
  state.counters["mean_ns"] = times.empty() ? 0.0 : sum / static_cast<double>(times.size());
  if (stage == Stage::path) {
    const auto summary = hop.connection->latency().summarize();
    state.counters["conn_mean_ns"] = summary.mean;
    state.counters["conn_p50_ns"] = static_cast<double>(summary.p50);
    state.counters["conn_p99_ns"] = static_cast<double>(summary.p99);
  }
  state.SetLabel(std::string(cold_name(cold)) + " " + stage_name(stage));
}

std::int64_t cold_iterations() {
  if (const char* text = std::getenv("POLYPORT_COLD_ITERATIONS")) {
    if (const long long n = std::atoll(text); n > 0) return n;
  }
  return 300;
}

BENCHMARK(BM_ColdPath)
    ->ArgNames({"cold", "stage"})
    ->ArgsProduct({{static_cast<int>(Cold::hot), static_cast<int>(Cold::sleep), static_cast<int>(Cold::evict),
                    static_cast<int>(Cold::tlb), static_cast<int>(Cold::lines)},
                   {static_cast<int>(Stage::path), static_cast<int>(Stage::clock), static_cast<int>(Stage::decode),
                    static_cast<int>(Stage::push)}})
    ->Iterations(cold_iterations())
    ->Unit(benchmark::kMicrosecond);

BENCHMARK(BM_cdr_to_lcm)->Repetitions(50)->ComputeStatistics("p99", p99)->ReportAggregatesOnly(true);
BENCHMARK(BM_dbc_to_cdr)->Repetitions(50)->ComputeStatistics("p99", p99)->ReportAggregatesOnly(true);
BENCHMARK(BM_cdr_to_cdr_passthrough)->Repetitions(50)->ComputeStatistics("p99", p99)->ReportAggregatesOnly(true);
BENCHMARK(BM_lcm_can)
    ->ArgNames({"lcm_bytes", "can_to_lcm"})
    ->ArgsProduct({{16, 1024}, {0, 1}})
    ->Repetitions(50)
    ->ComputeStatistics("p99", p99)
    ->ReportAggregatesOnly(true);

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (const char* revision = std::getenv("POLYPORT_GIT_REVISION")) benchmark::AddCustomContext("git_revision", revision);
  benchmark::AddCustomContext("benchmark", "converting connection: decode + map + encode of a 64-byte struct");
  // As polyportd: where clock_gettime is a system call (the vcan guest), the connection's own
  // stamps read the TSC clock, or they would time the system call.
  if (auto clock = use_clock(ClockChoice::automatic)) {
    benchmark::AddCustomContext("clock", clock.value().tsc ? "tsc" : "clock_gettime");
  } else {
    std::fprintf(stderr, "bench_conversion: %s\n", clock.error().message.c_str());
    return 1;
  }
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
