// Cyclone DDS 0.10 endpoints over serialized data: topics of any type, without generated
// code. A raw topic carries each sample as its CDR bytes, 4-byte encapsulation header
// included, under whatever type name we give it ("demo::Pose", spelled as idlc spells
// `module demo { struct Pose }`), so generated-code applications match it.
//
// Scope (the Cyclone model uses these through cyclonedds_interceptor.hpp):
//  - keyless topics only: every sample is one instance; a keyed peer type would not match
//    (the topic kind differs) and keyed instances are not kept apart;
//  - no XTypes type information is sent; Cyclone matches such endpoints by type name;
//  - the QoS below is all that is configurable.
//
// Threads: a Participant, its writers and readers are created and destroyed on a control
// thread. RawWriter::write may be called from any thread (Cyclone serializes writes per
// writer). A RawReader's callback runs on a Cyclone thread (the listener thread of the
// domain: the receive thread for remote data, the writing thread for data written in this
// process).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>

#include "polyport/base/clock.hpp"
#include "dds_settings.hpp"
#include "polyport/base/result.hpp"
#include "polyport/base/status.hpp"

struct ddsi_sertype;

namespace polyport::cyclonedds {

// Endpoint QoS: polyport's DdsQos (profile.hpp), every field mapped onto Cyclone's. Readers
// are reliable by default here too (DDS makes them best-effort), so a raw reader gets every
// sample of a reliable writer; it does not match best-effort writers (requested reliable,
// offered best-effort), so a reader for those must ask for best_effort.
using Qos = DdsQos;

// A DDS domain participant. The configuration is Cyclone XML (what CYCLONEDDS_URI holds):
// either the XML text itself (starting with '<') or a file name ("file://" optional). Empty:
// Cyclone's defaults (and CYCLONEDDS_URI from the environment). With a configuration, the
// participant gets a domain of its own made from it (dds_create_domain); one domain id can be
// configured once per process, so two Participants on one id share the first one's domain,
// and deleting that first one deletes the domain with every participant still in it.
class Participant {
 public:
  static Result<std::unique_ptr<Participant>> create(std::uint32_t domain_id,
                                                     const std::string& config = {});
  ~Participant();
  Participant(const Participant&) = delete;
  Participant& operator=(const Participant&) = delete;

  std::int32_t handle() const noexcept { return participant_; }
  std::uint32_t domain_id() const noexcept { return domain_id_; }

 private:
  Participant(std::uint32_t domain_id, std::int32_t domain, std::int32_t participant)
      : domain_id_(domain_id), domain_(domain), participant_(participant) {}
  std::uint32_t domain_id_;
  std::int32_t domain_;  // 0 when the participant uses an already existing domain
  std::int32_t participant_;
};

// `ignore_own` (writers and readers): the endpoint never matches an endpoint of the same
// participant (Cyclone's ignorelocal QoS), so a reader never gets what a writer of its own
// participant wrote. Loop prevention: see cyclonedds_domain.cpp.

// A writer of serialized samples on topic `topic_name` of type `type_name`.
class RawWriter {
 public:
  static Result<std::unique_ptr<RawWriter>> create(Participant& participant,
                                                   const std::string& topic_name,
                                                   const std::string& type_name,
                                                   const Qos& qos = {}, bool ignore_own = false);
  ~RawWriter();
  RawWriter(const RawWriter&) = delete;
  RawWriter& operator=(const RawWriter&) = delete;

  // Publishes one serialized sample (encapsulation header included; at least 4 bytes). The
  // bytes are copied into the one sample buffer Cyclone allocates per write; the caller
  // keeps `cdr`. bad_size: fewer than 4 bytes; timeout: a reliable writer's history stayed
  // full; error: anything else Cyclone refuses.
  Status write(const std::byte* cdr, std::uint32_t size) noexcept;

  // How many readers match (remote and local); -1 when Cyclone cannot tell.
  std::int32_t matched_readers() const noexcept;
  std::int32_t handle() const noexcept { return writer_; }
  // The writer's RTPS GUID (prefix, then entity id), as readers see it.
  std::array<std::uint8_t, 16> guid() const noexcept;

 private:
  RawWriter(std::int32_t publisher, std::int32_t topic, std::int32_t writer)
      : publisher_(publisher), topic_(topic), writer_(writer) {}
  std::int32_t publisher_;  // 0: the participant's implicit publisher
  std::int32_t topic_;
  std::int32_t writer_;
};

// A reader of serialized samples that hands each one to `callback` on Cyclone's thread.
// `source_timestamp` is the writer's DDS source timestamp (wall clock) moved onto
// CLOCK_MONOTONIC with this host's current offset between the two clocks (so it is only as
// good as the clock agreement between the writer's host and this one).
class RawReader {
 public:
  using Callback =
      std::function<void(const std::byte* cdr, std::uint32_t size, MonoTime source_timestamp)>;

  static Result<std::unique_ptr<RawReader>> create(Participant& participant,
                                                   const std::string& topic_name,
                                                   const std::string& type_name,
                                                   Callback callback, const Qos& qos = {},
                                                   bool ignore_own = false);
  // Deletes the reader first; Cyclone waits for a callback in progress to return.
  ~RawReader();
  RawReader(const RawReader&) = delete;
  RawReader& operator=(const RawReader&) = delete;

  std::int32_t matched_writers() const noexcept;
  std::uint64_t received() const noexcept;  // samples handed to the callback
  std::int32_t handle() const noexcept { return reader_; }

  struct State;  // what the listener sees (raw_topic.cpp)

 private:
  explicit RawReader(std::unique_ptr<State> state);
  std::unique_ptr<State> state_;
  std::int32_t subscriber_ = 0;  // 0: the participant's implicit subscriber
  std::int32_t topic_ = 0;
  std::int32_t reader_ = 0;
};

// Converts a DDS timestamp (ns since the epoch, CLOCK_REALTIME) into CLOCK_MONOTONIC with
// the current offset between the two clocks.
MonoTime monotonic_from_dds_time(std::int64_t dds_time) noexcept;

}  // namespace polyport::cyclonedds
