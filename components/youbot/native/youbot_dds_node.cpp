// youbot_dds_node: the youBot's driver or monitor (components/youbot) as a Cyclone DDS program
// of its own, for running one side of the youBot case outside polyport: types generated from
// config/types/youbot.idl by idlc, the C API, the simulation and script of youbot_model.hpp;
// no polyport code.
//
//   youbot_dds_node --role driver|monitor [--domain 0] [--period-ms 10] [--new-period-ms 40]
//                   [--duration SEC] [--exit-when-done]
//
// Topics (reliable, volatile, keep_last 10; notifications keep_last 64 so that a burst of
// refreshes does not push a busy or idle out):
//   youbot/driver/setJointPositions/request   youbot::SetJointPositions_Request  (one-way)
//   youbot/driver/setBaseVelocity/request     youbot::SetBaseVelocity_Request    (one-way)
//   youbot/driver/getJointPositions/request   youbot::GetJointPositions_Request
//   youbot/driver/getJointPositions/reply     youbot::GetJointPositions_Reply
//   youbot/state          youbot::State, the driver each cycle
//   youbot/notifications  polyport::ComponentNotification, the driver's busy / idle / refresh
//   youbot/period         youbot::Period, the monitor's new period for the driver
// The service topics follow polyport's "Services over DDS" (docs/PROFILES.md): the request's
// header carries the caller's writer GUID and a sequence number, the reply copies it.
//
// driver   serves the requests, runs the simulation every period (changed by youbot/period
//          from the next cycle on), publishes its state and notifications.
// monitor  waits until polyport's driver side matches every topic, then plays the script each
//          20 ms: one-way commands, queries with their replies matched by GUID and sequence.
//
// Output: JSON lines on stdout: {"event":"running"} once the entities exist; the monitor
// {"event":"matched"}, one {"event":"phase",...} per phase change with the report's fields
// (the MonitorReport of youbot.idl) and {"event":"report",...} at exit; the driver
// {"event":"period","period_s":..} per change and {"event":"exit","cycles":..}.
// Exit status: 0 stopped by a signal, --duration or (--exit-when-done) the script's end;
// 1 setup failed, no match within 30 s, or the script did not end; 2 bad command line.
//
// Threads: one. The loop sleeps to absolute CLOCK_MONOTONIC deadlines and takes every reader
// with dds_take into stack buffers; SIGINT / SIGTERM set an atomic flag checked at each wake.
#include <signal.h>
#include <time.h>

#include <CLI/CLI.hpp>
#include <atomic>
#include <cerrno>
#include <cinttypes>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <string>

#include "component_notification.h"
#include "dds/dds.h"
#include "youbot.h"
#include "youbot_model.hpp"

namespace {

namespace model = polyport::youbot::model;

constexpr int kExitOk = 0;
constexpr int kExitFailed = 1;
constexpr int kExitUsage = 2;
constexpr int kTakeBatch = 16;
constexpr std::int64_t kMonitorPeriodNs = 20'000'000;

std::atomic<bool> g_stop{false};
extern "C" void on_stop_signal(int) { g_stop.store(true, std::memory_order_relaxed); }

std::int64_t now_ns() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

void sleep_until(std::int64_t deadline_ns) {
  const timespec ts{static_cast<time_t>(deadline_ns / 1'000'000'000), static_cast<long>(deadline_ns % 1'000'000'000)};
  while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR && !g_stop.load()) {
  }
}

struct Options {
  std::string role;
  std::uint32_t domain = 0;
  double period_ms = 10.0;
  double new_period_ms = 40.0;
  double duration_s = 0.0;
  bool exit_when_done = false;
};

class Dds {
 public:
  explicit Dds(std::uint32_t domain) {
    participant_ = dds_create_participant(static_cast<dds_domainid_t>(domain), nullptr, nullptr);
    if (participant_ < 0) fail("participant", participant_);
  }
  ~Dds() {
    if (participant_ > 0) dds_delete(participant_);
  }
  Dds(const Dds&) = delete;
  Dds& operator=(const Dds&) = delete;

  bool ok() const { return ok_; }
  dds_entity_t writer(const dds_topic_descriptor_t& type, const char* name, int depth = 10) {
    return make(type, name, depth, true);
  }
  dds_entity_t reader(const dds_topic_descriptor_t& type, const char* name, int depth = 10) {
    return make(type, name, depth, false);
  }

