#include "lcm_instance.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include <lcm/lcm.h>
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

namespace polyport::lcm {

namespace {

void dispatch(const lcm_recv_buf_t* buffer, const char* /*channel*/, void* user) {
  static_cast<MessageHandler*>(user)->on_message(buffer->data, buffer->data_size);
}

std::string route_advice(const MulticastAddress& address) {
  return "add a route for it, e.g. as root: `ip link set lo multicast on && ip route add " + address.group +
         "/32 dev lo` (this host only), or give the host a default route";
}

// Whether the kernel has a route for the group: connect() on a UDP socket resolves it
// without sending anything.
Result<void> check_route(const MulticastAddress& address, const std::string& url) {
  sockaddr_in to{};
  to.sin_family = AF_INET;
  to.sin_port = htons(static_cast<std::uint16_t>(address.port));
  if (inet_pton(AF_INET, address.group.c_str(), &to.sin_addr) != 1) {
    return make_error("LCM URL '" + url + "': '" + address.group + "' is not an IPv4 multicast group");
  }
  const int fd = socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return make_error(std::string("cannot open a UDP socket: ") + std::strerror(errno));
  const int rc = connect(fd, reinterpret_cast<const sockaddr*>(&to), sizeof to);
  const int error = errno;
  close(fd);
  if (rc != 0) {
    return make_error("LCM URL '" + url + "': no route to multicast group " + address.group + " (" +
                      std::strerror(error) + "); " + route_advice(address));
  }
  return {};
}

}  // namespace

std::string channel_pattern(const std::string& channel) {
  std::string out;
  for (const char c : channel) {
    const bool plain = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_';
    if (!plain) out += '\\';
    out += c;
  }
  return out;
}

MulticastAddress multicast_address(const std::string& url) {
  constexpr std::string_view kScheme = "udpm://";
  if (url.rfind(kScheme, 0) != 0) return {};
  std::string rest = url.substr(kScheme.size());
  rest = rest.substr(0, rest.find('?'));
  MulticastAddress address{"239.255.76.67", 7667};
  if (rest.empty()) return address;
  const std::size_t colon = rest.find(':');
  address.group = rest.substr(0, colon);
  if (colon != std::string::npos) address.port = std::atoi(rest.c_str() + colon + 1);
  return address;
}

std::shared_ptr<FdReactor> Instance::create_reactor() {
  return FdReactor::create("pp-lcm-recv", "the LCM receive thread");
}

std::shared_ptr<Instance> Instance::create(const std::string& url, std::shared_ptr<FdReactor> reactor) {
  return std::shared_ptr<Instance>(new Instance(url, std::move(reactor)));
}

Instance::~Instance() {
  // After remove() the receive thread is past any lcm_handle of this instance.
  if (receiving_) reactor_->remove(fileno_);
  if (lcm_ != nullptr) lcm_destroy(lcm_);
}

Result<void> Instance::start() {
  if (fileno_ >= 0) return {};
  const MulticastAddress address = multicast_address(url_);
  if (!address.group.empty()) {
    // Before lcm_create, which refuses a group without a route and prints its own advice.
    if (auto routed = check_route(address, url_); !routed) return routed;
  }
  if (lcm_ == nullptr) {
    lcm_ = lcm_create(url_.c_str());
    if (lcm_ == nullptr) return make_error("LCM cannot open provider '" + url_ + "' (lcm_create failed)");
  }
  // For udpm this sets up the receive socket and runs LCM's self test (a message to itself).
  fileno_ = lcm_get_fileno(lcm_);
  if (fileno_ < 0) {
    std::string message = "LCM cannot receive on '" + url_ + "'";
    if (!address.group.empty()) {
      message += ": its multicast self test failed (datagrams to " + address.group +
                 " do not come back to this host); " + route_advice(address);
    }
    return make_error(message);
  }
  return {};
}

Result<void> Instance::receive() {
  if (receiving_) return {};
  if (fileno_ < 0) return make_error("LCM provider '" + url_ + "' is not open");
  reads_log_ = url_.rfind("file://", 0) == 0;  // before the receive thread can call on_readable
  if (auto added = reactor_->add(fileno_, *this); !added) {
    return make_error("LCM cannot receive on '" + url_ + "': " + added.error().message);
  }
  receiving_ = true;
  return {};
}

nlohmann::json Instance::scheduling() const { return reactor_->scheduling(); }

void Instance::on_readable() noexcept {
  if (lcm_handle(lcm_) < 0 && reads_log_) {
    // liblcm's file provider at the end of its log: the descriptor stays readable and every
    // lcm_handle returns -1 at once, so the thread would spin on it from now on.
    reactor_->remove_in_tick(fileno_);
    log_ended_.store(true, std::memory_order_release);
  }
}

ChannelEchoes& Instance::echoes(const std::string& channel) {
  auto& echoes = echoes_[channel];
  if (!echoes) echoes = std::make_unique<ChannelEchoes>();
  return *echoes;
}

Result<lcm_subscription_t*> Instance::subscribe(const std::string& channel, MessageHandler& handler) {
  lcm_subscription_t* subscription = lcm_subscribe(lcm_, channel_pattern(channel).c_str(), dispatch, &handler);
  if (subscription == nullptr) return make_error("LCM cannot subscribe to channel '" + channel + "'");
  // LCM queues 30 messages per subscription by default and drops the rest; the handler only
  // hands bytes on, so a deeper queue just rides out a burst.
  (void)lcm_subscription_set_queue_capacity(subscription, 256);
  return subscription;
}

void Instance::unsubscribe(lcm_subscription_t* subscription) noexcept {
  // LCM takes its handler lock here and while a handler runs, so this waits for one in progress.
  (void)lcm_unsubscribe(lcm_, subscription);
}

int Instance::publish(const char* channel, const void* data, std::uint32_t size) noexcept {
  return lcm_publish(lcm_, channel, data, size);
}

}  // namespace polyport::lcm
