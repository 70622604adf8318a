// Raw (serialized) topics for Cyclone DDS 0.10: a sertype whose samples are CDR bytes.
//
// Hot path. Who owns what, and which thread runs what:
//  - RawSerdata: one malloc block per sample (the ddsi_serdata header, then the bytes with
//    their encapsulation header), reference-counted by Cyclone; the last
//    ddsi_serdata_unref frees it (serdata_free). Writing makes exactly one, in
//    serdata_from_sample, the same one allocation Cyclone's own dds_write makes; receiving
//    from the network makes one in serdata_from_ser(_iov).
//  - RawWriter::write: the caller's bytes are copied once into that block; the caller keeps
//    its buffer. Runs on the caller's thread; for readers in this process Cyclone also
//    delivers on this thread, so their callbacks run inside write().
//  - RawReader: Cyclone's listener thread (the domain's receive thread for remote data, or
//    the writing thread for local data) calls on_data_available, which takes one serdata at
//    a time and calls the user callback with a pointer into it. That pointer is valid only
//    during the callback; the block is released right after it returns.
//  - Nothing here throws into Cyclone: every callback Cyclone calls is noexcept; an
//    exception from the user callback ends the process (std::terminate), by design.
#include "raw_topic.hpp"

#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <new>
#include <string_view>
#include <utility>
#include <vector>

#include "dds/dds.h"
#include "dds/ddsi/ddsi_keyhash.h"
#include "dds/ddsi/ddsi_serdata.h"
#include "dds/ddsi/ddsi_sertype.h"
#include "dds/ddsi/q_radmin.h"

#include "polyport/base/serial_counter.hpp"