 private:
  dds_entity_t make(const dds_topic_descriptor_t& type, const char* name, int depth, bool write) {
    if (!ok_) return 0;
    const dds_entity_t topic = dds_create_topic(participant_, &type, name, nullptr, nullptr);
    if (topic < 0) return fail(name, topic);
    dds_qos_t* qos = dds_create_qos();
    dds_qset_reliability(qos, DDS_RELIABILITY_RELIABLE, DDS_MSECS(100));
    dds_qset_history(qos, DDS_HISTORY_KEEP_LAST, depth);
    dds_qset_durability(qos, DDS_DURABILITY_VOLATILE);
    const dds_entity_t entity =
        write ? dds_create_writer(participant_, topic, qos, nullptr) : dds_create_reader(participant_, topic, qos, nullptr);
    dds_delete_qos(qos);
    return entity < 0 ? fail(name, entity) : entity;
  }
  dds_entity_t fail(const char* what, dds_return_t code) {
    std::fprintf(stderr, "youbot_dds_node: cannot create %s: %s\n", what, dds_strretcode(code));
    ok_ = false;
    return 0;
  }

  dds_entity_t participant_ = 0;
  bool ok_ = true;
};

bool publication_matched(dds_entity_t writer) {
  dds_publication_matched_status_t s{};
  return dds_get_publication_matched_status(writer, &s) == DDS_RETCODE_OK && s.current_count > 0;
}
bool subscription_matched(dds_entity_t reader) {
  dds_subscription_matched_status_t s{};
  return dds_get_subscription_matched_status(reader, &s) == DDS_RETCODE_OK && s.current_count > 0;
}

// Takes every sample of `reader` (in batches), calling fn(const T&) on each valid one.
template <class T, class F>
void take_all(dds_entity_t reader, F&& fn) {
  for (;;) {
    void* buffers[kTakeBatch] = {};
    dds_sample_info_t info[kTakeBatch];
    const dds_return_t n = dds_take(reader, buffers, info, kTakeBatch, kTakeBatch);
    if (n <= 0) return;
    for (dds_return_t i = 0; i < n; ++i) {
      if (info[i].valid_data) fn(*static_cast<const T*>(buffers[i]));
    }
    dds_return_loan(reader, buffers, n);
    if (n < kTakeBatch) return;
  }
}

void print_doubles(const char* name, const double* values) {
  std::printf(",\"%s\":[%.9g,%.9g,%.9g,%.9g,%.9g]", name, values[0], values[1], values[2], values[3], values[4]);
}

// ---- driver -----------------------------------------------------------------------------

int run_driver(const Options& options) {
  Dds dds(options.domain);
  const dds_entity_t set_joints = dds.reader(youbot_SetJointPositions_Request_desc, "youbot/driver/setJointPositions/request");
  const dds_entity_t set_base = dds.reader(youbot_SetBaseVelocity_Request_desc, "youbot/driver/setBaseVelocity/request");
  const dds_entity_t get_joints = dds.reader(youbot_GetJointPositions_Request_desc, "youbot/driver/getJointPositions/request");
  const dds_entity_t replies = dds.writer(youbot_GetJointPositions_Reply_desc, "youbot/driver/getJointPositions/reply");
  const dds_entity_t period_in = dds.reader(youbot_Period_desc, "youbot/period");
  const dds_entity_t state_out = dds.writer(youbot_State_desc, "youbot/state");
  const dds_entity_t notifications = dds.writer(polyport_ComponentNotification_desc, "youbot/notifications", 64);
  if (!dds.ok()) return kExitFailed;
  std::printf("{\"event\":\"running\",\"role\":\"driver\"}\n");
  std::fflush(stdout);

  model::Arm arm;
  model::Base base;
  std::uint64_t cycle = 0;
  std::uint64_t serial = 0;
  std::int64_t period_ns = std::llround(options.period_ms * 1e6);
  const auto notify = [&](std::int32_t kind) {
    polyport_ComponentNotification n{};
    n.kind = kind;
    n.serial = static_cast<std::int64_t>(++serial);
    n.time_ns = now_ns();
    std::snprintf(n.component, sizeof n.component, "%s", "Driver");
    dds_write(notifications, &n);
  };

  const std::int64_t start = now_ns();
  std::int64_t deadline = start;
  while (!g_stop.load(std::memory_order_relaxed)) {
    if (options.duration_s > 0 && now_ns() - start > std::llround(options.duration_s * 1e9)) break;
    take_all<youbot_Period>(period_in, [&](const youbot_Period& p) {
      if (std::isfinite(p.seconds) && p.seconds >= 1e-6 && p.seconds <= 3600.0) {
        period_ns = std::llround(p.seconds * 1e9);
        std::printf("{\"event\":\"period\",\"period_s\":%.9g}\n", p.seconds);
        std::fflush(stdout);
      }
    });
    take_all<youbot_SetBaseVelocity_Request>(set_base, [&](const youbot_SetBaseVelocity_Request& r) {
      base.vx = r.request.vx_mps;
      base.vy = r.request.vy_mps;
      base.wz = r.request.wz_rad_s;
    });
    take_all<youbot_SetJointPositions_Request>(set_joints, [&](const youbot_SetJointPositions_Request& r) {
      const bool was_moving = arm.moving();
      std::memcpy(arm.target, r.request.rad, sizeof arm.target);
      if (!was_moving) notify(polyport_NOTIFY_BUSY);
      if (!arm.moving()) notify(polyport_NOTIFY_IDLE);
    });
    take_all<youbot_GetJointPositions_Request>(get_joints, [&](const youbot_GetJointPositions_Request& r) {
      youbot_GetJointPositions_Reply reply{};
      reply.header.related_request_id = r.header.request_id;
      reply.header.status = 0;
      reply.reply.query_id = r.request.query_id;
      std::memcpy(reply.reply.rad, arm.position, sizeof reply.reply.rad);
      reply.reply.moving = arm.moving();
      reply.reply.cycle = cycle;
      dds_write(replies, &reply);
    });

    const double dt = static_cast<double>(period_ns) / 1e9;
    const bool was_moving = arm.moving();
    arm.step(dt);
    base.step(dt);
    if (was_moving && !arm.moving()) notify(polyport_NOTIFY_IDLE);
    youbot_State state{};
    state.cycle = ++cycle;
    state.stamp_ns = now_ns();
    state.period_s = dt;
    std::memcpy(state.joints_rad, arm.position, sizeof state.joints_rad);
    std::memcpy(state.targets_rad, arm.target, sizeof state.targets_rad);
    state.base_x_m = base.x;
    state.base_y_m = base.y;
    state.base_yaw_rad = base.yaw;
    state.base_velocity.vx_mps = base.vx;
    state.base_velocity.vy_mps = base.vy;
    state.base_velocity.wz_rad_s = base.wz;
    state.moving = arm.moving();
    dds_write(state_out, &state);
    notify(polyport_NOTIFY_REFRESH);

    deadline += period_ns;
    const std::int64_t now = now_ns();
    if (now > deadline) deadline += ((now - deadline) / period_ns + 1) * period_ns;  // skip missed periods
    sleep_until(deadline);
  }
  std::printf("{\"event\":\"exit\",\"cycles\":%" PRIu64 "}\n", cycle);
  std::fflush(stdout);
  return kExitOk;
}

