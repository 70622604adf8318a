// Push newest and push timed on real ports and connections (in-process): priming of a late
// subscriber, every Nth cycle per subscriber, the server's not-active state, subscription
// changes as the server's component sees them, and the client's subscribe / unsubscribe.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cstring>
#include <string>
#include <thread>
#include <vector>

#include "polyport/runtime/component.hpp"
#include "polyport/runtime/connection.hpp"
#include "polyport/runtime/execution_context.hpp"
#include "polyport/runtime/lifecycle.hpp"
#include "polyport/runtime/push_ports.hpp"
#include "polyport/runtime/push_server.hpp"

namespace polyport {
namespace {

using Value = std::uint64_t;
constexpr std::uint32_t kBytes = sizeof(Value);

class Sink final : public SampleSink {
 public:
  Status on_sample(const std::byte* data, const SampleMeta&) noexcept override {
    Value v = 0;
    std::memcpy(&v, data, sizeof v);
    got.push_back(v);
    return Status::ok;
  }
  std::vector<Value> got;
};

// A server port A.out with a push server, and subscribers made on demand.
struct Server {
  Component a{"A", "inproc"};
  Component b{"B", "inproc"};
  DataOutPort& out = a.add_port<DataOutPort>("out", PortKind::data, nullptr, kBytes);
  std::vector<std::unique_ptr<Connection>> connections;

