// Small components that the tests load through the in-process model, like any plugin.
#include <cstdint>
#include <string>
#include <string_view>
#include <thread>

#include "polyport/runtime/component_api.hpp"

namespace polyport::test {

struct Pair {
  std::int32_t a;
  std::int32_t b;
};
struct Sum {
  std::int32_t value;
};

// Counts its cycles on an output port.
class Ticker final : public ComponentBase {
 public:
  ReturnCode onExecute() override {
    ++count_;
    out_.write(count_);
    return ReturnCode::ok;
  }

 private:
  OutPort<std::int64_t> out_{*this, "count"};
  std::int64_t count_ = 0;
};

// Reads whatever arrives and republishes the latest value it saw.
class Collector final : public ComponentBase {
 public:
  ReturnCode onExecute() override {
    std::int64_t value = 0;
    while (in_.read(value) == Status::ok) last_ = value;
    seen_.write(last_);
    return ReturnCode::ok;
  }

 private:
  InPort<std::int64_t> in_{*this, "in"};
  OutPort<std::int64_t> seen_{*this, "seen"};
  std::int64_t last_ = 0;
};

// Provides `add`, run on its own execution context between cycles.
class Adder final : public ComponentBase {
 public:
  Adder() {
    calc_.provide<Pair, Sum>("add", [](const Pair& p, Sum& s) {
      s.value = p.a + p.b;
      return ReturnCode::ok;
    });
  }

 private:
  ProvidedService calc_{*this, "calc"};
};

// Calls `add` every cycle and publishes the sums it gets back.
class Caller final : public ComponentBase {
 public:
  ReturnCode onExecute() override {
    ++n_;
    Sum sum{};
    const Status status = calc_.query("add", Pair{n_, 1000}, sum, Nanos{200'000'000});
    if (status == Status::ok) sums_.write(static_cast<std::int64_t>(sum.value));
    return ReturnCode::ok;
  }

 private:
  RequiredService calc_{*this, "calc"};
  OutPort<std::int64_t> sums_{*this, "sums"};
  std::int32_t n_ = 0;
};

// Fails in onExecute once its count reaches the `fail_at` property.
class Faulty final : public ComponentBase {
 public:
  ReturnCode onExecute() override { return ++count_ >= property_int("fail_at", 5) ? ReturnCode::error : ReturnCode::ok; }

 private:
  std::int64_t count_ = 0;
};

// Declares its count port with a C++ type that does not match an int64 profile type.
class WrongSize final : public ComponentBase {
 private:
  OutPort<std::int32_t> out_{*this, "count"};
};

// tests/dds_peers/peer.idl's types in their flat layout (types.hpp): string<15> is char[16],
// sequence<double, 8> a length then 8 elements.
struct PeerPose {
  std::int32_t id;
  double x;
  float heading;
  bool valid;
  char frame[16];
  struct {
    std::uint32_t length;
    double items[8];
  } samples;
  std::int16_t quad[4];
};
struct PeerAddArgs {
  double a;
  double b;
};
struct PeerAddResult {
  double sum;
};

// Republishes every pose it receives with its id raised by 100000 (so a test tells relayed
// poses from the originals), every other field untouched.
class PoseRelay final : public ComponentBase {
 public:
  ReturnCode onExecute() override {
    PeerPose pose{};
    while (in_.read(pose) == Status::ok) {
      pose.id += 100000;
      out_.write(pose);
    }
    return ReturnCode::ok;
  }

 private:
  InPort<PeerPose> in_{*this, "in"};
  OutPort<PeerPose> out_{*this, "out"};
};

// Provides peer `add` (a + b), run on its own execution context between cycles.
class PeerAdder final : public ComponentBase {
 public:
  PeerAdder() {
    calc_.provide<PeerAddArgs, PeerAddResult>("add", [](const PeerAddArgs& args, PeerAddResult& result) {
      result.sum = args.a + args.b;
      return ReturnCode::ok;
    });
  }

 private:
  ProvidedService calc_{*this, "calc"};
};

// Calls peer `add` (n, 0.5) every cycle, n = 1, 2, ..., and publishes each sum it gets back.
class PeerCaller final : public ComponentBase {
 public:
  ReturnCode onExecute() override {
    ++n_;
    PeerAddResult result{};
    if (calc_.query("add", PeerAddArgs{static_cast<double>(n_), 0.5}, result, Nanos{500'000'000}) == Status::ok) {
      sums_.write(result);
    }
    return ReturnCode::ok;
  }

