// MappingProgram::run() allocates nothing: counted over every thread of the process (this
// binary replaces operator new, see alloc_counter.cpp) while programs that use every kind
// of step run many times, including runs that fail on a malformed source.
#include <gtest/gtest.h>

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "alloc_counter.hpp"
#include "polyport/base/diagnostics.hpp"
#include "polyport/codecs/mapping.hpp"
#include "polyport/types/types.hpp"

namespace polyport {
namespace {

using test::allocations;

constexpr char kTypes[] =
    "module a { enum Mode { IDLE, DRIVE, BRAKE };\n"
    "  struct Point { float x; string name; };\n"
    "  struct Msg { double speed_kmh; double v[3]; long seq; Mode mode; string<16> frame; string note;\n"
    "    sequence<Point> points; sequence<float, 4> weights; Mode modes[2]; }; };\n"
    "module b { enum Mode { BRAKE, IDLE, DRIVE };\n"
    "  struct Point { string name; double x; };\n"
    "  struct Vec { double x; double y; double z; };\n"
    "  struct Msg { double speed_mps; Vec v; long long seq; Mode mode; string frame; string<8> note;\n"
    "    sequence<Point, 4> points; sequence<double> weights; Mode modes[2]; double gain; string label; }; };\n";

class MappingAllocations : public ::testing::Test {
 protected:
  void SetUp() override {
    Diagnostics diagnostics;
    ASSERT_TRUE(types_.add_idl_text(kTypes, "alloc.idl", diagnostics));
    from_ = types_.find("a::Msg");
    to_ = types_.find("b::Msg");
    ASSERT_NE(from_, nullptr);
    ASSERT_NE(to_, nullptr);

    MappingSpec spec;
    MappingRule speed;
    speed.target = "speed_mps";
    speed.source = "speed_kmh";
    speed.from_unit = "km/h";
    speed.to_unit = "m/s";
    MappingRule vector;
    vector.kind = MappingRule::Kind::affine;
    vector.target = "v";
    vector.source = "v";
    vector.matrix = {0, 1, 0, 1, 0, 0, 0, 0, -1};
    vector.matrix_rows = 3;
    vector.matrix_cols = 3;
    vector.translation = {1, 2, 3};
    MappingRule note;
    note.target = "note";
    note.source = "note";
    note.truncate = true;
    MappingRule gain;
    gain.kind = MappingRule::Kind::constant;
    gain.target = "gain";
    gain.value = "0.5";
    MappingRule label = gain;
    label.target = "label";
    label.value = "constant label";
    spec.rules = {speed, vector, note, gain, label};
    std::vector<MappingProblem> problems;
    program_ = MappingProgram::compile(*from_, *to_, spec, problems);
    ASSERT_NE(program_, nullptr) << (problems.empty() ? "" : problems.front().message);

    // A source with two points, three weights and strings in its tail.
    source_.assign(512, std::byte{0});
    const auto at = [this](const char* field) { return from_->find_field(field)->offset; };
    put(at("speed_kmh"), 36.0);
    put(at("seq"), std::int32_t{12});
    put(at("mode"), std::int32_t{2});
    std::memcpy(source_.data() + at("frame"), "map", 3);
    const Type& point = *types_.find("a::Point");
    const std::uint32_t points = 256;
    put(at("points"), FlatSpan{points, 2});
    std::uint32_t text = points + 2 * point.size;
    for (std::uint32_t i = 0; i < 2; ++i) {
      put(points + i * point.size + point.find_field("name")->offset, FlatSpan{text, 5});
      std::memcpy(source_.data() + text, i == 0 ? "first" : "other", 5);
      text += 6;
    }
    put(at("note"), FlatSpan{text, 20});
    std::memcpy(source_.data() + text, "a note over 8 chars.", 20);
    put(at("weights"), std::uint32_t{3});
  }

  template <class T>
  void put(std::uint32_t offset, T value) {
    std::memcpy(source_.data() + offset, &value, sizeof value);
  }

