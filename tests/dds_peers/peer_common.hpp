// What the two test peers (cyclone_peer, fastdds_peer) share: stopping on a signal, JSON
// lines on stdout, waiting for a condition, and the one-line form of a received Pose.
#pragma once

#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdint>
#include <cstdio>
#include <string>
#include <thread>

namespace peer_common {

using Clock = std::chrono::steady_clock;

// SIGINT / SIGTERM end every loop, so the participant is deleted properly (for Fast DDS: its
// shared-memory segments are released).
inline std::atomic<bool> g_stop{false};
extern "C" inline void on_signal(int) { g_stop = true; }
inline void stop_on_signals() {
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
}

inline void line(const std::string& text) {
  std::fputs((text + "\n").c_str(), stdout);
  std::fflush(stdout);
}

template <class F>
bool wait_for(F&& condition, std::chrono::milliseconds limit) {
  const auto deadline = Clock::now() + limit;
  while (!condition()) {
    if (g_stop || Clock::now() > deadline) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  return true;
}

// A received Pose as printed by `sub` (doubles with all their digits).
inline void pose_line(std::int32_t id, double x, float heading, bool valid, const char* frame, const double* samples,
                      std::size_t count, const std::int16_t* quad) {
  std::string list;
  char number[32];
  for (std::size_t k = 0; k < count; ++k) {
    std::snprintf(number, sizeof number, "%.17g", samples[k]);
    list += (k ? "," : "") + std::string(number);
  }
  char text[1024];
  std::snprintf(text, sizeof text,
                R"({"id":%d,"x":%.17g,"heading":%.9g,"valid":%s,"frame":"%s","samples":[%s],"quad":[%d,%d,%d,%d]})", id,
                x, static_cast<double>(heading), valid ? "true" : "false", frame, list.c_str(), quad[0], quad[1],
                quad[2], quad[3]);
  line(text);
}

// `call` sends a request again when its reply does not come within a share of the timeout:
// a client's reader sees a server's writer a moment before that writer sees the reader, and
// a reply written in between is not for it (volatile topics keep nothing for late readers).
inline constexpr int kCallAttempts = 5;

// A reply as printed by `call`, with the number of requests it took.
inline void reply_line(int sequence, int attempts, std::int32_t status, double sum) {
  char text[256];
  std::snprintf(text, sizeof text, R"({"seq":%d,"attempts":%d,"status":%d,"sum":%.17g})", sequence, attempts, status,
                sum);
  line(text);
}

}  // namespace peer_common
