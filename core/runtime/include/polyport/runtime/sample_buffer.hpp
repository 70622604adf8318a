// The lock-free hand-off between one writing thread and one reading thread of a data
// connection, one per connection policy:
//   LatestValueBuffer  policy `data`: the latest value wins (triple buffer; wait-free).
//   BoundedQueue       policies `buffer` (full: the new sample is dropped) and `circular`
//                      (full: the oldest sample is dropped to make room).
// Ownership: each buffer owns its slots, allocated once at construction with room for
// `slot_bytes` per sample; push and pop copy bytes in and out and never allocate.
// Threads: push() from the single writer thread of the connection, pop() from the single
// reader thread. For `circular`, push() may also take the oldest slot itself, so the queue
// is safe with the writer and the reader both consuming (Vyukov's bounded MPMC queue).
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <memory>

#include "polyport/base/clock.hpp"

namespace polyport {

enum class PushResult : std::uint8_t {
  stored,           // the sample was stored, nothing lost
  dropped_newest,   // full `buffer`: this sample was dropped
  dropped_oldest,   // full `circular`: the oldest sample was dropped, this one stored
  overwritten,      // `data`: an unread older value was replaced by this one
  too_large,        // the sample does not fit a slot; dropped
};

enum class PopResult : std::uint8_t {
  no_data,   // nothing was ever written (or the queue is empty)
  old_data,  // `data` only: the value was already read once; it is copied again
  new_data,  // a sample not read before
  too_small, // the destination cannot hold the sample; the sample stays
};

struct SampleMeta {
  std::uint32_t size = 0;  // bytes of the sample
  MonoTime t_in;           // when the sample entered the connection
  MonoTime t_source;       // the source's own stamp, if it has one (0 otherwise)
};

class SampleBuffer {
 public:
  virtual ~SampleBuffer() = default;
  virtual PushResult push(const std::byte* data, const SampleMeta& meta) noexcept = 0;
  virtual PopResult pop(std::byte* dst, std::uint32_t capacity, SampleMeta& meta) noexcept = 0;
  virtual std::uint32_t slot_bytes() const noexcept = 0;
  virtual std::uint32_t depth() const noexcept = 0;  // slots a reader can see (1 for data)
};

class LatestValueBuffer final : public SampleBuffer {
 public:
  explicit LatestValueBuffer(std::uint32_t slot_bytes);
  [[gnu::hot]] PushResult push(const std::byte* data, const SampleMeta& meta) noexcept override;
  // push() for Connection, bound directly inside the library (hidden: no PLT stub and GOT
  // entry to fetch; see connection.hpp).
  [[gnu::hot, gnu::visibility("hidden")]] PushResult push_direct(const std::byte* data,
                                                                 const SampleMeta& meta) noexcept;
  PopResult pop(std::byte* dst, std::uint32_t capacity, SampleMeta& meta) noexcept override;
  std::uint32_t slot_bytes() const noexcept override { return slot_bytes_; }
  std::uint32_t depth() const noexcept override { return 1; }

 private:
  struct Slot;
  Slot& slot(std::uint8_t index) const noexcept;
  std::byte* slot_data(std::uint8_t index) const noexcept;

  std::uint32_t slot_bytes_;
  std::size_t slot_stride_;               // header + slot_bytes_, rounded to a cache line
  std::unique_ptr<std::byte[]> storage_;  // three slots, each a header then slot_bytes_
  std::byte* slots_ = nullptr;            // storage_ aligned to a cache line
  // Indices into the three slots: the writer's, the reader's, and the middle one, whose
  // index sits in middle_ with kFresh set while it holds a value the reader has not taken.
  std::uint8_t write_index_ = 0;
  std::uint8_t read_index_ = 1;
  std::atomic<std::uint8_t> middle_{2};
  bool has_value_ = false;  // reader side: something was ever taken
  bool unread_ = false;     // reader side: the reader's slot holds a value not handed out yet
};

class BoundedQueue final : public SampleBuffer {
 public:
  enum class WhenFull : std::uint8_t { drop_newest, drop_oldest };
  BoundedQueue(std::uint32_t depth, std::uint32_t slot_bytes, WhenFull when_full);
  PushResult push(const std::byte* data, const SampleMeta& meta) noexcept override;
  PopResult pop(std::byte* dst, std::uint32_t capacity, SampleMeta& meta) noexcept override;
  std::uint32_t slot_bytes() const noexcept override { return slot_bytes_; }
  std::uint32_t depth() const noexcept override { return depth_; }

 private:
  struct Cell;
  Cell& cell(std::uint64_t pos) const noexcept;
  std::byte* cell_data(std::uint64_t pos) const noexcept;
  std::byte* cell_base(std::uint64_t pos) const noexcept;
  bool try_push(const std::byte* data, const SampleMeta& meta) noexcept;
  bool try_discard_oldest() noexcept;

  std::uint32_t depth_;       // requested depth = number of cells (any value >= 1)
  std::uint64_t index_mask_;  // depth_ - 1 when depth_ is a power of two, else all ones (use %)
  std::uint32_t slot_bytes_;
  WhenFull when_full_;
  std::size_t cell_stride_;
  std::unique_ptr<std::byte[]> storage_;
  std::byte* cells_ = nullptr;  // storage_ aligned to a cache line
  alignas(64) std::atomic<std::uint64_t> enqueue_pos_{0};
  alignas(64) std::atomic<std::uint64_t> dequeue_pos_{0};
};

}  // namespace polyport
