// libFuzzer target for the live LCM receive path: each input is a message as LCM hands it to
// polyport's subscription on a channel of peer.pose_t (adaptors/lcm, without the SDK): the
// channel's check (length, fingerprint, size), then the adaptor's port and two connections
// as the engine wires them: one decodes into an in-process (flat) port, one decodes, maps onto
// another LCM struct (fields in another order, a derived length member) and encodes into an
// LCM port whose sink checks the result. Whatever the input, nothing may crash or read out of
// bounds; a message that was forwarded must come out as a valid pose2_t message.
// Build and run with ./scripts/fuzz.sh (clang, -DPOLYPORT_FUZZ=ON, into build-fuzz/).
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <memory>
#include <string_view>
#include <vector>

#include "lcm_adaptor.hpp"
#include "polyport/codecs/codec.hpp"
#include "polyport/codecs/mapping.hpp"
#include "polyport/runtime/connection.hpp"
#include "polyport/runtime/port.hpp"
#include "polyport/types/types.hpp"

namespace {

using namespace polyport;

constexpr std::string_view kTypes = R"(package fz;
struct pose_t { int32_t id; double x; float heading; boolean valid; string frame;
                int32_t nsamples; double samples[nsamples]; int16_t quad[4]; }
struct pose2_t { int16_t quad[4]; int32_t nsamples; double samples[nsamples]; string frame;
                 boolean valid; float heading; double x; int32_t id; }
)";

// Decodes what the LCM port's sink receives: it must be a pose2_t message.
class CheckingSink final : public SampleSink {
 public:
  explicit CheckingSink(const Codec& codec) : codec_(codec), flat_(1U << 20) {}
  Status on_sample(const std::byte* data, const SampleMeta& meta) noexcept override {
    if (!codec_.decode(data, meta.size, flat_.data(), static_cast<std::uint32_t>(flat_.size())).ok()) std::abort();
    return Status::ok;
  }

 private:
  const Codec& codec_;
  std::vector<std::byte> flat_;
};

PortSpec port_spec(PortDirection direction, const char* type) {
  PortSpec spec;
  spec.name = "pose";
  spec.direction = direction;
  spec.data_type = type;
  return spec;
}

struct Path {
  TypeRegistry types;
  std::unique_ptr<lcm::LcmAdaptor> source;
  std::unique_ptr<lcm::LcmAdaptor> sink;
  Component app{"app", "inproc"};
  DataInPort* flat_in = nullptr;
  std::unique_ptr<MappingProgram> mapping;
  std::unique_ptr<CheckingSink> checker;
  std::unique_ptr<Codec> pose2_codec;
  std::unique_ptr<Connection> to_flat;
  std::unique_ptr<Connection> to_lcm;

  Path() {
    Diagnostics diagnostics;
    if (!types.add_lcm_text(kTypes, "fz.lcm", diagnostics)) std::abort();
    const Type* pose = types.find("fz::pose_t");
    const Type* pose2 = types.find("fz::pose2_t");
    Subcomponent from;
    from.name = "from";
    from.profile.model = "lcm";
    from.profile.ports.push_back(port_spec(PortDirection::output, "fz::pose_t"));
    source = lcm::LcmAdaptor::create(from, types, diagnostics);
    Subcomponent to;
    to.name = "to";
    to.profile.model = "lcm";
    to.profile.ports.push_back(port_spec(PortDirection::input, "fz::pose2_t"));
    sink = lcm::LcmAdaptor::create(to, types, diagnostics);
    if (!source || !sink || pose == nullptr || pose2 == nullptr) std::abort();
    flat_in = &app.add_port<DataInPort>("in", PortKind::data, pose, 1U << 20, QueuePolicy::data, 1U);
    mapping = MappingProgram::compile(*pose, *pose2, MappingSpec{}, diagnostics);
    pose2_codec = make_lcm_codec(*pose2).value();
    if (!mapping) std::abort();
    checker = std::make_unique<CheckingSink>(*pose2_codec);
    DataOutPort& out = *source->channels()[0].out;
    DataInPort& lcm_in = *sink->channels()[0].in;
    lcm_in.set_sink(checker.get());
    to_flat = std::make_unique<Connection>(out, *flat_in, QueuePolicy::data, 1U);
    to_lcm = std::make_unique<Connection>(out, lcm_in, QueuePolicy::data, 1U, mapping.get());
    out.connections().add(*to_flat);
    flat_in->connections().add(*to_flat);
    out.connections().add(*to_lcm);
    lcm_in.connections().add(*to_lcm);
  }
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static Path path;
  if (size > (1U << 20)) return 0;
  const lcm::LcmAdaptor::Channel& channel = path.source->channels()[0];
  const auto bytes = static_cast<std::uint32_t>(size);
  if (lcm::check_message(channel, data, bytes) != lcm::MessageCheck::ok) return 0;
  (void)channel.out->write(data, bytes);
  static std::vector<std::byte> flat(1U << 20);
  (void)path.flat_in->read(flat.data(), static_cast<std::uint32_t>(flat.size()));
  return 0;
}
