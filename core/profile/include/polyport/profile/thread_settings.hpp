// The scheduling a profile asks for a thread a model runs for its components (an LCM
// instance's receive thread, the CAN epoll thread), written in the model's own component
// element as <receive_thread policy="SCHED_FIFO" priority="60" cpu="1"/>, with the values and
// checks of <execution_semantics>. Several components may share one such thread: the
// strongest request wins. Set-up code only; applied by runtime/thread_scheduling.hpp.
#pragma once

#include <optional>
#include <string>

#include "polyport/profile/profile.hpp"
#include "polyport/profile/profile_element.hpp"

namespace polyport {

struct ThreadScheduling {
  SchedPolicy policy = SchedPolicy::other;
  int priority = 0;        // 1 to 99 with SCHED_FIFO / SCHED_RR
  std::optional<int> cpu;  // pinned to this CPU
  bool realtime() const noexcept { return policy != SchedPolicy::other; }
  bool operator==(const ThreadScheduling&) const = default;
};

// The rule for <receive_thread>, keyed "receive_thread".
inline ElementRule receive_thread_rule() { return {"receive_thread", {"receive_thread"}, false, {"policy", "priority", "cpu"}}; }

// Reads <receive_thread> among `children`; nullopt when absent or wrong (each problem is
// reported at its attribute).
std::optional<ThreadScheduling> read_receive_thread(const ProfileChildren& children);

// The stronger of two requests: a real-time policy over SCHED_OTHER, then the higher
// priority; the CPU of the stronger, else the other's.
ThreadScheduling stronger(const ThreadScheduling& a, const ThreadScheduling& b);

// "SCHED_FIFO 60 on CPU 1", "SCHED_OTHER".
std::string to_string(const ThreadScheduling& scheduling);

}  // namespace polyport
