// Cyclone DDS ping-pong (idlc-generated bench types, C API): `ping` writes a sample on
// "ping" and waits (waitset, main thread) for the same sequence number on "pong"; `pong`
// echoes from a data-available listener, on Cyclone's receive thread, as ddsperf's pong does
// and as polyport forwards: the direct figure is then the SDK's best, not one with an extra
// wake-up of a second thread per hop. `relay` is what a bridge written natively with these
// types does: "ping" from domain A to B and "pong" from B to A, each forwarded from a
// listener; the runner sets it beside polyportd to tell polyport's cost from the SDK hops'.
//   pingpong_cyclone ping DOMAIN SIZE ROUNDS WARMUP [SAMPLES]   one JSON line (pingpong_common.hpp);
//                                                               SAMPLES: every round trip, ns
//   pingpong_cyclone pong DOMAIN SIZE                           until SIGINT / SIGTERM
//   pingpong_cyclone relay DOMAIN_A DOMAIN_B SIZE               until SIGINT / SIGTERM
// QoS: reliable, keep-last 10, volatile (polyport's defaults). Clock: CLOCK_MONOTONIC.
#include <atomic>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <string>
#include <vector>

#include "cyclone_endpoints.hpp"
#include "dds/dds.h"
#include "pingpong.h"
#include "pingpong_common.hpp"

namespace {

using bench::g_stop;
using bench::now_ns;

struct Endpoints {
  dds_entity_t participant, writer, reader, waitset;
};

using bench::cyclone::make_reader;
using bench::cyclone::make_writer;

// On Cyclone's receive thread: writes every sample taken to the writer `arg` points to, from
// the loaned sample (pong's echo, the relay's forward).
void forward(dds_entity_t reader, void* arg) {
  const dds_entity_t writer = *static_cast<const dds_entity_t*>(arg);
  bench::cyclone::take_each(reader, [&](const void* sample) { dds_write(writer, sample); });
}

// A reader whose samples forward() writes to `to`, which must be set and outlive the reader.
dds_entity_t make_forwarding_reader(dds_entity_t participant, const dds_topic_descriptor_t* type, const char* topic,
                                    dds_entity_t* to) {
  return make_reader(participant, type, topic, forward, to);
}

Endpoints open_ping(dds_domainid_t domain, const dds_topic_descriptor_t* type) {
  Endpoints e{};
  e.participant = dds_create_participant(domain, nullptr, nullptr);
  e.writer = make_writer(e.participant, type, "ping");
  e.reader = make_reader(e.participant, type, "pong");
  e.waitset = dds_create_waitset(e.participant);
  dds_waitset_attach(e.waitset, dds_create_readcondition(e.reader, DDS_ANY_STATE), 0);
  return e;
}

void wait_for_stop() {
  while (!g_stop) dds_sleepfor(DDS_MSECS(100));
}

bool matched(const Endpoints& e) {
  dds_publication_matched_status_t p{};
  dds_subscription_matched_status_t s{};
  dds_get_publication_matched_status(e.writer, &p);
  dds_get_subscription_matched_status(e.reader, &s);
  return p.current_count > 0 && s.current_count > 0;
}

// Takes one sample into `sample` (a struct of the bench type); waits at most `timeout`.
bool take_one(const Endpoints& e, void* sample, std::size_t bytes, dds_duration_t timeout) {
  void* buffers[1] = {nullptr};
  dds_sample_info_t info[1];
  for (;;) {
    const dds_return_t n = dds_take(e.reader, buffers, info, 1, 1);
    if (n > 0) {
      const bool valid = info[0].valid_data;
      if (valid) std::memcpy(sample, buffers[0], bytes);
      dds_return_loan(e.reader, buffers, n);
      if (valid) return true;
      continue;
    }
    if (g_stop) return false;
    if (dds_waitset_wait(e.waitset, nullptr, 0, timeout) <= 0) return false;
  }
}

template <class T>
int ping(dds_domainid_t domain, const dds_topic_descriptor_t* type, int rounds, int warmup, int size,
         const char* samples) {
  const Endpoints e = open_ping(domain, type);
  const std::int64_t deadline = now_ns() + 30'000'000'000;
  while (!matched(e)) {
    if (g_stop || now_ns() > deadline) return 1;
    dds_sleepfor(DDS_MSECS(10));
  }
  T sample{};
  T echo{};
  const int rc = bench::run_ping(
      "cyclonedds", size, rounds, warmup, samples,
      [&](std::uint64_t seq) {
        sample.seq = seq;
        return dds_write(e.writer, &sample) == DDS_RETCODE_OK;
      },
      [&](std::uint64_t seq) {
        while (take_one(e, &echo, sizeof echo, DDS_SECS(1))) {
          if (echo.seq == seq) return true;
        }
        return false;
      });
  dds_delete(e.participant);
  return rc;
}

int pong(dds_domainid_t domain, const dds_topic_descriptor_t* type) {
  const dds_entity_t participant = dds_create_participant(domain, nullptr, nullptr);
  static dds_entity_t echo = 0;  // forward()'s argument: set before the reader exists
  echo = make_writer(participant, type, "pong");
  make_forwarding_reader(participant, type, "ping", &echo);
  wait_for_stop();
  dds_delete(participant);
  return 0;
}

int relay(dds_domainid_t a, dds_domainid_t b, const dds_topic_descriptor_t* type) {
  const dds_entity_t on_a = dds_create_participant(a, nullptr, nullptr);
  const dds_entity_t on_b = dds_create_participant(b, nullptr, nullptr);
  static dds_entity_t ping_to_b = 0;  // forward()'s arguments: set before the readers exist
  static dds_entity_t pong_to_a = 0;
  ping_to_b = make_writer(on_b, type, "ping");
  pong_to_a = make_writer(on_a, type, "pong");
  make_forwarding_reader(on_a, type, "ping", &ping_to_b);
  make_forwarding_reader(on_b, type, "pong", &pong_to_a);
  wait_for_stop();
  dds_delete(on_a);
  dds_delete(on_b);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  bench::stop_on_signals();
  const std::optional<bench::Command> c = bench::parse_command(argc, argv);
  if (!c) return 2;
  const bool small = c->size == 16;
  const dds_topic_descriptor_t* type = small ? &bench_Ping16_desc : &bench_Ping1k_desc;
  const auto domain = static_cast<dds_domainid_t>(c->domain);
  if (c->mode == "ping") {
    return small ? ping<bench_Ping16>(domain, type, c->rounds, c->warmup, c->size, c->samples)
                 : ping<bench_Ping1k>(domain, type, c->rounds, c->warmup, c->size, c->samples);
  }
  if (c->mode == "pong") return pong(domain, type);
  return relay(domain, static_cast<dds_domainid_t>(c->domain_b), type);
}
