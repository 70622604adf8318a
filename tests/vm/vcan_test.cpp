// SocketCAN on vcan0 against real peers (can-utils' candump and cansend, iproute2's ip):
// what the future SocketCAN model will rely on, checked on the kernel itself. Every case
// runs in a guest of its own through scripts/vcan-run (label vm), started with --fd, so
// vcan0 is up with the CAN FD MTU: classic frames and FD frames share it, as on an FD bus.
//
// Waiting is always poll() with a deadline, never a sleep. The deadlines are generous and
// only bound a failure; nothing here measures latency.
#include <gtest/gtest.h>

#include <fcntl.h>
#include <linux/can.h>
#include <linux/can/raw.h>
#include <net/if.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <sys/syscall.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#ifndef CANFD_FDF
#define CANFD_FDF 0x04  // set by kernels from 6.2 on in every FD frame; 6.1 headers lack it
#endif

extern char** environ;

namespace {

using Clock = std::chrono::steady_clock;

constexpr const char* kInterface = "vcan0";
constexpr auto kPeerDeadline = std::chrono::seconds(5);  // bounds a failure, not a latency
constexpr int kResendEveryMs = 20;

std::string errno_text(int error) { return std::string(std::strerror(error)) + " (" + std::to_string(error) + ")"; }

int ms_until(Clock::time_point deadline) {
  auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
  return left > 0 ? static_cast<int>(left) : 0;
}

class FileDescriptor {
 public:
  FileDescriptor() = default;
  explicit FileDescriptor(int fd) : fd_(fd) {}
  FileDescriptor(FileDescriptor&& other) noexcept : fd_(std::exchange(other.fd_, -1)) {}
  FileDescriptor& operator=(FileDescriptor&& other) noexcept {
    reset(std::exchange(other.fd_, -1));
    return *this;
  }
  FileDescriptor(const FileDescriptor&) = delete;
  FileDescriptor& operator=(const FileDescriptor&) = delete;
  ~FileDescriptor() { reset(); }

  int get() const { return fd_; }
  bool valid() const { return fd_ >= 0; }
  void reset(int fd = -1) {
    if (fd_ >= 0) ::close(fd_);
    fd_ = fd;
  }

