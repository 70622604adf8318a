// The Cyclone DDS model's half of the DDS interface (interceptors/dds/dds_endpoint.hpp): a
// Domain over a raw_topic Participant, whose Writers and Readers are raw_topic's. The model
// itself is the shared DdsModel with this factory (daemon/models.cpp).
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include "polyport/profile/thread_settings.hpp"

#include "dds_endpoint.hpp"

namespace polyport::cyclonedds {

// config: Cyclone XML (a file name, "file://" optional, or the XML text), or "" for Cyclone's
// defaults (and CYCLONEDDS_URI from the environment).
Result<std::unique_ptr<dds::Domain>> make_cyclonedds_domain(std::uint32_t domain_id, const std::string& config);

// `config` (a file or XML) followed by a fragment that gives Cyclone's receive thread (recv,
// the only one: multiple receive threads are switched off, Cyclone 0.10 cannot name theirs),
// user delivery thread (dq.user) and timed-event thread (tev) the real-time class and
// priority of `scheduling` (Cyclone's "realtime" class is SCHED_FIFO; a SCHED_OTHER request
// leaves them as they are). Cyclone merges the list in order.
std::string with_thread_scheduling(const std::string& config, const ThreadScheduling& scheduling);

// The configuration used when a profile names none: config/cyclonedds-loopback.xml.
std::string default_config();

}  // namespace polyport::cyclonedds
