// A connection's delivery and hand-off. deliver() is the forwarding path on the writer's
// thread; take() is the reader's side. The buffer (pull mode) is owned by the connection
// and allocated once here. Whatever a sample's hand-over counts and records, it adds
// serially (serial_counter.hpp): one writer at a time reaches it (the port's writer, or the
// timer thread through enter / try_enter), one reader takes.
#include "polyport/runtime/connection.hpp"

#include "polyport/base/serial_counter.hpp"
#include "polyport/runtime/component.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>

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

// Where a stage's code starts (for prefetching it): GCC's extension that takes the function
// out of a bound pointer to member function (the implementation a virtual call would reach);
// null elsewhere.
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wpedantic"
#pragma GCC diagnostic ignored "-Wpmf-conversions"
const void* entry_of_decode(const Codec& codec) { return reinterpret_cast<const void*>(codec.*(&Codec::decode)); }
const void* entry_of_encode(const Codec& codec) { return reinterpret_cast<const void*>(codec.*(&Codec::encode)); }
const void* entry_of_run(const MappingProgram& mapping) {
  return reinterpret_cast<const void*>(mapping.*(&MappingProgram::run));
}
#pragma GCC diagnostic pop
#else
const void* entry_of_decode(const Codec&) { return nullptr; }
const void* entry_of_encode(const Codec&) { return nullptr; }
const void* entry_of_run(const MappingProgram&) { return nullptr; }
#endif

}  // namespace

Connection::Connection(DataOutPort& source, DataInPort& target, QueuePolicy policy, std::uint32_t depth,
                       const MappingProgram* mapping)
    : target_(target),
      buffer_(target.sink() ? nullptr
                            : make_buffer(policy, policy == QueuePolicy::data ? 1 : depth, target.max_sample_bytes())),
      mapping_(mapping),
      source_codec_(source.codec()),
      target_codec_(target.codec()),
      policy_(policy),
      converts_(mapping != nullptr || source.wire_format() != target.wire_format() || source.type() != target.type()),
      source_(source),
      depth_(policy == QueuePolicy::data ? 1 : depth) {
  if (buffer_ && policy == QueuePolicy::data) latest_ = static_cast<LatestValueBuffer*>(buffer_.get());
  if (!converts_) return;
  // Flat samples of either type, with the larger port's room for unbounded tails.
  flat_capacity_ = std::max(source.max_sample_bytes(), target.max_sample_bytes());
  if (source.type()) flat_capacity_ = std::max(flat_capacity_, source.type()->size);
  if (target.type()) flat_capacity_ = std::max(flat_capacity_, target.type()->size);
  wire_capacity_ = target.codec() ? target.codec()->max_wire_size(flat_capacity_) : flat_capacity_;
  if (source.codec()) decoded_ = std::make_unique<std::byte[]>(flat_capacity_);
  if (mapping_) mapped_ = std::make_unique<std::byte[]>(flat_capacity_);
  if (target.codec()) encoded_ = std::make_unique<std::byte[]>(wire_capacity_);
  // Taking the flat sample in place, only to copy it into the buffer: a sink, a mapping or an
  // encoder would read it where the wire put it, maybe misaligned.
  if (source.codec() && !mapping_ && !target.codec() && buffer_) in_place_ = source.codec()->in_place();
  // What a converting sample touches first in each stage, prefetched together as it enters
  // deliver() so that the cache misses overlap instead of coming one stage after another
  // (docs/ARCHITECTURE.md, "Cold caches"): the stage's object, its program, its output
  // buffer and the first lines of its code.
  const auto add = [this](const void* line) {
    if (line != nullptr && prefetch_count_ < kPrefetch) prefetch_[prefetch_count_++] = line;
  };
  const auto stage = [&](const void* object, const void* program, const void* buffer, const void* code) {
    add(object);
    add(program);
    add(buffer);
    for (int line = 0; code != nullptr && line < kCodeLines; ++line) add(static_cast<const char*>(code) + 64 * line);
  };
  if (source_codec_) stage(source_codec_, source_codec_->program_data(), decoded_.get(), entry_of_decode(*source_codec_));
  if (mapping_) stage(mapping_, mapping_->program_data(), mapped_.get(), entry_of_run(*mapping_));
  if (target_codec_) stage(target_codec_, target_codec_->program_data(), encoded_.get(), entry_of_encode(*target_codec_));
}

std::string Connection::name() const { return source_.full_name() + " -> " + target_.full_name(); }

