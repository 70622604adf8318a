// The Cyclone DDS side of a cross-model relay (relay.hpp): idlc's C types of
// benchmarks/dds/pingpong.idl, QoS as pingpong_cyclone's (reliable, keep-last 10, volatile);
// forwards from a data-available listener on Cyclone's receive thread, from the loaned
// sample.
#pragma once

#include <cstring>

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
    writer_ = dds_create_writer(participant_, topic(writes), qos_, nullptr);
    return writer_ > 0;
  }

  bool listen(const char* reads, Writer* onward) {
    onward_ = onward;
    dds_listener_t* listener = dds_create_listener(this);
    dds_lset_data_available(listener, &CycloneSide::on_data);
    const dds_entity_t reader = dds_create_reader(participant_, topic(reads), qos_, listener);
    dds_delete_listener(listener);
    return reader > 0;
  }

  bool write(const Fields& fields) override {
    sample_.seq = fields.seq;
    std::memcpy(sample_.pad, fields.pad, sizeof sample_.pad);
    return dds_write(writer_, &sample_) == DDS_RETCODE_OK;
  }

  int fd() const { return -1; }
  void handle() {}
  void close() { dds_delete(participant_); }

  CycloneSide() {
    qos_ = dds_create_qos();
    dds_qset_reliability(qos_, DDS_RELIABILITY_RELIABLE, DDS_SECS(1));
    dds_qset_history(qos_, DDS_HISTORY_KEEP_LAST, 10);
  }
  ~CycloneSide() { dds_delete_qos(qos_); }
  CycloneSide(const CycloneSide&) = delete;
  CycloneSide& operator=(const CycloneSide&) = delete;

 private:
  dds_entity_t topic(const char* name) {
    return dds_create_topic(participant_, CycloneType<Size>::descriptor(), name, nullptr, nullptr);
  }

  static void on_data(dds_entity_t reader, void* arg) {
    Writer* onward = static_cast<CycloneSide*>(arg)->onward_;
    void* buffers[8] = {};
    dds_sample_info_t info[8];
    for (;;) {
      const dds_return_t n = dds_take(reader, buffers, info, 8, 8);
      if (n <= 0) return;
      for (dds_return_t i = 0; i < n; ++i) {
        if (!info[i].valid_data) continue;
        const T* sample = static_cast<const T*>(buffers[i]);
        onward->write(Fields{sample->seq, sample->pad});
      }
      dds_return_loan(reader, buffers, n);
    }
  }

  dds_qos_t* qos_ = nullptr;
  dds_entity_t participant_ = 0;
  dds_entity_t writer_ = 0;
  Writer* onward_ = nullptr;
  T sample_{};
};

}  // namespace bench::relay
