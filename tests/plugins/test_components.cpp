// Small components that the tests load through the in-process model, like any plugin.
#include <cstdint>

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

// Inside the namespace so that the class names stay unqualified ("Ticker", ...).
POLYPORT_COMPONENTS(POLYPORT_COMPONENT(Ticker), POLYPORT_COMPONENT(Collector), POLYPORT_COMPONENT(Adder),
                    POLYPORT_COMPONENT(Caller), POLYPORT_COMPONENT(Faulty), POLYPORT_COMPONENT(WrongSize),
                    POLYPORT_COMPONENT(PoseRelay), POLYPORT_COMPONENT(PeerAdder), POLYPORT_COMPONENT(PeerCaller))

}  // namespace polyport::test
