// Data connections and their policies, driven through real ports.
#include <gtest/gtest.h>

#include <atomic>
#include <cstring>
#include <string>
#include <thread>
#include <vector>

#include "polyport/runtime/component.hpp"
#include "polyport/runtime/connection.hpp"

namespace polyport {
namespace {

constexpr std::uint32_t kBytes = sizeof(std::uint64_t);

struct Wire {
  Component a{"A", "inproc"};
  Component b{"B", "inproc"};
  DataOutPort& out = a.add_port<DataOutPort>("out", PortKind::data, nullptr, kBytes);
  std::unique_ptr<Connection> connection;
  DataInPort* in = nullptr;

  Wire(QueuePolicy policy, std::uint32_t depth) {
    in = &b.add_port<DataInPort>("in", PortKind::data, nullptr, kBytes, policy, depth);
    connection = std::make_unique<Connection>(out, *in, policy, depth);
    out.connections().add(*connection);
    in->connections().add(*connection);
  }
  Status write(std::uint64_t v) { return out.write(&v, sizeof v); }
  Status read(std::uint64_t& v) { return in->read(&v, sizeof v); }
};

TEST(DataConnection, DataPolicyKeepsTheLatestValue) {
  Wire w(QueuePolicy::data, 1);
  std::uint64_t v = 0;
  EXPECT_EQ(w.read(v), Status::no_data);
  for (std::uint64_t i = 1; i <= 3; ++i) EXPECT_EQ(w.write(i), Status::ok);
  ASSERT_EQ(w.read(v), Status::ok);
  EXPECT_EQ(v, 3u);
  v = 0;
  EXPECT_EQ(w.read(v), Status::old_data);
  EXPECT_EQ(v, 3u);
  const auto& k = w.connection->counters();
  EXPECT_EQ(k.received.load(), 3u);
  EXPECT_EQ(k.delivered.load(), 3u);
  EXPECT_EQ(k.overwritten.load(), 2u);
  EXPECT_EQ(k.read.load(), 1u);
  EXPECT_EQ(k.dropped(), 0u);
  EXPECT_EQ(w.connection->latency().summarize().count, 3u);
  EXPECT_EQ(w.connection->age().summarize().count, 1u);
}

// transit is t_out - t_source: recorded only for samples whose source stamped them, and at
// least as long as the time the sample spent before it was written.
TEST(DataConnection, TransitCountsFromTheSourcesOwnStamp) {
  Wire w(QueuePolicy::data, 1);
  std::uint64_t v = 1;
  ASSERT_EQ(w.write(v), Status::ok);
  EXPECT_EQ(w.connection->transit().summarize().count, 0u);  // no stamp: in-process writer
  const Nanos before_write{5'000'000};
  const MonoTime stamped = mono_now() + Nanos{-before_write.count};
  ASSERT_EQ(w.out.write(&v, sizeof v, stamped), Status::ok);
  const auto transit = w.connection->transit().summarize();
  ASSERT_EQ(transit.count, 1u);
  EXPECT_GE(transit.min, before_write.count);
  EXPECT_EQ(w.connection->latency().summarize().count, 2u);
  EXPECT_LT(w.connection->latency().summarize().max, transit.min);
}

TEST(DataConnection, BufferDropsTheNewestWhenFull) {
  Wire w(QueuePolicy::buffer, 4);
  for (std::uint64_t i = 0; i < 10; ++i) w.write(i);
  std::uint64_t v = 0;
  for (std::uint64_t i = 0; i < 4; ++i) {
    ASSERT_EQ(w.read(v), Status::ok);
    EXPECT_EQ(v, i);
  }
  EXPECT_EQ(w.read(v), Status::no_data);
  EXPECT_EQ(w.connection->counters().dropped_queue_full.load(), 6u);
  EXPECT_EQ(w.connection->counters().delivered.load(), 4u);
}

TEST(DataConnection, CircularDropsTheOldestWhenFull) {
  Wire w(QueuePolicy::circular, 4);
  for (std::uint64_t i = 0; i < 10; ++i) w.write(i);
  std::uint64_t v = 0;
  for (std::uint64_t i = 6; i < 10; ++i) {
    ASSERT_EQ(w.read(v), Status::ok);
    EXPECT_EQ(v, i);
  }
  EXPECT_EQ(w.read(v), Status::no_data);
  EXPECT_EQ(w.connection->counters().dropped_oldest.load(), 6u);
}

TEST(DataConnection, UnconnectedWriteIsCountedNotLost) {
  Component a{"A", "inproc"};
  auto& out = a.add_port<DataOutPort>("out", PortKind::data, nullptr, kBytes);
  std::uint64_t v = 1;
  EXPECT_EQ(out.write(&v, sizeof v), Status::not_connected);
  EXPECT_EQ(out.unconnected_writes(), 1u);
}

TEST(DataConnection, OversizedSampleIsDroppedAndCounted) {
  Wire w(QueuePolicy::buffer, 2);
  char big[64] = {};
  w.out.write(big, sizeof big);
  EXPECT_EQ(w.connection->counters().dropped_too_large.load(), 1u);
  std::uint64_t v = 0;
  EXPECT_EQ(w.read(v), Status::no_data);
}

TEST(DataConnection, ReadIntoTooSmallBufferIsAnError) {
  Wire w(QueuePolicy::buffer, 2);
  w.write(7);
  std::uint32_t small = 0;
  EXPECT_EQ(w.in->read(&small, sizeof small), Status::bad_size);
  std::uint64_t v = 0;
  ASSERT_EQ(w.read(v), Status::ok);  // the sample stayed
  EXPECT_EQ(v, 7u);
}

class RecordingSink final : public SampleSink {
 public:
  Status on_sample(const std::byte* data, const SampleMeta& meta) noexcept override {
    std::memcpy(&last, data, sizeof last);
    size = meta.size;
    ++count;
    return last == 13 ? Status::error : Status::ok;
  }
  std::uint64_t last = 0;
  std::uint32_t size = 0;
  int count = 0;
};

TEST(DataConnection, PushModeCallsTheSinkOnTheWritersThread) {
  Component a{"A", "inproc"};
  Component b{"B", "adaptor"};
  auto& out = a.add_port<DataOutPort>("out", PortKind::data, nullptr, kBytes);
  auto& in = b.add_port<DataInPort>("in", PortKind::data, nullptr, kBytes, QueuePolicy::data, 1);
  RecordingSink sink;
  in.set_sink(&sink);
  Connection c(out, in, QueuePolicy::data, 1);
  out.connections().add(c);
  in.connections().add(c);
  ASSERT_TRUE(c.push_mode());
  std::uint64_t v = 42;
  out.write(&v, sizeof v);
  EXPECT_EQ(sink.last, 42u);
  EXPECT_EQ(sink.size, kBytes);
  v = 13;  // the sink refuses this one
  out.write(&v, sizeof v);
  EXPECT_EQ(c.counters().delivered.load(), 1u);
  EXPECT_EQ(c.counters().dropped_sink_error.load(), 1u);
  EXPECT_EQ(c.latency().summarize().count, 2u);
}

TEST(DataConnection, FanOutDeliversToEveryConnection) {
  Component a{"A", "inproc"};
  Component b{"B", "inproc"};
  auto& out = a.add_port<DataOutPort>("out", PortKind::data, nullptr, kBytes);
  auto& in1 = b.add_port<DataInPort>("in1", PortKind::data, nullptr, kBytes, QueuePolicy::buffer, 4);
  auto& in2 = b.add_port<DataInPort>("in2", PortKind::data, nullptr, kBytes, QueuePolicy::data, 1);
  Connection c1(out, in1, QueuePolicy::buffer, 4), c2(out, in2, QueuePolicy::data, 1);
  out.connections().add(c1);
  in1.connections().add(c1);
  out.connections().add(c2);
  in2.connections().add(c2);
  std::uint64_t v = 5;
  out.write(&v, sizeof v);
  std::uint64_t r1 = 0, r2 = 0;
  EXPECT_EQ(in1.read(&r1, sizeof r1), Status::ok);
  EXPECT_EQ(in2.read(&r2, sizeof r2), Status::ok);
  EXPECT_EQ(r1, 5u);
  EXPECT_EQ(r2, 5u);
  out.connections().remove(c2);
  v = 6;
  out.write(&v, sizeof v);
  EXPECT_EQ(c2.counters().received.load(), 1u);
  EXPECT_EQ(c1.counters().received.load(), 2u);
}

// More connections than a port's list holds in its own cache line (they spill to the heap),
// and back to fewer.
TEST(DataConnection, FanOutToManyConnectionsAndBack) {
  constexpr int kCount = 7;
  Component a{"A", "inproc"};
  Component b{"B", "inproc"};
  auto& out = a.add_port<DataOutPort>("out", PortKind::data, nullptr, kBytes);
  std::vector<DataInPort*> ins;
  std::vector<std::unique_ptr<Connection>> connections;
  for (int i = 0; i < kCount; ++i) {
    ins.push_back(&b.add_port<DataInPort>("in" + std::to_string(i), PortKind::data, nullptr, kBytes, QueuePolicy::data, 1));
    connections.push_back(std::make_unique<Connection>(out, *ins.back(), QueuePolicy::data, 1));
    out.connections().add(*connections.back());
    ins.back()->connections().add(*connections.back());
  }
  ASSERT_EQ(out.connections().size(), static_cast<std::size_t>(kCount));
  std::uint64_t v = 11;
  out.write(&v, sizeof v);
  for (int i = 0; i < kCount; ++i) {
    std::uint64_t r = 0;
    EXPECT_EQ(ins[i]->read(&r, sizeof r), Status::ok) << i;
    EXPECT_EQ(r, 11u) << i;
  }
  for (int i = 0; i < 4; ++i) out.connections().remove(*connections[i]);
  ASSERT_EQ(out.connections().size(), 3u);
  v = 12;
  out.write(&v, sizeof v);
  for (int i = 0; i < kCount; ++i) {
    std::uint64_t r = 0;
    EXPECT_EQ(ins[i]->read(&r, sizeof r), i < 4 ? Status::old_data : Status::ok) << i;
    EXPECT_EQ(r, i < 4 ? 11u : 12u) << i;
    EXPECT_EQ(connections[i]->counters().received.load(), i < 4 ? 1u : 2u) << i;
  }
}

// A producer much faster than its consumer, on two threads: nothing torn, nothing
// reordered, and every sample accounted for as read or dropped by the policy's rule.
class FastProducer : public ::testing::TestWithParam<QueuePolicy> {};

TEST_P(FastProducer, EverySampleIsReadOrCountedAsDropped) {
  constexpr std::uint64_t kCount = 100'000;
  Wire w(GetParam(), 8);
  std::atomic<bool> done{false};
  std::thread producer([&] {
    for (std::uint64_t i = 1; i <= kCount; ++i) w.write(i);
    done.store(true, std::memory_order_release);
  });
  std::uint64_t last = 0, reads = 0;
  bool ordered = true;
  volatile std::uint64_t busy = 0;
  for (;;) {
    const bool finished = done.load(std::memory_order_acquire);
    std::uint64_t v = 0;
    Status s;
    while ((s = w.read(v)) == Status::ok) {
      ordered = ordered && v > last;
      last = v;
      ++reads;
      for (int spin = 0; spin < 2000; ++spin) busy = busy + 1;  // a slow consumer
    }
    if (finished) break;
  }
  producer.join();
  std::uint64_t v = 0;
  while (w.read(v) == Status::ok) {
    ordered = ordered && v > last;
    last = v;
    ++reads;
  }
  const auto& k = w.connection->counters();
  EXPECT_TRUE(ordered);
  EXPECT_EQ(k.received.load(), kCount);
  EXPECT_EQ(k.read.load(), reads);
  switch (GetParam()) {
    case QueuePolicy::data:
      EXPECT_EQ(last, kCount);  // the latest value always wins
      EXPECT_EQ(reads + k.overwritten.load(), kCount);
      break;
    case QueuePolicy::buffer:
      EXPECT_EQ(reads + k.dropped_queue_full.load(), kCount);
      EXPECT_GT(k.dropped_queue_full.load(), 0u);
      break;
    case QueuePolicy::circular:
      // The oldest samples make room, except when the reader is copying the oldest out for
      // longer than the writer waits: that push drops its own sample, counted as queue full
      // (sample_buffer.cpp). Then the very last sample may be the one dropped.
      EXPECT_EQ(reads + k.dropped_oldest.load() + k.dropped_queue_full.load(), kCount);
      EXPECT_GT(k.dropped_oldest.load(), 0u);
      if (k.dropped_queue_full.load() == 0) {
        EXPECT_EQ(last, kCount);  // the newest samples survive
      }
      break;
  }
}

INSTANTIATE_TEST_SUITE_P(Policies, FastProducer,
                         ::testing::Values(QueuePolicy::data, QueuePolicy::buffer, QueuePolicy::circular),
                         [](const auto& param_info) { return std::string(to_string(param_info.param)); });

}  // namespace
}  // namespace polyport
