// The Fast DDS model's half of the DDS interface (interceptors/dds/dds_endpoint.hpp): a
// Domain over a raw_type Participant, whose Writers and Readers are raw_type's. The model
// itself is the shared DdsModel with this factory (daemon/models.cpp).
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include "dds_endpoint.hpp"

namespace polyport::fastdds {

// config: a Fast DDS XML profiles file whose participant profile marked
// is_default_profile="true" gives the participant's QoS and transports; "" for polyport's
// built-in choice without a file (shared memory + UDPv4 on 127.0.0.1, as the shipped file).
Result<std::unique_ptr<dds::Domain>> make_fastdds_domain(std::uint32_t domain_id, const std::string& config);

// The configuration used when a profile names none: config/fastdds-loopback.xml.
std::string default_config();

}  // namespace polyport::fastdds
