#include "admin_server.hpp"

#include <errno.h>
#include <grp.h>
#include <poll.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <map>
#include <sstream>
#include <memory>
#include <vector>

#include <spdlog/spdlog.h>

namespace polyport::daemon {
namespace {

std::string errno_text() { return std::strerror(errno); }

void wake(int fd) {
  const std::uint64_t one = 1;
  [[maybe_unused]] ssize_t n = ::write(fd, &one, sizeof one);
}

void drain_eventfd(int fd) {
  std::uint64_t value = 0;
  [[maybe_unused]] ssize_t n = ::read(fd, &value, sizeof value);
}

struct Client {
  int fd = -1;
  std::uint64_t id = 0;
  admin::LineBuffer in;
  std::string out;
  std::size_t sent = 0;      // bytes of `out` already written
  bool in_flight = false;    // a request waits for its reply
  bool eof = false;          // the peer will send nothing more
  bool closing = false;      // close once `out` is written
  ~Client() {
    if (fd >= 0) ::close(fd);
  }
};

// Writes what the socket takes; false when the client is gone or must be cut off.
bool flush(Client& c) {
  while (c.sent < c.out.size()) {
    const ssize_t n = ::send(c.fd, c.out.data() + c.sent, c.out.size() - c.sent, MSG_NOSIGNAL | MSG_DONTWAIT);
    if (n > 0) {
      c.sent += static_cast<std::size_t>(n);
      continue;
    }
    if (n < 0 && errno == EINTR) continue;
    if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) break;
    return false;
  }
  if (c.sent == c.out.size()) {
    c.out.clear();
    c.sent = 0;
  }
  return c.out.size() - c.sent <= AdminServer::kMaxOutput;
}

// Whether the peer on `fd` (credentials `peer`) has `group` among its groups: its gid, or a
// supplementary group as the kernel recorded them at connect (SO_PEERGROUPS), or, on a kernel
// without that option, as /proc/<pid>/status lists them now.
bool peer_in_group(int fd, const ucred& peer, gid_t group) {
  if (peer.gid == group) return true;
  std::vector<gid_t> groups(64);
  for (int attempt = 0; attempt < 4; ++attempt) {
    socklen_t size = static_cast<socklen_t>(groups.size() * sizeof(gid_t));
    if (::getsockopt(fd, SOL_SOCKET, SO_PEERGROUPS, groups.data(), &size) == 0) {
      groups.resize(size / sizeof(gid_t));
      for (gid_t g : groups) {
        if (g == group) return true;
      }
      return false;
    }
    if (errno != ERANGE) break;
    groups.resize(size / sizeof(gid_t) + 1);
  }
  std::ifstream status("/proc/" + std::to_string(peer.pid) + "/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.rfind("Groups:", 0) != 0) continue;
    std::istringstream list(line.substr(7));
    unsigned long g = 0;
    while (list >> g) {
      if (g == group) return true;
    }
  }
  return false;
}

}  // namespace

Result<gid_t> admin_group(const std::string& name) {
  if (name.empty()) return make_error("--admin-group: an empty group name");
  // A name first; all digits and no such name: a gid.
  std::vector<char> buffer(16384);
  group entry{};
  group* found = nullptr;
  const int rc = ::getgrnam_r(name.c_str(), &entry, buffer.data(), buffer.size(), &found);
  if (rc == 0 && found != nullptr) return found->gr_gid;
  if (name.find_first_not_of("0123456789") == std::string::npos && name.size() < 10) {
    return static_cast<gid_t>(std::strtoul(name.c_str(), nullptr, 10));
  }
  return make_error("--admin-group: no group named '" + name + "'");
}

Result<std::string> default_admin_socket() {
  const std::string dir = admin::default_socket_dir();
  if (::mkdir(dir.c_str(), 0700) != 0 && errno != EEXIST) {
    return make_error("cannot create the admin socket folder '" + dir + "': " + errno_text() +
                      " (choose another with --admin-socket PATH, or --admin-socket none)");
  }
  return dir + "/polyportd-" + std::to_string(::getpid()) + ".sock";
}

AdminServer::~AdminServer() { stop(); }