  TypeRegistry types_;
  const Type* from_ = nullptr;
  const Type* to_ = nullptr;
  std::unique_ptr<MappingProgram> program_;
  std::vector<std::byte> source_;
};

TEST_F(MappingAllocations, RunAllocatesNothing) {
  std::vector<std::byte> target(1024);
  std::vector<std::byte> malformed = source_;
  std::memcpy(malformed.data() + from_->find_field("mode")->offset, "\x07\0\0\0", 4);  // no enumerator
  std::uint32_t size = 0;
  // Once before counting, so nothing lazily set up on a first call is counted.
  ASSERT_TRUE(program_->run(source_.data(), static_cast<std::uint32_t>(source_.size()), target.data(),
                            static_cast<std::uint32_t>(target.size()), size));
  const std::uint64_t before = allocations();
  std::uint64_t failures = 0;
  for (int i = 0; i < 10'000; ++i) {
    const bool ok = program_->run(source_.data(), static_cast<std::uint32_t>(source_.size()), target.data(),
                                  static_cast<std::uint32_t>(target.size()), size);
    if (!ok) ++failures;
    if (program_->run(malformed.data(), static_cast<std::uint32_t>(malformed.size()), target.data(),
                      static_cast<std::uint32_t>(target.size()), size)) {
      ++failures;
    }
    // A tail that does not fit fails as well.
    if (program_->run(source_.data(), static_cast<std::uint32_t>(source_.size()), target.data(), to_->size + 4,
                      size)) {
      ++failures;
    }
  }
  EXPECT_EQ(allocations() - before, 0u);
  EXPECT_EQ(failures, 0u);
  // The program did run: the speed went through its unit conversion.
  double speed = 0.0;
  ASSERT_TRUE(program_->run(source_.data(), static_cast<std::uint32_t>(source_.size()), target.data(),
                            static_cast<std::uint32_t>(target.size()), size));
  std::memcpy(&speed, target.data() + to_->find_field("speed_mps")->offset, sizeof speed);
  EXPECT_DOUBLE_EQ(speed, 10.0);
}

TEST_F(MappingAllocations, CountingWorks) {
  // The counter must see an allocation, or the test above proves nothing.
  const std::uint64_t before = allocations();
  auto described = program_->describe();
  EXPECT_FALSE(described.empty());
  EXPECT_GT(allocations() - before, 0u);
}

// LCM length members set from their sequences' counts (Op::length), including runs that fail
// because a count does not fit an int8_t length.
TEST(MappingAllocationsLcm, DerivedLengthsAllocateNothing) {
  TypeRegistry types;
  Diagnostics diagnostics;
  ASSERT_TRUE(types.add_idl_text(
      "module p { struct Pose { long id; sequence<double, 8> samples; sequence<octet> data; }; };\n", "p.idl",
      diagnostics));
  ASSERT_TRUE(types.add_lcm_text("package p;\nstruct pose_t { int32_t id; int32_t nsamples; double samples[nsamples];\n"
                                 "  int8_t n; byte data[n]; }\n",
                                 "p.lcm", diagnostics));
  const Type* from = types.find("p::Pose");
  const Type* to = types.find("p::pose_t");
  ASSERT_NE(from, nullptr);
  ASSERT_NE(to, nullptr);
  std::vector<MappingProblem> problems;
  const auto program = MappingProgram::compile(*from, *to, MappingSpec{}, problems);
  ASSERT_NE(program, nullptr) << (problems.empty() ? "" : problems.front().message);

  std::vector<std::byte> source(512, std::byte{0});
  const std::uint32_t samples = from->find_field("samples")->offset;
  const std::uint32_t data = from->find_field("data")->offset;
  const std::uint32_t three = 3;
  std::memcpy(source.data() + samples, &three, sizeof three);
  const FlatSpan four{256, 4};
  std::memcpy(source.data() + data, &four, sizeof four);
  std::vector<std::byte> too_long = source;
  const FlatSpan many{256, 200};
  std::memcpy(too_long.data() + data, &many, sizeof many);

  std::vector<std::byte> target(1024);
  std::uint32_t size = 0;
  ASSERT_TRUE(program->run(source.data(), static_cast<std::uint32_t>(source.size()), target.data(),
                           static_cast<std::uint32_t>(target.size()), size));
  const std::uint64_t before = allocations();
  std::uint64_t failures = 0;
  for (int i = 0; i < 10'000; ++i) {
    if (!program->run(source.data(), static_cast<std::uint32_t>(source.size()), target.data(),
                      static_cast<std::uint32_t>(target.size()), size)) {
      ++failures;
    }
    if (program->run(too_long.data(), static_cast<std::uint32_t>(too_long.size()), target.data(),
                     static_cast<std::uint32_t>(target.size()), size)) {
      ++failures;
    }
  }
  EXPECT_EQ(allocations() - before, 0u);
  EXPECT_EQ(failures, 0u);
  ASSERT_TRUE(program->run(source.data(), static_cast<std::uint32_t>(source.size()), target.data(),
                           static_cast<std::uint32_t>(target.size()), size));
  std::int32_t nsamples = 0;
  std::int8_t n = 0;
  std::memcpy(&nsamples, target.data() + to->find_field("nsamples")->offset, sizeof nsamples);
  std::memcpy(&n, target.data() + to->find_field("n")->offset, sizeof n);
  EXPECT_EQ(nsamples, 3);
  EXPECT_EQ(n, 4);
}

}  // namespace
}  // namespace polyport
