// Ports and the writer's side of the data path. See port.hpp for who owns what and which
// thread runs what.
#include "polyport/runtime/port.hpp"

#include <algorithm>

#include "polyport/base/serial_counter.hpp"
#include "polyport/runtime/component.hpp"
#include "polyport/runtime/connection.hpp"
#include "polyport/runtime/push_server.hpp"

namespace polyport {

Port::Port(Component& owner, std::string name, PortKind kind, PortDirection direction, const Type* type)
    : owner_(owner), name_(std::move(name)), kind_(kind), direction_(direction), type_(type) {}

Port::~Port() = default;

std::string Port::full_name() const { return owner_.name() + "." + name_; }

ConnectionSet::ConnectionSet() { publish({}); }

void ConnectionSet::publish(const std::vector<Connection*>& items) {
  auto list = std::make_unique<List>();
  list->size = items.size();
  Connection** storage = list->inline_;
  if (items.size() > List::kInline) {
    list->spill_ = std::make_unique<Connection*[]>(items.size());
    storage = list->spill_.get();
  }
  std::copy(items.begin(), items.end(), storage);
  list->items = storage;
  current_.store(list.get(), std::memory_order_release);
  retained_.push_back(std::move(list));
}

void ConnectionSet::add(Connection& connection) {
  std::vector<Connection*> items(current().begin(), current().end());
  items.push_back(&connection);
  if (observer_) observer_->adding(connection);
  publish(items);
  if (observer_) observer_->added(connection);
}

void ConnectionSet::remove(Connection& connection) {
  std::vector<Connection*> items(current().begin(), current().end());
  const std::size_t before = items.size();
  items.erase(std::remove(items.begin(), items.end(), &connection), items.end());
  publish(items);
  if (observer_ && items.size() != before) observer_->removed(connection);
}

DataOutPort::DataOutPort(Component& owner, std::string name, PortKind kind, const Type* type,
                         std::uint32_t max_sample_bytes)
    : Port(owner, std::move(name), kind, PortDirection::output, type), max_sample_bytes_(max_sample_bytes) {}

DataOutPort::~DataOutPort() = default;

void DataOutPort::set_push(std::unique_ptr<PushServer> push) {
  push_ = std::move(push);
  connections_.set_observer(push_.get());
}

Status DataOutPort::write(const void* data, std::uint32_t size, MonoTime t_source) noexcept {
  if (push_) return push_->write(data, size, t_source);
  return forward(data, size, t_source);
}

Status DataOutPort::forward(const void* data, std::uint32_t size, MonoTime t_source) noexcept {
  add_serial(written_);  // one writer at a time (port.hpp)
  const MonoTime now = mono_now();
  last_write_.store(now.ns, std::memory_order_relaxed);
  const ConnectionSet::List& list = connections_.current();
  if (list.size == 0) {
    add_serial(unconnected_);
    return Status::not_connected;
  }
  const SampleMeta meta{size, now, t_source};
  const auto* bytes = static_cast<const std::byte*>(data);
  for (Connection* connection : list) connection->deliver(bytes, meta);
  return Status::ok;
}

DataInPort::DataInPort(Component& owner, std::string name, PortKind kind, const Type* type,
                       std::uint32_t max_sample_bytes, QueuePolicy policy, std::uint32_t depth)
    : Port(owner, std::move(name), kind, PortDirection::input, type),
      max_sample_bytes_(max_sample_bytes),
      policy_(policy),
      depth_(depth) {}

Status DataInPort::read(void* dst, std::uint32_t capacity, SampleMeta* meta) noexcept {
  const ConnectionSet::List& list = connections_.current();
  if (list.size == 0) return Status::no_data;
  SampleMeta local{};
  SampleMeta& out = meta ? *meta : local;
  auto* bytes = static_cast<std::byte*>(dst);
  bool any_old = false;
  // Round robin so that one busy connection cannot starve the others of a queue port.
  for (std::size_t i = 0; i < list.size; ++i) {
    const std::size_t index = (next_ + i) % list.size;
    switch (list.items[index]->take(bytes, capacity, out)) {
      case PopResult::new_data:
        next_ = index + 1;
        return Status::ok;
      case PopResult::old_data:
        any_old = true;
        break;
      case PopResult::too_small:
        return Status::bad_size;
      case PopResult::no_data:
        break;
    }
  }
  // A stopped push server's subscribers are told so once they have read what came before.
  for (const Connection* connection : list) {
    if (const PushServer* push = connection->source().push(); push != nullptr && !push->active()) {
      return Status::not_active;
    }
  }
  // With several `data` connections, old_data leaves the value of the last one with data.
  return any_old ? Status::old_data : Status::no_data;
}

}  // namespace polyport
