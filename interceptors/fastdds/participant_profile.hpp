// A participant's QoS from a Fast DDS XML profiles file (the format FASTRTPS_DEFAULT_PROFILES_FILE
// names), for raw_type's Participant.
//
// Which profile: the participant profile the file marks is_default_profile="true", else the
// first participant profile in the file. Only that participant profile (with the transport
// descriptors it names) is used; endpoint QoS comes from polyport's profile (DdsQos), never
// from the file's publisher / subscriber profiles.
//
// Why not simply load_XML_profiles_file() and take the factory's default QoS: in Fast DDS 2.9
// loading a file does not change the factory's default participant QoS (it is fixed the
// first time the factory loads its own default file), and profile names and transport ids
// are process-wide. A second file reusing a name ("polyport_loopback", a copy of the shipped
// file with one change) is refused by Fast DDS with only a log line, and the first file's
// profile silently stands in for it. So each file's participant profile names and transport
// ids get a prefix of their own before Fast DDS sees the text, and the profile is then looked
// up by its prefixed name. is_default_profile is dropped on the way, so polyport's files never
// change what a plain Fast DDS participant in the same process gets.
//
// Threads: any set-up thread; a process-wide mutex serializes loading. The file is read on
// every call; Fast DDS is given it once per content (an edited file is loaded again under a
// new prefix, the old profile stays behind unused), keyed by canonical path and content.
#pragma once

#include <string>

#include <fastdds/dds/domain/qos/DomainParticipantQos.hpp>

#include "polyport/base/result.hpp"

namespace polyport::fastdds {

// Errors name the file: missing or unreadable, not well-formed XML (with line and column),
// no participant profile, or refused by Fast DDS (which logs why on stderr).
Result<eprosima::fastdds::dds::DomainParticipantQos> participant_qos_from_file(const std::string& file);

}  // namespace polyport::fastdds