std::string Connection::conversion() const {
  if (!converts_) return "passthrough";
  std::string steps(to_string(source_.wire_format()));
  if (source_.codec()) steps += " -> flat";
  if (mapping_) steps += " -> map";
  if (target_.codec()) steps += " -> " + std::string(to_string(target_.wire_format()));
  return steps;
}

void Connection::deliver(const std::byte* data, const SampleMeta& meta) noexcept {
  add_serial(counters_.received);
  if (const std::uint32_t gate = gate_.load(std::memory_order_relaxed); gate != 0 && !subscription_turn(gate))
      [[unlikely]] {
    return;
  }
  if (watchdog_) [[unlikely]] {
    // The source wrote this sample now; what can make it unusable is a silent upstream or
    // its own age.
    // A replaced sample is a drop (stale); the safe value that goes instead is counted by the
    // watchdog, not as delivered.
    const bool too_old = watchdog_->too_old(meta, meta.t_in);
    if (too_old || !watchdog_->fresh(meta.t_in)) {
      counters_.dropped_stale.fetch_add(1, std::memory_order_relaxed);
      if (too_old) watchdog_->counters().stale.fetch_add(1, std::memory_order_relaxed);
      hand_over_safe(meta);
      return;
    }
  }
  if (!converts_ && !filtered_ && !condition_) {
    forward(data, meta);
    return;
  }
  for (int i = 0; i < prefetch_count_; ++i) __builtin_prefetch(prefetch_[i]);
  SampleMeta converted = meta;
  const std::byte* bytes = data;
  // The source's flat sample: what a deadband or a condition compares and a conversion
  // starts from.
  if (const std::byte* flat = in_place_flat(in_place_, bytes, converted.size)) {
    // The flat sample is the wire bytes after the header: nothing to decode (codec.hpp).
    bytes = flat;
    converted.size = in_place_.flat_size;
  } else if (const Codec* codec = source_codec_) {
    const CodecResult decoded = codec->decode(bytes, converted.size, decoded_.get(), flat_capacity_);
    if (!decoded.ok()) {
      if (!converts_ && !condition_) {
        forward(data, meta);  // a passthrough forwards what it cannot judge, as without a deadband
        return;
      }
      counters_.dropped_decode_error.fetch_add(1, std::memory_order_relaxed);
      return;
    }
    bytes = decoded_.get();
    converted.size = decoded.size;
  }
  if (filtered_ && !passes_deadbands(bytes)) {
    counters_.dropped_filtered.fetch_add(1, std::memory_order_relaxed);
    return;
  }
  if (condition_ && !condition_->admits(bytes)) return;  // counted by the condition
  if (!converts_) {
    forward(data, meta);  // the bytes as they came
    return;
  }
  if (mapping_) {
    std::uint32_t mapped_size = 0;
    if (!mapping_->run(bytes, converted.size, mapped_.get(), flat_capacity_, mapped_size)) {
      counters_.dropped_map_error.fetch_add(1, std::memory_order_relaxed);
      return;
    }
    bytes = mapped_.get();
    converted.size = mapped_size;
  }
  if (const Codec* codec = target_codec_) {
    const CodecResult encoded = codec->encode(bytes, converted.size, encoded_.get(), wire_capacity_);
    if (!encoded.ok()) {
      counters_.dropped_encode_error.fetch_add(1, std::memory_order_relaxed);
      return;
    }
    if (encoded.clamped) counters_.clamped.fetch_add(encoded.clamped, std::memory_order_relaxed);
    bytes = encoded_.get();
    converted.size = encoded.size;
  }
  forward(bytes, converted);
}

namespace {

double number_at(const std::byte* flat, const DeadbandField& field) noexcept {
  return flat_number(flat, field.offset, field.kind);
}

}  // namespace

// Writer thread. The first sample passes; later ones when any field moved by more than its
// threshold since the last one that passed.
// A NaN moves to or from a number; after a safe value went out (deadband_primed_ cleared),
// the next sample passes whatever it is, so the target leaves the safe value.
bool Connection::passes_deadbands(const std::byte* flat) noexcept {
  bool passes = !deadband_primed_.load(std::memory_order_relaxed);
  for (std::size_t i = 0; i < deadbands_.size(); ++i) {
    const double now = number_at(flat, deadbands_[i]);
    const double last = deadband_last_[i];
    deadband_now_[i] = now;
    if (!passes && (std::isnan(now) != std::isnan(last) || std::abs(now - last) > deadbands_[i].threshold)) {
      passes = true;
    }
  }
  if (passes) {
    std::copy(deadband_now_.begin(), deadband_now_.end(), deadband_last_.begin());
    deadband_primed_.store(true, std::memory_order_relaxed);
  }
  return passes;
}

