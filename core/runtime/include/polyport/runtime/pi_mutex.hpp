#pragma once
// A mutex with priority inheritance and its condition variable, for hand-overs between a
// real-time thread and ordinary ones (an execution context taking a lifecycle command from the
// engine's control thread). With a plain mutex, a SCHED_FIFO context that blocks on a mutex held
// by a SCHED_OTHER thread waits for as long as other ordinary work keeps that thread off the
// CPU (priority inversion: 100 ms and more under a parallel build on two CPUs). With
// PTHREAD_PRIO_INHERIT the holder runs at the waiter's priority until it unlocks.
#include <pthread.h>

#include <mutex>

namespace polyport {

class PiMutex {
 public:
  PiMutex() noexcept {
    // Without inheritance (a C library that refuses the protocol) it is a plain mutex, still
    // correct but open to the inversion above: inherits_priority() says which one it is.
    pthread_mutexattr_t attributes;
    const bool have_attributes = pthread_mutexattr_init(&attributes) == 0;
    inherits_ = have_attributes && pthread_mutexattr_setprotocol(&attributes, PTHREAD_PRIO_INHERIT) == 0;
    if (inherits_ && pthread_mutex_init(&mutex_, &attributes) != 0) inherits_ = false;
    if (!inherits_) pthread_mutex_init(&mutex_, nullptr);
    if (have_attributes) pthread_mutexattr_destroy(&attributes);
  }
  ~PiMutex() { pthread_mutex_destroy(&mutex_); }
  PiMutex(const PiMutex&) = delete;
  PiMutex& operator=(const PiMutex&) = delete;

  void lock() noexcept { pthread_mutex_lock(&mutex_); }
  bool try_lock() noexcept { return pthread_mutex_trylock(&mutex_) == 0; }
  void unlock() noexcept { pthread_mutex_unlock(&mutex_); }
  pthread_mutex_t* native_handle() noexcept { return &mutex_; }
  bool inherits_priority() const noexcept { return inherits_; }

 private:
  pthread_mutex_t mutex_;
  bool inherits_ = false;
};

// Waits on a PiMutex directly (std::condition_variable_any would add a plain mutex of its own).
class PiCondition {
 public:
  PiCondition() noexcept { pthread_cond_init(&condition_, nullptr); }
  ~PiCondition() { pthread_cond_destroy(&condition_); }
  PiCondition(const PiCondition&) = delete;
  PiCondition& operator=(const PiCondition&) = delete;

  template <typename Predicate>
  void wait(std::unique_lock<PiMutex>& lock, Predicate ready) {
    while (!ready()) pthread_cond_wait(&condition_, lock.mutex()->native_handle());
  }
  void notify_all() noexcept { pthread_cond_broadcast(&condition_); }

 private:
  pthread_cond_t condition_;
};

}  // namespace polyport
