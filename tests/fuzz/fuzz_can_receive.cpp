// libFuzzer target for the live CAN receive path (adaptors/socketcan, without sockets): each
// input is a frame as the kernel hands it to the SocketCAN interceptor — 4 bytes of can_id
// (little-endian, with its EFF / RTR / ERR flags), 1 byte of length, then the data (the rest
// of the 64-byte data field is zero, as in a canfd_frame). An error frame is classified
// and written as a polyport::CanBusEvent; a data frame goes through SocketCanAdaptor::receive
// (id lookup, length check, write) into the component's ports, wired as the engine wires
// them: each port to an in-process (flat) port that decodes the DBC signals, and the Intel
// message mapped by name onto a Motorola one whose CAN sink decodes what it gets. Whatever
// the input, nothing may crash or read out of bounds, and what reaches the sink must decode.
// Build and run with ./scripts/fuzz.sh (clang, -DPOLYPORT_FUZZ=ON, into build-fuzz/).
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <string_view>
#include <vector>

#include "polyport/codecs/codec.hpp"
#include "polyport/codecs/mapping.hpp"
#include "polyport/runtime/connection.hpp"
#include "polyport/runtime/port.hpp"
#include "polyport/types/types.hpp"
#include "socketcan_adaptor.hpp"

namespace {

using namespace polyport;

// Intel and Motorola, signed and unsigned, scaled and offset signals; an extended-id
// multiplexed message; one with nested switches and value ranges (extended multiplexing,
// signals sharing bits under different values); a 64-byte CAN FD message with a float signal.
constexpr std::string_view kDbc = R"(VERSION ""
NS_ :
BS_:
BU_: A B
BO_ 256 Drive: 8 A
 SG_ speed : 0|16@1- (0.01,0) [-300|300] "m/s" B
 SG_ steer : 23|12@0- (0.1,-10) [-210|200] "deg" B
 SG_ mode : 32|3@1+ (1,0) [0|7] "" B
 SG_ gain : 40|8@1+ (0.5,1) [1|128.5] "" B
BO_ 257 DriveMotorola: 8 B
 SG_ speed : 7|16@0- (0.01,0) [-300|300] "m/s" A
 SG_ steer : 16|12@1- (0.1,-10) [-210|200] "deg" A
 SG_ mode : 39|3@0+ (1,0) [0|7] "" A
 SG_ gain : 47|8@0+ (0.5,1) [1|128.5] "" A
BO_ 2147484160 Pages: 8 A
 SG_ page M : 0|8@1+ (1,0) [0|255] "" B
 SG_ volts m1 : 8|16@1+ (0.001,0) [0|65.535] "V" B
 SG_ temp m2 : 8|8@1- (1,0) [-128|127] "degC" B
 SG_ seq : 56|8@1+ (1,0) [0|255] "" B
BO_ 258 Nested: 8 A
 SG_ service M : 0|8@1+ (1,0) [0|255] "" B
 SG_ pid m1M : 8|8@1+ (1,0) [0|255] "" B
 SG_ speed m13 : 16|8@1+ (1,0) [0|255] "" B
 SG_ rpm m12 : 23|16@0- (0.25,0) [0|0] "" B
 SG_ dtc m3 : 8|16@1+ (1,0) [0|0] "" B
BO_ 768 Cells: 64 A
 SG_ cell : 0|16@1+ (0.001,0) [0|65.535] "V" B
 SG_ yaw : 32|32@1- (1,0) [0|0] "rad/s" B
 SG_ tail : 511|8@0+ (1,0) [0|255] "" B
SIG_VALTYPE_ 768 yaw : 1;
SG_MUL_VAL_ 258 pid service 1-1;
SG_MUL_VAL_ 258 speed pid 13-13, 20-29;
SG_MUL_VAL_ 258 rpm pid 12-12;
SG_MUL_VAL_ 258 dtc service 3-7;
)";

constexpr std::string_view kBusEvent = R"(module polyport {
  enum CanBusEventKind { K0, K1, K2, K3, K4, K5, K6, K7, K8, K9 };
  enum CanBusState { S0, S1, S2, S3, S4, S5 };
  struct CanBusEvent { CanBusEventKind kind; CanBusState state; unsigned long error_class;
                       octet controller; octet protocol; octet tx_errors; octet rx_errors; };
};
)";

// Decodes what the CAN port's sink receives: it must be a DriveMotorola frame.
class CheckingSink final : public SampleSink {
 public:
  explicit CheckingSink(const Codec& codec) : codec_(codec), flat_(4096) {}
  Status on_sample(const std::byte* data, const SampleMeta& meta) noexcept override {
    if (meta.size != 8) std::abort();
    if (!codec_.decode(data, meta.size, flat_.data(), static_cast<std::uint32_t>(flat_.size())).ok()) std::abort();
    return Status::ok;
  }

