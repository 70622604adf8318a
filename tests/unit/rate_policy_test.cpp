// A connection's rate limit (newest wins) and deadbands, driven through real ports. Time
// passes by calling ConnectionTimer::check with a later instant, or by stamping samples.
#include <gtest/gtest.h>

#include <cstring>
#include <vector>

#include "polyport/runtime/component.hpp"
#include "polyport/runtime/connection.hpp"
#include "polyport/runtime/connection_timer.hpp"

namespace polyport {
namespace {

struct Sample {
  double x;
  std::int32_t n;
  float f;
};

class Sink : public SampleSink {
 public:
  Status on_sample(const std::byte* data, const SampleMeta& meta) noexcept override {
    Sample s{};
    std::memcpy(&s, data, std::min<std::size_t>(meta.size, sizeof s));
    got.push_back(s);
    return Status::ok;
  }
  std::vector<Sample> got;
};

struct Wire {
  Component a{"A", "inproc"};
  Component b{"B", "adaptor"};
  DataOutPort& out = a.add_port<DataOutPort>("out", PortKind::data, nullptr, sizeof(Sample));
  DataInPort& in = b.add_port<DataInPort>("in", PortKind::data, nullptr, sizeof(Sample), QueuePolicy::data, 1);
  Sink sink;
  std::unique_ptr<Connection> connection;
  ConnectionTimer timer;

