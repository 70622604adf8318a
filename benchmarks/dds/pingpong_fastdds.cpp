// Fast DDS ping-pong (fastddsgen-generated bench types): `ping` writes a sample on "ping" and
// waits (wait_for_unread_message, main thread) for the same sequence number on "pong"; `pong`
// echoes from on_data_available, on Fast DDS's receive thread, as polyport forwards (and as
// the Cyclone pong does). `relay` forwards "ping" from domain A to B and "pong" from B to A
// with these types, from listeners: a bridge written natively (pingpong_cyclone has the same).
// Same command line and output as pingpong_cyclone (ping, pong, relay). QoS: reliable,
// keep-last 10, volatile.
// Transports: Fast DDS's default participant profile (the runner points
// FASTRTPS_DEFAULT_PROFILES_FILE at config/fastdds-loopback.xml). Data sharing: Fast DDS's
// default (AUTO: the generated types are bounded and keyless, so two of these programs share
// their samples in memory); POLYPORT_BENCH_FASTDDS_DATA_SHARING=off turns it off, which is
// what a hop to or from polyport gets (its raw endpoints switch it off, raw_type.hpp).
#include <atomic>
#include <csignal>
#include <cstdlib>
#include <ctime>
#include <string>
#include <vector>

#include <fastdds/dds/domain/DomainParticipant.hpp>
#include <fastdds/dds/domain/DomainParticipantFactory.hpp>
#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/publisher/Publisher.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>
#include <fastdds/dds/topic/TypeSupport.hpp>

#include "fastdds_endpoints.hpp"
#include "pingpong.h"
#include "pingpongPubSubTypes.h"
#include "pingpong_common.hpp"

using namespace eprosima::fastdds::dds;

namespace {

using bench::g_stop;
using bench::now_ns;

struct Endpoints {
  DomainParticipant* participant = nullptr;
  DataWriter* writer = nullptr;
  DataReader* reader = nullptr;
};

// Writes every sample its reader takes to `writer`, on Fast DDS's receive thread (pong's echo,
// the relay's forward). `writer` is handed over before the reader exists, so that it is never
// called without one.
template <class T>
class Forward final : public DataReaderListener {
 public:
  DataWriter* writer = nullptr;

  void on_data_available(DataReader* reader) override {
    SampleInfo info;
    while (reader->take_next_sample(&sample_, &info) == ReturnCode_t::RETCODE_OK) {
      if (info.valid_data) writer->write(&sample_);
    }
  }

 private:
  T sample_;
};

using bench::fastdds::close;
using bench::fastdds::make_participant;
using bench::fastdds::make_reader;
using bench::fastdds::make_writer;

void wait_for_stop() {
  while (!g_stop) {
    struct timespec hundred_ms{0, 100'000'000};
    nanosleep(&hundred_ms, nullptr);
  }
}

bool matched(const Endpoints& e) {
  PublicationMatchedStatus p;
  SubscriptionMatchedStatus s;
  e.writer->get_publication_matched_status(p);
  e.reader->get_subscription_matched_status(s);
  return p.current_count > 0 && s.current_count > 0;
}

template <class T>
bool take_one(const Endpoints& e, T& sample, const eprosima::fastrtps::Duration_t& timeout) {
  SampleInfo info;
  for (;;) {
    if (e.reader->take_next_sample(&sample, &info) == ReturnCode_t::RETCODE_OK) {
      if (info.valid_data) return true;
      continue;
    }
    if (g_stop || !e.reader->wait_for_unread_message(timeout)) return false;
  }
}

template <class T, class PubSub>
int ping(int domain, int rounds, int warmup, int size, const char* samples) {
  Endpoints e;
  e.participant = make_participant<PubSub>(domain);
  e.writer = make_writer<PubSub>(e.participant, "ping");
  e.reader = make_reader<PubSub>(e.participant, "pong");
  const std::int64_t deadline = now_ns() + 30'000'000'000;
  while (!matched(e)) {
    if (g_stop || now_ns() > deadline) return 1;
    struct timespec ten_ms{0, 10'000'000};
    nanosleep(&ten_ms, nullptr);
  }
  T sample;
  T echo;
  const int rc = bench::run_ping(
      "fastdds", size, rounds, warmup, samples,
      [&](std::uint64_t seq) {
        sample.seq(seq);
        return e.writer->write(&sample);
      },
      [&](std::uint64_t seq) {
        while (take_one(e, echo, eprosima::fastrtps::Duration_t(1, 0))) {
          if (echo.seq() == seq) return true;
        }
        return false;
      });
  close(e.participant);
  return rc;
}

template <class T, class PubSub>
int pong(int domain) {
  Forward<T> echo;
  DomainParticipant* participant = make_participant<PubSub>(domain);
  echo.writer = make_writer<PubSub>(participant, "pong");
  make_reader<PubSub>(participant, "ping", &echo);
  wait_for_stop();
  close(participant);
  return 0;
}

template <class T, class PubSub>
int relay(int a, int b) {
  Forward<T> ping_to_b;
  Forward<T> pong_to_a;
  DomainParticipant* on_a = make_participant<PubSub>(a);
  DomainParticipant* on_b = make_participant<PubSub>(b);
  ping_to_b.writer = make_writer<PubSub>(on_b, "ping");
  pong_to_a.writer = make_writer<PubSub>(on_a, "pong");
  make_reader<PubSub>(on_a, "ping", &ping_to_b);
  make_reader<PubSub>(on_b, "pong", &pong_to_a);
  wait_for_stop();
  close(on_a);
  close(on_b);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  bench::stop_on_signals();
  const std::optional<bench::Command> c = bench::parse_command(argc, argv);
  if (!c) return 2;
  const bool small = c->size == 16;
  if (c->mode == "ping") {
    return small ? ping<bench::Ping16, bench::Ping16PubSubType>(c->domain, c->rounds, c->warmup, c->size, c->samples)
                 : ping<bench::Ping1k, bench::Ping1kPubSubType>(c->domain, c->rounds, c->warmup, c->size, c->samples);
  }
  if (c->mode == "pong") {
    return small ? pong<bench::Ping16, bench::Ping16PubSubType>(c->domain)
                 : pong<bench::Ping1k, bench::Ping1kPubSubType>(c->domain);
  }
  return small ? relay<bench::Ping16, bench::Ping16PubSubType>(c->domain, c->domain_b)
               : relay<bench::Ping1k, bench::Ping1kPubSubType>(c->domain, c->domain_b);
}
