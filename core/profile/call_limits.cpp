#include "polyport/profile/call_limits.hpp"

#include <string>

#include "polyport/profile/profile_text.hpp"

namespace polyport {

std::optional<std::int64_t> milliseconds_text(const ProfileElement& element, std::string_view what) {
  const std::string written = element.text();
  const auto value = text::parse_decimal(written);
  constexpr double kMaxMs = 86'400'000.0;
  if (!value || *value < 0.0 || *value > kMaxMs) {
    element.error_text("bad " + std::string(what) + " " + text::in_quotes(written) +
                       ": expected a number of milliseconds from 0 to 86400000");
    return std::nullopt;
  }
  return static_cast<std::int64_t>(*value * 1e6 + 0.5);
}

void read_call_limits(const ProfileChildren& children, CallLimits& limits) {
  if (const ProfileElement cap = children.one("max_calls_in_flight")) {
    const std::string written = cap.text();
    const auto value = text::parse_integer<std::uint32_t>(written);
    if (!value || *value == 0 || *value > kMaxCallsInFlight) {
      cap.error_text("bad max_calls_in_flight " + text::in_quotes(written) + ": expected an integer from 1 to " +
                     std::to_string(kMaxCallsInFlight));
    } else {
      limits.max_calls_in_flight = *value;
    }
  }
  if (const ProfileElement timeout = children.one("call_timeout")) {
    if (const auto ns = milliseconds_text(timeout, "call_timeout_ms"); ns && *ns > 0) {
      limits.call_timeout_ns = *ns;
    } else if (ns) {
      timeout.error_text("call_timeout_ms must be greater than 0");
    }
  }
}

}  // namespace polyport
