// CAN ping-pong over raw SocketCAN sockets (the kernel's API alone, no library): `ping` sends a
// classic 8-byte frame with id 0x100 carrying a sequence number and waits for the frame with id
// 0x101 carrying the same one; `pong` answers every 0x100 with a 0x101 of the same bytes;
// `relay` is what a bridge written natively with raw sockets does: 0x100 from interface A to B
// and 0x101 from B to A. The runner sets it beside polyportd to tell polyport's cost from the
// four vcan hops'. Frames are those of pingpong.dbc. The cross-model matrix
// (benchmarks/matrix) sets the same ping and pong against other models' programs, also with
// SIZE 64: CAN FD frames of 64 data bytes (pingpong_fd.dbc: the same ids, seq in the first 8
// bytes, the rest zero; the interface needs the FD MTU, scripts/vcan-run --fd).
//   pingpong_can ping N SIZE ROUNDS WARMUP [SAMPLES]   one JSON line (pingpong_common.hpp)
//   pingpong_can pong N SIZE                           until SIGINT / SIGTERM
//   pingpong_can relay N_A N_B SIZE                    until SIGINT / SIGTERM
//     SIZE  8 (classic frames) or 64 (CAN FD frames)
// N picks the interface vcanN: each path of the benchmark has interfaces of its own. Each
// socket's kernel filter passes only the id it reads.
// Threads: one per program; every read follows a poll() on main, and the relay's one poll()
// covers both of its sockets (one wake-up, one read and one write per frame forwarded).
#include <linux/can.h>
#include <linux/can/raw.h>
#include <net/if.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <string>

#include "pingpong_common.hpp"