 private:
  int fd_ = -1;
};

// --- CAN_RAW sockets -------------------------------------------------------------------

unsigned interface_index(const char* name) { return if_nametoindex(name); }

// A CAN_RAW socket bound to `ifindex`; with fd_frames it also reads and writes CAN FD
// frames. Reports a failure and returns an invalid descriptor when the kernel refuses.
FileDescriptor open_raw_socket(unsigned ifindex, bool fd_frames) {
  FileDescriptor sock(::socket(PF_CAN, SOCK_RAW, CAN_RAW));
  if (!sock.valid()) {
    ADD_FAILURE() << "socket(PF_CAN, SOCK_RAW, CAN_RAW): " << errno_text(errno);
    return {};
  }
  int on = 1;
  if (fd_frames && ::setsockopt(sock.get(), SOL_CAN_RAW, CAN_RAW_FD_FRAMES, &on, sizeof on) != 0) {
    ADD_FAILURE() << "CAN_RAW_FD_FRAMES: " << errno_text(errno);
    return {};
  }
  sockaddr_can address{};
  address.can_family = AF_CAN;
  address.can_ifindex = static_cast<int>(ifindex);
  if (::bind(sock.get(), reinterpret_cast<sockaddr*>(&address), sizeof address) != 0) {
    ADD_FAILURE() << "bind to ifindex " << ifindex << ": " << errno_text(errno);
    return {};
  }
  return sock;
}

FileDescriptor open_raw_socket(const char* name, bool fd_frames) {
  unsigned ifindex = interface_index(name);
  if (ifindex == 0) {
    ADD_FAILURE() << name << " does not exist: " << errno_text(errno);
    return {};
  }
  return open_raw_socket(ifindex, fd_frames);
}

// poll() for `events` until the deadline; returns revents (0 when the deadline passed).
short wait_for(int fd, short events, Clock::time_point deadline) {
  pollfd p{fd, events, 0};
  for (;;) {
    int n = ::poll(&p, 1, ms_until(deadline));
    if (n > 0) return p.revents;
    if (n == 0) return 0;
    if (errno != EINTR) return POLLERR;
  }
}

// One frame from a socket, waited for until the deadline.
std::optional<canfd_frame> receive_frame(int sock, Clock::time_point deadline, ssize_t* size = nullptr) {
  if ((wait_for(sock, POLLIN, deadline) & POLLIN) == 0) return std::nullopt;
  canfd_frame frame{};
  ssize_t n = ::read(sock, &frame, sizeof frame);
  if (size != nullptr) *size = n;
  if (n != static_cast<ssize_t>(CAN_MTU) && n != static_cast<ssize_t>(CANFD_MTU)) return std::nullopt;
  return frame;
}

can_frame classic_frame(canid_t id, std::initializer_list<std::uint8_t> bytes) {
  can_frame frame{};
  frame.can_id = id;
  frame.len = static_cast<std::uint8_t>(bytes.size());
  std::copy(bytes.begin(), bytes.end(), frame.data);
  return frame;
}

canfd_frame fd_frame_of_64_bytes(canid_t id) {
  canfd_frame frame{};
  frame.can_id = id;
  frame.len = CANFD_MAX_DLEN;
  frame.flags = CANFD_BRS;
  for (int i = 0; i < CANFD_MAX_DLEN; ++i) frame.data[i] = static_cast<std::uint8_t>(0xA0 + 3 * i);
  return frame;
}

std::string hex(const std::uint8_t* data, std::size_t size) {
  std::string text;
  char byte[3];
  for (std::size_t i = 0; i < size; ++i) {
    std::snprintf(byte, sizeof byte, "%02X", data[i]);
    text += byte;
  }
  return text;
}

// --- peer programs ---------------------------------------------------------------------

// The path of a program: looked up in PATH, then in /usr/sbin and /sbin (where `ip` lives,
// which a non-root PATH may lack). Empty when it is nowhere.
std::string locate(const std::string& name) {
  std::string path = std::getenv("PATH") != nullptr ? std::getenv("PATH") : "";
  path += ":/usr/sbin:/sbin";
  std::size_t start = 0;
  while (start <= path.size()) {
    std::size_t end = path.find(':', start);
    if (end == std::string::npos) end = path.size();
    std::string candidate = path.substr(start, end - start) + "/" + name;
    if (end > start && ::access(candidate.c_str(), X_OK) == 0) return candidate;
    start = end + 1;
  }
  return {};
}

// A program of can-utils or iproute2, started with its stdout and stderr on one pipe.
class Peer {
 public:
  static std::optional<Peer> start(std::vector<std::string> args) {
    std::string program = locate(args[0]);
    if (program.empty()) {
      ADD_FAILURE() << args[0] << " is not installed" << (args[0] == "ip" ? " (package iproute2)" : " (package can-utils)");
      return std::nullopt;
    }
    int pipe_fds[2];
    if (::pipe2(pipe_fds, O_CLOEXEC) != 0) {
      ADD_FAILURE() << "pipe2: " << errno_text(errno);
      return std::nullopt;
    }
    FileDescriptor read_end(pipe_fds[0]);
    FileDescriptor write_end(pipe_fds[1]);
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, 0, "/dev/null", O_RDONLY, 0);
    posix_spawn_file_actions_adddup2(&actions, write_end.get(), 1);
    posix_spawn_file_actions_adddup2(&actions, write_end.get(), 2);
    std::vector<char*> argv;
    for (auto& arg : args) argv.push_back(arg.data());
    argv.push_back(nullptr);
    pid_t pid = -1;
    int error = ::posix_spawn(&pid, program.c_str(), &actions, nullptr, argv.data(), environ);
    posix_spawn_file_actions_destroy(&actions);
    if (error != 0) {
      ADD_FAILURE() << "cannot start " << program << ": " << errno_text(error);
      return std::nullopt;
    }
    FileDescriptor pidfd(static_cast<int>(::syscall(SYS_pidfd_open, pid, 0)));
    if (!pidfd.valid()) {
      ADD_FAILURE() << "pidfd_open: " << errno_text(errno);
      ::kill(pid, SIGKILL);
      ::waitpid(pid, nullptr, 0);
      return std::nullopt;
    }
    return Peer(args[0], pid, std::move(pidfd), std::move(read_end));
  }

