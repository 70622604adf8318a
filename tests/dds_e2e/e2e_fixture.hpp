// The harness of the DDS end-to-end tests (e2e_test.cpp, vendor_mirror_test.cpp): child
// processes with their output in files, the profile templates of tests/data/dds_e2e filled in
// with a test's own domains, polyportd started and stopped as an operator would, and checks
// of what the peers printed. Every wait is for a line or a file, with a deadline.
#pragma once

#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "../support/daemon_harness.hpp"
#include "pose_checks.hpp"

namespace polyport::test {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using Json = nlohmann::json;

class DdsEndToEnd : public DaemonTest {
 public:  // the scenarios (e2e_scenarios.hpp) drive a test through these
  DdsEndToEnd() : DaemonTest("polyport-dds-e2e") {}

  void SetUp() override {
    if (std::string(CYCLONE_PEER).empty() || std::string(FASTDDS_PEER).empty()) {
      GTEST_SKIP() << "the test peers were not built: " << POLYPORT_PEERS_MISSING;
    }
    // Both SDKs of every child stay on loopback, with the configurations polyport ships.
    setenv("CYCLONEDDS_URI", "file://" POLYPORT_SOURCE_DIR "/config/cyclonedds-loopback.xml", 1);
    setenv("FASTRTPS_DEFAULT_PROFILES_FILE", POLYPORT_SOURCE_DIR "/config/fastdds-loopback.xml", 1);
    DaemonTest::SetUp();
  }

  // Fills in the profile templates with this test's domains; returns the application file.
  fs::path profiles(const std::string& app, int domain_a, int domain_b) {
    return fill_templates(POLYPORT_TEST_DATA "/dds_e2e",
                          {{"@A@", std::to_string(domain_a)}, {"@B@", std::to_string(domain_b)},
                           {"@SRC@", POLYPORT_SOURCE_DIR}},
                          app);
  }
};

// The DDS topic polyport reads for a connection's source port ("component.port"), as the
// component's entry in the statistics has it.
inline const Json* source_topic(const Json& stats, const Json& link) {
  const std::string source = link["source"];
  const auto dot = source.find('.');
  for (const Json& c : stats["components"]) {
    if (c["name"] != source.substr(0, dot) || !c.contains("dds")) continue;
    for (const Json& topic : c["dds"]["topics"]) {
      if (topic["port"] == source.substr(dot + 1) && topic["polyport"] == "reads") return &topic;
    }
  }
  ADD_FAILURE() << "no DDS topic read for " << source << " in " << stats.dump(2);
  return nullptr;
}

// Publishers below run until stopped: a subscriber's reader matches polyport's writer (the
// subscriber sees it) a moment before polyport's writer matches the reader, and samples
// written in between are not for it (volatile topics). So a test waits for enough samples,
// not for particular ones, and checks every field of each that arrived.
inline constexpr const char* kForever = "0";
// What tests/plugins PoseRelay adds to every id it relays.
inline constexpr int kRelayOffset = 100000;

}  // namespace polyport::test
