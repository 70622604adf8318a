#include "socketcan_interceptor.hpp"

#include <linux/can.h>
#include <linux/can/bcm.h>
#include <linux/can/error.h>
#include <linux/can/raw.h>
#include <linux/rtnetlink.h>
#include <net/if.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <iterator>
#include <string>
#include <thread>

#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "polyport/base/serial_counter.hpp"
#include "polyport/runtime/component_api.hpp"

#ifndef CANFD_FDF
#define CANFD_FDF 0x04  // kernels from 6.2 on mark every FD frame with it; older headers lack it
#endif

namespace polyport::socketcan {

namespace {

std::string errno_text(int error) { return std::string(std::strerror(error)); }

std::string hex_id(std::uint32_t can_id) {
  char text[16];
  std::snprintf(text, sizeof text, (can_id & CAN_EFF_FLAG) != 0 ? "0x%08X" : "0x%03X", can_id & CAN_EFF_MASK);
  return text;
}

std::int64_t ns_of(const timespec& t) noexcept {
  return static_cast<std::int64_t>(t.tv_sec) * 1'000'000'000 + t.tv_nsec;
}

// A TX_SETUP of one frame: bcm_msg_head, then the frame (can_frame or canfd_frame), contiguous.
struct BcmMessage {
  alignas(8) unsigned char bytes[sizeof(bcm_msg_head) + CANFD_MTU];
};

constexpr const char* kBusStateNames[] = {"error-active", "error-warning", "error-passive", "bus-off", "down", "missing"};
constexpr const char* kErrorKindNames[] = {"other", "error_warning", "error_passive", "bus_off", "restarted", "error_active"};
constexpr const char* kErrorClassNames[] = {"tx_timeout", "lost_arbitration", "controller", "protocol", "transceiver",
                                            "no_ack", "bus_off", "bus_error", "restarted", "counters"};
constexpr const char* kLinkNames[] = {"up", "down", "missing"};

}  // namespace

Status SocketCanInterceptor::FrameWriter::on_sample(const std::byte* data, const SampleMeta& meta) noexcept {
  // Counted in while it runs, so that unschedule() (after `active` is cleared) waits for a
  // sink that saw `active` before it: such a sink could start a broadcast manager task again.
  struct InSink {
    std::atomic<int>& count;
    explicit InSink(std::atomic<int>& c) : count(c) { count.fetch_add(1, std::memory_order_seq_cst); }
    ~InSink() { count.fetch_sub(1, std::memory_order_release); }
  } in_sink(in_sink_);
  if (!active.load(std::memory_order_seq_cst)) return Status::not_active;
  const DbcMessage& dbc = *message_.dbc;
  if (meta.size != dbc.length) {
    counters_.bad_length.fetch_add(1, std::memory_order_relaxed);
    return Status::bad_size;
  }
  canfd_frame frame{};
  frame.can_id = message_.can_id;
  frame.len = static_cast<std::uint8_t>(meta.size);
  std::memcpy(frame.data, data, meta.size);
  std::size_t size = CAN_MTU;  // can_frame and canfd_frame share their first 16 bytes
  if (dbc.fd) {
    frame.flags = static_cast<std::uint8_t>(CANFD_FDF | (dbc.bit_rate_switch ? CANFD_BRS : 0));
    size = CANFD_MTU;
  }
  bool ok = false;
  if (message_.cycle_ms != 0) {
    // Kept for reschedule(): words of the frame under the sequence lock.
    const std::uint32_t sequence = sequence_.load(std::memory_order_relaxed);
    sequence_.store(sequence + 1, std::memory_order_relaxed);
    std::atomic_thread_fence(std::memory_order_release);
    std::uint64_t words[kFrameWords];
    std::memcpy(words, &frame, sizeof frame);
    for (std::size_t i = 0; i < kFrameWords; ++i) last_[i].store(words[i], std::memory_order_relaxed);
    sequence_.store(sequence + 2, std::memory_order_release);
    // The broadcast manager sends it: the first TX_SETUP starts the timer and sends the
    // frame at once (TX_ANNOUNCE); later ones only replace the data of the running task.
    const bool first = !scheduled.load(std::memory_order_acquire);
    ok = setup(frame, size, first);
    if (first && ok) scheduled.store(true, std::memory_order_release);
  } else {
    // Loop prevention (can_reactor.hpp, CanEchoes): recorded before the write, since the
    // reactor may take the looped-back frame before write() returns.
    std::uint32_t readers = readers_.load(std::memory_order_acquire);
    if (reads_own_id_ && readers != 0) --readers;  // the sending socket does not get its own frames
    std::uint64_t fingerprint = 0;
    if (readers != 0) {
      fingerprint = frame_fingerprint(frame.can_id, frame.len, frame.data);
      // Now, not the sample's entry time: a polled or rate-limited connection hands a sample
      // on up to its period later, and an entry stamped then could be expired before it is sent.
      if (!echoes_.table.expect(fingerprint, readers, mono_now()))
        counters_.echo_unrecorded.fetch_add(1, std::memory_order_relaxed);
    }
    const int fd = fd_.load(std::memory_order_acquire);
    // On the reactor's own thread with io_uring: out with its next wait, counted when done.
    if (reactor_.send_with_next_wait(fd, &frame, static_cast<std::uint32_t>(size), *this,
                                     readers != 0 ? fingerprint : 0)) {
      return Status::ok;
    }
    ok = ::write(fd, &frame, size) == static_cast<ssize_t>(size);
    if (!ok && readers != 0) echoes_.table.forget(fingerprint);
  }
  if (!ok) {
    // EAGAIN / ENOBUFS: the interface's queue is full; the frame is dropped, never waited for.
    // ENXIO / ENODEV / ENETDOWN: the interface is gone or down; the tick re-attaches.
    counters_.send_failed.fetch_add(1, std::memory_order_relaxed);
    return Status::error;
  }
  counters_.sent.fetch_add(1, std::memory_order_relaxed);
  return Status::ok;
}

void SocketCanInterceptor::FrameWriter::on_send_done(int result, std::uint64_t cookie) noexcept {
  if (result >= 0) {
    counters_.sent.fetch_add(1, std::memory_order_relaxed);
    return;
  }
  if (cookie != 0) echoes_.table.forget(cookie);
  counters_.send_failed.fetch_add(1, std::memory_order_relaxed);
}

bool SocketCanInterceptor::FrameWriter::setup(const canfd_frame& frame, std::size_t frame_size, bool first) noexcept {
  bcm_msg_head head{};
  head.opcode = TX_SETUP;
  head.can_id = message_.can_id;
  head.nframes = 1;
  head.flags = (first ? SETTIMER | STARTTIMER | TX_ANNOUNCE : 0U) | (message_.dbc->fd ? CAN_FD_FRAME : 0U);
  head.count = 0;
  head.ival2.tv_sec = static_cast<long>(message_.cycle_ms / 1000);
  head.ival2.tv_usec = static_cast<long>(message_.cycle_ms % 1000) * 1000;
  BcmMessage message;
  std::memcpy(message.bytes, &head, sizeof head);
  std::memcpy(message.bytes + sizeof head, &frame, frame_size);
  const std::size_t size = sizeof head + frame_size;
  return ::write(bcm_fd_.load(std::memory_order_acquire), message.bytes, size) == static_cast<ssize_t>(size);
}

void SocketCanInterceptor::FrameWriter::reschedule() noexcept {
  if (message_.cycle_ms == 0 || !active.load(std::memory_order_acquire)) return;
  std::uint64_t words[kFrameWords];
  for (;;) {
    const std::uint32_t before = sequence_.load(std::memory_order_acquire);
    if (before == 0) return;  // no sample yet: nothing to send
    if ((before & 1U) != 0) continue;  // the sink is writing it now
    for (std::size_t i = 0; i < kFrameWords; ++i) words[i] = last_[i].load(std::memory_order_relaxed);
    std::atomic_thread_fence(std::memory_order_acquire);
    if (sequence_.load(std::memory_order_relaxed) == before) break;
  }
  canfd_frame frame;
  std::memcpy(&frame, words, sizeof frame);
  // A sink that runs now may start the task too (it sees scheduled false): both TX_SETUPs
  // start the same task, the later data wins.
  if (setup(frame, message_.dbc->fd ? CANFD_MTU : CAN_MTU, true)) scheduled.store(true, std::memory_order_release);
}

void SocketCanInterceptor::FrameWriter::unschedule() noexcept {
  // `active` is false now (stop); a sink that saw it true is past its TX_SETUP once it is out.
  while (in_sink_.load(std::memory_order_acquire) != 0) std::this_thread::yield();
  if (!scheduled.exchange(false, std::memory_order_acq_rel)) return;
  bcm_msg_head head{};
  head.opcode = TX_DELETE;
  head.can_id = message_.can_id;
  (void)::write(bcm_fd_.load(std::memory_order_acquire), &head, sizeof head);
}

// ---- CanReactor: link notifications ----------------------------------------------------------

CanReactor::~CanReactor() {
  if (links_.fd >= 0) {
    remove(links_.fd);  // the handler is not running, and is not called again
    ::close(links_.fd);
  }
}

Result<void> CanReactor::watch_links() {
  if (links_outcome_) return *links_outcome_;
  links_outcome_ = open_links();
  if (!*links_outcome_) {
    spdlog::warn("SocketCAN: no link notifications from the kernel ({}): interface changes are found by the "
                 "check every {} ms",
                 links_outcome_->error().message, tick_interval().count());
  }
  return *links_outcome_;
}

Result<void> CanReactor::open_links() {
  const int fd = ::socket(AF_NETLINK, SOCK_RAW | SOCK_NONBLOCK | SOCK_CLOEXEC, NETLINK_ROUTE);
  if (fd < 0) return make_error(std::string("netlink socket: ") + std::strerror(errno));
  sockaddr_nl address{};
  address.nl_family = AF_NETLINK;
  address.nl_groups = RTMGRP_LINK;
  if (::bind(fd, reinterpret_cast<const sockaddr*>(&address), sizeof address) != 0) {
    const int error = errno;
    ::close(fd);
    return make_error(std::string("netlink bind to RTMGRP_LINK: ") + std::strerror(error));
  }
  links_.fd = fd;  // before add(): the handler reads it on the reactor thread
  if (auto added = add(fd, links_); !added) {
    links_.fd = -1;
    ::close(fd);
    return added;
  }
  links_.watched.store(true, std::memory_order_release);
  return {};
}

void CanReactor::Links::on_readable() noexcept {
  // Reads every queued notification and runs the tick once for all of them. The socket is in
  // RTMGRP_LINK alone, so every message is an RTM_NEWLINK or RTM_DELLINK (a link added or
  // deleted, its flags changed): any one is a change, whole or cut short by the buffer.
  // ENOBUFS: the kernel dropped some (the socket's buffer was full), so something may have.
  alignas(nlmsghdr) char buffer[8192];
  bool changed = false;
  for (;;) {
    const ssize_t n = ::recv(fd, buffer, sizeof buffer, MSG_DONTWAIT);
    if (n < 0) {
      if (errno == EINTR) continue;
      if (errno == ENOBUFS) {
        changed = true;
        continue;
      }
      break;  // EAGAIN: all read
    }
    if (n == 0) break;
    changed = true;
  }
  if (!changed) return;
  notifications.fetch_add(1, std::memory_order_relaxed);
  reactor->tick_now();
}

// ---- SocketCanInterceptor -------------------------------------------------------------------

SocketCanInterceptor::SocketCanInterceptor(SocketCanAdaptor& adaptor, std::shared_ptr<CanReactor> reactor)
    : adaptor_(adaptor), reactor_(std::move(reactor)), echoes_(reactor_->echoes(adaptor_.settings().interface)) {
  const auto& messages = adaptor_.messages();
  counters_ = std::make_unique<Counters[]>(messages.size());
  auto reads = [&messages](std::uint32_t can_id) {
    for (const auto& m : messages) {
      if (m.out != nullptr && m.can_id == can_id) return true;
    }
    return false;
  };
  for (std::uint32_t i = 0; i < messages.size(); ++i) {
    const SocketCanAdaptor::Message& message = messages[i];
    if (message.out != nullptr) {
      writers_.push_back(nullptr);
    } else {
      writers_.push_back(
          std::make_unique<FrameWriter>(message, fd_, bcm_fd_, counters_[i], echoes_, reads(message.can_id), *reactor_));
      message.in->set_sink(writers_.back().get());  // before wiring: the connection is push mode
      periodic_ = periodic_ || message.cycle_ms != 0;
    }
  }
}

SocketCanInterceptor::~SocketCanInterceptor() {
  stop();
  // Frames handed to the reactor name the socket and the writer: both stay until they are out.
  for (auto& writer : writers_) {
    if (writer) writer->wait_sends_done();
  }
  if (const int fd = fd_.exchange(-1); fd >= 0) ::close(fd);
  if (const int fd = bcm_fd_.exchange(-1); fd >= 0) ::close(fd);
}

std::string SocketCanInterceptor::where() const {
  return adaptor_.name() + ": CAN interface '" + adaptor_.settings().interface + "'";
}

Result<void> SocketCanInterceptor::create_sockets() {
  const int fd = ::socket(PF_CAN, SOCK_RAW | SOCK_NONBLOCK | SOCK_CLOEXEC, CAN_RAW);
  if (fd < 0) {
    const int error = errno;
    return make_error(where() + ": socket(PF_CAN, SOCK_RAW, CAN_RAW): " + errno_text(error) +
                      (error == EAFNOSUPPORT || error == EPROTONOSUPPORT
                           ? " (this kernel has no SocketCAN: `modprobe can-raw can-bcm`, or, on a kernel built "
                             "without CAN, run polyportd through scripts/vcan-run)"
                           : ""));
  }
  fd_.store(fd, std::memory_order_release);  // unbound: receives nothing until attach() replaces it
  if (periodic_) {
    const int bcm = ::socket(PF_CAN, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, CAN_BCM);
    if (bcm < 0) {
      return make_error(where() + ": socket(PF_CAN, SOCK_DGRAM, CAN_BCM) for the periodic messages: " +
                        errno_text(errno) + " (load the kernel module: `modprobe can-bcm`)");
    }
    bcm_fd_.store(bcm, std::memory_order_release);
  }
  return {};
}

Result<void> SocketCanInterceptor::attach(int ifindex) {
  const SocketCanSettings& settings = adaptor_.settings();
  const std::string& name = settings.interface;
  const int fd = ::socket(PF_CAN, SOCK_RAW | SOCK_NONBLOCK | SOCK_CLOEXEC, CAN_RAW);
  if (fd < 0) return make_error(where() + ": socket(PF_CAN, SOCK_RAW, CAN_RAW): " + errno_text(errno));
  int bcm = -1;
  auto fail = [&](const std::string& what) {
    const std::string message = where() + ": " + what + ": " + errno_text(errno);
    ::close(fd);
    if (bcm >= 0) ::close(bcm);
    return make_error(message);
  };
  if (settings.fd) {
    ifreq request{};
    std::snprintf(request.ifr_name, IFNAMSIZ, "%s", name.c_str());
    if (::ioctl(fd, SIOCGIFMTU, &request) != 0) return fail("SIOCGIFMTU");
    if (request.ifr_mtu != static_cast<int>(CANFD_MTU)) {
      ::close(fd);
      return make_error(where() + " carries no CAN FD frames (MTU " + std::to_string(request.ifr_mtu) +
                        "), but the profile says <fd>true</fd>; e.g. `ip link set " + name + " mtu 72`");
    }
    const int on = 1;
    if (::setsockopt(fd, SOL_CAN_RAW, CAN_RAW_FD_FRAMES, &on, sizeof on) != 0) return fail("CAN_RAW_FD_FRAMES");
  }
  // Exactly the output ports' ids: the id bits, the EFF flag (an 11-bit id never matches a
  // 29-bit one) and the RTR flag (remote requests carry no data) all in the mask. No filter
  // at all (a component with input ports only) receives no data frame.
  std::vector<can_filter> filters;
  for (const auto& [can_id, index] : adaptor_.received_ids()) {
    const bool extended = (can_id & CAN_EFF_FLAG) != 0;
    filters.push_back(can_filter{can_id, (extended ? CAN_EFF_MASK : CAN_SFF_MASK) | CAN_EFF_FLAG | CAN_RTR_FLAG});
  }
  if (::setsockopt(fd, SOL_CAN_RAW, CAN_RAW_FILTER, filters.empty() ? nullptr : filters.data(),
                   static_cast<socklen_t>(filters.size() * sizeof(can_filter))) != 0) {
    return fail("CAN_RAW_FILTER");
  }
  // Every error frame: they pass CAN_RAW_FILTER only through this mask.
  const can_err_mask_t errors = CAN_ERR_MASK;
  if (::setsockopt(fd, SOL_CAN_RAW, CAN_RAW_ERR_FILTER, &errors, sizeof errors) != 0) return fail("CAN_RAW_ERR_FILTER");
  const int on = 1;
  if (::setsockopt(fd, SOL_SOCKET, SO_TIMESTAMPNS, &on, sizeof on) != 0) return fail("SO_TIMESTAMPNS");
  // The count of frames the kernel dropped because this socket's buffer was full.
  if (::setsockopt(fd, SOL_SOCKET, SO_RXQ_OVFL, &on, sizeof on) != 0) return fail("SO_RXQ_OVFL");
  sockaddr_can address{};
  address.can_family = AF_CAN;
  address.can_ifindex = ifindex;
  if (::bind(fd, reinterpret_cast<const sockaddr*>(&address), sizeof address) != 0) return fail("bind");
  if (periodic_) {
    bcm = ::socket(PF_CAN, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, CAN_BCM);
    if (bcm < 0) return fail("socket(PF_CAN, SOCK_DGRAM, CAN_BCM)");
    if (::connect(bcm, reinterpret_cast<const sockaddr*>(&address), sizeof address) != 0) return fail("BCM connect");
  }
  // Swap them in under the same descriptor numbers: a sink that loaded the number a moment
  // ago writes to the old socket or to the new one, never to a reused number. The old
  // sockets die with their last reference, and the old BCM tasks with them.
  const int old_fd = fd_.load(std::memory_order_acquire);
  // Watched before (or a re-attach whose add failed: tried again now).
  const bool watch = registered_ || rewatch_;
  if (registered_) reactor_->remove_in_tick(old_fd);
  registered_ = false;
  // The new socket counts its drops from 0 (no handler runs now: this is the tick or start).
  dropped_before_.fetch_add(dropped_.exchange(0, std::memory_order_relaxed), std::memory_order_relaxed);
  (void)::dup2(fd, old_fd);
  ::close(fd);
  if (watch) {
    if (auto added = reactor_->add_receiver_in_tick(old_fd, *this); !added) {
      rewatch_ = true;  // the tick's next attempt adds it again
      return make_error(where() + ": " + added.error().message);
    }
    registered_ = true;
    rewatch_ = false;
  }
  if (bcm >= 0) {
    for (auto& writer : writers_) {
      if (writer) writer->scheduled.store(false, std::memory_order_release);  // the next sample starts the task
    }
    (void)::dup2(bcm, bcm_fd_.load(std::memory_order_acquire));
    ::close(bcm);
  }
  return {};
}

bool SocketCanInterceptor::interface_flags(int& ifindex, bool& up) const noexcept {
  ifreq request{};
  std::snprintf(request.ifr_name, IFNAMSIZ, "%s", adaptor_.settings().interface.c_str());
  const int fd = fd_.load(std::memory_order_acquire);
  if (::ioctl(fd, SIOCGIFINDEX, &request) != 0) return false;
  ifindex = request.ifr_ifindex;
  if (::ioctl(fd, SIOCGIFFLAGS, &request) != 0) return false;
  up = (request.ifr_flags & IFF_UP) != 0;
  return true;
}

Result<void> SocketCanInterceptor::start() {
  if (active_) return {};
  if (fd_.load(std::memory_order_acquire) < 0) {
    if (auto created = create_sockets(); !created) return created;
  } else {
    drain();  // frames queued while stopped are stale
  }
  timespec mono{};
  timespec real{};
  ::clock_gettime(CLOCK_MONOTONIC, &mono);
  ::clock_gettime(CLOCK_REALTIME, &real);
  realtime_to_mono_ = Nanos{ns_of(mono) - ns_of(real)};
  const std::string& name = adaptor_.settings().interface;
  if (bound_ifindex_ == 0) {
    int ifindex = 0;
    bool up = false;
    if (interface_flags(ifindex, up)) {
      // A wrong MTU and the like are the profile's mistake: the start fails.
      if (auto attached = attach(ifindex); !attached) return attached;
      bound_ifindex_ = ifindex;
      had_interface_ = true;
      was_up_ = up;
      ifindex_.store(ifindex, std::memory_order_relaxed);
      link_.store(static_cast<int>(up ? Link::up : Link::down), std::memory_order_relaxed);
      if (!up) {
        spdlog::error("{} is down: no frames until it is up (`ip link set {} up`)", where(), name);
        emit(CanBusEventKind::interface_down, CanBusState::down, mono_now());
      }
    } else {
      spdlog::error("{} does not exist; the component runs without it and picks it up when it appears "
                    "(checked every {} ms, and on the kernel's link notifications): for a CAN controller, "
                    "e.g. `ip link set {} up type can bitrate 500000`; for a virtual bus, "
                    "`ip link add dev {} type vcan && ip link set {} up`",
                    where(), reactor_->tick_interval().count(), name, name, name);
      link_.store(static_cast<int>(Link::missing), std::memory_order_relaxed);
      emit(CanBusEventKind::interface_missing, CanBusState::missing, mono_now());
    }
  }
  receiving_.store(true, std::memory_order_release);
  // Always watched: error frames arrive even where no data frame is received.
  if (auto added = reactor_->add_receiver(fd_.load(std::memory_order_acquire), *this); !added) {
    receiving_.store(false, std::memory_order_release);
    return make_error(adaptor_.name() + ": " + added.error().message);
  }
  registered_ = true;
  count_in(true);
  for (auto& writer : writers_) {
    if (writer) writer->active.store(true, std::memory_order_release);
  }
  if (auto watched = reactor_->watch(*this); !watched) {
    stop();
    return make_error(adaptor_.name() + ": " + watched.error().message);
  }
  (void)reactor_->watch_links();  // without them (warned once), the tick alone finds link changes
  active_ = true;
  return {};
}

void SocketCanInterceptor::stop() noexcept {
  reactor_->unwatch(*this);  // from here on no tick touches this interceptor
  for (auto& writer : writers_) {
    if (writer) writer->active.store(false, std::memory_order_seq_cst);  // before unschedule's wait
  }
  for (auto& writer : writers_) {
    if (writer) writer->unschedule();
  }
  receiving_.store(false, std::memory_order_release);
  count_in(false);
  if (registered_) {
    reactor_->remove(fd_.load(std::memory_order_acquire));
    registered_ = false;
  }
  active_ = false;
}

void SocketCanInterceptor::count_in(bool in) noexcept {
  if (counted_in_ == in) return;
  counted_in_ = in;
  for (const SocketCanAdaptor::Message& message : adaptor_.messages()) {
    std::atomic<std::uint32_t>& counter = message.out != nullptr ? echoes_.readers_of(message.can_id) : echoes_.senders;
    if (in) {
      counter.fetch_add(1, std::memory_order_acq_rel);
    } else {
      counter.fetch_sub(1, std::memory_order_acq_rel);
    }
  }
}

void SocketCanInterceptor::drain() noexcept {
  canfd_frame frame;
  while (::recv(fd_.load(std::memory_order_acquire), &frame, sizeof frame, MSG_DONTWAIT) > 0) {
  }
}

void SocketCanInterceptor::emit(CanBusEventKind kind, CanBusState state, MonoTime t_source, std::uint32_t error_class,
                                const std::uint8_t* data) noexcept {
  DataOutPort* port = adaptor_.bus_events();
  if (port == nullptr) return;
  const CanBusEventSample event = bus_event(kind, state, error_class, data);
  (void)port->write(&event, sizeof event, t_source);
  events_.fetch_add(1, std::memory_order_relaxed);
}

void SocketCanInterceptor::on_error_frame(const canfd_frame& frame, MonoTime t_source) noexcept {
  const std::uint32_t error_class = frame.can_id & CAN_ERR_MASK;
  error_frames_.fetch_add(1, std::memory_order_relaxed);
  for (std::uint32_t bit = 0; bit < std::size(error_classes_); ++bit) {
    if ((error_class & (1U << bit)) != 0) error_classes_[bit].fetch_add(1, std::memory_order_relaxed);
  }
  const auto [kind, state] =
      classify_error_frame(error_class, frame.data, static_cast<CanBusState>(bus_state_.load(std::memory_order_relaxed)));
  error_kinds_[static_cast<int>(kind)].fetch_add(1, std::memory_order_relaxed);
  bus_state_.store(static_cast<std::int32_t>(state), std::memory_order_relaxed);
  tx_errors_.store(frame.data[6], std::memory_order_relaxed);
  rx_errors_.store(frame.data[7], std::memory_order_relaxed);
  emit(kind, state, t_source, error_class, frame.data);
}

SocketCanInterceptor::ReceiveBatch::ReceiveBatch() noexcept {
  for (unsigned i = 0; i < kBatch; ++i) {
    data[i] = iovec{&frames[i], sizeof frames[i]};
    headers[i] = mmsghdr{};
    headers[i].msg_hdr.msg_iov = &data[i];
    headers[i].msg_hdr.msg_iovlen = 1;
    headers[i].msg_hdr.msg_control = control[i];
    headers[i].msg_hdr.msg_controllen = kControl;
  }
}

void SocketCanInterceptor::on_readable() noexcept {
  const int fd = fd_.load(std::memory_order_acquire);
  // Up to kBatch frames per system call (recvmmsg); a call that returns fewer has emptied the
  // queue, so no further call is made to learn that (the epoll wait is level-triggered: a
  // frame that arrives meanwhile wakes it again). At most kCalls calls per wake-up, so one
  // busy interface cannot starve the others.
  constexpr int kCalls = 4;
  ReceiveBatch& batch = *batch_;
  for (int call = 0; call < kCalls; ++call) {
    const int count = ::recvmmsg(fd, batch.headers, kBatch, MSG_DONTWAIT, nullptr);
    if (count < 0) {
      if (errno == EAGAIN || errno == EWOULDBLOCK) return;
      if (errno == EINTR) continue;
      // ENODEV: the interface was deleted (the socket is unbound now); ENETDOWN: it was set
      // down. The tick reports both and re-attaches.
      if (errno == ENODEV) lost_.store(true, std::memory_order_release);
      read_errors_.fetch_add(1, std::memory_order_relaxed);
      return;
    }
    const bool receiving = receiving_.load(std::memory_order_acquire);
    for (int i = 0; i < count; ++i) {
      if (receiving) on_frame(batch.frames[i], batch.headers[i].msg_len, batch.headers[i].msg_hdr);
      // The kernel shortened the control length to what it wrote; the next call needs the room.
      batch.headers[i].msg_hdr.msg_controllen = kControl;
    }
    if (static_cast<unsigned>(count) < kBatch) return;
  }
}

void SocketCanInterceptor::on_message(const std::byte* data, std::uint32_t size, const msghdr& header) noexcept {
  if (!receiving_.load(std::memory_order_acquire)) return;
  canfd_frame frame;
  std::memcpy(&frame, data, std::min<std::size_t>(size, sizeof frame));
  on_frame(frame, (header.msg_flags & MSG_TRUNC) != 0 ? 0U : size, header);
}

void SocketCanInterceptor::on_receive_error(int error) noexcept {
  // As recvmmsg's errors in on_readable: ENODEV: deleted (the socket is unbound now);
  // ENETDOWN: set down. The tick reports both and re-attaches.
  if (error == ENODEV) lost_.store(true, std::memory_order_release);
  read_errors_.fetch_add(1, std::memory_order_relaxed);
}

void SocketCanInterceptor::on_frame(const canfd_frame& frame, unsigned size, const msghdr& header_in) noexcept {
  if (size != CAN_MTU && size != CANFD_MTU) {
    read_errors_.fetch_add(1, std::memory_order_relaxed);
    return;
  }
  // CMSG_NXTHDR takes a mutable msghdr; nothing is written through it.
  msghdr& header = const_cast<msghdr&>(header_in);
  MonoTime t_source{};
  for (cmsghdr* c = CMSG_FIRSTHDR(&header); c != nullptr; c = CMSG_NXTHDR(&header, c)) {
    if (c->cmsg_level == SOL_SOCKET && c->cmsg_type == SO_TIMESTAMPNS) {
      timespec stamp;
      std::memcpy(&stamp, CMSG_DATA(c), sizeof stamp);
      t_source = MonoTime{ns_of(stamp)} + realtime_to_mono_;
    } else if (c->cmsg_level == SOL_SOCKET && c->cmsg_type == SO_RXQ_OVFL) {
      std::uint32_t dropped;
      std::memcpy(&dropped, CMSG_DATA(c), sizeof dropped);
      dropped_.store(dropped, std::memory_order_relaxed);
    }
  }
  if ((frame.can_id & CAN_ERR_FLAG) != 0) {
    on_error_frame(frame, t_source);
    return;
  }
  // Loop prevention (can_reactor.hpp, CanEchoes): only a frame sent on this host, only while
  // polyport sends on the interface.
  if ((header.msg_flags & MSG_DONTROUTE) != 0 && echoes_.senders.load(std::memory_order_relaxed) != 0 &&
      !echoes_.table.empty() &&
      echoes_.table.consume(frame_fingerprint(frame.can_id, frame.len, frame.data), mono_now())) {
    loop_dropped_.fetch_add(1, std::memory_order_relaxed);
    return;
  }
  const SocketCanAdaptor::Received got = adaptor_.receive(frame.can_id, frame.data, frame.len, t_source);
  if (got.arrival == SocketCanAdaptor::Arrival::unknown_id) {
    unknown_id_.fetch_add(1, std::memory_order_relaxed);
    return;
  }
  Counters& counters = counters_[got.message];
  add_serial(counters.received);  // the reactor's thread alone counts frames in
  if (got.arrival == SocketCanAdaptor::Arrival::bad_length) counters.bad_length.fetch_add(1, std::memory_order_relaxed);
}

void SocketCanInterceptor::on_tick() noexcept {
  try {
    const std::string& name = adaptor_.settings().interface;
    const auto retry_ms = reactor_->tick_interval().count();
    int ifindex = 0;
    bool up = false;
    const bool exists = interface_flags(ifindex, up);
    const bool lost = lost_.exchange(false, std::memory_order_acq_rel);
    if (bound_ifindex_ != 0 && (!exists || ifindex != bound_ifindex_ || lost)) {
      bound_ifindex_ = 0;
      ifindex_.store(0, std::memory_order_relaxed);
      link_.store(static_cast<int>(Link::missing), std::memory_order_relaxed);
      losses_.fetch_add(1, std::memory_order_release);  // after the state it counts
      last_attach_error_.clear();
      spdlog::error("{} went away (deleted or re-created): no frames are received or sent until it is back; "
                    "picked up again on the kernel's link notification or within {} ms",
                    where(), retry_ms);
      emit(CanBusEventKind::interface_missing, CanBusState::missing, mono_now());
    }
    if (bound_ifindex_ == 0 && exists) {
      if (auto attached = attach(ifindex); !attached) {
        attach_failures_.fetch_add(1, std::memory_order_relaxed);
        if (attached.error().message != last_attach_error_) {
          last_attach_error_ = attached.error().message;
          spdlog::error("{} (retrying every {} ms)", last_attach_error_, retry_ms);
        }
      } else {
        // The periodic messages go on with their last frame; before the counters below, so
        // that whoever sees the return sees the tasks running.
        for (auto& writer : writers_) {
          if (writer) writer->reschedule();
        }
        bound_ifindex_ = ifindex;
        ifindex_.store(ifindex, std::memory_order_relaxed);
        was_up_ = up;
        link_.store(static_cast<int>(up ? Link::up : Link::down), std::memory_order_relaxed);
        bus_state_.store(static_cast<std::int32_t>(CanBusState::active), std::memory_order_relaxed);
        if (had_interface_) recoveries_.fetch_add(1, std::memory_order_release);  // after everything above
        had_interface_ = true;
        last_attach_error_.clear();
        spdlog::info("{} is back (ifindex {}, {}): sockets re-created and re-bound, filters set", where(), ifindex,
                     up ? "up" : "down");
        emit(CanBusEventKind::interface_back, up ? CanBusState::active : CanBusState::down, mono_now());
      }
    }
    if (bound_ifindex_ != 0 && up != was_up_) {
      was_up_ = up;
      link_.store(static_cast<int>(up ? Link::up : Link::down), std::memory_order_relaxed);
      if (up) {
        came_up_.fetch_add(1, std::memory_order_release);
        spdlog::info("{} is up again", where());
        emit(CanBusEventKind::interface_up, CanBusState::active, mono_now());
      } else {
        went_down_.fetch_add(1, std::memory_order_release);
        spdlog::error("{} is down: no frames until it is up again (`ip link set {} up`)", where(), name);
        emit(CanBusEventKind::interface_down, CanBusState::down, mono_now());
      }
    }
    const std::int32_t bus_state = bus_state_.load(std::memory_order_relaxed);
    if (bus_state != logged_bus_state_) {
      logged_bus_state_ = bus_state;
      if (bus_state == static_cast<std::int32_t>(CanBusState::bus_off)) {
        spdlog::error("{}: bus-off: the controller sends and receives nothing until it restarts "
                      "(e.g. `ip link set {} type can restart-ms 100`)",
                      where(), name);
      } else if (bus_state == static_cast<std::int32_t>(CanBusState::active)) {
        spdlog::info("{}: bus state error-active", where());
      } else {
        spdlog::warn("{}: bus state {} (tx errors {}, rx errors {})", where(), kBusStateNames[bus_state],
                     tx_errors_.load(std::memory_order_relaxed), rx_errors_.load(std::memory_order_relaxed));
      }
    }
  } catch (...) {
    // No memory for a log line: the next tick tries again.
  }
}

ReturnCode SocketCanInterceptor::command(LifecycleCommand command) { return start_stop_command(*this, command); }

InterceptorStatus SocketCanInterceptor::status() const {
  return InterceptorStatus{active_ ? "active" : "inactive", 0, 0};
}

void SocketCanInterceptor::describe(nlohmann::json& out) const {
  nlohmann::json ports = nlohmann::json::array();
  const auto& messages = adaptor_.messages();
  for (std::size_t i = 0; i < messages.size(); ++i) {
    const SocketCanAdaptor::Message& message = messages[i];
    const Counters& counters = counters_[i];
    nlohmann::json p{{"port", message.out ? message.out->name() : message.in->name()},
                     {"can_id", hex_id(message.can_id)},
                     {"message", message.name},
                     {"length", message.dbc->length},
                     {"polyport", message.out ? "receives" : "sends"}};
    if (message.out != nullptr) {
      p["received"] = counters.received.load(std::memory_order_relaxed);
      p["bad_length"] = counters.bad_length.load(std::memory_order_relaxed);
    } else {
      p["cycle_ms"] = message.cycle_ms;
      if (message.cycle_ms != 0) p["scheduled"] = writers_[i]->scheduled.load(std::memory_order_relaxed);
      p["sent"] = counters.sent.load(std::memory_order_relaxed);
      p["send_failed"] = counters.send_failed.load(std::memory_order_relaxed);
      if (const auto n = counters.echo_unrecorded.load(std::memory_order_relaxed); n != 0) p["echo_unrecorded"] = n;
      p["bad_length"] = counters.bad_length.load(std::memory_order_relaxed);
    }
    ports.push_back(std::move(p));
  }
  nlohmann::json kinds = nlohmann::json::object();
  for (std::size_t i = 0; i < std::size(error_kinds_); ++i) {
    kinds[kErrorKindNames[i]] = error_kinds_[i].load(std::memory_order_relaxed);
  }
  nlohmann::json classes = nlohmann::json::object();
  for (std::size_t i = 0; i < std::size(error_classes_); ++i) {
    classes[kErrorClassNames[i]] = error_classes_[i].load(std::memory_order_relaxed);
  }
  const SocketCanSettings& settings = adaptor_.settings();
  const DataOutPort* events = adaptor_.bus_events();
  out["socketcan"] = {{"interface", settings.interface},
                      {"io", to_string(reactor_->io())},
                      {"ring_receives", reactor_->ring_receives()},
                      {"fd", settings.fd},
                      {"link", kLinkNames[link_.load(std::memory_order_relaxed)]},
                      {"ifindex", ifindex_.load(std::memory_order_relaxed)},
                      {"losses", losses_.load(std::memory_order_acquire)},
                      {"recoveries", recoveries_.load(std::memory_order_acquire)},
                      {"went_down", went_down_.load(std::memory_order_acquire)},
                      {"came_up", came_up_.load(std::memory_order_acquire)},
                      {"attach_failures", attach_failures_.load(std::memory_order_relaxed)},
                      // Link changes the kernel announced (for any interface), each running the
                      // supervision at once; null where it announces none (netlink refused).
                      {"link_notifications", reactor_->links_watched()
                                                 ? nlohmann::json(reactor_->link_notifications())
                                                 : nlohmann::json()},
                      {"bus",
                       {{"state", kBusStateNames[bus_state_.load(std::memory_order_relaxed)]},
                        {"error_frames", error_frames_.load(std::memory_order_relaxed)},
                        {"kinds", std::move(kinds)},
                        {"classes", std::move(classes)},
                        {"tx_errors", tx_errors_.load(std::memory_order_relaxed)},
                        {"rx_errors", rx_errors_.load(std::memory_order_relaxed)}}},
                      {"bus_events", events != nullptr ? nlohmann::json(events->name()) : nlohmann::json()},
                      {"events", events_.load(std::memory_order_relaxed)},
                      {"unknown_id", unknown_id_.load(std::memory_order_relaxed)},
                      // Frames polyport itself sent on the interface, read back and not forwarded.
                      {"loop_dropped", loop_dropped_.load(std::memory_order_relaxed)},
                      {"read_errors", read_errors_.load(std::memory_order_relaxed)},
                      {"kernel_dropped", dropped_before_.load(std::memory_order_relaxed) +
                                             dropped_.load(std::memory_order_relaxed)},
                      {"ports", std::move(ports)}};
  if (nlohmann::json scheduling = reactor_->scheduling(); !scheduling.is_null()) {
    out["socketcan"]["receive_thread"] = std::move(scheduling);
  }
}

}  // namespace polyport::socketcan
