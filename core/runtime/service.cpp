// Service calls between a required and a provided port. A call is a PendingCall slot from the
// caller's fixed pool; its state moves free -> in_flight -> done (the caller takes the reply
// and frees it) or in_flight -> abandoned (the caller gave up; the provider frees it when it
// completes). State changes happen under the slot's mutex: this is the call path, where a
// synchronous caller blocks by definition, not the data forwarding path.
#include "polyport/runtime/service.hpp"

#include <chrono>
#include <cstring>
#include <thread>

#include "polyport/types/types.hpp"

namespace polyport {

namespace {
std::uint32_t payload_size(const Type* type) { return type ? type->size : 0; }
}  // namespace

void PendingCall::complete(Status status) noexcept {
  if (observer_ != nullptr) {
    // Asynchronous: nobody waits on the slot; the observer takes the reply, then the slot
    // goes back to the pool.
    status_ = status;
    if (status != Status::ok) reply_size = 0;
    observer_->on_call_complete(*this, status, tag_);
    owner_->finish_async(*this, status);
    return;
  }
  std::lock_guard<std::mutex> lock(mutex_);
  status_ = status;
  const State state = state_.load(std::memory_order_relaxed);
  if (state == State::abandoned || !wants_reply) {
    state_.store(State::free, std::memory_order_release);
  } else {
    state_.store(State::done, std::memory_order_release);
  }
  done_.notify_all();
}

ProvidedServicePort::ProvidedServicePort(Component& owner, std::string name, std::string service_type,
                                         std::vector<OperationInfo> operations, std::uint32_t queue_depth)
    : Port(owner, std::move(name), PortKind::service, PortDirection::provided, nullptr),
      service_type_(std::move(service_type)),
      operations_(std::move(operations)),
      entries_(operations_.size()),
      target_(this),
      queue_(queue_depth, sizeof(PendingCall*), BoundedQueue::WhenFull::drop_newest) {}

int ProvidedServicePort::find_operation(std::string_view operation_name) const noexcept {
  for (std::size_t i = 0; i < operations_.size(); ++i) {
    if (operations_[i].name == operation_name) return static_cast<int>(i);
  }
  return -1;
}

void ProvidedServicePort::set_handler(std::uint16_t operation, Handler handler, Dispatch dispatch) {
  entries_.at(operation) = Entry{std::move(handler), dispatch};
}

void ProvidedServicePort::set_accepting(bool accepting) noexcept {
  accepting_.store(accepting, std::memory_order_seq_cst);
  if (accepting) return;
  // A submit that read `accepting` before the store may still be running a handler.
  while (in_submit_.load(std::memory_order_seq_cst) != 0) std::this_thread::yield();
}

Status ProvidedServicePort::submit(PendingCall& call) noexcept {
  calls_.fetch_add(1, std::memory_order_relaxed);
  in_submit_.fetch_add(1, std::memory_order_seq_cst);
  Status status = Status::ok;
  if (!accepting_.load(std::memory_order_seq_cst)) {
    status = Status::not_active;
  } else if (call.operation >= entries_.size() || !entries_[call.operation].handler) {
    status = Status::unknown_operation;
  } else if (entries_[call.operation].dispatch == Dispatch::caller_thread) {
    run(call);
  } else {
    PendingCall* pointer = &call;
    const SampleMeta meta{sizeof(pointer), mono_now(), {}};
    if (queue_.push(reinterpret_cast<const std::byte*>(&pointer), meta) != PushResult::stored) {
      status = Status::queue_full;
    }
  }
  if (status != Status::ok) {
    rejected_.fetch_add(1, std::memory_order_relaxed);
    call.complete(status);
  }
  in_submit_.fetch_sub(1, std::memory_order_seq_cst);
  return status;
}

void ProvidedServicePort::run(PendingCall& call) noexcept {
  std::uint32_t reply_size = call.reply_capacity;
  Status status = Status::error;
  try {
    status = entries_[call.operation].handler(call.request, call.request_size, call.reply, reply_size);
  } catch (...) {
    status = Status::error;
  }
  call.reply_size = status == Status::ok ? reply_size : 0;
  call.complete(status);
}

std::size_t ProvidedServicePort::serve_queued() noexcept {
  // Calls queued just before the provider stopped are refused, not run after its stop.
  if (!accepting_.load(std::memory_order_acquire)) return cancel_queued(Status::not_active);
  std::size_t served = 0;
  PendingCall* call = nullptr;
  SampleMeta meta{};
  while (queue_.pop(reinterpret_cast<std::byte*>(&call), sizeof(call), meta) == PopResult::new_data) {
    run(*call);
    ++served;
  }
  return served;
}

std::size_t ProvidedServicePort::cancel_queued(Status status) noexcept {
  std::size_t cancelled = 0;
  PendingCall* call = nullptr;
  SampleMeta meta{};
  while (queue_.pop(reinterpret_cast<std::byte*>(&call), sizeof(call), meta) == PopResult::new_data) {
    call->complete(status);
    ++cancelled;
  }
  return cancelled;
}

RequiredServicePort::RequiredServicePort(Component& owner, std::string name, std::string service_type,
                                         std::vector<OperationInfo> operations, std::uint32_t max_in_flight)
    : Port(owner, std::move(name), PortKind::service, PortDirection::required, nullptr),
      service_type_(std::move(service_type)),
      operations_(std::move(operations)),
      max_in_flight_(max_in_flight == 0 ? 1 : max_in_flight) {
  std::uint32_t request_bytes = 0;
  std::uint32_t reply_bytes = 0;
  for (const OperationInfo& operation : operations_) {
    request_bytes = std::max(request_bytes, payload_size(operation.request));
    reply_bytes = std::max(reply_bytes, payload_size(operation.reply));
  }
  for (std::uint32_t i = 0; i < max_in_flight_; ++i) {
    auto call = std::make_unique<PendingCall>();
    call->request_storage_ = std::make_unique<std::byte[]>(request_bytes + 1);
    call->reply_storage_ = std::make_unique<std::byte[]>(reply_bytes + 1);
    call->reply = call->reply_storage_.get();
    call->reply_capacity = reply_bytes;
    call->owner_ = this;
    pool_.push_back(std::move(call));
  }
}

bool RequiredServicePort::connect(ProvidedServicePort& provider) {
  std::vector<int> index(operations_.size(), -1);
  for (std::size_t i = 0; i < operations_.size(); ++i) {
    index[i] = provider.find_operation(operations_[i].name);
    if (index[i] < 0) return false;
  }
  bindings_.push_back(std::make_unique<Binding>(Binding{&provider, std::move(index)}));
  binding_.store(bindings_.back().get(), std::memory_order_release);
  return true;
}

void RequiredServicePort::disconnect() noexcept { binding_.store(nullptr, std::memory_order_release); }

PendingCall* RequiredServicePort::acquire(std::string_view operation, const void* request,
                                          std::uint32_t request_size, bool wants_reply, Status& status,
                                          CallObserver* observer, std::uint64_t tag) noexcept {
  counters_.calls.fetch_add(1, std::memory_order_relaxed);
  const Binding* binding = binding_.load(std::memory_order_acquire);
  if (!binding) {
    counters_.not_connected.fetch_add(1, std::memory_order_relaxed);
    status = Status::not_connected;
    return nullptr;
  }
  int local = -1;
  for (std::size_t i = 0; i < operations_.size(); ++i) {
    if (operations_[i].name == operation) local = static_cast<int>(i);
  }
  if (local < 0) {
    counters_.errors.fetch_add(1, std::memory_order_relaxed);
    status = Status::unknown_operation;
    return nullptr;
  }
  if (request_size != payload_size(operations_[local].request)) {
    counters_.errors.fetch_add(1, std::memory_order_relaxed);
    status = Status::bad_size;
    return nullptr;
  }
  for (auto& slot : pool_) {
    PendingCall::State expected = PendingCall::State::free;
    if (!slot->state_.compare_exchange_strong(expected, PendingCall::State::in_flight, std::memory_order_acq_rel)) {
      continue;
    }
    PendingCall& call = *slot;
    call.operation = static_cast<std::uint16_t>(binding->remote_index[local]);
    if (request_size > 0) std::memcpy(call.request_storage_.get(), request, request_size);
    call.request = call.request_storage_.get();
    call.request_size = request_size;
    call.reply_size = 0;
    call.wants_reply = wants_reply;
    call.status_ = Status::ok;
    call.observer_ = observer;
    call.tag_ = tag;
    if (observer != nullptr) call.started_ = mono_now();
    status = binding->provider->dispatch(call);
    return &call;
  }
  counters_.too_many_calls.fetch_add(1, std::memory_order_relaxed);
  status = Status::too_many_calls;
  return nullptr;
}

Status RequiredServicePort::finish(PendingCall& call, void* reply, std::uint32_t reply_capacity,
                                   std::uint32_t* reply_size) noexcept {
  // Called with the call done; takes the reply and frees the slot.
  Status status = call.status_;
  if (status == Status::ok) {
    if (call.reply_size > reply_capacity) {
      status = Status::bad_size;
    } else if (call.reply_size > 0) {
      std::memcpy(reply, call.reply, call.reply_size);
    }
    if (reply_size) *reply_size = call.reply_size;
  }
  call.state_.store(PendingCall::State::free, std::memory_order_release);
  // A provider may end a call with `timeout` itself (a foreign model's call timeout).
  (status == Status::ok        ? counters_.ok
   : status == Status::timeout ? counters_.timeouts
                               : counters_.errors)
      .fetch_add(1, std::memory_order_relaxed);
  return status;
}

Status RequiredServicePort::query(std::string_view operation, const void* request, std::uint32_t request_size,
                                  void* reply, std::uint32_t reply_capacity, Nanos timeout,
                                  std::uint32_t* reply_size) {
  if (!blocking()) {
    // A call that may not wait is not made: the provider never sees it.
    counters_.calls.fetch_add(1, std::memory_order_relaxed);
    counters_.cancelled.fetch_add(1, std::memory_order_relaxed);
    return Status::cancelled;
  }
  CallHandle handle = this->request(operation, request, request_size);
  if (!handle) return handle.status;
  const Status status = receive(handle, reply, reply_capacity, timeout, reply_size);
  if (status == Status::timeout || status == Status::cancelled) cancel(handle);
  return status;
}

CallHandle RequiredServicePort::request(std::string_view operation, const void* request, std::uint32_t request_size) {
  CallHandle handle;
  const MonoTime start = mono_now();
  handle.call = acquire(operation, request, request_size, true, handle.status);
  handle.started = start;
  return handle;
}

Status RequiredServicePort::receive(CallHandle& handle, void* reply, std::uint32_t reply_capacity, Nanos timeout,
                                    std::uint32_t* reply_size) {
  return wait_for_reply(handle, reply, reply_capacity, true, timeout, reply_size);
}

Status RequiredServicePort::try_receive(CallHandle& handle, void* reply, std::uint32_t reply_capacity,
                                        std::uint32_t* reply_size) noexcept {
  return wait_for_reply(handle, reply, reply_capacity, false, Nanos{0}, reply_size);
}

Status RequiredServicePort::receive_wait(CallHandle& handle, void* reply, std::uint32_t reply_capacity,
                                         std::uint32_t* reply_size) {
  return wait_for_reply(handle, reply, reply_capacity, true, kWaitForever, reply_size);
}

Status RequiredServicePort::wait_for_reply(CallHandle& handle, void* reply, std::uint32_t reply_capacity, bool wait,
                                           Nanos timeout, std::uint32_t* reply_size) noexcept {
  if (!handle.call) return handle.status == Status::ok ? Status::no_data : handle.status;
  PendingCall& call = *handle.call;
  std::unique_lock<std::mutex> lock(call.mutex_);
  const auto done = [&] { return call.state_.load(std::memory_order_acquire) == PendingCall::State::done; };
  // The mode is read under the slot's mutex, which set_blocking takes after switching it off
  // and before waking: a wait either sees it off or is under way when the wake-up comes.
  const auto over = [&] { return done() || !blocking_.load(std::memory_order_seq_cst); };
  if (wait && !over()) {
    if (timeout == kWaitForever) {
      call.done_.wait(lock, over);
    } else {
      // Saturate, so that a huge timeout means "wait as long as it takes", not an overflow.
      const auto now = std::chrono::steady_clock::now();
      const auto room = std::chrono::steady_clock::time_point::max() - now;
      const auto span = std::chrono::nanoseconds(std::max<std::int64_t>(timeout.count, 0));
      const auto deadline = span >= room ? std::chrono::steady_clock::time_point::max() : now + span;
      call.done_.wait_until(lock, deadline, over);
    }
  }
  if (!done()) {
    if (!wait) return Status::no_data;  // not yet; nothing to count
    if (!blocking_.load(std::memory_order_seq_cst)) {
      counters_.cancelled.fetch_add(1, std::memory_order_relaxed);
      return Status::cancelled;
    }
    counters_.timeouts.fetch_add(1, std::memory_order_relaxed);
    return Status::timeout;
  }
  const Status status = finish(call, reply, reply_capacity, reply_size);
  lock.unlock();
  latency_.record((mono_now() - handle.started).count);
  handle.call = nullptr;
  handle.status = status;
  return status;
}

void RequiredServicePort::cancel(CallHandle& handle) noexcept {
  if (!handle.call) return;
  PendingCall& call = *handle.call;
  std::lock_guard<std::mutex> lock(call.mutex_);
  if (call.state_.load(std::memory_order_acquire) == PendingCall::State::done) {
    call.state_.store(PendingCall::State::free, std::memory_order_release);
  } else {
    call.state_.store(PendingCall::State::abandoned, std::memory_order_release);
  }
  handle.call = nullptr;
  handle.status = Status::cancelled;
}

void RequiredServicePort::set_blocking(bool blocking) noexcept {
  blocking_.store(blocking, std::memory_order_seq_cst);
  if (blocking) return;
  // Wakes every waiter; taking each slot's mutex after the store is what makes a wait that
  // was just about to start see the mode off (no lost wake-up). Slots that nobody waits on
  // cost a lock and an empty notify.
  for (auto& slot : pool_) {
    std::lock_guard<std::mutex> lock(slot->mutex_);
    slot->done_.notify_all();
  }
}

Status RequiredServicePort::request_async(std::string_view operation, const void* request,
                                          std::uint32_t request_size, CallObserver& observer,
                                          std::uint64_t tag) noexcept {
  Status status = Status::ok;
  // A call that reached the provider ends through the observer, refused or not.
  return acquire(operation, request, request_size, true, status, &observer, tag) != nullptr ? Status::ok : status;
}

void RequiredServicePort::finish_async(PendingCall& call, Status status) noexcept {
  if (status == Status::timeout) {
    counters_.timeouts.fetch_add(1, std::memory_order_relaxed);
  } else {
    (status == Status::ok ? counters_.ok : counters_.errors).fetch_add(1, std::memory_order_relaxed);
  }
  // Every call a reply ended, as the synchronous path records (a timeout had no reply).
  if (status != Status::timeout) latency_.record((mono_now() - call.started_).count);
  call.observer_ = nullptr;
  call.state_.store(PendingCall::State::free, std::memory_order_release);
}

Status RequiredServicePort::send(std::string_view operation, const void* request, std::uint32_t request_size) {
  // A refused one-way call was completed (and its slot freed) before dispatch returned;
  // only the returned status tells, the slot may already serve another call.
  Status status = Status::ok;
  if (acquire(operation, request, request_size, false, status) != nullptr) {  // not dereferenced
    (status == Status::ok ? counters_.ok : counters_.errors).fetch_add(1, std::memory_order_relaxed);
  }
  return status;
}

}  // namespace polyport
