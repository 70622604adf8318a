// Checks of what the test peers printed (tests/dds_peers, tests/lcm_e2e): the poses a
// subscriber received, each field against pose_values.hpp, and the statistics polyportd
// wrote. For end-to-end tests built on tests/support/daemon_harness.hpp.
#pragma once

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "../support/daemon_harness.hpp"
#include "pose_values.hpp"

namespace polyport::test {

// The Poses a subscriber printed.
inline std::vector<Json> poses(const Child& subscriber) {
  std::vector<Json> out;
  for (const Json& j : subscriber.lines()) {
    if (j.contains("id")) out.push_back(j);
  }
  return out;
}

// Every field of a received pose against what the publisher sent as its sample i, where i
// follows from the id (id_offset: what the relay adds).
inline void expect_pose(const Json& got, int id_offset = 0) {
  SCOPED_TRACE("pose " + got.dump());
  const int i = got["id"].get<int>() - id_offset - peer_values::id(0);
  EXPECT_EQ(got["id"].get<int>(), peer_values::id(i) + id_offset);
  EXPECT_DOUBLE_EQ(got["x"].get<double>(), peer_values::x(i));
  EXPECT_FLOAT_EQ(got["heading"].get<float>(), peer_values::heading(i));
  EXPECT_EQ(got["valid"].get<bool>(), peer_values::valid(i));
  EXPECT_EQ(got["frame"].get<std::string>(), peer_values::frame(i));
  ASSERT_EQ(got["samples"].size(), peer_values::sample_count(i));
  for (std::size_t k = 0; k < got["samples"].size(); ++k) {
    EXPECT_DOUBLE_EQ(got["samples"][k].get<double>(), peer_values::sample(i, static_cast<int>(k)));
  }
  for (int k = 0; k < 4; ++k) EXPECT_EQ(got["quad"][k].get<int>(), peer_values::quad(i, k));
}

// Received poses come in publication order, without repeats.
inline void expect_increasing(const std::vector<Json>& got) {
  for (std::size_t k = 1; k < got.size(); ++k) EXPECT_LT(got[k - 1]["id"].get<int>(), got[k]["id"].get<int>());
}

inline const Json* connection(const Json& stats, const std::string& name) {
  for (const Json& c : stats["connections"]) {
    if (c["name"] == name) return &c;
  }
  ADD_FAILURE() << "no connection " << name << " in " << stats.dump(2);
  return nullptr;
}

}  // namespace polyport::test
