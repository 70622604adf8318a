// The electric wheelchair of Salov et al. (2013), section 3, as three in-process components
// that all run periodically (10 ms in the shipped profiles):
//
//   HW.joystick --> Joystick.position   Joystick.reference --> Control.reference
//   HW.wheel_speeds --> Control.wheel_speeds   Control.voltages --> HW.voltages
//
// HWComp stands in for the chair's DSP and IO boards: it simulates the motors and the chair
// (steering.hpp) and plays a scripted joystick. HWCanComp is the HW side of a chair whose
// boards are on CAN (real, or wheelchair_sim): it relays their frames, decoded by a CAN proxy,
// and sends the voltages back (profiles/wheelchair_can_native.xml). The math lives in steering.cpp so that the
// tests close the same loop without the engine.
//
// Threading and memory: each component's hooks run on its execution context's thread (or
// the control thread while it is stopped), one at a time. All state is in members, sized at
// construction; onExecute does not allocate. Port payloads are copied by value.
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <string_view>

#include "polyport/runtime/component_api.hpp"
#include "steering.hpp"
#include "wheelchair_types.hpp"

namespace polyport::wheelchair {
namespace {

// A present property must parse: a typo in a profile should stop the component with
// bad_parameter rather than let it run on the default.
bool read_property(const ComponentBase& component, std::string_view name, double& value) {
  if (!component.has_property(name)) return true;
  const double parsed = component.property_double(name, std::numeric_limits<double>::quiet_NaN());
  if (std::isnan(parsed)) return false;
  value = parsed;
  return true;
}

bool read_geometry(const ComponentBase& component, ChairGeometry& geometry) {
  return read_property(component, "wheel_radius", geometry.wheel_radius_m) &&
         read_property(component, "track", geometry.track_m) &&
         read_property(component, "wheelbase", geometry.wheelbase_m);
}

// old_data still carries the latest value; anything else leaves `last` as it was.
template <class T>
void read_latest(InPort<T>& port, T& last) noexcept {
  T value = last;
  const Status status = port.read(value);
  if (status == Status::ok || status == Status::old_data) last = value;
}

// A passive context reports period 0; the chair was designed for 10 ms.
double step_seconds(const ComponentBase& component) noexcept {
  const double period = component.period_seconds();
  return period > 0.0 ? period : kDefaultPeriodS;
}

}  // namespace

// Joystick handling: stick position to reference direction and speed.
class JoystickComp final : public ComponentBase {
 public:
  ReturnCode onInitialize() override {
    max_speed_mps_ = kDefaultMaxSpeedMps;
    if (!read_property(*this, "max_speed", max_speed_mps_)) return ReturnCode::bad_parameter;
    if (!std::isfinite(max_speed_mps_) || max_speed_mps_ <= 0.0) return ReturnCode::bad_parameter;
    return ReturnCode::ok;
  }

  ReturnCode onActivated() override {
    position_ = {};  // a restart must not drive off on a stale stick reading
    return ReturnCode::ok;
  }

  ReturnCode onExecute() override {
    read_latest(position_in_, position_);
    reference_out_.write(joystick_to_reference(position_, max_speed_mps_));
    return ReturnCode::ok;
  }

  // max_speed may change while the chair runs (polyportctl set Joystick max_speed 0.8); on
  // this component's thread, between two cycles.
  ReturnCode onPropertyChanged(std::string_view name, std::string_view) override {
    if (name != "max_speed") return ReturnCode::unsupported;
    double speed = max_speed_mps_;
    if (!read_property(*this, "max_speed", speed) || !std::isfinite(speed) || speed <= 0.0) {
      return ReturnCode::bad_parameter;
    }
    max_speed_mps_ = speed;
    return ReturnCode::ok;
  }

 private:
  InPort<JoystickPosition> position_in_{*this, "position"};
  OutPort<Reference> reference_out_{*this, "reference"};
  double max_speed_mps_ = kDefaultMaxSpeedMps;
  JoystickPosition position_;
};

// Steering control: speed-ratio (electronic differential) references and a PI speed loop
// per wheel, producing the two motor reference voltages.
class ControlComp final : public ComponentBase {
 public:
  ReturnCode onInitialize() override {
    ControllerParams params;
    if (!read_property(*this, "kp", params.kp) || !read_property(*this, "ki", params.ki) ||
        !read_property(*this, "voltage_limit", params.voltage_limit_v) || !read_geometry(*this, params.geometry)) {
      return ReturnCode::bad_parameter;
    }
    if (!validate(params).empty()) return ReturnCode::bad_parameter;
    controller_.set_params(params);
    controller_.reset();
    return ReturnCode::ok;
  }

  ReturnCode onActivated() override {
    controller_.reset();
    reference_ = {};
    speeds_ = {};
    return ReturnCode::ok;
  }

  ReturnCode onExecute() override {
    read_latest(reference_in_, reference_);
    read_latest(speeds_in_, speeds_);
    voltages_out_.write(controller_.step(reference_, speeds_, step_seconds(*this)));
    return ReturnCode::ok;
  }

  ReturnCode onDeactivated() override {
    // Leave the motors unpowered: the HW side keeps applying the last voltages it received.
    voltages_out_.write(MotorVoltages{});
    return ReturnCode::ok;
  }

