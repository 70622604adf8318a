// What the DDS models share: a vendor-neutral view of one DDS domain and its raw
// (serialized) endpoints. interceptors/cyclonedds and interceptors/fastdds each implement
// Domain over their SDK; the DDS interceptor (dds_interceptor.hpp), which also opens the
// topics of core's service bridges, is written once against it.
//
// Every sample is its CDR bytes, 4-byte encapsulation header included, on a topic whose type
// name is what idlc / fastddsgen applications register ("demo::Pose"), so generated-code
// applications match polyport's endpoints and nothing is generated for polyport.
//
// Threads: domains, writers and readers are created and destroyed on the control thread.
// Writer::write may be called from any thread. A Reader's callback runs on the SDK's own
// thread; a Reader's destructor returns only once no callback of it is running, and no
// callback starts after it returns. One reader's callbacks do not overlap each other (each
// implementation says how it ensures this).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <string_view>

#include "polyport/base/clock.hpp"
#include "dds_settings.hpp"
#include "polyport/base/result.hpp"
#include "polyport/base/status.hpp"

namespace polyport::dds {

// An RTPS GUID: 12-byte prefix then the 4-byte entity id, as on the wire.
using Guid = std::array<std::uint8_t, 16>;

struct EndpointSpec {
  std::string topic;
  std::string type_name;     // no leading "::"
  DdsQos qos;
  std::uint32_t max_size = 0;  // the largest sample, header included
  // The type has no unbounded string or sequence, so max_size is its own largest encoding,
  // not a cap polyport chose: an SDK may preallocate or share memory of that size (Fast DDS's
  // data sharing with a peer on this host, raw_type.hpp).
  bool bounded = false;
};

// `cdr` is valid only during the call. `source_timestamp`: the writer's DDS source timestamp
// moved onto CLOCK_MONOTONIC with this host's current offset between the clocks.
using ReceiveCallback =
    std::function<void(const std::byte* cdr, std::uint32_t size, MonoTime source_timestamp)>;

class Writer {
 public:
  virtual ~Writer() = default;
  // Publishes one serialized sample (header included). The SDK copies the bytes; the
  // caller keeps them. bad_size: shorter than the header or larger than max_size; timeout:
  // a reliable writer's history stayed full; error: anything else the SDK refuses.
  virtual Status write(const std::byte* cdr, std::uint32_t size) noexcept = 0;
  virtual std::int32_t matched_readers() const noexcept = 0;  // -1: the SDK cannot tell
  virtual Guid guid() const noexcept = 0;
};

class Reader {
 public:
  virtual ~Reader() = default;
  virtual std::int32_t matched_writers() const noexcept = 0;  // -1: the SDK cannot tell
  virtual std::uint64_t received() const noexcept = 0;        // samples handed to the callback
  // Samples the SDK delivered but the reader could not hand over (too large, no header).
  virtual std::uint64_t refused() const noexcept = 0;
  // Samples written by one of polyport's own writers on the topic in this domain, dropped
  // (loop prevention, own_writers.hpp): a sample polyport wrote is never forwarded again.
  virtual std::uint64_t loop_dropped() const noexcept = 0;
};

// One participant on one domain id, with the vendor's configuration. Its readers drop the
// samples of its own writers on the same topic (loop prevention, own_writers.hpp).
class Domain {
 public:
  virtual ~Domain() = default;
  virtual std::string_view vendor() const noexcept = 0;  // "cyclonedds", "fastdds"
  virtual std::uint32_t id() const noexcept = 0;
  virtual Result<std::unique_ptr<Writer>> create_writer(const EndpointSpec& spec) = 0;
  virtual Result<std::unique_ptr<Reader>> create_reader(const EndpointSpec& spec, ReceiveCallback callback) = 0;
};

}  // namespace polyport::dds