  Wire() {
    in.set_sink(&sink);
    connection = std::make_unique<Connection>(out, in, QueuePolicy::data, 1);
    out.connections().add(*connection);
    in.connections().add(*connection);
  }
  void write(double x, std::int32_t n = 0, float f = 0.0F) {
    const Sample s{x, n, f};
    out.write(&s, sizeof s);
  }
  const ConnectionCounters& counters() const { return connection->counters(); }
};

TEST(Deadband, OnlySamplesThatMovedMoreThanTheThresholdPass) {
  Wire w;
  w.connection->set_deadbands({DeadbandField{offsetof(Sample, x), TypeKind::float64, 0.1, "x"}});
  for (const double x : {1.0, 1.05, 1.08, 1.2, 1.15, 1.31, 0.0}) w.write(x);
  // 1.0 (the first), 1.2 (moved 0.2 from 1.0), 1.31 (0.11 from 1.2), 0.0: compared with the
  // last sample that passed, not the last one seen.
  ASSERT_EQ(w.sink.got.size(), 4U);
  EXPECT_EQ(w.sink.got[0].x, 1.0);
  EXPECT_EQ(w.sink.got[1].x, 1.2);
  EXPECT_EQ(w.sink.got[2].x, 1.31);
  EXPECT_EQ(w.sink.got[3].x, 0.0);
  EXPECT_EQ(w.counters().received.load(), 7U);
  EXPECT_EQ(w.counters().delivered.load(), 4U);
  EXPECT_EQ(w.counters().dropped_filtered.load(), 3U);
  EXPECT_EQ(w.counters().dropped(), 3U);
}

TEST(Deadband, AnyFieldThatMovedLetsTheSamplePass) {
  Wire w;
  w.connection->set_deadbands({DeadbandField{offsetof(Sample, x), TypeKind::float64, 1.0, "x"},
                               DeadbandField{offsetof(Sample, n), TypeKind::int32, 0.0, "n"},
                               DeadbandField{offsetof(Sample, f), TypeKind::float32, 0.5, "f"}});
  w.write(0.0, 5, 0.0F);
  w.write(0.5, 5, 0.25F);  // nothing moved enough
  w.write(0.5, 6, 0.25F);  // n moved (threshold 0: any change)
  w.write(0.5, 6, 1.0F);   // f moved 0.75
  w.write(0.5, 6, 1.0F);   // nothing
  ASSERT_EQ(w.sink.got.size(), 3U);
  EXPECT_EQ(w.sink.got[1].n, 6);
  EXPECT_EQ(w.sink.got[2].f, 1.0F);
  EXPECT_EQ(w.counters().dropped_filtered.load(), 2U);
}

TEST(RateLimit, SamplesBeforeTheirTurnAreHeldAndTheNewestGoesWhenItComes) {
  Wire w;
  constexpr Nanos kInterval{1'000'000'000};  // 1 per second: nothing in this test waits for it
  w.connection->set_rate_limit(kInterval);
  w.timer.add(*w.connection);
  w.write(1.0);  // the first passes
  ASSERT_EQ(w.sink.got.size(), 1U);
  EXPECT_EQ(w.connection->held_due(), MonoTime{});
  w.write(2.0);
  w.write(3.0);  // held, replacing 2.0
  ASSERT_EQ(w.sink.got.size(), 1U);
  const MonoTime due = w.connection->held_due();
  ASSERT_NE(due, MonoTime{});
  // Before its turn the timer leaves it, and says when to look again: at the turn.
  EXPECT_EQ(w.timer.check(due + Nanos{-1}), due);
  EXPECT_EQ(w.sink.got.size(), 1U);
  w.timer.check(due);
  ASSERT_EQ(w.sink.got.size(), 2U);
  EXPECT_EQ(w.sink.got[1].x, 3.0);  // newest wins
  EXPECT_EQ(w.connection->held_due(), MonoTime{});
  w.timer.check(due + kInterval);  // nothing held: nothing goes
  EXPECT_EQ(w.sink.got.size(), 2U);
  EXPECT_EQ(w.counters().received.load(), 3U);
  EXPECT_EQ(w.counters().delivered.load(), 2U);
  EXPECT_EQ(w.counters().dropped_rate_limited.load(), 1U);
  EXPECT_EQ(w.connection->latency().summarize().count, 2U);
}

TEST(RateLimit, ASampleAfterItsTurnGoesAtOnceAndReplacesTheHeldOne) {
  Wire w;
  w.connection->set_rate_limit(Nanos{1'000'000});  // 1 ms
  w.write(1.0);
  w.write(2.0);  // held
  const MonoTime due = w.connection->held_due();
  ASSERT_NE(due, MonoTime{});
  while (mono_now() < due) {
  }
  w.write(3.0);  // its turn has come: it goes, and 2.0 is dropped as replaced
  ASSERT_EQ(w.sink.got.size(), 2U);
  EXPECT_EQ(w.sink.got[1].x, 3.0);
  EXPECT_EQ(w.connection->held_due(), MonoTime{});
  EXPECT_EQ(w.counters().dropped_rate_limited.load(), 1U);
}

TEST(RateLimit, PullModeReaderGetsTheHeldSampleWhenItIsReleased) {
  Component a{"A", "inproc"};
  Component b{"B", "inproc"};
  auto& out = a.add_port<DataOutPort>("out", PortKind::data, nullptr, sizeof(Sample));
  auto& in = b.add_port<DataInPort>("in", PortKind::data, nullptr, sizeof(Sample), QueuePolicy::circular, 8);
  Connection connection(out, in, QueuePolicy::circular, 8);
  connection.set_rate_limit(Nanos{1'000'000'000});
  out.connections().add(connection);
  in.connections().add(connection);
  ConnectionTimer timer;
  timer.add(connection);
  for (double x : {1.0, 2.0, 3.0}) {
    const Sample s{x, 0, 0.0F};
    out.write(&s, sizeof s);
  }
  Sample s{};
  ASSERT_EQ(in.read(&s, sizeof s), Status::ok);
  EXPECT_EQ(s.x, 1.0);
  EXPECT_EQ(in.read(&s, sizeof s), Status::no_data);
  timer.check(connection.held_due());
  ASSERT_EQ(in.read(&s, sizeof s), Status::ok);
  EXPECT_EQ(s.x, 3.0);
}

}  // namespace
}  // namespace polyport
