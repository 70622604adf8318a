// Participant QoS from a Fast DDS XML profiles file: see participant_profile.hpp for which
// profile is used and why names get a per-file prefix.
#include "participant_profile.hpp"

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <exception>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <mutex>
#include <sstream>
#include <utility>
#include <vector>

#include <fastdds/dds/domain/DomainParticipantFactory.hpp>
#include <pugixml.hpp>

#include "sdk_log.hpp"

namespace polyport::fastdds {

namespace {

namespace dds = eprosima::fastdds::dds;

// "file:line:col" for a byte offset into `text`, as polyport's own profile errors read.
std::string where(const std::string& file, const std::string& text, std::ptrdiff_t offset) {
  std::size_t line = 1;
  std::size_t column = 1;
  const auto end = static_cast<std::size_t>(std::max<std::ptrdiff_t>(0, offset));
  for (std::size_t i = 0; i < end && i < text.size(); ++i) {
    if (text[i] == '\n') {
      ++line;
      column = 1;
    } else {
      ++column;
    }
  }
  return file + ":" + std::to_string(line) + ":" + std::to_string(column);
}

// The <profiles> elements: Fast DDS accepts them under a <dds> root or as the root itself.
std::vector<pugi::xml_node> profiles_of(const pugi::xml_document& doc) {
  std::vector<pugi::xml_node> out;
  const pugi::xml_node root = doc.document_element();
  if (std::strcmp(root.name(), "profiles") == 0) {
    out.push_back(root);
  } else if (std::strcmp(root.name(), "dds") == 0) {
    for (pugi::xml_node node : root.children("profiles")) out.push_back(node);
  }
  return out;
}

void set_text(pugi::xml_node element, const std::string& text) {
  element.text().set(text.c_str());
}

// Gives every participant profile name and transport id in the document `prefix` (references
// from a participant's <userTransports> included), drops is_default_profile from participant
// profiles, and returns the prefixed name of the chosen profile ("" if there is none).
std::string rename(pugi::xml_document& doc, const std::string& prefix) {
  std::string chosen;
  std::string first;
  for (pugi::xml_node profiles : profiles_of(doc)) {
    for (pugi::xml_node descriptors : profiles.children("transport_descriptors")) {
      for (pugi::xml_node descriptor : descriptors.children("transport_descriptor")) {
        for (pugi::xml_node id : descriptor.children("transport_id")) {
          set_text(id, prefix + id.text().get());
        }
      }
    }
    for (pugi::xml_node participant : profiles.children("participant")) {
      pugi::xml_attribute name = participant.attribute("profile_name");
      if (!name) continue;  // Fast DDS refuses the file then; its log says so
      const std::string renamed = prefix + name.value();
      name.set_value(renamed.c_str());
      if (first.empty()) first = renamed;
      pugi::xml_attribute is_default = participant.attribute("is_default_profile");
      if (is_default && chosen.empty() && std::strcmp(is_default.value(), "true") == 0) chosen = renamed;
      if (is_default) participant.remove_attribute(is_default);
      for (pugi::xml_node transports : participant.child("rtps").children("userTransports")) {
        for (pugi::xml_node id : transports.children("transport_id")) {
          set_text(id, prefix + id.text().get());
        }
      }
    }
  }
  return chosen.empty() ? first : chosen;
}

std::mutex g_mutex;
// The prefixed name of each file's chosen profile, by canonical path and content: an edited
// file (a configuration reload) is loaded again under a new prefix. Guarded by g_mutex.
std::map<std::pair<std::string, std::string>, std::string> g_loaded;
unsigned g_attempts = 0;  // numbers the prefixes; guarded by g_mutex

}  // namespace

Result<dds::DomainParticipantQos> participant_qos_from_file(const std::string& file) {
  route_sdk_log();
  std::error_code ec;
  std::string path = std::filesystem::weakly_canonical(file, ec).string();
  if (ec) path = file;

  std::lock_guard lock(g_mutex);
  try {
    std::ifstream in(file, std::ios::binary);
    if (!in) {
      return make_error("fastdds: cannot open the XML profiles file '" + file + "': " + std::strerror(errno));
    }
    std::string text{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
    auto* factory = dds::DomainParticipantFactory::get_instance();
    auto found = g_loaded.find({path, text});
    if (found == g_loaded.end()) {
      pugi::xml_document doc;
      const pugi::xml_parse_result parsed = doc.load_buffer(text.data(), text.size());
      if (!parsed) {
        return make_error("fastdds: " + where(file, text, parsed.offset) +
                          ": not well-formed XML: " + parsed.description());
      }
      // A prefix no earlier attempt used, so a file refused half-way leaves nothing behind
      // that a later one could collide with.
      const std::string prefix = "polyport" + std::to_string(g_attempts++) + "/";
      const std::string profile = rename(doc, prefix);
      if (profile.empty()) {
        return make_error("fastdds: '" + file +
                          "' has no participant profile (<profiles><participant profile_name=\"...\">)");
      }
      std::ostringstream out;
      doc.save(out, "", pugi::format_raw);
      const std::string renamed = out.str();
      if (factory->load_XML_profiles_string(renamed.c_str(), renamed.size()) != ReturnCode_t::RETCODE_OK) {
        flush_sdk_log();
        return make_error("fastdds: Fast DDS refused the XML profiles file '" + file + "' (Fast DDS logs why)");
      }
      found = g_loaded.emplace(std::make_pair(path, std::move(text)), profile).first;
    }
    dds::DomainParticipantQos qos;
    if (factory->get_participant_qos_from_profile(found->second, qos) != ReturnCode_t::RETCODE_OK) {
      // Fast DDS 2.9 can report success for a document while dropping one of its profiles
      // (seen with a profile name already in use); the profile is missing then.
      flush_sdk_log();
      return make_error("fastdds: Fast DDS refused the participant profile in '" + file +
                        "' (Fast DDS logs why)");
    }
    return qos;
  } catch (const std::exception& e) {
    return make_error("fastdds: XML profiles file '" + file + "': " + e.what());
  } catch (...) {
    return make_error("fastdds: XML profiles file '" + file + "': unknown exception");
  }
}

}  // namespace polyport::fastdds
