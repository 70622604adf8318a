// The LCM side of a cross-model relay (relay.hpp): lcm-gen's C types of
// benchmarks/lcm/pingpong.lcm on udpm://239.255.76.67:PORT?ttl=0 (PORT: the domain), channels
// PING and PONG; forwards from the generated handler, which lcm_handle() calls on the relay's
// main thread once poll() says a datagram is there. lcm_publish is thread-safe: the other
// side's receive thread publishes here.
#pragma once

#include <lcm/lcm.h>

#include <cstdint>
#include <cstdio>
#include <cstring>
#include <string>

#include "bench_lcm_ping16_t.h"
#include "bench_lcm_ping1k_t.h"
#include "relay.hpp"

namespace bench::relay {

template <int Size>
struct LcmType;
template <>
struct LcmType<16> {
  using T = bench_lcm_ping16_t;
  static int publish(lcm_t* l, const char* c, const T* m) { return bench_lcm_ping16_t_publish(l, c, m); }
  static bool subscribe(lcm_t* l, const char* c, bench_lcm_ping16_t_handler_t h, void* user) {
    return bench_lcm_ping16_t_subscribe(l, c, h, user) != nullptr;
  }
};
template <>
struct LcmType<1024> {
  using T = bench_lcm_ping1k_t;
  static int publish(lcm_t* l, const char* c, const T* m) { return bench_lcm_ping1k_t_publish(l, c, m); }
  static bool subscribe(lcm_t* l, const char* c, bench_lcm_ping1k_t_handler_t h, void* user) {
    return bench_lcm_ping1k_t_subscribe(l, c, h, user) != nullptr;
  }
};

template <int Size>
class LcmSide final : public Writer {
  using T = typename LcmType<Size>::T;

 public:
  static constexpr const char* kModel = "lcm";
  static constexpr const char* kPing = "PING";
  static constexpr const char* kPong = "PONG";

  bool open(int port, const char* writes) {
    const std::string url = "udpm://239.255.76.67:" + std::to_string(port) + "?ttl=0";
    lcm_ = lcm_create(url.c_str());
    if (lcm_ == nullptr) std::fprintf(stderr, "cannot create LCM on %s (does 239.255.76.67 have a route?)\n", url.c_str());
    writes_ = writes;
    return lcm_ != nullptr;
  }

  bool listen(const char* reads, Writer* onward) {
    onward_ = onward;
    return LcmType<Size>::subscribe(lcm_, reads, &LcmSide::on_message, this);
  }

  bool write(const Fields& fields) override {
    out_.seq = static_cast<std::int64_t>(fields.seq);
    std::memcpy(out_.pad, fields.pad, sizeof out_.pad);
    return LcmType<Size>::publish(lcm_, writes_, &out_) == 0;
  }

  int fd() const { return lcm_get_fileno(lcm_); }
  void handle() { lcm_handle(lcm_); }
  void close() { lcm_destroy(lcm_); }

 private:
  static void on_message(const lcm_recv_buf_t*, const char*, const T* msg, void* user) {
    static_cast<LcmSide*>(user)->onward_->write(Fields{static_cast<std::uint64_t>(msg->seq), msg->pad});
  }

  lcm_t* lcm_ = nullptr;
  const char* writes_ = nullptr;
  Writer* onward_ = nullptr;
  T out_{};
};

}  // namespace bench::relay
