// The cross-model matrix's in-process model (run_matrix.cpp, "inprocess"): a pong that
// answers each ping from its CallbackInPort, on the thread that delivered it (a foreign
// model's receive thread, inside polyportd), so that an in-process echo costs what polyport's
// path costs and not a component's period; and a ping that sends the next ping from the
// callback that takes the pong, and writes the percentiles of its one run as the ping programs
// do (benchmarks/common/pingpong_common.hpp).
//
// Types: the flat layout of the ping types of every model (benchmarks/dds/pingpong.idl
// bench::Ping16 / Ping1k, benchmarks/lcm/pingpong.lcm bench_lcm::ping16_t / ping1k_t): a
// 64-bit sequence number and padding to 16 B or 1 KiB. The component profile names the other
// side's type, so polyport converts between its wire format and this layout and nothing maps.
// Threads: the pong has none of its own (passive); on_ping runs on the writer's thread and
// writes `pong`, which nothing else writes, so the one-writer rule of DataOutPort::write holds
// as long as one connection feeds `ping` (the runner's profiles have one). The ping: see Ping.
#include <atomic>
#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

#include "pingpong_common.hpp"
#include "polyport/runtime/component_api.hpp"
#include "polyport/runtime/drain_gate.hpp"

namespace bench_inproc {

template <int Pad>
struct Ping {
  std::uint64_t seq;
  std::uint8_t pad[Pad];
};
using Ping16 = Ping<8>;
using Ping1k = Ping<1016>;
static_assert(sizeof(Ping16) == 16 && sizeof(Ping1k) == 1024);

// ping -> pong, the same sample, from the callback.
template <class Sample>
class Pong final : public polyport::ComponentBase {
 public:
  void on_ping(const Sample& ping, const polyport::SampleMeta&) { pong_.write(ping); }

 private:
  polyport::CallbackInPort<Sample> ping_{*this, "ping", &Pong::on_ping};
  polyport::OutPort<Sample> pong_{*this, "pong"};
};

using Pong16 = Pong<Ping16>;
using Pong1k = Pong<Ping1k>;

// Sends ping 0, 1, 2, ... on `ping` and takes each pong on `pong`: warm-up then `rounds`
// measured round trips (CLOCK_MONOTONIC, from before the write to the pong's callback), then
// one JSON line in the file the property `report` names (as pingpong_common.hpp's report();
// cpu_ns: polyportd's own CPU time over the measured round trips, then the processes of
// POLYPORT_BENCH_CPU_PIDS) and, with `samples`, every round trip in that file. Properties:
// rounds, warmup, report, samples, timeout_ms (a pong that has not come by then is lost:
// the next ping goes), start_ms (the first ping's delay after activation, for the far side's
// discovery).
//
// Threads: onExecute (the component's context, every period) starts the run and gives a lost
// round up; on_pong runs on the pong's writer's thread: a foreign model's receive thread, or,
// with an in-process pong, this very thread inside its own write() (the pong answers from its
// callback). Each round is claimed once, by the compare-exchange on expected_ (the pong of
// that round, or the timeout); the claimer asks for the next ping. Sending is a trampoline
// (core's DrainGate): a request that finds a send under way only counts itself and returns,
// and the sending thread sends again once its write has returned, so a pong that comes back
// inside the write does not send from inside it (no recursion, one writer of `ping` at a
// time, whichever thread).
template <class Sample>
class PingComp final : public polyport::ComponentBase {
 public:
  polyport::ReturnCode onInitialize() override {
    rounds_ = property_int("rounds", 1000);
    warmup_ = property_int("warmup", 100);
    report_ = property("report");
    samples_ = property("samples");
    timeout_ns_ = property_int("timeout_ms", 1000) * 1'000'000;
    start_ns_ = property_int("start_ms", 500) * 1'000'000;
    if (rounds_ <= 0 || warmup_ < 0 || report_.empty() || timeout_ns_ <= 0) return polyport::ReturnCode::bad_parameter;
    rtt_.assign(static_cast<std::size_t>(rounds_), -1);
    return polyport::ReturnCode::ok;
  }
  polyport::ReturnCode onActivated() override {
    activated_ns_ = bench::now_ns();
    return polyport::ReturnCode::ok;
  }
  polyport::ReturnCode onExecute() override {
    if (finished_.load(std::memory_order_acquire)) {
      if (!reported_) {
        reported_ = true;
        write_report();
      }
      return polyport::ReturnCode::ok;
    }
    if (!started_) {
      if (bench::now_ns() - activated_ns_ < start_ns_) return polyport::ReturnCode::ok;
      started_ = true;
      if (warmup_ == 0) cpu_.start();
      request_send();
      return polyport::ReturnCode::ok;
    }
    std::uint64_t round = expected_.load(std::memory_order_acquire);
    const bool sent = sent_seq_.load(std::memory_order_acquire) == round;
    if (sent && bench::now_ns() - sent_at_.load(std::memory_order_acquire) > timeout_ns_ &&
        expected_.compare_exchange_strong(round, round + 1, std::memory_order_acq_rel)) {
      ++lost_;
      next_after(round);
    }
    return polyport::ReturnCode::ok;
  }
  void on_pong(const Sample& pong, const polyport::SampleMeta&) {
    const std::int64_t now = bench::now_ns();
    std::uint64_t round = pong.seq;
    if (!expected_.compare_exchange_strong(round, round + 1, std::memory_order_acq_rel)) return;  // late or lost
    if (round >= static_cast<std::uint64_t>(warmup_)) {
      rtt_[round - static_cast<std::uint64_t>(warmup_)] = now - sent_at_.load(std::memory_order_acquire);
    }
    next_after(round);
  }

