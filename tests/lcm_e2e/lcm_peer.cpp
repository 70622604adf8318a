// An LCM application built with Debian's lcm-gen (C) and liblcm alone, for the end-to-end
// tests: it publishes or subscribes on a channel and prints what it received as JSON lines.
//
//   lcm_peer pub  URL CHANNEL [PERIOD_MS [START]]  poses i = START, START+1, ... until stopped
//   lcm_peer sub  URL CHANNEL                      prints every pose it receives
//   lcm_peer bad  URL CHANNEL [PERIOD_MS]          per round: an other_t, a pose cut short
//                                                  after its fingerprint, then a good pose
//   lcm_peer blob-pub URL CHANNEL BYTES [PERIOD_MS] blob_t messages of BYTES bytes
//   lcm_peer blob-sub URL CHANNEL                  prints id, size and whether every byte is right
//   lcm_peer teleop URL SPEED_MPS                  the wheelchair's LCM teleop (config/types/
//                                                  wheelchair.lcm): publishes a straight reference
//                                                  every 10 ms, prints the wheel speeds it gets
//   lcm_peer serve URL REQUEST REPLY [COUNT [silent]]
//       serves calc's add: add_request_t on channel REQUEST, add_reply_t (sum = a + b) on REPLY;
//       prints each request; exits after COUNT requests (0: until stopped); `silent` never replies
//   lcm_peer call URL REQUEST REPLY COUNT [TIMEOUT_MS [bad]]
//       calls add(i, 0.5), i = 1..COUNT, one at a time; prints each reply (reply_line); exits 1
//       when one does not come within TIMEOUT_MS. `bad`: before each request, an other_t and a
//       request cut short on the request channel
//
// Values are those of tests/dds_peers/pose_values.hpp, so a receiver checks every field.
#include <lcm/lcm.h>
#include <poll.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <thread>
#include <vector>

#include <unistd.h>

#include "peer_add_reply_t.h"
#include "peer_add_request_t.h"
#include "peer_blob_t.h"
#include "peer_common.hpp"
#include "peer_other_t.h"
#include "peer_pose_t.h"
#include "pose_values.hpp"
#include "wheelchair_lcm_reference_t.h"
#include "wheelchair_lcm_wheel_speeds_t.h"

