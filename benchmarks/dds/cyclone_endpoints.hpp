// The Cyclone DDS endpoints of the ping-pong programs (pingpong_cyclone.cpp) and of the
// cross-model relays' Cyclone side (benchmarks/matrix/side_cyclone.hpp), with idlc's types:
// writers and readers reliable, keep-last 10, volatile (polyport's defaults), and the loaned
// take loop their data-available listeners run on Cyclone's receive thread. The endpoints are
// made on the main thread before any sample flows.
#pragma once

#include "dds/dds.h"

namespace bench::cyclone {

inline dds_qos_t* endpoint_qos() {
  dds_qos_t* qos = dds_create_qos();
  dds_qset_reliability(qos, DDS_RELIABILITY_RELIABLE, DDS_SECS(1));
  dds_qset_history(qos, DDS_HISTORY_KEEP_LAST, 10);
  return qos;
}

inline dds_entity_t make_writer(dds_entity_t participant, const dds_topic_descriptor_t* type, const char* topic) {
  dds_qos_t* qos = endpoint_qos();
  const dds_entity_t writer =
      dds_create_writer(participant, dds_create_topic(participant, type, topic, nullptr, nullptr), qos, nullptr);
  dds_delete_qos(qos);
  return writer;
}

// `on_data` (pong, relay): a data-available listener called with `arg`, which must outlive
// the reader.
inline dds_entity_t make_reader(dds_entity_t participant, const dds_topic_descriptor_t* type, const char* topic,
                                dds_on_data_available_fn on_data = nullptr, void* arg = nullptr) {
  dds_qos_t* qos = endpoint_qos();
  dds_listener_t* listener = nullptr;
  if (on_data != nullptr) {
    listener = dds_create_listener(arg);
    dds_lset_data_available(listener, on_data);
  }
  const dds_entity_t reader =
      dds_create_reader(participant, dds_create_topic(participant, type, topic, nullptr, nullptr), qos, listener);
  if (listener != nullptr) dds_delete_listener(listener);
  dds_delete_qos(qos);
  return reader;
}

// Takes every sample `reader` has, on loan, and calls `each(sample)` for the valid ones.
template <class Each>
void take_each(dds_entity_t reader, Each each) {
  void* buffers[8] = {};
  dds_sample_info_t info[8];
  for (;;) {
    const dds_return_t n = dds_take(reader, buffers, info, 8, 8);
    if (n <= 0) return;
    for (dds_return_t i = 0; i < n; ++i) {
      if (info[i].valid_data) each(static_cast<const void*>(buffers[i]));
    }
    dds_return_loan(reader, buffers, n);
  }
}

}  // namespace bench::cyclone
