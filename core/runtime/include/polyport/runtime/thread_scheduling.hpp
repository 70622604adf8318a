// Applying a scheduling request (policy, priority, CPU) to a running thread: execution
// contexts, an LCM instance's receive thread, the CAN epoll thread. Control path.
#pragma once

#include <pthread.h>

#include <string>
#include <string_view>

#include "polyport/profile/thread_settings.hpp"

namespace polyport {

struct SchedulingOutcome {
  bool realtime_applied = false;  // the policy and priority were taken
  bool pinned = false;            // the CPU was taken
  std::string problem;            // one sentence per refusal, for a warning; empty when none
};

// Why this process may not give a thread `scheduling`'s real-time priority (not root and
// RLIMIT_RTPRIO below it), for SDKs that fail outright when refused; empty when it may.
std::string realtime_refusal(const ThreadScheduling& scheduling);

// `what` names the thread in the problem ("execution context 'ec-10ms'").
SchedulingOutcome apply_scheduling(pthread_t thread, const ThreadScheduling& scheduling, std::string_view what);

}  // namespace polyport
