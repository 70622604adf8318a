// A Cyclone DDS application for the end-to-end tests, written the usual way: types generated
// by idlc from peer.idl, the C API, the SDK's default QoS except reliable keep-last 10 (ROS
// 2's default). It knows nothing of polyport. One line of JSON per event on stdout.
//
//   cyclone_peer pub   DOMAIN TOPIC COUNT PERIOD_MS [START]   publish Poses START..START+COUNT-1 (0: no end)
//   cyclone_peer sub   DOMAIN TOPIC COUNT TIMEOUT_S           print each Pose; exit 0 after COUNT
//   cyclone_peer call  DOMAIN BASE COUNT TIMEOUT_MS           call BASE add(i, 0.5) COUNT times
//   cyclone_peer serve DOMAIN BASE COUNT [silent]             answer COUNT add requests
// Built with POLYPORT_BAD_POSE (cyclone_bad_peer), `pub` publishes bad_pose.idl's peer::Pose.
// Exit status: 0 done, 1 timed out or failed, 2 bad arguments.
#include <atomic>
#include <chrono>
#include <csignal>
#include <cinttypes>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <thread>

#include "dds/dds.h"
#include "peer_common.hpp"
#ifdef POLYPORT_BAD_POSE
#include "bad_pose.h"
#else
#include "peer.h"
#include "pose_values.hpp"
#endif

