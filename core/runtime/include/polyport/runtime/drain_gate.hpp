// One drainer at a time, without a lock: for SDK callbacks that say "there is data, take it"
// and may come from more than one thread at once (Fast DDS calls a reader's listener from
// its receive thread and, for a writer in the same process, from the writing thread).
//
// Each notification calls run(drain). If nobody is draining, this thread drains, and keeps
// draining until no notification arrived during its last pass; otherwise it only records the
// notification and returns at once, and the thread that is draining runs one more pass for
// it. So:
//  - drain never runs on two threads at once (state it touches needs no lock);
//  - every notification is followed by a drain that starts after it (nothing is left behind
//    until the next notification);
//  - a notifier never waits, never blocks and never allocates, and a drain that triggers a
//    notification of its own gate (a write delivered in-process back to the same reader)
//    does not deadlock: the nested call returns and the outer loop drains again.
// The cost: a notifier that finds a drain in progress hands its data to that drainer's
// thread. On the uncontended path it is one atomic add and one atomic subtract.
#pragma once

#include <atomic>
#include <cstdint>

namespace polyport {

class DrainGate {
 public:
  // `drain` must not throw: a pass that unwound would leave its notifications counted, and
  // the gate shut for good.
  template <class Drain>
  void run(Drain&& drain) noexcept {
    static_assert(noexcept(drain()), "DrainGate::run needs a noexcept drain");
    // Notifications not yet answered by a pass; the thread that raised it from 0 drains.
    if (pending_.fetch_add(1, std::memory_order_acq_rel) != 0) return;
    std::uint64_t answered = 1;
    for (;;) {
      drain();
      // A pass answers every notification counted before it started; any that came during
      // the pass are still counted, and need another pass.
      const std::uint64_t before = pending_.fetch_sub(answered, std::memory_order_acq_rel);
      if (before == answered) return;
      answered = before - answered;
    }
  }

 private:
  std::atomic<std::uint64_t> pending_{0};
};

}  // namespace polyport
