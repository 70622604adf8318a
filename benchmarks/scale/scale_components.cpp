// The scale benchmark's and the soak's components (benchmarks/scale/README.md,
// benchmarks/soak/README.md): a source that writes one 64-byte sample per cycle and a sink that
// reads all it got, counting what it missed by the samples' sequence numbers. Nothing else, so the daemon's CPU time is the forwarding's and
// the execution contexts'.
#include <cstdint>
#include <ctime>

#include "polyport/runtime/component_api.hpp"

namespace {

// scale::Sample64 of scale.idl in its flat layout.
struct Sample64 {
  std::uint64_t seq;
  std::uint64_t stamp_ns;
  std::uint8_t pad[48];
};
static_assert(sizeof(Sample64) == 64);

class ScaleSource final : public polyport::ComponentBase {
 public:
  polyport::ReturnCode onExecute() override {
    timespec now{};
    clock_gettime(CLOCK_MONOTONIC, &now);
    sample_.seq += 1;
    sample_.stamp_ns = static_cast<std::uint64_t>(now.tv_sec) * 1000000000u + static_cast<std::uint64_t>(now.tv_nsec);
    out_.write(sample_);
    return polyport::ReturnCode::ok;
  }

 private:
  polyport::OutPort<Sample64> out_{*this, "out"};
  Sample64 sample_{};
};

class ScaleSink final : public polyport::ComponentBase {
 public:
  polyport::ReturnCode onExecute() override {
    Sample64 sample{};
    const std::uint64_t missed_before = missed_;
    while (in_.read(sample) == polyport::Status::ok) {
      if (last_ != 0 && sample.seq > last_ + 1) missed_ += sample.seq - last_ - 1;
      last_ = sample.seq;
    }
    // Written when it changes: the soak traces it for every sink (benchmarks/soak).
    if (missed_ != missed_before) missed_out_.write(missed_);
    return polyport::ReturnCode::ok;
  }

 private:
  polyport::InPort<Sample64> in_{*this, "in"};
  polyport::OutPort<std::uint64_t> missed_out_{*this, "missed"};
  std::uint64_t last_ = 0;
  std::uint64_t missed_ = 0;
};

}  // namespace

POLYPORT_COMPONENTS(POLYPORT_COMPONENT(ScaleSource), POLYPORT_COMPONENT(ScaleSink))
