#include "polyport/runtime/service_bridge.hpp"

#include <algorithm>
#include <chrono>
#include <cstring>

#include <nlohmann/json.hpp>

#include "polyport/runtime/model.hpp"

namespace polyport {

namespace {

std::uint64_t load_u64(const std::byte* p) noexcept {
  std::uint64_t value = 0;
  std::memcpy(&value, p, sizeof value);
  return value;
}

void store_u64(std::byte* p, std::uint64_t value) noexcept { std::memcpy(p, &value, sizeof value); }

// The reply header's status: polyport's Status codes; anything else a peer sends is an error.
Status status_from_wire(std::int32_t code) noexcept {
  if (code < 0 || code > static_cast<std::int32_t>(Status::error)) return Status::error;
  const auto status = static_cast<Status>(code);
  // Read results are not call outcomes.
  if (status == Status::old_data || status == Status::no_data) return Status::error;
  return status;
}

void buffers_for(CallSlot& slot, const RpcService& service, bool reply) {
  std::uint32_t flat = 1;
  std::uint32_t wire = 1;
  for (const RpcOperation& op : service.operations) {
    const RpcLayout& layout = reply ? op.reply : op.request;
    if (layout.type == nullptr) continue;
    flat = std::max(flat, layout.type->size);
    wire = std::max(wire, layout.max_size);
  }
  slot.flat = std::make_unique<std::byte[]>(flat);
  slot.wire = std::make_unique<std::byte[]>(wire);
}

nlohmann::json counters_json(const ServiceCounters& c) {
  return {{"calls", c.calls.load()},       {"replies", c.replies.load()},     {"errors", c.errors.load()},
          {"timeouts", c.timeouts.load()}, {"refused", c.refused.load()},     {"malformed", c.malformed.load()},
          {"unmatched", c.unmatched.load()}};
}

nlohmann::json operation_json(const RpcOperation& op, const std::string& key) {
  nlohmann::json o{
      {"operation", op.name}, {"request_" + key, op.request.address}, {"request_type", op.request.type_name}};
  if (!op.oneway) {
    o["reply_" + key] = op.reply.address;
    o["reply_type"] = op.reply.type_name;
  }
  return o;
}

}  // namespace

std::string check_rpc_struct(const Type* wire_type, std::string_view header_name, const std::string& payload_name,
                             const TypeRegistry& types, std::string_view header_file, RpcLayout& layout,
                             const Type*& header) {
  if (wire_type == nullptr || wire_type->resolved().kind != TypeKind::structure) return "is not a struct";
  const Type& wire = wire_type->resolved();
  const std::string shape = "{ " + std::string(header_name) + " header;" +
                            (payload_name.empty() ? std::string() : " " + payload_name + " <member>;") + " }";
  const std::size_t members = payload_name.empty() ? 1 : 2;
  if (wire.fields.size() != members) return "must be " + shape;
  header = &wire.fields[0].type->resolved();
  if (header->kind != TypeKind::structure || header->name != header_name) {
    return "must start with a " + std::string(header_name) + " (" + std::string(header_file) + "); expected " +
           shape;
  }
  if (members == 2) {
    const Type* payload = types.find(payload_name);
    if (payload == nullptr || &wire.fields[1].type->resolved() != &payload->resolved()) {
      return "must be " + shape + " (its second member is a '" + wire.fields[1].type->name + "')";
    }
    // Unbounded members live in a sample's tail, which a call does not carry (its payload
    // is the type's fixed part).
    if (has_unbounded(*payload)) {
      return "carries '" + payload_name +
             "', which has an unbounded string or sequence; service payloads must be bounded";
    }
    layout.body_offset = wire.fields[1].offset;
    layout.body_size = payload->size;
  }
  layout.type = &wire;
  return {};
}

bool add_rpc_service(Component& component, const PortSpec& spec, const TypeRegistry& types,
                     std::uint32_t max_in_flight, std::string_view kind, std::string_view address,
                     const RpcLayoutReader& read_layout, Diagnostics& diagnostics, RpcService& service) {
  bool ok = true;
  for (const OperationSpec& op : spec.operations) {
    RpcOperation operation;
    operation.name = op.name;
    operation.oneway = op.oneway;
    ok = read_layout(op, false, operation.request) && ok;
    if (!op.oneway) ok = read_layout(op, true, operation.reply) && ok;
    service.operations.push_back(std::move(operation));
  }
  if (spec.operations.empty()) {
    diagnostics.error(spec.where, {},
                      "service port '" + spec.name + "': " + std::string(kind) +
                          " lists its operations (each one is a request and a reply " + std::string(address) + ")");
    ok = false;
  }
  if (!ok) return false;
  if (spec.direction == PortDirection::provided) {
    service.provided =
        &component.add_port<ProvidedServicePort>(spec.name, spec.service_type, operations_of(spec, types));
  } else {
    service.required = &component.add_port<RequiredServicePort>(spec.name, spec.service_type,
                                                                 operations_of(spec, types), max_in_flight);
  }
  return true;
}

// ---- ServiceServer: polyport calls a service the foreign application provides --------------

ServiceServer::ServiceServer(const RpcService& service, std::uint32_t max_in_flight, std::int64_t timeout_ns,
                             std::string address_key)
    : service_(service),
      timeout_ns_(timeout_ns),
      address_key_(std::move(address_key)),
      slots_(std::max<std::uint32_t>(max_in_flight, 1)) {
  for (CallSlot& slot : slots_) buffers_for(slot, service_, false);
  service_.provided->set_target(this);
}

// The provided port keeps pointing here: the interceptor owning this goes just before the
// adaptor owning the port (Proxy), and nothing dispatches once the engine has stopped.
ServiceServer::~ServiceServer() { stop(); }

Result<void> ServiceServer::start(RpcTransport& transport) {
  if (active_.load()) return {};
  endpoints_.clear();
  endpoints_.resize(service_.operations.size());
  for (std::size_t i = 0; i < service_.operations.size(); ++i) {
    const RpcOperation& op = service_.operations[i];
    Endpoints& ends = endpoints_[i];
    auto sender = transport.sender(op.request);
    if (!sender) return make_error(op.request.address + ": " + sender.error().message);
    ends.request = std::move(sender).value();
    if (op.oneway) continue;
    ends.reply_flat = std::make_unique<std::byte[]>(op.reply.type->size);
    const auto index = static_cast<std::uint16_t>(i);
    auto receiver = transport.receiver(
        op.reply, [this, index](const std::byte* wire, std::uint32_t size) { on_reply(index, wire, size); });
    if (!receiver) return make_error(op.reply.address + ": " + receiver.error().message);
    ends.reply = std::move(receiver).value();
  }
  {
    std::lock_guard<std::mutex> lock(timer_mutex_);
    timer_stop_ = false;
  }
  timer_ = std::thread([this] { expire(); });
  active_.store(true, std::memory_order_seq_cst);
  return {};
}

void ServiceServer::stop() noexcept {
  active_.store(false, std::memory_order_seq_cst);
  while (in_submit_.load(std::memory_order_seq_cst) != 0) std::this_thread::yield();
  if (timer_.joinable()) {
    {
      std::lock_guard<std::mutex> lock(timer_mutex_);
      timer_stop_ = true;
    }
    timer_wake_.notify_all();
    timer_.join();
  }
  for (Endpoints& ends : endpoints_) ends.reply.reset();  // no reply callback after this
  for (CallSlot& slot : slots_) {
    std::uint8_t expected = CallSlot::pending;
    if (slot.state.compare_exchange_strong(expected, CallSlot::completing)) finish(slot, Status::not_active);
  }
  for (Endpoints& ends : endpoints_) {
    if (ends.request) retired_.push_back(std::move(ends.request));
  }
  endpoints_.clear();
}

Status ServiceServer::submit(PendingCall& call) noexcept {
  in_submit_.fetch_add(1, std::memory_order_seq_cst);
  counters_.calls.fetch_add(1, std::memory_order_relaxed);
  Status status = Status::ok;
  CallSlot* slot = nullptr;
  std::size_t index = 0;
  if (!active_.load(std::memory_order_seq_cst)) {
    status = Status::not_active;
  } else if (call.operation >= service_.operations.size()) {
    status = Status::unknown_operation;
  } else {
    for (; index < slots_.size(); ++index) {
      std::uint8_t expected = CallSlot::free;
      if (slots_[index].state.compare_exchange_strong(expected, CallSlot::claimed, std::memory_order_acq_rel)) {
        slot = &slots_[index];
        break;
      }
    }
    if (slot == nullptr) {
      status = Status::too_many_calls;
      counters_.refused.fetch_add(1, std::memory_order_relaxed);
    }
  }
  if (slot == nullptr) {
    counters_.errors.fetch_add(1, std::memory_order_relaxed);
    call.complete(status);
    in_submit_.fetch_sub(1, std::memory_order_seq_cst);
    return status;
  }

  const RpcOperation& op = service_.operations[call.operation];
  const RpcLayout& layout = op.request;
  Endpoints& ends = endpoints_[call.operation];
  // The sequence number names the slot (sequence % slots), so a reply finds it at once.
  slot->generation += 1;
  const std::uint64_t sequence = slot->generation * slots_.size() + index;
  slot->sequence.store(sequence, std::memory_order_relaxed);
  std::byte* flat = slot->flat.get();
  std::memset(flat, 0, layout.type->size);
  if (const std::uint8_t* caller = ends.request->caller()) {
    std::memcpy(flat + layout.caller_offset, caller, layout.caller_size);
  }
  store_u64(flat + layout.sequence_offset, sequence);
  if (layout.body_size != 0 && call.request_size == layout.body_size) {
    std::memcpy(flat + layout.body_offset, call.request, layout.body_size);
  }
  const CodecResult encoded = layout.codec->encode(flat, layout.type->size, slot->wire.get(), layout.max_size);
  if (!encoded.ok() || (layout.body_size != 0 && call.request_size != layout.body_size)) {
    slot->state.store(CallSlot::free, std::memory_order_release);
    status = encoded.ok() ? Status::bad_size : Status::error;
    counters_.errors.fetch_add(1, std::memory_order_relaxed);
    call.complete(status);
    in_submit_.fetch_sub(1, std::memory_order_seq_cst);
    return status;
  }
  slot->operation.store(call.operation, std::memory_order_relaxed);
  slot->call = &call;
  slot->deadline_ns.store((mono_now() + Nanos{timeout_ns_}).ns, std::memory_order_relaxed);
  // Pending before the send: a server in this process may reply inside it.
  slot->state.store(op.oneway ? CallSlot::completing : CallSlot::pending, std::memory_order_release);
  status = ends.request->send(slot->wire.get(), encoded.size);
  if (op.oneway) {
    finish(*slot, status);
  } else if (status != Status::ok) {
    std::uint8_t expected = CallSlot::pending;
    if (slot->state.compare_exchange_strong(expected, CallSlot::completing)) finish(*slot, status);
  }
  in_submit_.fetch_sub(1, std::memory_order_seq_cst);
  return status;
}

void ServiceServer::finish(CallSlot& slot, Status status) noexcept {
  PendingCall* call = slot.call;
  slot.call = nullptr;
  if (status == Status::ok) {
    counters_.replies.fetch_add(1, std::memory_order_relaxed);
  } else {
    counters_.errors.fetch_add(1, std::memory_order_relaxed);
    if (status == Status::timeout) counters_.timeouts.fetch_add(1, std::memory_order_relaxed);
  }
  slot.state.store(CallSlot::free, std::memory_order_release);
  if (call != nullptr) call->complete(status);
}

void ServiceServer::on_reply(std::uint16_t operation, const std::byte* wire, std::uint32_t size) noexcept {
  const RpcLayout& layout = service_.operations[operation].reply;
  Endpoints& ends = endpoints_[operation];
  std::byte* flat = ends.reply_flat.get();
  if (!layout.codec->decode(wire, size, flat, layout.type->size).ok()) {
    counters_.malformed.fetch_add(1, std::memory_order_relaxed);
    return;
  }
  // Replies reach every receiver of the reply topic or channel: keep those to our requests.
  const std::uint8_t* caller = ends.request->caller();
  if (caller != nullptr && std::memcmp(flat + layout.caller_offset, caller, layout.caller_size) != 0) {
    counters_.unmatched.fetch_add(1, std::memory_order_relaxed);
    return;
  }
  const std::uint64_t sequence = load_u64(flat + layout.sequence_offset);
  CallSlot& slot = slots_[sequence % slots_.size()];
  auto ours = [&] {
    return slot.sequence.load(std::memory_order_relaxed) == sequence &&
           slot.operation.load(std::memory_order_relaxed) == operation;
  };
  std::uint8_t expected = CallSlot::pending;
  if (!ours() || !slot.state.compare_exchange_strong(expected, CallSlot::completing, std::memory_order_acq_rel)) {
    counters_.unmatched.fetch_add(1, std::memory_order_relaxed);  // late (timed out) or a duplicate
    return;
  }
  if (!ours()) {
    // The slot was freed and taken by a newer call between the check and the exchange.
    slot.state.store(CallSlot::pending, std::memory_order_release);
    counters_.unmatched.fetch_add(1, std::memory_order_relaxed);
    return;
  }
  std::int32_t code = 0;
  std::memcpy(&code, flat + layout.status_offset, sizeof code);
  Status status = status_from_wire(code);
  PendingCall& call = *slot.call;
  if (status == Status::ok) {
    if (layout.body_size > call.reply_capacity) {
      status = Status::bad_size;
    } else {
      if (layout.body_size != 0) std::memcpy(call.reply, flat + layout.body_offset, layout.body_size);
      call.reply_size = layout.body_size;
    }
  }
  finish(slot, status);
}

void ServiceServer::expire() noexcept {
  // Wakes a few times per timeout, so a call ends at most a quarter timeout late.
  const auto period = std::chrono::nanoseconds(std::clamp<std::int64_t>(timeout_ns_ / 4, 1'000'000, 100'000'000));
  std::unique_lock<std::mutex> lock(timer_mutex_);
  while (!timer_stop_) {
    timer_wake_.wait_for(lock, period, [this] { return timer_stop_; });
    const std::int64_t now = mono_now().ns;
    for (CallSlot& slot : slots_) {
      // The call whose deadline is read: its sequence number, read before its state (a newer
      // call writes its sequence number when it claims the slot, its deadline before it
      // stores pending).
      const std::uint64_t sequence = slot.sequence.load(std::memory_order_acquire);
      if (slot.state.load(std::memory_order_acquire) != CallSlot::pending ||
          slot.deadline_ns.load(std::memory_order_relaxed) > now) {
        continue;
      }
      std::uint8_t expected = CallSlot::pending;
      if (!slot.state.compare_exchange_strong(expected, CallSlot::completing)) continue;
      if (slot.sequence.load(std::memory_order_acquire) != sequence) {
        // The expired call ended and a newer one took the slot meanwhile: not this one's
        // deadline. Back to pending (a reply in this short window is lost; the call then
        // times out on its own deadline).
        slot.state.store(CallSlot::pending, std::memory_order_release);
        continue;
      }
      finish(slot, Status::timeout);
    }
  }
}

void ServiceServer::describe(nlohmann::json& out) const {
  nlohmann::json operations = nlohmann::json::array();
  for (std::size_t i = 0; i < service_.operations.size(); ++i) {
    nlohmann::json o = operation_json(service_.operations[i], address_key_);
    if (i < endpoints_.size()) {
      if (endpoints_[i].request) endpoints_[i].request->describe(o);
      if (endpoints_[i].reply) endpoints_[i].reply->describe(o);
    }
    operations.push_back(std::move(o));
  }
  out = {{"port", service_.provided->name()},
         {"polyport", "calls"},
         {"max_calls_in_flight", slots_.size()},
         {"call_timeout_ms", static_cast<double>(timeout_ns_) / 1e6},
         {"operations", std::move(operations)},
         {"counters", counters_json(counters_)}};
}

// ---- ServiceClient: the foreign application calls a service polyport forwards in-process ---

ServiceClient::ServiceClient(const RpcService& service, std::uint32_t max_in_flight, std::string address_key)
    : service_(service), address_key_(std::move(address_key)), slots_(std::max<std::uint32_t>(max_in_flight, 1)) {
  for (CallSlot& slot : slots_) buffers_for(slot, service_, true);
}

ServiceClient::~ServiceClient() { stop(); }

Result<void> ServiceClient::start(RpcTransport& transport) {
  if (endpoints_.empty()) {
    // Senders and buffers once: a completion of a call from before a stop may still use them.
    for (const RpcOperation& op : service_.operations) {
      auto ends = std::make_unique<Endpoints>();
      ends->request_flat = std::make_unique<std::byte[]>(op.request.type->size);
      if (!op.oneway) {
        auto sender = transport.sender(op.reply);
        if (!sender) {
          endpoints_.clear();
          return make_error(op.reply.address + ": " + sender.error().message);
        }
        ends->reply_owner = std::move(sender).value();
        ends->refusal_flat = std::make_unique<std::byte[]>(op.reply.type->size);
        ends->refusal_wire = std::make_unique<std::byte[]>(op.reply.max_size);
      }
      endpoints_.push_back(std::move(ends));
    }
  }
  for (auto& ends : endpoints_) ends->reply.store(ends->reply_owner.get(), std::memory_order_release);
  // Receivers last: a request may arrive as soon as one exists.
  for (std::size_t i = 0; i < service_.operations.size(); ++i) {
    const auto index = static_cast<std::uint16_t>(i);
    auto receiver = transport.receiver(service_.operations[i].request, [this, index](const std::byte* wire,
                                                                                     std::uint32_t size) {
      on_request(index, wire, size);
    });
    if (!receiver) {
      stop();
      return make_error(service_.operations[i].request.address + ": " + receiver.error().message);
    }
    endpoints_[i]->request = std::move(receiver).value();
  }
  return {};
}

void ServiceClient::stop() noexcept {
  for (auto& ends : endpoints_) ends->request.reset();  // no request callback after this
  // Calls still in the provider complete later; their replies are dropped.
  for (auto& ends : endpoints_) ends->reply.store(nullptr, std::memory_order_release);
}

void ServiceClient::on_request(std::uint16_t operation, const std::byte* wire, std::uint32_t size) noexcept {
  const RpcOperation& op = service_.operations[operation];
  Endpoints& ends = *endpoints_[operation];
  std::byte* flat = ends.request_flat.get();
  if (!op.request.codec->decode(wire, size, flat, op.request.type->size).ok()) {
    counters_.malformed.fetch_add(1, std::memory_order_relaxed);
    return;
  }
  counters_.calls.fetch_add(1, std::memory_order_relaxed);
  const std::byte* body = op.request.body_size != 0 ? flat + op.request.body_offset : nullptr;
  if (op.oneway) {
    const Status status = service_.required->send(op.name, body, op.request.body_size);
    if (status != Status::ok) counters_.errors.fetch_add(1, std::memory_order_relaxed);
    return;
  }
  std::uint8_t caller[kMaxCallerBytes] = {};
  std::memcpy(caller, flat + op.request.caller_offset, op.request.caller_size);
  const std::uint64_t sequence = load_u64(flat + op.request.sequence_offset);

  std::size_t index = 0;
  for (; index < slots_.size(); ++index) {
    std::uint8_t expected = CallSlot::free;
    if (slots_[index].state.compare_exchange_strong(expected, CallSlot::pending, std::memory_order_acq_rel)) break;
  }
  if (index == slots_.size()) {
    counters_.refused.fetch_add(1, std::memory_order_relaxed);
    reply(operation, caller, sequence, Status::too_many_calls, nullptr, 0, ends.refusal_flat.get(),
          ends.refusal_wire.get());
    return;
  }
  CallSlot& slot = slots_[index];
  slot.operation.store(operation, std::memory_order_relaxed);
  std::memcpy(slot.caller, caller, kMaxCallerBytes);
  slot.caller_sequence = sequence;
  const Status status = service_.required->request_async(op.name, body, op.request.body_size, *this, index);
  if (status != Status::ok) {
    // Not started (not connected, no slot in the port's pool...): the observer is not called.
    slot.state.store(CallSlot::free, std::memory_order_release);
    reply(operation, caller, sequence, status, nullptr, 0, ends.refusal_flat.get(), ends.refusal_wire.get());
  }
}

void ServiceClient::on_call_complete(const PendingCall& call, Status status, std::uint64_t tag) noexcept {
  CallSlot& slot = slots_[tag];
  const std::uint32_t body_size = status == Status::ok ? call.reply_size : 0;
  reply(slot.operation.load(std::memory_order_relaxed), slot.caller, slot.caller_sequence, status, call.reply,
        body_size, slot.flat.get(), slot.wire.get());
  slot.state.store(CallSlot::free, std::memory_order_release);
}

void ServiceClient::reply(std::uint16_t operation, const std::uint8_t* caller, std::uint64_t sequence, Status status,
                          const std::byte* body, std::uint32_t body_size, std::byte* flat, std::byte* wire) noexcept {
  const RpcLayout& layout = service_.operations[operation].reply;
  if (status == Status::ok && body_size != layout.body_size) status = Status::bad_size;
  std::memset(flat, 0, layout.type->size);
  std::memcpy(flat + layout.caller_offset, caller, layout.caller_size);
  store_u64(flat + layout.sequence_offset, sequence);
  const auto code = static_cast<std::int32_t>(status);
  std::memcpy(flat + layout.status_offset, &code, sizeof code);
  if (status == Status::ok && body_size != 0) std::memcpy(flat + layout.body_offset, body, body_size);
  (status == Status::ok ? counters_.replies : counters_.errors).fetch_add(1, std::memory_order_relaxed);
  RpcSender* sender = endpoints_[operation]->reply.load(std::memory_order_acquire);
  if (sender == nullptr) return;  // stopped: the foreign caller times out by itself
  const CodecResult encoded = layout.codec->encode(flat, layout.type->size, wire, layout.max_size);
  if (!encoded.ok() || sender->send(wire, encoded.size) != Status::ok) {
    counters_.errors.fetch_add(1, std::memory_order_relaxed);
  }
}

void ServiceClient::describe(nlohmann::json& out) const {
  nlohmann::json operations = nlohmann::json::array();
  for (std::size_t i = 0; i < service_.operations.size(); ++i) {
    nlohmann::json o = operation_json(service_.operations[i], address_key_);
    if (i < endpoints_.size() && endpoints_[i]->request) endpoints_[i]->request->describe(o);
    operations.push_back(std::move(o));
  }
  out = {{"port", service_.required->name()},
         {"polyport", "serves"},
         {"max_calls_in_flight", slots_.size()},
         {"operations", std::move(operations)},
         {"counters", counters_json(counters_)}};
}

}  // namespace polyport
