// The receive thread the LCM and SocketCAN models share (interceptors/common/fd_reactor.hpp),
// waiting with epoll and with io_uring: handlers run while their descriptor is readable (level
// triggered), not after remove(), and with the ring a handler's send_with_next_wait() goes out
// in order (with what it writes itself when the reactor's slots are taken) and tells its
// tracker the result, failures included. Pipes and Unix sockets stand in for the models'. Every wait polls a condition until a deadline.
#include <gtest/gtest.h>

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/utsname.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <functional>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "../support/eventually.hpp"
#include "fd_reactor.hpp"

namespace polyport {
namespace {

using test::eventually;
constexpr auto kDeadline = std::chrono::seconds(5);  // bounds a failure, not a latency

// Reads one byte per call: the reactor must call it again while bytes are left.
class ByteReader final : public ReadableHandler {
 public:
  explicit ByteReader(int fd) : fd_(fd) {}
  void on_readable() noexcept override {
    char byte = 0;
    if (::read(fd_, &byte, 1) == 1) bytes.fetch_add(1);
    calls.fetch_add(1);
    if (then) then(byte);
  }
  std::atomic<int> bytes{0};
  std::atomic<int> calls{0};
  std::function<void(char)> then;  // set before add(), run on the reactor thread

 private:
  int fd_;
};

struct Pipe {
  int read_end = -1, write_end = -1;
  Pipe() {
    int fds[2];
    EXPECT_EQ(::pipe2(fds, O_NONBLOCK | O_CLOEXEC), 0);
    read_end = fds[0];
    write_end = fds[1];
  }
  ~Pipe() {
    ::close(read_end);
    ::close(write_end);
  }
  void put(const std::string& bytes) const {
    ASSERT_EQ(::write(write_end, bytes.data(), bytes.size()), static_cast<ssize_t>(bytes.size()));
  }
};

class Tracker final : public SendTracker {
 public:
  void on_send_done(int result, std::uint64_t cookie) noexcept override {
    const std::lock_guard lock(mutex);
    results.emplace_back(result, cookie);
  }
  std::vector<std::pair<int, std::uint64_t>> done() {
    const std::lock_guard lock(mutex);
    return results;
  }

 private:
  std::mutex mutex;
  std::vector<std::pair<int, std::uint64_t>> results;
};

class FdReactorTest : public ::testing::TestWithParam<ReactorIo> {
 protected:
  void SetUp() override {
    reactor = FdReactor::create("pp-test-react", "the test's receive thread", GetParam());
    // The first add() starts the thread and says how it waits.
    auto added = reactor->add(starter.read_end, starter_reader);
    if (!added && GetParam() == ReactorIo::io_uring) {
      GTEST_SKIP() << "this kernel gives no io_uring, so only the epoll backend is tested here: "
                   << added.error().message;
    }
    ASSERT_TRUE(added) << added.error().message;
    ASSERT_EQ(reactor->io(), GetParam());
  }
  void TearDown() override {
    if (reactor) reactor->remove(starter.read_end);
  }

  // Adds a descriptor of its own, makes it readable and waits for its handler's turn, twice: the
  // thread has run whole rounds since the call began.
  bool rounds_pass() {
    Pipe pipe;
    ByteReader reader(pipe.read_end);
    if (!reactor->add(pipe.read_end, reader)) return false;
    bool turned = true;
    for (int turn = 1; turn <= 2 && turned; ++turn) {
      pipe.put("z");
      turned = eventually([&] { return reader.bytes == turn; }, kDeadline);
    }
    reactor->remove(pipe.read_end);
    return turned;
  }

