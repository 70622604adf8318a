// Counting heap allocations on polyport's part of a forwarding path, for one test binary
// (include it in exactly one source file: it defines malloc and friends). malloc itself is
// interposed (glibc's entry points), so C code (the SDKs) and C++ code (operator new goes
// through malloc) are both seen; a thread counts into g_polyport_allocations only while it
// is inside polyport's part of the path (a Scope marks it; each model's test marks its own
// edges: where polyport's receive callback is entered, and the SDK's write that it calls).
// g_all_allocations counts everything.
#pragma once

#include <atomic>
#include <cerrno>
#include <cstddef>
#include <cstdint>

// Counting at malloc itself (glibc's entry points, interposed), so C code (Cyclone) and C++
// code (operator new goes through malloc) are both seen.
extern "C" {
void* __libc_malloc(std::size_t size);
void* __libc_calloc(std::size_t count, std::size_t size);
void* __libc_realloc(void* pointer, std::size_t size);
void* __libc_memalign(std::size_t alignment, std::size_t size);
}

namespace polyport::test {
std::atomic<std::uint64_t> g_polyport_allocations{0};
std::atomic<std::uint64_t> g_all_allocations{0};
std::atomic<std::uint64_t> g_callbacks{0};  // reader callbacks entered
thread_local bool t_in_polyport = false;

inline void count() noexcept {
  g_all_allocations.fetch_add(1, std::memory_order_relaxed);
  if (t_in_polyport) g_polyport_allocations.fetch_add(1, std::memory_order_relaxed);
}
}  // namespace polyport::test

extern "C" {
using polyport::test::count;
void* malloc(std::size_t size) {
  count();
  return __libc_malloc(size);
}
void* calloc(std::size_t count_, std::size_t size) {
  count();
  return __libc_calloc(count_, size);
}
void* realloc(void* pointer, std::size_t size) {
  count();
  return __libc_realloc(pointer, size);
}
void* aligned_alloc(std::size_t alignment, std::size_t size) {
  count();
  return __libc_memalign(alignment, size);
}
void* memalign(std::size_t alignment, std::size_t size) {
  count();
  return __libc_memalign(alignment, size);
}
int posix_memalign(void** out, std::size_t alignment, std::size_t size) {
  count();
  void* p = __libc_memalign(alignment, size);
  if (p == nullptr) return ENOMEM;
  *out = p;
  return 0;
}
}

namespace polyport::test {

// Marks polyport's part of the path for the counter.
class Scope {
 public:
  explicit Scope(bool inside) : previous_(t_in_polyport) { t_in_polyport = inside; }
  ~Scope() { t_in_polyport = previous_; }
  Scope(const Scope&) = delete;
  Scope& operator=(const Scope&) = delete;

 private:
  bool previous_;
};

}  // namespace polyport::test