  Server(PushPattern pattern, Nanos cycle = Nanos{0}, std::uint32_t writes_per_cycle = 1) {
    out.set_push(std::make_unique<PushServer>(out, pattern, cycle, writes_per_cycle));
  }
  PushServer& push() { return *out.push(); }
  // A pull-mode subscriber B.<name>, connected now.
  DataInPort& subscribe(const std::string& name, QueuePolicy policy = QueuePolicy::circular, std::uint32_t every = 0) {
    DataInPort& in = b.add_port<DataInPort>(name, PortKind::data, nullptr, kBytes, policy, 16);
    connect(in, policy, every);
    return in;
  }
  Connection& connect(DataInPort& in, QueuePolicy policy, std::uint32_t every = 0) {
    connections.push_back(std::make_unique<Connection>(out, in, policy, 16));
    Connection& c = *connections.back();
    if (every != 0) c.set_subscription(every);
    in.connections().add(c);
    out.connections().add(c);
    return c;
  }
  Status write(Value v) { return out.write(&v, sizeof v); }
};

std::vector<Value> drain(DataInPort& in) {
  std::vector<Value> got;
  Value v = 0;
  while (in.read(&v, sizeof v) == Status::ok) got.push_back(v);
  return got;
}

TEST(PushNewest, ASubscriberConnectedLaterGetsTheLatestValueAtOnce) {
  Server s(PushPattern::newest);
  DataInPort& early = s.subscribe("early");
  for (Value v = 1; v <= 3; ++v) EXPECT_EQ(s.write(v), Status::ok);
  DataInPort& late = s.subscribe("late");
  EXPECT_EQ(drain(late), (std::vector<Value>{3}));  // the latest, not the history
  for (Value v = 4; v <= 5; ++v) s.write(v);
  // Every new value reaches every subscriber; the early one got each from the start.
  EXPECT_EQ(drain(early), (std::vector<Value>{1, 2, 3, 4, 5}));
  EXPECT_EQ(drain(late), (std::vector<Value>{4, 5}));
  EXPECT_EQ(s.push().counters().primed.load(), 1u);
  EXPECT_EQ(s.connections[1]->counters().received.load(), 3u);  // the primed value and two new ones
}

TEST(PushNewest, APushModeSubscriberIsPrimedThroughItsSink) {
  Server s(PushPattern::newest);
  s.write(7);  // nobody listens yet: kept all the same
  EXPECT_EQ(s.out.unconnected_writes(), 1u);
  DataInPort& in = s.b.add_port<DataInPort>("sink", PortKind::data, nullptr, kBytes, QueuePolicy::data, 1);
  Sink sink;
  in.set_sink(&sink);
  s.connect(in, QueuePolicy::data);
  EXPECT_EQ(sink.got, (std::vector<Value>{7}));
  s.write(8);
  EXPECT_EQ(sink.got, (std::vector<Value>{7, 8}));
}

TEST(PushNewest, NothingToPrimeBeforeTheFirstValueOrWhileStopped) {
  Server s(PushPattern::newest);
  DataInPort& first = s.subscribe("first");
  EXPECT_TRUE(drain(first).empty());
  s.write(1);
  s.push().stop();
  DataInPort& second = s.subscribe("second");
  Value v = 0;
  EXPECT_EQ(second.read(&v, sizeof v), Status::not_active);
  s.push().start();
  EXPECT_EQ(second.read(&v, sizeof v), Status::no_data);
  EXPECT_EQ(s.push().counters().primed.load(), 0u);
}

TEST(PushTimed, EachSubscriberTakesTheFirstOfEveryNCycles) {
  Server s(PushPattern::timed, Nanos{10'000'000});
  DataInPort& each = s.subscribe("each");
  DataInPort& every3 = s.subscribe("every3", QueuePolicy::circular, 3);
  for (Value v = 1; v <= 10; ++v) s.write(v);
  EXPECT_EQ(drain(each), (std::vector<Value>{1, 2, 3, 4, 5, 6, 7, 8, 9, 10}));
  EXPECT_EQ(drain(every3), (std::vector<Value>{1, 4, 7, 10}));
  const ConnectionCounters& k = s.connections[1]->counters();
  EXPECT_EQ(k.received.load(), 10u);
  EXPECT_EQ(k.delivered.load(), 4u);
  EXPECT_EQ(k.skipped.load(), 6u);
  EXPECT_EQ(k.dropped(), 0u);  // skipping a cycle the subscriber did not ask for is no drop
  EXPECT_EQ(s.connections[1]->subscription_every(), 3u);
}

TEST(PushTimed, AnInProcessServerIsThinnedToItsBaseCycle) {
  // Base cycle 30 ms on a 10 ms component: the first write of every three goes.
  Server s(PushPattern::timed, Nanos{30'000'000}, 3);
  DataInPort& each = s.subscribe("each");
  for (Value v = 1; v <= 7; ++v) EXPECT_EQ(s.write(v), Status::ok);
  EXPECT_EQ(drain(each), (std::vector<Value>{1, 4, 7}));
  EXPECT_EQ(s.push().counters().between_cycles.load(), 4u);
}

TEST(PushTimed, AStoppedServerSendsNothingAndItsSubscribersReadNotActive) {
  Server s(PushPattern::timed, Nanos{10'000'000});
  DataInPort& queue = s.subscribe("queue");
  DataInPort& latest = s.subscribe("latest", QueuePolicy::data);
  s.write(1);
  s.push().stop();
  EXPECT_FALSE(s.push().active());
  EXPECT_EQ(s.write(2), Status::not_active);
  Value v = 0;
  // What came before the stop is read first.
  ASSERT_EQ(queue.read(&v, sizeof v), Status::ok);
  EXPECT_EQ(v, 1u);
  EXPECT_EQ(queue.read(&v, sizeof v), Status::not_active);
  ASSERT_EQ(latest.read(&v, sizeof v), Status::ok);
  EXPECT_EQ(latest.read(&v, sizeof v), Status::not_active);  // rather than old_data
  s.push().start();
  EXPECT_EQ(s.write(3), Status::ok);
  ASSERT_EQ(queue.read(&v, sizeof v), Status::ok);
  EXPECT_EQ(v, 3u);
  EXPECT_EQ(queue.read(&v, sizeof v), Status::no_data);
  EXPECT_EQ(s.push().counters().not_active.load(), 1u);
  EXPECT_EQ(s.connections[0]->counters().received.load(), 2u);
}

TEST(PushTimed, TheServerIsToldOfEachSubscribeAndUnsubscribe) {
  Server s(PushPattern::timed, Nanos{10'000'000});
  SubscriptionChange change;
  EXPECT_FALSE(s.push().next_change(change));
  s.subscribe("fast");
  s.subscribe("slow", QueuePolicy::circular, 5);
  EXPECT_EQ(s.push().subscribers(), 2u);
  ASSERT_TRUE(s.push().next_change(change));
  EXPECT_EQ(change.kind, SubscriptionChange::Kind::subscribe);
  EXPECT_STREQ(change.subscriber, "B.fast");
  EXPECT_EQ(change.every, 1u);
  EXPECT_EQ(change.subscribers, 1u);
  ASSERT_TRUE(s.push().next_change(change));
  EXPECT_STREQ(change.subscriber, "B.slow");
  EXPECT_EQ(change.every, 5u);
  EXPECT_EQ(change.subscribers, 2u);
  s.out.connections().remove(*s.connections[0]);
  ASSERT_TRUE(s.push().next_change(change));
  EXPECT_EQ(change.kind, SubscriptionChange::Kind::unsubscribe);
  EXPECT_STREQ(change.subscriber, "B.fast");
  EXPECT_EQ(change.subscribers, 1u);
  EXPECT_FALSE(s.push().next_change(change));
}

TEST(PushTimed, TheOldestChangesGoWhenTheComponentDoesNotLook) {
  Server s(PushPattern::timed, Nanos{10'000'000});
  for (int i = 0; i < 40; ++i) s.subscribe("s" + std::to_string(i));
  EXPECT_EQ(s.push().counters().changes_lost.load(), 8u);
  SubscriptionChange change;
  ASSERT_TRUE(s.push().next_change(change));
  EXPECT_STREQ(change.subscriber, "B.s8");
}

// A component's client port: subscribe(every) and unsubscribe() on its input port.
class Client final : public ComponentBase {
 public:
  PushClientPort<Value> in{*this, "in"};
};
class ServerComponent final : public ComponentBase {
 public:
  PushServerPort<Value> out{*this, "out"};
};

TEST(PushTimed, AClientSubscribesAndUnsubscribesOnItsInputPort) {
  Server s(PushPattern::timed, Nanos{10'000'000});
  Client client;
  DataInPort& in = s.b.add_port<DataInPort>("in", PortKind::data, nullptr, kBytes, QueuePolicy::circular, 8);
  *client.port_declarations().front().bound = &in;
  ServerComponent server;
  *server.port_declarations().front().bound = &s.out;

  Value v = 0;
  EXPECT_EQ(client.in.subscribe(2), Status::not_connected);  // nothing connected yet
  s.connect(in, QueuePolicy::circular);
  EXPECT_EQ(client.in.subscribe(0), Status::bad_size);
  ASSERT_EQ(client.in.subscribe(2), Status::ok);
  for (Value i = 1; i <= 4; ++i) EXPECT_EQ(server.out.put(i), Status::ok);
  std::vector<Value> got;
  while (client.in.get_update(v) == Status::ok) got.push_back(v);
  EXPECT_EQ(got, (std::vector<Value>{1, 3}));
  ASSERT_EQ(client.in.unsubscribe(), Status::ok);
  server.out.put(5);
  EXPECT_EQ(client.in.get_update(v), Status::no_data);
  EXPECT_FALSE(s.connections[0]->subscribed());

  // The server saw: the connection, the client's subscribe(2), its unsubscribe.
  EXPECT_EQ(server.out.subscribers(), 1u);
  SubscriptionChange change;
  std::vector<std::pair<SubscriptionChange::Kind, std::uint32_t>> seen;
  while (server.out.next_change(change)) seen.emplace_back(change.kind, change.every);
  EXPECT_EQ(seen, (std::vector<std::pair<SubscriptionChange::Kind, std::uint32_t>>{
                      {SubscriptionChange::Kind::subscribe, 1},
                      {SubscriptionChange::Kind::subscribe, 2},
                      {SubscriptionChange::Kind::unsubscribe, 2}}));

  server.out.stop();
  EXPECT_FALSE(server.out.active());
  EXPECT_EQ(server.out.put(6), Status::not_active);
  EXPECT_EQ(client.in.get_update(v), Status::not_active);
}

// Subscribers connected while the writer writes as fast as it can: each gets the latest value
// at once and then every later one, in order, none twice and none missed (the priming and the
// writer's forwarding never interleave on a connection).
TEST(PushNewest, SubscribersConnectedWhileTheWriterWritesMissNothingAndGetNothingTwice) {
  Server s(PushPattern::newest);
  constexpr int kSubscribers = 20;
  constexpr Value kStretch = 3'000;  // writes between two subscribers
  constexpr Value kWrites = (kSubscribers + 1) * kStretch;
  constexpr std::uint32_t kDepth = 1U << 16;  // holds every sample a subscriber can get
  std::atomic<Value> written{0};
  std::atomic<int> connected{0};
  // The writer never runs more than one stretch ahead of the subscribers: the i-th connects
  // while the writer is within its i-th stretch (or waits at its end).
  std::thread writer([&] {
    for (Value v = 1; v <= kWrites; ++v) {
      if (v % kStretch == 0) {
        while (connected.load(std::memory_order_acquire) < static_cast<int>(std::min<Value>(v / kStretch, kSubscribers))) {
          std::this_thread::yield();
        }
      }
      s.write(v);
      written.store(v, std::memory_order_release);
    }
  });
  std::vector<DataInPort*> subscribers;
  for (int i = 0; i < kSubscribers; ++i) {
    while (written.load(std::memory_order_acquire) <= static_cast<Value>(i) * kStretch) std::this_thread::yield();
    DataInPort& in = s.b.add_port<DataInPort>("late" + std::to_string(i), PortKind::data, nullptr, kBytes,
                                              QueuePolicy::buffer, kDepth);
    s.connections.push_back(std::make_unique<Connection>(s.out, in, QueuePolicy::buffer, kDepth));
    in.connections().add(*s.connections.back());
    s.out.connections().add(*s.connections.back());
    subscribers.push_back(&in);
    connected.store(i + 1, std::memory_order_release);
  }
  writer.join();
  for (DataInPort* in : subscribers) {
    const std::vector<Value> got = drain(*in);
    ASSERT_FALSE(got.empty()) << in->name();
    EXPECT_EQ(got.back(), kWrites) << in->name();
    for (std::size_t i = 1; i < got.size(); ++i) {
      ASSERT_EQ(got[i], got[i - 1] + 1) << in->name() << " at " << i;
    }
  }
}

// A multiple as large as the counter goes still subscribes (it is not taken for the
// "unsubscribed" mark), and a push timed server's component keeps its period: its base
// cycle is counted in periods, so another period would change every subscriber's cycle.
TEST(PushTimed, TheLargestMultipleSubscribesAndTheServersPeriodIsKept) {
  Server s(PushPattern::timed, Nanos{10'000'000});
  Client client;
  DataInPort& in = s.b.add_port<DataInPort>("in", PortKind::data, nullptr, kBytes, QueuePolicy::circular, 8);
  *client.port_declarations().front().bound = &in;
  s.connect(in, QueuePolicy::circular);
  ASSERT_EQ(client.in.subscribe(UINT32_MAX), Status::ok);
  EXPECT_TRUE(s.connections[0]->subscribed());
  s.write(1);
  s.write(2);
  Value v = 0;
  EXPECT_EQ(client.in.get_update(v), Status::ok);
  EXPECT_EQ(v, 1u);
  EXPECT_EQ(client.in.get_update(v), Status::no_data);  // 2 was skipped

  ServerComponent server;
  *server.port_declarations().front().bound = &s.out;
  server.set_instance("A", {}, 0.01);
  Lifecycle lifecycle(server);
  ExecutionSettings settings;
  settings.name = "push-server";
  settings.period = Nanos{10'000'000};
  ExecutionContext context(settings);
  context.add(lifecycle);
  EXPECT_EQ(server.request_period(0.02), ReturnCode::unsupported);
  EXPECT_EQ(context.period().count, 10'000'000);
  EXPECT_EQ(context.period_changes(), 0u);
}

}  // namespace
}  // namespace polyport
