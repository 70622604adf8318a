// Cyclone DDS ping-pong (idlc-generated bench types, C API): `ping` writes a sample on
// "ping" and waits (waitset) for the same sequence number on "pong"; `pong` echoes.
//   pingpong_cyclone ping DOMAIN SIZE ROUNDS WARMUP     prints one JSON line (stats.hpp)
//   pingpong_cyclone pong DOMAIN SIZE                   until SIGINT / SIGTERM
// QoS: reliable, keep-last 10, volatile (polyport's defaults). Clock: CLOCK_MONOTONIC.
#include <atomic>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <string>
#include <vector>

#include "dds/dds.h"
#include "pingpong.h"
#include "pingpong_common.hpp"

namespace {

using bench::g_stop;
using bench::now_ns;

struct Endpoints {
  dds_entity_t participant, writer, reader, waitset;
};

Endpoints open(dds_domainid_t domain, const dds_topic_descriptor_t* type, const char* out, const char* in) {
  Endpoints e{};
  e.participant = dds_create_participant(domain, nullptr, nullptr);
  dds_qos_t* qos = dds_create_qos();
  dds_qset_reliability(qos, DDS_RELIABILITY_RELIABLE, DDS_SECS(1));
  dds_qset_history(qos, DDS_HISTORY_KEEP_LAST, 10);
  e.writer = dds_create_writer(e.participant, dds_create_topic(e.participant, type, out, nullptr, nullptr), qos, nullptr);
  e.reader = dds_create_reader(e.participant, dds_create_topic(e.participant, type, in, nullptr, nullptr), qos, nullptr);
  dds_delete_qos(qos);
  e.waitset = dds_create_waitset(e.participant);
  dds_waitset_attach(e.waitset, dds_create_readcondition(e.reader, DDS_ANY_STATE), 0);
  return e;
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
int ping(dds_domainid_t domain, const dds_topic_descriptor_t* type, int rounds, int warmup, int size) {
  const Endpoints e = open(domain, type, "ping", "pong");
  const std::int64_t deadline = now_ns() + 30'000'000'000;
  while (!matched(e)) {
    if (g_stop || now_ns() > deadline) return 1;
    dds_sleepfor(DDS_MSECS(10));
  }
  T sample{};
  T echo{};
  const int rc = bench::run_ping(
      "cyclonedds", size, rounds, warmup,
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

template <class T>
int pong(dds_domainid_t domain, const dds_topic_descriptor_t* type) {
  const Endpoints e = open(domain, type, "pong", "ping");
  T sample{};
  while (!g_stop) {
    if (take_one(e, &sample, sizeof sample, DDS_MSECS(200))) dds_write(e.writer, &sample);
  }
  dds_delete(e.participant);
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
  const auto domain = static_cast<dds_domainid_t>(std::atoi(argv[2]));
  const int size = std::atoi(argv[3]);
  const bool small = size == 16;
  if (!small && size != 1024) return 2;
  if (mode == "ping" && argc >= 6) {
    const int rounds = std::atoi(argv[4]);
    const int warmup = std::atoi(argv[5]);
    return small ? ping<bench_Ping16>(domain, &bench_Ping16_desc, rounds, warmup, size)
                 : ping<bench_Ping1k>(domain, &bench_Ping1k_desc, rounds, warmup, size);
  }
  if (mode == "pong") {
    return small ? pong<bench_Ping16>(domain, &bench_Ping16_desc) : pong<bench_Ping1k>(domain, &bench_Ping1k_desc);
  }
  return 2;
}