  Pipe starter;
  ByteReader starter_reader{starter.read_end};
  std::shared_ptr<FdReactor> reactor;
};

TEST_P(FdReactorTest, CallsTheHandlerWhileTheDescriptorIsReadable) {
  Pipe pipe;
  ByteReader reader(pipe.read_end);
  ASSERT_TRUE(reactor->add(pipe.read_end, reader));
  pipe.put("abc");
  ASSERT_TRUE(eventually([&] { return reader.bytes == 3; }, kDeadline)) << reader.bytes << " of 3 bytes read";
  pipe.put("d");
  ASSERT_TRUE(eventually([&] { return reader.bytes == 4; }, kDeadline)) << reader.bytes << " of 4 bytes read";
  reactor->remove(pipe.read_end);
  // One call per byte: a call finding nothing would mean the descriptor was reported unreadable.
  EXPECT_EQ(reader.calls, 4);
}

TEST_P(FdReactorTest, AfterRemoveTheHandlerIsNotCalledAgain) {
  Pipe removed_pipe;
  ByteReader removed(removed_pipe.read_end);
  ASSERT_TRUE(reactor->add(removed_pipe.read_end, removed));
  removed_pipe.put("x");
  ASSERT_TRUE(eventually([&] { return removed.bytes == 1; }, kDeadline));
  reactor->remove(removed_pipe.read_end);
  removed_pipe.put("y");
  ASSERT_TRUE(rounds_pass());  // with "y" waiting on the removed one
  EXPECT_EQ(removed.calls, 1);
}

TEST_P(FdReactorTest, AHandlerMayTakeItsOwnDescriptorOut) {
  Pipe pipe;
  ByteReader reader(pipe.read_end);
  reader.then = [&](char) { reactor->remove_in_tick(pipe.read_end); };
  ASSERT_TRUE(reactor->add(pipe.read_end, reader));
  pipe.put("ab");
  ASSERT_TRUE(eventually([&] { return reader.calls == 1; }, kDeadline));
  ASSERT_TRUE(rounds_pass());  // "b" is still there; the handler is out
  EXPECT_EQ(reader.calls, 1);
}

TEST_P(FdReactorTest, AClosedDescriptorIsRefused) {
  Pipe pipe;
  ByteReader reader(pipe.read_end);
  const int closed = ::dup(pipe.read_end);
  ::close(closed);
  if (GetParam() == ReactorIo::io_uring) {
    const Result<void> added = reactor->add(closed, reader);
    ASSERT_FALSE(added);
    EXPECT_NE(added.error().message.find("Bad file descriptor"), std::string::npos) << added.error().message;
  } else {
    const Result<void> added = reactor->add(closed, reader);
    ASSERT_FALSE(added);
    EXPECT_NE(added.error().message.find("epoll_ctl"), std::string::npos) << added.error().message;
  }
}

// A Unix socket pair of `type`: what is sent on `ours` is read on `theirs`; SOCK_DGRAM keeps
// each send whole, SOCK_STREAM keeps every byte in the order it went out.
struct SocketPair {
  int ours = -1, theirs = -1;
  explicit SocketPair(int type) {
    int fds[2];
    EXPECT_EQ(::socketpair(AF_UNIX, type | SOCK_NONBLOCK | SOCK_CLOEXEC, 0, fds), 0);
    ours = fds[0];
    theirs = fds[1];
  }
  ~SocketPair() {
    ::close(ours);
    ::close(theirs);
  }
  // The datagrams waiting on `theirs` (of a stream: what it holds, in pieces).
  std::vector<std::string> received() const {
    std::vector<std::string> out;
    char buffer[4096];
    for (ssize_t n; (n = ::recv(theirs, buffer, sizeof buffer, 0)) > 0;) out.emplace_back(buffer, static_cast<size_t>(n));
    return out;
  }
  void take(std::string& into) const {
    for (const std::string& bytes : received()) into += bytes;
  }
};
struct Datagrams : SocketPair {
  Datagrams() : SocketPair(SOCK_DGRAM) {}
};
struct Stream : SocketPair {
  Stream() : SocketPair(SOCK_STREAM) {}
};

bool no_send_in_flight(const SendTracker& tracker) {
  return eventually([&] { return tracker.in_flight.load() == 0; }, kDeadline);
}

// 70 sends per handler call, more than the reactor's 64 slots: those it cannot take the
// handler writes itself, after what the reactor queued, and every byte arrives in order.
TEST_P(FdReactorTest, AHandlersSendsGoOutWithTheNextWaitInOrder) {
  constexpr int kPerCall = 70;  // the three calls' 210 sends fit the socket's send buffer: none fails
  Pipe pipe;
  Stream stream;
  Tracker tracker;
  ByteReader reader(pipe.read_end);
  std::atomic<int> handed{0};
  std::string expected;
  for (char byte : std::string("abc")) {
    for (int k = 0; k < kPerCall; ++k) expected += byte + std::to_string(k / 10) + std::to_string(k % 10) + ",";
  }
  reader.then = [&](char byte) {
    for (int k = 0; k < kPerCall; ++k) {
      const std::string message = byte + std::to_string(k / 10) + std::to_string(k % 10) + ",";
      if (reactor->send_with_next_wait(stream.ours, message.data(), static_cast<std::uint32_t>(message.size()),
                                       tracker, static_cast<std::uint64_t>(k))) {
        handed.fetch_add(1);
      } else {
        (void)::send(stream.ours, message.data(), message.size(), MSG_DONTWAIT);
      }
    }
  };
  ASSERT_TRUE(reactor->add(pipe.read_end, reader));
  pipe.put("abc");
  std::string got;
  ASSERT_TRUE(eventually(
      [&] {
        stream.take(got);
        return got.size() >= expected.size();
      },
      kDeadline))
      << got.size() << " of " << expected.size() << " bytes";
  EXPECT_EQ(got, expected);
  reactor->remove(pipe.read_end);
  ASSERT_TRUE(no_send_in_flight(tracker)) << tracker.in_flight.load() << " sends never done";
  const auto done = tracker.done();
  if (GetParam() == ReactorIo::epoll) {
    EXPECT_EQ(handed, 0) << "an epoll reactor sends nothing for its handlers";
    EXPECT_TRUE(done.empty());
    return;
  }
  EXPECT_GE(handed, 3 * 64) << "the ring took fewer sends than its slots";
  EXPECT_LT(handed, 3 * kPerCall) << "the ring took more sends than its slots";
  ASSERT_EQ(static_cast<int>(done.size()), handed.load());
  for (const auto& [result, cookie] : done) {
    EXPECT_EQ(result, 4) << "send " << cookie;  // the bytes sent
  }
}

bool kernel_at_least(int major, int minor) {
  utsname name{};
  int got_major = 0, got_minor = 0;
  return ::uname(&name) == 0 && std::sscanf(name.release, "%d.%d", &got_major, &got_minor) == 2 &&
         (got_major > major || (got_major == major && got_minor >= minor));
}

// A receiver of datagrams: with the ring the reactor receives them (on_message), with epoll the
// receiver reads them itself when called (on_readable); either way each message is recorded
// with the sender's pid from its SCM_CREDENTIALS control message (SO_PASSCRED).
class Receiver final : public MessageHandler {
 public:
  explicit Receiver(int fd) : fd_(fd) {}
  struct Message {
    std::string bytes;
    pid_t pid = 0;
    bool truncated = false;
  };
  void on_message(const std::byte* data, std::uint32_t size, const msghdr& header) noexcept override {
    record(std::string(reinterpret_cast<const char*>(data), size), header);
    from_ring.fetch_add(1);
  }
  void on_readable() noexcept override {
    char bytes[kMessageBytes];
    alignas(cmsghdr) char control[kControlBytes];
    for (;;) {
      iovec data{bytes, sizeof bytes};
      msghdr header{};
      header.msg_iov = &data;
      header.msg_iovlen = 1;
      header.msg_control = control;
      header.msg_controllen = control_bytes();
      const ssize_t n = ::recvmsg(fd_, &header, MSG_DONTWAIT);
      if (n < 0) return;
      record(std::string(bytes, static_cast<std::size_t>(n)), header);
    }
  }
  void on_receive_error(int) noexcept override { errors.fetch_add(1); }
  std::uint32_t control_bytes() const noexcept override { return CMSG_SPACE(sizeof(ucred)); }
  std::vector<Message> messages() {
    const std::lock_guard lock(mutex_);
    return messages_;
  }
  std::atomic<int> from_ring{0};
  std::atomic<int> errors{0};

