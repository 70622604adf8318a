// Time on the forwarding path is CLOCK_MONOTONIC, as nanoseconds in distinct types so that
// a monotonic stamp is never mixed up with a wall-clock one or with a duration.
//
// mono_now() and wall_now() read the system clocks (clock_gettime, a vDSO call of ≈ 25 ns on
// an ordinary Linux host). Where clock_gettime is a system call instead — user-mode Linux,
// some hypervisors' clock sources: microseconds per read, several reads per forwarded
// sample — a process may switch them to the TSC clock (use_clock, below): the CPU's
// invariant time-stamp counter scaled to CLOCK_MONOTONIC and kept on it by a calibration
// thread, as the vDSO itself does on a host whose clock source is the TSC. The switch is
// made once, before any stamp is taken; readers never wait for the calibration thread.
#pragma once

#include <atomic>
#include <cstdint>
#include <ctime>
#include <string>

#include "polyport/base/result.hpp"

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

namespace detail {

// The TSC clock's scale, published by its calibration thread as a latch (two copies and a
// sequence: a reader takes the copy the writer is not changing, and reads again only if the
// sequence moved meanwhile, so it never waits for a preempted writer).
struct TscScale {
  std::atomic<std::int64_t> base_tsc{0};
  std::atomic<std::int64_t> base_mono_ns{0};  // CLOCK_MONOTONIC at base_tsc
  std::atomic<std::int64_t> wall_minus_mono_ns{0};
  std::atomic<std::uint64_t> ns_per_tick_q32{0};  // nanoseconds per tick, 32.32 fixed point
};
struct TscClock {
  std::atomic<bool> active{false};
  std::atomic<std::uint32_t> sequence{0};
  TscScale copies[2];
};
extern TscClock g_tsc_clock;  // clock.cpp

// A system clock in nanoseconds (clock_gettime).
inline std::int64_t system_ns(clockid_t id) noexcept {
  timespec ts{};
  clock_gettime(id, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

// A line's value `ticks` after its base: ticks × a 32.32 rate in 128 bits (64 would overflow
// after ≈ 2 s at 2–3 GHz). The calibration thread evaluates lines with this too, so that
// where it joins a new line to the old one the two agree to the nanosecond.
inline std::int64_t tsc_line_ns(std::int64_t base_ns, std::int64_t ticks, std::uint64_t per_tick_q32) noexcept {
  __extension__ using Wide = __int128;
  return base_ns + static_cast<std::int64_t>((static_cast<Wide>(ticks) * static_cast<Wide>(per_tick_q32)) >> 32);
}

#if defined(__x86_64__)
// RDTSC is not ordered with the loads around it: a stamp may be taken some tens of cycles
// early or late, well inside the calibration's own error; an LFENCE would cost more than that.
// A short interval between two stamps moves with the code around them, though: in the vcan
// guest a CAN passthrough's in-to-out p90 read 45-48 ns with LFENCE, 51-69 or 95-103 ns
// without, depending on what ran before the entry stamp; the round trip did not get shorter
// with the fences (four alternated pairs, +1.0 us at the median, undecided), so they stay out
// and such a figure is read as a bound, to within about 50 ns.
inline std::int64_t read_tsc() noexcept { return static_cast<std::int64_t>(__builtin_ia32_rdtsc()); }

inline std::int64_t tsc_mono_ns(std::int64_t* wall_offset = nullptr) noexcept {
  for (;;) {
    const std::uint32_t sequence = g_tsc_clock.sequence.load(std::memory_order_acquire);
    const TscScale& scale = g_tsc_clock.copies[sequence & 1U];
    const std::int64_t base_tsc = scale.base_tsc.load(std::memory_order_relaxed);
    const std::int64_t base_ns = scale.base_mono_ns.load(std::memory_order_relaxed);
    const std::uint64_t per_tick = scale.ns_per_tick_q32.load(std::memory_order_relaxed);
    const std::int64_t wall = scale.wall_minus_mono_ns.load(std::memory_order_relaxed);
    // The TSC is read before the sequence is checked again: a value from this copy's line is
    // for a moment when the line was still the published one (see publish in clock.cpp).
    const std::int64_t tsc = read_tsc();
    std::atomic_thread_fence(std::memory_order_acquire);
    if (g_tsc_clock.sequence.load(std::memory_order_relaxed) != sequence) continue;
    if (wall_offset != nullptr) *wall_offset = wall;
    return tsc_line_ns(base_ns, tsc - base_tsc, per_tick);
  }
}
#endif

}  // namespace detail

inline MonoTime mono_now() noexcept {
#if defined(__x86_64__)
  if (detail::g_tsc_clock.active.load(std::memory_order_acquire)) return MonoTime{detail::tsc_mono_ns()};
#endif
  return MonoTime{detail::system_ns(CLOCK_MONOTONIC)};
}

inline WallTime wall_now() noexcept {
#if defined(__x86_64__)
  if (detail::g_tsc_clock.active.load(std::memory_order_acquire)) {
    std::int64_t offset = 0;
    const std::int64_t mono = detail::tsc_mono_ns(&offset);
    return WallTime{mono + offset};
  }
#endif
  return WallTime{detail::system_ns(CLOCK_REALTIME)};
}

inline timespec to_timespec(MonoTime t) noexcept {
  return timespec{static_cast<time_t>(t.ns / 1'000'000'000), static_cast<long>(t.ns % 1'000'000'000)};
}

// ---- Choosing the clock (set-up code, once per process) ---------------------------------------

enum class ClockChoice {
  automatic,  // the TSC clock where clock_gettime is slow (kSlowSystemClock) and the TSC fit
  system,     // clock_gettime always
  tsc,        // the TSC clock, or an error saying why it cannot be used here
};

struct ClockInfo {
  bool tsc = false;               // mono_now / wall_now read the TSC clock
  double system_read_ns = 0;      // one clock_gettime(CLOCK_MONOTONIC), the fastest of a few
  double tsc_ghz = 0;             // the TSC's measured rate (0: not calibrated)
  std::string why;                // one sentence: why this clock
};

// Beyond this a clock_gettime is a system call, not a vDSO read.
inline constexpr double kSlowSystemClockNs = 1000;

// Switches mono_now / wall_now to the TSC clock when `choice` asks for it (automatic: when a
// clock_gettime takes ≥ kSlowSystemClockNs, the CPU has an invariant TSC and the kernel does
// not keep its own time with another clock source), starting its
// calibration thread (`pp-clock`, ≈ 0.1 ms of CPU per second). Call before any component
// starts; a second call returns what the first chose.
Result<ClockInfo> use_clock(ClockChoice choice);

struct ClockStats {
  bool tsc = false;
  double tsc_ghz = 0;
  std::uint64_t calibrations = 0;
  std::uint64_t steps = 0;             // calibrations that found it ≥ 1 ms off: stepped ahead or slewed back
  std::int64_t last_error_ns = 0;      // CLOCK_MONOTONIC − the TSC clock at the last calibration
  std::int64_t max_abs_error_ns = 0;   // the largest |last_error_ns| after the first second
  std::uint64_t skipped = 0;           // calibrations skipped: their clock read was held up (preempted)
  bool given_up = false;               // the TSC misbehaved (went back, changed rate): clock_gettime again
  std::string why_given_up;            // what it did
  // wall_now() − clock_gettime(CLOCK_REALTIME), checked halfway between calibrations from the
  // tightest of a few TSC brackets around the system call (after the first second): how far
  // this process's wall stamps are from the kernel's, which is what a comparison with
  // another process's stamps inherits. Includes where in the system call the kernel reads its
  // clock, the same in every process of one machine.
  std::uint64_t wall_checks = 0;
  double wall_error_mean_ns = 0;
  std::int64_t wall_error_min_ns = 0;
  std::int64_t wall_error_max_ns = 0;
};
ClockStats clock_stats();

// Stops the calibration thread and goes back to clock_gettime (tests only: a process that
// switched keeps the TSC clock until it exits).
void stop_tsc_clock_for_tests();

}  // namespace polyport
