// Service ports: a required port calls operations of the provided port it is connected to.
//
// A call lives in a PendingCall slot taken from the caller's fixed pool (the cap on calls in
// flight), so calling allocates nothing. The provided port hands the slot to its
// ServiceTarget: in-process handlers run it on the caller's thread or queue it for the
// provider's own execution context; a foreign model's adaptor forwards it to its peer and
// completes it from that model's receive thread. The caller waits for completion with a
// timeout or without one (a blocking wait is what a synchronous call is); a slot abandoned by
// a caller that gave up is returned to the pool when the provider completes it.
//
// The blocking mode (SmartSoft's `blocking(false)`): while it is off, no call of the port
// waits. A wait under way ends at once with `cancelled` and a waiting call started then
// returns `cancelled` at once, so that a component being stopped rushes through its calls
// instead of hanging on a provider that does not answer. The engine switches it off before
// it deactivates or stops the component and on again when it activates it.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>
#include <vector>

#include "polyport/base/clock.hpp"
#include "polyport/runtime/histogram.hpp"
#include "polyport/runtime/port.hpp"
#include "polyport/runtime/sample_buffer.hpp"

namespace polyport {

struct OperationInfo {
  std::string name;
  const Type* request = nullptr;  // null: no request payload
  const Type* reply = nullptr;    // null: no reply payload
  bool oneway = false;
};

class PendingCall;
class RequiredServicePort;

// Told of the end of an asynchronous call (RequiredServicePort::request_async), exactly once,
// on whichever thread completes it (the provider's, or the caller's own when the provider
// runs or refuses it at once). `call.reply` / `call.reply_size` hold the reply when status is
// ok; they are valid only during the call, after which the slot goes back to the pool.
class CallObserver {
 public:
  virtual void on_call_complete(const PendingCall& call, Status status, std::uint64_t tag) noexcept = 0;

 protected:
  ~CallObserver() = default;
};

class PendingCall {
 public:
  enum class State : std::uint8_t { free, in_flight, done, abandoned };

  std::uint16_t operation = 0;  // index into the provided port's operations
  const std::byte* request = nullptr;
  std::uint32_t request_size = 0;
  std::byte* reply = nullptr;  // the slot's reply buffer
  std::uint32_t reply_capacity = 0;
  std::uint32_t reply_size = 0;
  bool wants_reply = true;

  // Provider side: called exactly once per submitted call.
  void complete(Status status) noexcept;

 private:
  friend class RequiredServicePort;
  std::atomic<State> state_{State::free};
  Status status_ = Status::ok;
  RequiredServicePort* owner_ = nullptr;
  CallObserver* observer_ = nullptr;  // set for asynchronous calls with an observer
  std::uint64_t tag_ = 0;
  MonoTime started_;
  std::mutex mutex_;
  std::condition_variable done_;
  std::unique_ptr<std::byte[]> request_storage_;
  std::unique_ptr<std::byte[]> reply_storage_;
};

class ServiceTarget {
 public:
  virtual ~ServiceTarget() = default;
  // Takes the call: completes it now or later. Returns ok when it was accepted (run or
  // queued), else the reason it was refused (the call is then already completed with it).
  virtual Status submit(PendingCall& call) noexcept = 0;
};

class ProvidedServicePort final : public Port, private ServiceTarget {
 public:
  enum class Dispatch : std::uint8_t {
    caller_thread,  // run on the caller's thread, at once
    own_thread,     // queued; run by the provider's execution context (serve_queued)
  };
  // reply_size is in/out: capacity in, bytes written out.
  using Handler = std::function<Status(const std::byte* request, std::uint32_t request_size,
                                       std::byte* reply, std::uint32_t& reply_size)>;

  ProvidedServicePort(Component& owner, std::string name, std::string service_type,
                      std::vector<OperationInfo> operations, std::uint32_t queue_depth = 64);

