// An event connection's condition. admits() runs on the source's writer thread (the
// forwarding path); activations on the client's or the control thread. The thresholds'
// storage is allocated in the constructor and never again.
#include "polyport/runtime/event_condition.hpp"

#include <algorithm>
#include <cstring>

#include "polyport/codecs/mapping.hpp"
#include "polyport/runtime/connection.hpp"
#include "polyport/runtime/port.hpp"

namespace polyport {

double flat_number(const std::byte* flat, std::uint32_t offset, TypeKind kind) noexcept {
  const std::byte* at = flat + offset;
  const auto get = [at](auto value) {
    std::memcpy(&value, at, sizeof value);
    return static_cast<double>(value);
  };
  switch (kind) {
    case TypeKind::int8: return get(std::int8_t{});
    case TypeKind::uint8: case TypeKind::octet: return get(std::uint8_t{});
    case TypeKind::int16: return get(std::int16_t{});
    case TypeKind::uint16: return get(std::uint16_t{});
    case TypeKind::int32: return get(std::int32_t{});
    case TypeKind::uint32: return get(std::uint32_t{});
    case TypeKind::int64: return get(std::int64_t{});
    case TypeKind::uint64: return get(std::uint64_t{});
    case TypeKind::float32: return get(float{});
    case TypeKind::float64: return get(double{});
    default: return 0.0;
  }
}

namespace {

// A NaN holds for `ne` only, as in C.
bool holds(double field, ConditionOp op, double threshold) noexcept {
  switch (op) {
    case ConditionOp::lt: return field < threshold;
    case ConditionOp::le: return field <= threshold;
    case ConditionOp::gt: return field > threshold;
    case ConditionOp::ge: return field >= threshold;
    case ConditionOp::eq: return field == threshold;
    case ConditionOp::ne: return field != threshold;
  }
  return false;
}

}  // namespace

EventCondition::EventCondition(std::vector<ConditionField> fields, EventMode mode, bool active)
    : fields_(std::move(fields)),
      thresholds_(std::make_unique<std::atomic<double>[]>(fields_.size())),
      scratch_(std::make_unique<double[]>(fields_.size())),
      last_thresholds_(std::make_unique<double[]>(fields_.size())) {
  std::vector<double> values;
  for (const ConditionField& field : fields_) values.push_back(field.value);
  publish(active, mode, values.data());
  const bool whole = read(last_, last_thresholds_.get());  // no activation runs concurrently yet
  (void)whole;
  if (active) counters_.activations.fetch_add(1, std::memory_order_relaxed);
}

void EventCondition::publish(bool active, EventMode mode, const double* thresholds) noexcept {
  const std::uint64_t sequence = sequence_.load(std::memory_order_relaxed);
  sequence_.store(sequence + 1, std::memory_order_relaxed);  // odd: being written
  std::atomic_thread_fence(std::memory_order_release);
  active_.store(active, std::memory_order_relaxed);
  mode_.store(mode, std::memory_order_relaxed);
  generation_.store(generation_.load(std::memory_order_relaxed) + 1, std::memory_order_relaxed);
  for (std::size_t i = 0; i < fields_.size(); ++i) thresholds_[i].store(thresholds[i], std::memory_order_relaxed);
  sequence_.store(sequence + 2, std::memory_order_release);
}

bool EventCondition::read(Snapshot& snapshot, double* thresholds) const noexcept {
  const std::uint64_t before = sequence_.load(std::memory_order_acquire);
  if (before & 1u) return false;  // an activation is being written
  snapshot = Snapshot{active_.load(std::memory_order_relaxed), mode_.load(std::memory_order_relaxed),
                      generation_.load(std::memory_order_relaxed)};
  for (std::size_t i = 0; i < fields_.size(); ++i) thresholds[i] = thresholds_[i].load(std::memory_order_relaxed);
  std::atomic_thread_fence(std::memory_order_acquire);
  return sequence_.load(std::memory_order_relaxed) == before;
}

// The writer never waits for an activation being written (its thread may be a real-time one
// on the activator's CPU): it tests against the last activation it read whole, as if the
// sample had come just before the new one.
bool EventCondition::admits(const std::byte* flat) noexcept {
  Snapshot now{};
  if (read(now, scratch_.get())) {
    last_ = now;
    std::copy_n(scratch_.get(), fields_.size(), last_thresholds_.get());
  }
  now = last_;
  const bool spent = now.mode == EventMode::single && spent_.load(std::memory_order_relaxed) == now.generation;
  if (!now.active || spent) {
    counters_.inactive.fetch_add(1, std::memory_order_relaxed);
    return false;
  }
  counters_.tested.fetch_add(1, std::memory_order_relaxed);
  for (std::size_t i = 0; i < fields_.size(); ++i) {
    if (!holds(flat_number(flat, fields_[i].offset, fields_[i].kind), fields_[i].op, last_thresholds_[i])) {
      counters_.suppressed.fetch_add(1, std::memory_order_relaxed);
      return false;
    }
  }
  if (now.mode == EventMode::single) spent_.store(now.generation, std::memory_order_relaxed);
  counters_.fired.fetch_add(1, std::memory_order_relaxed);
  return true;
}

bool EventCondition::knows(std::span<const ConditionParameter> parameters) const noexcept {
  for (const ConditionParameter& parameter : parameters) {
    if (!uses(parameter.name)) return false;
  }
  return true;
}

Status EventCondition::activate(EventMode mode, std::span<const ConditionParameter> parameters) noexcept {
  if (!knows(parameters)) return Status::error;
  apply(mode, parameters);
  return Status::ok;
}

bool EventCondition::uses(std::string_view parameter) const noexcept {
  for (const ConditionField& field : fields_) {
    if (!field.param.empty() && field.param == parameter) return true;
  }
  return false;
}

void EventCondition::apply(EventMode mode, std::span<const ConditionParameter> parameters) noexcept {
  const std::lock_guard<PiMutex> lock(activating_);
  // Room for the thresholds without allocating: the writer's scratch is not this thread's,
  // so a small array on the stack, in chunks when a condition has many fields.
  constexpr std::size_t kOnStack = 32;
  double values[kOnStack];
  const std::size_t count = fields_.size();
  std::unique_ptr<double[]> many;
  double* thresholds = values;
  if (count > kOnStack) {
    many = std::make_unique<double[]>(count);  // not on any forwarding path
    thresholds = many.get();
  }
  for (std::size_t i = 0; i < count; ++i) {
    thresholds[i] = fields_[i].value;
    for (const ConditionParameter& parameter : parameters) {
      if (!fields_[i].param.empty() && fields_[i].param == parameter.name) thresholds[i] = parameter.value;
    }
  }
  publish(true, mode, thresholds);
  counters_.activations.fetch_add(1, std::memory_order_relaxed);
}

void EventCondition::deactivate() noexcept {
  const std::lock_guard<PiMutex> lock(activating_);
  // The thresholds stay as they were (stats show them); only `active` changes.
  constexpr std::size_t kOnStack = 32;
  double values[kOnStack];
  std::unique_ptr<double[]> many;
  double* thresholds = values;
  if (fields_.size() > kOnStack) {
    many = std::make_unique<double[]>(fields_.size());
    thresholds = many.get();
  }
  for (std::size_t i = 0; i < fields_.size(); ++i) thresholds[i] = thresholds_[i].load(std::memory_order_relaxed);
  publish(false, mode_.load(std::memory_order_relaxed), thresholds);
}

bool EventCondition::active() const noexcept {
  const bool active = active_.load(std::memory_order_relaxed);
  if (!active || mode_.load(std::memory_order_relaxed) != EventMode::single) return active;
  return spent_.load(std::memory_order_relaxed) != generation_.load(std::memory_order_relaxed);
}

EventMode EventCondition::mode() const noexcept { return mode_.load(std::memory_order_relaxed); }

std::vector<double> EventCondition::thresholds() const {
  std::vector<double> values(fields_.size());
  for (std::size_t i = 0; i < fields_.size(); ++i) values[i] = thresholds_[i].load(std::memory_order_relaxed);
  return values;
}

Result<std::unique_ptr<EventCondition>> make_event_condition(const Type& source_type, const ConditionSpec& spec) {
  std::vector<ConditionField> fields;
  for (const ConditionFieldSpec& field : spec.fields) {
    const FieldPathResult found = find_field_path(source_type, field.field);
    if (!found.place) return make_error("condition field '" + field.field + "' not found in '" + source_type.name + "'");
    if (!is_number(found.place->type->kind)) {
      return make_error("condition field '" + field.field + "' of '" + source_type.name + "' is not a number");
    }
    fields.push_back(
        ConditionField{found.place->offset, found.place->type->kind, field.op, field.value, field.param, field.field});
  }
  return std::make_unique<EventCondition>(std::move(fields), spec.mode, spec.active);
}

Status activate_conditions(DataInPort& port, EventMode mode, std::span<const ConditionParameter> parameters) noexcept {
  // All or none: a parameter that no condition uses changes none of them. A port with
  // several conditions gives each the parameters it uses.
  bool any = false;
  for (const ConditionParameter& parameter : parameters) {
    bool used = false;
    for (Connection* connection : port.connections().current()) {
      if (const EventCondition* condition = connection->condition()) used = used || condition->uses(parameter.name);
    }
    if (!used) return Status::error;
  }
  for (Connection* connection : port.connections().current()) {
    if (EventCondition* condition = connection->condition()) {
      condition->apply(mode, parameters);
      any = true;
    }
  }
  return any ? Status::ok : Status::not_connected;
}

Status deactivate_conditions(DataInPort& port) noexcept {
  bool any = false;
  for (Connection* connection : port.connections().current()) {
    if (EventCondition* condition = connection->condition()) {
      condition->deactivate();
      any = true;
    }
  }
  return any ? Status::ok : Status::not_connected;
}

}  // namespace polyport
