// The Fast DDS endpoints of the ping-pong programs (pingpong_fastdds.cpp) and of the
// cross-model relays' Fast DDS side (benchmarks/matrix/side_fastdds.hpp), with fastddsgen's
// types: a participant with the type registered; writers and readers reliable, keep-last 10,
// volatile; data sharing Fast DDS's default (AUTO) unless POLYPORT_BENCH_FASTDDS_DATA_SHARING
// is "off". Called on the main thread before any sample flows.
#pragma once

#include <cstdlib>
#include <string>

#include <fastdds/dds/domain/DomainParticipant.hpp>
#include <fastdds/dds/domain/DomainParticipantFactory.hpp>
#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/publisher/Publisher.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>
#include <fastdds/dds/topic/TypeSupport.hpp>

namespace bench::fastdds {

using namespace eprosima::fastdds::dds;

inline bool data_sharing_off() {
  const char* setting = std::getenv("POLYPORT_BENCH_FASTDDS_DATA_SHARING");
  return setting != nullptr && std::string(setting) == "off";
}

template <class PubSub>
DomainParticipant* make_participant(int domain) {
  DomainParticipant* participant =
      DomainParticipantFactory::get_instance()->create_participant(domain, PARTICIPANT_QOS_DEFAULT);
  TypeSupport type(new PubSub());
  type.register_type(participant);
  return participant;
}

template <class PubSub>
DataWriter* make_writer(DomainParticipant* participant, const char* topic) {
  DataWriterQos qos = DATAWRITER_QOS_DEFAULT;
  qos.reliability().kind = RELIABLE_RELIABILITY_QOS;
  qos.history().kind = KEEP_LAST_HISTORY_QOS;
  qos.history().depth = 10;
  if (data_sharing_off()) qos.data_sharing().off();
  Topic* t = participant->create_topic(topic, PubSub().getName(), TOPIC_QOS_DEFAULT);
  return participant->create_publisher(PUBLISHER_QOS_DEFAULT)->create_datawriter(t, qos);
}

// `listener` (pong, relay): data-available only; it must outlive the reader.
template <class PubSub>
DataReader* make_reader(DomainParticipant* participant, const char* topic, DataReaderListener* listener = nullptr) {
  DataReaderQos qos = DATAREADER_QOS_DEFAULT;
  qos.reliability().kind = RELIABLE_RELIABILITY_QOS;
  qos.history().kind = KEEP_LAST_HISTORY_QOS;
  qos.history().depth = 10;
  if (data_sharing_off()) qos.data_sharing().off();
  Topic* t = participant->create_topic(topic, PubSub().getName(), TOPIC_QOS_DEFAULT);
  return participant->create_subscriber(SUBSCRIBER_QOS_DEFAULT)
      ->create_datareader(t, qos, listener, listener != nullptr ? StatusMask::data_available() : StatusMask::none());
}

inline void close(DomainParticipant* participant) {
  participant->delete_contained_entities();
  DomainParticipantFactory::get_instance()->delete_participant(participant);
}

}  // namespace bench::fastdds
