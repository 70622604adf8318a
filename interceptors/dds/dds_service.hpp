// Services over DDS: each operation of a DDS service port is a request topic and a reply
// topic (DdsAdaptor::Operation); every sample starts with a correlation header
// (config/types/polyport_rpc.idl): the GUID of the request's writer and a sequence number,
// copied by the server into its reply. Two bridges, one per direction:
//
//  - ServiceServer: the DDS application provides the service; polyport's in-process callers
//    call it. It is the provided port's ServiceTarget: submit() encodes the request with a
//    fresh sequence number into a slot of a fixed table (the cap on calls in flight) and
//    writes it; the reply reader finds the slot from the sequence number and completes the
//    call. A timer thread completes calls whose reply has not come within the call timeout
//    (with `timeout`), so a silent or vanished server never keeps a caller's slot.
//  - ServiceClient: the DDS application calls; polyport forwards to the in-process provider
//    its required port is connected to. The request reader decodes the request into a slot,
//    starts an asynchronous call (RequiredServicePort::request_async, no waiting thread) and
//    the completion encodes the reply with the request's identity and writes it.
//
// Errors go back to the caller: the reply header's status carries polyport's Status code
// (too_many_calls when the table is full, not_connected, timeout, error ...); a DDS caller
// sees it in the reply, an in-process caller as the call's status. A request or reply
// whose bytes do not decode is counted (malformed) and dropped.
//
// Threads: submit() runs on the in-process caller's thread, reader callbacks on the SDK's
// thread (one at a time per reader), completions on the in-process provider's thread or
// the reader's. Slots move between states with atomics; each slot has its own buffers, so
// nothing on these paths allocates or locks (the SDK's write may). start/stop/describe run
// on the control thread.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "dds_adaptor.hpp"
#include "dds_endpoint.hpp"
#include "polyport/base/result.hpp"
#include "polyport/runtime/service.hpp"

namespace polyport::dds {

// One call's buffers and state, in a fixed table.
struct CallSlot {
  enum State : std::uint8_t { free, claimed, pending, completing };
  std::atomic<std::uint8_t> state{free};
  // Written by the slot's owner while it is claimed; read by a reply's thread before it
  // tries to take the slot, hence atomic.
  std::atomic<std::uint16_t> operation{0};
  std::atomic<std::uint64_t> sequence{0};  // ServiceServer: the sequence number this call was given
  std::uint64_t generation = 0;      // ServiceServer: how many calls the slot has carried
  PendingCall* call = nullptr;       // ServiceServer: the in-process call
  std::int64_t deadline_ns = 0;      // ServiceServer: when the call times out
  std::uint8_t identity[24] = {};    // ServiceClient: the request's writer GUID + sequence
  std::unique_ptr<std::byte[]> flat;  // the request or reply struct, flat
  std::unique_ptr<std::byte[]> wire;  // its encoding
};

struct ServiceCounters {
  std::atomic<std::uint64_t> calls{0};      // requests taken (submitted / received)
  std::atomic<std::uint64_t> replies{0};    // replies delivered (to the caller / written)
  std::atomic<std::uint64_t> errors{0};     // calls that ended with another status than ok
  std::atomic<std::uint64_t> timeouts{0};   // ServiceServer: no reply within the timeout
  std::atomic<std::uint64_t> refused{0};    // the table of calls in flight was full
  std::atomic<std::uint64_t> malformed{0};  // samples that did not decode
  std::atomic<std::uint64_t> unmatched{0};  // replies for no call of ours (other clients', late)
};

class ServiceServer final : public ServiceTarget {
 public:
  ServiceServer(const DdsAdaptor::Service& service, std::uint32_t max_in_flight, std::int64_t timeout_ns);
  ~ServiceServer() override;
  ServiceServer(const ServiceServer&) = delete;
  ServiceServer& operator=(const ServiceServer&) = delete;

  Result<void> start(Domain& domain);
  // Refuses new calls, waits for submits under way, completes calls in flight with
  // not_active and stops the timer. Writers are kept until destruction.
  void stop() noexcept;
  Status submit(PendingCall& call) noexcept override;
  void describe(nlohmann::json& out) const;

 private:
  struct Endpoints {
    std::unique_ptr<Writer> request;
    std::unique_ptr<Reader> reply;
    Guid guid{};
    std::unique_ptr<std::byte[]> reply_flat;  // the reply reader's decode buffer
  };
  void on_reply(std::uint16_t operation, const std::byte* cdr, std::uint32_t size) noexcept;
  void finish(CallSlot& slot, Status status) noexcept;
  void expire() noexcept;  // the timer thread

  const DdsAdaptor::Service& service_;
  std::int64_t timeout_ns_;
  std::vector<CallSlot> slots_;
  std::vector<Endpoints> endpoints_;  // per operation
  std::vector<std::unique_ptr<Writer>> retired_;
  std::atomic<bool> active_{false};
  std::atomic<std::uint32_t> in_submit_{0};
  ServiceCounters counters_;
  std::mutex timer_mutex_;
  std::condition_variable timer_wake_;
  bool timer_stop_ = false;
  std::thread timer_;
};

class ServiceClient final : private CallObserver {
 public:
  ServiceClient(const DdsAdaptor::Service& service, std::uint32_t max_in_flight);
  ~ServiceClient();
  ServiceClient(const ServiceClient&) = delete;
  ServiceClient& operator=(const ServiceClient&) = delete;

  Result<void> start(Domain& domain);
  // Deletes the request readers; calls still in flight in the provider complete later and
  // their replies are dropped (the reply writers are detached until the next start).
  void stop() noexcept;
  void describe(nlohmann::json& out) const;

 private:
  struct Endpoints {
    std::unique_ptr<Reader> request;
    std::unique_ptr<Writer> reply_owner;
    std::atomic<Writer*> reply{nullptr};
    std::unique_ptr<std::byte[]> request_flat;  // the request reader's decode buffer
    std::unique_ptr<std::byte[]> refusal_flat;  // the request reader's error replies
    std::unique_ptr<std::byte[]> refusal_wire;
  };
  void on_request(std::uint16_t operation, const std::byte* cdr, std::uint32_t size) noexcept;
  void on_call_complete(const PendingCall& call, Status status, std::uint64_t tag) noexcept override;
  // Encodes a reply with `identity`, `status` and `body` into flat/wire and writes it.
  void reply(std::uint16_t operation, const std::uint8_t* identity, Status status, const std::byte* body,
             std::uint32_t body_size, std::byte* flat, std::byte* wire) noexcept;

  const DdsAdaptor::Service& service_;
  std::vector<CallSlot> slots_;
  std::vector<std::unique_ptr<Endpoints>> endpoints_;  // per operation; made by the first start
  ServiceCounters counters_;
};

}  // namespace polyport::dds