namespace polyport::cyclonedds {

namespace {

// ---- the sample type that dds_write / dds_take see for a raw topic ------------------------

// dds_write(writer, &sample) with {data, size}. dds_take into it copies into `data` when
// `capacity` is enough (size is always set); nothing is allocated for the caller.
struct RawSample {
  std::byte* data;
  std::uint32_t size;
  std::uint32_t capacity;
};

// ---- serdata --------------------------------------------------------------------------------

struct RawSerdata {
  ddsi_serdata c;  // first: Cyclone casts between the two
  std::uint32_t size;
  std::uint32_t pad_;
  // `size` bytes follow, 8-aligned.
  unsigned char* bytes() noexcept { return reinterpret_cast<unsigned char*>(this + 1); }
  const unsigned char* bytes() const noexcept {
    return reinterpret_cast<const unsigned char*>(this + 1);
  }
};
static_assert(sizeof(RawSerdata) % 8 == 0);

const ddsi_serdata_ops& serdata_ops() noexcept;

RawSerdata* as_raw(ddsi_serdata* d) noexcept { return reinterpret_cast<RawSerdata*>(d); }
const RawSerdata* as_raw(const ddsi_serdata* d) noexcept {
  return reinterpret_cast<const RawSerdata*>(d);
}

// Keyless: every sample is the one instance, so the hash is a constant.
constexpr std::uint32_t kKeylessHash = 0x706f6c79u;

RawSerdata* new_serdata(const ddsi_sertype* type, ddsi_serdata_kind kind,
                        std::size_t size) noexcept {
  if (size > UINT32_MAX) return nullptr;
  void* memory = std::malloc(sizeof(RawSerdata) + size);
  if (memory == nullptr) return nullptr;
  auto* d = static_cast<RawSerdata*>(memory);
  std::memset(&d->c, 0, sizeof d->c);
  ddsi_serdata_init(&d->c, type, kind);
  d->c.hash = kKeylessHash;
  d->size = static_cast<std::uint32_t>(size);
  d->pad_ = 0;
  return d;
}

std::uint32_t serdata_get_size(const ddsi_serdata* d) noexcept { return as_raw(d)->size; }

bool serdata_eqkey(const ddsi_serdata*, const ddsi_serdata*) noexcept { return true; }

void serdata_free(ddsi_serdata* d) noexcept { std::free(as_raw(d)); }

// From received fragments: `fragchain` lists byte ranges [min, maxp1) of the serialized
// sample (encapsulation header included), possibly overlapping, in increasing order.
ddsi_serdata* serdata_from_ser(const ddsi_sertype* type, ddsi_serdata_kind kind,
                               const nn_rdata* fragchain, std::size_t size) noexcept {
  RawSerdata* d = new_serdata(type, kind, size);
  if (d == nullptr) return nullptr;
  std::size_t filled = 0;
  for (const nn_rdata* frag = fragchain; frag != nullptr; frag = frag->nextfrag) {
    if (frag->maxp1 <= filled) continue;
    if (frag->min > filled) {  // a hole: never handed to us, but do not copy garbage
      serdata_free(&d->c);
      return nullptr;
    }
    const std::size_t end = std::min<std::size_t>(frag->maxp1, size);
    const unsigned char* payload = NN_RMSG_PAYLOADOFF(frag->rmsg, NN_RDATA_PAYLOAD_OFF(frag));
    std::memcpy(d->bytes() + filled, payload + (filled - frag->min), end - filled);
    filled = end;
    if (filled == size) break;
  }
  if (filled != size) {
    serdata_free(&d->c);
    return nullptr;
  }
  return &d->c;
}

ddsi_serdata* serdata_from_ser_iov(const ddsi_sertype* type, ddsi_serdata_kind kind,
                                   ddsrt_msg_iovlen_t niov, const ddsrt_iovec_t* iov,
                                   std::size_t size) noexcept {
  RawSerdata* d = new_serdata(type, kind, size);
  if (d == nullptr) return nullptr;
  std::size_t filled = 0;
  for (ddsrt_msg_iovlen_t i = 0; i < niov && filled < size; ++i) {
    const std::size_t n = std::min<std::size_t>(iov[i].iov_len, size - filled);
    std::memcpy(d->bytes() + filled, iov[i].iov_base, n);
    filled += n;
  }
  if (filled != size) {
    serdata_free(&d->c);
    return nullptr;
  }
  return &d->c;
}

// Keyless: a key-only serdata carries nothing.
ddsi_serdata* serdata_from_keyhash(const ddsi_sertype* type, const ddsi_keyhash*) noexcept {
  RawSerdata* d = new_serdata(type, SDK_KEY, 0);
  return d == nullptr ? nullptr : &d->c;
}

ddsi_serdata* serdata_from_sample(const ddsi_sertype* type, ddsi_serdata_kind kind,
                                  const void* sample) noexcept {
  const auto* raw = static_cast<const RawSample*>(sample);
  const std::size_t size = kind == SDK_DATA ? raw->size : 0;
  RawSerdata* d = new_serdata(type, kind, size);
  if (d == nullptr) return nullptr;
  if (size > 0) std::memcpy(d->bytes(), raw->data, size);
  return &d->c;
}

void serdata_to_ser(const ddsi_serdata* d, std::size_t off, std::size_t sz, void* buf) noexcept {
  std::memcpy(buf, as_raw(d)->bytes() + off, sz);
}

ddsi_serdata* serdata_to_ser_ref(const ddsi_serdata* d, std::size_t off, std::size_t sz,
                                 ddsrt_iovec_t* ref) noexcept {
  ref->iov_base = const_cast<unsigned char*>(as_raw(d)->bytes() + off);
  ref->iov_len = static_cast<ddsrt_iov_len_t>(sz);
  return ddsi_serdata_ref(d);
}

void serdata_to_ser_unref(ddsi_serdata* d, const ddsrt_iovec_t*) noexcept {
  ddsi_serdata_unref(d);
}

bool serdata_to_sample(const ddsi_serdata* d, void* sample, void**, void*) noexcept {
  auto* raw = static_cast<RawSample*>(sample);
  const RawSerdata* from = as_raw(d);
  raw->size = from->size;
  if (raw->data == nullptr || raw->capacity < from->size) return false;
  std::memcpy(raw->data, from->bytes(), from->size);
  return true;
}

// The "untyped" form is the key alone (Cyclone keeps it in its instance map, with type
// null). Keyless: nothing.
ddsi_serdata* serdata_to_untyped(const ddsi_serdata* d) noexcept {
  RawSerdata* key = new_serdata(d->type, SDK_KEY, 0);
  if (key == nullptr) return nullptr;
  key->c.type = nullptr;
  key->c.hash = d->hash;
  return &key->c;
}

bool serdata_untyped_to_sample(const ddsi_sertype*, const ddsi_serdata*, void* sample, void**,
                               void*) noexcept {
  if (sample != nullptr) static_cast<RawSample*>(sample)->size = 0;
  return true;
}

std::size_t serdata_print(const ddsi_sertype*, const ddsi_serdata* d, char* buf,
                          std::size_t size) noexcept {
  const int n = std::snprintf(buf, size, "(%u bytes of CDR)", as_raw(d)->size);
  return n < 0 ? 0 : static_cast<std::size_t>(n);
}

void serdata_get_keyhash(const ddsi_serdata*, ddsi_keyhash* buf, bool) noexcept {
  std::memset(buf->value, 0, sizeof buf->value);
}

const ddsi_serdata_ops& serdata_ops() noexcept {
  static const ddsi_serdata_ops ops = [] {
    ddsi_serdata_ops o;
    std::memset(&o, 0, sizeof o);  // the iceoryx (DDS_HAS_SHM) entries stay null: no SHM
    o.eqkey = serdata_eqkey;
    o.get_size = serdata_get_size;
    o.from_ser = serdata_from_ser;
    o.from_ser_iov = serdata_from_ser_iov;
    o.from_keyhash = serdata_from_keyhash;
    o.from_sample = serdata_from_sample;
    o.to_ser = serdata_to_ser;
    o.to_ser_ref = serdata_to_ser_ref;
    o.to_ser_unref = serdata_to_ser_unref;
    o.to_sample = serdata_to_sample;
    o.to_untyped = serdata_to_untyped;
    o.untyped_to_sample = serdata_untyped_to_sample;
    o.free = serdata_free;
    o.print = serdata_print;
    o.get_keyhash = serdata_get_keyhash;
    return o;
  }();
  return ops;
}

// ---- sertype --------------------------------------------------------------------------------

struct RawSertype {
  ddsi_sertype c;  // first
};

void sertype_free(ddsi_sertype* tp) noexcept {
  ddsi_sertype_fini(tp);
  delete reinterpret_cast<RawSertype*>(tp);
}

void sertype_zero_samples(const ddsi_sertype*, void* samples, std::size_t count) noexcept {
  std::memset(samples, 0, count * sizeof(RawSample));
}

void sertype_realloc_samples(void** ptrs, const ddsi_sertype*, void* old, std::size_t oldcount,
                             std::size_t count) noexcept {
  auto* samples = static_cast<RawSample*>(std::realloc(old, count * sizeof(RawSample)));
  if (samples == nullptr && count > 0) {  // Cyclone has no way to hear this; keep `old`
    for (std::size_t i = 0; i < count; ++i) ptrs[i] = nullptr;
    return;
  }
  if (count > oldcount) std::memset(samples + oldcount, 0, (count - oldcount) * sizeof(RawSample));
  for (std::size_t i = 0; i < count; ++i) ptrs[i] = samples + i;
}

// A RawSample owns nothing; only the array itself (from realloc_samples) may be freed.
void sertype_free_samples(const ddsi_sertype*, void** ptrs, std::size_t, dds_free_op_t op) noexcept {
  if ((op & DDS_FREE_ALL_BIT) != 0) std::free(ptrs[0]);
}

// Two raw sertypes with the same name (and flags, compared by Cyclone) are the same type.
bool sertype_equal(const ddsi_sertype*, const ddsi_sertype*) noexcept { return true; }
std::uint32_t sertype_hash(const ddsi_sertype*) noexcept { return 0; }

std::size_t sertype_get_serialized_size(const ddsi_sertype*, const void* sample) noexcept {
  return static_cast<const RawSample*>(sample)->size;
}

bool sertype_serialize_into(const ddsi_sertype*, const void* sample, void* dst,
                            std::size_t dst_size) noexcept {
  const auto* raw = static_cast<const RawSample*>(sample);
  if (dst_size < raw->size) return false;
  std::memcpy(dst, raw->data, raw->size);
  return true;
}

const ddsi_sertype_ops& sertype_ops() noexcept {
  static const ddsi_sertype_ops ops = [] {
    ddsi_sertype_ops o;
    std::memset(&o, 0, sizeof o);  // no type id/map/info (no XTypes), no derived sertypes
    o.version = ddsi_sertype_v0;
    o.free = sertype_free;
    o.zero_samples = sertype_zero_samples;
    o.realloc_samples = sertype_realloc_samples;
    o.free_samples = sertype_free_samples;
    o.equal = sertype_equal;
    o.hash = sertype_hash;
    o.get_serialized_size = sertype_get_serialized_size;
    o.serialize_into = sertype_serialize_into;
    return o;
  }();
  return ops;
}

// ---- helpers --------------------------------------------------------------------------------

Error sdk_error(std::string_view what, dds_return_t rc) {
  return make_error(std::string(what) + ": " + dds_strretcode(rc) + " (" + std::to_string(rc) + ")");
}

struct QosDeleter {
  void operator()(dds_qos_t* qos) const noexcept { dds_delete_qos(qos); }
};
using QosPtr = std::unique_ptr<dds_qos_t, QosDeleter>;

dds_duration_t duration(const std::optional<std::int64_t>& ns) { return ns ? *ns : DDS_INFINITY; }

QosPtr to_dds(const Qos& qos) {
  QosPtr q(dds_create_qos());
  dds_qset_reliability(q.get(),
                       qos.reliability == Qos::Reliability::reliable ? DDS_RELIABILITY_RELIABLE
                                                                     : DDS_RELIABILITY_BEST_EFFORT,
                       DDS_MSECS(100));
  dds_qset_durability(q.get(), qos.durability == Qos::Durability::transient_local
                                   ? DDS_DURABILITY_TRANSIENT_LOCAL
                                   : DDS_DURABILITY_VOLATILE);
  const dds_history_kind_t history =
      qos.history == Qos::History::keep_last ? DDS_HISTORY_KEEP_LAST : DDS_HISTORY_KEEP_ALL;
  dds_qset_history(q.get(), history, qos.depth);
  // What a transient-local writer keeps for late readers is its durability service's history,
  // which Cyclone defaults to keep-last 1; make it the endpoint's history, as the profile says
  // (and as ROS 2 does).
  dds_qset_durability_service(q.get(), 0, history, qos.depth, DDS_LENGTH_UNLIMITED, DDS_LENGTH_UNLIMITED,
                              DDS_LENGTH_UNLIMITED);
  dds_qset_deadline(q.get(), duration(qos.deadline_ns));
  dds_qset_lifespan(q.get(), duration(qos.lifespan_ns));
  const dds_liveliness_kind_t liveliness =
      qos.liveliness == Qos::Liveliness::automatic               ? DDS_LIVELINESS_AUTOMATIC
      : qos.liveliness == Qos::Liveliness::manual_by_participant ? DDS_LIVELINESS_MANUAL_BY_PARTICIPANT
                                                                 : DDS_LIVELINESS_MANUAL_BY_TOPIC;
  dds_qset_liveliness(q.get(), liveliness, duration(qos.lease_ns));
  return q;
}

// Partitions belong to the publisher / subscriber: an endpoint with partitions gets one of
// its own. Returns 0 (use the participant's implicit one) when there are none.
Result<dds_entity_t> partition_parent(dds_entity_t participant, const Qos& qos, bool publisher) {
  if (qos.partitions.empty()) return dds_entity_t{0};
  QosPtr q(dds_create_qos());
  std::vector<const char*> names;
  for (const std::string& name : qos.partitions) names.push_back(name.c_str());
  dds_qset_partition(q.get(), static_cast<std::uint32_t>(names.size()), names.data());
  const dds_entity_t parent = publisher ? dds_create_publisher(participant, q.get(), nullptr)
                                        : dds_create_subscriber(participant, q.get(), nullptr);
  if (parent < 0) return sdk_error(publisher ? "creating a publisher" : "creating a subscriber", parent);
  return parent;
}

Result<std::string> check(const Qos& qos) {
  if (qos.history == Qos::History::keep_last && qos.depth < 1)
    return make_error("history keep_last needs a depth of at least 1, not " + std::to_string(qos.depth));
  return std::string();
}

// A topic of a fresh raw sertype named `type_name`. Cyclone interns sertypes per domain: an
// equal one already registered is used instead, and ours is released by Cyclone.
Result<dds_entity_t> create_raw_topic(dds_entity_t participant, const std::string& topic_name,
                                      const std::string& type_name) {
  if (topic_name.empty() || type_name.empty())
    return make_error("a raw topic needs a topic name and a type name");
  auto* sertype = new (std::nothrow) RawSertype{};
  if (sertype == nullptr) return make_error("out of memory creating sertype " + type_name);
  ddsi_sertype_init(&sertype->c, type_name.c_str(), &sertype_ops(), &serdata_ops(),
                    true /* keyless */);
  // dds_create_topic_sertype consumes the caller's reference on success (the topic holds
  // its own; an equal sertype already registered is used instead and ours is released). On
  // failure it depends on where it failed: early checks leave the reference with the caller,
  // later ones release it. An extra reference held across the call, dropped afterwards, is
  // right on every path (at worst the sertype leaks after an early failure; it is never
  // freed twice).
  ddsi_sertype* st = ddsi_sertype_ref(&sertype->c);
  const dds_entity_t topic =
      dds_create_topic_sertype(participant, topic_name.c_str(), &st, nullptr, nullptr, nullptr);
  ddsi_sertype_unref(&sertype->c);
  if (topic < 0)
    return sdk_error("creating topic '" + topic_name + "' of type '" + type_name + "'", topic);
  return topic;
}

}  // namespace

MonoTime monotonic_from_dds_time(std::int64_t dds_time) noexcept {
  const MonoTime mono = mono_now();
  const WallTime wall = wall_now();
  return MonoTime{dds_time - wall.ns + mono.ns};
}

// ---- Participant ----------------------------------------------------------------------------

Result<std::unique_ptr<Participant>> Participant::create(std::uint32_t domain_id,
                                                         const std::string& config) {
  if (domain_id > 230)
    return make_error("DDS domain id " + std::to_string(domain_id) + " is out of range (0..230)");
  dds_entity_t domain = 0;
  if (!config.empty()) {
    std::string uri = config;
    const auto first = config.find_first_not_of(" \t\r\n");
    if (first != std::string::npos && config[first] != '<' && config.rfind("file://", 0) != 0)
      uri = "file://" + config;
    domain = dds_create_domain(domain_id, uri.c_str());
    if (domain == DDS_RETCODE_PRECONDITION_NOT_MET) {
      domain = 0;  // the domain exists in this process already: join it as configured
    } else if (domain < 0) {
      return sdk_error("creating DDS domain " + std::to_string(domain_id) + " from config '" +
                           config.substr(0, 200) + "'",
                       domain);
    }
  }
  const dds_entity_t participant = dds_create_participant(domain_id, nullptr, nullptr);
  if (participant < 0) {
    if (domain > 0) dds_delete(domain);
    return sdk_error("creating a participant in DDS domain " + std::to_string(domain_id),
                     participant);
  }
  return std::unique_ptr<Participant>(new Participant(domain_id, domain, participant));
}

Participant::~Participant() {
  dds_delete(participant_);
  if (domain_ > 0) dds_delete(domain_);
}

// ---- RawWriter ------------------------------------------------------------------------------

Result<std::unique_ptr<RawWriter>> RawWriter::create(Participant& participant,
                                                     const std::string& topic_name,
                                                     const std::string& type_name, const Qos& qos,
                                                     bool ignore_own) {
  if (auto ok = check(qos); !ok) return ok.error();
  auto publisher = partition_parent(participant.handle(), qos, true);
  if (!publisher) return publisher.error();
  auto topic = create_raw_topic(participant.handle(), topic_name, type_name);
  if (!topic) {
    if (publisher.value() > 0) dds_delete(publisher.value());
    return topic.error();
  }
  const QosPtr dds_qos = to_dds(qos);
  if (ignore_own) dds_qset_ignorelocal(dds_qos.get(), DDS_IGNORELOCAL_PARTICIPANT);
  const dds_entity_t parent = publisher.value() > 0 ? publisher.value() : participant.handle();
  const dds_entity_t writer = dds_create_writer(parent, topic.value(), dds_qos.get(), nullptr);
  if (writer < 0) {
    dds_delete(topic.value());
    if (publisher.value() > 0) dds_delete(publisher.value());
    return sdk_error("creating a writer on topic '" + topic_name + "'", writer);
  }
  return std::unique_ptr<RawWriter>(new RawWriter(publisher.value(), topic.value(), writer));
}

RawWriter::~RawWriter() {
  dds_delete(writer_);
  dds_delete(topic_);
  if (publisher_ > 0) dds_delete(publisher_);
}

std::array<std::uint8_t, 16> RawWriter::guid() const noexcept {
  std::array<std::uint8_t, 16> out{};
  dds_guid_t guid;
  if (dds_get_guid(writer_, &guid) == DDS_RETCODE_OK) std::memcpy(out.data(), guid.v, out.size());
  return out;
}

Status RawWriter::write(const std::byte* cdr, std::uint32_t size) noexcept {
  if (cdr == nullptr || size < 4) return Status::bad_size;
  RawSample sample{const_cast<std::byte*>(cdr), size, size};
  const dds_return_t rc = dds_write(writer_, &sample);
  if (rc == DDS_RETCODE_OK) return Status::ok;
  return rc == DDS_RETCODE_TIMEOUT ? Status::timeout : Status::error;
}

std::int32_t RawWriter::matched_readers() const noexcept {
  dds_publication_matched_status_t status{};
  if (dds_get_publication_matched_status(writer_, &status) != DDS_RETCODE_OK) return -1;
  return static_cast<std::int32_t>(status.current_count);
}

// ---- RawReader ------------------------------------------------------------------------------

struct RawReader::State {
  Callback callback;
  std::atomic<std::uint64_t> received{0};
  std::atomic<std::uint64_t> foreign{0};  // serdata of another sertype (not expected)
};

namespace {

void on_data_available(dds_entity_t reader, void* arg) noexcept {
  auto* state = static_cast<RawReader::State*>(arg);
  for (;;) {
    ddsi_serdata* serdata = nullptr;
    dds_sample_info_t info;
    if (dds_takecdr(reader, &serdata, 1, &info, DDS_ANY_STATE) != 1 || serdata == nullptr) break;
    if (info.valid_data) {
      if (serdata->ops == &serdata_ops()) {
        const RawSerdata* raw = as_raw(serdata);
        state->callback(reinterpret_cast<const std::byte*>(raw->bytes()), raw->size,
                        monotonic_from_dds_time(info.source_timestamp));
        add_serial(state->received);  // Cyclone calls a reader's listener one at a time
      } else {
        state->foreign.fetch_add(1, std::memory_order_relaxed);
      }
    }
    ddsi_serdata_unref(serdata);
  }
}

}  // namespace

RawReader::RawReader(std::unique_ptr<State> state) : state_(std::move(state)) {}

Result<std::unique_ptr<RawReader>> RawReader::create(Participant& participant,
                                                     const std::string& topic_name,
                                                     const std::string& type_name,
                                                     Callback callback, const Qos& qos, bool ignore_own) {
  if (!callback) return make_error("a raw reader on '" + topic_name + "' needs a callback");
  if (auto ok = check(qos); !ok) return ok.error();
  auto subscriber = partition_parent(participant.handle(), qos, false);
  if (!subscriber) return subscriber.error();
  auto topic = create_raw_topic(participant.handle(), topic_name, type_name);
  if (!topic) {
    if (subscriber.value() > 0) dds_delete(subscriber.value());
    return topic.error();
  }

  auto state = std::make_unique<State>();
  state->callback = std::move(callback);
  std::unique_ptr<RawReader> reader(new RawReader(std::move(state)));
  reader->topic_ = topic.value();
  reader->subscriber_ = subscriber.value();

  dds_listener_t* listener = dds_create_listener(reader->state_.get());
  dds_lset_data_available(listener, on_data_available);
  const QosPtr dds_qos = to_dds(qos);
  if (ignore_own) dds_qset_ignorelocal(dds_qos.get(), DDS_IGNORELOCAL_PARTICIPANT);
  const dds_entity_t parent = reader->subscriber_ > 0 ? reader->subscriber_ : participant.handle();
  const dds_entity_t handle = dds_create_reader(parent, topic.value(), dds_qos.get(), listener);
  dds_delete_listener(listener);
  if (handle < 0) {
    return sdk_error("creating a reader on topic '" + topic_name + "'", handle);  // the destructor cleans up
  }
  reader->reader_ = handle;
  return reader;
}

RawReader::~RawReader() {
  if (reader_ > 0) dds_delete(reader_);  // returns once no listener call is running
  if (topic_ > 0) dds_delete(topic_);
  if (subscriber_ > 0) dds_delete(subscriber_);
}

std::int32_t RawReader::matched_writers() const noexcept {
  dds_subscription_matched_status_t status{};
  if (dds_get_subscription_matched_status(reader_, &status) != DDS_RETCODE_OK) return -1;
  return static_cast<std::int32_t>(status.current_count);
}

std::uint64_t RawReader::received() const noexcept {
  return state_->received.load(std::memory_order_relaxed);
}

}  // namespace polyport::cyclonedds
