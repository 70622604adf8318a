#include "fd_reactor.hpp"

#include <fcntl.h>
#include <poll.h>
#include <pthread.h>
#include <sys/epoll.h>
#include <sys/eventfd.h>
#include <sys/timerfd.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <future>
#include <string>
#include <utility>

#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#ifdef POLYPORT_WITH_IO_URING
#include <liburing.h>
#endif

namespace polyport {

const char* to_string(ReactorIo io) noexcept {
  switch (io) {
    case ReactorIo::epoll: return "epoll";
    case ReactorIo::io_uring: return "io_uring";
    case ReactorIo::automatic: return "auto";
  }
  return "?";
}

#ifdef POLYPORT_WITH_IO_URING

// What the thread keeps for the ring; touched by the reactor thread alone once it runs.
//
// Every submission carries a tag: its kind in the top two bits, a registration's generation in
// the next 30 and an index in the low 32. A descriptor's registration is one slot of `watched`,
// reused after it is removed with a new generation, so a completion of a poll armed before the
// removal (cancelled, or already on the completion queue) finds another generation and is
// dropped. A send's tag names its slot of `sends`, whose bytes the kernel reads when the next
// io_uring_enter submits it (MSG_DONTWAIT: it completes in that call, never later).
// A receiver (add_receiver) is a multishot recvmsg instead of a poll: each message arrives in
// one of `buffers` (a provided-buffer ring, group 0, shared by every receiver), laid out as
// io_uring_recvmsg_out, the control messages, the payload; the buffer goes back to the ring
// once its handler has returned. A receiver whose receives fail three times in a row without a
// message, or on a kernel without multishot recvmsg, is polled instead (its on_readable reads).
struct FdReactor::Ring {
  static constexpr unsigned kEntries = 256;
  static constexpr unsigned kSends = 64;
  static constexpr unsigned kCompletions = 32;  // taken from the queue per look
  static constexpr unsigned kBuffers = 128;      // a power of two
  static constexpr unsigned kBufferBytes = 256;  // recvmsg_out + control + a CAN FD frame
  static_assert(sizeof(io_uring_recvmsg_out) + MessageHandler::kControlBytes + MessageHandler::kMessageBytes <=
                kBufferBytes);
  enum Kind : std::uint64_t { kReceive = 0, kPoll = 1, kSend = 2, kCancel = 3 };

  struct Watched {
    int fd = -1;
    ReadableHandler* handler = nullptr;
    MessageHandler* receiver = nullptr;  // received by the ring; null: polled
    std::unique_ptr<msghdr> header;     // the receiver's recvmsg template (the kernel reads it at submit)
    std::uint32_t generation = 0;
    int failures = 0;            // receives failed in a row
    bool received_once = false;  // a receive of this registration delivered a message
    bool active = false;
    Kind armed = kCancel;        // what arm() last submitted for it (kPoll or kReceive)
    static constexpr int kPolledAfter = 3;
    bool polled() const noexcept { return receiver == nullptr || failures >= kPolledAfter; }
  };
  struct Send {
    alignas(8) unsigned char bytes[kSendBytes];
    SendTracker* tracker = nullptr;
    std::uint64_t cookie = 0;
  };

  io_uring ring{};
  bool live = false;  // `ring` was set up (and is to be torn down)
  // Receivers' buffers (registered at init: 5.19; multishot recvmsg itself: 6.0, found out at
  // the first receive). Null: every descriptor is polled.
  io_uring_buf_ring* buffer_ring = nullptr;
  unsigned char* buffers = nullptr;
  bool receives = false;
  std::atomic<bool>* receives_flag = nullptr;  // FdReactor::ring_receives_, for describe()
  std::vector<Watched> watched;
  Send sends[kSends];
  unsigned free_sends[kSends];
  unsigned free_count = kSends;
  // Sends prepared whose completion has not been taken from the queue yet: the round's wait
  // asks for that many completions and one more, so that a send completing in the call does
  // not end the wait (the one system call is then the send and the wait for the next event).
  unsigned sends_out = 0;

