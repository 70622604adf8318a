// wheelchair_fastdds_hw: the wheelchair's HW component (the CAN driver side, Salov et al.
// 2013, section 3) as a Fast DDS program of its own, for the suite's configurations where HW
// is in a different middleware from the others: no polyport, types generated from
// config/types/wheelchair.idl by Debian's fastddsgen, the DDS API as an application writes it.
// It does what wheelchair_dds_node --role hw does with Cyclone DDS (node_common.hpp has the
// CAN side both use):
//
//   wheelchair_fastdds_hw [--period-ms 10] [--if vcan0] [--summary FILE] [--domain 0]
//
// Each period it drains the raw CAN socket on --if (kernel filters for 0x101 joystick and
// 0x181 encoders), publishes wheelchair/joystick and wheelchair/wheel_speeds, takes the newest
// wheelchair/voltages and, once one has come, sends 0x201 with the latest every period.
// Readers and writers: reliable, keep_last 1, volatile (what polyport's DDS ports use by
// default). Transports: Fast DDS's default participant profile (FASTRTPS_DEFAULT_PROFILES_FILE;
// the suite points it at config/fastdds-loopback.xml).
// On stderr: "wheelchair_fastdds_hw hw: running" once the entities exist. At exit
// (SIGINT/SIGTERM), --summary FILE gets the JSON object of wheelchair_dds_node's hw role:
// role, period_ms, periods, overruns, lateness_ns, cpu_s, frames_rx, frames_tx, bad_frames,
// rx_errors, tx_errors.
// Exit status: 0 stopped by a signal; 1 setup failed or the summary could not be written;
// 2 bad command line.
//
// Threads: the main thread runs the periodic loop and owns every entity and the socket; Fast
// DDS's own threads receive into the reader's history, which the loop takes from.
#include <cstdint>
#include <cstdio>
#include <optional>
#include <string>

#include <fastdds/dds/domain/DomainParticipant.hpp>
#include <fastdds/dds/domain/DomainParticipantFactory.hpp>
#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/publisher/Publisher.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>
#include <fastdds/dds/topic/TypeSupport.hpp>

#include "node_common.hpp"
#include "wheelchair.h"
#include "wheelchairPubSubTypes.h"

namespace {

using namespace eprosima::fastdds::dds;
using namespace polyport::wheelchair::node;

struct Options : NodeOptions {
  Options() {
    program = "wheelchair_fastdds_hw";
    role = "hw";
  }
};

// What polyport's DDS ports use by default for the wheelchair's topics: reliable, keep_last 1,
// volatile; for a writer's QoS and a reader's alike.
template <class Qos>
Qos node_qos(Qos qos) {
  qos.reliability().kind = RELIABLE_RELIABILITY_QOS;
  qos.history().kind = KEEP_LAST_HISTORY_QOS;
  qos.history().depth = 1;
  qos.durability().kind = VOLATILE_DURABILITY_QOS;
  return qos;
}

// The participant and what the HW role creates on it; a failure is printed once with the name
// of what could not be created and turns `ok` false.
class Dds {
 public:
  explicit Dds(int domain) {
    participant_ = DomainParticipantFactory::get_instance()->create_participant(domain, PARTICIPANT_QOS_DEFAULT);
    if (check(participant_, "participant") != nullptr) {
      publisher_ = check(participant_->create_publisher(PUBLISHER_QOS_DEFAULT), "publisher");
      subscriber_ = check(participant_->create_subscriber(SUBSCRIBER_QOS_DEFAULT), "subscriber");
    }
  }
  ~Dds() {
    if (participant_ == nullptr) return;
    participant_->delete_contained_entities();
    DomainParticipantFactory::get_instance()->delete_participant(participant_);
  }
  Dds(const Dds&) = delete;
  Dds& operator=(const Dds&) = delete;

