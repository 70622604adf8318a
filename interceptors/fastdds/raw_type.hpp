// Fast DDS 2.9 endpoints over serialized payloads: the native half of the fastdds proxy.
//
// polyport never links code generated for a user's type. A RawType registers under the
// name a fastddsgen-generated application registers ("demo::Pose", the IDL's qualified
// name), so Fast DDS matches it with that application's readers and writers by topic and
// type name, and moves the CDR bytes (4-byte encapsulation header included) untouched.
// Decoding, when a connection needs it, is the adaptor's job (polyport's own CDR codec).
//
// Lifetimes: a Participant must outlive every RawWriter and RawReader made on it. Every
// SDK call is wrapped: Fast DDS exceptions never leave this library; set-up returns
// Result, the forwarding path returns Status.
#pragma once

#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <string>

#include <fastdds/dds/topic/TopicDataType.hpp>

#include "polyport/base/clock.hpp"
#include "polyport/runtime/drain_gate.hpp"
#include "dds_settings.hpp"
#include "polyport/base/result.hpp"
#include "polyport/base/status.hpp"
#include "own_writers.hpp"

namespace eprosima::fastdds::dds {
class DomainParticipant;
class Publisher;
class Subscriber;
class DataWriter;
class DataReader;
struct SampleInfo;
class Topic;
}  // namespace eprosima::fastdds::dds

namespace polyport::fastdds {

// The largest payload (header included) a raw endpoint carries unless told otherwise.
inline constexpr std::uint32_t kDefaultMaxPayload = 64 * 1024;

// One sample as the raw type sees it. Writing: `data`/`size` point at the caller's bytes
// (nothing is copied until Fast DDS serializes into its own payload). Reading: Fast DDS
// deserializes into `storage` (owned by whoever created the sample, `capacity` bytes) and
// `data`/`size` then point there.
struct RawSample {
  const std::byte* data = nullptr;
  std::uint32_t size = 0;
  std::byte* storage = nullptr;
  std::uint32_t capacity = 0;
};

// A TopicDataType that copies serialized bytes between a RawSample and a payload.
class RawType final : public eprosima::fastdds::dds::TopicDataType {
 public:
  // `type_name`: exactly what the peer's generated PubSubType passes to setName()
  // (fastddsgen 2.3: the IDL's qualified name with "::", no leading "::").
  // `max_size`: the largest payload, header included.
  // `keyed`: whether the peer's type has @key members. Fast DDS 2.9 matches only endpoints
  // of the same topic kind (WITH_KEY / NO_KEY), so this must agree with the peer's IDL or
  // nothing matches. A keyed raw type cannot compute instance handles from raw bytes (it
  // does not know which members are the key), so it is for readers only, and files every
  // sample under one instance (see getKey in raw_type.cpp for what that loses).
  // `bounded`: max_size is the type's own largest encoding (no unbounded string or sequence),
  // which makes Fast DDS treat the type as bounded: endpoints of a bounded keyless type may
  // then share samples in memory with peers on this host (data sharing, below).
  RawType(const std::string& type_name, std::uint32_t max_size, bool keyed = false, bool bounded = false);
  ~RawType() override;

  bool is_bounded() const override { return bounded_; }

  bool serialize(void* data, eprosima::fastrtps::rtps::SerializedPayload_t* payload) override;
  bool deserialize(eprosima::fastrtps::rtps::SerializedPayload_t* payload, void* data) override;
  std::function<std::uint32_t()> getSerializedSizeProvider(void* data) override;
  void* createData() override;  // a RawSample with max_size bytes of storage
  void deleteData(void* data) override;
  bool getKey(void* data, eprosima::fastrtps::rtps::InstanceHandle_t* handle,
              bool force_md5 = false) override;

  std::uint32_t max_size() const noexcept { return max_size_; }
  bool bounded() const noexcept { return bounded_; }
  // Samples refused: larger than the reading side's storage, or shorter than the header.
  // Fast DDS drops them (and logs); this is the only place polyport can count them.
  std::uint64_t refused() const noexcept { return refused_.load(std::memory_order_relaxed); }

