// Counters that one thread at a time adds to: the forwarding path's per-sample counts.
//
// A relaxed fetch_add is still a locked read-modify-write on x86, and a locked instruction
// waits for the store buffer to drain: tens of cycles each, several per forwarded sample
// (port, connection, model counters and three histogram fields each), which the CPU-per-
// message figures show (README, "LCM one core"). A counter that only one thread writes at a
// time, each writer handing over to the next through a synchronising operation (a lock, a
// release / acquire flag, a thread's start or join), needs no lock: a plain load and store
// of the atomic keeps every increment, and readers on other threads still see whole values.
// Where two threads may add at the same moment, use fetch_add: this would lose counts.
#pragma once

#include <atomic>
#include <cstdint>

namespace polyport {

inline void add_serial(std::atomic<std::uint64_t>& counter, std::uint64_t n = 1) noexcept {
  counter.store(counter.load(std::memory_order_relaxed) + n, std::memory_order_relaxed);
}

}  // namespace polyport
