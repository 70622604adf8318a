// The CAN side of a cross-model relay (relay.hpp): one raw SocketCAN socket (the kernel's API
// alone, as benchmarks/can/pingpong_can.cpp) on vcanN (N: the domain), the frames of
// benchmarks/can/pingpong.dbc: "ping" is id 0x100, "pong" 0x101, classic CAN with 8 data bytes
// carrying seq little-endian, for the 16 B type; for the 1 KiB type those of pingpong_fd.dbc,
// CAN FD frames of 64 data bytes (the interface needs the FD MTU), seq in the first 8, the rest
// zero. The other side's pad is not carried (as via polyport, where the DBC messages have no
// signal for it): dropped on the way to CAN, and all zero on the way from it.
//
// Forwards from the relay's main thread, which polls the socket (fd() / handle()); the other
// side's receive thread writes frames on the same socket (write() on a raw CAN socket is one
// system call per frame, safe beside the main thread's read()).
#pragma once

#include <linux/can.h>
#include <linux/can/raw.h>
#include <net/if.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <string>

#include "relay.hpp"

namespace bench::relay {

template <int Size>
class CanSide final : public Writer {
 public:
  static constexpr const char* kModel = "can";
  static constexpr const char* kPing = "ping";
  static constexpr const char* kPong = "pong";

  bool open(int n, const char* writes) {
    const std::string name = "vcan" + std::to_string(n);
    fd_ = socket(PF_CAN, SOCK_RAW, CAN_RAW);
    sockaddr_can address{};
    address.can_family = AF_CAN;
    address.can_ifindex = static_cast<int>(if_nametoindex(name.c_str()));
    // No filter yet: the socket receives nothing until listen() says which id it reads.
    const int fd_frames = kFd ? 1 : 0;
    if (fd_ < 0 || address.can_ifindex == 0 || setsockopt(fd_, SOL_CAN_RAW, CAN_RAW_FILTER, nullptr, 0) != 0 ||
        setsockopt(fd_, SOL_CAN_RAW, CAN_RAW_FD_FRAMES, &fd_frames, sizeof fd_frames) != 0 ||
        bind(fd_, reinterpret_cast<const sockaddr*>(&address), sizeof address) != 0) {
      std::fprintf(stderr, "%s: %s\n", name.c_str(), std::strerror(errno));
      return false;
    }
    writes_ = id_of(writes);
    return true;
  }

  bool listen(const char* reads, Writer* onward) {
    onward_ = onward;
    const can_filter filter{id_of(reads), CAN_SFF_MASK | CAN_EFF_FLAG | CAN_RTR_FLAG};
    return setsockopt(fd_, SOL_CAN_RAW, CAN_RAW_FILTER, &filter, sizeof filter) == 0;
  }

  bool write(const Fields& fields) override {
    canfd_frame frame{};
    frame.can_id = writes_;
    frame.len = kBytes;
    for (int i = 0; i < 8; ++i) frame.data[i] = static_cast<std::uint8_t>(fields.seq >> (8 * i));
    return ::write(fd_, &frame, kMtu) == static_cast<ssize_t>(kMtu);
  }

  int fd() const { return fd_; }

  void handle() {
    canfd_frame frame{};
    if (read(fd_, &frame, sizeof frame) != static_cast<ssize_t>(kMtu) || frame.len != kBytes) return;
    std::uint64_t seq = 0;
    for (int i = 7; i >= 0; --i) seq = (seq << 8) | frame.data[i];
    static constexpr std::uint8_t kNoPad[Size - 8] = {};
    onward_->write(Fields{seq, kNoPad});
  }

  void close() {
    if (fd_ >= 0) ::close(fd_);
  }

 private:
  static constexpr bool kFd = Size > 16;
  static constexpr std::uint8_t kBytes = kFd ? CANFD_MAX_DLEN : CAN_MAX_DLEN;
  static constexpr std::size_t kMtu = kFd ? CANFD_MTU : CAN_MTU;  // can_frame / canfd_frame: one layout

  static canid_t id_of(const char* message) { return std::strcmp(message, kPing) == 0 ? 0x100 : 0x101; }

  int fd_ = -1;
  canid_t writes_ = 0;
  Writer* onward_ = nullptr;
};

}  // namespace bench::relay
