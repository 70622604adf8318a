// The in-process component API of SmartSoft's push patterns (push_server.hpp):
//
//   class Odometry : public polyport::ComponentBase {
//     polyport::PushServerPort<Pose> pose_{*this, "pose"};   // <push pattern="timed" cycle_ms="20"/>
//     polyport::ReturnCode onExecute() override {
//       polyport::SubscriptionChange change;
//       while (pose_.next_change(change)) { ... change.kind, change.every, change.subscriber ... }
//       pose_.put(current_pose());       // not_active while stopped
//       ...
//   class Planner : public polyport::ComponentBase {
//     polyport::PushClientPort<Pose> pose_{*this, "pose"};
//     ... pose_.subscribe(5); pose_.get_update(p) == Status::ok ... pose_.unsubscribe();
//
// The pattern and base cycle are the component profile's (<push> in the port's <data_port>):
// the same class serves push newest and push timed.
#pragma once

#include "polyport/runtime/component_api.hpp"
#include "polyport/runtime/connection.hpp"
#include "polyport/runtime/push_server.hpp"

namespace polyport {

template <class T>
class PushServerPort {
 public:
  PushServerPort(ComponentBase& owner, std::string name) : port_(owner, std::move(name)) {}
  // Sends a new value to every subscriber (push timed: once per base cycle; an in-process
  // periodic component calls it each period, and the port sends the first of each cycle).
  Status put(const T& value) noexcept { return port_.write(value); }
  // SmartSoft's server start / stop: stopped ("not active"), put() sends nothing and
  // subscribers' reads return Status::not_active. A port without <push> is always active.
  void start() noexcept {
    if (PushServer* push = port_.port().push()) push->start();
  }
  void stop() noexcept {
    if (PushServer* push = port_.port().push()) push->stop();
  }
  bool active() const noexcept {
    const PushServer* push = port_.port().push();
    return push == nullptr || push->active();
  }
  std::size_t subscribers() const noexcept { return port_.port().connections().size(); }
  // The next subscribe / unsubscribe since the last call (see PushServer::next_change).
  bool next_change(SubscriptionChange& change) noexcept {
    PushServer* push = port_.port().push();
    return push != nullptr && push->next_change(change);
  }
  DataOutPort& port() const noexcept { return port_.port(); }

 private:
  OutPort<T> port_;
};

template <class T>
class PushClientPort {
 public:
  PushClientPort(ComponentBase& owner, std::string name) : port_(owner, std::move(name)) {}
  // ok: a new value; old_data: the latest again (data policy); no_data: nothing yet or not
  // subscribed; not_active: the server is stopped (after what it sent before was read).
  Status get_update(T& value) noexcept { return port_.read(value); }
  // Subscribes again, every `every`-th base cycle of a push timed server (1: each; ignored
  // by push newest). Returns not_connected when no push server is connected, bad_size for 0.
  // The server is told. Not for the forwarding path: it names the subscriber in a string.
  Status subscribe(std::uint32_t every = 1) { return change(SubscriptionChange::Kind::subscribe, every); }
  Status unsubscribe() { return change(SubscriptionChange::Kind::unsubscribe, 0); }
  DataInPort& port() const noexcept { return port_.port(); }

 private:
  Status change(SubscriptionChange::Kind kind, std::uint32_t every) {
    if (kind == SubscriptionChange::Kind::subscribe && every == 0) return Status::bad_size;
    Status status = Status::not_connected;
    for (Connection* connection : port_.port().connections().current()) {
      PushServer* push = connection->source().push();
      if (push == nullptr) continue;
      if (kind == SubscriptionChange::Kind::unsubscribe) {
        connection->unsubscribe();
        push->tell(kind, *connection, std::max<std::uint32_t>(connection->subscription_every(), 1));
      } else {
        connection->set_subscription(push->pattern() == PushPattern::timed ? every : 0);
        push->tell(kind, *connection, every);
      }
      status = Status::ok;
    }
    return status;
  }

  InPort<T> port_;
};

}  // namespace polyport
