// LCM ping-pong, built from pingpong.lcm with Debian's lcm-gen (C) and liblcm alone: `ping`
// publishes a message on channel PING and waits for the same sequence number on PONG; `pong`
// echoes every PING as a PONG from its handler; `relay` is what a bridge written natively with
// these types does: PING from provider A to B and PONG from B to A, each decoded by the
// generated handler and published again. The runner sets it beside polyportd to tell
// polyport's cost from the four LCM hops'.
//   pingpong_lcm ping PORT SIZE ROUNDS WARMUP [SAMPLES]   one JSON line (pingpong_common.hpp)
//   pingpong_lcm pong PORT SIZE                           until SIGINT / SIGTERM
//   pingpong_lcm relay PORT_A PORT_B SIZE                 until SIGINT / SIGTERM
// PORT picks the provider udpm://239.255.76.67:PORT?ttl=0: each path of the benchmark has its
// own port, so the kernel never hands one path's datagrams to another's sockets.
// Threads: one per program; lcm_handle() runs on main once poll() says a datagram is there.
#include <lcm/lcm.h>
#include <poll.h>

#include <cstdint>
#include <cstdio>
#include <string>

#include "bench_lcm_ping16_t.h"
#include "bench_lcm_ping1k_t.h"
#include "pingpong_common.hpp"

