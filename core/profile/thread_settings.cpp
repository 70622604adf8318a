// <receive_thread policy priority cpu/>: the scheduling of a thread a model runs
// (thread_settings.hpp), checked as <execution_semantics> is.
#include "polyport/profile/thread_settings.hpp"

#include "loader.hpp"

namespace polyport {

std::optional<ThreadScheduling> read_receive_thread(const ProfileChildren& children) {
  using namespace detail;
  const ProfileElement element = children.one("receive_thread");
  if (!element) return std::nullopt;
  ThreadScheduling out;
  bool ok = true;
  if (element.has_attribute("policy")) {
    const std::string written = element.attribute("policy");
    if (const auto policy = lookup(kSchedPolicies, written)) {
      out.policy = *policy;
    } else {
      element.error_attribute("policy", "bad scheduling policy " + in_quotes(written) + " (accepted: " +
                                            accepted(kSchedPolicies) + ")");
      ok = false;
    }
  }
  if (element.has_attribute("priority")) {
    const std::string written = element.attribute("priority");
    const auto priority = parse_integer<int>(written);
    if (!priority) {
      element.error_attribute("priority", "bad priority " + in_quotes(written) + ": expected an integer");
      ok = false;
    } else {
      out.priority = *priority;
    }
  }
  if (ok && out.realtime()) {
    const std::string name(detail::sched_policy_name(out.policy));
    if (!element.has_attribute("priority")) {
      element.error(name + " needs a priority from " + std::to_string(kMinRtPriority) + " to " +
                    std::to_string(kMaxRtPriority));
      ok = false;
    } else if (out.priority < kMinRtPriority || out.priority > kMaxRtPriority) {
      element.error_attribute("priority", "priority " + std::to_string(out.priority) + " is out of range for " + name +
                                              " (" + std::to_string(kMinRtPriority) + " to " +
                                              std::to_string(kMaxRtPriority) + ")");
      ok = false;
    }
  }
  if (element.has_attribute("cpu")) {
    const std::string written = element.attribute("cpu");
    const auto cpu = parse_integer<int>(written);
    if (!cpu || *cpu < 0 || *cpu > kMaxCpu) {
      element.error_attribute("cpu", "bad cpu " + in_quotes(written) + ": expected an integer from 0 to " +
                                         std::to_string(kMaxCpu));
      ok = false;
    } else {
      out.cpu = *cpu;
    }
  }
  if (!ok) return std::nullopt;
  return out;
}

ThreadScheduling stronger(const ThreadScheduling& a, const ThreadScheduling& b) {
  const bool a_first = a.realtime() != b.realtime() ? a.realtime() : a.priority >= b.priority;
  ThreadScheduling out = a_first ? a : b;
  if (!out.cpu) out.cpu = a_first ? b.cpu : a.cpu;
  return out;
}

std::string to_string(const ThreadScheduling& scheduling) {
  std::string out(detail::sched_policy_name(scheduling.policy));
  if (scheduling.realtime()) out += " " + std::to_string(scheduling.priority);
  if (scheduling.cpu) out += " on CPU " + std::to_string(*scheduling.cpu);
  return out;
}

}  // namespace polyport