 private:
  std::uint32_t max_size_;
  bool bounded_;
  std::atomic<std::uint64_t> refused_{0};
};

// Which transports a participant uses. All stay on this host.
//  - shm_and_udp_loopback (the default): shared memory plus UDPv4 restricted to 127.0.0.1.
//    Why: it is the only restricted option that reaches a Fast DDS application left at its
//    default QoS (built-in transports: SHM + UDPv4 on every interface). Such a peer
//    announces only its non-loopback addresses (e.g. eth0's); a participant whitelisted to
//    127.0.0.1 cannot send there, so UDP alone never completes discovery with it (tested:
//    no match within 15 s). SPDP still meets over loopback multicast and the rest goes over
//    shared memory. Costs: stale /dev/shm segments if the daemon is killed (`fastdds shm
//    clean`), and the median on the reference VM was a little above UDP-only
//    (baselines.md section 3.4: 25.9 vs 23.7 us, small samples).
//  - udp_loopback: UDPv4 only, 127.0.0.1. Reaches peers that are also restricted to
//    loopback, or hosts / network namespaces where lo is the only interface (then every
//    peer announces 127.0.0.1). No shared memory to leak.
//  - shm: shared memory only. Reaches only peers that also use SHM, on this host, sharing
//    /dev/shm (not another container without it).
//  - fastdds_defaults: whatever a plain Fast DDS application gets: the default participant
//    profile of the file FASTRTPS_DEFAULT_PROFILES_FILE names (or DEFAULT_FASTRTPS_PROFILES.xml
//    in the working directory), which Fast DDS loads by itself, else its built-in transports
//    (SHM + UDPv4 on every interface: not restricted to this host). `name` is not used.
// Data sharing (Fast DDS 2.9 moves a sample through a shared-memory pool of the writer's
// instead of a transport, for keyless types that declare themselves bounded, between endpoints
// on one host): a raw endpoint uses it, as Fast DDS's AUTO kind does, when its type is bounded
// (RawType's `bounded`: an IDL type without unbounded strings or sequences, whose largest
// encoding is then each pool slot's size), keyless, and its DdsQos allows it (data_sharing,
// default automatic); the peer decides too (fastddsgen's code for a bounded type uses it by
// default). Why: on one core, the native relay of the benchmarks was 1-9 us slower one-way
// without it, and polyport, before it shared memory, was as slow as that relay (README,
// "Fast DDS on one core, explained"). Else samples go over the participant's transports.
enum class Transport : std::uint8_t { udp_loopback, shm, shm_and_udp_loopback, fastdds_defaults };

struct ParticipantOptions {
  std::uint32_t domain_id = 0;
  Transport transport = Transport::shm_and_udp_loopback;
  std::string name = "polyport";
  // A Fast DDS XML profiles file: when set, the participant QoS (transports and name
  // included) is the file's participant profile marked is_default_profile="true", else its
  // first participant profile (participant_profile.hpp), and `transport` and `name` are not
  // used. config/fastdds-loopback.xml is the file form of shm_and_udp_loopback.
  std::string profiles_file;
};

// Endpoint QoS is polyport's DdsQos (profile.hpp), every field mapped onto Fast DDS's
// DataWriterQos / DataReaderQos (raw_type.cpp, apply): reliability, durability, history kind
// and depth, deadline, lifespan (writers and, as Fast DDS 2.9 has it, readers), liveliness
// kind and lease; nullopt durations are infinite. Partitions go on the endpoint's own
// publisher / subscriber. Its defaults (reliable, volatile, keep_last 10) are what ROS 2's
// default profile and fastddsgen's example apps use, so a default peer matches (a reliable
// reader does not match a best-effort writer, and a transient_local reader does not match a
// volatile one).

class Participant {
 public:
  static Result<std::unique_ptr<Participant>> create(const ParticipantOptions& options);
  ~Participant();
  Participant(const Participant&) = delete;
  Participant& operator=(const Participant&) = delete;

  std::uint32_t domain_id() const noexcept { return domain_id_; }
  // The SDK object, for tests and tools; owned by this Participant.
  eprosima::fastdds::dds::DomainParticipant* native() const noexcept { return participant_; }

  // Registers a RawType (once per name; a later call with a larger max_size or another
  // `keyed` is refused, since Fast DDS cannot replace a registered type) and finds or
  // creates the topic.
  Result<eprosima::fastdds::dds::Topic*> raw_topic(const std::string& topic_name,
                                                   const std::string& type_name,
                                                   std::uint32_t max_size, bool keyed = false,
                                                   bool bounded = false);