  Ring() {
    for (unsigned i = 0; i < kSends; ++i) free_sends[i] = kSends - 1 - i;
  }
  ~Ring() {
    if (live) io_uring_queue_exit(&ring);  // unregisters the buffer ring too
    std::free(buffer_ring);
    std::free(buffers);
  }

  // io_uring_queue_init with the cheapest task-work settings this kernel takes; -errno.
  int init() {
    // Completions are reaped by this thread alone, in its wait: the kernel need not interrupt
    // it for their work (5.19). Not IORING_SETUP_DEFER_TASKRUN: in the vcan guest (6.1) it made
    // a forwarded frame's round trip ~25 us longer than COOP_TASKRUN, as long as epoll's.
    const unsigned tries[] = {IORING_SETUP_COOP_TASKRUN, 0};
    int rc = -EINVAL;
    for (unsigned flags : tries) {
      rc = io_uring_queue_init(kEntries, &ring, flags);
      if (rc != -EINVAL) break;
    }
    if (rc < 0) return rc;
    live = true;
    io_uring_probe* probe = io_uring_get_probe_ring(&ring);
    const bool has_all = probe != nullptr && io_uring_opcode_supported(probe, IORING_OP_POLL_ADD) &&
                         io_uring_opcode_supported(probe, IORING_OP_POLL_REMOVE) &&
                         io_uring_opcode_supported(probe, IORING_OP_SEND);
    const bool has_receive = probe != nullptr && io_uring_opcode_supported(probe, IORING_OP_RECVMSG) &&
                             io_uring_opcode_supported(probe, IORING_OP_ASYNC_CANCEL);
    if (probe != nullptr) io_uring_free_probe(probe);
    if (!has_all) return -EOPNOTSUPP;  // the destructor tears it down
    if (has_receive) set_up_buffers();
    return 0;
  }

  void set_up_buffers() {
    void* ring_memory = nullptr;
    void* buffer_memory = nullptr;
    // The kernel maps the ring's entries: page-aligned.
    const long page = ::sysconf(_SC_PAGESIZE);
    if (::posix_memalign(&ring_memory, page > 0 ? static_cast<std::size_t>(page) : 4096,
                         kBuffers * sizeof(io_uring_buf)) != 0) {
      return;
    }
    if (::posix_memalign(&buffer_memory, 64, std::size_t{kBuffers} * kBufferBytes) != 0) {
      std::free(ring_memory);
      return;
    }
    std::memset(ring_memory, 0, kBuffers * sizeof(io_uring_buf));
    io_uring_buf_reg reg{};
    reg.ring_addr = reinterpret_cast<std::uintptr_t>(ring_memory);
    reg.ring_entries = kBuffers;
    reg.bgid = 0;
    if (const int rc = io_uring_register_buf_ring(&ring, &reg, 0); rc != 0) {  // before 5.19
      spdlog::info("io_uring_register_buf_ring: {}: sockets are polled and read by their handlers",
                   std::strerror(-rc));
      std::free(ring_memory);
      std::free(buffer_memory);
      return;
    }
    buffer_ring = static_cast<io_uring_buf_ring*>(ring_memory);
    buffers = static_cast<unsigned char*>(buffer_memory);
    io_uring_buf_ring_init(buffer_ring);
    for (unsigned id = 0; id < kBuffers; ++id) {
      io_uring_buf_ring_add(buffer_ring, buffers + std::size_t{id} * kBufferBytes, kBufferBytes,
                            static_cast<unsigned short>(id), io_uring_buf_ring_mask(kBuffers), static_cast<int>(id));
    }
    io_uring_buf_ring_advance(buffer_ring, kBuffers);
    receives = true;
    receives_flag->store(true, std::memory_order_release);
  }

  void give_back(unsigned id) noexcept {
    io_uring_buf_ring_add(buffer_ring, buffers + std::size_t{id} * kBufferBytes, kBufferBytes,
                          static_cast<unsigned short>(id), io_uring_buf_ring_mask(kBuffers), 0);
    io_uring_buf_ring_advance(buffer_ring, 1);
  }