namespace {

using namespace peer_common;

dds_qos_t* default_qos() {
  dds_qos_t* qos = dds_create_qos();
  dds_qset_reliability(qos, DDS_RELIABILITY_RELIABLE, DDS_SECS(1));
  dds_qset_history(qos, DDS_HISTORY_KEEP_LAST, 10);
  return qos;
}

int publication_matches(dds_entity_t writer) {
  dds_publication_matched_status_t s{};
  return dds_get_publication_matched_status(writer, &s) == DDS_RETCODE_OK ? static_cast<int>(s.current_count) : 0;
}
int subscription_matches(dds_entity_t reader) {
  dds_subscription_matched_status_t s{};
  return dds_get_subscription_matched_status(reader, &s) == DDS_RETCODE_OK ? static_cast<int>(s.current_count) : 0;
}

int publish(dds_entity_t participant, const char* topic_name, int count, int period_ms, int start) {
#ifdef POLYPORT_BAD_POSE
  const dds_entity_t topic = dds_create_topic(participant, &peer_Pose_desc, topic_name, nullptr, nullptr);
#else
  const dds_entity_t topic = dds_create_topic(participant, &peer_Pose_desc, topic_name, nullptr, nullptr);
#endif
  dds_qos_t* qos = default_qos();
  const dds_entity_t writer = dds_create_writer(participant, topic, qos, nullptr);
  dds_delete_qos(qos);
  if (writer < 0) return 1;
  if (!wait_for([&] { return publication_matches(writer) > 0; }, std::chrono::seconds(30))) {
    line(R"({"event":"no_match"})");
    return 1;
  }
  line(R"({"event":"matched"})");
  for (int i = start; !g_stop && (count == 0 || i < start + count); ++i) {  // COUNT 0: until stopped
    peer_Pose pose{};
#ifdef POLYPORT_BAD_POSE
    pose.junk = static_cast<std::uint8_t>(i);
#else
    const std::string frame = peer_values::frame(i);
    pose.id = peer_values::id(i);
    pose.x = peer_values::x(i);
    pose.heading = peer_values::heading(i);
    pose.valid = peer_values::valid(i);
    std::snprintf(pose.frame, sizeof pose.frame, "%s", frame.c_str());
    double samples[8];
    for (std::uint32_t k = 0; k < peer_values::sample_count(i); ++k) samples[k] = peer_values::sample(i, static_cast<int>(k));
    pose.samples._buffer = samples;
    pose.samples._length = pose.samples._maximum = peer_values::sample_count(i);
    pose.samples._release = false;
    for (int k = 0; k < 4; ++k) pose.quad[k] = peer_values::quad(i, k);
#endif
    if (dds_write(writer, &pose) != DDS_RETCODE_OK) return 1;
    if (period_ms > 0) std::this_thread::sleep_for(std::chrono::milliseconds(period_ms));
  }
  dds_wait_for_acks(writer, DDS_SECS(5));
  line(R"({"event":"done"})");
  return 0;
}

#ifndef POLYPORT_BAD_POSE
int subscribe(dds_entity_t participant, const char* topic_name, int count, int timeout_s) {
  const dds_entity_t topic = dds_create_topic(participant, &peer_Pose_desc, topic_name, nullptr, nullptr);
  dds_qos_t* qos = default_qos();
  const dds_entity_t reader = dds_create_reader(participant, topic, qos, nullptr);
  dds_delete_qos(qos);
  if (reader < 0) return 1;
  line(R"({"event":"ready"})");
  const auto deadline = Clock::now() + std::chrono::seconds(timeout_s);
  int received = 0;
  bool announced = false;
  while (!g_stop && received < count && Clock::now() < deadline) {
    if (!announced && subscription_matches(reader) > 0) {
      line(R"({"event":"matched"})");
      announced = true;
    }
    void* buffers[1] = {nullptr};
    dds_sample_info_t info[1];
    const dds_return_t n = dds_take(reader, buffers, info, 1, 1);
    if (n <= 0) {
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
      continue;
    }
    if (info[0].valid_data) {
      const auto* p = static_cast<const peer_Pose*>(buffers[0]);
      pose_line(p->id, p->x, p->heading, p->valid, p->frame, p->samples._buffer, p->samples._length, p->quad);
      ++received;
    }
    dds_return_loan(reader, buffers, n);
  }
  return received == count ? 0 : 1;
}

std::string topic_of(const char* base, const char* suffix) { return std::string(base) + "/add/" + suffix; }

int call(dds_entity_t participant, const char* base, int count, int timeout_ms) {
  const dds_entity_t request_topic = dds_create_topic(participant, &peer_Add_Request_desc,
                                                      topic_of(base, "request").c_str(), nullptr, nullptr);
  const dds_entity_t reply_topic =
      dds_create_topic(participant, &peer_Add_Reply_desc, topic_of(base, "reply").c_str(), nullptr, nullptr);
  dds_qos_t* qos = default_qos();
  const dds_entity_t writer = dds_create_writer(participant, request_topic, qos, nullptr);
  const dds_entity_t reader = dds_create_reader(participant, reply_topic, qos, nullptr);
  dds_delete_qos(qos);
  if (writer < 0 || reader < 0) return 1;
  if (!wait_for([&] { return publication_matches(writer) > 0 && subscription_matches(reader) > 0; },
                std::chrono::seconds(30))) {
    line(R"({"event":"no_match"})");
    return 1;
  }
  line(R"({"event":"matched"})");
  dds_guid_t guid;
  dds_get_guid(writer, &guid);
  int answered = 0;
  for (int i = 1; i <= count; ++i) {
    peer_Add_Request request{};
    std::memcpy(request.header.request_id.writer_guid, guid.v, 16);
    request.header.request_id.sequence_number = static_cast<std::uint64_t>(i);
    request.request.a = i;
    request.request.b = 0.5;
    bool got = false;
    int attempts = 0;
    while (!got && attempts < kCallAttempts) {
      ++attempts;
      if (dds_write(writer, &request) != DDS_RETCODE_OK) return 1;
      const auto deadline = Clock::now() + std::chrono::milliseconds(timeout_ms / kCallAttempts);
      while (!got && Clock::now() < deadline) {
        void* buffers[1] = {nullptr};
        dds_sample_info_t info[1];
        const dds_return_t n = dds_take(reader, buffers, info, 1, 1);
        if (n <= 0) {
          std::this_thread::sleep_for(std::chrono::milliseconds(1));
          continue;
        }
        const auto* reply = static_cast<const peer_Add_Reply*>(buffers[0]);
        // Replies reach every client: keep ours.
        if (info[0].valid_data && std::memcmp(reply->header.related_request_id.writer_guid, guid.v, 16) == 0 &&
            reply->header.related_request_id.sequence_number == static_cast<std::uint64_t>(i)) {
          reply_line(i, attempts, reply->header.status, reply->reply.sum);
          got = true;
          ++answered;
        }
        dds_return_loan(reader, buffers, n);
      }
    }
    if (!got) line(R"({"seq":)" + std::to_string(i) + R"(,"attempts":)" + std::to_string(attempts) + R"(,"timeout":true})");
  }
  return answered == count ? 0 : 1;
}

int serve(dds_entity_t participant, const char* base, int count, bool silent) {
  const dds_entity_t request_topic = dds_create_topic(participant, &peer_Add_Request_desc,
                                                      topic_of(base, "request").c_str(), nullptr, nullptr);
  const dds_entity_t reply_topic =
      dds_create_topic(participant, &peer_Add_Reply_desc, topic_of(base, "reply").c_str(), nullptr, nullptr);
  dds_qos_t* qos = default_qos();
  const dds_entity_t reader = dds_create_reader(participant, request_topic, qos, nullptr);
  const dds_entity_t writer = dds_create_writer(participant, reply_topic, qos, nullptr);
  dds_delete_qos(qos);
  if (writer < 0 || reader < 0) return 1;
  line(R"({"event":"ready"})");
  if (!wait_for([&] { return publication_matches(writer) > 0 && subscription_matches(reader) > 0; },
                std::chrono::seconds(30))) {
    line(R"({"event":"no_match"})");
    return 1;
  }
  line(R"({"event":"matched"})");
  int served = 0;
  const auto deadline = Clock::now() + std::chrono::seconds(60);
  while (!g_stop && served < count && Clock::now() < deadline) {
    void* buffers[1] = {nullptr};
    dds_sample_info_t info[1];
    const dds_return_t n = dds_take(reader, buffers, info, 1, 1);
    if (n <= 0) {
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
      continue;
    }
    if (info[0].valid_data) {
      const auto* request = static_cast<const peer_Add_Request*>(buffers[0]);
      ++served;
      line(R"({"request":)" + std::to_string(request->header.request_id.sequence_number) + "}");
      if (!silent) {
        peer_Add_Reply reply{};
        reply.header.related_request_id = request->header.request_id;
        reply.header.status = 0;
        reply.reply.sum = request->request.a + request->request.b;
        dds_write(writer, &reply);
      }
    }
    dds_return_loan(reader, buffers, n);
  }
  dds_wait_for_acks(writer, DDS_SECS(5));
  return served == count ? 0 : 1;
}
#endif

}  // namespace