 private:
  Participant() = default;
  std::uint32_t domain_id_ = 0;
  eprosima::fastdds::dds::DomainParticipant* participant_ = nullptr;
  std::mutex topics_mutex_;  // raw_topic may be called from any set-up thread
};

class RawWriter {
 public:
  static Result<std::unique_ptr<RawWriter>> create(Participant& participant,
                                                   const std::string& topic_name,
                                                   const std::string& type_name, const DdsQos& qos,
                                                   std::uint32_t max_size = kDefaultMaxPayload,
                                                   bool bounded = false);
  ~RawWriter();
  RawWriter(const RawWriter&) = delete;
  RawWriter& operator=(const RawWriter&) = delete;

  // Publishes one serialized sample (encapsulation header included). bad_size: shorter than
  // the header or larger than max_size; error: Fast DDS refused or threw.
  Status write(const std::byte* cdr, std::uint32_t size) noexcept;
  // Readers currently matched (from the SDK's publication-matched status).
  std::int32_t matched_readers() const noexcept;
  // The writer's RTPS GUID: the 12-byte prefix, then the 4-byte entity id, as on the wire.
  std::array<std::uint8_t, 16> guid() const noexcept;
  // Its key among polyport's writers (own_writers.hpp): the entity id.
  std::uint64_t own_key() const noexcept;

 private:
  RawWriter() = default;
  Participant* participant_ = nullptr;
  eprosima::fastdds::dds::Publisher* publisher_ = nullptr;
  eprosima::fastdds::dds::DataWriter* writer_ = nullptr;
  std::uint32_t max_size_ = 0;
};

class RawReader {
 public:
  // Runs on a Fast DDS thread (see raw_type.cpp); `cdr` is valid only during the call.
  using Callback = std::function<void(const std::byte* cdr, std::uint32_t size,
                                      MonoTime source_timestamp)>;

  static Result<std::unique_ptr<RawReader>> create(Participant& participant,
                                                   const std::string& topic_name,
                                                   const std::string& type_name, const DdsQos& qos,
                                                   Callback callback,
                                                   std::uint32_t max_size = kDefaultMaxPayload,
                                                   bool keyed = false,
                                                   std::shared_ptr<const polyport::dds::OwnWriters> own = nullptr,
                                                   bool bounded = false);
  ~RawReader();
  RawReader(const RawReader&) = delete;
  RawReader& operator=(const RawReader&) = delete;

  std::int32_t matched_writers() const noexcept;
  // Samples dropped because they did not fit max_size (or had no header) since this reader
  // was made. Counted by the participant's RawType, so shared by every raw reader of that
  // type on the participant that exists at the same time.
  std::uint64_t refused() const noexcept { return type_ != nullptr ? type_->refused() - refused_before_ : 0; }
  // Samples of a writer in `own` (create) of this participant, dropped before the callback.
  std::uint64_t loop_dropped() const noexcept { return loop_dropped_.load(std::memory_order_relaxed); }

 private:
  class Listener;
  RawReader() = default;
  void on_data_available(eprosima::fastdds::dds::DataReader* reader) noexcept;
  bool is_own(const eprosima::fastdds::dds::SampleInfo& info) const noexcept;

  Participant* participant_ = nullptr;
  eprosima::fastdds::dds::Subscriber* subscriber_ = nullptr;
  eprosima::fastdds::dds::DataReader* reader_ = nullptr;
  const RawType* type_ = nullptr;  // owned by the participant's type registry
  std::uint64_t refused_before_ = 0;  // the type's count when this reader was made
  std::unique_ptr<Listener> listener_;
  Callback callback_;
  std::unique_ptr<std::byte[]> storage_;
  std::uint32_t capacity_ = 0;
  DrainGate drains_;  // see raw_type.cpp: more than one Fast DDS thread may deliver
  std::atomic<bool> stopping_{false};
  std::atomic<int> in_flight_{0};
  std::shared_ptr<const polyport::dds::OwnWriters> own_;  // null: every sample goes to the callback
  std::array<std::uint8_t, 12> own_prefix_{};   // the participant's GUID prefix
  std::atomic<std::uint64_t> loop_dropped_{0};
};

}  // namespace polyport::fastdds