namespace {

using bench::g_stop;
using bench::now_ns;

constexpr const char* kPing = "PING";
constexpr const char* kPong = "PONG";

std::string url_of(int port) { return "udpm://239.255.76.67:" + std::to_string(port) + "?ttl=0"; }

lcm_t* open_lcm(int port) {
  lcm_t* lcm = lcm_create(url_of(port).c_str());
  if (lcm == nullptr) {
    std::fprintf(stderr, "cannot create LCM on %s (does 239.255.76.67 have a route?)\n", url_of(port).c_str());
  }
  return lcm;
}

// The generated functions of one message type.
template <class T>
struct Generated;
template <>
struct Generated<bench_lcm_ping16_t> {
  using Handler = bench_lcm_ping16_t_handler_t;
  static int publish(lcm_t* l, const char* c, const bench_lcm_ping16_t* m) { return bench_lcm_ping16_t_publish(l, c, m); }
  static bool subscribe(lcm_t* l, const char* c, Handler h, void* user) {
    return bench_lcm_ping16_t_subscribe(l, c, h, user) != nullptr;
  }
};
template <>
struct Generated<bench_lcm_ping1k_t> {
  using Handler = bench_lcm_ping1k_t_handler_t;
  static int publish(lcm_t* l, const char* c, const bench_lcm_ping1k_t* m) { return bench_lcm_ping1k_t_publish(l, c, m); }
  static bool subscribe(lcm_t* l, const char* c, Handler h, void* user) {
    return bench_lcm_ping1k_t_subscribe(l, c, h, user) != nullptr;
  }
};

// Handles what arrives on `lcm` until `done()` or `timeout_ms` (< 0: until g_stop).
template <class Done>
bool handle_until(lcm_t* lcm, int timeout_ms, Done done) {
  pollfd p{lcm_get_fileno(lcm), POLLIN, 0};
  const std::int64_t deadline = now_ns() + std::int64_t{timeout_ms} * 1'000'000;
  while (!done()) {
    if (g_stop) return false;
    const std::int64_t left_ms = timeout_ms < 0 ? 100 : (deadline - now_ns()) / 1'000'000;
    if (timeout_ms >= 0 && left_ms < 0) return false;
    if (poll(&p, 1, static_cast<int>(left_ms)) > 0 && lcm_handle(lcm) != 0) return false;
  }
  return true;
}

// A handler publishing every message it gets on `channel` of `to` (pong: back on PONG; relay:
// onward, on the other provider).
template <class T>
struct Forward {
  lcm_t* to;
  const char* channel;
  static void on(const lcm_recv_buf_t*, const char*, const T* msg, void* user) {
    const auto* f = static_cast<const Forward*>(user);
    Generated<T>::publish(f->to, f->channel, msg);
  }
};

template <class T>
int ping(int port, int size, int rounds, int warmup, const char* samples) {
  lcm_t* lcm = open_lcm(port);
  if (lcm == nullptr) return 1;
  std::int64_t echoed = -1;
  Generated<T>::subscribe(
      lcm, kPong,
      [](const lcm_recv_buf_t*, const char*, const T* msg, void* user) { *static_cast<std::int64_t*>(user) = msg->seq; },
      &echoed);
  T sample{};
  // UDP multicast has no discovery: probe until the path answers, with sequence numbers from
  // 2^52 up (above any measured one): positive, so that they survive a path through a model
  // whose seq is unsigned (the cross-model matrix's DDS pong), where polyport saturates a
  // negative one at 0, and exact in a double, so that they survive one whose seq is a DBC
  // signal (the matrix's CAN pong: physical values are doubles).
  const std::int64_t deadline = now_ns() + 30'000'000'000;
  for (std::int64_t probe = std::int64_t{1} << 52;; ++probe) {
    sample.seq = probe;
    Generated<T>::publish(lcm, kPing, &sample);
    if (handle_until(lcm, 100, [&] { return echoed == probe; })) break;
    if (g_stop || now_ns() > deadline) {
      lcm_destroy(lcm);
      return 1;
    }
  }
  const int rc = bench::run_ping(
      "lcm", size, rounds, warmup, samples,
      [&](std::uint64_t seq) {
        sample.seq = static_cast<std::int64_t>(seq);
        return Generated<T>::publish(lcm, kPing, &sample) == 0;
      },
      [&](std::uint64_t seq) {
        return handle_until(lcm, 1000, [&] { return echoed == static_cast<std::int64_t>(seq); });
      });
  lcm_destroy(lcm);
  return rc;
}

template <class T>
int pong(int port) {
  lcm_t* lcm = open_lcm(port);
  if (lcm == nullptr) return 1;
  Forward<T> back{lcm, kPong};
  Generated<T>::subscribe(lcm, kPing, &Forward<T>::on, &back);
  handle_until(lcm, -1, [] { return false; });
  lcm_destroy(lcm);
  return 0;
}

template <class T>
int relay(int port_a, int port_b) {
  lcm_t* a = open_lcm(port_a);
  lcm_t* b = open_lcm(port_b);
  if (a == nullptr || b == nullptr) return 1;
  Forward<T> ping_to_b{b, kPing};
  Forward<T> pong_to_a{a, kPong};
  Generated<T>::subscribe(a, kPing, &Forward<T>::on, &ping_to_b);
  Generated<T>::subscribe(b, kPong, &Forward<T>::on, &pong_to_a);
  pollfd p[2] = {{lcm_get_fileno(a), POLLIN, 0}, {lcm_get_fileno(b), POLLIN, 0}};
  while (!g_stop) {
    if (poll(p, 2, 100) <= 0) continue;
    if ((p[0].revents & POLLIN) != 0 && lcm_handle(a) != 0) break;
    if ((p[1].revents & POLLIN) != 0 && lcm_handle(b) != 0) break;
  }
  lcm_destroy(a);
  lcm_destroy(b);
  return 0;
}

template <class T>
int run(const bench::Command& c) {
  if (c.mode == "ping") return ping<T>(c.domain, c.size, c.rounds, c.warmup, c.samples);
  if (c.mode == "pong") return pong<T>(c.domain);
  return relay<T>(c.domain, c.domain_b);
}

}  // namespace

int main(int argc, char** argv) {
  bench::stop_on_signals();
  const std::optional<bench::Command> c = bench::parse_command(argc, argv);
  if (!c) return 2;
  return c->size == 16 ? run<bench_lcm_ping16_t>(*c) : run<bench_lcm_ping1k_t>(*c);
}
