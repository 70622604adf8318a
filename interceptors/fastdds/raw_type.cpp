// Fast DDS 2.9 raw endpoints (raw_type.hpp). This is the hot-path file.
//
// Buffer ownership:
//  - Writing: RawWriter::write() wraps the caller's bytes in a RawSample on its stack; Fast
//    DDS asks RawType::serialize() to copy them into a payload from the writer's own pool,
//    synchronously, inside DataWriter::write(). The caller's buffer is free again as soon as
//    write() returns. That copy is the only one polyport adds.
//  - Reading: the RawReader owns one storage block of max_size bytes, allocated at creation.
//    take_next_sample() makes RawType::deserialize() copy the payload there, and the user
//    callback gets a pointer into it, valid only until the callback returns.
// Threads:
//  - The callback runs on whichever Fast DDS thread calls on_data_available(): the
//    participant's receive thread for samples from the network or shared memory, but the
//    *writing thread itself* for a writer in the same process (Fast DDS 2.9 intra-process
//    delivery runs the whole chain inside DataWriter::write()). So two threads can deliver to
//    one reader at once; a DrainGate (polyport/drain_gate.hpp) keeps the single storage block
//    to one of them without a lock: a thread that finds another taking leaves its samples
//    to that one, which takes again before it returns.
//  - The callback must not write to a DataWriter whose reader is in this process on the same
//    topic chain back to itself: intra-process delivery would recurse into Fast DDS
//    (baselines.md §3.4 saw a deadlock in SendBuffersManager::get_buffer doing that). The
//    gate itself does not recurse: a nested notification returns at once.
//  - ~RawReader() waits for a callback in progress to finish, so the callback never runs on a
//    destroyed reader.
#include "raw_type.hpp"

#include <algorithm>
#include <cstring>
#include <exception>
#include <limits>
#include <thread>
#include <utility>

#include <fastdds/dds/domain/DomainParticipant.hpp>
#include <fastdds/dds/domain/DomainParticipantFactory.hpp>
#include <fastdds/dds/domain/qos/DomainParticipantQos.hpp>
#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/publisher/Publisher.hpp>
#include <fastdds/dds/publisher/qos/DataWriterQos.hpp>
#include <fastdds/dds/publisher/qos/PublisherQos.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/DataReaderListener.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>
#include <fastdds/dds/subscriber/qos/DataReaderQos.hpp>
#include <fastdds/dds/subscriber/qos/SubscriberQos.hpp>
#include <fastdds/dds/topic/Topic.hpp>
#include <fastdds/dds/topic/TypeSupport.hpp>
#include <fastdds/rtps/transport/UDPv4TransportDescriptor.h>
#include <fastdds/rtps/transport/shared_mem/SharedMemTransportDescriptor.h>

#include "participant_profile.hpp"
#include "sdk_log.hpp"

