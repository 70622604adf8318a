#include "socketcan_interceptor.hpp"

#include <linux/can.h>
#include <linux/can/raw.h>
#include <net/if.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <string>

#include <nlohmann/json.hpp>

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

// The id of a received frame as the ports' table spells it: 11 or 29 bits, CAN_EFF_FLAG
// for 29-bit ids, no RTR or error flag.
std::uint32_t frame_key(canid_t id) noexcept {
  return (id & CAN_EFF_FLAG) != 0 ? (id & (CAN_EFF_FLAG | CAN_EFF_MASK)) : (id & CAN_SFF_MASK);
}

std::int64_t ns_of(const timespec& t) noexcept {
  return static_cast<std::int64_t>(t.tv_sec) * 1'000'000'000 + t.tv_nsec;
}

}  // namespace

Status SocketCanInterceptor::FrameWriter::on_sample(const std::byte* data, const SampleMeta& meta) noexcept {
  if (!active.load(std::memory_order_acquire)) return Status::not_active;
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
  const ssize_t written = ::write(fd_.load(std::memory_order_acquire), &frame, size);
  if (written != static_cast<ssize_t>(size)) {
    // EAGAIN / ENOBUFS: the interface's queue is full; the frame is dropped, never waited for.
    counters_.send_failed.fetch_add(1, std::memory_order_relaxed);
    return Status::error;
  }
  counters_.sent.fetch_add(1, std::memory_order_relaxed);
  return Status::ok;
}

SocketCanInterceptor::SocketCanInterceptor(SocketCanAdaptor& adaptor, std::shared_ptr<CanReactor> reactor)
    : adaptor_(adaptor), reactor_(std::move(reactor)) {
  const auto& messages = adaptor_.messages();
  counters_ = std::make_unique<Counters[]>(messages.size());
  for (std::uint32_t i = 0; i < messages.size(); ++i) {
    const SocketCanAdaptor::Message& message = messages[i];
    if (message.out != nullptr) {
      by_can_id_.emplace_back(message.can_id, i);
      writers_.push_back(nullptr);
    } else {
      writers_.push_back(std::make_unique<FrameWriter>(message, fd_, counters_[i]));
      message.in->set_sink(writers_.back().get());  // before wiring: the connection is push mode
    }
  }
  std::sort(by_can_id_.begin(), by_can_id_.end());
}

SocketCanInterceptor::~SocketCanInterceptor() {
  stop();
  if (const int fd = fd_.exchange(-1); fd >= 0) ::close(fd);
}

Result<void> SocketCanInterceptor::open_socket() {
  const SocketCanSettings& settings = adaptor_.settings();
  const std::string& name = settings.interface;
  const std::string where = adaptor_.name() + ": CAN interface '" + name + "'";
  const unsigned ifindex = ::if_nametoindex(name.c_str());
  if (ifindex == 0) {
    return make_error(where + " does not exist (" + errno_text(errno) +
                      "); create it first, e.g. `ip link add dev " + name + " type vcan && ip link set " + name +
                      " up` (waiting for it to appear is planned)");
  }
  const int fd = ::socket(PF_CAN, SOCK_RAW | SOCK_NONBLOCK | SOCK_CLOEXEC, CAN_RAW);
  if (fd < 0) return make_error(where + ": socket(PF_CAN, SOCK_RAW, CAN_RAW): " + errno_text(errno));
  auto fail = [&](const std::string& what) {
    const std::string message = where + ": " + what + ": " + errno_text(errno);
    ::close(fd);
    return make_error(message);
  };
  if (settings.fd) {
    ifreq request{};
    std::snprintf(request.ifr_name, IFNAMSIZ, "%s", name.c_str());
    if (::ioctl(fd, SIOCGIFMTU, &request) != 0) return fail("SIOCGIFMTU");
    if (request.ifr_mtu != static_cast<int>(CANFD_MTU)) {
      ::close(fd);
      return make_error(where + " carries no CAN FD frames (MTU " + std::to_string(request.ifr_mtu) +
                        "), but the profile says <fd>true</fd>; e.g. `ip link set " + name + " mtu 72`");
    }
    const int on = 1;
    if (::setsockopt(fd, SOL_CAN_RAW, CAN_RAW_FD_FRAMES, &on, sizeof on) != 0) return fail("CAN_RAW_FD_FRAMES");
  }
  // Exactly the output ports' ids: the id bits, the EFF flag (an 11-bit id never matches a
  // 29-bit one) and the RTR flag (remote requests carry no data) all in the mask. No filter
  // at all (a component with input ports only) receives nothing.
  std::vector<can_filter> filters;
  for (const auto& [can_id, index] : by_can_id_) {
    const bool extended = (can_id & CAN_EFF_FLAG) != 0;
    filters.push_back(can_filter{can_id, (extended ? CAN_EFF_MASK : CAN_SFF_MASK) | CAN_EFF_FLAG | CAN_RTR_FLAG});
  }
  if (::setsockopt(fd, SOL_CAN_RAW, CAN_RAW_FILTER, filters.empty() ? nullptr : filters.data(),
                   static_cast<socklen_t>(filters.size() * sizeof(can_filter))) != 0) {
    return fail("CAN_RAW_FILTER");
  }
  const int on = 1;
  if (::setsockopt(fd, SOL_SOCKET, SO_TIMESTAMPNS, &on, sizeof on) != 0) return fail("SO_TIMESTAMPNS");
  sockaddr_can address{};
  address.can_family = AF_CAN;
  address.can_ifindex = static_cast<int>(ifindex);
  if (::bind(fd, reinterpret_cast<const sockaddr*>(&address), sizeof address) != 0) return fail("bind");
  fd_.store(fd, std::memory_order_release);
  return {};
}