  static std::uint64_t tag(Kind kind, std::uint32_t generation, std::uint32_t index) noexcept {
    return (std::uint64_t{kind} << 62) | (std::uint64_t{generation & 0x3fffffffU} << 32) | index;
  }

  // A free submission entry; submits what is queued when there is none (the queue is then empty:
  // null only if that submit failed, which needs a completion queue overflowing, and the
  // queue's 512 entries are more than the polls, cancels and 64 sends that can be out at once).
  io_uring_sqe* entry() noexcept {
    io_uring_sqe* sqe = io_uring_get_sqe(&ring);
    if (sqe == nullptr) {
      (void)io_uring_submit(&ring);
      sqe = io_uring_get_sqe(&ring);
    }
    return sqe;
  }

  bool received(const Watched& w) const noexcept { return receives && !w.polled(); }

  void arm(std::uint32_t index) noexcept {
    Watched& w = watched[index];
    io_uring_sqe* sqe = entry();
    if (sqe == nullptr) return;  // see entry(): not seen to happen; the descriptor would go unwatched
    if (received(w)) {
      io_uring_prep_recvmsg_multishot(sqe, w.fd, w.header.get(), 0);
      sqe->flags |= IOSQE_BUFFER_SELECT;
      sqe->buf_group = 0;
      io_uring_sqe_set_data64(sqe, tag(kReceive, w.generation, index));
      w.armed = kReceive;
      return;
    }
    io_uring_prep_poll_add(sqe, w.fd, POLLIN);
    io_uring_sqe_set_data64(sqe, tag(kPoll, w.generation, index));
    w.armed = kPoll;
  }

  Result<void> add(int fd, ReadableHandler& handler, MessageHandler* receiver = nullptr) {
    if (::fcntl(fd, F_GETFD) < 0) return make_error(std::string("io_uring poll of descriptor ") +
                                                   std::to_string(fd) + ": " + std::strerror(errno));
    std::uint32_t index = 0;
    while (index < watched.size() && watched[index].active) ++index;
    if (index == watched.size()) watched.emplace_back();  // the control side of the thread: may allocate
    Watched& w = watched[index];
    w.fd = fd;
    w.handler = &handler;
    w.receiver = receiver;
    w.failures = 0;
    w.received_once = false;
    if (receiver != nullptr) {
      if (!w.header) w.header = std::make_unique<msghdr>();
      *w.header = msghdr{};
      w.header->msg_controllen = std::min(receiver->control_bytes(), MessageHandler::kControlBytes);
    }
    w.generation = (w.generation + 1) & 0x3fffffffU;
    w.active = true;
    arm(index);
    return {};
  }

  void remove(int fd) noexcept {
    for (std::uint32_t index = 0; index < watched.size(); ++index) {
      Watched& w = watched[index];
      if (!w.active || w.fd != fd) continue;
      const bool was_received = w.armed == kReceive;
      const std::uint64_t armed = tag(was_received ? kReceive : kPoll, w.generation, index);
      w.active = false;
      w.generation = (w.generation + 1) & 0x3fffffffU;
      // The armed poll or receive holds the descriptor's file until it is cancelled (a dup2 over
      // the number would otherwise leave it watching the old socket).
      if (io_uring_sqe* sqe = entry()) {
        if (was_received) {
          io_uring_prep_cancel64(sqe, armed, 0);
        } else {
          io_uring_prep_poll_remove(sqe, armed);
        }
        io_uring_sqe_set_data64(sqe, tag(kCancel, 0, 0));
      }
      // Submitted now, with any re-arm queued for it this round, while the number still names
      // the old socket: the caller may dup2 another over it or close it next.
      (void)io_uring_submit(&ring);
    }
  }