namespace {

using peer_common::g_stop;
using peer_common::line;

std::uint8_t blob_byte(int id, std::size_t k) { return static_cast<std::uint8_t>((id * 7 + k) % 251); }

// Fills `pose` with sample i; `samples` and `frame` keep the storage it points into.
void make_pose(int i, peer_pose_t& pose, std::vector<double>& samples, std::string& frame) {
  pose.id = peer_values::id(i);
  pose.x = peer_values::x(i);
  pose.heading = peer_values::heading(i);
  pose.valid = peer_values::valid(i) ? 1 : 0;
  frame = peer_values::frame(i);
  pose.frame = frame.data();
  samples.resize(peer_values::sample_count(i));
  for (std::size_t k = 0; k < samples.size(); ++k) samples[k] = peer_values::sample(i, static_cast<int>(k));
  pose.nsamples = static_cast<int32_t>(samples.size());
  pose.samples = samples.data();
  for (int k = 0; k < 4; ++k) pose.quad[k] = peer_values::quad(i, k);
}

void on_pose(const lcm_recv_buf_t*, const char*, const peer_pose_t* pose, void*) {
  peer_common::pose_line(pose->id, pose->x, pose->heading, pose->valid != 0, pose->frame, pose->samples,
                         static_cast<std::size_t>(pose->nsamples), pose->quad);
}

void on_blob(const lcm_recv_buf_t*, const char*, const peer_blob_t* blob, void*) {
  bool ok = blob->size >= 0;
  for (std::size_t k = 0; ok && k < static_cast<std::size_t>(blob->size); ++k) ok = blob->data[k] == blob_byte(blob->id, k);
  line(R"({"blob":)" + std::to_string(blob->id) + R"(,"size":)" + std::to_string(blob->size) + R"(,"ok":)" +
       (ok ? "true" : "false") + "}");
}

void on_wheel_speeds(const lcm_recv_buf_t*, const char*, const wheelchair_lcm_wheel_speeds_t* speeds, void*) {
  char text[256];
  std::snprintf(text, sizeof text, R"({"left":%.17g,"right":%.17g,"heading":%.17g,"time":%.17g})", speeds->left_rad_s,
                speeds->right_rad_s, speeds->heading_deg, speeds->time_s);
  line(text);
}

// Handles messages until stopped.
int serve(lcm_t* lcm) {
  const int fd = lcm_get_fileno(lcm);
  if (fd < 0) {
    line(R"({"event":"error","what":"lcm_get_fileno"})");
    return 1;
  }
  line(R"({"event":"subscribed"})");
  while (!g_stop) {
    pollfd p{fd, POLLIN, 0};
    if (poll(&p, 1, 100) > 0) lcm_handle(lcm);
  }
  return 0;
}

void pause_ms(int ms) { std::this_thread::sleep_for(std::chrono::milliseconds(ms)); }

// ---- the calc service -------------------------------------------------------------------

struct Server {
  lcm_t* lcm = nullptr;
  std::string reply_channel;
  bool silent = false;
  int served = 0;
};

void on_add_request(const lcm_recv_buf_t*, const char*, const peer_add_request_t* request, void* user) {
  auto& server = *static_cast<Server*>(user);
  char text[256];
  std::snprintf(text, sizeof text, R"({"request":%lld,"client":%lld,"a":%.17g,"b":%.17g})",
                static_cast<long long>(request->header.sequence), static_cast<long long>(request->header.client_id),
                request->request.a, request->request.b);
  line(text);
  ++server.served;
  if (server.silent) return;
  peer_add_reply_t reply{};
  reply.header.client_id = request->header.client_id;
  reply.header.sequence = request->header.sequence;
  reply.header.status = 0;
  reply.reply.sum = request->request.a + request->request.b;
  peer_add_reply_t_publish(server.lcm, server.reply_channel.c_str(), &reply);
}

int serve_calc(lcm_t* lcm, const char* request_channel, const char* reply_channel, int count, bool silent) {
  Server server{lcm, reply_channel, silent, 0};
  peer_add_request_t_subscription_t* subscription =
      peer_add_request_t_subscribe(lcm, request_channel, on_add_request, &server);
  const int fd = lcm_get_fileno(lcm);
  line(R"({"event":"serving"})");
  while (!g_stop && (count == 0 || server.served < count)) {
    pollfd p{fd, POLLIN, 0};
    if (poll(&p, 1, 100) > 0) lcm_handle(lcm);
  }
  peer_add_request_t_unsubscribe(lcm, subscription);
  return 0;
}

struct Caller {
  std::int64_t client_id = 0;
  std::int64_t sequence = 0;
  bool got = false;
  std::int32_t status = 0;
  double sum = 0;
};

void on_add_reply(const lcm_recv_buf_t*, const char*, const peer_add_reply_t* reply, void* user) {
  auto& caller = *static_cast<Caller*>(user);
  // Replies go to every subscriber of the channel: keep ours.
  if (reply->header.client_id != caller.client_id || reply->header.sequence != caller.sequence) return;
  caller.got = true;
  caller.status = reply->header.status;
  caller.sum = reply->reply.sum;
}

// A request is sent again when its reply does not come within a share of the timeout: the
// first ones may go out before polyport has subscribed to the request channel.
int call_calc(lcm_t* lcm, const std::string& request_channel, const char* reply_channel, int count, int timeout_ms,
              bool bad) {
  Caller caller;
  caller.client_id = (static_cast<std::int64_t>(getpid()) << 20) | 0x5a5a;
  // lcm-gen's subscription is freed by its unsubscribe only, not by lcm_destroy.
  struct Unsubscribe {
    lcm_t* lcm;
    peer_add_reply_t_subscription_t* subscription;
    ~Unsubscribe() { peer_add_reply_t_unsubscribe(lcm, subscription); }
  } unsubscribe{lcm, peer_add_reply_t_subscribe(lcm, reply_channel, on_add_reply, &caller)};
  const int fd = lcm_get_fileno(lcm);
  std::vector<std::uint8_t> wire;
  for (int i = 1; i <= count && !g_stop; ++i) {
    peer_add_request_t request{};
    request.header.client_id = caller.client_id;
    request.header.sequence = i;
    request.request.a = i;
    request.request.b = 0.5;
    caller.sequence = i;
    caller.got = false;
    int attempts = 0;
    while (!caller.got && attempts < peer_common::kCallAttempts && !g_stop) {
      ++attempts;
      if (bad) {
        peer_other_t other{i, 1.5};
        peer_other_t_publish(lcm, request_channel.c_str(), &other);
        wire.resize(static_cast<std::size_t>(peer_add_request_t_encoded_size(&request)));
        peer_add_request_t_encode(wire.data(), 0, static_cast<int>(wire.size()), &request);
        lcm_publish(lcm, request_channel.c_str(), wire.data(), 20);  // the fingerprint and half the header
      }
      peer_add_request_t_publish(lcm, request_channel.c_str(), &request);
      const auto until =
          std::chrono::steady_clock::now() + std::chrono::milliseconds(timeout_ms / peer_common::kCallAttempts);
      while (!caller.got && !g_stop && std::chrono::steady_clock::now() < until) {
        pollfd p{fd, POLLIN, 0};
        if (poll(&p, 1, 5) > 0) lcm_handle(lcm);
      }
    }
    if (!caller.got) {
      line(R"({"event":"no_reply","seq":)" + std::to_string(i) + "}");
      return 1;
    }
    peer_common::reply_line(i, attempts, caller.status, caller.sum);
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  peer_common::stop_on_signals();
  if (argc < 4) {
    std::fprintf(stderr, "usage: lcm_peer pub|sub|bad|blob-pub|blob-sub|teleop|serve|call URL CHANNEL [...]\n");
    return 2;
  }
  const std::string mode = argv[1];
  const char* channel = argv[3];
  lcm_t* lcm = lcm_create(argv[2]);
  if (lcm == nullptr) {
    line(R"({"event":"error","what":"lcm_create"})");
    return 1;
  }
  int rc = 0;
  if (mode == "sub") {
    peer_pose_t_subscription_t* subscription = peer_pose_t_subscribe(lcm, channel, on_pose, nullptr);
    rc = serve(lcm);
    peer_pose_t_unsubscribe(lcm, subscription);
  } else if (mode == "blob-sub") {
    peer_blob_t_subscription_t* subscription = peer_blob_t_subscribe(lcm, channel, on_blob, nullptr);
    rc = serve(lcm);
    peer_blob_t_unsubscribe(lcm, subscription);
  } else if (mode == "pub" || mode == "bad") {
    const int period = argc > 4 ? std::atoi(argv[4]) : 20;
    int i = argc > 5 ? std::atoi(argv[5]) : 0;
    peer_pose_t pose{};
    std::vector<double> samples;
    std::string frame;
    std::vector<std::uint8_t> wire;
    for (; !g_stop; ++i) {
      make_pose(i, pose, samples, frame);
      if (mode == "bad") {
        peer_other_t other{i, 1.5};
        peer_other_t_publish(lcm, channel, &other);
        wire.resize(static_cast<std::size_t>(peer_pose_t_encoded_size(&pose)));
        peer_pose_t_encode(wire.data(), 0, static_cast<int>(wire.size()), &pose);
        lcm_publish(lcm, channel, wire.data(), 12);  // the fingerprint and half the id
      }
      peer_pose_t_publish(lcm, channel, &pose);
      line(R"({"event":"published","id":)" + std::to_string(pose.id) + "}");
      pause_ms(period);
    }
  } else if (mode == "teleop") {
    // argv[3] is the speed here: the channels are the shipped profile's.
    wheelchair_lcm_wheel_speeds_t_subscription_t* subscription =
        wheelchair_lcm_wheel_speeds_t_subscribe(lcm, "WHEELCHAIR_WHEEL_SPEEDS", on_wheel_speeds, nullptr);
    const int fd = lcm_get_fileno(lcm);
    const wheelchair_lcm_reference_t reference{0.0, std::atof(argv[3])};
    while (!g_stop) {
      wheelchair_lcm_reference_t_publish(lcm, "WHEELCHAIR_REFERENCE", &reference);
      pollfd p{fd, POLLIN, 0};
      const auto until = std::chrono::steady_clock::now() + std::chrono::milliseconds(10);
      while (!g_stop && std::chrono::steady_clock::now() < until) {
        if (poll(&p, 1, 2) > 0) lcm_handle(lcm);
      }
    }
    wheelchair_lcm_wheel_speeds_t_unsubscribe(lcm, subscription);
  } else if ((mode == "serve" || mode == "call") && argc < 5) {
    std::fprintf(stderr, "lcm_peer %s: URL REQUEST_CHANNEL REPLY_CHANNEL [...]\n", mode.c_str());
    rc = 2;
  } else if (mode == "serve") {
    const int count = argc > 5 ? std::atoi(argv[5]) : 0;
    rc = serve_calc(lcm, channel, argv[4], count, argc > 6 && std::string(argv[6]) == "silent");
  } else if (mode == "call") {
    const int count = argc > 5 ? std::atoi(argv[5]) : 5;
    const int timeout = argc > 6 ? std::atoi(argv[6]) : 5000;
    rc = call_calc(lcm, channel, argv[4], count, timeout, argc > 7 && std::string(argv[7]) == "bad");
  } else if (mode == "blob-pub") {
    const int bytes = argc > 4 ? std::atoi(argv[4]) : 200000;
    const int period = argc > 5 ? std::atoi(argv[5]) : 50;
    std::vector<std::uint8_t> data(static_cast<std::size_t>(bytes));
    for (int id = 1; !g_stop; ++id) {
      for (std::size_t k = 0; k < data.size(); ++k) data[k] = blob_byte(id, k);
      peer_blob_t blob{id, bytes, data.data()};
      peer_blob_t_publish(lcm, channel, &blob);
      line(R"({"event":"published","blob":)" + std::to_string(id) + "}");
      pause_ms(period);
    }
  } else {
    std::fprintf(stderr, "lcm_peer: unknown mode '%s'\n", mode.c_str());
    rc = 2;
  }
  lcm_destroy(lcm);
  return rc;
}
