// The youBot case of the JOrocos paper (Brugali et al., seed 000, section 5) as two in-process
// components (profiles/youbot.xml):
//
//   Monitor.driver ==service==> Driver.commands   (setJointPositions, setBaseVelocity: one-way;
//                                                  getJointPositions: a query)
//   Driver.state --> Monitor.state      Driver.notifications --event--> Monitor.notifications
//   Monitor.period --> Driver.period    (a new period for the driver's execution context)
//
// YoubotDriver simulates the robot (youbot_model.hpp): five arm joints moving toward their
// set positions at a maximum joint speed, a base integrating its velocity. It raises busy when
// a setJointPositions starts a motion, idle when every joint has arrived, and refresh after
// each new state; a Period on its `period` port changes its period from the next cycle on.
// YoubotMonitor plays the script of youbot_model.hpp's MonitorScript and writes what it saw on
// its `report` port (and a line on stderr at each phase).
//
// Threading and memory: each component's hooks and (own-thread dispatch) the driver's service
// handlers run on its execution context's thread, one at a time, so the members need no lock.
// Nothing allocates after onInitialize.
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <limits>
#include <type_traits>

#include "polyport/runtime/component_api.hpp"
#include "youbot_model.hpp"
#include "youbot_types.hpp"

namespace polyport::youbot {
namespace {

constexpr std::size_t kJoints = model::kJoints;
static_assert(kJoints == kArmJoints);

bool read_positive(const ComponentBase& component, std::string_view name, double& value) {
  if (!component.has_property(name)) return true;
  const double parsed = component.property_double(name, std::numeric_limits<double>::quiet_NaN());
  if (!std::isfinite(parsed) || parsed <= 0.0) return false;
  value = parsed;
  return true;
}

}  // namespace

class YoubotDriver final : public ComponentBase {
 public:
  YoubotDriver() {
    commands_.provide_oneway<JointPositions>("setJointPositions", [this](const JointPositions& p) { set_joints(p); });
    commands_.provide_oneway<BaseVelocity>("setBaseVelocity", [this](const BaseVelocity& v) {
      base_.vx = v.vx_mps;
      base_.vy = v.vy_mps;
      base_.wz = v.wz_rad_s;
    });
    commands_.provide<JointQuery, JointReply>("getJointPositions", [this](const JointQuery& q, JointReply& r) {
      r.query_id = q.query_id;
      std::memcpy(r.rad, arm_.position, sizeof r.rad);
      r.moving = arm_.moving();
      r.cycle = cycle_;
      return ReturnCode::ok;
    });
  }

  ReturnCode onInitialize() override {
    arm_ = {};
    base_ = {};
    arm_.max_speed = model::kDefaultMaxJointSpeed;
    if (!read_positive(*this, "max_joint_speed", arm_.max_speed)) return ReturnCode::bad_parameter;
    return ReturnCode::ok;
  }

  ReturnCode onExecute() override {
    Period period{};
    if (period_in_.read(period) == Status::ok) {
      // Refused values (not positive, under 1 us) leave the period as it is.
      if (request_period(period.seconds) != ReturnCode::ok) ++refused_periods_;
    }
    const double dt = period_seconds();
    const bool was_moving = arm_.moving();
    arm_.step(dt);
    base_.step(dt);
    const bool moving = arm_.moving();
    if (was_moving && !moving) notify_idle();

    State state{};
    state.cycle = ++cycle_;
    state.stamp_ns = mono_now().ns;
    state.period_s = dt;
    std::memcpy(state.joints_rad, arm_.position, sizeof state.joints_rad);
    std::memcpy(state.targets_rad, arm_.target, sizeof state.targets_rad);
    state.base_x_m = base_.x;
    state.base_y_m = base_.y;
    state.base_yaw_rad = base_.yaw;
    state.base_velocity = BaseVelocity{base_.vx, base_.vy, base_.wz};
    state.moving = moving;
    state_out_.write(state);
    notify_refresh();
    return ReturnCode::ok;
  }

 private:
  void set_joints(const JointPositions& p) {
    const bool was_moving = arm_.moving();
    std::memcpy(arm_.target, p.rad, sizeof arm_.target);
    // busy: an operation started; one that needs no motion is over at once.
    if (!was_moving) notify_busy();
    if (!arm_.moving()) notify_idle();
  }

  ProvidedService commands_{*this, "commands"};
  OutPort<State> state_out_{*this, "state"};
  InPort<Period> period_in_{*this, "period"};
  model::Arm arm_;
  model::Base base_;
  std::uint64_t cycle_ = 0;
  std::uint64_t refused_periods_ = 0;
};

// NotificationIn: the port kind notifications arrive on: an event port from an in-process
// driver (or an LCM channel), a data port from a topic of a model without event ports (a
// DDS driver program): YoubotMonitor and YoubotTopicMonitor.
template <bool kFromTopic>
class MonitorComponent final : public ComponentBase {
 public:
  ReturnCode onInitialize() override {
    double new_period_ms = 40.0;
    if (!read_positive(*this, "new_period_ms", new_period_ms)) return ReturnCode::bad_parameter;
    script_ = model::MonitorScript(new_period_ms / 1000.0);
    query_ = {};
    return ReturnCode::ok;
  }