  bool send(int fd, const void* data, std::uint32_t size, SendTracker& tracker, std::uint64_t cookie) noexcept {
    if (size > kSendBytes) return false;
    io_uring_sqe* sqe = free_count != 0 ? entry() : nullptr;
    if (sqe == nullptr) {
      // The caller writes the frame itself: what is queued goes first, so frames keep their order.
      (void)io_uring_submit(&ring);
      return false;
    }
    const unsigned index = free_sends[--free_count];
    Send& s = sends[index];
    std::memcpy(s.bytes, data, size);
    s.tracker = &tracker;
    s.cookie = cookie;
    tracker.in_flight.fetch_add(1, std::memory_order_relaxed);
    ++sends_out;
    io_uring_prep_send(sqe, fd, s.bytes, size, MSG_DONTWAIT | MSG_NOSIGNAL);
    io_uring_sqe_set_data64(sqe, tag(kSend, 0, index));
    return true;
  }

  // The end of a send: its tracker told, its slot free again.
  void finish_send(std::uint32_t index, int result) noexcept {
    Send& s = sends[index];
    SendTracker* tracker = s.tracker;
    s.tracker = nullptr;
    free_sends[free_count++] = index;
    --sends_out;
    tracker->on_send_done(result, s.cookie);
    tracker->in_flight.fetch_sub(1, std::memory_order_release);
  }

  // After the thread's last round: every send still out is done, sent or not, so that no
  // tracker waits for it (the kernel took it when the submit succeeded; else -ECANCELED).
  void finish_all() noexcept {
    io_uring_cqe* cqe = nullptr;
    while (io_uring_peek_cqe(&ring, &cqe) == 0) {
      const std::uint64_t user_data = cqe->user_data;
      const int result = cqe->res;
      io_uring_cqe_seen(&ring, cqe);
      if ((user_data >> 62) == kSend) finish_send(static_cast<std::uint32_t>(user_data), result);
    }
    for (std::uint32_t index = 0; index < kSends; ++index) {
      if (sends[index].tracker != nullptr) finish_send(index, -ECANCELED);
    }
  }

  // One completion: a handler's turn (and its poll armed again), a message for a receiver, a
  // send's result, or nothing.
  void complete(std::uint64_t user_data, int result, std::uint32_t flags) noexcept {
    const auto kind = static_cast<Kind>(user_data >> 62);
    const auto index = static_cast<std::uint32_t>(user_data);
    if (kind == kSend) {
      finish_send(index, result);
      return;
    }
    if (kind == kReceive) {
      receive(index, static_cast<std::uint32_t>(user_data >> 32) & 0x3fffffffU, result, flags);
      return;
    }
    if (kind != kPoll || index >= watched.size()) return;
    const auto generation = static_cast<std::uint32_t>(user_data >> 32) & 0x3fffffffU;
    if (!watched[index].active || watched[index].generation != generation) return;  // removed since
    if (result < 0) {
      // The poll could not be armed: the descriptor was closed while watched, which its owner
      // never does (sockets are replaced by dup2 under the same number, after a remove). Armed
      // again it would fail again, so it stays unwatched, and says so once.
      spdlog::error("io_uring poll of descriptor {} failed: {}; it is no longer watched", watched[index].fd,
                    std::strerror(-result));
      watched[index].active = false;
      return;
    }
    watched[index].handler->on_readable();
    // Armed again unless the handler removed it (the vector may have grown: index, not reference).
    if (watched[index].active && watched[index].generation == generation) arm(index);
  }