  DataWriter* writer(TopicDataType* type, const char* name) {
    Topic* t = topic(type, name);
    if (t == nullptr) return nullptr;
    return check(publisher_->create_datawriter(t, node_qos(DATAWRITER_QOS_DEFAULT)), "writer", name);
  }
  DataReader* reader(TopicDataType* type, const char* name) {
    Topic* t = topic(type, name);
    if (t == nullptr) return nullptr;
    return check(subscriber_->create_datareader(t, node_qos(DATAREADER_QOS_DEFAULT)), "reader", name);
  }
  bool ok() const { return ok_; }

 private:
  // `type` is owned by the TypeSupport from here on.
  Topic* topic(TopicDataType* type, const char* name) {
    if (!ok_) {
      delete type;
      return nullptr;
    }
    TypeSupport support(type);
    support.register_type(participant_);
    return check(participant_->create_topic(name, support.get_type_name(), TOPIC_QOS_DEFAULT), "topic", name);
  }
  template <class T>
  T* check(T* entity, const char* what, const char* topic = nullptr) {
    if (entity == nullptr && ok_) {
      std::fprintf(stderr, "wheelchair_fastdds_hw: cannot create the DDS %s%s%s\n", what, topic ? " " : "",
                   topic ? topic : "");
      ok_ = false;
    }
    return entity;
  }

  DomainParticipant* participant_ = nullptr;
  Publisher* publisher_ = nullptr;
  Subscriber* subscriber_ = nullptr;
  bool ok_ = true;
};

// Takes every sample the reader holds; `last` becomes the newest valid one. Returns whether
// there was one.
bool take_newest(DataReader* reader, wheelchair::MotorVoltages& last) {
  bool got = false;
  wheelchair::MotorVoltages sample;
  SampleInfo info;
  while (reader->take_next_sample(&sample, &info) == ReturnCode_t::RETCODE_OK) {
    if (info.valid_data) {
      last = sample;
      got = true;
    }
  }
  return got;
}

int run_hw(const Options& options) {
  HwBus bus(options);
  if (!bus.ok()) return kExitFailed;
  Dds dds(options.domain);
  DataWriter* joystick_out = dds.writer(new wheelchair::JoystickPositionPubSubType(), "wheelchair/joystick");
  DataWriter* speeds_out = dds.writer(new wheelchair::WheelSpeedsPubSubType(), "wheelchair/wheel_speeds");
  DataReader* voltages_in = dds.reader(new wheelchair::MotorVoltagesPubSubType(), "wheelchair/voltages");
  if (!dds.ok()) return kExitFailed;
  announce(options);

  LoopStats stats;
  wheelchair::JoystickPosition joystick;
  wheelchair::WheelSpeeds speeds;
  wheelchair::MotorVoltages voltages;
  bool have_voltages = false;
  run_periodic(options, stats, [&] {
    bus.drain();
    joystick.x(bus.stick().x);
    joystick.y(bus.stick().y);
    joystick_out->write(&joystick);
    const polyport::wheelchair::WheelSpeeds s = bus.wheel_speeds();
    speeds.left_rad_s(s.left_rad_s);
    speeds.right_rad_s(s.right_rad_s);
    speeds.heading_deg(s.heading_deg);
    speeds.steering_deg(s.steering_deg);
    speeds.time_s(s.time_s);
    speeds_out->write(&speeds);
    if (take_newest(voltages_in, voltages)) have_voltages = true;
    if (have_voltages) bus.send(polyport::wheelchair::MotorVoltages{voltages.left_v(), voltages.right_v()});
  });
  return write_summary(options, stats, bus.summary_fields()) ? kExitOk : kExitFailed;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"wheelchair_fastdds_hw: the wheelchair's hw component (CAN driver side) as a Fast DDS program "
               "(transports from FASTRTPS_DEFAULT_PROFILES_FILE)"};
  Options options;
  if (const std::optional<int> done = parse_node_options(app, options, argc, argv)) return *done;
  stop_on_signals();
  return run_hw(options);
}