  ReturnCode onExecute() override {
    State state{};
    if (state_in_.read(state) == Status::ok) script_.on_state(state.cycle, state.stamp_ns, state.period_s);
    ComponentNotification n{};
    while (take_notification(n) == Status::ok) script_.on_notification(n.kind);
    if (query_) {
      JointReply reply{};
      const Status status = driver_.receive(query_, reply, Nanos{0});
      if (status == Status::ok) {
        script_.on_reply(reply.rad, reply.moving);
        query_ = {};
      } else if (status != Status::timeout) {
        query_ = {};  // failed: asked again next cycle
      }
    }

    const model::MonitorScript::Actions a = script_.step();
    if (a.set_base) driver_.send("setBaseVelocity", BaseVelocity{a.base[0], a.base[1], a.base[2]});
    if (a.set_period) period_out_.write(Period{a.period_s});
    if (a.set_joints) {
      JointPositions p{};
      std::memcpy(p.rad, a.joints, sizeof p.rad);
      driver_.send("setJointPositions", p);
    }
    if (a.query && !query_) query_ = driver_.request("getJointPositions", JointQuery{++query_sequence_});
    if (a.phase_changed) log_phase();
    write_report();
    return ReturnCode::ok;
  }

  ReturnCode onDeactivated() override {
    if (query_) driver_.port().cancel(query_);
    query_ = {};
    return ReturnCode::ok;
  }

 private:
  Status take_notification(ComponentNotification& n) noexcept {
    if constexpr (kFromTopic) {
      // A buffer or circular data port: each read takes the next one; old_data means none.
      const Status status = notifications_.read(n);
      return status == Status::ok ? Status::ok : Status::no_data;
    } else {
      return notifications_.take(n);
    }
  }

  void write_report() noexcept {
    MonitorReport r{};
    r.phase = script_.phase();
    r.busy = script_.busy();
    r.idle = script_.idle();
    r.refresh = script_.refresh();
    r.states = script_.states();
    r.queries = script_.queries();
    std::memcpy(r.queried_rad, script_.queried(), sizeof r.queried_rad);
    std::memcpy(r.commanded_rad, script_.commanded(), sizeof r.commanded_rad);
    r.rate_before_hz = script_.meter().rate_before_hz();
    r.rate_after_hz = script_.meter().rate_after_hz();
    r.period_before_s = script_.meter().period_before_s();
    r.period_after_s = script_.meter().period_after_s();
    report_out_.write(r);
  }

  // Three lines in a run, at the phase changes: not on any data path.
  void log_phase() const {
    const double* q = script_.queried();
    const model::RateMeter& m = script_.meter();
    static constexpr const char* kPhases[] = {"commanding pose A", "pose A reached; new period, commanding pose B",
                                              "pose B reached; base stopped, done"};
    std::fprintf(stderr,
                 "youbot monitor %s: %s | notifications busy %llu idle %llu refresh %llu | queried "
                 "[%.3f %.3f %.3f %.3f %.3f] | driver %.1f Hz at %.0f ms",
                 instance_name().c_str(), kPhases[script_.phase()], static_cast<unsigned long long>(script_.busy()),
                 static_cast<unsigned long long>(script_.idle()), static_cast<unsigned long long>(script_.refresh()),
                 q[0], q[1], q[2], q[3], q[4], m.rate_before_hz(), m.period_before_s() * 1e3);
    if (m.changed()) std::fprintf(stderr, ", then %.1f Hz at %.0f ms", m.rate_after_hz(), m.period_after_s() * 1e3);
    std::fprintf(stderr, "\n");
  }

  using NotificationPort = std::conditional_t<kFromTopic, InPort<ComponentNotification>, EventInPort<ComponentNotification>>;

  RequiredService driver_{*this, "driver"};
  InPort<State> state_in_{*this, "state"};
  NotificationPort notifications_{*this, "notifications"};
  OutPort<Period> period_out_{*this, "period"};
  OutPort<MonitorReport> report_out_{*this, "report"};
  model::MonitorScript script_{0.04};
  CallHandle query_{};
  std::uint32_t query_sequence_ = 0;
};

using YoubotMonitor = MonitorComponent<false>;
using YoubotTopicMonitor = MonitorComponent<true>;

}  // namespace polyport::youbot

using polyport::youbot::YoubotDriver;
using polyport::youbot::YoubotMonitor;
using polyport::youbot::YoubotTopicMonitor;

POLYPORT_COMPONENTS(POLYPORT_COMPONENT(YoubotDriver), POLYPORT_COMPONENT(YoubotMonitor),
                    POLYPORT_COMPONENT(YoubotTopicMonitor))