Result<void> SocketCanInterceptor::start() {
  if (active_) return {};
  if (fd_.load(std::memory_order_acquire) < 0) {
    if (auto opened = open_socket(); !opened) return opened;
  } else {
    drain();  // frames queued while stopped are stale
  }
  timespec mono{};
  timespec real{};
  ::clock_gettime(CLOCK_MONOTONIC, &mono);
  ::clock_gettime(CLOCK_REALTIME, &real);
  realtime_to_mono_ = Nanos{ns_of(mono) - ns_of(real)};
  if (!by_can_id_.empty()) {
    receiving_.store(true, std::memory_order_release);
    if (auto added = reactor_->add(fd_.load(std::memory_order_acquire), *this); !added) {
      receiving_.store(false, std::memory_order_release);
      return make_error(adaptor_.name() + ": " + added.error().message);
    }
    registered_ = true;
  }
  for (auto& writer : writers_) {
    if (writer) writer->active.store(true, std::memory_order_release);
  }
  active_ = true;
  return {};
}

void SocketCanInterceptor::stop() noexcept {
  for (auto& writer : writers_) {
    if (writer) writer->active.store(false, std::memory_order_release);
  }
  receiving_.store(false, std::memory_order_release);
  if (registered_) {
    reactor_->remove(fd_.load(std::memory_order_acquire));
    registered_ = false;
  }
  active_ = false;
}

void SocketCanInterceptor::drain() noexcept {
  canfd_frame frame;
  while (::recv(fd_.load(std::memory_order_acquire), &frame, sizeof frame, MSG_DONTWAIT) > 0) {
  }
}

void SocketCanInterceptor::on_readable() noexcept {
  const int fd = fd_.load(std::memory_order_acquire);
  const auto& messages = adaptor_.messages();
  // A bounded batch per wake-up, so one busy interface cannot starve the others.
  for (int batch = 0; batch < 64; ++batch) {
    canfd_frame frame;
    iovec data{&frame, sizeof frame};
    alignas(cmsghdr) char control[CMSG_SPACE(sizeof(timespec))];
    msghdr header{};
    header.msg_iov = &data;
    header.msg_iovlen = 1;
    header.msg_control = control;
    header.msg_controllen = sizeof control;
    const ssize_t size = ::recvmsg(fd, &header, MSG_DONTWAIT);
    if (size < 0) {
      if (errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR) read_errors_.fetch_add(1, std::memory_order_relaxed);
      return;
    }
    if (!receiving_.load(std::memory_order_acquire)) continue;
    if (size != static_cast<ssize_t>(CAN_MTU) && size != static_cast<ssize_t>(CANFD_MTU)) {
      read_errors_.fetch_add(1, std::memory_order_relaxed);
      continue;
    }
    const std::uint32_t key = frame_key(frame.can_id);
    const auto found = std::lower_bound(by_can_id_.begin(), by_can_id_.end(), std::pair<std::uint32_t, std::uint32_t>{key, 0});
    if (found == by_can_id_.end() || found->first != key) {
      unknown_id_.fetch_add(1, std::memory_order_relaxed);
      continue;
    }
    const SocketCanAdaptor::Message& message = messages[found->second];
    Counters& counters = counters_[found->second];
    counters.received.fetch_add(1, std::memory_order_relaxed);
    if (frame.len != message.dbc->length) {
      counters.bad_length.fetch_add(1, std::memory_order_relaxed);
      continue;
    }
    MonoTime t_source{};
    for (cmsghdr* c = CMSG_FIRSTHDR(&header); c != nullptr; c = CMSG_NXTHDR(&header, c)) {
      if (c->cmsg_level == SOL_SOCKET && c->cmsg_type == SO_TIMESTAMPNS) {
        timespec stamp;
        std::memcpy(&stamp, CMSG_DATA(c), sizeof stamp);
        t_source = MonoTime{ns_of(stamp)} + realtime_to_mono_;
      }
    }
    (void)message.out->write(frame.data, frame.len, t_source);
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
      p["sent"] = counters.sent.load(std::memory_order_relaxed);
      p["send_failed"] = counters.send_failed.load(std::memory_order_relaxed);
      p["bad_length"] = counters.bad_length.load(std::memory_order_relaxed);
    }
    ports.push_back(std::move(p));
  }
  const SocketCanSettings& settings = adaptor_.settings();
  out["socketcan"] = {{"interface", settings.interface},
                      {"fd", settings.fd},
                      {"unknown_id", unknown_id_.load(std::memory_order_relaxed)},
                      {"read_errors", read_errors_.load(std::memory_order_relaxed)},
                      {"ports", std::move(ports)}};
}

}  // namespace polyport::socketcan
