// What every model that carries services reads the same way from its component element
// (DDS's <dds>, LCM's <lcm>): the cap on calls in flight per service port and how long
// polyport waits for a foreign server's reply. Set-up code only.
#pragma once

#include <cstdint>
#include <optional>
#include <string_view>

#include "polyport/profile/profile_element.hpp"

namespace polyport {

struct CallLimits {
  std::uint32_t max_calls_in_flight = 16;        // per service port, both directions
  std::int64_t call_timeout_ns = 1'000'000'000;  // a foreign provider's reply, at most
};

// Calls in flight per service port: enough for any sane client, bounded for the tables.
inline constexpr std::uint32_t kMaxCallsInFlight = 4096;

// The rules for the two elements, keyed "max_calls_in_flight" and "call_timeout".
inline ElementRule max_calls_rule() { return {"max_calls_in_flight", {"max_calls_in_flight"}}; }
inline ElementRule call_timeout_rule() { return {"call_timeout", {"call_timeout_ms"}}; }

// A duration in milliseconds (decimal, 0 to a day), as nanoseconds; a bad one is reported
// at the text ("bad <what> 'x': expected a number of milliseconds from 0 to 86400000").
std::optional<std::int64_t> milliseconds_text(const ProfileElement& element, std::string_view what);

// Reads <max_calls_in_flight> and <call_timeout_ms> among `children` into `limits`; each bad
// value is reported where it is written and leaves the default.
void read_call_limits(const ProfileChildren& children, CallLimits& limits);

}  // namespace polyport
