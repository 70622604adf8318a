// In-process components of the push tests (a plugin of their own):
//  - PushTicker: a push server port `ticks`; each cycle it puts the next count with how many
//    subscribes and unsubscribes it was told of, and stops ("not active") at `stop_at`;
//  - PushWatcher: a push client port `ticks`; it republishes each update on `seen`, and once
//    the server says not_active, a tick with n = -1. With `every` > 0 it subscribes itself
//    with that multiple on its first cycle.
#include "polyport/runtime/push_ports.hpp"

namespace polyport {
namespace {

struct Tick {
  std::int64_t n;
  std::int32_t subscribes;
  std::int32_t unsubscribes;
};

class PushTicker final : public ComponentBase {
 public:
  ReturnCode onInitialize() override {
    stop_at_ = property_int("stop_at", 0);
    return ReturnCode::ok;
  }
  ReturnCode onExecute() override {
    SubscriptionChange change;
    while (ticks_.next_change(change)) {
      if (change.kind == SubscriptionChange::Kind::subscribe) {
        ++subscribes_;
      } else {
        ++unsubscribes_;
      }
    }
    ++n_;
    if (stop_at_ > 0 && n_ == stop_at_) ticks_.stop();
    (void)ticks_.put(Tick{n_, subscribes_, unsubscribes_});
    return ReturnCode::ok;
  }

 private:
  PushServerPort<Tick> ticks_{*this, "ticks"};
  std::int64_t n_ = 0;
  std::int64_t stop_at_ = 0;
  std::int32_t subscribes_ = 0;
  std::int32_t unsubscribes_ = 0;
};

class PushWatcher final : public ComponentBase {
 public:
  ReturnCode onInitialize() override {
    every_ = property_int("every", 0);
    return ReturnCode::ok;
  }
  ReturnCode onExecute() override {
    if (every_ > 0) {
      (void)ticks_.subscribe(static_cast<std::uint32_t>(every_));
      every_ = 0;
    }
    Tick tick{};
    Status status = Status::ok;
    while ((status = ticks_.get_update(tick)) == Status::ok) seen_.write(tick);
    if (status == Status::not_active && !told_) {
      told_ = true;
      seen_.write(Tick{-1, 0, 0});
    }
    return ReturnCode::ok;
  }

 private:
  PushClientPort<Tick> ticks_{*this, "ticks"};
  OutPort<Tick> seen_{*this, "seen"};
  std::int64_t every_ = 0;
  bool told_ = false;
};

}  // namespace

POLYPORT_COMPONENTS(POLYPORT_COMPONENT(PushTicker), POLYPORT_COMPONENT(PushWatcher))

}  // namespace polyport
