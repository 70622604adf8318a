// Services carried by a foreign model as messages: each operation of a foreign service port is
// a request message and a reply message (DDS: two topics; LCM: two channels), and every
// message is a struct whose first member is a correlation header — who called (DDS: the
// request writer's GUID; LCM: a client id) and the caller's sequence number, plus a status in
// replies — followed by the operation's payload. The model checks those structs and records
// where the header fields and the payload sit (RpcLayout); it supplies the endpoints
// (RpcTransport). The bridges here do the calls, the same for every model. Two bridges, one
// per direction:
//
//  - ServiceServer: the foreign application provides the service; polyport's in-process
//    callers call it. It is the provided port's ServiceTarget: submit() encodes the request
//    with a fresh sequence number into a slot of a fixed table (the cap on calls in flight)
//    and sends it; the reply receiver finds the slot from the sequence number and completes
//    the call. A timer thread completes calls whose reply has not come within the call
//    timeout (with `timeout`), so a silent or vanished server never keeps a caller's slot.
//  - ServiceClient: the foreign application calls; polyport forwards to the in-process
//    provider its required port is connected to. The request receiver decodes the request
//    into a slot, starts an asynchronous call (RequiredServicePort::request_async, no
//    waiting thread) and the completion encodes the reply with the request's identity and
//    sends it.
//
// Errors go back to the caller: the reply header's status carries polyport's Status code
// (too_many_calls when the table is full, not_connected, timeout, error ...); a foreign caller
// sees it in the reply, an in-process caller as the call's status. A request or reply whose
// bytes do not decode (a wrong LCM fingerprint included) is counted (malformed) and dropped.
//
// Threads: submit() runs on the in-process caller's thread, receiver callbacks on the
// model's receive thread (one at a time per receiver), completions on the in-process
// provider's thread or the receiver's. Slots move between states with atomics; each slot has
// its own buffers, so nothing on these paths allocates or locks (the model's send may).
// start/stop/describe run on the control thread.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "polyport/base/result.hpp"
#include "polyport/base/diagnostics.hpp"
#include "polyport/codecs/codec.hpp"
#include "polyport/profile/profile.hpp"
#include "polyport/runtime/component.hpp"
#include "polyport/runtime/service.hpp"
#include "polyport/types/types.hpp"

namespace polyport {

// Where the parts of one request or reply struct sit in its flat sample.
struct RpcLayout {
  const Type* type = nullptr;    // the struct on the wire (a header, then the payload)
  std::string type_name;         // as the model names it
  std::string address;           // the topic or channel it travels on
  const Codec* codec = nullptr;  // the model's wire format
  bool reply = false;            // the reply message (else the request)
  std::uint32_t max_size = 0;    // largest encoded message
  std::uint32_t caller_offset = 0;    // who called: DDS octet[16] writer GUID, LCM int64 client id
  std::uint32_t caller_size = 0;      // at most kMaxCallerBytes
  std::uint32_t sequence_offset = 0;  // the caller's sequence number (64 bits)
  std::uint32_t status_offset = 0;    // int32 status; replies only
  std::uint32_t body_offset = 0;      // the payload member
  std::uint32_t body_size = 0;        // 0: no payload
};

struct RpcOperation {
  std::string name;
  bool oneway = false;
  RpcLayout request;
  RpcLayout reply;  // type null when oneway
};

// One foreign service port: exactly one of provided / required is set.
struct RpcService {
  ProvidedServicePort* provided = nullptr;  // the foreign application serves the calls
  RequiredServicePort* required = nullptr;  // the foreign application makes the calls
  std::vector<RpcOperation> operations;     // in the port's operation order
};

inline constexpr std::uint32_t kMaxCallerBytes = 16;

// Checks that `wire` (a registry type, null when unknown) is the struct
// `{ <header_name> header; <payload_name> <member>; }` (no payload member when `payload_name`
// is empty) with a payload of bounded size, and fills the layout's type and body; the model
// checks the header's own fields. `header` is set to the header struct; `header_file` is the
// file that declares it. Returns what is wrong ("is not a struct", "must be { ... }"), empty
// when nothing is.
std::string check_rpc_struct(const Type* wire, std::string_view header_name, const std::string& payload_name,
                             const TypeRegistry& types, std::string_view header_file, RpcLayout& layout,
                             const Type*& header);

// Fills one operation's request (reply = false) or reply layout, reporting any problem.
using RpcLayoutReader = std::function<bool(const OperationSpec& operation, bool reply, RpcLayout& layout)>;

// A foreign service port of `component`: each operation's layouts from `read_layout` (the
// reply's only when the operation is not oneway), then the provided or required port
// (`max_in_flight` calls for a required one) into `service`. `kind` and `address` name such
// a port and what carries a message for the messages ("a DDS service port", "topic"). False
// when a problem was reported; no port is added then.
bool add_rpc_service(Component& component, const PortSpec& spec, const TypeRegistry& types,
                     std::uint32_t max_in_flight, std::string_view kind, std::string_view address,
                     const RpcLayoutReader& read_layout, Diagnostics& diagnostics, RpcService& service);

// Sends the messages of one direction of one operation. Any thread.
class RpcSender {
 public:
  virtual ~RpcSender() = default;
  virtual Status send(const std::byte* wire, std::uint32_t size) noexcept = 0;
  // What a server bridge writes as the caller of its requests (DDS: the writer's GUID);
  // `caller_size` bytes.
  virtual const std::uint8_t* caller() const noexcept { return nullptr; }
  virtual void describe(nlohmann::json& /*operation*/) const {}
};

// Receives the messages of one direction of one operation; after its destructor returns, its
// callback is not running and is not called again.
class RpcReceiver {
 public:
  virtual ~RpcReceiver() = default;
  virtual void describe(nlohmann::json& /*operation*/) const {}
};

// `wire` is valid only during the call.
using RpcReceive = std::function<void(const std::byte* wire, std::uint32_t size)>;

// The model's endpoints for a service's operations. Control thread.
class RpcTransport {
 public:
  virtual ~RpcTransport() = default;
  virtual Result<std::unique_ptr<RpcSender>> sender(const RpcLayout& layout) = 0;
  virtual Result<std::unique_ptr<RpcReceiver>> receiver(const RpcLayout& layout, RpcReceive receive) = 0;
};

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
  std::atomic<std::int64_t> deadline_ns{0};  // ServiceServer: when the call times out (read by the timer)
  std::uint8_t caller[kMaxCallerBytes] = {};  // ServiceClient: the request's caller
  std::uint64_t caller_sequence = 0;          // ServiceClient: and its sequence number
  std::unique_ptr<std::byte[]> flat;  // the request or reply struct, flat
  std::unique_ptr<std::byte[]> wire;  // its encoding
};

