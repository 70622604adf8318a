// The Fast DDS model's half of the DDS interface (interceptors/dds/dds_endpoint.hpp): a
// Domain over a raw_type Participant, whose Writers and Readers are raw_type's. The model
// itself is the shared DdsModel with this factory (daemon/models.cpp).
//
// Threads and ownership: as dds_endpoint.hpp says. The Domain owns its Participant; every
// Writer and Reader it makes must be destroyed before it. A Reader's callback runs on a Fast
// DDS thread (raw_type.cpp says which); one Reader's callbacks never overlap, because
// RawReader takes its samples under its own mutex.
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include "dds_endpoint.hpp"

namespace polyport::fastdds {

// config: the path of a Fast DDS XML profiles file, or "" for the SDK's defaults.
//  - A file: the participant is made from its participant profile marked
//    is_default_profile="true", else its first participant profile (participant_profile.hpp),
//    on `domain_id` (a domainId in the file is not used). Errors name the file: missing,
//    not well-formed XML, no participant profile, refused by Fast DDS.
//  - "": what a plain Fast DDS application gets (Transport::fastdds_defaults in raw_type.hpp:
//    FASTRTPS_DEFAULT_PROFILES_FILE's default profile if set, else built-in transports on
//    every interface).
// EndpointSpec::max_size is the largest sample, header included (0: kDefaultMaxPayload). A
// type is registered once per domain with the first endpoint's max_size; a later endpoint of
// that type asking for more is refused (Fast DDS cannot resize a registered type).
Result<std::unique_ptr<dds::Domain>> make_fastdds_domain(std::uint32_t domain_id, const std::string& config);

// The configuration used when a profile names none: config/fastdds-loopback.xml.
std::string default_config();

}  // namespace polyport::fastdds
