// Converting connections allocate nothing per sample: XCDR1 -> LCM and DBC -> XCDR1 of a
// 64-byte struct, decode + by-name mapping + encode, counted over the whole process.
#include <gtest/gtest.h>

#include <vector>

#include "alloc_counter.hpp"
#include "polyport/codecs/codec.hpp"
#include "polyport/runtime/component.hpp"
#include "polyport/runtime/connection.hpp"
#include "polyport/codecs/mapping.hpp"
#include "polyport/types/types.hpp"

namespace polyport {
namespace {

using test::allocations;

class CountingSink final : public SampleSink {
 public:
  Status on_sample(const std::byte*, const SampleMeta& meta) noexcept override {
    last_size = meta.size;
    ++count;
    return Status::ok;
  }
  std::uint32_t last_size = 0;
  std::uint64_t count = 0;
};

class ConversionAllocations : public ::testing::Test {
 protected:
  void SetUp() override {
    Diagnostics d;
    types.add_type_file(POLYPORT_SOURCE_DIR "/benchmarks/types/bench.idl", d);
    types.add_type_file(POLYPORT_SOURCE_DIR "/benchmarks/types/bench.lcm", d);
    types.add_type_file(POLYPORT_SOURCE_DIR "/benchmarks/types/bench.dbc", d);
    for (const auto& p : d.all()) ADD_FAILURE() << p.to_string();
    idl = types.find("bench::Wheel64");
    lcm = types.find("bench::wheel64_t");
    dbc = types.find("bench::Wheel64Frame");
    ASSERT_TRUE(idl && lcm && dbc);
  }

  // Writes `n` samples through a converting connection; returns allocations during them.
  std::uint64_t run(WireFormat from_format, const Type& from, WireFormat to_format, const Type& to, int n) {
    auto source_codec = make_codec(from_format, from);
    auto target_codec = make_codec(to_format, to);
    EXPECT_TRUE(source_codec && target_codec);
    if (!source_codec || !target_codec) return ~0ull;
    Diagnostics d;
    auto mapping = MappingProgram::compile(from, to, MappingSpec{}, d);
    EXPECT_TRUE(mapping);
    if (!mapping) return ~0ull;
    Component a{"A", "src"};
    Component b{"B", "dst"};
    auto& out = a.add_port<DataOutPort>("out", PortKind::data, &from, 512);
    auto& in = b.add_port<DataInPort>("in", PortKind::data, &to, 512, QueuePolicy::data, 1);
    out.set_wire_format(from_format, source_codec.value().get());
    in.set_wire_format(to_format, target_codec.value().get());
    CountingSink sink;
    in.set_sink(&sink);
    Connection connection(out, in, QueuePolicy::data, 1, mapping.get());
    out.connections().add(connection);
    in.connections().add(connection);

    const double values[8] = {12.5, 12.0, 3.25, 3.5, 18.0, 18.125, 40.0, 24.2};
    std::vector<std::byte> wire(source_codec.value()->max_wire_size(sizeof values));
    const CodecResult encoded = source_codec.value()->encode(reinterpret_cast<const std::byte*>(values), sizeof values,
                                                             wire.data(), static_cast<std::uint32_t>(wire.size()));
    EXPECT_TRUE(encoded.ok());
    const std::uint64_t before = allocations();
    for (int i = 0; i < n; ++i) out.write(wire.data(), encoded.size);
    const std::uint64_t during = allocations() - before;
    EXPECT_EQ(sink.count, static_cast<std::uint64_t>(n));
    EXPECT_EQ(connection.counters().dropped(), 0u);
    return during;
  }

  TypeRegistry types;
  const Type* idl = nullptr;
  const Type* lcm = nullptr;
  const Type* dbc = nullptr;
};

TEST_F(ConversionAllocations, CdrToLcmAllocatesNothingPerSample) {
  EXPECT_EQ(run(WireFormat::xcdr1, *idl, WireFormat::lcm, *lcm, 10'000), 0u);
}

TEST_F(ConversionAllocations, DbcToCdrAllocatesNothingPerSample) {
  EXPECT_EQ(run(WireFormat::dbc, *dbc, WireFormat::xcdr1, *idl, 10'000), 0u);
}

}  // namespace
}  // namespace polyport
