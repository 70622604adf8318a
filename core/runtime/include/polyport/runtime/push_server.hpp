// SmartSoft's push patterns on an output data port (a "push server"):
//  - push newest: every new value reaches every subscriber (the port's connections, with
//    their queue policies), and a subscriber that comes later (a connection made at run time
//    or by a reload) is primed with the latest value at once;
//  - push timed: the port publishes once per base cycle; each subscribing connection takes
//    every Nth cycle (Connection::set_subscription). An in-process periodic component whose
//    base cycle is k periods has its writes thinned to the first of every k.
// Either can be stopped by its component ("not active"): writes go nowhere, and subscribers'
// reads say not_active once they have read what came before.
//
// Ownership: the port owns its PushServer; the latest sample's slot is allocated once, here.
// Threads: write() runs on the port's writer thread and never allocates. For push newest it
// holds a flag that the control thread takes only while it primes a new connection and
// publishes it (ConnectionSetObserver), so that the new subscriber neither misses a sample
// nor gets one twice. Subscription changes (connections added or removed, a client's
// subscribe / unsubscribe) go into a small queue under a mutex, which the server's component
// drains with try_lock (never waiting) on its own thread.
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string_view>

#include "polyport/base/clock.hpp"
#include "polyport/base/result.hpp"
#include "polyport/base/status.hpp"
#include "polyport/profile/profile.hpp"
#include "polyport/runtime/port.hpp"

namespace polyport {

struct Subcomponent;

// One subscribe or unsubscribe as the server's component is told of it.
struct SubscriptionChange {
  enum class Kind : std::uint8_t { subscribe, unsubscribe };
  Kind kind = Kind::subscribe;
  std::uint32_t every = 1;    // push timed: the subscriber's multiple of the base cycle
  std::uint32_t subscribers = 0;  // the server's subscribers after this change
  char subscriber[96] = {};   // "Component.port" of the subscriber, cut to fit
};

struct PushCounters {
  std::atomic<std::uint64_t> primed{0};            // latest values handed to new subscribers
  std::atomic<std::uint64_t> not_active{0};        // writes while stopped (sent nowhere)
  std::atomic<std::uint64_t> between_cycles{0};    // in-process writes thinned to the base cycle
  std::atomic<std::uint64_t> latest_too_large{0};  // larger than the latest value's slot: not kept
  std::atomic<std::uint64_t> changes_lost{0};      // subscription changes the component did not drain in time
};

class PushServer final : public ConnectionSetObserver {
 public:
  // `writes_per_cycle`: an in-process periodic component's base cycle in periods (1 else).
  PushServer(DataOutPort& port, PushPattern pattern, Nanos cycle, std::uint32_t writes_per_cycle = 1);
  PushServer(const PushServer&) = delete;
  PushServer& operator=(const PushServer&) = delete;
  ~PushServer() override;

  PushPattern pattern() const noexcept { return pattern_; }
  Nanos cycle() const noexcept { return cycle_; }  // timed: the base cycle (0: newest)
  DataOutPort& port() const noexcept { return port_; }

  // Writer thread: DataOutPort::write of a push port comes here.
  Status write(const void* data, std::uint32_t size, MonoTime t_source) noexcept;

  // The server's state (its component's thread, or any): stopped, nothing is sent and
  // subscribers read not_active. Started at first.
  void start() noexcept { active_.store(true, std::memory_order_release); }
  void stop() noexcept { active_.store(false, std::memory_order_release); }
  bool active() const noexcept { return active_.load(std::memory_order_acquire); }
  std::size_t subscribers() const noexcept { return port_.connections().size(); }

  // The next subscription change since the last call; false when none (or when the control
  // thread is adding one right now: ask again next cycle). Never waits.
  bool next_change(SubscriptionChange& change) noexcept;
  // A client (its in-process input port) subscribed again or unsubscribed.
  void tell(SubscriptionChange::Kind kind, const Connection& subscriber, std::uint32_t every) noexcept;

  // ConnectionSetObserver (control thread).
  void adding(Connection& connection) noexcept override;
  void added(Connection& connection) noexcept override;
  void removed(Connection& connection) noexcept override;

  const PushCounters& counters() const noexcept { return counters_; }

 private:
  void lock() noexcept;
  void unlock() noexcept;
  void queue_change(SubscriptionChange::Kind kind, const Connection& subscriber, std::uint32_t every) noexcept;

  DataOutPort& port_;
  PushPattern pattern_;
  Nanos cycle_;
  std::uint32_t writes_per_cycle_;
  std::uint32_t phase_ = 0;  // writer thread: writes since the last base cycle began
  std::atomic<bool> active_{true};
  // Push newest: held by the writer, or the control thread priming. 0 free, 1 held, 2 held
  // with a sleeper (a futex word: a waiter sleeps instead of yielding, which a real-time
  // writer would never do in favour of an ordinary holder).
  std::atomic<std::uint32_t> busy_{0};
  std::atomic<const void*> holder_{nullptr};  // the thread that holds busy_ (re-entry check)
  // Push newest: the latest sample (under busy_).
  std::unique_ptr<std::byte[]> latest_;
  std::uint32_t latest_capacity_ = 0;
  SampleMeta latest_meta_{};
  bool has_latest_ = false;
  // Subscription changes, oldest first.
  static constexpr std::size_t kChanges = 32;
  std::mutex changes_mutex_;
  std::array<SubscriptionChange, kChanges> changes_{};
  std::size_t changes_head_ = 0;
  std::size_t changes_count_ = 0;
  PushCounters counters_;
};

// Gives each output data port the PushServer its <push> asks for (after the component's model
// made its ports).
Result<void> attach_push_servers(const Subcomponent& sub, Component& adaptor);

}  // namespace polyport
