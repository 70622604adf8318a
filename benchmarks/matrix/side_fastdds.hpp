// The Fast DDS side of a cross-model relay (relay.hpp): fastddsgen's C++ types of
// benchmarks/dds/pingpong.idl, QoS and data sharing as pingpong_fastdds's (reliable,
// keep-last 10, volatile; POLYPORT_BENCH_FASTDDS_DATA_SHARING=off turns data sharing off);
// forwards from on_data_available on Fast DDS's receive thread.
#pragma once

#include <cstdlib>
#include <cstring>
#include <string>

#include <fastdds/dds/domain/DomainParticipant.hpp>
#include <fastdds/dds/domain/DomainParticipantFactory.hpp>
#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/publisher/Publisher.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>
#include <fastdds/dds/topic/TypeSupport.hpp>

#include "fastdds_gen/pingpongPubSubTypes.h"
#include "relay.hpp"

namespace bench::relay {

template <int Size>
struct FastddsType;
template <>
struct FastddsType<16> {
  using T = ::bench::Ping16;
  using PubSub = ::bench::Ping16PubSubType;
};
template <>
struct FastddsType<1024> {
  using T = ::bench::Ping1k;
  using PubSub = ::bench::Ping1kPubSubType;
};

template <int Size>
class FastddsSide final : public Writer, public eprosima::fastdds::dds::DataReaderListener {
  using T = typename FastddsType<Size>::T;
  using PubSub = typename FastddsType<Size>::PubSub;

 public:
  static constexpr const char* kModel = "fastdds";
  static constexpr const char* kPing = "ping";
  static constexpr const char* kPong = "pong";

  bool open(int domain, const char* writes) {
    using namespace eprosima::fastdds::dds;
    participant_ = DomainParticipantFactory::get_instance()->create_participant(domain, PARTICIPANT_QOS_DEFAULT);
    if (participant_ == nullptr) return false;
    TypeSupport type(new PubSub());
    type.register_type(participant_);
    DataWriterQos qos = DATAWRITER_QOS_DEFAULT;
    qos.reliability().kind = RELIABLE_RELIABILITY_QOS;
    qos.history().kind = KEEP_LAST_HISTORY_QOS;
    qos.history().depth = 10;
    if (data_sharing_off()) qos.data_sharing().off();
    writer_ = participant_->create_publisher(PUBLISHER_QOS_DEFAULT)->create_datawriter(topic(writes), qos);
    return writer_ != nullptr;
  }

  bool listen(const char* reads, Writer* onward) {
    using namespace eprosima::fastdds::dds;
    onward_ = onward;
    DataReaderQos qos = DATAREADER_QOS_DEFAULT;
    qos.reliability().kind = RELIABLE_RELIABILITY_QOS;
    qos.history().kind = KEEP_LAST_HISTORY_QOS;
    qos.history().depth = 10;
    if (data_sharing_off()) qos.data_sharing().off();
    return participant_->create_subscriber(SUBSCRIBER_QOS_DEFAULT)
               ->create_datareader(topic(reads), qos, this, StatusMask::data_available()) != nullptr;
  }

  bool write(const Fields& fields) override {
    out_.seq(fields.seq);
    std::memcpy(out_.pad().data(), fields.pad, out_.pad().size());
    return writer_->write(&out_);
  }

  void on_data_available(eprosima::fastdds::dds::DataReader* reader) override {
    eprosima::fastdds::dds::SampleInfo info;
    while (reader->take_next_sample(&in_, &info) == eprosima::fastrtps::types::ReturnCode_t::RETCODE_OK) {
      if (info.valid_data) onward_->write(Fields{in_.seq(), in_.pad().data()});
    }
  }

  int fd() const { return -1; }
  void handle() {}
  void close() {
    participant_->delete_contained_entities();
    eprosima::fastdds::dds::DomainParticipantFactory::get_instance()->delete_participant(participant_);
  }

 private:
  static bool data_sharing_off() {
    const char* setting = std::getenv("POLYPORT_BENCH_FASTDDS_DATA_SHARING");
    return setting != nullptr && std::string(setting) == "off";
  }
  eprosima::fastdds::dds::Topic* topic(const char* name) {
    return participant_->create_topic(name, PubSub().getName(), eprosima::fastdds::dds::TOPIC_QOS_DEFAULT);
  }

  eprosima::fastdds::dds::DomainParticipant* participant_ = nullptr;
  eprosima::fastdds::dds::DataWriter* writer_ = nullptr;
  Writer* onward_ = nullptr;
  T in_;   // the receive thread's
  T out_;  // the other side's receiving thread's
};

}  // namespace bench::relay