struct ServiceCounters {
  std::atomic<std::uint64_t> calls{0};      // requests taken (submitted / received)
  std::atomic<std::uint64_t> replies{0};    // replies delivered (to the caller / sent)
  std::atomic<std::uint64_t> errors{0};     // calls that ended with another status than ok
  std::atomic<std::uint64_t> timeouts{0};   // ServiceServer: no reply within the timeout
  std::atomic<std::uint64_t> refused{0};    // the table of calls in flight was full
  std::atomic<std::uint64_t> malformed{0};  // messages that did not decode
  std::atomic<std::uint64_t> unmatched{0};  // replies for no call of ours (other clients', late)
};

class ServiceServer final : public ServiceTarget {
 public:
  // `address_key` names the addresses in describe ("topic": request_topic, reply_topic).
  ServiceServer(const RpcService& service, std::uint32_t max_in_flight, std::int64_t timeout_ns,
                std::string address_key);
  ~ServiceServer() override;
  ServiceServer(const ServiceServer&) = delete;
  ServiceServer& operator=(const ServiceServer&) = delete;

  Result<void> start(RpcTransport& transport);
  // Refuses new calls, waits for submits under way, completes calls in flight with
  // not_active and stops the timer. Senders are kept until destruction.
  void stop() noexcept;
  Status submit(PendingCall& call) noexcept override;
  void describe(nlohmann::json& out) const;

 private:
  struct Endpoints {
    std::unique_ptr<RpcSender> request;
    std::unique_ptr<RpcReceiver> reply;
    std::unique_ptr<std::byte[]> reply_flat;  // the reply receiver's decode buffer
  };
  void on_reply(std::uint16_t operation, const std::byte* wire, std::uint32_t size) noexcept;
  void finish(CallSlot& slot, Status status) noexcept;
  void expire() noexcept;  // the timer thread

  const RpcService& service_;
  std::int64_t timeout_ns_;
  std::string address_key_;
  std::vector<CallSlot> slots_;
  std::vector<Endpoints> endpoints_;  // per operation
  std::vector<std::unique_ptr<RpcSender>> retired_;
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
  ServiceClient(const RpcService& service, std::uint32_t max_in_flight, std::string address_key);
  ~ServiceClient();
  ServiceClient(const ServiceClient&) = delete;
  ServiceClient& operator=(const ServiceClient&) = delete;

  Result<void> start(RpcTransport& transport);
  // Deletes the request receivers; calls still in flight in the provider complete later and
  // their replies are dropped (the reply senders are detached until the next start).
  void stop() noexcept;
  void describe(nlohmann::json& out) const;

 private:
  struct Endpoints {
    std::unique_ptr<RpcReceiver> request;
    std::unique_ptr<RpcSender> reply_owner;
    std::atomic<RpcSender*> reply{nullptr};
    std::unique_ptr<std::byte[]> request_flat;  // the request receiver's decode buffer
    std::unique_ptr<std::byte[]> refusal_flat;  // the request receiver's error replies
    std::unique_ptr<std::byte[]> refusal_wire;
  };
  void on_request(std::uint16_t operation, const std::byte* wire, std::uint32_t size) noexcept;
  void on_call_complete(const PendingCall& call, Status status, std::uint64_t tag) noexcept override;
  // Encodes a reply to `caller`'s call `sequence` with `status` and `body` into flat/wire and
  // sends it.
  void reply(std::uint16_t operation, const std::uint8_t* caller, std::uint64_t sequence, Status status,
             const std::byte* body, std::uint32_t body_size, std::byte* flat, std::byte* wire) noexcept;

  const RpcService& service_;
  std::string address_key_;
  std::vector<CallSlot> slots_;
  std::vector<std::unique_ptr<Endpoints>> endpoints_;  // per operation; made by the first start
  ServiceCounters counters_;
};

}  // namespace polyport
