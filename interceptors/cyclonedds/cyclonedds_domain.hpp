// The Cyclone DDS model's half of the DDS interface (interceptors/dds/dds_endpoint.hpp): a
// Domain over a raw_topic Participant, whose Writers and Readers are raw_topic's. The model
// itself is the shared DdsModel with this factory (daemon/models.cpp).
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include "dds_endpoint.hpp"

namespace polyport::cyclonedds {

// config: Cyclone XML (a file name, "file://" optional, or the XML text), or "" for Cyclone's
// defaults (and CYCLONEDDS_URI from the environment).
Result<std::unique_ptr<dds::Domain>> make_cyclonedds_domain(std::uint32_t domain_id, const std::string& config);

// The configuration used when a profile names none: config/cyclonedds-loopback.xml.
std::string default_config();

}  // namespace polyport::cyclonedds
