// One data or event connection: from an output port to an input port, with the reading
// side's policy, its lock-free buffer (pull mode) and its instrumentation.
//
// deliver() runs on the writer's thread (the forwarding path): no allocation, no lock,
// no logging. take() runs on the reader's thread. Counters are relaxed atomics read by the
// stats thread; histograms are lock-free.
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "polyport/codecs/codec.hpp"
#include "polyport/runtime/histogram.hpp"
#include "polyport/codecs/mapping.hpp"
#include "polyport/runtime/event_condition.hpp"
#include "polyport/runtime/port.hpp"
#include "polyport/runtime/watchdog.hpp"

namespace polyport {

struct ConnectionCounters {
  std::atomic<std::uint64_t> received{0};          // samples that entered the connection
  std::atomic<std::uint64_t> delivered{0};         // stored for the reader, or taken by a sink
  std::atomic<std::uint64_t> read{0};              // new samples the reader took (pull mode)
  std::atomic<std::uint64_t> overwritten{0};       // `data`: an unread value was replaced
  std::atomic<std::uint64_t> dropped_queue_full{0};   // `buffer` full: the new sample
  std::atomic<std::uint64_t> dropped_oldest{0};       // `circular` full: the oldest sample
  std::atomic<std::uint64_t> dropped_too_large{0};    // larger than the connection's slots
  std::atomic<std::uint64_t> dropped_sink_error{0};   // the sink (adaptor) refused it
  std::atomic<std::uint64_t> dropped_decode_error{0}; // the source's bytes did not decode
  std::atomic<std::uint64_t> dropped_map_error{0};    // the mapping could not run on it
  std::atomic<std::uint64_t> dropped_encode_error{0}; // the target format could not hold it
  std::atomic<std::uint64_t> clamped{0};              // values clamped to range by the encoder
  std::atomic<std::uint64_t> dropped_stale{0};        // older than the watchdog's max_age (replaced)
  std::atomic<std::uint64_t> dropped_filtered{0};     // within every deadband: nothing moved enough
  std::atomic<std::uint64_t> dropped_rate_limited{0}; // held for the rate limit, then replaced by a newer one
  // Push timed: not this subscriber's cycle, or it had unsubscribed. Not a drop: it did not ask.
  std::atomic<std::uint64_t> skipped{0};

  std::uint64_t dropped() const noexcept {
    return dropped_queue_full.load(std::memory_order_relaxed) +
           dropped_oldest.load(std::memory_order_relaxed) +
           dropped_too_large.load(std::memory_order_relaxed) +
           dropped_sink_error.load(std::memory_order_relaxed) +
           dropped_decode_error.load(std::memory_order_relaxed) +
           dropped_map_error.load(std::memory_order_relaxed) +
           dropped_encode_error.load(std::memory_order_relaxed) +
           dropped_stale.load(std::memory_order_relaxed) +
           dropped_filtered.load(std::memory_order_relaxed) +
           dropped_rate_limited.load(std::memory_order_relaxed);
  }
};

// A deadband's number, resolved in the source type's flat layout.
struct DeadbandField {
  std::uint32_t offset = 0;
  TypeKind kind = TypeKind::float64;
  double threshold = 0.0;
  std::string path;  // as the profile names it, for check and stats
};

// Layout: a sample that comes every few milliseconds finds none of the connection in the
// caches, and each cache line it touches is a trip to memory (0.2-0.3 us each on a shared
// VM). So what deliver() reads for every sample sits in the object's first two lines and
// the counters it bumps in the next; the rest (policies' state, histograms) follows.
class Connection {
 public:
  // Pull mode when target has no sink: a buffer of the given policy and depth, with slots
  // of target.max_sample_bytes(). Push mode (target has a sink): no buffer.
  // The bytes pass through untouched when both ports share a wire format and a type and
  // there is no mapping; otherwise the connection decodes the source's format (if not
  // flat), runs the mapping (if any) and encodes the target's format (if not flat), in
  // scratch buffers it allocates here, once.
  Connection(DataOutPort& source, DataInPort& target, QueuePolicy policy, std::uint32_t depth,
             const MappingProgram* mapping = nullptr);
  Connection(const Connection&) = delete;
  Connection& operator=(const Connection&) = delete;

  // Writer thread; called by DataOutPort and PushServer. Hot: the path's functions share a
  // page of code (.text.hot). Hidden, like the private steps below, so that calls inside the
  // library are direct: through the PLT, each call would touch two more cache lines (a PLT
  // stub and a GOT entry) that a sample every few milliseconds finds cold.
  [[gnu::hot, gnu::visibility("hidden")]] void deliver(const std::byte* data, const SampleMeta& meta) noexcept;
  PopResult take(std::byte* dst, std::uint32_t capacity, SampleMeta& meta) noexcept;  // reader

