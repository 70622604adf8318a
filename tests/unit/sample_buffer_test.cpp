#include "polyport/runtime/sample_buffer.hpp"

#include <gtest/gtest.h>

#include <array>
#include <atomic>
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <thread>
#include <vector>

namespace {

using polyport::BoundedQueue;
using polyport::LatestValueBuffer;
using polyport::MonoTime;
using polyport::PopResult;
using polyport::PushResult;
using polyport::SampleBuffer;
using polyport::SampleMeta;

constexpr std::uint32_t kWords = 8;  // a sample is 1..kWords copies of its sequence number
constexpr std::uint32_t kSlotBytes = kWords * sizeof(std::uint64_t);

// A sample whose every word is its sequence number, so a read that mixes two writes (a
// torn read) shows as unequal words; its length also depends on the sequence number.
struct Sample {
  std::array<std::uint64_t, kWords> words{};
  SampleMeta meta;

  explicit Sample(std::uint64_t seq, std::uint32_t word_count = 0) {
    const std::uint32_t n = word_count != 0 ? word_count : 1 + static_cast<std::uint32_t>(seq % kWords);
    words.fill(seq);
    meta.size = n * static_cast<std::uint32_t>(sizeof(std::uint64_t));
    meta.t_in = MonoTime{static_cast<std::int64_t>(seq) * 10};
    meta.t_source = MonoTime{static_cast<std::int64_t>(seq) * 10 + 1};
  }
  const std::byte* bytes() const { return reinterpret_cast<const std::byte*>(words.data()); }
};

struct Received {
  PopResult result = PopResult::no_data;
  std::uint64_t seq = 0;
  bool intact = false;  // every word equal, size and stamps those of seq
  SampleMeta meta;
};

Received pop_sample(SampleBuffer& buffer, std::uint32_t capacity = kSlotBytes) {
  std::array<std::uint64_t, kWords> words{};
  words.fill(~std::uint64_t{0});
  Received r;
  r.result = buffer.pop(reinterpret_cast<std::byte*>(words.data()), capacity, r.meta);
  if (r.result != PopResult::new_data && r.result != PopResult::old_data) return r;
  r.seq = words[0];
  const std::uint32_t n = r.meta.size / sizeof(std::uint64_t);
  r.intact = n >= 1 && n <= kWords && r.meta.size % sizeof(std::uint64_t) == 0 &&
             r.meta.t_in.ns == static_cast<std::int64_t>(r.seq) * 10 &&
             r.meta.t_source.ns == static_cast<std::int64_t>(r.seq) * 10 + 1;
  for (std::uint32_t i = 0; i < n && r.intact; ++i) r.intact = words[i] == r.seq;
  return r;
}

PushResult push_sample(SampleBuffer& buffer, std::uint64_t seq, std::uint32_t word_count = 0) {
  const Sample s(seq, word_count);
  return buffer.push(s.bytes(), s.meta);
}

// Keeps the consumer slower than the producer without sleeping.
void busy_work(int rounds) {
  volatile std::uint64_t sink = 0;
  for (int i = 0; i < rounds; ++i) sink = sink + static_cast<std::uint64_t>(i);
}

// ---------------------------------------------------------------------------------------
// LatestValueBuffer

TEST(LatestValueBuffer, NoDataBeforeFirstWrite) {
  LatestValueBuffer b(kSlotBytes);
  EXPECT_EQ(b.depth(), 1u);
  EXPECT_EQ(b.slot_bytes(), kSlotBytes);
  EXPECT_EQ(pop_sample(b).result, PopResult::no_data);
  EXPECT_EQ(pop_sample(b).result, PopResult::no_data);
}

TEST(LatestValueBuffer, NewThenOldData) {
  LatestValueBuffer b(kSlotBytes);
  EXPECT_EQ(push_sample(b, 1), PushResult::stored);
  auto r = pop_sample(b);
  EXPECT_EQ(r.result, PopResult::new_data);
  EXPECT_EQ(r.seq, 1u);
  EXPECT_TRUE(r.intact);
  r = pop_sample(b);  // nothing new: the same value is copied again
  EXPECT_EQ(r.result, PopResult::old_data);
  EXPECT_EQ(r.seq, 1u);
  EXPECT_TRUE(r.intact);
  EXPECT_EQ(push_sample(b, 2), PushResult::stored);  // 1 was read, nothing lost
  r = pop_sample(b);
  EXPECT_EQ(r.result, PopResult::new_data);
  EXPECT_EQ(r.seq, 2u);
}

TEST(LatestValueBuffer, UnreadValueIsOverwritten) {
  LatestValueBuffer b(kSlotBytes);
  EXPECT_EQ(push_sample(b, 1), PushResult::stored);
  EXPECT_EQ(push_sample(b, 2), PushResult::overwritten);
  EXPECT_EQ(push_sample(b, 3), PushResult::overwritten);
  auto r = pop_sample(b);
  EXPECT_EQ(r.result, PopResult::new_data);
  EXPECT_EQ(r.seq, 3u);
  EXPECT_TRUE(r.intact);
  EXPECT_EQ(push_sample(b, 4), PushResult::stored);
  EXPECT_EQ(pop_sample(b).seq, 4u);
  EXPECT_EQ(pop_sample(b).result, PopResult::old_data);
}

TEST(LatestValueBuffer, TooLargeIsRejectedAndKeepsTheOldValue) {
  LatestValueBuffer b(16);
  EXPECT_EQ(push_sample(b, 7, 2), PushResult::stored);  // exactly slot_bytes fits
  EXPECT_EQ(push_sample(b, 8, 3), PushResult::too_large);
  const auto r = pop_sample(b);
  EXPECT_EQ(r.result, PopResult::new_data);
  EXPECT_EQ(r.seq, 7u);
}

TEST(LatestValueBuffer, TooSmallLeavesTheSampleAvailable) {
  LatestValueBuffer b(kSlotBytes);
  EXPECT_EQ(push_sample(b, 5, 4), PushResult::stored);  // 32 bytes
  auto r = pop_sample(b, 16);
  EXPECT_EQ(r.result, PopResult::too_small);
  EXPECT_EQ(r.meta.size, 32u);  // tells how much room is needed
  r = pop_sample(b, 32);
  EXPECT_EQ(r.result, PopResult::new_data);  // still new: it was never handed out
  EXPECT_EQ(r.seq, 5u);
  EXPECT_TRUE(r.intact);
  EXPECT_EQ(pop_sample(b, 8).result, PopResult::too_small);  // also for old data
  EXPECT_EQ(pop_sample(b).result, PopResult::old_data);
}

TEST(LatestValueBuffer, EmptySample) {
  LatestValueBuffer b(0);
  SampleMeta meta;
  meta.t_in = MonoTime{99};
  EXPECT_EQ(b.push(nullptr, meta), PushResult::stored);
  SampleMeta out;
  EXPECT_EQ(b.pop(nullptr, 0, out), PopResult::new_data);
  EXPECT_EQ(out.size, 0u);
  EXPECT_EQ(out.t_in, MonoTime{99});
}

TEST(LatestValueBuffer, ConcurrentFastWriterSlowReader) {
  constexpr std::uint64_t kCount = 200'000;
  LatestValueBuffer b(kSlotBytes);
  std::uint64_t overwritten = 0;
  std::thread writer([&] {
    for (std::uint64_t seq = 0; seq < kCount; ++seq) {
      const PushResult r = push_sample(b, seq);
      if (r == PushResult::overwritten) ++overwritten;
      else if (r != PushResult::stored) ADD_FAILURE() << "push " << seq;
    }
  });
  std::uint64_t fresh_reads = 0;
  std::uint64_t torn = 0;
  std::uint64_t out_of_order = 0;
  bool have_last = false;
  std::uint64_t last = 0;
  // No deadline: the writer's final value stays fresh until taken, so this loop ends.
  while (!have_last || last != kCount - 1) {
    const Received r = pop_sample(b);
    if (r.result == PopResult::no_data) continue;
    if (!r.intact) ++torn;
    if (r.result == PopResult::new_data) {
      if (have_last && r.seq <= last) ++out_of_order;
      ++fresh_reads;
      last = r.seq;
      have_last = true;
      busy_work(200);
    } else if (r.result == PopResult::old_data) {
      if (!have_last || r.seq != last) ++out_of_order;  // old data is the last value again
    } else {
      ADD_FAILURE() << "pop result " << static_cast<int>(r.result);
    }
  }
  writer.join();
  EXPECT_EQ(torn, 0u);
  EXPECT_EQ(out_of_order, 0u);
  EXPECT_EQ(last, kCount - 1);
  // Every value was either read as new exactly once or replaced unread.
  EXPECT_EQ(fresh_reads + overwritten, kCount);
  EXPECT_EQ(pop_sample(b).result, PopResult::old_data);
}

// ---------------------------------------------------------------------------------------
// BoundedQueue, single thread

TEST(BoundedQueue, EmptyQueueHasNoData) {
  BoundedQueue q(4, kSlotBytes, BoundedQueue::WhenFull::drop_newest);
  EXPECT_EQ(q.depth(), 4u);
  EXPECT_EQ(q.slot_bytes(), kSlotBytes);
  EXPECT_EQ(pop_sample(q).result, PopResult::no_data);
}

TEST(BoundedQueue, ZeroDepthIsRejected) {
  EXPECT_THROW(BoundedQueue(0, kSlotBytes, BoundedQueue::WhenFull::drop_newest),
               std::invalid_argument);
}

TEST(BoundedQueue, DropNewestKeepsTheFirstDepthSamples) {
  for (std::uint32_t depth : {1u, 2u, 3u, 5u, 7u, 8u, 100u}) {
    SCOPED_TRACE(depth);
    BoundedQueue q(depth, kSlotBytes, BoundedQueue::WhenFull::drop_newest);
    for (std::uint64_t seq = 0; seq < depth + 3; ++seq) {
      EXPECT_EQ(push_sample(q, seq), seq < depth ? PushResult::stored : PushResult::dropped_newest);
    }
    for (std::uint64_t seq = 0; seq < depth; ++seq) {
      const auto r = pop_sample(q);
      ASSERT_EQ(r.result, PopResult::new_data);
      EXPECT_EQ(r.seq, seq);
      EXPECT_TRUE(r.intact);
    }
    EXPECT_EQ(pop_sample(q).result, PopResult::no_data);
  }
}

TEST(BoundedQueue, DropOldestKeepsTheLastDepthSamples) {
  for (std::uint32_t depth : {1u, 2u, 3u, 5u, 7u, 8u, 100u}) {
    SCOPED_TRACE(depth);
    BoundedQueue q(depth, kSlotBytes, BoundedQueue::WhenFull::drop_oldest);
    const std::uint64_t total = depth + 3;
    for (std::uint64_t seq = 0; seq < total; ++seq) {
      EXPECT_EQ(push_sample(q, seq), seq < depth ? PushResult::stored : PushResult::dropped_oldest);
    }
    for (std::uint64_t seq = total - depth; seq < total; ++seq) {
      const auto r = pop_sample(q);
      ASSERT_EQ(r.result, PopResult::new_data);
      EXPECT_EQ(r.seq, seq);
      EXPECT_TRUE(r.intact);
    }
    EXPECT_EQ(pop_sample(q).result, PopResult::no_data);
  }
}

TEST(BoundedQueue, FifoOrderAcrossManyWraps) {
  for (std::uint32_t depth : {1u, 3u, 5u, 16u}) {
    for (auto policy : {BoundedQueue::WhenFull::drop_newest, BoundedQueue::WhenFull::drop_oldest}) {
      SCOPED_TRACE(depth);
      BoundedQueue q(depth, kSlotBytes, policy);
      std::uint64_t next_in = 0;
      std::uint64_t next_out = 0;
      for (int round = 0; round < 500; ++round) {
        const std::uint64_t burst = 1 + static_cast<std::uint64_t>(round) % depth;  // never full
        for (std::uint64_t i = 0; i < burst; ++i) ASSERT_EQ(push_sample(q, next_in++), PushResult::stored);
        for (std::uint64_t i = 0; i < burst; ++i) {
          const auto r = pop_sample(q);
          ASSERT_EQ(r.result, PopResult::new_data);
          ASSERT_EQ(r.seq, next_out++);
          ASSERT_TRUE(r.intact);
        }
      }
      EXPECT_EQ(pop_sample(q).result, PopResult::no_data);
    }
  }
}

TEST(BoundedQueue, DropOldestAfterPartialDrain) {
  BoundedQueue q(3, kSlotBytes, BoundedQueue::WhenFull::drop_oldest);
  for (std::uint64_t seq = 0; seq < 3; ++seq) push_sample(q, seq);
  EXPECT_EQ(pop_sample(q).seq, 0u);
  EXPECT_EQ(push_sample(q, 3), PushResult::stored);          // room again after a pop
  EXPECT_EQ(push_sample(q, 4), PushResult::dropped_oldest);  // drops 1
  for (std::uint64_t seq : {2u, 3u, 4u}) EXPECT_EQ(pop_sample(q).seq, seq);
  EXPECT_EQ(pop_sample(q).result, PopResult::no_data);
}

TEST(BoundedQueue, TooLargeIsRejected) {
  BoundedQueue q(2, 16, BoundedQueue::WhenFull::drop_newest);
  EXPECT_EQ(push_sample(q, 1, 3), PushResult::too_large);
  EXPECT_EQ(pop_sample(q).result, PopResult::no_data);
  EXPECT_EQ(push_sample(q, 2, 2), PushResult::stored);  // exactly slot_bytes fits
  const auto r = pop_sample(q);
  EXPECT_EQ(r.result, PopResult::new_data);
  EXPECT_EQ(r.seq, 2u);
}

TEST(BoundedQueue, TooSmallLeavesTheSampleQueued) {
  BoundedQueue q(3, kSlotBytes, BoundedQueue::WhenFull::drop_newest);
  push_sample(q, 1, 6);  // 48 bytes
  push_sample(q, 2, 1);
  auto r = pop_sample(q, 40);
  EXPECT_EQ(r.result, PopResult::too_small);
  EXPECT_EQ(r.meta.size, 48u);
  r = pop_sample(q, 48);
  EXPECT_EQ(r.result, PopResult::new_data);
  EXPECT_EQ(r.seq, 1u);
  EXPECT_TRUE(r.intact);
  EXPECT_EQ(pop_sample(q, 8).seq, 2u);
  EXPECT_EQ(pop_sample(q).result, PopResult::no_data);
}

TEST(BoundedQueue, EmptySamplesAndMetaPassThrough) {
  BoundedQueue q(1, 0, BoundedQueue::WhenFull::drop_oldest);
  SampleMeta meta;
  meta.t_in = MonoTime{5};
  meta.t_source = MonoTime{6};
  EXPECT_EQ(q.push(nullptr, meta), PushResult::stored);
  EXPECT_EQ(q.push(nullptr, meta), PushResult::dropped_oldest);
  SampleMeta out;
  EXPECT_EQ(q.pop(nullptr, 0, out), PopResult::new_data);
  EXPECT_EQ(out.size, 0u);
  EXPECT_EQ(out.t_in, MonoTime{5});
  EXPECT_EQ(out.t_source, MonoTime{6});
  EXPECT_EQ(q.pop(nullptr, 0, out), PopResult::no_data);
}

// ---------------------------------------------------------------------------------------
// BoundedQueue, a fast writer and a slow reader on two threads

struct StressOutcome {
  std::uint64_t received = 0;
  std::uint64_t dropped = 0;
  std::uint64_t gave_up = 0;  // drop_oldest: the reader held the oldest too long; new one dropped
  bool last_pushed = true;
  std::uint64_t torn = 0;
  std::uint64_t out_of_order = 0;
  std::uint64_t too_small = 0;
  std::uint64_t first = 0;
  std::uint64_t last = 0;
};

// peek_small: the reader first offers a 2-word destination, so larger samples come back
// too_small and stay queued (while, for drop_oldest, the writer may discard them).
StressOutcome run_stress(std::uint32_t depth, BoundedQueue::WhenFull policy, bool peek_small) {
  constexpr std::uint64_t kCount = 200'000;
  BoundedQueue q(depth, kSlotBytes, policy);
  const PushResult drop =
      policy == BoundedQueue::WhenFull::drop_newest ? PushResult::dropped_newest : PushResult::dropped_oldest;
  std::atomic<bool> done{false};
  StressOutcome out;
  std::thread writer([&] {
    for (std::uint64_t seq = 0; seq < kCount; ++seq) {
      const PushResult r = push_sample(q, seq);
      out.last_pushed = r != PushResult::dropped_newest;
      if (r == drop) {
        ++out.dropped;
      } else if (r == PushResult::dropped_newest) {  // drop_oldest giving up on a slow reader
        ++out.dropped;
        ++out.gave_up;
      } else if (r != PushResult::stored) {
        ADD_FAILURE() << "push " << seq;
      }
    }
    done.store(true, std::memory_order_release);
  });
  bool have_last = false;
  for (;;) {
    // Read done before popping: if it was set and the queue is still empty, every push
    // has landed and the queue is truly drained.
    const bool finished = done.load(std::memory_order_acquire);
    Received r = pop_sample(q, peek_small ? 16 : kSlotBytes);
    if (r.result == PopResult::too_small) {
      ++out.too_small;
      r = pop_sample(q);
      // The writer may have discarded that sample meanwhile; a later one may be there.
    }
    if (r.result == PopResult::new_data) {
      if (!r.intact) ++out.torn;
      if (have_last && r.seq <= out.last) ++out.out_of_order;
      if (!have_last) out.first = r.seq;
      out.last = r.seq;
      have_last = true;
      ++out.received;
      busy_work(100);
    } else if (r.result == PopResult::no_data) {
      if (finished) break;
    } else {
      ADD_FAILURE() << "pop result " << static_cast<int>(r.result);
    }
  }
  writer.join();
  EXPECT_EQ(out.torn, 0u);
  EXPECT_EQ(out.out_of_order, 0u);
  EXPECT_EQ(out.received + out.dropped, kCount);  // every sample accounted for, exactly
  EXPECT_GT(out.dropped, 0u);                      // the writer did outrun the reader
  if (policy == BoundedQueue::WhenFull::drop_newest) {
    EXPECT_EQ(out.first, 0u);  // the queue was empty: the first sample always fits
  } else {
    if (out.last_pushed) {
      EXPECT_EQ(out.last, kCount - 1);  // nothing comes after the last to push it out
    }
  }
  return out;
}

TEST(BoundedQueue, ConcurrentDropNewestDepth1) { run_stress(1, BoundedQueue::WhenFull::drop_newest, false); }
TEST(BoundedQueue, ConcurrentDropNewestDepth5) { run_stress(5, BoundedQueue::WhenFull::drop_newest, false); }
TEST(BoundedQueue, ConcurrentDropNewestDepth64) { run_stress(64, BoundedQueue::WhenFull::drop_newest, false); }
TEST(BoundedQueue, ConcurrentDropOldestDepth1) { run_stress(1, BoundedQueue::WhenFull::drop_oldest, false); }
TEST(BoundedQueue, ConcurrentDropOldestDepth3) { run_stress(3, BoundedQueue::WhenFull::drop_oldest, false); }
TEST(BoundedQueue, ConcurrentDropOldestDepth64) { run_stress(64, BoundedQueue::WhenFull::drop_oldest, false); }
TEST(BoundedQueue, ConcurrentDropOldestWithTooSmallPeeks) {
  const auto out = run_stress(5, BoundedQueue::WhenFull::drop_oldest, true);
  EXPECT_GT(out.too_small, 0u);
}
TEST(BoundedQueue, ConcurrentDropNewestWithTooSmallPeeks) {
  const auto out = run_stress(3, BoundedQueue::WhenFull::drop_newest, true);
  EXPECT_GT(out.too_small, 0u);
}

}  // namespace