 private:
  InPort<Reference> reference_in_{*this, "reference"};
  InPort<WheelSpeeds> speeds_in_{*this, "wheel_speeds"};
  OutPort<MotorVoltages> voltages_out_{*this, "voltages"};
  SpeedRatioController controller_;
  Reference reference_;
  WheelSpeeds speeds_;
};

// The DSP and IO boards, simulated: motor voltages in; encoder speeds, heading and the
// scripted joystick out.
class HWComp final : public ComponentBase {
 public:
  ReturnCode onInitialize() override {
    const std::string scenario_text = property("scenario", kDefaultScenario);
    const ScenarioParseResult parsed = parse_scenario(scenario_text);
    if (!parsed.ok()) return ReturnCode::bad_parameter;

    PlantParams params;
    const bool read = read_property(*this, "armature_resistance", params.armature_resistance_ohm) &&
                      read_property(*this, "armature_inductance", params.armature_inductance_h) &&
                      read_property(*this, "motor_constant", params.motor_constant) &&
                      read_property(*this, "drive_inertia", params.drive_inertia_kg_m2) &&
                      read_property(*this, "viscous_friction", params.viscous_friction) &&
                      read_property(*this, "mass", params.mass_kg) &&
                      read_property(*this, "yaw_inertia", params.yaw_inertia_kg_m2) &&
                      read_property(*this, "voltage_limit", params.voltage_limit_v) &&
                      read_geometry(*this, params.geometry);
    if (!read || !validate(params).empty()) return ReturnCode::bad_parameter;

    scenario_ = parsed.scenario;
    plant_ = WheelchairPlant(params);
    return ReturnCode::ok;
  }

  ReturnCode onActivated() override {
    // Every activation replays the scenario from a chair at rest at time 0.
    plant_.reset();
    voltages_ = {};
    return ReturnCode::ok;
  }

  ReturnCode onExecute() override {
    read_latest(voltages_in_, voltages_);
    plant_.step(voltages_, step_seconds(*this));
    const WheelSpeeds speeds = plant_.output();
    speeds_out_.write(speeds);
    joystick_out_.write(scenario_.position_at(speeds.time_s));
    return ReturnCode::ok;
  }

 private:
  OutPort<JoystickPosition> joystick_out_{*this, "joystick"};
  InPort<MotorVoltages> voltages_in_{*this, "voltages"};
  OutPort<WheelSpeeds> speeds_out_{*this, "wheel_speeds"};
  Scenario scenario_;
  WheelchairPlant plant_;
  MotorVoltages voltages_;  // zero until the first reading; then the last one received
};

// The CAN driver side of the real chair: the boards' frames arrive through a CAN proxy (the
// socketcan model decodes them with config/types/wheelchair_can.dbc) and go on to Joystick
// and Control; Control's voltages go back out to the bus. Each period it forwards the newest
// of everything. The motor voltages go out only once Control has sent some, so the boards
// see the controller appear rather than a stream of zeros from start-up.
class HWCanComp final : public ComponentBase {
 public:
  ReturnCode onInitialize() override { return read_geometry(*this, geometry_) ? ReturnCode::ok : ReturnCode::bad_parameter; }

  ReturnCode onActivated() override {
    joystick_ = {};
    encoders_ = {};
    voltages_ = {};
    have_voltages_ = false;
    periods_ = 0;
    return ReturnCode::ok;
  }

  ReturnCode onExecute() override {
    read_latest(joystick_in_, joystick_);
    read_latest(encoders_in_, encoders_);
    MotorVoltages voltages = voltages_;
    const Status status = voltages_in_.read(voltages);
    if (status == Status::ok || status == Status::old_data) {
      voltages_ = voltages;
      have_voltages_ = true;
    }
    ++periods_;
    joystick_out_.write(joystick_);
    WheelSpeeds speeds;
    speeds.left_rad_s = encoders_.left_rad_s;
    speeds.right_rad_s = encoders_.right_rad_s;
    speeds.steering_deg = realised_steering_deg(encoders_.left_rad_s, encoders_.right_rad_s, geometry_);
    speeds.heading_deg = 0.0;  // the encoders do not give it
    speeds.time_s = static_cast<double>(periods_) * step_seconds(*this);
    speeds_out_.write(speeds);
    if (have_voltages_) motors_out_.write(voltages_);
    return ReturnCode::ok;
  }

 private:
  InPort<JoystickPosition> joystick_in_{*this, "joystick_frame"};
  InPort<EncoderSpeeds> encoders_in_{*this, "encoders"};
  InPort<MotorVoltages> voltages_in_{*this, "voltages"};
  OutPort<JoystickPosition> joystick_out_{*this, "joystick"};
  OutPort<WheelSpeeds> speeds_out_{*this, "wheel_speeds"};
  OutPort<MotorVoltages> motors_out_{*this, "motor_voltages"};
  ChairGeometry geometry_;
  JoystickPosition joystick_;
  EncoderSpeeds encoders_;
  MotorVoltages voltages_;
  bool have_voltages_ = false;
  std::int64_t periods_ = 0;
};

}  // namespace polyport::wheelchair

using polyport::wheelchair::ControlComp;
using polyport::wheelchair::HWCanComp;
using polyport::wheelchair::HWComp;
using polyport::wheelchair::JoystickComp;

POLYPORT_COMPONENTS(POLYPORT_COMPONENT(JoystickComp), POLYPORT_COMPONENT(ControlComp), POLYPORT_COMPONENT(HWComp),
                    POLYPORT_COMPONENT(HWCanComp))
