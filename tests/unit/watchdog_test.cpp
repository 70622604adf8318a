// Connection watchdogs: the safe value on the forwarding path, at the reader and from the
// watchdog thread, the state it keeps, and what it counts. Time passes by calling
// ConnectionTimer::check with a later instant, or by waiting on the clock for a condition.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cstring>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "polyport/runtime/component.hpp"
#include "polyport/runtime/connection.hpp"
#include "polyport/runtime/connection_timer.hpp"
#include "polyport/runtime/watchdog.hpp"

namespace polyport {
namespace {

constexpr std::uint32_t kBytes = sizeof(std::uint64_t);
constexpr std::uint64_t kSafe = 0xDEAD;
constexpr Nanos kDeadline{200'000'000};  // long enough that a busy machine does not trip it by itself

std::vector<std::byte> safe_bytes() {
  std::vector<std::byte> bytes(kBytes);
  std::memcpy(bytes.data(), &kSafe, kBytes);
  return bytes;
}

// Counts what reaches it, and whether two calls ever overlapped.
class Sink : public SampleSink {
 public:
  Status on_sample(const std::byte* data, const SampleMeta& meta) noexcept override {
    if (inside_.fetch_add(1) != 0) overlapped_.store(true);
    std::uint64_t v = 0;
    std::memcpy(&v, data, std::min<std::uint32_t>(meta.size, kBytes));
    last_.store(v);
    count_.fetch_add(1);
    if (v == kSafe) safe_.fetch_add(1);
    inside_.fetch_sub(1);
    return Status::ok;
  }
  std::uint64_t last() const { return last_.load(); }
  int count() const { return count_.load(); }
  int safe() const { return safe_.load(); }
  bool overlapped() const { return overlapped_.load(); }

 private:
  std::atomic<int> inside_{0};
  std::atomic<bool> overlapped_{false};
  std::atomic<std::uint64_t> last_{0};
  std::atomic<int> count_{0};
  std::atomic<int> safe_{0};
};

// Source A.out -> B.in, optionally watched also through Up.out; pull mode unless a sink is given.
struct Guarded {
  Component a{"A", "inproc"};
  Component b{"B", "inproc"};
  Component up{"Up", "inproc"};
  DataOutPort& out = a.add_port<DataOutPort>("out", PortKind::data, nullptr, kBytes);
  DataOutPort& upstream = up.add_port<DataOutPort>("out", PortKind::data, nullptr, kBytes);
  DataInPort& in = b.add_port<DataInPort>("in", PortKind::data, nullptr, kBytes, QueuePolicy::data, 1);
  std::unique_ptr<Connection> connection;
  ConnectionTimer monitor;