  const std::string& service_type() const noexcept { return service_type_; }
  const std::vector<OperationInfo>& operations() const noexcept { return operations_; }
  int find_operation(std::string_view operation_name) const noexcept;  // -1 if none

  void set_handler(std::uint16_t operation, Handler handler, Dispatch dispatch);
  // Replaces the in-process dispatch, e.g. by an adaptor forwarding to a foreign model.
  void set_target(ServiceTarget* target) noexcept { target_ = target; }

  // Called by a connected required port: hands the call to the target (the in-process
  // handlers unless set_target replaced them).
  Status dispatch(PendingCall& call) noexcept { return target_->submit(call); }
  // Runs queued own_thread calls; the provider's thread. Returns how many ran.
  std::size_t serve_queued() noexcept;
  // Completes every queued call with `status` (e.g. not_active when the provider stops).
  std::size_t cancel_queued(Status status) noexcept;
  // Calls are accepted only between the provider's start and stop. Refusing waits until no
  // call is still being submitted or run on another thread, so that after it returns no
  // handler runs until calls are accepted again.
  void set_accepting(bool accepting) noexcept;

  std::uint64_t calls() const noexcept { return calls_.load(std::memory_order_relaxed); }
  std::uint64_t rejected() const noexcept { return rejected_.load(std::memory_order_relaxed); }

 private:
  struct Entry {
    Handler handler;
    Dispatch dispatch = Dispatch::own_thread;
  };
  Status submit(PendingCall& call) noexcept override;  // in-process dispatch
  void run(PendingCall& call) noexcept;

  std::string service_type_;
  std::vector<OperationInfo> operations_;
  std::vector<Entry> entries_;
  ServiceTarget* target_;
  BoundedQueue queue_;
  std::atomic<bool> accepting_{false};
  std::atomic<std::uint32_t> in_submit_{0};  // submit() calls under way, on any thread
  std::atomic<std::uint64_t> calls_{0};
  std::atomic<std::uint64_t> rejected_{0};
};

// A timeout that means "no timeout": wait until the reply comes or the blocking mode goes off.
inline constexpr Nanos kWaitForever{std::numeric_limits<std::int64_t>::max()};

// A handle on an asynchronous call started by request().
struct CallHandle {
  PendingCall* call = nullptr;
  Status status = Status::ok;  // why call is null, when it is
  MonoTime started;
  explicit operator bool() const noexcept { return call != nullptr; }
};

class RequiredServicePort final : public Port {
 public:
  RequiredServicePort(Component& owner, std::string name, std::string service_type,
                      std::vector<OperationInfo> operations, std::uint32_t max_in_flight = 8);

  // Control thread, also while callers call: binds to a provider (operations matched by
  // name), replacing any binding; false if an operation of this port is missing there. A call
  // already made goes on with the provider it was made to.
  bool connect(ProvidedServicePort& provider);
  void disconnect() noexcept;
  bool connected() const noexcept { return binding_.load(std::memory_order_acquire) != nullptr; }
  ProvidedServicePort* provider() const noexcept {
    const Binding* binding = binding_.load(std::memory_order_acquire);
    return binding != nullptr ? binding->provider : nullptr;
  }