int main(int argc, char** argv) {
  if (argc < 5) {
    std::fprintf(stderr, "usage: %s pub|sub|call|serve DOMAIN TOPIC COUNT [ARG] [ARG]\n", argv[0]);
    return 2;
  }
  stop_on_signals();
  const std::string mode = argv[1];
  const auto domain = static_cast<dds_domainid_t>(std::atoi(argv[2]));
  const char* topic = argv[3];
  const int count = std::atoi(argv[4]);
  const int arg = argc > 5 ? std::atoi(argv[5]) : 0;
  const dds_entity_t participant = dds_create_participant(domain, nullptr, nullptr);
  if (participant < 0) {
    std::fprintf(stderr, "cannot create a participant: %s\n", dds_strretcode(participant));
    return 1;
  }
  int rc = 2;
  if (mode == "pub") rc = publish(participant, topic, count, arg, argc > 6 ? std::atoi(argv[6]) : 0);
#ifndef POLYPORT_BAD_POSE
  if (mode == "sub") rc = subscribe(participant, topic, count, arg > 0 ? arg : 30);
  if (mode == "call") rc = call(participant, topic, count, arg > 0 ? arg : 2000);
  if (mode == "serve") rc = serve(participant, topic, count, argc > 5 && std::string(argv[5]) == "silent");
#endif
  dds_delete(participant);
  return rc;
}