  explicit Guarded(SampleSink* sink = nullptr, bool with_upstream = false, Nanos max_age = {},
                   QueuePolicy policy = QueuePolicy::data) {
    if (sink) in.set_sink(sink);
    connection = std::make_unique<Connection>(out, in, policy, policy == QueuePolicy::data ? 1 : 4);
    connection->set_watchdog(std::make_unique<ConnectionWatchdog>(out, with_upstream ? &upstream : nullptr,
                                                                  kDeadline, max_age, safe_bytes()));
    out.connections().add(*connection);
    in.connections().add(*connection);
    monitor.add(*connection);
  }
  Status write(std::uint64_t v, MonoTime t_source = {}) { return out.write(&v, sizeof v, t_source); }
  Status read(std::uint64_t& v) { return in.read(&v, sizeof v); }
  ConnectionWatchdog& watchdog() { return *connection->watchdog(); }
  std::uint64_t safe_values() { return watchdog().counters().safe_values.load(); }
};

// Waits on the clock until the source's deadline has passed (no sleep that hopes).
void wait_past_deadline(const DataOutPort& port) {
  const MonoTime until = port.last_write() + kDeadline + Nanos{1'000'000};
  while (mono_now() < until) std::this_thread::sleep_for(std::chrono::milliseconds(1));
}

TEST(Watchdog, ReaderGetsTheSafeValueBeforeTheFirstSampleAndAfterTheDeadline) {
  Guarded g;
  std::uint64_t v = 0;
  ASSERT_EQ(g.read(v), Status::ok);  // nothing written yet: the safe value, once as new
  EXPECT_EQ(v, kSafe);
  v = 0;
  ASSERT_EQ(g.read(v), Status::old_data);
  EXPECT_EQ(v, kSafe);

  ASSERT_EQ(g.write(5), Status::ok);
  ASSERT_EQ(g.read(v), Status::ok);
  EXPECT_EQ(v, 5u);
  EXPECT_EQ(g.read(v), Status::old_data);
  EXPECT_EQ(v, 5u);

  wait_past_deadline(g.out);
  ASSERT_EQ(g.read(v), Status::ok);
  EXPECT_EQ(v, kSafe);
  ASSERT_EQ(g.write(6), Status::ok);  // the source is back
  ASSERT_EQ(g.read(v), Status::ok);
  EXPECT_EQ(v, 6u);
  EXPECT_EQ(g.safe_values(), 2u);
  EXPECT_EQ(g.connection->counters().read.load(), 2u);
  EXPECT_EQ(g.connection->counters().dropped(), 0u);
}

TEST(Watchdog, QueueReaderGetsTheSafeValueOnce) {
  Guarded g(nullptr, false, {}, QueuePolicy::circular);
  std::uint64_t v = 0;
  ASSERT_EQ(g.write(1), Status::ok);
  wait_past_deadline(g.out);
  ASSERT_EQ(g.read(v), Status::ok);
  EXPECT_EQ(v, kSafe);
  EXPECT_EQ(g.read(v), Status::no_data);
  ASSERT_EQ(g.write(2), Status::ok);
  ASSERT_EQ(g.read(v), Status::ok);
  EXPECT_EQ(v, 1u);  // what was queued before the deadline is still there, in order
  ASSERT_EQ(g.read(v), Status::ok);
  EXPECT_EQ(v, 2u);
}

// The motor command of a controller that keeps running after its input went silent: every
// command is replaced while the upstream port is silent, and passes again once it writes.
TEST(Watchdog, SilentUpstreamReplacesEverySampleOnTheForwardingPath) {
  Sink sink;
  Guarded g(&sink, true);
  ASSERT_TRUE(g.connection->push_mode());
  for (std::uint64_t i = 1; i <= 3; ++i) ASSERT_EQ(g.write(i), Status::ok);
  EXPECT_EQ(sink.count(), 3);
  EXPECT_EQ(sink.safe(), 3);  // the upstream never wrote
  std::uint64_t up = 1;
  g.upstream.write(&up, sizeof up);
  ASSERT_EQ(g.write(7), Status::ok);
  EXPECT_EQ(sink.last(), 7u);
  EXPECT_EQ(sink.safe(), 3);
  EXPECT_EQ(g.connection->counters().received.load(), 4u);
  EXPECT_EQ(g.connection->counters().delivered.load(), 4u);
  EXPECT_EQ(g.safe_values(), 3u);

  wait_past_deadline(g.upstream);
  ASSERT_EQ(g.write(8), Status::ok);
  EXPECT_EQ(sink.last(), kSafe);
  EXPECT_EQ(g.safe_values(), 4u);
}

TEST(Watchdog, MonitorTripsSendsTheSafeValueOnceAndCountsTheRecovery) {
  Sink sink;
  Guarded g(&sink);
  const MonoTime start = mono_now();
  // Before any sample: waiting, and a push-mode target gets the safe value once.
  g.monitor.check(start);
  EXPECT_EQ(g.watchdog().state(), WatchdogState::waiting);
  EXPECT_EQ(sink.safe(), 1);
  g.monitor.check(start + Nanos{1'000'000});
  EXPECT_EQ(sink.safe(), 1);

  ASSERT_EQ(g.write(3), Status::ok);
  const MonoTime written = g.out.last_write();
  const MonoTime next = g.monitor.check(written);
  EXPECT_EQ(g.watchdog().state(), WatchdogState::ok);
  // It looks again just as the deadline passes, or sooner (it sleeps 100 ms at most).
  EXPECT_LE(next, written + kDeadline + Nanos{1});
  EXPECT_GT(next, written);
  EXPECT_EQ(g.watchdog().counters().trips.load(), 0u);

  g.monitor.check(written + kDeadline);  // at the deadline: still fresh
  EXPECT_EQ(g.watchdog().state(), WatchdogState::ok);
  g.monitor.check(written + kDeadline + Nanos{1});
  EXPECT_EQ(g.watchdog().state(), WatchdogState::tripped);
  EXPECT_EQ(g.watchdog().counters().trips.load(), 1u);
  EXPECT_EQ(sink.last(), kSafe);
  EXPECT_EQ(sink.safe(), 2);
  g.monitor.check(written + kDeadline + Nanos{5'000'000});
  EXPECT_EQ(sink.safe(), 2);  // once per trip

  ASSERT_EQ(g.write(4), Status::ok);
  EXPECT_EQ(sink.last(), 4u);
  g.monitor.check(g.out.last_write());
  EXPECT_EQ(g.watchdog().state(), WatchdogState::ok);
  EXPECT_EQ(g.watchdog().counters().recoveries.load(), 1u);
  EXPECT_EQ(g.safe_values(), 2u);
  // Safe values from the watchdog thread are not samples of the connection.
  EXPECT_EQ(g.connection->counters().received.load(), 2u);
}

TEST(Watchdog, SamplesOlderThanMaxAgeAreReplacedAndCounted) {
  Sink sink;
  Guarded g(&sink, false, Nanos{50'000'000});
  ASSERT_EQ(g.write(1, mono_now() + Nanos{-60'000'000}), Status::ok);
  EXPECT_EQ(sink.last(), kSafe);
  ASSERT_EQ(g.write(2, mono_now() + Nanos{-1'000'000}), Status::ok);
  EXPECT_EQ(sink.last(), 2u);
  ASSERT_EQ(g.write(3), Status::ok);  // no source stamp: no age to judge
  EXPECT_EQ(sink.last(), 3u);
  EXPECT_EQ(g.watchdog().counters().stale.load(), 1u);
  EXPECT_EQ(g.connection->counters().dropped_stale.load(), 1u);
  EXPECT_EQ(g.connection->counters().dropped(), 1u);
}

// The watchdog thread's safe value and forwarded samples never reach a sink at once.
TEST(Watchdog, SafeValueAndSamplesNeverOverlapAtTheSink) {
  Sink sink;
  Guarded g(&sink);
  std::atomic<bool> stop{false};
  std::thread writer([&] {
    for (std::uint64_t i = 1; !stop.load(); ++i) g.write(i);
  });
  // Each check at a far instant sees the source silent and writes the safe value when it
  // can take the sink; a fresh write in between makes the next one trip again.
  while (g.out.last_write().ns == 0) std::this_thread::yield();
  // Until both have reached the sink many times (the writer may be preempted inside the sink,
  // and the watchdog thread then waits for it: bounded by time, not by a count of passes).
  const auto limit = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  while ((g.watchdog().counters().trips.load() < 1000 || sink.safe() < 100 || sink.count() < 10000) &&
         std::chrono::steady_clock::now() < limit) {
    g.monitor.check(mono_now() + Nanos{2 * kDeadline.count});
    g.monitor.check(mono_now());
  }
  const int emitted_before = sink.safe();
  stop.store(true);
  writer.join();
  EXPECT_FALSE(sink.overlapped());
  EXPECT_GE(emitted_before, 100) << "sink count " << sink.count();
  EXPECT_GE(g.watchdog().counters().trips.load(), 1000u);
}

// An event port (<watchdog><event>) hears of each trip and recovery, with the counts so far.
TEST(Watchdog, EventPortHearsOfTripsAndRecoveries) {
  Sink sink;
  Guarded g(&sink, true);
  Component events{"watchdogs", "inproc"};
  Component monitor{"Monitor", "inproc"};
  auto& out = events.add_port<DataOutPort>("B.in", PortKind::event, nullptr, sizeof(WatchdogEventSample));
  auto& in = monitor.add_port<DataInPort>("alarms", PortKind::event, nullptr, sizeof(WatchdogEventSample),
                                          QueuePolicy::circular, 8);
  Connection told(out, in, QueuePolicy::circular, 8);
  out.connections().add(told);
  in.connections().add(told);
  g.watchdog().set_events(&out, g.connection->name());

  std::uint64_t up = 1;
  g.upstream.write(&up, sizeof up);
  ASSERT_EQ(g.write(1), Status::ok);
  const MonoTime written = g.out.last_write();
  g.monitor.check(written);  // armed: no event
  WatchdogEventSample event{};
  EXPECT_EQ(in.read(&event, sizeof event), Status::no_data);
  wait_past_deadline(g.upstream);
  ASSERT_EQ(g.write(2), Status::ok);  // the source goes on; the upstream is the silent one
  const MonoTime later = mono_now();
  g.monitor.check(later);
  ASSERT_EQ(in.read(&event, sizeof event), Status::ok);
  EXPECT_EQ(event.kind, 0);
  EXPECT_EQ(event.trips, 1u);
  EXPECT_EQ(event.recoveries, 0u);
  EXPECT_EQ(std::string(event.connection), "A.out -> B.in");
  EXPECT_EQ(std::string(event.silent_port), "Up.out");
  EXPECT_EQ(event.silent_ns, (later - g.upstream.last_write()).count);

  g.upstream.write(&up, sizeof up);
  ASSERT_EQ(g.write(3), Status::ok);
  g.monitor.check(mono_now());
  ASSERT_EQ(in.read(&event, sizeof event), Status::ok);
  EXPECT_EQ(event.kind, 1);
  EXPECT_EQ(event.trips, 1u);
  EXPECT_EQ(event.recoveries, 1u);
  EXPECT_EQ(std::string(event.silent_port), "");
  EXPECT_EQ(in.read(&event, sizeof event), Status::no_data);
}

// The thread itself: it wakes at the deadline, says so, and writes the safe value.
TEST(Watchdog, MonitorThreadTripsAfterTheDeadlineAndReportsIt) {
  Sink sink;
  Guarded g(&sink);
  std::mutex mutex;
  std::vector<std::pair<std::string, bool>> told;
  g.monitor.start([&](const std::string& message, bool problem) {
    std::lock_guard<std::mutex> lock(mutex);
    told.emplace_back(message, problem);
  });
  ASSERT_EQ(g.write(9), Status::ok);
  const MonoTime written = g.out.last_write();
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (g.watchdog().counters().trips.load() == 0 && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  ASSERT_EQ(g.watchdog().counters().trips.load(), 1u);
  while (sink.last() != kSafe && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  EXPECT_EQ(sink.last(), kSafe);
  EXPECT_GE(mono_now() - written, kDeadline);
  g.monitor.stop();
  std::lock_guard<std::mutex> lock(mutex);
  bool tripped = false;
  for (const auto& [message, problem] : told) {
    if (message.find("tripped") == std::string::npos) continue;
    tripped = true;
    EXPECT_TRUE(problem);
    EXPECT_NE(message.find("A.out -> B.in"), std::string::npos) << message;
    EXPECT_NE(message.find("A.out silent for more than 200.0 ms"), std::string::npos) << message;
  }
  EXPECT_TRUE(tripped);
}

}  // namespace
}  // namespace polyport
