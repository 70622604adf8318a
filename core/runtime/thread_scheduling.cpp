#include "polyport/runtime/thread_scheduling.hpp"

#include <sched.h>
#include <sys/resource.h>
#include <unistd.h>

#include <cstring>

namespace polyport {

std::string realtime_refusal(const ThreadScheduling& scheduling) {
  if (!scheduling.realtime() || geteuid() == 0) return {};
  rlimit limit{};
  if (getrlimit(RLIMIT_RTPRIO, &limit) == 0 &&
      (limit.rlim_cur == RLIM_INFINITY || limit.rlim_cur >= static_cast<rlim_t>(scheduling.priority))) {
    return {};
  }
  return "real-time priority " + std::to_string(scheduling.priority) + " is not allowed for this process (not root, " +
         "RLIMIT_RTPRIO " + std::to_string(limit.rlim_cur) + ")";
}

SchedulingOutcome apply_scheduling(pthread_t thread, const ThreadScheduling& scheduling, std::string_view what) {
  SchedulingOutcome out;
  if (scheduling.realtime()) {
    sched_param param{};
    param.sched_priority = scheduling.priority;
    const int policy = scheduling.policy == SchedPolicy::fifo ? SCHED_FIFO : SCHED_RR;
    const int rc = pthread_setschedparam(thread, policy, &param);
    if (rc == 0) {
      out.realtime_applied = true;
    } else {
      out.problem = std::string(what) + ": real-time priority " + std::to_string(scheduling.priority) + " refused (" +
                    std::strerror(rc) + "); running with SCHED_OTHER";
    }
  }
  if (scheduling.cpu) {
    cpu_set_t set;
    CPU_ZERO(&set);
    CPU_SET(*scheduling.cpu, &set);
    const int rc = pthread_setaffinity_np(thread, sizeof(set), &set);
    if (rc == 0) {
      out.pinned = true;
    } else {
      out.problem += std::string(out.problem.empty() ? "" : "; ") + std::string(what) + ": pinning to CPU " +
                     std::to_string(*scheduling.cpu) + " refused (" + std::strerror(rc) + "); not pinned";
    }
  }
  return out;
}

}  // namespace polyport