Result<void> AdminServer::start(const std::string& path, std::optional<gid_t> group) {
  group_ = group;
  sockaddr_un address{};
  address.sun_family = AF_UNIX;
  if (path.size() >= sizeof address.sun_path) {
    return make_error("admin socket path '" + path + "' is longer than " + std::to_string(sizeof address.sun_path - 1) +
                      " bytes");
  }
  std::memcpy(address.sun_path, path.c_str(), path.size() + 1);
  // A socket file left behind: replaced when nobody listens on it.
  struct stat st{};
  if (::lstat(path.c_str(), &st) == 0) {
    if (!S_ISSOCK(st.st_mode)) return make_error("'" + path + "' exists and is not a socket");
    const int probe = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
    const bool live = probe >= 0 && ::connect(probe, reinterpret_cast<sockaddr*>(&address), sizeof address) == 0;
    if (probe >= 0) ::close(probe);
    if (live) return make_error("another daemon listens on the admin socket '" + path + "'");
    ::unlink(path.c_str());
  }
  listen_fd_ = ::socket(AF_UNIX, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (listen_fd_ < 0) return make_error("admin socket: " + errno_text());
  // Created 0600 (0660 with a group) from the start (umask), not chmod-ed after: no window
  // where others may connect. The group is given to it right after: until then the group is
  // the daemon's own, whose members the daemon's user trusts anyway.
  const mode_t old_mask = ::umask(group ? 0117 : 0177);
  const int bound = ::bind(listen_fd_, reinterpret_cast<sockaddr*>(&address), sizeof address);
  const int bind_errno = errno;
  ::umask(old_mask);
  if (bound != 0) {
    ::close(listen_fd_);
    listen_fd_ = -1;
    return make_error("cannot create the admin socket '" + path + "': " + std::strerror(bind_errno));
  }
  path_ = path;
  if (group && ::chown(path.c_str(), static_cast<uid_t>(-1), *group) != 0) {
    const std::string why = errno_text();
    stop();
    return make_error("admin socket '" + path + "': cannot give it to group " + std::to_string(*group) + ": " + why);
  }
  if (::chmod(path.c_str(), group ? 0660 : 0600) != 0 || ::listen(listen_fd_, 16) != 0) {
    const std::string why = errno_text();
    stop();
    return make_error("admin socket '" + path + "': " + why);
  }
  wake_fd_ = ::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
  request_fd_ = ::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
  if (wake_fd_ < 0 || request_fd_ < 0) {
    const std::string why = errno_text();
    stop();
    return make_error("admin socket: eventfd: " + why);
  }
  thread_ = std::thread([this] { loop(); });
  return {};
}

void AdminServer::stop() {
  if (thread_.joinable()) {
    stopping_.store(true);
    wake(wake_fd_);
    thread_.join();
  }
  for (int* fd : {&listen_fd_, &wake_fd_, &request_fd_}) {
    if (*fd >= 0) ::close(*fd);
    *fd = -1;
  }
  if (!path_.empty()) ::unlink(path_.c_str());
  path_.clear();
}

void AdminServer::serve(const Handler& handler, const Left& left) {
  drain_eventfd(request_fd_);
  std::deque<Pending> work;
  std::vector<std::uint64_t> gone;
  {
    std::lock_guard lock(mutex_);
    work.swap(requests_);
    gone.swap(left_);
  }
  if (left) {
    for (std::uint64_t client : gone) left(client);
  }
  if (work.empty()) return;
  for (Pending& p : work) {
    std::string reply;
    try {
      reply = handler(p.request, p.client);
    } catch (const std::exception& e) {
      reply = admin::error_reply(p.request.id, admin::kRefused, std::string("internal error: ") + e.what());
    }
    bool departed = false;
    {
      std::lock_guard lock(mutex_);
      departed = departed_.erase(p.client) > 0;
      if (departed) {
        // Nobody to answer; a stream just opened for it ends at once.
      } else if (reply.empty()) {
        streams_.insert(p.client);  // kStreaming: send() answers
      } else {
        replies_.push_back(Reply{p.client, std::move(reply), true});
      }
    }
    if (departed && reply.empty() && left) left(p.client);
  }
  wake(wake_fd_);
}

void AdminServer::send(std::uint64_t client, std::string lines, bool last) {
  {
    std::lock_guard lock(mutex_);
    if (last) streams_.erase(client);
    replies_.push_back(Reply{client, std::move(lines), last});
  }
  wake(wake_fd_);
}

void AdminServer::loop() {
  std::map<std::uint64_t, std::unique_ptr<Client>> clients;
  std::uint64_t next_id = 1;
  const uid_t own_uid = ::geteuid();
  std::vector<pollfd> fds;
  std::vector<Client*> polled;
  std::string line;
  char buffer[16384];

  // Takes every complete line while no request is in flight; false: cut the client off.
  auto take_lines = [&](Client& c) {
    while (!c.in_flight && !c.closing) {
      const auto next = c.in.next(line);
      if (next == admin::LineBuffer::Next::need_more) break;
      if (next == admin::LineBuffer::Next::too_long) {
        c.out += admin::error_reply(nullptr, admin::kTooLong,
                                    "request longer than " + std::to_string(admin::kMaxRequestLine) +
                                        " bytes; connection closed");
        c.closing = true;
        spdlog::warn("admin socket: a client sent a request line over {} bytes; cut off", admin::kMaxRequestLine);
        break;
      }
      admin::ParseError error;
      std::optional<admin::Request> request = admin::parse_request(line, error);
      if (!request) {
        c.out += admin::error_reply(error.id, error.code, error.message);
        continue;
      }
      {
        std::lock_guard lock(mutex_);
        requests_.push_back(Pending{c.id, std::move(*request)});
      }
      c.in_flight = true;
      wake(request_fd_);
    }
    if (c.eof && !c.in_flight) c.closing = true;
    return flush(c);
  };

  while (!stopping_.load()) {
    fds.clear();
    polled.clear();
    fds.push_back({listen_fd_, POLLIN, 0});
    fds.push_back({wake_fd_, POLLIN, 0});
    for (auto& [id, c] : clients) {
      short events = 0;
      if (!c->in_flight && !c->closing && !c->eof) events |= POLLIN;
      if (c->sent < c->out.size()) events |= POLLOUT;
      fds.push_back({c->fd, events, 0});
      polled.push_back(c.get());
    }
    if (::poll(fds.data(), fds.size(), -1) < 0) {
      if (errno == EINTR) continue;
      break;
    }
    std::vector<std::uint64_t> cut;
    if (fds[1].revents & POLLIN) {
      drain_eventfd(wake_fd_);
      std::deque<Reply> replies;
      {
        std::lock_guard lock(mutex_);
        replies.swap(replies_);
      }
      for (Reply& reply : replies) {
        auto it = clients.find(reply.client);
        if (it == clients.end()) continue;  // the client left meanwhile
        Client& c = *it->second;
        c.out += reply.text;
        if (!reply.last) {
          // A streamed line: the request stays in flight. A client that does not read is cut
          // off here once kMaxOutput waits for it; nothing is held back for it.
          if (!flush(c)) cut.push_back(reply.client);
          continue;
        }
        c.in_flight = false;
        if (!take_lines(c)) cut.push_back(reply.client);
      }
    }
    for (std::size_t i = 0; i < polled.size(); ++i) {
      Client& c = *polled[i];
      const short revents = fds[i + 2].revents;
      if (revents == 0) continue;
      bool keep = true;
      if (revents & POLLIN) {
        // At most a few reads per wake, so one busy client does not starve the others.
        for (int reads = 0; reads < 8 && keep; ++reads) {
          const ssize_t n = ::recv(c.fd, buffer, sizeof buffer, MSG_DONTWAIT);
          if (n > 0) {
            c.in.append(buffer, static_cast<std::size_t>(n));
            if (c.in.buffered() > admin::kMaxRequestLine + 1) break;  // take_lines judges it
            continue;
          }
          if (n == 0) c.eof = true;
          else if (errno == EINTR) continue;
          else if (errno != EAGAIN && errno != EWOULDBLOCK) keep = false;
          break;
        }
        if (keep) keep = take_lines(c);
      } else if (revents & (POLLERR | POLLHUP | POLLNVAL)) {
        keep = false;
      }
      if (keep && (revents & POLLOUT)) keep = flush(c);
      if (!keep) cut.push_back(c.id);
    }
    for (auto& [id, c] : clients) {
      if (c->closing && c->sent == c->out.size() && !c->in_flight) cut.push_back(id);
    }
    bool streams_left = false;
    for (std::uint64_t id : cut) {
      auto it = clients.find(id);
      if (it == clients.end()) continue;
      const Client& c = *it->second;
      if (c.out.size() - c.sent > kMaxOutput) {
        spdlog::warn("admin socket: a client left {} bytes of replies unread; cut off", c.out.size() - c.sent);
      }
      if (c.in_flight) {
        std::lock_guard lock(mutex_);
        if (streams_.erase(id) > 0) {
          left_.push_back(id);
          streams_left = true;
        } else if (std::none_of(replies_.begin(), replies_.end(), [id](const Reply& r) { return r.client == id && r.last; })) {
          departed_.insert(id);  // its request waits for serve(), or is being answered
        }
      }
      clients.erase(it);
    }
    if (streams_left) wake(request_fd_);

    if (fds[0].revents & POLLIN) {
      for (;;) {
        const int fd = ::accept4(listen_fd_, nullptr, nullptr, SOCK_NONBLOCK | SOCK_CLOEXEC);
        if (fd < 0) break;
        auto c = std::make_unique<Client>();
        c->fd = fd;
        c->id = next_id++;
        ucred peer{};
        socklen_t size = sizeof peer;
        if (::getsockopt(fd, SOL_SOCKET, SO_PEERCRED, &peer, &size) != 0) {
          c->out = admin::error_reply(nullptr, admin::kAccessDenied, "access denied: cannot read the peer's credentials");
          c->closing = true;
        } else if (peer.uid != own_uid && peer.uid != 0 && !(group_ && peer_in_group(fd, peer, *group_))) {
          spdlog::warn("admin socket: refused a connection from uid {} (pid {})", peer.uid, peer.pid);
          std::string why = "access denied: uid " + std::to_string(peer.uid) + " is neither the daemon's uid (" +
                            std::to_string(own_uid) + ") nor root";
          if (group_) why += ", and not in the allowed group (gid " + std::to_string(*group_) + ")";
          c->out = admin::error_reply(nullptr, admin::kAccessDenied, why);
          c->closing = true;
        } else if (clients.size() >= kMaxClients) {
          c->out = admin::error_reply(nullptr, admin::kRefused,
                                      "too many clients (" + std::to_string(kMaxClients) + "); try again later");
          c->closing = true;
        }
        if (c->closing) {
          flush(*c);  // best effort; the client is closed right away
          continue;
        }
        clients.emplace(c->id, std::move(c));
      }
    }
  }
}

}  // namespace polyport::daemon