  Peer(Peer&& other) noexcept
      : name_(std::move(other.name_)),
        pid_(std::exchange(other.pid_, -1)),
        pidfd_(std::move(other.pidfd_)),
        output_fd_(std::move(other.output_fd_)),
        output_(std::move(other.output_)) {}
  Peer& operator=(Peer&&) = delete;
  ~Peer() {
    if (pid_ > 0) {
      ::kill(pid_, SIGKILL);
      ::waitpid(pid_, nullptr, 0);
    }
  }

  // True once the peer has written something (or closed its output).
  bool output_ready(int timeout_ms) {
    pollfd p{output_fd_.get(), POLLIN, 0};
    return ::poll(&p, 1, timeout_ms) > 0;
  }

  // Everything the peer writes until it closes its output, and its exit status
  // (nullopt when it did not finish by the deadline).
  std::optional<int> finish(Clock::time_point deadline) {
    char buffer[4096];
    while (output_fd_.valid()) {
      if ((wait_for(output_fd_.get(), POLLIN, deadline) & (POLLIN | POLLHUP | POLLERR)) == 0) return std::nullopt;
      ssize_t n = ::read(output_fd_.get(), buffer, sizeof buffer);
      if (n > 0) {
        output_.append(buffer, static_cast<std::size_t>(n));
      } else if (n == 0 || errno != EINTR) {
        output_fd_.reset();
      }
    }
    if ((wait_for(pidfd_.get(), POLLIN, deadline) & POLLIN) == 0) return std::nullopt;
    int status = 0;
    ::waitpid(pid_, &status, 0);
    pid_ = -1;
    return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  }

  const std::string& output() const { return output_; }
  const std::string& name() const { return name_; }

 private:
  Peer(std::string name, pid_t pid, FileDescriptor pidfd, FileDescriptor output_fd)
      : name_(std::move(name)), pid_(pid), pidfd_(std::move(pidfd)), output_fd_(std::move(output_fd)) {}

  std::string name_;
  pid_t pid_ = -1;
  FileDescriptor pidfd_;
  FileDescriptor output_fd_;
  std::string output_;
};

// Runs a peer to its end: a failure unless it exits 0 before the deadline.
void run_peer(std::vector<std::string> args) {
  std::string line;
  for (const auto& arg : args) line += (line.empty() ? "" : " ") + arg;
  auto peer = Peer::start(std::move(args));
  ASSERT_TRUE(peer.has_value());
  auto status = peer->finish(Clock::now() + kPeerDeadline);
  ASSERT_TRUE(status.has_value()) << line << " did not finish within 5 s";
  ASSERT_EQ(*status, 0) << line << " failed: " << peer->output();
}

// candump -L prints "(seconds.micros) vcan0 123#DEADBEEF"; this returns what follows the
// timestamp on the first line.
std::string candump_frame_text(const std::string& output) {
  std::string line = output.substr(0, output.find('\n'));
  auto after_timestamp = line.find(") ");
  return after_timestamp == std::string::npos ? line : line.substr(after_timestamp + 2);
}