namespace {

using bench::g_stop;
using bench::now_ns;

constexpr canid_t kPingId = 0x100;
constexpr canid_t kPongId = 0x101;

// The frames' data bytes: 8 (classic frames) or 64 (FD frames), set once from the command line.
int g_bytes = 8;
using Data = std::uint8_t[CANFD_MAX_DLEN];

// A raw CAN socket on vcanN that reads frames of `reads` alone; -1 (after saying why) on error.
int open_can(int n, canid_t reads) {
  const std::string name = "vcan" + std::to_string(n);
  const int fd = socket(PF_CAN, SOCK_RAW, CAN_RAW);
  if (fd < 0) {
    std::fprintf(stderr, "socket(PF_CAN): %s\n", std::strerror(errno));
    return -1;
  }
  const can_filter filter{reads, CAN_SFF_MASK | CAN_EFF_FLAG | CAN_RTR_FLAG};
  const int fd_frames = g_bytes > CAN_MAX_DLEN ? 1 : 0;
  sockaddr_can address{};
  address.can_family = AF_CAN;
  address.can_ifindex = static_cast<int>(if_nametoindex(name.c_str()));
  if (address.can_ifindex == 0 || setsockopt(fd, SOL_CAN_RAW, CAN_RAW_FILTER, &filter, sizeof filter) != 0 ||
      setsockopt(fd, SOL_CAN_RAW, CAN_RAW_FD_FRAMES, &fd_frames, sizeof fd_frames) != 0 ||
      bind(fd, reinterpret_cast<const sockaddr*>(&address), sizeof address) != 0) {
    std::fprintf(stderr, "%s: %s\n", name.c_str(), std::strerror(errno));
    close(fd);
    return -1;
  }
  return fd;
}

// The size of a frame of g_bytes in the socket API: CAN_MTU or CANFD_MTU (the two structs share
// their layout up to the data bytes).
ssize_t mtu() { return g_bytes > CAN_MAX_DLEN ? CANFD_MTU : CAN_MTU; }

bool send_frame(int fd, canid_t id, const Data& data) {
  canfd_frame frame{};
  frame.can_id = id;
  frame.len = static_cast<std::uint8_t>(g_bytes);
  std::memcpy(frame.data, data, static_cast<std::size_t>(g_bytes));
  return write(fd, &frame, static_cast<std::size_t>(mtu())) == mtu();
}

// Reads one frame into `data` (the socket said one is there).
bool read_one(int fd, Data& data) {
  canfd_frame frame{};
  if (read(fd, &frame, sizeof frame) != mtu() || frame.len != g_bytes) return false;
  std::memcpy(data, frame.data, static_cast<std::size_t>(g_bytes));
  return true;
}

// Reads one frame into `data` when one comes within `timeout_ms`.
bool read_frame(int fd, Data& data, int timeout_ms) {
  pollfd p{fd, POLLIN, 0};
  return poll(&p, 1, timeout_ms) > 0 && read_one(fd, data);
}

std::uint64_t seq_of(const Data& data) {
  std::uint64_t seq = 0;
  for (int i = 7; i >= 0; --i) seq = (seq << 8) | data[i];
  return seq;
}

void put_seq(Data& data, std::uint64_t seq) {
  for (int i = 0; i < 8; ++i) data[i] = static_cast<std::uint8_t>(seq >> (8 * i));
}

// Waits at most a second for the echo of `seq`.
bool echoed(int fd, std::uint64_t seq) {
  const std::int64_t deadline = now_ns() + 1'000'000'000;
  Data data;
  for (std::int64_t left = 1000; left > 0 && !g_stop; left = (deadline - now_ns()) / 1'000'000) {
    if (read_frame(fd, data, static_cast<int>(left)) && seq_of(data) == seq) return true;
  }
  return false;
}

int ping(int n, int rounds, int warmup, const char* samples) {
  const int fd = open_can(n, kPongId);
  if (fd < 0) return 1;
  Data data = {};
  // No discovery on CAN: probe until the path answers, with sequence numbers from 2^52 up
  // (above any measured one): exact in a double, so that they survive a path that decodes the
  // frame into pingpong.dbc's physical values (the cross-model matrix's CAN -> other model),
  // and positive as an LCM pong's signed seq.
  const std::int64_t deadline = now_ns() + 30'000'000'000;
  for (std::uint64_t probe = std::uint64_t{1} << 52;; ++probe) {
    put_seq(data, probe);
    if (send_frame(fd, kPingId, data) && echoed(fd, probe)) break;
    if (g_stop || now_ns() > deadline) {
      close(fd);
      return 1;
    }
  }
  const int rc = bench::run_ping(
      "socketcan", g_bytes, rounds, warmup, samples,
      [&](std::uint64_t seq) {
        put_seq(data, seq);
        return send_frame(fd, kPingId, data);
      },
      [&](std::uint64_t seq) { return echoed(fd, seq); });
  close(fd);
  return rc;
}

int pong(int n) {
  const int fd = open_can(n, kPingId);
  if (fd < 0) return 1;
  Data data;
  while (!g_stop) {
    if (read_frame(fd, data, 100)) send_frame(fd, kPongId, data);
  }
  close(fd);
  return 0;
}

int relay(int a, int b) {
  const int on_a = open_can(a, kPingId);
  const int on_b = open_can(b, kPongId);
  if (on_a < 0 || on_b < 0) return 1;
  pollfd p[2] = {{on_a, POLLIN, 0}, {on_b, POLLIN, 0}};
  Data data;
  while (!g_stop) {
    if (poll(p, 2, 100) <= 0) continue;
    if ((p[0].revents & POLLIN) != 0 && read_one(on_a, data)) send_frame(on_b, kPingId, data);
    if ((p[1].revents & POLLIN) != 0 && read_one(on_b, data)) send_frame(on_a, kPongId, data);
  }
  close(on_a);
  close(on_b);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  bench::stop_on_signals();
  const std::optional<bench::Command> c = bench::parse_command(argc, argv, {8, 64});
  if (!c) return 2;
  g_bytes = c->size;
  if (c->mode == "ping") return ping(c->domain, c->rounds, c->warmup, c->samples);
  if (c->mode == "pong") return pong(c->domain);
  return relay(c->domain, c->domain_b);
}
