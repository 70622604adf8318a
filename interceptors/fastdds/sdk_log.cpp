#include "sdk_log.hpp"

#include <cstdio>
#include <memory>
#include <mutex>
#include <string>

#include <fastdds/dds/log/Log.hpp>

namespace polyport::fastdds {

namespace {

using eprosima::fastdds::dds::Log;

const char* level_name(Log::Kind kind) {
  switch (kind) {
    case Log::Kind::Error:
      return "error";
    case Log::Kind::Warning:
      return "warning";
    case Log::Kind::Info:
      return "info";
  }
  return "info";
}

class StderrConsumer final : public eprosima::fastdds::dds::LogConsumer {
 public:
  void Consume(const Log::Entry& entry) override {
    // Fast DDS stamps "YYYY-MM-DD HH:MM:SS.mmm"; polyport's log lines put a 'T' between.
    std::string stamp = entry.timestamp;
    if (stamp.size() > 10 && stamp[10] == ' ') stamp[10] = 'T';
    const char* category = entry.context.category != nullptr ? entry.context.category : "";
    const char* function = entry.context.function != nullptr ? entry.context.function : "";
    std::fprintf(stderr, "%s %s fastdds %s: %s%s%s%s\n", stamp.c_str(), level_name(entry.kind), category,
                 entry.message.c_str(), *function != '\0' ? " (" : "", function, *function != '\0' ? ")" : "");
  }
};

}  // namespace

void route_sdk_log() {
  static std::once_flag once;
  std::call_once(once, [] {
    Log::ClearConsumers();
    Log::RegisterConsumer(std::make_unique<StderrConsumer>());
  });
}

void flush_sdk_log() { Log::Flush(); }

}  // namespace polyport::fastdds