// Writer thread. One sample in every `gate` goes, starting with the first this connection
// sees; a multiple set meanwhile takes effect where the count stands (it wraps under a
// smaller one), so a subscriber's cycle never stretches beyond its new multiple.
bool Connection::subscription_turn(std::uint32_t gate) noexcept {
  if (gate == kUnsubscribed) {
    counters_.skipped.fetch_add(1, std::memory_order_relaxed);
    return false;
  }
  if (phase_ >= gate) phase_ = 0;
  const bool turn = phase_ == 0;
  phase_ = phase_ + 1 == gate ? 0 : phase_ + 1;
  if (!turn) counters_.skipped.fetch_add(1, std::memory_order_relaxed);
  return turn;
}

void Connection::set_subscription(std::uint32_t every) noexcept {
  // UINT32_MAX is the gate's "unsubscribed" mark: a multiple that large is one short of it.
  if (every == kUnsubscribed) every = kUnsubscribed - 1;
  every_.store(every, std::memory_order_relaxed);
  gate_.store(every, std::memory_order_relaxed);
}

void Connection::forward(const std::byte* data, const SampleMeta& meta) noexcept {
  if (interval_.count > 0) {
    hand_over_limited(data, meta);
  } else {
    hand_over(data, meta);
  }
}

// Newest wins: a sample whose turn has not come is held (replacing one held before); the
// timer thread hands it over when its turn comes, unless a newer sample arrives after it.
// Polling: every sample is held, and the timer thread hands the newest over at each tick.
void Connection::hand_over_limited(const std::byte* data, const SampleMeta& meta) noexcept {
  if (!enter()) {
    counters_.dropped_sink_error.fetch_add(1, std::memory_order_relaxed);
    return;
  }
  const bool held_before = has_held_.load(std::memory_order_relaxed);
  if (!poll_ && meta.t_in.ns - last_sent_.load(std::memory_order_relaxed) >= interval_.count) {
    if (held_before) has_held_.store(false, std::memory_order_relaxed);
    last_sent_.store(meta.t_in.ns, std::memory_order_relaxed);
    hand_over_claimed(data, meta);
  } else if (meta.size > held_capacity_) {
    counters_.dropped_too_large.fetch_add(1, std::memory_order_relaxed);
    leave();
    return;
  } else {
    std::memcpy(held_.get(), data, meta.size);
    held_meta_ = meta;
    has_held_.store(true, std::memory_order_relaxed);
  }
  // The one held before is replaced by this newer sample either way.
  if (held_before) counters_.dropped_rate_limited.fetch_add(1, std::memory_order_relaxed);
  leave();
}

MonoTime Connection::held_due() const noexcept {
  if (!has_held_.load(std::memory_order_relaxed)) return MonoTime{};
  return MonoTime{last_sent_.load(std::memory_order_relaxed) + interval_.count};
}

void Connection::set_poll(Nanos period) {
  set_rate_limit(period);
  poll_ = true;
}

bool Connection::release_held(MonoTime now) noexcept {
  if (!try_enter()) return false;  // the writer has the connection right now
  if (has_held_.load(std::memory_order_relaxed) &&
      (poll_ || now.ns - last_sent_.load(std::memory_order_relaxed) >= interval_.count)) {
    has_held_.store(false, std::memory_order_relaxed);
    if (watchdog_ && !watchdog_->fresh(now)) {
      // Held from before the watchdog tripped: the target keeps the safe value.
      counters_.dropped_stale.fetch_add(1, std::memory_order_relaxed);
    } else {
      last_sent_.store(now.ns, std::memory_order_relaxed);
      hand_over_claimed(held_.get(), held_meta_);
    }
  }
  leave();
  return true;
}

// A safe value goes out (claimed): a held sample must not follow it, and the deadband must let
// the next sample through.
void Connection::safe_value_sent() noexcept {
  if (has_held_.load(std::memory_order_relaxed)) {
    has_held_.store(false, std::memory_order_relaxed);
    counters_.dropped_stale.fetch_add(1, std::memory_order_relaxed);
  }
  deadband_primed_.store(false, std::memory_order_relaxed);
}

