// What a DDS component profile says in the DDS models' own elements (model_section.hpp):
// <dds> (domain, configuration file, QoS, service limits), each port's <topic> and <qos>,
// and each service operation's dds_request / dds_reply structs. DdsSection reads them for
// both DDS models (cyclonedds, fastdds); the adaptor and the model read the DdsSettings it
// returns. SDK-free, so profiles are checked on machines without either SDK.
#pragma once

#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "polyport/base/diagnostics.hpp"
#include "polyport/profile/call_limits.hpp"
#include "polyport/profile/model_section.hpp"
#include "polyport/profile/profile.hpp"
#include "polyport/profile/thread_settings.hpp"

namespace polyport {

// DDS endpoint QoS. The defaults are ROS 2's default profile, which is also what idlc /
// fastddsgen example applications use: reliable, volatile, keep_last 10, no deadline,
// infinite lifespan, automatic liveliness with an infinite lease, the default partition.
// A component's <dds><qos> sets its ports' QoS; a port's <qos> overrides it field by field.
struct DdsQos {
  enum class Reliability : std::uint8_t { best_effort, reliable };
  enum class Durability : std::uint8_t { volatile_, transient_local };
  enum class History : std::uint8_t { keep_last, keep_all };
  enum class Liveliness : std::uint8_t { automatic, manual_by_participant, manual_by_topic };
  enum class DataSharing : std::uint8_t { automatic, off };
  Reliability reliability = Reliability::reliable;
  Durability durability = Durability::volatile_;
  History history = History::keep_last;
  std::int32_t depth = 10;                  // keep_last only
  std::optional<std::int64_t> deadline_ns;  // nullopt: infinite
  std::optional<std::int64_t> lifespan_ns;  // nullopt: infinite
  Liveliness liveliness = Liveliness::automatic;
  std::optional<std::int64_t> lease_ns;     // nullopt: infinite
  std::vector<std::string> partitions;      // empty: the default ("") partition
  // Fast DDS only (Cyclone DDS warns and ignores it): automatic lets an endpoint of a
  // bounded, keyless type share samples in memory with a peer on this host that can too
  // (Fast DDS's data sharing, its AUTO kind); off never does (e.g. containers that do not
  // share /dev/shm but look like one host to Fast DDS).
  DataSharing data_sharing = DataSharing::automatic;

  bool operator==(const DdsQos&) const = default;
};

namespace dds {

// The structs on an operation's request and reply topics (a correlation header, then the
// payload; see docs/PROFILES.md).
struct OperationTypes {
  std::string request_type;
  std::string reply_type;  // empty for a oneway operation
};

struct PortSettings {
  std::string topic;  // the topic (service ports: the base of the request/reply topics); empty: the port name
  DdsQos qos;         // the component's <dds><qos>, then the port's <qos>
  std::map<std::string, OperationTypes, std::less<>> operations;  // service ports, by operation name

  const OperationTypes* operation(std::string_view name) const;
};

// CallLimits: per service port, both directions; call_timeout_ns bounds a DDS provider's reply.
struct DdsSettings final : ModelSettings, CallLimits {
  std::uint32_t domain = 0;
  // The middleware configuration file (absolute): nullopt = the model's shipped default; an
  // empty path = the SDK's own defaults (for Cyclone: CYCLONEDDS_URI from the environment).
  std::optional<std::filesystem::path> config;
  DdsQos qos;                               // <dds><qos>: the default of every port
  SourceLocation where;                     // the <dds> element; line 0 when there is none
  // <receive_thread>: the scheduling of the SDK's receive and delivery threads of the domain,
  // where the vendor lets polyport set it (Cyclone DDS; not Fast DDS 2.9: a warning).
  std::optional<ThreadScheduling> receive_threads;
  std::map<std::string, PortSettings, std::less<>> ports;  // by port name

  PortSettings defaults;  // of a port the profile does not describe: the component's QoS
  // A port's settings; `defaults` for a port the profile did not describe.
  const PortSettings& port(std::string_view name) const;
};

// The DDS settings of a component profile; the defaults when it has none (a profile built
// in code rather than loaded).
std::shared_ptr<const DdsSettings> dds_settings(const ComponentProfile& profile);

class DdsSection final : public ModelSection {
 public:
  const ModelVocabulary& vocabulary() const noexcept override;
  std::unique_ptr<ComponentSectionReader> reader(std::string_view model) const override;
};

}  // namespace dds
}  // namespace polyport
