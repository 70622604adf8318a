// Push newest and push timed on an output data port. See push_server.hpp for who owns what
// and which thread runs what.
#include "polyport/runtime/push_server.hpp"

#include <linux/futex.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstring>

#include "polyport/runtime/component.hpp"
#include "polyport/runtime/connection.hpp"

namespace polyport {

PushServer::PushServer(DataOutPort& port, PushPattern pattern, Nanos cycle, std::uint32_t writes_per_cycle)
    : port_(port), pattern_(pattern), cycle_(cycle), writes_per_cycle_(std::max<std::uint32_t>(writes_per_cycle, 1)) {
  if (pattern_ == PushPattern::newest) {
    latest_capacity_ = port.max_sample_bytes();
    latest_ = std::make_unique<std::byte[]>(latest_capacity_);
  }
}

PushServer::~PushServer() = default;

namespace {
// A per-thread address: who holds the latest slot.
const void* this_thread_token() noexcept {
  thread_local const char token = 0;
  return &token;
}
}  // namespace

void PushServer::lock() noexcept {
  // Held by the other side for one copy and forward (the writer) or one priming hand-over (the
  // control thread): spin briefly, then sleep on the word until the holder lets go, so that a
  // preempted holder gets the CPU even from a real-time writer (sched_yield would not give it
  // to a thread of lower priority). Uncontended, one compare-exchange.
  std::uint32_t expected = 0;
  for (int spins = 0; spins < 256; ++spins) {
    expected = 0;
    if (busy_.compare_exchange_weak(expected, 1, std::memory_order_acquire, std::memory_order_relaxed)) {
      holder_.store(this_thread_token(), std::memory_order_relaxed);
      return;
    }
#if defined(__x86_64__) || defined(__i386__)
    __builtin_ia32_pause();
#endif
  }
  // Marked 2 (a sleeper) while anyone holds it; taken as 2 too, since other sleepers may remain.
  while (busy_.exchange(2, std::memory_order_acquire) != 0) {
    syscall(SYS_futex, reinterpret_cast<std::uint32_t*>(&busy_), FUTEX_WAIT_PRIVATE, 2U, nullptr, nullptr, 0);
  }
  holder_.store(this_thread_token(), std::memory_order_relaxed);
}

void PushServer::unlock() noexcept {
  holder_.store(nullptr, std::memory_order_relaxed);
  if (busy_.exchange(0, std::memory_order_release) == 2) {
    syscall(SYS_futex, reinterpret_cast<std::uint32_t*>(&busy_), FUTEX_WAKE_PRIVATE, 1, nullptr, nullptr, 0);
  }
}

Status PushServer::write(const void* data, std::uint32_t size, MonoTime t_source) noexcept {
  if (!active_.load(std::memory_order_relaxed)) {
    counters_.not_active.fetch_add(1, std::memory_order_relaxed);
    return Status::not_active;
  }
  if (pattern_ == PushPattern::timed) {
    // An in-process component writes each period; the base cycle is every k-th of them.
    if (writes_per_cycle_ > 1) {
      const bool turn = phase_ == 0;
      phase_ = phase_ + 1 == writes_per_cycle_ ? 0 : phase_ + 1;
      if (!turn) {
        counters_.between_cycles.fetch_add(1, std::memory_order_relaxed);
        return Status::ok;
      }
    }
    return port_.forward(data, size, t_source);
  }
  if (holder_.load(std::memory_order_relaxed) == this_thread_token()) {
    // A subscriber's sink wrote into this port again on this thread (while it held the
    // latest slot): forward it, keep the outer sample as the latest, never wait for itself.
    return port_.forward(data, size, t_source);
  }
  lock();
  if (size <= latest_capacity_) {
    std::memcpy(latest_.get(), data, size);
    latest_meta_ = SampleMeta{size, {}, t_source};
    has_latest_ = true;
  } else {
    has_latest_ = false;  // a value that is not the latest must not be handed to anyone
    counters_.latest_too_large.fetch_add(1, std::memory_order_relaxed);
  }
  const Status status = port_.forward(data, size, t_source);
  unlock();
  return status;
}

// Push newest: the new subscriber gets the latest value before it sees the writer's next one;
// the writer waits meanwhile (one hand-over, on a control-plane action).
void PushServer::adding(Connection& connection) noexcept {
  if (pattern_ != PushPattern::newest) return;
  lock();
  if (has_latest_ && active_.load(std::memory_order_relaxed)) {
    SampleMeta meta = latest_meta_;
    meta.t_in = mono_now();  // its time in polyport starts now, not when it was written
    connection.deliver(latest_.get(), meta);
    counters_.primed.fetch_add(1, std::memory_order_relaxed);
  }
}

void PushServer::added(Connection& connection) noexcept {
  if (pattern_ == PushPattern::newest) unlock();
  queue_change(SubscriptionChange::Kind::subscribe, connection, std::max<std::uint32_t>(connection.subscription_every(), 1));
}

void PushServer::removed(Connection& connection) noexcept {
  queue_change(SubscriptionChange::Kind::unsubscribe, connection, std::max<std::uint32_t>(connection.subscription_every(), 1));
}

void PushServer::tell(SubscriptionChange::Kind kind, const Connection& subscriber, std::uint32_t every) noexcept {
  queue_change(kind, subscriber, every);
}

void PushServer::queue_change(SubscriptionChange::Kind kind, const Connection& subscriber, std::uint32_t every) noexcept {
  SubscriptionChange change;
  change.kind = kind;
  change.every = every;
  change.subscribers = static_cast<std::uint32_t>(subscribers());
  const std::string name = subscriber.target().full_name();
  std::memcpy(change.subscriber, name.data(), std::min(name.size(), sizeof change.subscriber - 1));
  const std::lock_guard lock(changes_mutex_);
  if (changes_count_ == kChanges) {
    // The oldest goes: what the component has not looked at for 32 changes is history.
    changes_head_ = (changes_head_ + 1) % kChanges;
    --changes_count_;
    counters_.changes_lost.fetch_add(1, std::memory_order_relaxed);
  }
  changes_[(changes_head_ + changes_count_) % kChanges] = change;
  ++changes_count_;
}

bool PushServer::next_change(SubscriptionChange& change) noexcept {
  const std::unique_lock lock(changes_mutex_, std::try_to_lock);
  if (!lock.owns_lock() || changes_count_ == 0) return false;
  change = changes_[changes_head_];
  changes_head_ = (changes_head_ + 1) % kChanges;
  --changes_count_;
  return true;
}

Result<void> attach_push_servers(const Subcomponent& sub, Component& adaptor) {
  const ComponentProfile& profile = sub.profile;
  for (const PortSpec& spec : profile.ports) {
    if (!spec.push) continue;
    auto* port = dynamic_cast<DataOutPort*>(adaptor.find_port(spec.name));
    if (port == nullptr) return make_error("the push port " + sub.name + "." + spec.name + " is no output data port");
    std::uint32_t writes_per_cycle = 1;
    const bool periodic = profile.execution.type == ExecutionType::periodic ||
                          profile.execution.type == ExecutionType::periodic_exclusive;
    if (spec.push->pattern == PushPattern::timed && profile.model == "inproc" && periodic &&
        profile.execution.period_ms > 0.0) {
      writes_per_cycle = static_cast<std::uint32_t>(std::max<long long>(1, std::llround(spec.push->cycle_ms / profile.execution.period_ms)));
    }
    const Nanos cycle{static_cast<std::int64_t>(std::llround(spec.push->cycle_ms * 1e6))};
    port->set_push(std::make_unique<PushServer>(*port, spec.push->pattern, cycle, writes_per_cycle));
  }
  return {};
}

}  // namespace polyport