 private:
  void record(std::string bytes, const msghdr& header) {
    Message m{std::move(bytes), 0, (header.msg_flags & MSG_TRUNC) != 0};
    msghdr& h = const_cast<msghdr&>(header);
    for (cmsghdr* c = CMSG_FIRSTHDR(&h); c != nullptr; c = CMSG_NXTHDR(&h, c)) {
      if (c->cmsg_level == SOL_SOCKET && c->cmsg_type == SCM_CREDENTIALS) {
        ucred credentials;
        std::memcpy(&credentials, CMSG_DATA(c), sizeof credentials);
        m.pid = credentials.pid;
      }
    }
    const std::lock_guard lock(mutex_);
    messages_.push_back(std::move(m));
  }
  int fd_;
  std::mutex mutex_;
  std::vector<Message> messages_;
};

TEST_P(FdReactorTest, AReceiverGetsEveryMessageWithItsControlMessages) {
  Datagrams sockets;
  const int on = 1;
  ASSERT_EQ(::setsockopt(sockets.theirs, SOL_SOCKET, SO_PASSCRED, &on, sizeof on), 0);
  Receiver receiver(sockets.theirs);
  ASSERT_TRUE(reactor->add_receiver(sockets.theirs, receiver));
  std::vector<std::string> sent;
  for (int i = 0; i < 5; ++i) sent.push_back("message " + std::to_string(i));
  sent.push_back(std::string(100, 'x'));  // longer than a receiver takes (kMessageBytes)
  for (const std::string& m : sent) {
    ASSERT_TRUE(eventually([&] { return ::send(sockets.ours, m.data(), m.size(), MSG_DONTWAIT) == static_cast<ssize_t>(m.size()); }, kDeadline));
  }
  ASSERT_TRUE(eventually([&] { return receiver.messages().size() == sent.size(); }, kDeadline))
      << receiver.messages().size() << " of " << sent.size() << " messages";
  reactor->remove(sockets.theirs);
  const auto got = receiver.messages();
  for (std::size_t i = 0; i < got.size(); ++i) {
    const std::size_t want = std::min<std::size_t>(sent[i].size(), MessageHandler::kMessageBytes);
    EXPECT_EQ(got[i].bytes, sent[i].substr(0, want)) << "message " << i;
    EXPECT_EQ(got[i].truncated, sent[i].size() > MessageHandler::kMessageBytes) << "message " << i;
    EXPECT_EQ(got[i].pid, ::getpid()) << "message " << i << ": its SCM_CREDENTIALS";
  }
  EXPECT_EQ(receiver.errors, 0);
  // The ring receives itself where the kernel has multishot recvmsg (6.0); epoll, or an older
  // kernel's ring, lets the receiver read.
  const bool ring_receives = GetParam() == ReactorIo::io_uring && reactor->ring_receives() && kernel_at_least(6, 0);
  EXPECT_EQ(receiver.from_ring, ring_receives ? static_cast<int>(sent.size()) : 0);
}

// What the SocketCAN interceptor does when its interface comes back: the receiver removed, a
// new socket dup2()ed over the number, the number added again. Only the new socket's messages
// arrive, and all of them.
TEST_P(FdReactorTest, AReceiverReAddedOverANewSocketGetsItsMessages) {
  Datagrams first, second;
  Receiver receiver(first.theirs);
  ASSERT_TRUE(reactor->add_receiver(first.theirs, receiver));
  ASSERT_EQ(::send(first.ours, "one", 3, 0), 3);
  ASSERT_TRUE(eventually([&] { return receiver.messages().size() == 1; }, kDeadline));
  reactor->remove(first.theirs);
  ASSERT_EQ(::send(first.ours, "lost", 4, 0), 4);  // to the old socket, after the removal
  ASSERT_EQ(::dup2(second.theirs, first.theirs), first.theirs);
  ASSERT_TRUE(reactor->add_receiver(first.theirs, receiver));
  for (const char* m : {"two", "three"}) ASSERT_EQ(::send(second.ours, m, std::strlen(m), 0), static_cast<ssize_t>(std::strlen(m)));
  ASSERT_TRUE(eventually([&] { return receiver.messages().size() == 3; }, kDeadline)) << receiver.messages().size();
  reactor->remove(first.theirs);
  const auto got = receiver.messages();
  ASSERT_EQ(got.size(), 3u);
  EXPECT_EQ(got[0].bytes, "one");
  EXPECT_EQ(got[1].bytes, "two");
  EXPECT_EQ(got[2].bytes, "three");
}

// More messages at once than the ring has buffers (128): the receive ends when they run out and
// is armed again once they are back; every message arrives, in order.
TEST_P(FdReactorTest, AReceiverGetsABurstLargerThanTheBuffers) {
  const int theirs = ::socket(AF_INET, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  const int ours = ::socket(AF_INET, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t length = sizeof address;
  ASSERT_EQ(::bind(theirs, reinterpret_cast<const sockaddr*>(&address), sizeof address), 0);
  ASSERT_EQ(::getsockname(theirs, reinterpret_cast<sockaddr*>(&address), &length), 0);
  ASSERT_EQ(::connect(ours, reinterpret_cast<const sockaddr*>(&address), sizeof address), 0);
  const int buffer = 1 << 20;  // room for the whole burst (capped at net.core.rmem_max)
  ASSERT_EQ(::setsockopt(theirs, SOL_SOCKET, SO_RCVBUF, &buffer, sizeof buffer), 0);
  Receiver receiver(theirs);
  // Stopped while the burst is sent: the handler blocks the reactor thread until it is all queued.
  std::atomic<bool> hold{true};
  Pipe gate;
  ByteReader gatekeeper(gate.read_end);
  gatekeeper.then = [&](char) {
    while (hold.load()) std::this_thread::yield();
  };
  ASSERT_TRUE(reactor->add(gate.read_end, gatekeeper));
  ASSERT_TRUE(reactor->add_receiver(theirs, receiver));
  gate.put("g");
  ASSERT_TRUE(eventually([&] { return gatekeeper.calls == 1; }, kDeadline));
  constexpr int kBurst = 150;  // above the 128 buffers; ≈ 110 KB of queued datagrams
  for (int i = 0; i < kBurst; ++i) {
    const std::string m = std::to_string(i);
    ASSERT_EQ(::send(ours, m.data(), m.size(), 0), static_cast<ssize_t>(m.size())) << "datagram " << i;
  }
  hold = false;
  ASSERT_TRUE(eventually([&] { return receiver.messages().size() == kBurst; }, kDeadline))
      << receiver.messages().size() << " of " << kBurst << " datagrams";
  reactor->remove(theirs);
  reactor->remove(gate.read_end);
  const auto got = receiver.messages();
  for (int i = 0; i < kBurst; ++i) EXPECT_EQ(got[static_cast<std::size_t>(i)].bytes, std::to_string(i));
  ::close(theirs);
  ::close(ours);
}

// Only a ring hands sends to the kernel.
using FdReactorRingTest = FdReactorTest;

TEST_P(FdReactorRingTest, ASendTheKernelRefusesIsReportedToItsTracker) {
  Pipe pipe;
  Datagrams sockets;  // nobody reads `theirs`: its queue fills, then sends fail with EAGAIN
  Tracker tracker;
  ByteReader reader(pipe.read_end);
  std::atomic<int> handed{0};
  reader.then = [&](char) {
    const char message[] = "a frame";
    if (reactor->send_with_next_wait(sockets.ours, message, sizeof message, tracker, 7)) handed.fetch_add(1);
  };
  ASSERT_TRUE(reactor->add(pipe.read_end, reader));
  // Far more datagrams than a Unix socket queues (net.unix.max_dgram_qlen, 10 by default;
  // the receive buffer's bytes bound it too).
  constexpr int kSends = 2000;
  for (int sent = 0; sent < kSends; sent += 100) pipe.put(std::string(100, 'x'));
  ASSERT_TRUE(eventually([&] { return reader.bytes == kSends; }, kDeadline)) << reader.bytes;
  reactor->remove(pipe.read_end);
  ASSERT_TRUE(no_send_in_flight(tracker)) << tracker.in_flight.load() << " sends never done";
  const auto done = tracker.done();
  ASSERT_EQ(static_cast<int>(done.size()), handed.load());
  int failed = 0;
  for (const auto& [result, cookie] : done) {
    EXPECT_EQ(cookie, 7u);
    if (result < 0) {
      EXPECT_EQ(result, -EAGAIN);
      ++failed;
    } else {
      EXPECT_EQ(result, 8);
    }
  }
  EXPECT_GT(failed, 0) << "no send failed: the peer's queue never filled";
  EXPECT_EQ(static_cast<std::size_t>(handed.load() - failed), sockets.received().size());
}

TEST_P(FdReactorTest, AnotherThreadCannotHandOverASend) {
  Datagrams sockets;
  Tracker tracker;
  const char message[] = "x";
  EXPECT_FALSE(reactor->send_with_next_wait(sockets.ours, message, sizeof message, tracker, 0));
  EXPECT_EQ(tracker.in_flight, 0u);
}

std::string name_of(const ::testing::TestParamInfo<ReactorIo>& param) { return to_string(param.param); }
INSTANTIATE_TEST_SUITE_P(Waits, FdReactorTest, ::testing::Values(ReactorIo::epoll, ReactorIo::io_uring), name_of);
INSTANTIATE_TEST_SUITE_P(Waits, FdReactorRingTest, ::testing::Values(ReactorIo::io_uring), name_of);

TEST(FdReactorAutomatic, WaitsOneWayOrTheOther) {
  Pipe pipe;
  ByteReader reader(pipe.read_end);
  auto reactor = FdReactor::create("pp-test-react", "the test's receive thread", ReactorIo::automatic);
  EXPECT_EQ(reactor->io(), ReactorIo::automatic);  // not started yet
  ASSERT_TRUE(reactor->add(pipe.read_end, reader));
  EXPECT_NE(reactor->io(), ReactorIo::automatic);
  pipe.put("a");
  EXPECT_TRUE(eventually([&] { return reader.bytes == 1; }, kDeadline));
  reactor->remove(pipe.read_end);
}

}  // namespace
}  // namespace polyport