 private:
  // `round` is over (its pong came, or it was given up): the next one, or the end.
  void next_after(std::uint64_t round) {
    const std::uint64_t next = round + 1;
    if (next == static_cast<std::uint64_t>(warmup_)) cpu_.start();
    if (next >= static_cast<std::uint64_t>(warmup_ + rounds_)) {
      cpu_.stop();
      finished_.store(true, std::memory_order_release);
      return;
    }
    request_send();
  }
  void request_send() {
    sends_.run([this]() noexcept {
      if (finished_.load(std::memory_order_acquire)) return;
      Sample ping{};
      ping.seq = expected_.load(std::memory_order_acquire);
      sent_at_.store(bench::now_ns(), std::memory_order_release);
      sent_seq_.store(ping.seq, std::memory_order_release);
      // Senders in flight: 1 unless a send nests inside a write or runs beside another one.
      const int depth = send_depth_.fetch_add(1, std::memory_order_acq_rel) + 1;
      if (depth > max_send_depth_.load(std::memory_order_relaxed)) max_send_depth_.store(depth, std::memory_order_relaxed);
      ping_.write(ping);  // an in-process pong's answer comes back inside this call
      send_depth_.fetch_sub(1, std::memory_order_acq_rel);
    });
  }
  void write_report() {
    std::vector<std::int64_t> rtt;
    for (const std::int64_t r : rtt_) {
      if (r >= 0) rtt.push_back(r);
    }
    std::vector<std::int64_t> one_way;
    for (const std::int64_t r : rtt) one_way.push_back(r / 2);
    if (std::FILE* out = std::fopen(report_.c_str(), "w")) {
      std::fprintf(out, R"({"vendor":"inprocess","size":%zu,"warmup":%lld,"lost":%d,"rtt_ns":%s,"one_way_ns":%s,)"
                        R"("cpu_ns":%s,"max_send_depth":%d})"
                        "\n",
                   sizeof(Sample), static_cast<long long>(warmup_), lost_, bench::summary(rtt).c_str(),
                   bench::summary(one_way).c_str(), cpu_.json().c_str(), max_send_depth_.load());
      std::fclose(out);
    }
    if (!samples_.empty()) bench::write_samples(samples_.c_str(), rtt, std::vector<std::int64_t>(rtt.size(), 0));
  }

  polyport::OutPort<Sample> ping_{*this, "ping"};
  polyport::CallbackInPort<Sample> pong_{*this, "pong", &PingComp::on_pong};
  std::int64_t rounds_ = 0, warmup_ = 0, timeout_ns_ = 0, start_ns_ = 0, activated_ns_ = 0;
  std::string report_, samples_;
  std::vector<std::int64_t> rtt_;  // per measured round, -1 when lost; sized before the run
  bench::CpuClocks cpu_;
  std::atomic<std::uint64_t> expected_{0};    // the round whose pong is awaited
  std::atomic<std::uint64_t> sent_seq_{~0ull};
  std::atomic<std::int64_t> sent_at_{0};
  polyport::DrainGate sends_;                 // one sender at a time, never nested
  std::atomic<int> send_depth_{0}, max_send_depth_{0};  // sends in flight (reported: the gate's proof)
  std::atomic<bool> finished_{false};
  int lost_ = 0;                              // the context's thread only
  bool started_ = false, reported_ = false;   // the context's thread only
};

using Ping16Comp = PingComp<Ping16>;
using Ping1kComp = PingComp<Ping1k>;

POLYPORT_COMPONENTS(POLYPORT_COMPONENT(Pong16), POLYPORT_COMPONENT(Pong1k), POLYPORT_COMPONENT(Ping16Comp),
                    POLYPORT_COMPONENT(Ping1kComp))

}  // namespace bench_inproc