// Starts `candump -L -n 1 vcan0,ID:7FF`, then sends `frame` every 20 ms until candump has
// printed it: candump binds its socket at some point after it starts, and a frame sent
// before that reaches nobody, so the first frames may go unseen. Returns candump's output.
std::string send_until_candump_prints(int sock, const void* frame, std::size_t size, canid_t id) {
  char filter[32];
  std::snprintf(filter, sizeof filter, "%s,%03X:7FF", kInterface, id);
  auto candump = Peer::start({"candump", "-L", "-n", "1", filter});
  if (!candump) return {};
  auto deadline = Clock::now() + kPeerDeadline;
  int sent = 0;
  while (!candump->output_ready(sent == 0 ? 0 : kResendEveryMs)) {
    if (Clock::now() > deadline) {
      ADD_FAILURE() << "candump printed nothing within 5 s of " << sent << " frames sent";
      return {};
    }
    ssize_t n = ::write(sock, frame, size);
    if (n != static_cast<ssize_t>(size)) {
      ADD_FAILURE() << "write of a " << size << "-byte frame: " << (n < 0 ? errno_text(errno) : std::to_string(n));
      return {};
    }
    ++sent;
  }
  auto status = candump->finish(deadline);
  EXPECT_TRUE(status.has_value()) << "candump did not exit after one frame: " << candump->output();
  EXPECT_EQ(status.value_or(-1), 0) << candump->output();
  return candump->output();
}

// --- the interface ---------------------------------------------------------------------

TEST(VcanInterface, IsUpWithTheCanFdMtu) {
  FileDescriptor sock(::socket(PF_CAN, SOCK_RAW, CAN_RAW));
  ASSERT_TRUE(sock.valid()) << "socket(PF_CAN): " << errno_text(errno) << " (no CAN in this kernel?)";
  ifreq request{};
  std::snprintf(request.ifr_name, IFNAMSIZ, "%s", kInterface);
  ASSERT_EQ(::ioctl(sock.get(), SIOCGIFMTU, &request), 0) << kInterface << ": " << errno_text(errno);
  EXPECT_EQ(request.ifr_mtu, static_cast<int>(CANFD_MTU));
  ASSERT_EQ(::ioctl(sock.get(), SIOCGIFFLAGS, &request), 0) << errno_text(errno);
  EXPECT_TRUE(request.ifr_flags & IFF_UP);
}

// --- classic frames --------------------------------------------------------------------

TEST(ClassicFrame, WrittenOnARawSocketReachesCandump) {
  auto sock = open_raw_socket(kInterface, false);
  ASSERT_TRUE(sock.valid());
  can_frame frame = classic_frame(0x123, {0x11, 0x22, 0x33, 0x44, 0x55, 0x66, 0x77, 0x88});
  std::string output = send_until_candump_prints(sock.get(), &frame, sizeof frame, 0x123);
  EXPECT_EQ(candump_frame_text(output), "vcan0 123#1122334455667788") << output;
}

TEST(ClassicFrame, SentByCansendArrivesOnARawSocket) {
  auto sock = open_raw_socket(kInterface, false);
  ASSERT_TRUE(sock.valid());
  run_peer({"cansend", kInterface, "123#DEADBEEF"});
  ssize_t size = 0;
  auto frame = receive_frame(sock.get(), Clock::now() + kPeerDeadline, &size);
  ASSERT_TRUE(frame.has_value()) << "no frame within 5 s (read returned " << size << ")";
  EXPECT_EQ(size, static_cast<ssize_t>(CAN_MTU));
  EXPECT_EQ(frame->can_id, 0x123u) << "an 11-bit data frame: no EFF, RTR or ERR flag";
  ASSERT_EQ(frame->len, 4);
  EXPECT_EQ(hex(frame->data, frame->len), "DEADBEEF");
}

TEST(ClassicFrame, ExtendedIdFromCansendKeepsTheEffFlag) {
  auto sock = open_raw_socket(kInterface, false);
  ASSERT_TRUE(sock.valid());
  run_peer({"cansend", kInterface, "1ABCDEF0#01"});
  auto frame = receive_frame(sock.get(), Clock::now() + kPeerDeadline);
  ASSERT_TRUE(frame.has_value()) << "no frame within 5 s";
  EXPECT_EQ(frame->can_id, 0x1ABCDEF0u | CAN_EFF_FLAG);
  ASSERT_EQ(frame->len, 1);
  EXPECT_EQ(frame->data[0], 0x01);
}

