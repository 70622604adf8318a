// Fast DDS ping-pong (fastddsgen-generated bench types): `ping` writes a sample on "ping" and
// waits (wait_for_unread_message) for the same sequence number on "pong"; `pong` echoes.
// Same command line and output as pingpong_cyclone. QoS: reliable, keep-last 10, volatile.
// Transports: Fast DDS's default participant profile (the runner points
// FASTRTPS_DEFAULT_PROFILES_FILE at config/fastdds-loopback.xml).
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

template <class PubSub>
Endpoints open(int domain, const char* out, const char* in) {
  Endpoints e;
  e.participant = DomainParticipantFactory::get_instance()->create_participant(domain, PARTICIPANT_QOS_DEFAULT);
  TypeSupport type(new PubSub());
  type.register_type(e.participant);
  Topic* out_topic = e.participant->create_topic(out, type.get_type_name(), TOPIC_QOS_DEFAULT);
  Topic* in_topic = e.participant->create_topic(in, type.get_type_name(), TOPIC_QOS_DEFAULT);
  DataWriterQos wq = DATAWRITER_QOS_DEFAULT;
  wq.reliability().kind = RELIABLE_RELIABILITY_QOS;
  wq.history().kind = KEEP_LAST_HISTORY_QOS;
  wq.history().depth = 10;
  DataReaderQos rq = DATAREADER_QOS_DEFAULT;
  rq.reliability().kind = RELIABLE_RELIABILITY_QOS;
  rq.history().kind = KEEP_LAST_HISTORY_QOS;
  rq.history().depth = 10;
  e.writer = e.participant->create_publisher(PUBLISHER_QOS_DEFAULT)->create_datawriter(out_topic, wq);
  e.reader = e.participant->create_subscriber(SUBSCRIBER_QOS_DEFAULT)->create_datareader(in_topic, rq);
  return e;
}

void close(Endpoints& e) {
  e.participant->delete_contained_entities();
  DomainParticipantFactory::get_instance()->delete_participant(e.participant);
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
int ping(int domain, int rounds, int warmup, int size) {
  Endpoints e = open<PubSub>(domain, "ping", "pong");
  const std::int64_t deadline = now_ns() + 30'000'000'000;
  while (!matched(e)) {
    if (g_stop || now_ns() > deadline) return 1;
    struct timespec ten_ms{0, 10'000'000};
    nanosleep(&ten_ms, nullptr);
  }
  T sample;
  T echo;
  const int rc = bench::run_ping(
      "fastdds", size, rounds, warmup,
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
  close(e);
  return rc;
}

template <class T, class PubSub>
int pong(int domain) {
  Endpoints e = open<PubSub>(domain, "pong", "ping");
  T sample;
  while (!g_stop) {
    if (take_one(e, sample, eprosima::fastrtps::Duration_t(0, 200'000'000))) e.writer->write(&sample);
  }
  close(e);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  bench::stop_on_signals();
  if (argc < 4) {
    std::fprintf(stderr, "usage: %s ping DOMAIN SIZE ROUNDS WARMUP | pong DOMAIN SIZE\n", argv[0]);
    return 2;
  }
  const std::string mode = argv[1];
  const int domain = std::atoi(argv[2]);
  const int size = std::atoi(argv[3]);
  const bool small = size == 16;
  if (!small && size != 1024) return 2;
  if (mode == "ping" && argc >= 6) {
    const int rounds = std::atoi(argv[4]);
    const int warmup = std::atoi(argv[5]);
    return small ? ping<bench::Ping16, bench::Ping16PubSubType>(domain, rounds, warmup, size)
                 : ping<bench::Ping1k, bench::Ping1kPubSubType>(domain, rounds, warmup, size);
  }
  if (mode == "pong") {
    return small ? pong<bench::Ping16, bench::Ping16PubSubType>(domain)
                 : pong<bench::Ping1k, bench::Ping1kPubSubType>(domain);
  }
  return 2;
}
