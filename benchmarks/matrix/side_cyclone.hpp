// The Cyclone DDS side of a cross-model relay (relay.hpp): idlc's C types of
// benchmarks/dds/pingpong.idl, the endpoints of pingpong_cyclone (cyclone_endpoints.hpp:
// reliable, keep-last 10, volatile); forwards from a data-available listener on Cyclone's
// receive thread, from the loaned sample.
#pragma once

#include <cstring>

#include "cyclone_endpoints.hpp"
#include "cyclone_gen/pingpong.h"
#include "dds/dds.h"
#include "relay.hpp"

namespace bench::relay {

template <int Size>
struct CycloneType;
template <>
struct CycloneType<16> {
  using T = bench_Ping16;
  static const dds_topic_descriptor_t* descriptor() { return &bench_Ping16_desc; }
};
template <>
struct CycloneType<1024> {
  using T = bench_Ping1k;
  static const dds_topic_descriptor_t* descriptor() { return &bench_Ping1k_desc; }
};

template <int Size>
class CycloneSide final : public Writer {
  using T = typename CycloneType<Size>::T;

 public:
  static constexpr const char* kModel = "cyclonedds";
  static constexpr const char* kPing = "ping";
  static constexpr const char* kPong = "pong";

  bool open(int domain, const char* writes) {
    participant_ = dds_create_participant(static_cast<dds_domainid_t>(domain), nullptr, nullptr);
    if (participant_ < 0) return false;
    writer_ = cyclone::make_writer(participant_, CycloneType<Size>::descriptor(), writes);
    return writer_ > 0;
  }

  bool listen(const char* reads, Writer* onward) {
    onward_ = onward;
    return cyclone::make_reader(participant_, CycloneType<Size>::descriptor(), reads, &CycloneSide::on_data, this) > 0;
  }

  bool write(const Fields& fields) override {
    sample_.seq = fields.seq;
    std::memcpy(sample_.pad, fields.pad, sizeof sample_.pad);
    return dds_write(writer_, &sample_) == DDS_RETCODE_OK;
  }

  int fd() const { return -1; }
  void handle() {}
  void close() { dds_delete(participant_); }

 private:
  static void on_data(dds_entity_t reader, void* arg) {
    Writer* onward = static_cast<CycloneSide*>(arg)->onward_;
    cyclone::take_each(reader, [&](const void* loaned) {
      const T* sample = static_cast<const T*>(loaned);
      onward->write(Fields{sample->seq, sample->pad});
    });
  }

  dds_entity_t participant_ = 0;
  dds_entity_t writer_ = 0;
  Writer* onward_ = nullptr;
  T sample_{};
};

}  // namespace bench::relay
