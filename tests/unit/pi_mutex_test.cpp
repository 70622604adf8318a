// The execution contexts' command mutex inherits priority: a real-time thread waiting for it
// lifts an ordinary holder above the work that would otherwise keep the holder off the CPU.
#include "polyport/runtime/pi_mutex.hpp"

#include <gtest/gtest.h>
#include <pthread.h>
#include <sched.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstring>
#include <string>
#include <thread>

namespace polyport {
namespace {

// Gives the calling thread a policy, then puts it on one CPU (in that order: an ordinary thread
// moved first onto the CPU a real-time one spins on would never run again); "" when done.
std::string place(int cpu, int policy, int priority) {
  sched_param param{};
  param.sched_priority = priority;
  if (int e = pthread_setschedparam(pthread_self(), policy, &param); e != 0) {
    return std::string("pthread_setschedparam: ") + std::strerror(e);
  }
  cpu_set_t set;
  CPU_ZERO(&set);
  CPU_SET(cpu, &set);
  if (int e = pthread_setaffinity_np(pthread_self(), sizeof set, &set); e != 0) {
    return std::string("pthread_setaffinity_np: ") + std::strerror(e);
  }
  return "";
}

// glibc on Linux supports PTHREAD_PRIO_INHERIT: the mutex must say it got it (a plain mutex
// here would mean the protocol was lost, and the real-time hand-over open to inversion).
TEST(PiMutex, SaysItInheritsPriority) {
  PiMutex mutex;
  EXPECT_TRUE(mutex.inherits_priority());
}

TEST(PiMutex, HandsOverUnderAConditionLikeAStdMutex) {
  PiMutex mutex;
  PiCondition changed;
  int value = 0;
  std::thread writer([&] {
    for (int i = 1; i <= 1000; ++i) {
      std::unique_lock<PiMutex> lock(mutex);
      changed.wait(lock, [&] { return value == 2 * i - 2; });
      value += 1;
      changed.notify_all();
    }
  });
  for (int i = 1; i <= 1000; ++i) {
    std::unique_lock<PiMutex> lock(mutex);
    changed.wait(lock, [&] { return value == 2 * i - 1; });
    value += 1;
    changed.notify_all();
  }
  writer.join();
  EXPECT_EQ(value, 2000);
}

// On one CPU: an ordinary thread holds the mutex, a SCHED_FIFO 20 thread spins (so the
// ordinary one gets no CPU), and a SCHED_FIFO 30 thread asks for the mutex. With priority
// inheritance the holder runs at 30, unlocks, and the FIFO 30 thread gets the mutex while the
// spinner still spins. Without it, the holder waits until the spinner gives up (0.5 s here,
// under the kernel's real-time throttling window, which would otherwise let it run).
TEST(PiMutex, AnOrdinaryHolderRunsAtItsRealTimeWaitersPriority) {
  if (sysconf(_SC_NPROCESSORS_ONLN) < 2) GTEST_SKIP() << "needs two CPUs: the test's own thread stays off CPU 0";
  if (std::string why = place(1, SCHED_OTHER, 0); !why.empty()) GTEST_SKIP() << "cannot pin to CPU 1: " << why;
  {
    std::string why;
    std::thread probe([&] { why = place(0, SCHED_FIFO, 30); });
    probe.join();
    if (!why.empty()) GTEST_SKIP() << "SCHED_FIFO not permitted here (root or CAP_SYS_NICE needed): " << why;
  }
  PiMutex mutex;
  std::atomic<bool> locked{false}, release{false}, spinning{false}, taken{false}, spinner_saw_it{false};

  std::thread holder([&] {
    ASSERT_EQ(place(0, SCHED_OTHER, 0), "");
    mutex.lock();
    locked = true;
    while (!release.load()) {
    }
    mutex.unlock();
  });
  while (!locked.load()) std::this_thread::yield();

  std::thread spinner([&] {
    ASSERT_EQ(place(0, SCHED_FIFO, 20), "");
    spinning = true;
    const auto until = std::chrono::steady_clock::now() + std::chrono::milliseconds(500);
    while (std::chrono::steady_clock::now() < until) {
      if (taken.load()) {
        spinner_saw_it = true;
        return;
      }
    }
  });
  while (!spinning.load()) std::this_thread::yield();
  release = true;  // the holder would unlock now, if it ran

  std::thread waiter([&] {
    ASSERT_EQ(place(0, SCHED_FIFO, 30), "");
    mutex.lock();
    taken = true;
    mutex.unlock();
  });
  waiter.join();
  spinner.join();
  holder.join();
  EXPECT_TRUE(taken.load());
  EXPECT_TRUE(spinner_saw_it.load()) << "the real-time waiter got the mutex only after the spinner stopped: "
                                        "its ordinary holder did not inherit its priority";
}

}  // namespace
}  // namespace polyport
