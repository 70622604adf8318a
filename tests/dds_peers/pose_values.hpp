// The values every test peer publishes and checks: sample i of a run is a function of i, so
// a receiver checks every field of what arrived without being told what was sent.
#pragma once

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <string>

namespace peer_values {

inline std::int32_t id(int i) { return 1000 + i; }
inline double x(int i) { return 0.5 * i - 3.25; }
inline float heading(int i) { return static_cast<float>(i) * 0.25F; }
inline bool valid(int i) { return i % 2 == 0; }
inline std::string frame(int i) { return "frame_" + std::to_string(i % 100); }
inline std::uint32_t sample_count(int i) { return static_cast<std::uint32_t>(i % 8); }
inline double sample(int i, int k) { return i * 10.0 + k; }
inline std::int16_t quad(int i, int k) { return static_cast<std::int16_t>(i * 4 + k - 7); }

}  // namespace peer_values