namespace polyport::fastdds {

namespace dds = eprosima::fastdds::dds;
using eprosima::fastrtps::rtps::SerializedPayload_t;

namespace {

// The 4-byte encapsulation header: bytes 0-1 the representation id, whose low bit is the
// byte order (CDR_BE 0x0000, CDR_LE 0x0001; XCDR2 ids keep the same rule).
constexpr std::uint32_t kHeaderSize = 4;

std::string describe(const std::exception& e) { return e.what(); }

}  // namespace

// ---- RawType ------------------------------------------------------------------------------

RawType::RawType(const std::string& type_name, std::uint32_t max_size, bool keyed, bool bounded)
    : max_size_(max_size), bounded_(bounded) {
  setName(type_name.c_str());
  // Fast DDS sizes each pooled payload from m_typeSize; the generated types add the same
  // 4 header bytes into it, so this is the payload limit header included.
  m_typeSize = max_size;
  // The topic kind (WITH_KEY / NO_KEY) follows from this, and 2.9 refuses to match
  // endpoints whose kinds differ: it must agree with the peer's IDL (see raw_type.hpp).
  m_isGetKeyDefined = keyed;
  // polyport has no TypeObject for the type, and an invented one could only mislead
  // peers that compare them. Announcing none, 2.9 matches on topic and type name, as it
  // does for fastddsgen 2.3 code generated without -typeobject (what the tests cover).
  auto_fill_type_object(false);
  auto_fill_type_information(false);
}

RawType::~RawType() = default;

bool RawType::serialize(void* data, SerializedPayload_t* payload) {
  const auto* sample = static_cast<const RawSample*>(data);
  if (sample == nullptr || payload == nullptr || sample->size < kHeaderSize ||
      sample->size > payload->max_size) {
    return false;
  }
  std::memcpy(payload->data, sample->data, sample->size);
  payload->length = sample->size;
  // Fast DDS reads the byte order from here (not from the bytes) when it needs it.
  const bool little = (std::to_integer<unsigned>(sample->data[1]) & 1u) != 0;
  payload->encapsulation = little ? CDR_LE : CDR_BE;
  return true;
}

bool RawType::deserialize(SerializedPayload_t* payload, void* data) {
  auto* sample = static_cast<RawSample*>(data);
  if (sample == nullptr || payload == nullptr || payload->length < kHeaderSize ||
      payload->length > sample->capacity) {
    refused_.fetch_add(1, std::memory_order_relaxed);
    return false;
  }
  std::memcpy(sample->storage, payload->data, payload->length);
  sample->data = sample->storage;
  sample->size = payload->length;
  return true;
}

std::function<std::uint32_t()> RawType::getSerializedSizeProvider(void* data) {
  // Called by DataWriter::write() before serialize(): the payload it reserves is this big.
  const auto* sample = static_cast<const RawSample*>(data);
  return [sample]() -> std::uint32_t { return sample->size; };
}

void* RawType::createData() {
  // Fast DDS creates samples for its own use (e.g. take into a loaned sequence); give them
  // their own storage so deserialize() has somewhere to copy to.
  auto* sample = new (std::nothrow) RawSample{};
  if (sample == nullptr) return nullptr;
  sample->storage = new (std::nothrow) std::byte[max_size_];
  sample->capacity = sample->storage != nullptr ? max_size_ : 0;
  return sample;
}

void RawType::deleteData(void* data) {
  auto* sample = static_cast<RawSample*>(data);
  if (sample == nullptr) return;
  delete[] sample->storage;
  delete sample;
}

// Raw bytes do not say which members are the key, so the real key hash cannot be computed
// here. A keyed raw type gives every sample one fixed handle instead: Fast DDS 2.9 calls this
// on the reader for samples that arrive over a transport without a key hash (its writers do
// not send one unless asked), and a reader history that gets no handle aborts
// (DataReaderHistory::update_instance_nts asserts). Consequence: all of a keyed peer's
// instances are one instance on the raw reader. Every sample still arrives (the listener
// takes them as they come), but per-instance history depth and dispose / unregister per
// instance are lost. RawWriter has no keyed option: a peer reader would file every sample
// under the wrong instance. The fix is the real key hash, once polyport's IDL parser records
// @key members.
bool RawType::getKey(void*, eprosima::fastrtps::rtps::InstanceHandle_t* handle, bool) {
  if (!m_isGetKeyDefined || handle == nullptr) return false;
  for (std::uint8_t i = 0; i < 16; ++i) handle->value[i] = 0;
  handle->value[15] = 1;  // not HANDLE_NIL (all zero), which Fast DDS treats as "no instance"
  return true;
}

// ---- Participant --------------------------------------------------------------------------

Result<std::unique_ptr<Participant>> Participant::create(const ParticipantOptions& options) {
  route_sdk_log();
  try {
    auto* factory = dds::DomainParticipantFactory::get_instance();
    dds::DomainParticipantQos qos = dds::PARTICIPANT_QOS_DEFAULT;
    // PARTICIPANT_QOS_DEFAULT itself (not a copy) makes Fast DDS use its own default profile.
    const dds::DomainParticipantQos* chosen = &qos;
    if (!options.profiles_file.empty()) {
      Result<dds::DomainParticipantQos> from_file = participant_qos_from_file(options.profiles_file);
      if (!from_file) return from_file.error();
      qos = std::move(from_file).value();
    } else if (options.transport == Transport::fastdds_defaults) {
      chosen = &dds::PARTICIPANT_QOS_DEFAULT;
    } else {
      qos.name(options.name);
      // Replace the built-in transports (SHM + UDPv4 on every interface) with the chosen ones.
      qos.transport().use_builtin_transports = false;
      const bool udp = options.transport != Transport::shm;
      const bool shm = options.transport != Transport::udp_loopback;
      if (shm) {
        qos.transport().user_transports.push_back(
            std::make_shared<eprosima::fastdds::rtps::SharedMemTransportDescriptor>());
      }
      if (udp) {
        auto descriptor = std::make_shared<eprosima::fastdds::rtps::UDPv4TransportDescriptor>();
        descriptor->interfaceWhiteList.emplace_back("127.0.0.1");
        qos.transport().user_transports.push_back(std::move(descriptor));
      }
    }
    dds::DomainParticipant* native =
        factory->create_participant(static_cast<dds::DomainId_t>(options.domain_id), *chosen);
    if (native == nullptr) {
      flush_sdk_log();
      return make_error("fastdds: cannot create a participant on domain " +
                        std::to_string(options.domain_id) +
                        (options.profiles_file.empty() ? std::string()
                                                       : " from '" + options.profiles_file + "'") +
                        " (Fast DDS logs why)");
    }
    std::unique_ptr<Participant> participant(new Participant());
    participant->domain_id_ = options.domain_id;
    participant->participant_ = native;
    return participant;
  } catch (const std::exception& e) {
    return make_error("fastdds: creating a participant: " + describe(e));
  } catch (...) {
    return make_error("fastdds: creating a participant: unknown exception");
  }
}

Participant::~Participant() {
  if (participant_ == nullptr) return;
  try {
    // Topics (and anything a user made through native()) go with the participant.
    participant_->delete_contained_entities();
    dds::DomainParticipantFactory::get_instance()->delete_participant(participant_);
  } catch (...) {
    // A destructor must not throw; the SDK object leaks rather than take the daemon down.
  }
}

Result<dds::Topic*> Participant::raw_topic(const std::string& topic_name,
                                           const std::string& type_name, std::uint32_t max_size,
                                           bool keyed, bool bounded) {
  std::lock_guard lock(topics_mutex_);
  try {
    dds::TypeSupport existing = participant_->find_type(type_name);
    if (existing.empty()) {
      // The first endpoint of a name registers it; later ones share what it registered
      // (a bounded name stays bounded: every endpoint of one IDL type asks the same).
      dds::TypeSupport type(new RawType(type_name, max_size, keyed, bounded));
      if (type.register_type(participant_) != ReturnCode_t::RETCODE_OK) {
        return make_error("fastdds: cannot register type " + type_name);
      }
    } else {
      auto* raw = dynamic_cast<RawType*>(existing.get());
      if (raw == nullptr) {
        return make_error("fastdds: type " + type_name + " is already registered (not raw)");
      }
      if (raw->m_isGetKeyDefined != keyed) {
        return make_error("fastdds: type " + type_name + " is registered " +
                          (keyed ? "without" : "with") + " a key");
      }
      if (raw->max_size() < max_size) {
        return make_error("fastdds: type " + type_name + " is registered with max size " +
                          std::to_string(raw->max_size()) + ", " + std::to_string(max_size) +
                          " asked for");
      }
    }
    dds::TopicDescription* description = participant_->lookup_topicdescription(topic_name);
    if (description != nullptr) {
      auto* topic = dynamic_cast<dds::Topic*>(description);
      if (topic == nullptr || topic->get_type_name() != type_name) {
        return make_error("fastdds: topic " + topic_name + " exists with type " +
                          description->get_type_name());
      }
      return topic;
    }
    dds::Topic* topic = participant_->create_topic(topic_name, type_name, dds::TOPIC_QOS_DEFAULT);
    if (topic == nullptr) return make_error("fastdds: cannot create topic " + topic_name);
    return topic;
  } catch (const std::exception& e) {
    return make_error("fastdds: topic " + topic_name + ": " + describe(e));
  } catch (...) {
    return make_error("fastdds: topic " + topic_name + ": unknown exception");
  }
}

// ---- QoS ----------------------------------------------------------------------------------

namespace {

// nullopt is infinite. Durations past Duration_t's 32-bit seconds (68 years) are infinite
// too, and negative ones (the loader refuses them) zero, rather than wrapping around.
eprosima::fastrtps::Duration_t duration(const std::optional<std::int64_t>& ns) {
  if (!ns) return eprosima::fastrtps::c_TimeInfinite;
  const std::int64_t value = std::max<std::int64_t>(*ns, 0);
  if (value / 1'000'000'000 >= std::numeric_limits<std::int32_t>::max()) {
    return eprosima::fastrtps::c_TimeInfinite;
  }
  return eprosima::fastrtps::Duration_t(static_cast<std::int32_t>(value / 1'000'000'000),
                                        static_cast<std::uint32_t>(value % 1'000'000'000));
}

// `shares_memory` (shares_memory() below): data sharing where the peer can too, else none.
template <class EndpointQos>
void apply(const DdsQos& in, bool shares_memory, EndpointQos& out) {
  out.reliability().kind = in.reliability == DdsQos::Reliability::reliable
                               ? dds::RELIABLE_RELIABILITY_QOS
                               : dds::BEST_EFFORT_RELIABILITY_QOS;
  out.durability().kind = in.durability == DdsQos::Durability::transient_local
                              ? dds::TRANSIENT_LOCAL_DURABILITY_QOS
                              : dds::VOLATILE_DURABILITY_QOS;
  out.history().kind =
      in.history == DdsQos::History::keep_all ? dds::KEEP_ALL_HISTORY_QOS : dds::KEEP_LAST_HISTORY_QOS;
  out.history().depth = in.depth > 0 ? in.depth : 1;
  if (in.history == DdsQos::History::keep_last) {
    // Fast DDS refuses a depth above the per-instance sample limit (400 by default), so a
    // deep history raises the limits with it.
    dds::ResourceLimitsQosPolicy& limits = out.resource_limits();
    const std::int32_t depth = out.history().depth;
    if (limits.max_samples_per_instance > 0 && limits.max_samples_per_instance < depth) {
      limits.max_samples_per_instance = depth;
    }
    if (limits.max_samples > 0 && limits.max_samples < depth) limits.max_samples = depth;
  }
  out.deadline().period = duration(in.deadline_ns);
  out.lifespan().duration = duration(in.lifespan_ns);
  out.liveliness().kind = in.liveliness == DdsQos::Liveliness::automatic ? dds::AUTOMATIC_LIVELINESS_QOS
                          : in.liveliness == DdsQos::Liveliness::manual_by_participant
                              ? dds::MANUAL_BY_PARTICIPANT_LIVELINESS_QOS
                              : dds::MANUAL_BY_TOPIC_LIVELINESS_QOS;
  out.liveliness().lease_duration = duration(in.lease_ns);
  if (in.lease_ns && out.liveliness().lease_duration != eprosima::fastrtps::c_TimeInfinite) {
    // Fast DDS asserts automatic / per-participant liveliness every announcement_period and
    // refuses a writer whose period (infinite by default) is not below its lease. A third of
    // the lease lets two assertions go missing before a reader declares the writer lost.
    const std::int64_t lease = std::max<std::int64_t>(*in.lease_ns, 3);
    out.liveliness().announcement_period = duration(lease / 3);
  }
  // Data sharing (raw_type.hpp): AUTO only where it can work, else off, explicitly.
  if (shares_memory) {
    out.data_sharing().automatic();
  } else {
    out.data_sharing().off();
  }
}

// Whether an endpoint of `type_name` (registered by raw_topic) may share samples in memory:
// the registered type is bounded and keyless and the QoS allows it.
bool shares_memory(const Participant& participant, const std::string& type_name, const DdsQos& qos) {
  if (qos.data_sharing != DdsQos::DataSharing::automatic) return false;
  const auto* type = dynamic_cast<const RawType*>(participant.native()->find_type(type_name).get());
  return type != nullptr && type->bounded() && !type->m_isGetKeyDefined;
}

template <class GroupQos>
void apply_partitions(const DdsQos& in, GroupQos& out) {
  for (const std::string& name : in.partitions) out.partition().push_back(name.c_str());
}

}  // namespace

// ---- RawWriter ----------------------------------------------------------------------------

Result<std::unique_ptr<RawWriter>> RawWriter::create(Participant& participant,
                                                     const std::string& topic_name,
                                                     const std::string& type_name, const DdsQos& qos,
                                                     std::uint32_t max_size, bool bounded) {
  Result<dds::Topic*> topic = participant.raw_topic(topic_name, type_name, max_size, false, bounded);
  if (!topic) return topic.error();  // also when type_name is registered keyed (see getKey)
  std::unique_ptr<RawWriter> writer(new RawWriter());
  writer->participant_ = &participant;
  writer->max_size_ = max_size;
  try {
    dds::PublisherQos publisher_qos = dds::PUBLISHER_QOS_DEFAULT;
    apply_partitions(qos, publisher_qos);
    writer->publisher_ = participant.native()->create_publisher(publisher_qos);
    if (writer->publisher_ == nullptr) return make_error("fastdds: cannot create a publisher");
    dds::DataWriterQos writer_qos = dds::DATAWRITER_QOS_DEFAULT;
    apply(qos, shares_memory(participant, type_name, qos), writer_qos);
    writer->writer_ = writer->publisher_->create_datawriter(topic.value(), writer_qos);
    if (writer->writer_ == nullptr) {
      return make_error("fastdds: cannot create a writer on " + topic_name);
    }
    return writer;
  } catch (const std::exception& e) {
    return make_error("fastdds: writer on " + topic_name + ": " + describe(e));
  } catch (...) {
    return make_error("fastdds: writer on " + topic_name + ": unknown exception");
  }
}

RawWriter::~RawWriter() {
  if (publisher_ == nullptr) return;
  try {
    if (writer_ != nullptr) publisher_->delete_datawriter(writer_);
    participant_->native()->delete_publisher(publisher_);
  } catch (...) {
  }
}

Status RawWriter::write(const std::byte* cdr, std::uint32_t size) noexcept {
  if (cdr == nullptr || size < kHeaderSize || size > max_size_) return Status::bad_size;
  RawSample sample{cdr, size, nullptr, 0};
  try {
    return writer_->write(&sample) ? Status::ok : Status::error;
  } catch (...) {
    return Status::error;
  }
}

std::int32_t RawWriter::matched_readers() const noexcept {
  try {
    dds::PublicationMatchedStatus status;
    if (writer_->get_publication_matched_status(status) != ReturnCode_t::RETCODE_OK) return 0;
    return status.current_count;
  } catch (...) {
    return 0;
  }
}

std::array<std::uint8_t, 16> RawWriter::guid() const noexcept {
  std::array<std::uint8_t, 16> out{};
  try {
    const eprosima::fastrtps::rtps::GUID_t& guid = writer_->guid();
    std::memcpy(out.data(), guid.guidPrefix.value, 12);
    std::memcpy(out.data() + 12, guid.entityId.value, 4);
  } catch (...) {
  }
  return out;
}

std::uint64_t RawWriter::own_key() const noexcept {
  const std::array<std::uint8_t, 16> id = guid();
  std::uint32_t entity = 0;
  std::memcpy(&entity, id.data() + 12, sizeof entity);
  return entity;
}

// ---- RawReader ----------------------------------------------------------------------------

class RawReader::Listener final : public dds::DataReaderListener {
 public:
  explicit Listener(RawReader& owner) : owner_(owner) {}
  // The SDK passes the reader: with transient_local, history can arrive inside
  // create_datareader(), before RawReader::reader_ is even set.
  void on_data_available(dds::DataReader* reader) override { owner_.on_data_available(reader); }

 private:
  RawReader& owner_;
};

Result<std::unique_ptr<RawReader>> RawReader::create(Participant& participant,
                                                     const std::string& topic_name,
                                                     const std::string& type_name, const DdsQos& qos,
                                                     Callback callback, std::uint32_t max_size,
                                                     bool keyed,
                                                     std::shared_ptr<const polyport::dds::OwnWriters> own,
                                                     bool bounded) {
  if (!callback) return make_error("fastdds: reader on " + topic_name + " without a callback");
  Result<dds::Topic*> topic = participant.raw_topic(topic_name, type_name, max_size, keyed, bounded);
  if (!topic) return topic.error();
  std::unique_ptr<RawReader> reader(new RawReader());
  reader->participant_ = &participant;
  reader->callback_ = std::move(callback);
  reader->capacity_ = max_size;
  reader->own_ = std::move(own);
  try {
    const eprosima::fastrtps::rtps::GuidPrefix_t& prefix = participant.native()->guid().guidPrefix;
    std::memcpy(reader->own_prefix_.data(), prefix.value, reader->own_prefix_.size());
    reader->type_ = dynamic_cast<const RawType*>(participant.native()->find_type(type_name).get());
    if (reader->type_ != nullptr) reader->refused_before_ = reader->type_->refused();
    reader->storage_ = std::make_unique<std::byte[]>(max_size);
    reader->listener_ = std::make_unique<Listener>(*reader);
    dds::SubscriberQos subscriber_qos = dds::SUBSCRIBER_QOS_DEFAULT;
    apply_partitions(qos, subscriber_qos);
    reader->subscriber_ = participant.native()->create_subscriber(subscriber_qos);
    if (reader->subscriber_ == nullptr) return make_error("fastdds: cannot create a subscriber");
    dds::DataReaderQos reader_qos = dds::DATAREADER_QOS_DEFAULT;
    apply(qos, shares_memory(participant, type_name, qos), reader_qos);
    // The listener is attached at creation, so no sample arrives before it is in place.
    reader->reader_ = reader->subscriber_->create_datareader(
        topic.value(), reader_qos, reader->listener_.get(), dds::StatusMask::data_available());
    if (reader->reader_ == nullptr) {
      return make_error("fastdds: cannot create a reader on " + topic_name);
    }
    return reader;
  } catch (const std::exception& e) {
    return make_error("fastdds: reader on " + topic_name + ": " + describe(e));
  } catch (...) {
    return make_error("fastdds: reader on " + topic_name + ": unknown exception");
  }
}

RawReader::~RawReader() {
  // Stop new callbacks from doing work, detach the listener, then wait for one already in
  // progress: Fast DDS 2.9 does not promise that delete_datareader() waits for it.
  stopping_.store(true);
  try {
    if (reader_ != nullptr) reader_->set_listener(nullptr);
  } catch (...) {
  }
  while (in_flight_.load() != 0) std::this_thread::yield();
  if (subscriber_ == nullptr) return;
  try {
    if (reader_ != nullptr) subscriber_->delete_datareader(reader_);
    participant_->native()->delete_subscriber(subscriber_);
  } catch (...) {
  }
}

// The publication handle of a sample is its writer's GUID (prefix, then entity id).
bool RawReader::is_own(const dds::SampleInfo& info) const noexcept {
  const eprosima::fastrtps::rtps::octet* handle = info.publication_handle.value;
  if (std::memcmp(handle, own_prefix_.data(), own_prefix_.size()) != 0) return false;
  std::uint32_t entity = 0;
  std::memcpy(&entity, handle + 12, sizeof entity);
  return own_->contains(entity);
}

void RawReader::on_data_available(dds::DataReader* reader) noexcept {
  in_flight_.fetch_add(1);
  if (!stopping_.load()) {
    drains_.run([this, reader]() noexcept {
      RawSample sample{nullptr, 0, storage_.get(), capacity_};
      dds::SampleInfo info;
      try {
        while (reader->take_next_sample(&sample, &info) == ReturnCode_t::RETCODE_OK) {
          if (!info.valid_data) continue;  // a dispose or unregister: nothing to forward
          if (own_ && is_own(info)) {
            // Written by one of polyport's own writers on this topic: forwarding it again
            // would loop (own_writers.hpp).
            loop_dropped_.fetch_add(1, std::memory_order_relaxed);
            continue;
          }
          // The source timestamp is the writer's wall clock; polyport's path time is
          // CLOCK_MONOTONIC, so carry the sample's age over: mono_now - (wall_now - source).
          // Accurate to the two clocks' skew between peers (zero on one host).
          const std::int64_t age_ns = wall_now().ns - info.source_timestamp.to_ns();
          callback_(sample.data, sample.size, MonoTime{mono_now().ns - age_ns});
        }
      } catch (...) {
        // The callback or the SDK threw: drop the rest of this batch rather than unwind
        // through Fast DDS's listener thread; the next notification takes what is left.
      }
    });
  }
  in_flight_.fetch_sub(1);
}

std::int32_t RawReader::matched_writers() const noexcept {
  try {
    dds::SubscriptionMatchedStatus status;
    if (reader_->get_subscription_matched_status(status) != ReturnCode_t::RETCODE_OK) return 0;
    return status.current_count;
  } catch (...) {
    return 0;
  }
}

}  // namespace polyport::fastdds
