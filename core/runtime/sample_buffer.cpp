// The per-connection hand-off buffers (see sample_buffer.hpp for the policies).
//
// Ownership: every buffer allocates its slots once in its constructor and owns them for its
// whole life; push() copies the writer's bytes into a slot, pop() copies them out into the
// reader's destination, and neither allocates nor takes a lock.
// Threads: push() runs only on the connection's writer thread, pop() only on its reader
// thread. In LatestValueBuffer each of the three slots belongs at any instant to exactly
// one side (writer, reader, or the shared middle); ownership moves by one atomic exchange.
// In BoundedQueue a cell belongs to whoever claimed its position (the writer to fill it,
// the reader -- or, for drop_oldest, the writer -- to empty it) until it publishes the
// cell's next sequence number with a release store. The one place a side waits for the
// other: a drop_oldest push on a full queue whose oldest cell the reader is copying out at
// that moment spins (then yields) until that single copy ends, rather than discard more.
#include "polyport/runtime/sample_buffer.hpp"

#include <bit>
#include <cstring>
#include <new>
#include <stdexcept>
#include <thread>

namespace polyport {

namespace {

constexpr std::size_t kCacheLine = 64;
// Sample bytes start at this alignment after a slot's header, like memory from malloc.
constexpr std::size_t kDataAlign = alignof(std::max_align_t);

constexpr std::size_t round_up(std::size_t n, std::size_t to) noexcept {
  return (n + to - 1) / to * to;
}

// An over-aligned operator new[] would need a matching aligned delete[], which
// std::unique_ptr<std::byte[]> does not call; so allocate a little more and align by hand.
std::byte* align_to_line(std::byte* p) noexcept {
  const auto addr = reinterpret_cast<std::uintptr_t>(p);
  return p + (round_up(addr, kCacheLine) - addr);
}

void copy_bytes(std::byte* dst, const std::byte* src, std::uint32_t n) noexcept {
  if (n != 0) std::memcpy(dst, src, n);  // memcpy with a null pointer is UB even for 0
}

// Busy-wait politely: a few spins first (the other side is mid-memcpy on another core),
// then give the core away in case that side was preempted on ours.
// How long a drop_oldest push waits for a reader mid-copy: 64 pauses, then 16 yields.
constexpr unsigned kMaxWaitRounds = 80;

void backoff(unsigned& round) noexcept {
  if (++round < 64) {
#if defined(__x86_64__) || defined(__i386__)
    __builtin_ia32_pause();
#endif
  } else {
    std::this_thread::yield();
  }
}

}  // namespace

// ---------------------------------------------------------------------------------------
// LatestValueBuffer: a triple buffer.

namespace {
constexpr std::uint8_t kIndexMask = 0x03;
constexpr std::uint8_t kFresh = 0x80;  // the middle slot holds a value the reader never took
}  // namespace

struct LatestValueBuffer::Slot {
  SampleMeta meta;
  // The sample's bytes follow at header_bytes().
  static constexpr std::size_t header_bytes() noexcept { return round_up(sizeof(Slot), kDataAlign); }
};

LatestValueBuffer::LatestValueBuffer(std::uint32_t slot_bytes)
    : slot_bytes_(slot_bytes),
      slot_stride_(round_up(Slot::header_bytes() + slot_bytes, kCacheLine)) {
  // Cache-line strides keep the writer's slot and the reader's slot off each other's lines.
  storage_ = std::make_unique<std::byte[]>(3 * slot_stride_ + kCacheLine);
  slots_ = align_to_line(storage_.get());
  for (std::uint8_t i = 0; i < 3; ++i) new (slots_ + i * slot_stride_) Slot{};
}

LatestValueBuffer::Slot& LatestValueBuffer::slot(std::uint8_t index) const noexcept {
  return *std::launder(reinterpret_cast<Slot*>(slots_ + index * slot_stride_));
}

std::byte* LatestValueBuffer::slot_data(std::uint8_t index) const noexcept {
  return slots_ + index * slot_stride_ + Slot::header_bytes();
}

PushResult LatestValueBuffer::push(const std::byte* data, const SampleMeta& meta) noexcept {
  return push_direct(data, meta);
}

PushResult LatestValueBuffer::push_direct(const std::byte* data, const SampleMeta& meta) noexcept {
  if (meta.size > slot_bytes_) return PushResult::too_large;
  // The write slot is the writer's alone: fill it without any synchronisation.
  slot(write_index_).meta = meta;
  copy_bytes(slot_data(write_index_), data, meta.size);
  // Release publishes the bytes with the slot; acquire makes the reader's last reads of the
  // slot we get back happen before we overwrite it on the next push.
  const std::uint8_t previous =
      middle_.exchange(static_cast<std::uint8_t>(write_index_ | kFresh), std::memory_order_acq_rel);
  write_index_ = previous & kIndexMask;
  return (previous & kFresh) != 0 ? PushResult::overwritten : PushResult::stored;
}

PopResult LatestValueBuffer::pop(std::byte* dst, std::uint32_t capacity, SampleMeta& meta) noexcept {
  // Only the writer sets kFresh and only the reader clears it, so a relaxed peek is enough
  // to decide; the exchange itself carries the acquire for the slot's contents.
  if ((middle_.load(std::memory_order_relaxed) & kFresh) != 0) {
    const std::uint8_t previous = middle_.exchange(read_index_, std::memory_order_acq_rel);
    read_index_ = previous & kIndexMask;
    has_value_ = true;
    // A value left unread by a too_small pop is replaced here by a newer one: for `data`
    // the latest value wins.
    unread_ = true;
  }
  if (!has_value_) return PopResult::no_data;
  const Slot& s = slot(read_index_);
  if (s.meta.size > capacity) {
    // The value stays in the reader's slot (and unread_ stays set), so a retry with a
    // larger destination still gets it as new data. meta.size says how much is needed.
    meta.size = s.meta.size;
    return PopResult::too_small;
  }
  meta = s.meta;
  copy_bytes(dst, slot_data(read_index_), s.meta.size);
  const PopResult result = unread_ ? PopResult::new_data : PopResult::old_data;
  unread_ = false;
  return result;
}

// ---------------------------------------------------------------------------------------
// BoundedQueue: Vyukov's bounded MPMC queue with per-cell sequence numbers, generalised to
// any depth. Position pos lives in cell pos % depth. The cell's sequence tells which side
// may use it next, with positions doubled so that even depth 1 is unambiguous:
//   2 * pos       empty, waiting for the producer of position pos
//   2 * pos + 1   full, waiting for the consumer of position pos
// A consumer that empties position pos hands the cell on with 2 * (pos + depth).
// (The classic encoding pos / pos + 1 confuses "full at pos" with "empty at pos + 1" when
// there is a single cell.)

struct BoundedQueue::Cell {
  std::atomic<std::uint64_t> sequence;
  // The sample's size, atomic so that the reader may look at it before claiming the cell
  // (to answer too_small without taking the sample), while the writer may be discarding it.
  std::atomic<std::uint32_t> size;
  SampleMeta meta;
  // The sample's bytes follow at header_bytes().
  static constexpr std::size_t header_bytes() noexcept { return round_up(sizeof(Cell), kDataAlign); }
};

namespace {
constexpr std::uint64_t kNoMask = ~std::uint64_t{0};
}  // namespace

BoundedQueue::BoundedQueue(std::uint32_t depth, std::uint32_t slot_bytes, WhenFull when_full)
    : depth_(depth),
      index_mask_(std::has_single_bit(depth) ? depth - 1 : kNoMask),
      slot_bytes_(slot_bytes),
      when_full_(when_full),
      cell_stride_(round_up(Cell::header_bytes() + slot_bytes, kCacheLine)) {
  if (depth == 0) throw std::invalid_argument("BoundedQueue: depth must be at least 1");
  storage_ = std::make_unique<std::byte[]>(depth_ * cell_stride_ + kCacheLine);
  cells_ = align_to_line(storage_.get());
  for (std::uint64_t pos = 0; pos < depth_; ++pos) {
    Cell* c = new (cell_base(pos)) Cell{};
    c->sequence.store(2 * pos, std::memory_order_relaxed);
    c->size.store(0, std::memory_order_relaxed);
  }
}

std::byte* BoundedQueue::cell_base(std::uint64_t pos) const noexcept {
  // A power-of-two depth takes a mask; any other depth pays a division, which is still
  // cheap next to the copy of the sample.
  const std::uint64_t index = index_mask_ != kNoMask ? (pos & index_mask_) : pos % depth_;
  return cells_ + index * cell_stride_;
}

BoundedQueue::Cell& BoundedQueue::cell(std::uint64_t pos) const noexcept {
  return *std::launder(reinterpret_cast<Cell*>(cell_base(pos)));
}

std::byte* BoundedQueue::cell_data(std::uint64_t pos) const noexcept {
  return cell_base(pos) + Cell::header_bytes();
}

bool BoundedQueue::try_push(const std::byte* data, const SampleMeta& meta) noexcept {
  std::uint64_t pos = enqueue_pos_.load(std::memory_order_relaxed);
  for (;;) {
    Cell& c = cell(pos);
    // Acquire: the consumer that emptied this cell last finished reading it before we write.
    const std::uint64_t seq = c.sequence.load(std::memory_order_acquire);
    const auto diff = static_cast<std::int64_t>(seq - 2 * pos);
    if (diff == 0) {
      // Only one writer exists, but claiming by CAS keeps the queue correct regardless.
      if (enqueue_pos_.compare_exchange_weak(pos, pos + 1, std::memory_order_relaxed)) break;
    } else if (diff < 0) {
      return false;  // the cell still holds (or is being emptied of) the sample depth ago
    } else {
      pos = enqueue_pos_.load(std::memory_order_relaxed);
    }
  }
  Cell& c = cell(pos);
  c.meta = meta;
  c.size.store(meta.size, std::memory_order_relaxed);
  copy_bytes(cell_data(pos), data, meta.size);
  c.sequence.store(2 * pos + 1, std::memory_order_release);  // publish to the consumer
  return true;
}

bool BoundedQueue::try_discard_oldest() noexcept {
  // Runs on the writer thread. Discard only the sample that blocks the next push: if the
  // reader has already claimed it, the cell comes free as soon as its copy ends, and
  // discarding the one after it would lose a sample for nothing.
  std::uint64_t pos = dequeue_pos_.load(std::memory_order_relaxed);
  if (pos + depth_ != enqueue_pos_.load(std::memory_order_relaxed)) return false;
  Cell& c = cell(pos);
  if (c.sequence.load(std::memory_order_acquire) != 2 * pos + 1) return false;
  // The CAS decides between us and the reader: whoever moves dequeue_pos_ owns the cell.
  // Acquire pairs with the release of a too_small peek in pop() (see there).
  if (!dequeue_pos_.compare_exchange_strong(pos, pos + 1, std::memory_order_acquire,
                                            std::memory_order_relaxed)) {
    return false;
  }
  c.sequence.store(2 * (pos + depth_), std::memory_order_release);
  return true;
}

PushResult BoundedQueue::push(const std::byte* data, const SampleMeta& meta) noexcept {
  if (meta.size > slot_bytes_) return PushResult::too_large;
  if (try_push(data, meta)) return PushResult::stored;
  if (when_full_ == WhenFull::drop_newest) return PushResult::dropped_newest;
  // drop_oldest: at most one sample is discarded per push, so that the push results
  // account for every lost sample. If the reader holds the oldest cell mid-copy, we wait a
  // few rounds for that copy to finish. A reader preempted mid-copy (e.g. by this writer at
  // a real-time priority on the same CPU) would make that wait unbounded, so after
  // kMaxWaitRounds the new sample is dropped instead: the writer never blocks.
  bool discarded = false;
  for (unsigned round = 0; round < kMaxWaitRounds;) {
    if (!discarded && try_discard_oldest()) discarded = true;
    if (try_push(data, meta)) return discarded ? PushResult::dropped_oldest : PushResult::stored;
    backoff(round);
  }
  return PushResult::dropped_newest;
}

PopResult BoundedQueue::pop(std::byte* dst, std::uint32_t capacity, SampleMeta& meta) noexcept {
  std::uint64_t pos = dequeue_pos_.load(std::memory_order_relaxed);
  for (;;) {
    Cell& c = cell(pos);
    // Acquire: the producer's bytes for this position are visible once we see it full.
    const std::uint64_t seq = c.sequence.load(std::memory_order_acquire);
    const auto diff = static_cast<std::int64_t>(seq - (2 * pos + 1));
    if (diff == 0) {
      // Peek at the size before claiming: a too-small destination leaves the sample queued.
      // The peek is valid only if nobody claimed this position meanwhile (a claim lets the
      // writer refill the cell). When we claim it ourselves, our later release of the cell
      // orders the peek before any refill. When we do not, a CAS that leaves pos in place
      // confirms nobody had claimed it, and its release pairs with the acquire of the
      // claim that comes later, which orders our peek before that refill as well.
      const std::uint32_t size = c.size.load(std::memory_order_relaxed);
      if (size > capacity) {
        if (dequeue_pos_.compare_exchange_strong(pos, pos, std::memory_order_release,
                                                 std::memory_order_relaxed)) {
          meta.size = size;
          return PopResult::too_small;
        }
        continue;  // pos now holds the current dequeue position
      }
      if (dequeue_pos_.compare_exchange_weak(pos, pos + 1, std::memory_order_acquire,
                                             std::memory_order_relaxed)) {
        break;
      }
    } else if (diff < 0) {
      return PopResult::no_data;
    } else {
      pos = dequeue_pos_.load(std::memory_order_relaxed);
    }
  }
  Cell& c = cell(pos);
  meta = c.meta;
  copy_bytes(dst, cell_data(pos), meta.size);
  // Release: our reads of the cell happen before the producer refills it.
  c.sequence.store(2 * (pos + depth_), std::memory_order_release);
  return PopResult::new_data;
}

}  // namespace polyport
