// What the cross-model relays (relay_<sdk>_<sdk>.cpp) share: a relay is a bridge written with
// two SDKs alone, the native counterpart of polyportd between a ping program of one model and
// a pong program of another. It reads "ping" on the ping program's side and writes each sample
// on the pong program's side, converted field by field into that SDK's generated type (seq and
// pad: what the benchmark's types have in common), and "pong" back the other way. Each SDK's
// side is a class of side_<sdk>.hpp with one writer and one reader:
//   bool open(int domain, const char* writes)         a participant / provider and its writer
//   bool listen(const char* reads, Writer* onward)     its reader, handing every sample onward
//   int fd() / void handle()                           LCM: the socket the main thread polls
//   void close()
//   static constexpr kModel, kPing, kPong              the model and its topic / channel names
//
//   relay_X_Y PING_MODEL DOMAIN_PING DOMAIN_PONG SIZE
//     PING_MODEL  X or Y (e.g. cyclonedds or lcm): the ping program's model; the pong
//                 program's is the other
//     DOMAIN_*    a DDS domain, for LCM the port of udpm://239.255.76.67:PORT?ttl=0, for CAN
//                 the N of the interface vcanN (side_can.hpp)
//     SIZE        16 or 1024 (the ping-pong types of benchmarks/dds/pingpong.idl and
//                 benchmarks/lcm/pingpong.lcm); CAN carries them in classic 8-byte frames and
//                 CAN FD 64-byte frames (side_can.hpp)
//   Runs until SIGINT / SIGTERM.
//
// Threads: a DDS side forwards from its SDK's receive thread (a data-available listener, as
// the same-model pong and relay programs do); an LCM side from the main thread, which polls
// its socket and calls lcm_handle(). Each side's writer is written by one thread only (the
// other side's receiving thread), so the sample it converts into is a member, reused.
#pragma once

#include <poll.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <string>

#include "pingpong_common.hpp"

namespace bench::relay {

// The fields the two types of a relay have in common: what one side hands the other.
struct Fields {
  std::uint64_t seq;
  const std::uint8_t* pad;  // the type's pad array (SIZE - 8 bytes)
};

class Writer {
 public:
  virtual bool write(const Fields& fields) = 0;

 protected:
  ~Writer() = default;
};

template <class PingSide, class PongSide>
int run(int domain_ping, int domain_pong) {
  PingSide a;  // beside the ping program: reads its pings, writes it the pongs
  PongSide b;  // beside the pong program: writes it the pings, reads its pongs
  if (!a.open(domain_ping, PingSide::kPong) || !b.open(domain_pong, PongSide::kPing) ||
      !a.listen(PingSide::kPing, &b) || !b.listen(PongSide::kPong, &a)) {
    std::fprintf(stderr, "cannot open the relay's endpoints\n");
    return 1;
  }
  pollfd p[2] = {{a.fd(), POLLIN, 0}, {b.fd(), POLLIN, 0}};
  while (!g_stop) {
    if (p[0].fd < 0 && p[1].fd < 0) {
      timespec hundred_ms{0, 100'000'000};
      nanosleep(&hundred_ms, nullptr);
      continue;
    }
    if (poll(p, 2, 100) <= 0) continue;  // a negative fd is ignored by poll()
    if ((p[0].revents & POLLIN) != 0) a.handle();
    if ((p[1].revents & POLLIN) != 0) b.handle();
  }
  a.close();
  b.close();
  return 0;
}

template <template <int> class X, template <int> class Y, int Size>
int run_sized(bool x_pings, int domain_ping, int domain_pong) {
  return x_pings ? run<X<Size>, Y<Size>>(domain_ping, domain_pong) : run<Y<Size>, X<Size>>(domain_ping, domain_pong);
}

// The relay's command line (above) for the SDKs X and Y.
template <template <int> class X, template <int> class Y>
int relay_main(int argc, char** argv) {
  stop_on_signals();
  const std::string ping_model = argc == 5 ? argv[1] : "";
  const bool x_pings = ping_model == X<16>::kModel;
  const int size = argc == 5 ? std::atoi(argv[4]) : 0;
  if ((!x_pings && ping_model != Y<16>::kModel) || (size != 16 && size != 1024)) {
    std::fprintf(stderr, "usage: %s %s|%s DOMAIN_PING DOMAIN_PONG SIZE\n       SIZE: 16 or 1024\n", argv[0],
                 X<16>::kModel, Y<16>::kModel);
    return 2;
  }
  const int ping = std::atoi(argv[2]);
  const int pong = std::atoi(argv[3]);
  return size == 16 ? run_sized<X, Y, 16>(x_pings, ping, pong) : run_sized<X, Y, 1024>(x_pings, ping, pong);
}

}  // namespace bench::relay
