// A plain Fast DDS application for the domain tests (domain_test.cpp), run as a process of
// its own: demo::Pose from fastddsgen (raw_roundtrip.idl), the default participant QoS
// (built-in transports: SHM + UDPv4 on every interface, as an application left at its
// defaults has) and default endpoint QoS. It knows nothing of polyport. One line per event
// on stdout:
//   fastdds_generated_app sub DOMAIN TOPIC COUNT   prints "matched", then
//                                                  "sample SEQ X Y HEADING VALID FRAME R1,R2,..."
//                                                  per sample; exits 0 after COUNT samples
//   fastdds_generated_app pub DOMAIN TOPIC COUNT   once matched, writes seq 1..COUNT
//                                                  (x = seq / 2, frame "from_app", readings
//                                                  {seq, -seq}), each acknowledged before
//                                                  the next; prints "done", exits 0
// Exit 2: nothing matched within 20 s; 3: fewer samples or acknowledgments than asked for
// within 20 s; 1: set-up failed. SIGTERM / SIGINT end it cleanly (shared memory released).
#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <thread>

#include <fastdds/dds/domain/DomainParticipant.hpp>
#include <fastdds/dds/domain/DomainParticipantFactory.hpp>
#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/publisher/Publisher.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>
#include <fastdds/dds/topic/TypeSupport.hpp>

#include "raw_roundtrip.h"
#include "raw_roundtripPubSubTypes.h"

using namespace eprosima::fastdds::dds;

namespace {

using Clock = std::chrono::steady_clock;
constexpr auto kLimit = std::chrono::seconds(20);

std::atomic<bool> g_stop{false};
extern "C" void on_signal(int) { g_stop = true; }

template <class F>
bool wait_for(F&& condition) {
  const auto deadline = Clock::now() + kLimit;
  while (!condition()) {
    if (g_stop || Clock::now() > deadline) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  return true;
}

void print_sample(const demo::Pose& p) {
  std::string readings;
  for (short r : p.readings()) readings += (readings.empty() ? "" : ",") + std::to_string(r);
  std::printf("sample %u %.17g %.17g %.9g %d %s %s\n", p.seq(), p.x(), p.y(), static_cast<double>(p.heading()),
              p.valid() ? 1 : 0, p.frame().c_str(), readings.empty() ? "-" : readings.c_str());
  std::fflush(stdout);
}

int run(bool publish, int domain, const std::string& topic_name, int count) {
  auto* factory = DomainParticipantFactory::get_instance();
  DomainParticipant* participant = factory->create_participant(domain, PARTICIPANT_QOS_DEFAULT);
  if (participant == nullptr) return 1;
  int code = 0;
  TypeSupport type(new demo::PosePubSubType());
  type.register_type(participant);
  Topic* topic = participant->create_topic(topic_name, type.get_type_name(), TOPIC_QOS_DEFAULT);
  if (topic == nullptr) {
    code = 1;
  } else if (publish) {
    DataWriter* writer =
        participant->create_publisher(PUBLISHER_QOS_DEFAULT)->create_datawriter(topic, DATAWRITER_QOS_DEFAULT);
    if (writer == nullptr) {
      code = 1;
    } else if (!wait_for([&] {
                 PublicationMatchedStatus status;
                 writer->get_publication_matched_status(status);
                 return status.current_count > 0;
               })) {
      code = 2;
    } else {
      for (int i = 1; i <= count && code == 0; ++i) {
        demo::Pose p;
        p.seq(static_cast<std::uint32_t>(i));
        p.x(i / 2.0);
        p.y(-1.0);
        p.heading(0.25f);
        p.valid(true);
        p.frame("from_app");
        p.readings({static_cast<short>(i), static_cast<short>(-i)});
        if (!writer->write(&p) || writer->wait_for_acknowledgments(eprosima::fastrtps::Duration_t(20, 0)) !=
                                      ReturnCode_t::RETCODE_OK) {
          code = 3;
        }
      }
      if (code == 0) {
        std::printf("done\n");
        std::fflush(stdout);
      }
    }
  } else {
    DataReader* reader =
        participant->create_subscriber(SUBSCRIBER_QOS_DEFAULT)->create_datareader(topic, DATAREADER_QOS_DEFAULT);
    if (reader == nullptr) {
      code = 1;
    } else if (!wait_for([&] {
                 SubscriptionMatchedStatus status;
                 reader->get_subscription_matched_status(status);
                 return status.current_count > 0;
               })) {
      code = 2;
    } else {
      std::printf("matched\n");
      std::fflush(stdout);
      int received = 0;
      const bool all = wait_for([&] {
        demo::Pose p;
        SampleInfo info;
        while (received < count && reader->take_next_sample(&p, &info) == ReturnCode_t::RETCODE_OK) {
          if (!info.valid_data) continue;
          print_sample(p);
          ++received;
        }
        return received >= count;
      });
      if (!all) code = 3;
    }
  }
  participant->delete_contained_entities();
  factory->delete_participant(participant);
  return code;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 5 || (std::string(argv[1]) != "pub" && std::string(argv[1]) != "sub")) {
    std::fprintf(stderr, "usage: %s pub|sub DOMAIN TOPIC COUNT\n", argv[0]);
    return 1;
  }
  std::signal(SIGTERM, on_signal);
  std::signal(SIGINT, on_signal);
  return run(std::string(argv[1]) == "pub", std::atoi(argv[2]), argv[3], std::atoi(argv[4]));
}