 private:
  const Codec& codec_;
  std::vector<std::byte> flat_;
};

PortSpec port_spec(const char* name, PortDirection direction, const char* type) {
  PortSpec spec;
  spec.name = name;
  spec.direction = direction;
  spec.data_type = type;
  return spec;
}

struct Path {
  TypeRegistry types;
  std::unique_ptr<socketcan::SocketCanAdaptor> source;
  std::unique_ptr<socketcan::SocketCanAdaptor> sink;
  Component app{"app", "inproc"};
  std::vector<DataInPort*> flat_ins;
  std::unique_ptr<MappingProgram> mapping;
  std::unique_ptr<Codec> motorola_codec;
  std::unique_ptr<CheckingSink> checker;
  std::vector<std::unique_ptr<Connection>> connections;

  void connect(DataOutPort& out, DataInPort& in, const MappingProgram* program = nullptr) {
    connections.push_back(std::make_unique<Connection>(out, in, QueuePolicy::data, 1U, program));
    out.connections().add(*connections.back());
    in.connections().add(*connections.back());
  }

  Path() {
    Diagnostics diagnostics;
    if (!types.add_dbc_text(kDbc, "fz.dbc", diagnostics) || !types.add_idl_text(kBusEvent, "bus.idl", diagnostics)) {
      std::abort();
    }
    auto settings = std::make_shared<socketcan::SocketCanSettings>();
    settings->fd = true;
    Subcomponent from;
    from.name = "bus";
    from.profile.model = "socketcan";
    from.profile.model_settings = settings;
    const char* received[] = {"fz::Drive", "fz::Pages", "fz::Nested", "fz::Cells"};
    for (const char* type : received) from.profile.ports.push_back(port_spec(type + 4, PortDirection::output, type));
    from.profile.ports.push_back(port_spec("events", PortDirection::output, "polyport::CanBusEvent"));
    source = socketcan::SocketCanAdaptor::create(from, types, diagnostics);
    Subcomponent to;
    to.name = "out";
    to.profile.model = "socketcan";
    to.profile.ports.push_back(port_spec("motorola", PortDirection::input, "fz::DriveMotorola"));
    sink = socketcan::SocketCanAdaptor::create(to, types, diagnostics);
    const Type* drive = types.find("fz::Drive");
    const Type* motorola = types.find("fz::DriveMotorola");
    if (!source || !sink || drive == nullptr || motorola == nullptr || source->bus_events() == nullptr) std::abort();

    for (const auto& message : source->messages()) {
      DataInPort& flat = app.add_port<DataInPort>(message.name, PortKind::data, message.out->type(), 4096,
                                                 QueuePolicy::data, 1U);
      flat_ins.push_back(&flat);
      connect(*message.out, flat);
    }
    DataInPort& events = app.add_port<DataInPort>("events", PortKind::data, source->bus_events()->type(), 64,
                                                  QueuePolicy::data, 1U);
    flat_ins.push_back(&events);
    connect(*source->bus_events(), events);

    mapping = MappingProgram::compile(*drive, *motorola, MappingSpec{}, diagnostics);
    motorola_codec = make_dbc_codec(*motorola).value();
    if (!mapping) std::abort();
    checker = std::make_unique<CheckingSink>(*motorola_codec);
    DataInPort& can_in = *sink->messages()[0].in;
    can_in.set_sink(checker.get());
    connect(*source->messages()[0].out, can_in, mapping.get());
  }
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static Path path;
  if (size < 5) return 0;
  std::uint32_t can_id = 0;
  std::memcpy(&can_id, data, 4);
  const std::uint8_t length = data[4];
  std::uint8_t payload[64] = {};
  std::memcpy(payload, data + 5, std::min<std::size_t>(size - 5, sizeof payload));
  constexpr std::uint32_t kErrorFlag = 0x20000000U;  // CAN_ERR_FLAG
  if ((can_id & kErrorFlag) != 0) {
    const std::uint32_t error_class = can_id & 0x1FFFFFFFU;  // CAN_ERR_MASK
    const auto meaning = socketcan::classify_error_frame(error_class, payload, socketcan::CanBusState::active);
    const socketcan::CanBusEventSample event = socketcan::bus_event(meaning.kind, meaning.state, error_class, payload);
    (void)path.source->bus_events()->write(&event, sizeof event);
  } else {
    (void)path.source->receive(can_id, payload, length, MonoTime{});
  }
  static std::vector<std::byte> flat(4096);
  for (DataInPort* in : path.flat_ins) (void)in->read(flat.data(), static_cast<std::uint32_t>(flat.size()));
  return 0;
}
