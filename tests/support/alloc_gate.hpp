// Counting heap allocations on polyport's part of a DDS forwarding path, for one test binary
// (include it in exactly one source file: it defines malloc and friends). malloc itself is
// interposed (glibc's entry points), so C code (Cyclone) and C++ code (operator new goes
// through malloc) are both seen; a thread counts into g_polyport_allocations only while it
// is inside polyport's part of the path: a CountingDomain wraps a vendor's Domain so that
// entering polyport's reader callback switches counting on and calling the SDK's write
// switches it off (and back on when the write returns). g_all_allocations counts everything.
#pragma once

#include <atomic>
#include <cerrno>
#include <cstddef>
#include <cstdint>
#include <memory>

#include "dds_endpoint.hpp"
#include "dds_model.hpp"

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

class CountingWriter final : public dds::Writer {
 public:
  explicit CountingWriter(std::unique_ptr<dds::Writer> inner) : inner_(std::move(inner)) {}
  Status write(const std::byte* cdr, std::uint32_t size) noexcept override {
    Scope sdk(false);
    return inner_->write(cdr, size);
  }
  std::int32_t matched_readers() const noexcept override { return inner_->matched_readers(); }
  dds::Guid guid() const noexcept override { return inner_->guid(); }

 private:
  std::unique_ptr<dds::Writer> inner_;
};

class CountingDomain final : public dds::Domain {
 public:
  explicit CountingDomain(std::unique_ptr<dds::Domain> inner) : inner_(std::move(inner)) {}
  std::string_view vendor() const noexcept override { return inner_->vendor(); }
  std::uint32_t id() const noexcept override { return inner_->id(); }
  Result<std::unique_ptr<dds::Writer>> create_writer(const dds::EndpointSpec& spec) override {
    auto writer = inner_->create_writer(spec);
    if (!writer) return writer.error();
    return std::unique_ptr<dds::Writer>(std::make_unique<CountingWriter>(std::move(writer).value()));
  }
  Result<std::unique_ptr<dds::Reader>> create_reader(const dds::EndpointSpec& spec,
                                                     dds::ReceiveCallback callback) override {
    return inner_->create_reader(spec, [callback = std::move(callback)](const std::byte* cdr, std::uint32_t size,
                                                                        MonoTime source) {
      Scope polyport(true);
      g_callbacks.fetch_add(1, std::memory_order_relaxed);
      callback(cdr, size, source);
    });
  }

 private:
  std::unique_ptr<dds::Domain> inner_;
};

// A DDS model whose domains (made by `make`) count polyport's allocations.
inline std::unique_ptr<dds::DdsModel> counting_model(std::string name, dds::DdsModel::DomainFactory make,
                                                     std::string default_config) {
  return std::make_unique<dds::DdsModel>(
      std::move(name),
      [make = std::move(make)](std::uint32_t domain, const std::string& config) -> Result<std::unique_ptr<dds::Domain>> {
        auto inner = make(domain, config);
        if (!inner) return inner.error();
        return std::unique_ptr<dds::Domain>(std::make_unique<CountingDomain>(std::move(inner).value()));
      },
      std::move(default_config));
}

}  // namespace polyport::test
