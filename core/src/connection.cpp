// A connection's delivery and hand-off. deliver() is the forwarding path on the writer's
// thread; take() is the reader's side. The buffer (pull mode) is owned by the connection
// and allocated once here.
#include "polyport/connection.hpp"

#include "polyport/component.hpp"

namespace polyport {

namespace {
std::unique_ptr<SampleBuffer> make_buffer(QueuePolicy policy, std::uint32_t depth, std::uint32_t slot_bytes) {
  switch (policy) {
    case QueuePolicy::data:
      return std::make_unique<LatestValueBuffer>(slot_bytes);
    case QueuePolicy::buffer:
      return std::make_unique<BoundedQueue>(depth, slot_bytes, BoundedQueue::WhenFull::drop_newest);
    case QueuePolicy::circular:
      return std::make_unique<BoundedQueue>(depth, slot_bytes, BoundedQueue::WhenFull::drop_oldest);
  }
  return nullptr;
}
}  // namespace

Connection::Connection(DataOutPort& source, DataInPort& target, QueuePolicy policy, std::uint32_t depth)
    : source_(source),
      target_(target),
      policy_(policy),
      depth_(policy == QueuePolicy::data ? 1 : depth),
      buffer_(target.sink() ? nullptr : make_buffer(policy, depth_, target.max_sample_bytes())) {}

std::string Connection::name() const { return source_.full_name() + " -> " + target_.full_name(); }

void Connection::deliver(const std::byte* data, const SampleMeta& meta) noexcept {
  counters_.received.fetch_add(1, std::memory_order_relaxed);
  if (!buffer_) {
    const Status status = target_.sink()->on_sample(data, meta);
    latency_.record((mono_now() - meta.t_in).count);
    if (status == Status::ok) {
      counters_.delivered.fetch_add(1, std::memory_order_relaxed);
    } else {
      counters_.dropped_sink_error.fetch_add(1, std::memory_order_relaxed);
    }
    return;
  }
  const PushResult result = buffer_->push(data, meta);
  latency_.record((mono_now() - meta.t_in).count);
  switch (result) {
    case PushResult::stored:
      counters_.delivered.fetch_add(1, std::memory_order_relaxed);
      break;
    case PushResult::overwritten:
      counters_.delivered.fetch_add(1, std::memory_order_relaxed);
      counters_.overwritten.fetch_add(1, std::memory_order_relaxed);
      break;
    case PushResult::dropped_oldest:
      counters_.delivered.fetch_add(1, std::memory_order_relaxed);
      counters_.dropped_oldest.fetch_add(1, std::memory_order_relaxed);
      break;
    case PushResult::dropped_newest:
      counters_.dropped_queue_full.fetch_add(1, std::memory_order_relaxed);
      break;
    case PushResult::too_large:
      counters_.dropped_too_large.fetch_add(1, std::memory_order_relaxed);
      break;
  }
}

PopResult Connection::take(std::byte* dst, std::uint32_t capacity, SampleMeta& meta) noexcept {
  if (!buffer_) return PopResult::no_data;
  const PopResult result = buffer_->pop(dst, capacity, meta);
  if (result == PopResult::new_data) {
    counters_.read.fetch_add(1, std::memory_order_relaxed);
    age_.record((mono_now() - meta.t_in).count);
  }
  return result;
}

}  // namespace polyport
