// The Fast DDS side of a cross-model relay (relay.hpp): fastddsgen's C++ types of
// benchmarks/dds/pingpong.idl, the endpoints of pingpong_fastdds (fastdds_endpoints.hpp:
// reliable, keep-last 10, volatile; POLYPORT_BENCH_FASTDDS_DATA_SHARING=off turns data
// sharing off); forwards from on_data_available on Fast DDS's receive thread.
#pragma once

#include <cstring>

#include <fastdds/dds/subscriber/SampleInfo.hpp>

#include "fastdds_endpoints.hpp"
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
    participant_ = fastdds::make_participant<PubSub>(domain);
    writer_ = participant_ != nullptr ? fastdds::make_writer<PubSub>(participant_, writes) : nullptr;
    return writer_ != nullptr;
  }

  bool listen(const char* reads, Writer* onward) {
    onward_ = onward;
    return fastdds::make_reader<PubSub>(participant_, reads, this) != nullptr;
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
  void close() { fastdds::close(participant_); }

 private:
  eprosima::fastdds::dds::DomainParticipant* participant_ = nullptr;
  eprosima::fastdds::dds::DataWriter* writer_ = nullptr;
  Writer* onward_ = nullptr;
  T in_;   // the receive thread's
  T out_;  // the other side's receiving thread's
};

}  // namespace bench::relay