// SO_TIMESTAMPNS: each received frame carries the kernel's CLOCK_REALTIME time of its
// reception, as a control message.
TEST(ClassicFrame, ReceivedFramesCarryAKernelTimestamp) {
  auto receiver = open_raw_socket(kInterface, false);
  auto sender = open_raw_socket(kInterface, false);
  ASSERT_TRUE(receiver.valid() && sender.valid());
  int on = 1;
  ASSERT_EQ(::setsockopt(receiver.get(), SOL_SOCKET, SO_TIMESTAMPNS, &on, sizeof on), 0) << errno_text(errno);

  timespec before{};
  ::clock_gettime(CLOCK_REALTIME, &before);
  can_frame frame = classic_frame(0x321, {0xCA, 0xFE});
  ASSERT_EQ(::write(sender.get(), &frame, sizeof frame), static_cast<ssize_t>(sizeof frame)) << errno_text(errno);
  ASSERT_TRUE(wait_for(receiver.get(), POLLIN, Clock::now() + kPeerDeadline) & POLLIN) << "no frame within 5 s";

  can_frame received{};
  iovec data{&received, sizeof received};
  alignas(cmsghdr) char control[CMSG_SPACE(sizeof(timespec)) + 64];
  msghdr message{};
  message.msg_iov = &data;
  message.msg_iovlen = 1;
  message.msg_control = control;
  message.msg_controllen = sizeof control;
  ASSERT_EQ(::recvmsg(receiver.get(), &message, 0), static_cast<ssize_t>(CAN_MTU)) << errno_text(errno);
  timespec after{};
  ::clock_gettime(CLOCK_REALTIME, &after);
  EXPECT_EQ(received.can_id, 0x321u);
  EXPECT_EQ(message.msg_flags & MSG_CTRUNC, 0);

  std::optional<timespec> stamp;
  for (cmsghdr* c = CMSG_FIRSTHDR(&message); c != nullptr; c = CMSG_NXTHDR(&message, c)) {
    if (c->cmsg_level == SOL_SOCKET && c->cmsg_type == SCM_TIMESTAMPNS) {
      timespec t;
      std::memcpy(&t, CMSG_DATA(c), sizeof t);
      stamp = t;
    }
  }
  ASSERT_TRUE(stamp.has_value()) << "no SCM_TIMESTAMPNS control message";
  auto ns = [](const timespec& t) { return std::int64_t{t.tv_sec} * 1'000'000'000 + t.tv_nsec; };
  EXPECT_LE(ns(before), ns(*stamp)) << "stamped before the frame was written";
  EXPECT_LE(ns(*stamp), ns(after)) << "stamped after it was read";
}

// --- CAN FD frames (vcan0 has the FD MTU) ----------------------------------------------

TEST(FdFrame, SixtyFourBytesWrittenOnARawSocketReachCandump) {
  auto sock = open_raw_socket(kInterface, true);
  ASSERT_TRUE(sock.valid());
  canfd_frame frame = fd_frame_of_64_bytes(0x456);
  std::string output = send_until_candump_prints(sock.get(), &frame, sizeof frame, 0x456);
  // candump's FD format: ID##<flags nibble><data>. Kernels from 6.2 add CANFD_FDF to the flags.
  std::string text = candump_frame_text(output);
  std::string prefix = "vcan0 456##";
  ASSERT_EQ(text.substr(0, prefix.size()), prefix) << output;
  ASSERT_EQ(text.size(), prefix.size() + 1 + 2 * CANFD_MAX_DLEN) << output;
  int flags = std::stoi(text.substr(prefix.size(), 1), nullptr, 16);
  EXPECT_EQ(flags & ~CANFD_FDF, CANFD_BRS) << output;
  EXPECT_EQ(text.substr(prefix.size() + 1), hex(frame.data, CANFD_MAX_DLEN)) << output;
}

TEST(FdFrame, SixtyFourBytesSentByCansendArriveOnARawSocket) {
  auto sock = open_raw_socket(kInterface, true);
  ASSERT_TRUE(sock.valid());
  canfd_frame expected = fd_frame_of_64_bytes(0x456);
  run_peer({"cansend", kInterface, "456##1" + hex(expected.data, CANFD_MAX_DLEN)});
  ssize_t size = 0;
  auto frame = receive_frame(sock.get(), Clock::now() + kPeerDeadline, &size);
  ASSERT_TRUE(frame.has_value()) << "no frame within 5 s (read returned " << size << ")";
  EXPECT_EQ(size, static_cast<ssize_t>(CANFD_MTU)) << "an FD frame reads as a whole canfd_frame";
  EXPECT_EQ(frame->can_id, 0x456u);
  EXPECT_EQ(frame->flags & ~CANFD_FDF, CANFD_BRS);
  ASSERT_EQ(frame->len, CANFD_MAX_DLEN);
  EXPECT_EQ(hex(frame->data, frame->len), hex(expected.data, CANFD_MAX_DLEN));
}

// Without CAN_RAW_FD_FRAMES a socket never sees FD frames, even on an FD interface: the
// classic frame sent after the FD one is the first thing it reads.
TEST(FdFrame, ClassicOnlySocketDoesNotSeeThem) {
  auto classic = open_raw_socket(kInterface, false);
  ASSERT_TRUE(classic.valid());
  run_peer({"cansend", kInterface, "456##1" + std::string(2 * CANFD_MAX_DLEN, '0')});
  run_peer({"cansend", kInterface, "457#01"});
  ssize_t size = 0;
  auto frame = receive_frame(classic.get(), Clock::now() + kPeerDeadline, &size);
  ASSERT_TRUE(frame.has_value()) << "no frame within 5 s (read returned " << size << ")";
  EXPECT_EQ(size, static_cast<ssize_t>(CAN_MTU));
  EXPECT_EQ(frame->can_id, 0x457u);
}

// --- the interface going away and coming back ------------------------------------------
// What the kernel (6.1) does to a socket bound to vcan0; the SocketCAN model has to cope.

std::vector<std::string> ip(std::initializer_list<std::string> args) {
  std::vector<std::string> argv{"ip"};
  argv.insert(argv.end(), args);
  return argv;
}

// The error a bound socket reports: poll() flags POLLERR, and read() returns it once.
int pending_error(int sock) {
  if ((wait_for(sock, POLLIN, Clock::now() + kPeerDeadline) & POLLERR) == 0) return 0;
  canfd_frame frame;
  return ::read(sock, &frame, sizeof frame) < 0 ? errno : 0;
}

TEST(InterfaceLifecycle, DownReportsEnetdownAndUpKeepsTheBinding) {
  auto sock = open_raw_socket(kInterface, false);
  ASSERT_TRUE(sock.valid());
  ASSERT_NO_FATAL_FAILURE(run_peer(ip({"link", "set", kInterface, "down"})));

  EXPECT_EQ(pending_error(sock.get()), ENETDOWN);
  can_frame frame = classic_frame(0x100, {0x01});
  EXPECT_EQ(::write(sock.get(), &frame, sizeof frame), -1);
  EXPECT_EQ(errno, ENETDOWN) << "write on a down interface: " << errno_text(errno);

  ASSERT_NO_FATAL_FAILURE(run_peer(ip({"link", "set", kInterface, "up"})));
  ASSERT_NO_FATAL_FAILURE(run_peer({"cansend", kInterface, "101#02"}));
  auto received = receive_frame(sock.get(), Clock::now() + kPeerDeadline);
  ASSERT_TRUE(received.has_value()) << "the socket is still bound and receives once the interface is up";
  EXPECT_EQ(received->can_id, 0x101u);
}

TEST(InterfaceLifecycle, DeleteReportsEnodevAndLeavesTheSocketUnboundWithoutFilters) {
  unsigned old_index = interface_index(kInterface);
  ASSERT_NE(old_index, 0u);
  auto sock = open_raw_socket(old_index, false);
  ASSERT_TRUE(sock.valid());
  ASSERT_NO_FATAL_FAILURE(run_peer(ip({"link", "del", kInterface})));

  // Unregistering first takes the interface down (ENETDOWN), then ENODEV replaces it.
  EXPECT_EQ(pending_error(sock.get()), ENODEV);
  // The socket is now bound to no interface at all: a write has nowhere to go.
  can_frame frame = classic_frame(0x200, {0x01});
  EXPECT_EQ(::write(sock.get(), &frame, sizeof frame), -1);
  EXPECT_EQ(errno, ENXIO) << "write after the interface was deleted: " << errno_text(errno);

  ASSERT_NO_FATAL_FAILURE(run_peer(ip({"link", "add", "dev", kInterface, "type", "vcan"})));
  ASSERT_NO_FATAL_FAILURE(run_peer(ip({"link", "set", kInterface, "up"})));
  unsigned new_index = interface_index(kInterface);
  ASSERT_NE(new_index, 0u);
  EXPECT_NE(new_index, old_index) << "the re-created vcan0 is a new interface";

  // A frame on the new vcan0 reaches a socket bound to it, and not the old socket: the
  // kernel delivers one frame to every matching socket before any of them can read it, so
  // once the fresh socket has it the old one would have it too.
  auto fresh = open_raw_socket(new_index, false);
  ASSERT_TRUE(fresh.valid());
  ASSERT_NO_FATAL_FAILURE(run_peer({"cansend", kInterface, "201#02"}));
  auto received = receive_frame(fresh.get(), Clock::now() + kPeerDeadline);
  ASSERT_TRUE(received.has_value()) << "the fresh socket got nothing within 5 s";
  EXPECT_EQ(received->can_id, 0x201u);
  EXPECT_EQ(wait_for(sock.get(), POLLIN, Clock::now()), 0) << "the old socket is not bound to the new vcan0";

  // Binding the old socket to the new interface is accepted, but is not enough: the kernel
  // dropped the socket's filters with the interface (the default accept-all one too), so
  // it still receives nothing ...
  sockaddr_can address{};
  address.can_family = AF_CAN;
  address.can_ifindex = static_cast<int>(new_index);
  ASSERT_EQ(::bind(sock.get(), reinterpret_cast<sockaddr*>(&address), sizeof address), 0) << errno_text(errno);
  ASSERT_NO_FATAL_FAILURE(run_peer({"cansend", kInterface, "202#03"}));
  received = receive_frame(fresh.get(), Clock::now() + kPeerDeadline);
  ASSERT_TRUE(received.has_value()) << "the fresh socket got nothing within 5 s";
  EXPECT_EQ(received->can_id, 0x202u);
  EXPECT_EQ(wait_for(sock.get(), POLLIN, Clock::now()), 0) << "re-bound, the old socket has no filter";

  // ... until it is given a filter again.
  can_filter accept_all{0, 0};
  ASSERT_EQ(::setsockopt(sock.get(), SOL_CAN_RAW, CAN_RAW_FILTER, &accept_all, sizeof accept_all), 0) << errno_text(errno);
  ASSERT_NO_FATAL_FAILURE(run_peer({"cansend", kInterface, "203#04"}));
  received = receive_frame(sock.get(), Clock::now() + kPeerDeadline);
  ASSERT_TRUE(received.has_value()) << "re-bound with a filter, the old socket got nothing within 5 s";
  EXPECT_EQ(received->can_id, 0x203u);
}

}  // namespace
