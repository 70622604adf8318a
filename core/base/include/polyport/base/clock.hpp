// Time on the forwarding path is CLOCK_MONOTONIC, as nanoseconds in distinct types so that
// a monotonic stamp is never mixed up with a wall-clock one or with a duration.
#pragma once

#include <cstdint>
#include <ctime>

namespace polyport {

struct Nanos {  // an elapsed time
  std::int64_t count = 0;
  friend constexpr bool operator==(Nanos, Nanos) = default;
  friend constexpr auto operator<=>(Nanos, Nanos) = default;
};

struct MonoTime {  // a CLOCK_MONOTONIC instant
  std::int64_t ns = 0;
  friend constexpr bool operator==(MonoTime, MonoTime) = default;
  friend constexpr auto operator<=>(MonoTime, MonoTime) = default;
  friend constexpr Nanos operator-(MonoTime a, MonoTime b) { return Nanos{a.ns - b.ns}; }
  friend constexpr MonoTime operator+(MonoTime a, Nanos d) { return MonoTime{a.ns + d.count}; }
};

struct WallTime {  // a CLOCK_REALTIME instant, for headers and logs only
  std::int64_t ns = 0;
};

inline MonoTime mono_now() noexcept {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return MonoTime{static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec};
}

inline WallTime wall_now() noexcept {
  timespec ts{};
  clock_gettime(CLOCK_REALTIME, &ts);
  return WallTime{static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec};
}

inline timespec to_timespec(MonoTime t) noexcept {
  return timespec{static_cast<time_t>(t.ns / 1'000'000'000), static_cast<long>(t.ns % 1'000'000'000)};
}

}  // namespace polyport
