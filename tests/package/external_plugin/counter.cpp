// One periodic component with one output port: every cycle it writes the next count.
#include <cstdint>

#include "polyport/runtime/component_api.hpp"

namespace {

// Laid out like ext::Count in count.idl (the engine checks size and alignment at load time).
struct Count {
  std::uint64_t value;
  double time_s;
};

class CounterComp : public polyport::ComponentBase {
 public:
  polyport::ReturnCode onInitialize() override {
    step_ = static_cast<std::uint64_t>(property_double("step", 1.0));
    return step_ > 0 ? polyport::ReturnCode::ok : polyport::ReturnCode::bad_parameter;
  }
  polyport::ReturnCode onExecute() override {
    next_.value += step_;
    next_.time_s += period_seconds();
    count_.write(next_);
    return polyport::ReturnCode::ok;
  }

 private:
  polyport::OutPort<Count> count_{*this, "count"};
  Count next_{0, 0.0};
  std::uint64_t step_ = 1;
};

}  // namespace

POLYPORT_COMPONENTS(POLYPORT_COMPONENT(CounterComp))