  void receive(std::uint32_t index, std::uint32_t generation, int result, std::uint32_t flags) noexcept {
    const bool has_buffer = (flags & IORING_CQE_F_BUFFER) != 0;
    const unsigned id = flags >> IORING_CQE_BUFFER_SHIFT;
    auto current = [&] {
      return index < watched.size() && watched[index].active && watched[index].generation == generation;
    };
    if (current()) {
      Watched& w = watched[index];
      if (result >= 0 && has_buffer) {
        w.failures = 0;
        w.received_once = true;
        msghdr& header = *w.header;
        unsigned char* buffer = buffers + std::size_t{id} * kBufferBytes;
        io_uring_recvmsg_out* out = io_uring_recvmsg_validate(buffer, result, &header);
        if (out == nullptr) {
          w.receiver->on_receive_error(EMSGSIZE);
        } else {
          msghdr view{};
          view.msg_control = static_cast<unsigned char*>(io_uring_recvmsg_name(out)) + header.msg_namelen;
          view.msg_controllen = out->controllen;
          view.msg_flags = static_cast<int>(out->flags);
          std::uint32_t size = io_uring_recvmsg_payload_length(out, result, &header);
          if (size > MessageHandler::kMessageBytes) {  // the buffer holds more than a handler takes
            size = MessageHandler::kMessageBytes;
            view.msg_flags |= MSG_TRUNC;
          }
          w.receiver->on_message(static_cast<const std::byte*>(io_uring_recvmsg_payload(out, &header)), size, view);
        }
      } else if (result == -EINVAL && !w.received_once) {
        // Its first receive refused: no multishot recvmsg in this kernel (before 6.0). Polled
        // from now on (each receiver finds out for itself).
        w.failures = Watched::kPolledAfter;
      } else if (result < 0 && result != -ENOBUFS) {
        // ENOBUFS: every provided buffer was taken (a CAN socket never reports ENOBUFS itself);
        // the ones handed back since let it go on.
        if (++watched[index].failures >= 3) {
          spdlog::warn("io_uring receive on descriptor {} failed three times in a row ({}): polled from now on",
                       watched[index].fd, std::strerror(-result));
        }
        watched[index].receiver->on_receive_error(-result);
      }
    }
    if (has_buffer) give_back(id);
    // A multishot receive ends with an error, or when the buffers ran out: armed again.
    if ((flags & IORING_CQE_F_MORE) == 0 && current()) arm(index);
  }
};

#else  // no liburing at build time: the thread always waits with epoll

struct FdReactor::Ring {
  std::atomic<bool>* receives_flag = nullptr;
  int init() { return -ENOSYS; }
  Result<void> add(int, ReadableHandler&, MessageHandler* = nullptr) { return make_error("built without io_uring"); }
  void remove(int) noexcept {}
  bool send(int, const void*, std::uint32_t, SendTracker&, std::uint64_t) noexcept { return false; }
};

#endif

FdReactor::FdReactor(std::string thread_name, std::string what, ReactorIo io, std::chrono::milliseconds tick_interval)
    : thread_name_(std::move(thread_name)),
      what_(std::move(what)),
      tick_interval_(tick_interval.count() > 0 ? tick_interval : kTickInterval),  // 0 would disarm the timer
      io_(io) {}

std::shared_ptr<FdReactor> FdReactor::create(std::string thread_name, std::string what, ReactorIo io) {
  return std::shared_ptr<FdReactor>(new FdReactor(std::move(thread_name), std::move(what), io));
}

FdReactor::~FdReactor() {
  if (thread_.joinable()) {
    stopping_.store(true, std::memory_order_release);
    const std::uint64_t one = 1;
    (void)::write(wake_fd_, &one, sizeof one);
    thread_.join();
  }
  ring_.reset();
  if (timer_fd_ >= 0) ::close(timer_fd_);
  if (wake_fd_ >= 0) ::close(wake_fd_);
  if (epoll_fd_ >= 0) ::close(epoll_fd_);
}

Result<void> FdReactor::start() {
  const std::lock_guard lock(start_mutex_);
  if (thread_.joinable()) return {};
  // A failure closes what this call opened, so a later add() starts afresh and leaks nothing.
  auto close_all = [this] {
    for (int* fd : {&timer_fd_, &wake_fd_, &epoll_fd_}) {
      if (*fd >= 0) ::close(*fd);
      *fd = -1;
    }
  };
  auto fail = [&](const char* what) {
    const std::string message = std::string(what) + ": " + std::strerror(errno);
    close_all();
    return make_error(message);
  };
  epoll_fd_ = ::epoll_create1(EPOLL_CLOEXEC);
  if (epoll_fd_ < 0) return fail("epoll_create1");
  wake_fd_ = ::eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
  if (wake_fd_ < 0) return fail("eventfd");
  timer_fd_ = ::timerfd_create(CLOCK_MONOTONIC, TFD_CLOEXEC | TFD_NONBLOCK);
  if (timer_fd_ < 0) return fail("timerfd_create");
  epoll_event event{};
  event.events = EPOLLIN;
  event.data.ptr = static_cast<ReadableHandler*>(&wake_);
  if (::epoll_ctl(epoll_fd_, EPOLL_CTL_ADD, wake_fd_, &event) != 0) return fail("epoll_ctl");
  event.data.ptr = static_cast<ReadableHandler*>(&timer_);
  if (::epoll_ctl(epoll_fd_, EPOLL_CTL_ADD, timer_fd_, &event) != 0) return fail("epoll_ctl");
  // The ring is made by the thread that alone submits to it; start() waits to know how it waits.
  const ReactorIo asked = io_.load(std::memory_order_relaxed);
  std::promise<int> ring_made;
  std::future<int> ring_result = ring_made.get_future();
  thread_ = std::thread([this, asked, &ring_made] {
    thread_id_.store(static_cast<unsigned long>(pthread_self()), std::memory_order_release);
    int rc = -EOPNOTSUPP;
    if (asked != ReactorIo::epoll) {
      auto ring = std::make_unique<Ring>();
      ring->receives_flag = &ring_receives_;
      rc = ring->init();
      if (rc == 0) ring_ = std::move(ring);
    }
    io_.store(ring_ ? ReactorIo::io_uring : ReactorIo::epoll, std::memory_order_release);
    const bool leave = asked == ReactorIo::io_uring && !ring_;
    ring_made.set_value(rc);  // `ring_made` is start()'s: not touched after this
    if (!leave) run();
  });
  const int ring_rc = ring_result.get();
  if (asked == ReactorIo::io_uring && ring_rc != 0) {
    thread_id_.store(0, std::memory_order_release);  // pthread_t values are reused
    thread_.join();
    close_all();
    io_.store(asked, std::memory_order_release);
    return make_error(std::string("io_uring_setup for ") + what_ + ": " + std::strerror(-ring_rc) +
                      " (this kernel or a seccomp filter refuses io_uring; --can-io epoll waits with epoll)");
  }
  if (asked == ReactorIo::automatic && ring_rc != 0) {
    spdlog::info("{} waits with epoll: io_uring_setup: {}", what_, std::strerror(-ring_rc));
  }
  pthread_setname_np(thread_.native_handle(), thread_name_.c_str());
  apply_scheduling();
  return {};
}

void FdReactor::want(const ThreadScheduling& scheduling) {
  std::lock_guard<std::mutex> lock(start_mutex_);
  const ThreadScheduling wanted = scheduling_ ? stronger(*scheduling_, scheduling) : scheduling;
  if (scheduling_ && wanted == *scheduling_) return;
  scheduling_ = wanted;
  if (thread_.joinable()) apply_scheduling();
}

void FdReactor::apply_scheduling() {
  if (!scheduling_) return;
  applied_ = polyport::apply_scheduling(thread_.native_handle(), *scheduling_, what_);
  if (!applied_.problem.empty()) spdlog::warn("{}", applied_.problem);
}

nlohmann::json FdReactor::scheduling() const {
  std::lock_guard<std::mutex> lock(start_mutex_);
  if (!scheduling_) return nullptr;
  return {{"asked", to_string(*scheduling_)}, {"realtime", applied_.realtime_applied}, {"pinned", applied_.pinned}};
}

bool FdReactor::on_thread() const noexcept {
  const unsigned long id = thread_id_.load(std::memory_order_acquire);
  return id != 0 && pthread_equal(static_cast<pthread_t>(id), pthread_self()) != 0;
}

bool FdReactor::on_reactor_thread(const std::function<void()>& change) {
  if (on_thread()) {
    change();
    return true;
  }
  std::unique_lock lock(changes_mutex_);
  if (thread_gone_) return false;
  changes_.push_back(change);
  const std::uint64_t ticket = ++changes_posted_;
  lock.unlock();
  const std::uint64_t one = 1;
  (void)::write(wake_fd_, &one, sizeof one);
  lock.lock();
  changes_made_.wait(lock, [&] { return changes_done_ >= ticket || thread_gone_; });
  // A thread that left its loop (an io_uring_enter error) watches nothing more: a change left
  // for it is moot.
  return changes_done_ >= ticket;
}

void FdReactor::run_changes() noexcept {
  std::vector<std::function<void()>> now;
  {
    const std::lock_guard lock(changes_mutex_);
    now.swap(changes_);
  }
  for (const auto& change : now) change();
  {
    const std::lock_guard lock(changes_mutex_);
    changes_done_ += now.size();
  }
  changes_made_.notify_all();
}

void FdReactor::Wake::on_readable() noexcept {
  std::uint64_t count = 0;
  (void)::read(reactor->wake_fd_, &count, sizeof count);
  if (reactor->ring_) reactor->run_changes();
}

Result<void> FdReactor::add(int fd, ReadableHandler& handler) {
  if (auto started = start(); !started) return started;
  return add_in_tick(fd, handler);
}

void FdReactor::remove(int fd) noexcept {
  if (!thread_.joinable()) return;
  if (io() == ReactorIo::io_uring) {
    (void)on_reactor_thread([this, fd] { ring_->remove(fd); });
    return;
  }
  (void)::epoll_ctl(epoll_fd_, EPOLL_CTL_DEL, fd, nullptr);
  // The thread may have taken this socket's event from epoll_wait before the DEL and be
  // calling its handler now. Wake it and wait until it finishes a round begun after the DEL
  // had been read: by then it is past any call for this socket.
  const std::uint32_t round = rounds_.load(std::memory_order_acquire);
  const std::uint64_t one = 1;
  (void)::write(wake_fd_, &one, sizeof one);
  for (std::uint32_t seen = round; seen == round; seen = rounds_.load(std::memory_order_acquire)) {
    rounds_.wait(seen, std::memory_order_acquire);
  }
}

void FdReactor::remove_in_tick(int fd) noexcept {
  if (ring_) {
    ring_->remove(fd);
    return;
  }
  (void)::epoll_ctl(epoll_fd_, EPOLL_CTL_DEL, fd, nullptr);
}

Result<void> FdReactor::add_in_tick(int fd, ReadableHandler& handler) {
  if (io() == ReactorIo::io_uring) {
    Result<void> added = make_error(what_ + " has stopped (io_uring_enter failed)");
    (void)on_reactor_thread([&] { added = ring_->add(fd, handler); });
    return added;
  }
  epoll_event event{};
  event.events = EPOLLIN;
  event.data.ptr = static_cast<ReadableHandler*>(&handler);
  if (::epoll_ctl(epoll_fd_, EPOLL_CTL_ADD, fd, &event) != 0) {
    return make_error(std::string("epoll_ctl(EPOLL_CTL_ADD): ") + std::strerror(errno));
  }
  return {};
}

Result<void> FdReactor::add_receiver(int fd, MessageHandler& handler) {
  if (auto started = start(); !started) return started;
  return add_receiver_in_tick(fd, handler);
}

Result<void> FdReactor::add_receiver_in_tick(int fd, MessageHandler& handler) {
  if (io() != ReactorIo::io_uring) return add_in_tick(fd, handler);
  Result<void> added = make_error(what_ + " has stopped (io_uring_enter failed)");
  (void)on_reactor_thread([&] { added = ring_->add(fd, handler, &handler); });
  return added;
}

bool FdReactor::send_with_next_wait(int fd, const void* data, std::uint32_t size, SendTracker& tracker,
                                    std::uint64_t cookie) noexcept {
  // on_thread() first: only the thread itself reads ring_ here.
  return on_thread() && ring_ != nullptr && ring_->send(fd, data, size, tracker, cookie);
}

Result<void> FdReactor::watch(Supervised& supervised) {
  if (auto started = start(); !started) return started;
  {
    // The tick runs once something is watched (an idle timer would wake the thread for nothing).
    const std::lock_guard lock(start_mutex_);
    if (!ticking_) {
      itimerspec period{};
      const auto seconds = std::chrono::duration_cast<std::chrono::seconds>(tick_interval_);
      period.it_interval.tv_sec = static_cast<time_t>(seconds.count());
      period.it_interval.tv_nsec = static_cast<long>(std::chrono::nanoseconds(tick_interval_ - seconds).count());
      period.it_value = period.it_interval;
      if (::timerfd_settime(timer_fd_, 0, &period, nullptr) != 0) {
        return make_error(std::string("timerfd_settime: ") + std::strerror(errno));
      }
      ticking_ = true;
    }
  }
  const std::lock_guard lock(supervised_mutex_);
  supervised_.push_back(&supervised);
  return {};
}

void FdReactor::unwatch(Supervised& supervised) noexcept {
  const std::lock_guard lock(supervised_mutex_);
  supervised_.erase(std::remove(supervised_.begin(), supervised_.end(), &supervised), supervised_.end());
}

void FdReactor::tick() noexcept {
  std::uint64_t expirations = 0;
  (void)::read(timer_fd_, &expirations, sizeof expirations);
  const std::lock_guard lock(supervised_mutex_);
  for (Supervised* supervised : supervised_) supervised->on_tick();
}

void FdReactor::run() noexcept {
  if (ring_) {
    run_ring();
  } else {
    run_epoll();
  }
  {
    const std::lock_guard lock(changes_mutex_);
    thread_gone_ = true;
  }
  changes_made_.notify_all();
  // A remove() must not wait for a thread that has left: count one more round for it.
  rounds_.fetch_add(1, std::memory_order_seq_cst);
  rounds_.notify_all();
}

void FdReactor::end_round() noexcept {
  // seq_cst, not a plain store: notify_all() then reads whether anyone waits, and that read
  // must not pass the new count (remove() registers as a waiter before it reads the count).
  rounds_.fetch_add(1, std::memory_order_seq_cst);
  rounds_.notify_all();
}

void FdReactor::run_epoll() noexcept {
  constexpr int kMaxEvents = 16;
  epoll_event events[kMaxEvents];
  while (!stopping_.load(std::memory_order_acquire)) {
    const int ready = ::epoll_wait(epoll_fd_, events, kMaxEvents, -1);
    for (int i = 0; i < ready; ++i) static_cast<ReadableHandler*>(events[i].data.ptr)->on_readable();
    if (ready < 0 && errno != EINTR) break;
    end_round();
  }
}

void FdReactor::run_ring() noexcept {
#ifdef POLYPORT_WITH_IO_URING
  Ring& r = *ring_;
  (void)r.add(wake_fd_, wake_);
  (void)r.add(timer_fd_, timer_);
  struct Done {
    std::uint64_t user_data;
    int result;
    std::uint32_t flags;
  };
  Done done[Ring::kCompletions];
  io_uring_cqe* cqes[Ring::kCompletions];
  while (!stopping_.load(std::memory_order_acquire)) {
    // Submits what the last round queued (its sends, the polls armed again) and waits for the
    // next event: the round's one system call. The sends complete in the call (MSG_DONTWAIT),
    // so it waits for their completions and one more. Completions left from the last look (more
    // than kCompletions came) are taken first, without waiting.
    const int rc = io_uring_cq_ready(&r.ring) != 0 ? io_uring_submit(&r.ring)
                                                   : io_uring_submit_and_wait(&r.ring, r.sends_out + 1);
    if (rc < 0 && rc != -EINTR && rc != -EAGAIN && rc != -EBUSY) {
      spdlog::error("{}: io_uring_enter: {}; the thread stops", what_, std::strerror(-rc));
      break;
    }
    // Copied out first: a handler's submission may need the room on the completion queue.
    const unsigned n = io_uring_peek_batch_cqe(&r.ring, cqes, Ring::kCompletions);
    for (unsigned i = 0; i < n; ++i) done[i] = Done{cqes[i]->user_data, cqes[i]->res, cqes[i]->flags};
    io_uring_cq_advance(&r.ring, n);
    for (unsigned i = 0; i < n; ++i) r.complete(done[i].user_data, done[i].result, done[i].flags);
    end_round();
  }
  // Sends still queued go out (or are given up), so no tracker waits for them forever.
  (void)io_uring_submit(&r.ring);
  r.finish_all();
#endif
}

}  // namespace polyport
