// The SocketCAN model's one receive thread for every CAN socket of the daemon (an FdReactor,
// interceptors/common/fd_reactor.hpp, named pp-can-recv whichever way it waits), with the interface supervision as
// its tick, and the loop-prevention state of each interface. The model hands it out; the
// interceptors hold it; it goes with the last of them.
#pragma once

#include <atomic>
#include <cstdint>
#include <cstring>
#include <map>
#include <memory>
#include <string>

#include "fd_reactor.hpp"
#include "polyport/runtime/echo_table.hpp"

namespace polyport::socketcan {

// Loop prevention on one CAN interface (polyport/runtime/echo_table.hpp). The kernel loops
// every frame a socket sends back to the host's other raw sockets on the interface (not to
// the sender's own: CAN_RAW_RECV_OWN_MSGS is off), marked MSG_DONTROUTE as locally sent, but
// says nothing of which socket sent it. So a raw frame polyport sends on an id that a raw
// socket of polyport's reads on the interface is recorded first (a fingerprint of id, length
// and data, with how many of those sockets will see it), and those sockets drop it. Shared by
// the interceptors of the interface; made and counted on the control thread.
struct CanEchoes {
  EchoTable table;
  std::atomic<std::uint32_t> senders{0};  // polyport's sending ports on the interface, started
  // Polyport's started raw sockets that receive each id; entries stay while the reactor does.
  std::atomic<std::uint32_t>& readers_of(std::uint32_t can_id) {
    auto& readers = readers_[can_id];
    if (!readers) readers = std::make_unique<std::atomic<std::uint32_t>>(0);
    return *readers;
  }

 private:
  std::map<std::uint32_t, std::unique_ptr<std::atomic<std::uint32_t>>> readers_;
};

// The fingerprint of a frame, for CanEchoes: id, length and data bytes.
inline std::uint64_t frame_fingerprint(std::uint32_t can_id, std::uint8_t len, const std::uint8_t* data) noexcept {
  std::uint8_t bytes[sizeof can_id + 1 + 64];
  std::memcpy(bytes, &can_id, sizeof can_id);
  bytes[sizeof can_id] = len;
  const std::size_t n = len <= 64 ? len : 64;
  std::memcpy(bytes + sizeof can_id + 1, data, n);
  return message_fingerprint(bytes, sizeof can_id + 1 + n);
}

class CanReactor final : public FdReactor {
 public:
  // `io`: how the thread waits (FdReactor): the SocketCAN model asks for io_uring where the
  // kernel gives it, so that a frame forwarded CAN -> CAN goes out with the thread's next wait.
  static std::shared_ptr<CanReactor> create(ReactorIo io) { return std::shared_ptr<CanReactor>(new CanReactor(io)); }

  // The loop-prevention state of `interface`; lives as long as the reactor. Control thread.
  CanEchoes& echoes(const std::string& interface) {
    auto& echoes = echoes_[interface];
    if (!echoes) echoes = std::make_unique<CanEchoes>();
    return *echoes;
  }

 private:
  explicit CanReactor(ReactorIo io) : FdReactor("pp-can-recv", "the CAN receive thread", io) {}
  std::map<std::string, std::unique_ptr<CanEchoes>> echoes_;  // control thread
};

}  // namespace polyport::socketcan