void Connection::set_rate_limit(Nanos interval) {
  interval_ = interval;
  held_capacity_ = std::max(wire_capacity_, std::max(source_.max_sample_bytes(), target_.max_sample_bytes()));
  held_ = std::make_unique<std::byte[]>(held_capacity_);
  guarded_ = true;
}

void Connection::set_deadbands(std::vector<DeadbandField> fields) {
  deadbands_ = std::move(fields);
  filtered_ = !deadbands_.empty();
  deadband_last_.assign(deadbands_.size(), 0.0);
  deadband_now_.assign(deadbands_.size(), 0.0);
  need_source_flat();
}

void Connection::set_condition(std::unique_ptr<EventCondition> condition) {
  condition_ = std::move(condition);
  need_source_flat();
}

// A deadband or a condition reads the source's flat sample even where the bytes pass through.
void Connection::need_source_flat() {
  in_place_ = {};  // deadbands and conditions read the flat sample's numbers: decode it
  if (source_.codec() && !decoded_) {
    flat_capacity_ = std::max(source_.max_sample_bytes(), source_.type() ? source_.type()->size : 0u);
    decoded_ = std::make_unique<std::byte[]>(flat_capacity_);
  }
}

void Connection::set_watchdog(std::unique_ptr<ConnectionWatchdog> watchdog) {
  watchdog_ = std::move(watchdog);
  // Push mode: the timer thread writes the safe value to the sink, the writer its samples.
  if (push_mode()) guarded_ = true;
}

namespace {
// A per-thread address: who holds a connection's hand-over flag.
const void* this_thread_token() noexcept {
  thread_local const char token = 0;
  return &token;
}
}  // namespace

bool Connection::enter() noexcept {
  const void* me = this_thread_token();
  if (holder_.load(std::memory_order_relaxed) == me) return false;  // re-entered from its own sink
  for (int spins = 0; busy_.exchange(true, std::memory_order_acquire); ++spins) {
    if (spins < 256) {
#if defined(__x86_64__) || defined(__i386__)
      __builtin_ia32_pause();
#endif
      continue;
    }
    // The timer thread holds it for one hand-over; if that thread is not running (a writer
    // at a real-time priority on its CPU), sleep on the flag so that it can finish.
    waiters_.fetch_add(1, std::memory_order_relaxed);
    busy_.wait(true, std::memory_order_relaxed);
    waiters_.fetch_sub(1, std::memory_order_relaxed);
  }
  holder_.store(me, std::memory_order_relaxed);
  return true;
}

bool Connection::try_enter() noexcept {
  if (busy_.exchange(true, std::memory_order_acquire)) return false;
  holder_.store(this_thread_token(), std::memory_order_relaxed);
  return true;
}

void Connection::leave() noexcept {
  holder_.store(nullptr, std::memory_order_relaxed);
  busy_.store(false, std::memory_order_release);
  if (waiters_.load(std::memory_order_relaxed) != 0) busy_.notify_all();
}

void Connection::hand_over(const std::byte* data, const SampleMeta& meta, bool count) noexcept {
  if (!guarded_) {
    hand_over_claimed(data, meta, count);
    return;
  }
  if (!enter()) {
    // The target's own sink wrote into this connection again: refused, not a deadlock.
    counters_.dropped_sink_error.fetch_add(1, std::memory_order_relaxed);
    return;
  }
  hand_over_claimed(data, meta, count);
  leave();
}

// `count`: false for a safe value, which the watchdog counts and which is no sample of the
// connection's.
void Connection::hand_over_claimed(const std::byte* data, const SampleMeta& meta, bool count) noexcept {
  if (!buffer_) {
    const Status status = to_sink(data, meta);
    if (!count) return;
    if (status == Status::ok) {
      add_serial(counters_.delivered);
    } else {
      counters_.dropped_sink_error.fetch_add(1, std::memory_order_relaxed);
    }
    return;
  }
  const PushResult result = latest_ ? latest_->push_direct(data, meta) : buffer_->push(data, meta);
  const MonoTime stored = mono_now();
  latency_.record_serial((stored - meta.t_in).count);
  if (meta.t_source.ns != 0) transit_.record_serial((stored - meta.t_source).count);
  if (!count) return;
  switch (result) {
    case PushResult::stored:
      add_serial(counters_.delivered);
      break;
    case PushResult::overwritten:
      add_serial(counters_.delivered);
      add_serial(counters_.overwritten);
      break;
    case PushResult::dropped_oldest:
      add_serial(counters_.delivered);
      add_serial(counters_.dropped_oldest);
      break;
    case PushResult::dropped_newest:
      add_serial(counters_.dropped_queue_full);
      break;
    case PushResult::too_large:
      add_serial(counters_.dropped_too_large);
      break;
  }
}