  // Synchronous call: waits at most `timeout` (kWaitForever: until the reply comes or the
  // blocking mode goes off). On timeout or cancelled the call is given up (its slot returns
  // to the pool when the provider completes it). While the blocking mode is off it returns
  // cancelled at once and the provider is not called.
  Status query(std::string_view operation, const void* request, std::uint32_t request_size,
               void* reply, std::uint32_t reply_capacity, Nanos timeout,
               std::uint32_t* reply_size = nullptr);
  // Asynchronous call (SmartSoft's request / receive / receiveWait): request() starts it;
  // receive() waits at most `timeout` for its reply, try_receive() not at all (no_data: not
  // yet), receive_wait() as long as it takes. A receive that ends with timeout, no_data or
  // cancelled (the blocking mode is off, see set_blocking) leaves the call in flight: receive
  // again, or cancel() to give up on it. A reply that is there is taken whatever the mode.
  CallHandle request(std::string_view operation, const void* request, std::uint32_t request_size);
  Status receive(CallHandle& handle, void* reply, std::uint32_t reply_capacity, Nanos timeout,
                 std::uint32_t* reply_size = nullptr);
  Status try_receive(CallHandle& handle, void* reply, std::uint32_t reply_capacity,
                     std::uint32_t* reply_size = nullptr) noexcept;
  Status receive_wait(CallHandle& handle, void* reply, std::uint32_t reply_capacity,
                      std::uint32_t* reply_size = nullptr);
  // Gives up on the call (SmartSoft's discard); a later receive on the handle returns
  // cancelled.
  void cancel(CallHandle& handle) noexcept;

  // The blocking mode; on from construction. Switching it off wakes every call of this port
  // that waits (they return cancelled); calls already in flight stay in flight. Any thread
  // (the engine's control thread, or the component itself); not on the forwarding path.
  void set_blocking(bool blocking) noexcept;
  bool blocking() const noexcept { return blocking_.load(std::memory_order_acquire); }
  // One-way send: no reply, no wait.
  Status send(std::string_view operation, const void* request, std::uint32_t request_size);
  // Asynchronous call without a waiting thread: `observer` is told of its end with `tag`.
  // Returns ok when the call reached the provider: the observer is then called exactly once
  // (maybe before this returns), also when the provider refused it. Otherwise returns why
  // (not_connected, unknown_operation, bad_size, too_many_calls) and the observer is not
  // called. Allocates nothing, takes no lock of its own (the provider's dispatch may).
  Status request_async(std::string_view operation, const void* request, std::uint32_t request_size,
                       CallObserver& observer, std::uint64_t tag) noexcept;

  const std::string& service_type() const noexcept { return service_type_; }
  const std::vector<OperationInfo>& operations() const noexcept { return operations_; }
  std::uint32_t max_in_flight() const noexcept { return max_in_flight_; }

  struct Counters {
    std::atomic<std::uint64_t> calls{0}, ok{0}, timeouts{0}, errors{0}, not_connected{0},
        too_many_calls{0}, cancelled{0};
  };
  const Counters& counters() const noexcept { return counters_; }
  const LatencyHistogram& latency() const noexcept { return latency_; }

 private:
  friend class PendingCall;
  PendingCall* acquire(std::string_view operation, const void* request, std::uint32_t request_size,
                       bool wants_reply, Status& status, CallObserver* observer = nullptr,
                       std::uint64_t tag = 0) noexcept;
  void finish_async(PendingCall& call, Status status) noexcept;
  void release(PendingCall& call) noexcept;
  Status finish(PendingCall& call, void* reply, std::uint32_t reply_capacity,
                std::uint32_t* reply_size) noexcept;
  // receive's common part; `wait` false: no wait at all (try_receive).
  Status wait_for_reply(CallHandle& handle, void* reply, std::uint32_t reply_capacity, bool wait,
                        Nanos timeout, std::uint32_t* reply_size) noexcept;

  std::string service_type_;
  std::vector<OperationInfo> operations_;
  std::uint32_t max_in_flight_;
  std::vector<std::unique_ptr<PendingCall>> pool_;
  // A provider and, per operation of this port, its index there, published whole (one
  // pointer) so that a caller never pairs a provider with another's indexes. Earlier
  // bindings are kept: a caller may still be reading one (the forwarding path takes no lock).
  struct Binding {
    ProvidedServicePort* provider = nullptr;
    std::vector<int> remote_index;  // our operation index -> provider's
  };
  std::atomic<const Binding*> binding_{nullptr};
  std::vector<std::unique_ptr<Binding>> bindings_;  // control thread
  Counters counters_;
  LatencyHistogram latency_;
  std::atomic<bool> blocking_{true};
};

}  // namespace polyport