  DataOutPort& source() const noexcept { return source_; }
  DataInPort& target() const noexcept { return target_; }
  QueuePolicy policy() const noexcept { return policy_; }
  std::uint32_t depth() const noexcept { return depth_; }
  bool push_mode() const noexcept { return buffer_ == nullptr; }
  bool passthrough() const noexcept { return !converts_; }
  std::string name() const;  // "A.out -> B.in"
  std::string conversion() const;  // "passthrough" or the steps, e.g. "xcdr1 -> flat -> map -> lcm"

  // Policies, set before the connection carries samples (control thread).
  // The fail-safe (watchdog.hpp); null: none.
  void set_watchdog(std::unique_ptr<ConnectionWatchdog> watchdog);
  ConnectionWatchdog* watchdog() const noexcept { return watchdog_.get(); }
  // At most one sample per `interval`, newest wins (allocates the held sample's slot).
  void set_rate_limit(Nanos interval);
  Nanos rate_interval() const noexcept { return interval_; }
  // Polling (JOrocos): samples are not forwarded as they come; every `period` the newest one
  // that came since the last tick is handed over (nothing when none came).
  void set_poll(Nanos period);
  bool polled() const noexcept { return poll_; }
  // Samples pass only when a field moved by more than its threshold (allocates the decode
  // scratch when the source has a wire format of its own).
  void set_deadbands(std::vector<DeadbandField> fields);
  const std::vector<DeadbandField>& deadbands() const noexcept { return deadbands_; }
  // An event with a condition (event_condition.hpp): samples go to the target only when the
  // condition holds for them and its activation is active (allocates the decode scratch as a
  // deadband does).
  void set_condition(std::unique_ptr<EventCondition> condition);
  EventCondition* condition() const noexcept { return condition_.get(); }
  // Push timed (push_server.hpp): the connection takes the first of every `every` samples of
  // its source (0: every sample, no subscription). A client may change it while samples flow
  // (subscribe / unsubscribe on its input port); unsubscribed, it takes none.
  void set_subscription(std::uint32_t every) noexcept;
  void unsubscribe() noexcept { gate_.store(kUnsubscribed, std::memory_order_relaxed); }
  std::uint32_t subscription_every() const noexcept { return every_.load(std::memory_order_relaxed); }
  bool subscribed() const noexcept { return gate_.load(std::memory_order_relaxed) != kUnsubscribed; }

  // The timer thread's side (connection_timer.hpp). Each returns false, having done nothing,
  // when the writer has the connection at that moment: try again shortly.
  // Push mode: hands the safe value to the sink.
  enum class SafeValueResult : std::uint8_t { sent, busy, refused };
  SafeValueResult emit_safe_value(MonoTime now) noexcept;
  // When the sample held for the rate limit may go; MonoTime{} when none is held. (Polling:
  // the timer thread keeps the ticks itself, in next_poll.)
  MonoTime held_due() const noexcept;
  // Hands the held sample over if its turn has come.
  bool release_held(MonoTime now) noexcept;

  const ConnectionCounters& counters() const noexcept { return counters_; }
  // t_out - t_in, polyport's own time: entry until stored for the reader (pull) or handed to
  // the sink (push), conversion included.
  const LatencyHistogram& latency() const noexcept { return latency_; }
  // t_read - t_in: entry until the reader took the sample (pull mode only).
  const LatencyHistogram& age() const noexcept { return age_; }
  // Push mode: time spent in the target's sink (for a foreign model, its SDK's write), which
  // latency() does not include.
  const LatencyHistogram& sink_time() const noexcept { return sink_time_; }
  // t_out - t_source, for samples whose model stamps their source (a DDS writer's source
  // timestamp, a CAN frame's kernel receive time; both moved onto CLOCK_MONOTONIC): the
  // transfer from the source component to this connection's reader or sink, polyport's own
  // time included. Empty when the source model gives no stamp.
  const LatencyHistogram& transit() const noexcept { return transit_; }

