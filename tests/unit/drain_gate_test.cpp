// DrainGate: one drainer at a time, no notification left without a later drain, nested
// notifications do not recurse.
#include "polyport/runtime/drain_gate.hpp"

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <functional>
#include <cstdint>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

namespace polyport {
namespace {

TEST(DrainGate, DrainsOncePerUncontendedNotification) {
  DrainGate gate;
  int passes = 0;
  gate.run([&]() noexcept { ++passes; });
  EXPECT_EQ(passes, 1);
  gate.run([&]() noexcept { ++passes; });
  EXPECT_EQ(passes, 2);
}

TEST(DrainGate, NotificationDuringADrainGetsAnotherPassNotANestedOne) {
  // As when a sample taken is written to a writer whose reader is in this process: the
  // SDK notifies the same reader from inside the drain.
  DrainGate gate;
  int depth = 0;
  int deepest = 0;
  int passes = 0;
  int nested_left = 2;
  std::function<void()> drain = [&]() noexcept {
    ++depth;
    deepest = std::max(deepest, depth);
    ++passes;
    if (nested_left > 0) {
      --nested_left;
      gate.run([&]() noexcept { drain(); });
    }
    --depth;
  };
  gate.run([&]() noexcept { drain(); });
  EXPECT_EQ(deepest, 1);
  EXPECT_EQ(passes, 3);  // the first, and one more for each nested notification
  // The gate is open again afterwards.
  gate.run([&]() noexcept { drain(); });
  EXPECT_EQ(passes, 4);
}

TEST(DrainGate, ManyNotifiersOneDrainerAtATimeAndNothingLeftBehind) {
  DrainGate gate;
  std::atomic<std::uint64_t> produced{0};
  std::uint64_t consumed = 0;      // touched only inside drains: no lock, no atomic
  std::uint64_t drain_passes = 0;  // likewise
  std::atomic<int> draining{0};
  std::atomic<int> overlaps{0};
  const auto drain = [&]() noexcept {
    if (draining.fetch_add(1) != 0) overlaps.fetch_add(1);
    consumed = produced.load(std::memory_order_acquire);
    ++drain_passes;
    draining.fetch_sub(1);
  };
  constexpr int kThreads = 4;
  constexpr int kPerThread = 200'000;
  std::atomic<int> ready{0};
  std::vector<std::thread> notifiers;
  for (int t = 0; t < kThreads; ++t) {
    notifiers.emplace_back([&] {
      // All start together, so that notifications really meet drains in progress.
      ready.fetch_add(1);
      while (ready.load() < kThreads) std::this_thread::yield();
      for (int i = 0; i < kPerThread; ++i) {
        produced.fetch_add(1, std::memory_order_release);
        gate.run(drain);
      }
    });
  }
  for (std::thread& t : notifiers) t.join();
  EXPECT_EQ(overlaps.load(), 0);
  // The last pass started after the last notification, so it saw everything produced.
  EXPECT_EQ(consumed, std::uint64_t{kThreads} * kPerThread);
  EXPECT_GE(drain_passes, 1u);
  EXPECT_LE(drain_passes, std::uint64_t{kThreads} * kPerThread);
  // How many notifications were answered by another thread's pass (informational: how much
  // the threads met depends on the machine).
  std::printf("DrainGate: %llu notifications, %llu drain passes\n",
              static_cast<unsigned long long>(kThreads) * kPerThread,
              static_cast<unsigned long long>(drain_passes));
}

}  // namespace
}  // namespace polyport