 private:
  RequiredService calc_{*this, "calc"};
  OutPort<PeerAddResult> sums_{*this, "sums"};
  std::int32_t n_ = 0;
};

// Publishes its `step` property every cycle, and whether its last onPropertyChanged ran on
// the thread that runs its onExecute (1), another thread (0), or has not run (-1). Takes
// changes of `step` (an integer >= 0) while it runs; refuses a negative one (bad_parameter)
// and changes of any other property (unsupported). A negative `step` in its profile fails
// its initialization.
class Tunable final : public ComponentBase {
 public:
  ReturnCode onInitialize() override {
    step_ = property_int("step", 1);
    return step_ < 0 ? ReturnCode::bad_parameter : ReturnCode::ok;
  }
  ReturnCode onExecute() override {
    execute_thread_ = std::this_thread::get_id();
    step_out_.write(step_);
    hook_out_.write(hook_on_execute_thread_);
    return ReturnCode::ok;
  }
  ReturnCode onPropertyChanged(std::string_view name, std::string_view) override {
    hook_on_execute_thread_ = std::this_thread::get_id() == execute_thread_ ? 1 : 0;
    if (name != "step") return ReturnCode::unsupported;
    const std::int64_t step = property_int("step", -1);
    if (step < 0) return ReturnCode::bad_parameter;
    step_ = step;
    return ReturnCode::ok;
  }

 private:
  OutPort<std::int64_t> step_out_{*this, "step"};
  OutPort<std::int64_t> hook_out_{*this, "hook_on_ec"};
  std::int64_t step_ = 1;
  std::int64_t hook_on_execute_thread_ = -1;
  std::thread::id execute_thread_;
};

// tests/data/condevents/battery.idl's cond::BatteryState in its flat layout.
struct BatteryState {
  double charge;
  std::int32_t cycle;
  char note[16];
};

// An event server's state: every cycle a new charge, 100 down to 0, then 100 again.
class BatteryServer final : public ComponentBase {
 public:
  ReturnCode onExecute() override {
    BatteryState state{};
    state.charge = static_cast<double>(100 - cycle_ % 101);
    state.cycle = cycle_++;
    state_.raise(state);
    return ReturnCode::ok;
  }

 private:
  EventOutPort<BatteryState> state_{*this, "state"};
  std::int32_t cycle_ = 0;
};

// An event client. With a `mode` property (single / continuous) it activates its event on its
// first cycle with parameter level = its `level` property, and then holds the server to it:
// an event whose charge is not below the level puts it in error. Publishes how many events
// it took.
class ConditionClient final : public ComponentBase {
 public:
  ReturnCode onExecute() override {
    const std::string mode = property("mode");
    const double level = property_double("level", 0.0);
    if (!activated_ && !mode.empty()) {
      activated_ = true;
      const EventMode wanted = mode == "single" ? EventMode::single : EventMode::continuous;
      if (low_.activate(wanted, {{"level", level}}) != Status::ok) return ReturnCode::error;
      // A parameter no field names is refused and changes nothing.
      if (low_.activate(wanted, {{"no_such_parameter", 1.0}}) != Status::error) return ReturnCode::error;
    }
    BatteryState event{};
    while (low_.take(event) == Status::ok) {
      ++events_;
      if (!mode.empty() && !(event.charge < level)) return ReturnCode::error;
    }
    events_out_.write(events_);
    return ReturnCode::ok;
  }

 private:
  EventInPort<BatteryState> low_{*this, "low"};
  OutPort<std::int64_t> events_out_{*this, "events"};
  std::int64_t events_ = 0;
  bool activated_ = false;
};

// Answers each sample as it arrives (a CallbackInPort), on the writer's thread: the value
// goes out again on `out`, and `meta_ok` counts those whose meta had the sample's size and a
// time of entry.
class Echo final : public ComponentBase {
 public:
  void on_in(const std::int64_t& value, const SampleMeta& meta) {
    if (meta.size == sizeof value && meta.t_in.ns > 0) meta_ok_.write(++meta_ok_count_);
    out_.write(value);
  }

 private:
  CallbackInPort<std::int64_t> in_{*this, "in", &Echo::on_in};
  OutPort<std::int64_t> out_{*this, "out"};
  OutPort<std::int64_t> meta_ok_{*this, "meta_ok"};
  std::int64_t meta_ok_count_ = 0;
};

// Inside the namespace so that the class names stay unqualified ("Ticker", ...).
POLYPORT_COMPONENTS(POLYPORT_COMPONENT(Ticker), POLYPORT_COMPONENT(Collector), POLYPORT_COMPONENT(Adder),
                    POLYPORT_COMPONENT(Caller), POLYPORT_COMPONENT(Faulty), POLYPORT_COMPONENT(WrongSize),
                    POLYPORT_COMPONENT(PoseRelay), POLYPORT_COMPONENT(PeerAdder), POLYPORT_COMPONENT(PeerCaller),
                    POLYPORT_COMPONENT(Tunable), POLYPORT_COMPONENT(BatteryServer),
                    POLYPORT_COMPONENT(ConditionClient), POLYPORT_COMPONENT(Echo))

}  // namespace polyport::test