Status Connection::to_sink(const std::byte* data, const SampleMeta& meta) noexcept {
  // polyport's own time ends where the sink (an adaptor, or a foreign SDK's write) begins.
  const MonoTime handed = mono_now();
  latency_.record_serial((handed - meta.t_in).count);
  if (meta.t_source.ns != 0) transit_.record_serial((handed - meta.t_source).count);
  const Status status = target_.sink()->on_sample(data, meta);
  sink_time_.record_serial((mono_now() - handed).count);
  return status;
}

// The safe value instead of a sample (already in the target's format: no conversion).
void Connection::hand_over_safe(const SampleMeta& meta) noexcept {
  watchdog_->counters().safe_values.fetch_add(1, std::memory_order_relaxed);
  const SampleMeta safe{watchdog_->safe_size(), meta.t_in, {}};
  if (!guarded_) {
    safe_value_sent();
    hand_over_claimed(watchdog_->safe_bytes(), safe, false);
    return;
  }
  if (!enter()) {
    counters_.dropped_sink_error.fetch_add(1, std::memory_order_relaxed);
    return;
  }
  safe_value_sent();
  hand_over_claimed(watchdog_->safe_bytes(), safe, false);
  leave();
}

Connection::SafeValueResult Connection::emit_safe_value(MonoTime now) noexcept {
  if (!watchdog_ || buffer_) return SafeValueResult::sent;  // pull-mode readers take it themselves
  if (!try_enter()) return SafeValueResult::busy;  // a sample is on its way to the sink right now
  safe_value_sent();
  const Status status = to_sink(watchdog_->safe_bytes(), SampleMeta{watchdog_->safe_size(), now, {}});
  leave();
  if (status != Status::ok) {
    watchdog_->counters().safe_value_errors.fetch_add(1, std::memory_order_relaxed);
    return SafeValueResult::refused;
  }
  watchdog_->counters().safe_values.fetch_add(1, std::memory_order_relaxed);
  return SafeValueResult::sent;
}

PopResult Connection::take(std::byte* dst, std::uint32_t capacity, SampleMeta& meta) noexcept {
  if (!buffer_) return PopResult::no_data;
  if (!watchdog_) {
    const PopResult result = buffer_->pop(dst, capacity, meta);
    if (result == PopResult::new_data) {
      add_serial(counters_.read);
      age_.record_serial((mono_now() - meta.t_in).count);
    }
    return result;
  }
  // With a watchdog: one clock read, at the start, for freshness, age and the age histogram.
  const MonoTime now = mono_now();
  if (!watchdog_->fresh(now)) return take_safe(dst, capacity, meta, now);
  const PopResult result = buffer_->pop(dst, capacity, meta);
  if (result == PopResult::old_data && reader_has_safe_) {
    return take_safe(dst, capacity, meta, now);  // nothing new since the safe value: keep it
  }
  if (result == PopResult::new_data) {
    if (watchdog_->too_old(meta, now)) {
      counters_.dropped_stale.fetch_add(1, std::memory_order_relaxed);
      watchdog_->counters().stale.fetch_add(1, std::memory_order_relaxed);
      return take_safe(dst, capacity, meta, now);
    }
    reader_has_safe_ = false;
    add_serial(counters_.read);
    age_.record_serial((now - meta.t_in).count);
  }
  return result;
}

// The reader gets the safe value as a new sample once, then as the value it already has
// (`data`) or nothing new (queues), until samples pass again.
PopResult Connection::take_safe(std::byte* dst, std::uint32_t capacity, SampleMeta& meta, MonoTime now) noexcept {
  const std::uint32_t size = watchdog_->safe_size();
  if (size > capacity) return PopResult::too_small;
  const bool again = reader_has_safe_;
  if (again && policy_ != QueuePolicy::data) return PopResult::no_data;
  std::copy_n(watchdog_->safe_bytes(), size, dst);
  meta = SampleMeta{size, now, {}};
  if (again) return PopResult::old_data;
  reader_has_safe_ = true;
  watchdog_->counters().safe_values.fetch_add(1, std::memory_order_relaxed);
  return PopResult::new_data;
}

}  // namespace polyport