 private:
  [[gnu::hot, gnu::visibility("hidden")]] void forward(const std::byte* data, const SampleMeta& meta) noexcept;
  [[gnu::hot, gnu::visibility("hidden")]] void hand_over(const std::byte* data, const SampleMeta& meta,
                                                         bool count = true) noexcept;
  [[gnu::hot, gnu::visibility("hidden")]] void hand_over_claimed(const std::byte* data, const SampleMeta& meta,
                                                                 bool count = true) noexcept;
  void safe_value_sent() noexcept;
  void hand_over_limited(const std::byte* data, const SampleMeta& meta) noexcept;
  bool passes_deadbands(const std::byte* flat) noexcept;
  bool subscription_turn(std::uint32_t gate) noexcept;
  Status to_sink(const std::byte* data, const SampleMeta& meta) noexcept;
  // The writer's and the timer thread's turns at the target, when both can reach it (a
  // watchdog on a push-mode target, a rate limit): the writer waits only while the timer
  // thread hands over a safe value or a held sample; the timer thread never waits.
  // enter() returns false when this thread holds the flag already (the target's sink wrote
  // into this connection again): the caller drops the sample instead of waiting for itself.
  bool enter() noexcept;
  bool try_enter() noexcept;
  void leave() noexcept;
  void hand_over_safe(const SampleMeta& meta) noexcept;
  PopResult take_safe(std::byte* dst, std::uint32_t capacity, SampleMeta& meta, MonoTime now) noexcept;

  // ---- Every sample (first two cache lines).
  DataInPort& target_;
  std::unique_ptr<SampleBuffer> buffer_;
  LatestValueBuffer* latest_ = nullptr;  // buffer_ for `data`, called without the vtable
  const MappingProgram* mapping_;
  const Codec* source_codec_;  // the ports' codecs (set before wiring)
  const Codec* target_codec_;
  // A converting sample's cold lines, prefetched together as it enters deliver() (set at
  // construction): each stage's object, program, output buffer and first kCodeLines of code.
  static constexpr int kCodeLines = 4;
  static constexpr int kPrefetch = 3 * (3 + kCodeLines);
  const void* prefetch_[kPrefetch] = {};
  int prefetch_count_ = 0;
  InPlaceLayout in_place_{};  // the source's samples that need no decoding (codec.hpp)
  std::unique_ptr<ConnectionWatchdog> watchdog_;
  std::unique_ptr<EventCondition> condition_;
  // Scratch for conversions (writer thread only): the source's flat sample, the mapped
  // flat sample, the target's encoded bytes.
  std::unique_ptr<std::byte[]> decoded_;
  std::unique_ptr<std::byte[]> mapped_;
  std::unique_ptr<std::byte[]> encoded_;
  std::uint32_t flat_capacity_ = 0;
  std::uint32_t wire_capacity_ = 0;
  // Rate limit: the interval between hand-overs (0: none).
  Nanos interval_{0};
  // Push timed: gate_ is the multiple in force (0: none, kUnsubscribed: none taken), every_
  // the one subscribed to; phase_ counts the source's samples (writer thread).
  static constexpr std::uint32_t kUnsubscribed = UINT32_MAX;
  std::atomic<std::uint32_t> gate_{0};
  QueuePolicy policy_;
  bool converts_;
  bool guarded_ = false;   // enter()/leave() around every hand-over
  bool filtered_ = false;  // deadbands_ is not empty
  // ---- The counters deliver() bumps (received, delivered, overwritten) lead the next line.
  alignas(64) ConnectionCounters counters_;

 public:
  std::int64_t next_poll = 0;  // timer thread: the next tick of a polled connection

 private:
  // ---- Policies' state, read only when the profile set them.
  DataOutPort& source_;
  std::uint32_t depth_;
  bool reader_has_safe_ = false;  // reader thread: the safe value was taken since the last sample
  std::atomic<bool> busy_{false};
  std::atomic<const void*> holder_{nullptr};  // the thread that holds busy_ (re-entry check)
  std::atomic<int> waiters_{0};               // writers asleep on busy_
  // Rate limit: the last hand-over and the sample held for its turn.
  bool poll_ = false;
  std::atomic<std::int64_t> last_sent_{INT64_MIN / 2};
  std::unique_ptr<std::byte[]> held_;
  std::uint32_t held_capacity_ = 0;
  SampleMeta held_meta_{};
  std::atomic<bool> has_held_{false};
  // Deadbands (writer thread): the values of the last sample that passed, and of this one.
  std::vector<DeadbandField> deadbands_;
  std::vector<double> deadband_last_;
  std::vector<double> deadband_now_;
  std::atomic<bool> deadband_primed_{false};  // cleared when a safe value goes out
  void need_source_flat();
  std::atomic<std::uint32_t> every_{0};
  std::uint32_t phase_ = 0;
  LatencyHistogram latency_;
  LatencyHistogram age_;
  LatencyHistogram sink_time_;
  LatencyHistogram transit_;
};

}  // namespace polyport