// ---- monitor ----------------------------------------------------------------------------

void print_report(const char* event, const model::MonitorScript& s) {
  const model::RateMeter& m = s.meter();
  std::printf("{\"event\":\"%s\",\"phase\":%u,\"busy\":%" PRIu64 ",\"idle\":%" PRIu64 ",\"refresh\":%" PRIu64
              ",\"states\":%" PRIu64 ",\"queries\":%u",
              event, s.phase(), s.busy(), s.idle(), s.refresh(), s.states(), s.queries());
  print_doubles("queried_rad", s.queried());
  print_doubles("commanded_rad", s.commanded());
  std::printf(",\"rate_before_hz\":%.6g,\"rate_after_hz\":%.6g,\"period_before_s\":%.9g,\"period_after_s\":%.9g}\n",
              m.rate_before_hz(), m.rate_after_hz(), m.period_before_s(), m.period_after_s());
  std::fflush(stdout);
}

int run_monitor(const Options& options) {
  Dds dds(options.domain);
  const dds_entity_t set_joints = dds.writer(youbot_SetJointPositions_Request_desc, "youbot/driver/setJointPositions/request");
  const dds_entity_t set_base = dds.writer(youbot_SetBaseVelocity_Request_desc, "youbot/driver/setBaseVelocity/request");
  const dds_entity_t get_joints = dds.writer(youbot_GetJointPositions_Request_desc, "youbot/driver/getJointPositions/request");
  const dds_entity_t replies = dds.reader(youbot_GetJointPositions_Reply_desc, "youbot/driver/getJointPositions/reply");
  const dds_entity_t period_out = dds.writer(youbot_Period_desc, "youbot/period");
  const dds_entity_t state_in = dds.reader(youbot_State_desc, "youbot/state");
  const dds_entity_t notifications = dds.reader(polyport_ComponentNotification_desc, "youbot/notifications", 64);
  if (!dds.ok()) return kExitFailed;
  std::printf("{\"event\":\"running\",\"role\":\"monitor\"}\n");
  std::fflush(stdout);

  // Commands sent before the driver's side reads them would be lost (volatile topics).
  const std::int64_t match_deadline = now_ns() + 30'000'000'000;
  while (!(publication_matched(set_joints) && publication_matched(set_base) && publication_matched(get_joints) &&
           publication_matched(period_out) && subscription_matched(replies) && subscription_matched(state_in) &&
           subscription_matched(notifications))) {
    if (g_stop.load() || now_ns() > match_deadline) {
      std::printf("{\"event\":\"no_match\"}\n");
      return kExitFailed;
    }
    sleep_until(now_ns() + 10'000'000);
  }
  std::printf("{\"event\":\"matched\"}\n");
  std::fflush(stdout);

  dds_guid_t guid{};
  dds_get_guid(get_joints, &guid);
  model::MonitorScript script(options.new_period_ms / 1000.0);
  std::uint64_t query_sequence = 0;
  bool query_outstanding = false;
  std::int64_t query_sent = 0;
  const std::int64_t start = now_ns();
  std::int64_t deadline = start;
  while (!g_stop.load(std::memory_order_relaxed)) {
    if (options.duration_s > 0 && now_ns() - start > std::llround(options.duration_s * 1e9)) break;
    take_all<youbot_State>(state_in, [&](const youbot_State& s) { script.on_state(s.cycle, s.stamp_ns, s.period_s); });
    take_all<polyport_ComponentNotification>(notifications, [&](const polyport_ComponentNotification& n) {
      script.on_notification(static_cast<std::int32_t>(n.kind));
    });
    take_all<youbot_GetJointPositions_Reply>(replies, [&](const youbot_GetJointPositions_Reply& r) {
      // Replies reach every client: keep the answer to our outstanding request only.
      if (!query_outstanding || std::memcmp(r.header.related_request_id.writer_guid, guid.v, 16) != 0 ||
          r.header.related_request_id.sequence_number != query_sequence) {
        return;
      }
      query_outstanding = false;
      if (r.header.status == 0) script.on_reply(r.reply.rad, r.reply.moving);
    });
    // A query without an answer for a second is given up and asked again.
    if (query_outstanding && now_ns() - query_sent > 1'000'000'000) query_outstanding = false;

    const model::MonitorScript::Actions a = script.step();
    if (a.set_base) {
      youbot_SetBaseVelocity_Request r{};
      r.request = {a.base[0], a.base[1], a.base[2]};
      dds_write(set_base, &r);
    }
    if (a.set_period) {
      const youbot_Period p{a.period_s};
      dds_write(period_out, &p);
    }
    if (a.set_joints) {
      youbot_SetJointPositions_Request r{};
      std::memcpy(r.request.rad, a.joints, sizeof r.request.rad);
      dds_write(set_joints, &r);
    }
    if (a.query && !query_outstanding) {
      youbot_GetJointPositions_Request r{};
      std::memcpy(r.header.request_id.writer_guid, guid.v, 16);
      r.header.request_id.sequence_number = ++query_sequence;
      r.request.query_id = static_cast<std::uint32_t>(query_sequence);
      query_outstanding = dds_write(get_joints, &r) == DDS_RETCODE_OK;
      query_sent = now_ns();
    }
    if (a.phase_changed) print_report("phase", script);
    if (script.phase() >= 2 && options.exit_when_done) break;

    deadline += kMonitorPeriodNs;
    const std::int64_t now = now_ns();
    if (now > deadline) deadline += ((now - deadline) / kMonitorPeriodNs + 1) * kMonitorPeriodNs;
    sleep_until(deadline);
  }
  print_report("report", script);
  return options.exit_when_done && script.phase() < 2 ? kExitFailed : kExitOk;
}

}  // namespace

int main(int argc, char** argv) {
  Options options;
  CLI::App app{"The youBot's driver or monitor as a Cyclone DDS program (polyport's youBot case)"};
  app.add_option("--role", options.role, "driver or monitor")->required()->check(CLI::IsMember({"driver", "monitor"}));
  app.add_option("--domain", options.domain, "DDS domain")->check(CLI::Range(0, 232));
  app.add_option("--period-ms", options.period_ms, "driver: the initial period")->check(CLI::Range(0.001, 10000.0));
  app.add_option("--new-period-ms", options.new_period_ms, "monitor: the period it asks the driver for")
      ->check(CLI::Range(0.001, 10000.0));
  app.add_option("--duration", options.duration_s, "stop after this many seconds (0: at a signal)");
  app.add_flag("--exit-when-done", options.exit_when_done, "monitor: exit once the script has ended");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? kExitOk : kExitUsage;
  }
  struct sigaction action {};
  action.sa_handler = on_stop_signal;
  sigemptyset(&action.sa_mask);
  sigaction(SIGINT, &action, nullptr);
  sigaction(SIGTERM, &action, nullptr);
  return options.role == "driver" ? run_driver(options) : run_monitor(options);
}
