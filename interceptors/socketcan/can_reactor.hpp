// The SocketCAN model's one receive thread for every CAN socket of the daemon (an FdReactor,
// interceptors/common/fd_reactor.hpp, named pp-can-recv whichever way it waits), with the interface supervision as
// its tick, the kernel's link notifications that run the tick at once, and the loop-prevention
// state of each interface. The model hands it out; the interceptors hold it; it goes with the
// last of them.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <cstring>
#include <map>
#include <memory>
#include <optional>
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
  // `check`: the supervision tick's interval (the interfaces looked up by name).
  static std::shared_ptr<CanReactor> create(ReactorIo io, std::chrono::milliseconds check = kTickInterval) {
    return std::shared_ptr<CanReactor>(new CanReactor(io, check));
  }
  ~CanReactor() override;

  // Link notifications: a NETLINK_ROUTE socket in the RTMGRP_LINK group on the reactor, whose
  // RTM_NEWLINK / RTM_DELLINK messages (an interface added, deleted, set up or down: an adapter
  // plugged in, `ip link add`) run the supervision tick at once instead of at its next
  // tick interval; the tick stays for what the socket may miss (a notification the kernel
  // dropped: ENOBUFS runs the tick as well). Opened on the first call, later calls return
  // its outcome. Control thread. An error (no netlink here) is warned about once and leaves the
  // tick alone to find link changes.
  Result<void> watch_links();
  // Notifications that ran the tick (any thread).
  std::uint64_t link_notifications() const noexcept { return links_.notifications.load(std::memory_order_relaxed); }
  bool links_watched() const noexcept { return links_.watched.load(std::memory_order_acquire); }

  // The loop-prevention state of `interface`; lives as long as the reactor. Control thread.
  CanEchoes& echoes(const std::string& interface) {
    auto& echoes = echoes_[interface];
    if (!echoes) echoes = std::make_unique<CanEchoes>();
    return *echoes;
  }

 private:
  // The netlink socket's handler, on the reactor thread.
  struct Links final : ReadableHandler {
    CanReactor* reactor;
    int fd = -1;  // control thread, before the handler is added
    std::atomic<bool> watched{false};
    std::atomic<std::uint64_t> notifications{0};
    explicit Links(CanReactor* r) : reactor(r) {}
    void on_readable() noexcept override;
  };

  CanReactor(ReactorIo io, std::chrono::milliseconds check)
      : FdReactor("pp-can-recv", "the CAN receive thread", io, check) {}
  Result<void> open_links();
  std::map<std::string, std::unique_ptr<CanEchoes>> echoes_;  // control thread
  Links links_{this};
  std::optional<Result<void>> links_outcome_;  // control thread: watch_links()'s first outcome
};

}  // namespace polyport::socketcan
