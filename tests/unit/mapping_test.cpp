// MappingProgram: what compile() accepts and refuses (with the exact messages), and what
// run() writes, on flat samples built from the layouts the type registry computes.

#include "polyport/codecs/mapping.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>
#include <memory>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "polyport/base/diagnostics.hpp"
#include "polyport/codecs/codec.hpp"
#include "polyport/types/types.hpp"

namespace {

using namespace polyport;
using Kind = MappingRule::Kind;

// A flat sample: 8-byte aligned storage, filled with a marker byte so that a byte run()
// forgets to write shows up.
class Sample {
 public:
  explicit Sample(std::size_t size, std::byte fill = std::byte{0xAB}) : words_((size + 7) / 8), size_(size) {
    std::memset(words_.data(), static_cast<int>(fill), words_.size() * 8);
  }
  std::byte* data() { return reinterpret_cast<std::byte*>(words_.data()); }
  const std::byte* data() const { return reinterpret_cast<const std::byte*>(words_.data()); }
  std::uint32_t size() const { return static_cast<std::uint32_t>(size_); }

  template <class T>
  void set(std::uint32_t offset, T value) {
    std::memcpy(data() + offset, &value, sizeof value);
  }
  template <class T>
  T get(std::uint32_t offset) const {
    T value;
    std::memcpy(&value, data() + offset, sizeof value);
    return value;
  }
  void set_text(std::uint32_t offset, std::string_view text) {
    std::memcpy(data() + offset, text.data(), text.size());
  }
  std::string text(std::uint32_t offset, std::size_t length) const {
    return std::string(reinterpret_cast<const char*>(data() + offset), length);
  }

 private:
  std::vector<std::uint64_t> words_;
  std::size_t size_;
};

MappingRule copy_rule(std::string target, std::string source) {
  MappingRule rule;
  rule.target = std::move(target);
  rule.source = std::move(source);
  return rule;
}

MappingRule constant_rule(std::string target, std::string value) {
  MappingRule rule;
  rule.kind = Kind::constant;
  rule.target = std::move(target);
  rule.value = std::move(value);
  return rule;
}

MappingRule transform_rule(Kind kind, std::string target, std::string source, std::uint32_t rows, std::uint32_t cols,
                           std::vector<double> matrix, std::vector<double> translation = {}) {
  MappingRule rule;
  rule.kind = kind;
  rule.target = std::move(target);
  rule.source = std::move(source);
  rule.matrix = std::move(matrix);
  rule.matrix_rows = rows;
  rule.matrix_cols = cols;
  rule.translation = std::move(translation);
  return rule;
}

class MappingFixture : public ::testing::Test {
 protected:
  void define(std::string_view idl) {
    Diagnostics diagnostics;
    const std::string file = "mapping" + std::to_string(++files_) + ".idl";
    ASSERT_TRUE(types_.add_idl_text(idl, file, diagnostics))
        << (diagnostics.all().empty() ? "" : diagnostics.all().front().to_string());
  }

  void define_lcm(std::string_view lcm) {
    Diagnostics diagnostics;
    const std::string file = "mapping" + std::to_string(++files_) + ".lcm";
    ASSERT_TRUE(types_.add_lcm_text(lcm, file, diagnostics))
        << (diagnostics.all().empty() ? "" : diagnostics.all().front().to_string());
  }

  const Type& type(std::string_view name) {
    const Type* found = types_.find(name);
    if (found == nullptr) {
      ADD_FAILURE() << "no type " << name;
      return *types_.primitive(TypeKind::octet);
    }
    return *found;
  }

  // The byte offset of "a.b[1].c" in a type (the test's own reading of the layout rules).
  std::uint32_t at(std::string_view type_name, std::string_view path) {
    const Type* current = &type(type_name).resolved();
    std::uint32_t offset = 0;
    std::size_t i = 0;
    while (i < path.size()) {
      if (path[i] == '.') ++i;
      if (path[i] == '[') {
        const std::size_t close = path.find(']', i);
        const auto index = static_cast<std::uint32_t>(std::stoul(std::string(path.substr(i + 1, close - i - 1))));
        offset += index * current->element->size;
        current = &current->element->resolved();
        i = close + 1;
        continue;
      }
      std::size_t end = path.find_first_of(".[", i);
      if (end == std::string_view::npos) end = path.size();
      const Field* field = current->find_field(path.substr(i, end - i));
      if (field == nullptr) {
        ADD_FAILURE() << "no field " << path.substr(i, end - i) << " in " << current->name;
        return 0;
      }
      offset += field->offset;
      current = &field->type->resolved();
      i = end;
    }
    return offset;
  }

  // Compiles; returns the program (null on failure) and keeps the problems' messages.
  std::unique_ptr<MappingProgram> compile(std::string_view from, std::string_view to, const MappingSpec& spec = {}) {
    problems_.clear();
    auto program = MappingProgram::compile(type(from), type(to), spec, problems_);
    EXPECT_EQ(program == nullptr, !problems_.empty());
    return program;
  }

  std::vector<std::string> messages() const {
    std::vector<std::string> out;
    for (const MappingProblem& problem : problems_) out.push_back(problem.message);
    return out;
  }

  // Compiles and must succeed.
  std::unique_ptr<MappingProgram> compile_ok(std::string_view from, std::string_view to, const MappingSpec& spec = {}) {
    auto program = compile(from, to, spec);
    EXPECT_NE(program, nullptr) << ::testing::PrintToString(messages());
    return program;
  }

  // Compiles and must fail with exactly these messages.
  void expect_errors(std::string_view from, std::string_view to, const MappingSpec& spec,
                     const std::vector<std::string>& expected) {
    const auto program = compile(from, to, spec);
    EXPECT_EQ(program, nullptr);
    EXPECT_EQ(messages(), expected);
  }

  // Runs into a fresh target of `capacity` bytes (default: the fixed part).
  Sample run(const MappingProgram& program, std::string_view to, const Sample& source, std::uint32_t capacity = 0,
             bool expect_ok = true) {
    Sample target(capacity == 0 ? type(to).size : capacity);
    std::uint32_t size = 0;
    EXPECT_EQ(program.run(source.data(), source.size(), target.data(), target.size(), size), expect_ok);
    if (expect_ok) last_size_ = size;
    return target;
  }

  static MappingSpec spec_of(std::vector<MappingRule> rules, bool by_name = true) {
    MappingSpec spec;
    spec.rules = std::move(rules);
    spec.by_name = by_name;
    return spec;
  }

  TypeRegistry types_;
  std::vector<MappingProblem> problems_;
  std::uint32_t last_size_ = 0;
  int files_ = 0;
};

// ---------------------------------------------------------------------------------------

class MappingByName : public MappingFixture {};

TEST_F(MappingByName, FieldsOfTheSameNameInAnyOrder) {
  define("struct A { double x; double y; long id; };\n"
         "struct B { long id; double y; double x; };\n");
  const auto program = compile_ok("A", "B");
  ASSERT_NE(program, nullptr);
  Sample source(type("A").size);
  source.set(at("A", "x"), 1.5);
  source.set(at("A", "y"), -2.0);
  source.set(at("A", "id"), std::int32_t{42});
  const Sample target = run(*program, "B", source);
  EXPECT_EQ(target.get<std::int32_t>(at("B", "id")), 42);
  EXPECT_EQ(target.get<double>(at("B", "y")), -2.0);
  EXPECT_EQ(target.get<double>(at("B", "x")), 1.5);
  EXPECT_EQ(target.get<std::uint32_t>(4), 0u);  // the padding after `id` is zeroed
  EXPECT_EQ(last_size_, type("B").size);
}

TEST_F(MappingByName, SameLayoutIsOneCopy) {
  define("struct A { double v[8]; };\nstruct B { double v[8]; };\n"
         "struct P { double a; double b; double c; double d; double e; double f; double g; double h; };\n"
         "struct Q { double a; double b; double c; double d; double e; double f; double g; double h; };\n");
  const auto arrays = compile_ok("A", "B");
  ASSERT_NE(arrays, nullptr);
  EXPECT_EQ(arrays->describe(), std::vector<std::string>{"copy 64 bytes @0 -> @0 (the whole sample)"});
  const auto fields = compile_ok("P", "Q");
  ASSERT_NE(fields, nullptr);
  EXPECT_EQ(fields->describe(), std::vector<std::string>{"copy 64 bytes @0 -> @0 (the whole sample)"});
}

TEST_F(MappingByName, NestedStructsRecursively) {
  define("module a { struct Vec { double x; double y; double z; }; struct Pose { Vec position; float heading; };\n"
         "  struct Msg { long seq; Pose pose; }; };\n"
         "module b { struct Vec { double z; double x; double y; }; struct Pose { double heading; Vec position; };\n"
         "  struct Msg { Pose pose; long long seq; }; };\n");
  const auto program = compile_ok("a::Msg", "b::Msg");
  ASSERT_NE(program, nullptr);
  Sample source(type("a::Msg").size);
  source.set(at("a::Msg", "seq"), std::int32_t{7});
  source.set(at("a::Msg", "pose.position.x"), 1.0);
  source.set(at("a::Msg", "pose.position.y"), 2.0);
  source.set(at("a::Msg", "pose.position.z"), 3.0);
  source.set(at("a::Msg", "pose.heading"), 0.5f);
  const Sample target = run(*program, "b::Msg", source);
  EXPECT_EQ(target.get<std::int64_t>(at("b::Msg", "seq")), 7);
  EXPECT_EQ(target.get<double>(at("b::Msg", "pose.position.x")), 1.0);
  EXPECT_EQ(target.get<double>(at("b::Msg", "pose.position.y")), 2.0);
  EXPECT_EQ(target.get<double>(at("b::Msg", "pose.position.z")), 3.0);
  EXPECT_EQ(target.get<double>(at("b::Msg", "pose.heading")), 0.5);
}

TEST_F(MappingByName, ArraysElementWise) {
  define("struct E { short a; double b; };\nstruct F { double b; long a; };\n"
         "struct A { float v[3]; long m[2][2]; E e[2]; };\n"
         "struct B { double v[3]; long long m[2][2]; F e[2]; };\n");
  const auto program = compile_ok("A", "B");
  ASSERT_NE(program, nullptr);
  Sample source(type("A").size);
  for (int i = 0; i < 3; ++i) source.set(at("A", "v[" + std::to_string(i) + "]"), 0.25f * static_cast<float>(i + 1));
  for (int i = 0; i < 4; ++i) source.set(at("A", "m") + 4 * i, std::int32_t{-10 * i});
  source.set(at("A", "e[0].a"), std::int16_t{-3});
  source.set(at("A", "e[0].b"), 3.5);
  source.set(at("A", "e[1].a"), std::int16_t{4});
  source.set(at("A", "e[1].b"), 4.5);
  const Sample target = run(*program, "B", source);
  for (int i = 0; i < 3; ++i) EXPECT_EQ(target.get<double>(at("B", "v[" + std::to_string(i) + "]")), 0.25 * (i + 1));
  for (int i = 0; i < 4; ++i) EXPECT_EQ(target.get<std::int64_t>(at("B", "m") + 8 * i), -10 * i);
  EXPECT_EQ(target.get<std::int32_t>(at("B", "e[0].a")), -3);
  EXPECT_EQ(target.get<double>(at("B", "e[0].b")), 3.5);
  EXPECT_EQ(target.get<std::int32_t>(at("B", "e[1].a")), 4);
  EXPECT_EQ(target.get<double>(at("B", "e[1].b")), 4.5);
  EXPECT_EQ(target.get<std::uint32_t>(at("B", "e[0].a") + 4), 0u);  // element padding
}

TEST_F(MappingByName, BoundedSequencesCopyTheirLengthAndZeroTheRest) {
  define("struct A { sequence<float, 4> s; };\nstruct B { sequence<double, 6> s; };\n");
  const auto program = compile_ok("A", "B");
  ASSERT_NE(program, nullptr);
  Sample source(type("A").size);
  source.set(at("A", "s"), std::uint32_t{3});
  for (int i = 0; i < 3; ++i) source.set(4 + 4 * i, static_cast<float>(i) + 0.5f);
  const Sample target = run(*program, "B", source);
  EXPECT_EQ(target.get<std::uint32_t>(0), 3u);
  EXPECT_EQ(target.get<std::uint32_t>(4), 0u);  // padding before the doubles
  for (int i = 0; i < 3; ++i) EXPECT_EQ(target.get<double>(8 + 8 * i), i + 0.5);
  for (int i = 3; i < 6; ++i) EXPECT_EQ(target.get<std::uint64_t>(8 + 8 * i), 0u);
}

TEST_F(MappingByName, ASequenceLongerThanTheTargetBoundFailsUnlessTruncated) {
  define("struct A { sequence<long, 8> s; };\nstruct B { sequence<long, 2> s; };\n");
  Sample source(type("A").size);
  source.set(0, std::uint32_t{3});
  for (int i = 0; i < 3; ++i) source.set(4 + 4 * i, std::int32_t{i + 1});
  const auto strict = compile_ok("A", "B");
  ASSERT_NE(strict, nullptr);
  run(*strict, "B", source, 0, false);
  source.set(0, std::uint32_t{2});
  EXPECT_EQ(run(*strict, "B", source).get<std::uint32_t>(0), 2u);

  source.set(0, std::uint32_t{3});
  MappingRule cut = copy_rule("s", "s");
  cut.truncate = true;
  const auto truncating = compile_ok("A", "B", spec_of({cut}));
  ASSERT_NE(truncating, nullptr);
  const Sample target = run(*truncating, "B", source);
  EXPECT_EQ(target.get<std::uint32_t>(0), 2u);
  EXPECT_EQ(target.get<std::int32_t>(4), 1);
  EXPECT_EQ(target.get<std::int32_t>(8), 2);
}

TEST_F(MappingByName, UnboundedSequencesGoToTheTargetTail) {
  define("struct P { float x; string name; };\nstruct Q { string name; double x; };\n"
         "struct A { long id; sequence<P> points; };\nstruct C { sequence<Q> points; };\n");
  // A -> C: an unbounded sequence of structs with strings, both sides in the tails.
  const auto program = compile_ok("A", "C");
  ASSERT_NE(program, nullptr);
  const std::uint32_t p_size = type("P").size;
  Sample source(256);
  source.set(at("A", "id"), std::int32_t{9});
  const std::uint32_t first = 64;
  source.set(at("A", "points"), FlatSpan{first, 2});
  const std::uint32_t text = first + 2 * p_size;
  for (std::uint32_t i = 0; i < 2; ++i) {
    source.set(first + i * p_size + at("P", "x"), 1.5f + static_cast<float>(i));
    const std::string name = i == 0 ? "left" : "right";
    source.set(first + i * p_size + at("P", "name"), FlatSpan{text + 8 * i, static_cast<std::uint32_t>(name.size())});
    source.set_text(text + 8 * i, name);
  }
  const Sample target = run(*program, "C", source, 128);
  const auto points = target.get<FlatSpan>(at("C", "points"));
  EXPECT_EQ(points.count, 2u);
  EXPECT_EQ(points.offset, 8u);  // right after the fixed part, aligned for the elements
  const std::uint32_t q_size = type("Q").size;
  for (std::uint32_t i = 0; i < 2; ++i) {
    const std::uint32_t element = points.offset + i * q_size;
    EXPECT_EQ(target.get<double>(element + at("Q", "x")), 1.5 + i);
    const auto name = target.get<FlatSpan>(element + at("Q", "name"));
    EXPECT_EQ(target.text(name.offset, name.count), i == 0 ? "left" : "right");
    EXPECT_EQ(target.get<char>(name.offset + name.count), '\0');
  }
  EXPECT_EQ(last_size_, 8 + 2 * q_size + 5 + 6);
  // The tail must fit the capacity the caller gives.
  run(*program, "C", source, 8 + 2 * q_size + 5, false);
}

TEST_F(MappingByName, StringsBetweenEveryKindOfBound) {
  define("struct A { string<8> a; string<8> b; string c; string d; };\n"
         "struct B { string<16> a; string b; string<4> c; string d; };\n");
  const auto program = compile_ok("A", "B");
  ASSERT_NE(program, nullptr);
  Sample source(128);
  source.set_text(at("A", "a"), std::string("hello\0\0\0\0", 9));
  source.set_text(at("A", "b"), std::string("world!!!\0", 9));
  source.set(at("A", "c"), FlatSpan{96, 3});
  source.set_text(96, std::string("abc\0", 4));
  source.set(at("A", "d"), FlatSpan{100, 6});
  source.set_text(100, std::string("tail-d\0", 7));
  const Sample target = run(*program, "B", source, 128);
  EXPECT_EQ(target.text(at("B", "a"), 17), std::string("hello") + std::string(12, '\0'));
  const auto b = target.get<FlatSpan>(at("B", "b"));
  EXPECT_EQ(target.text(b.offset, b.count + 1), std::string("world!!!\0", 9));
  EXPECT_EQ(target.text(at("B", "c"), 5), std::string("abc\0\0", 5));
  const auto d = target.get<FlatSpan>(at("B", "d"));
  EXPECT_EQ(target.text(d.offset, d.count), "tail-d");
  EXPECT_EQ(b.offset, type("B").size);

  // A source longer than a bounded target fails the run...
  source.set(at("A", "c"), FlatSpan{100, 6});
  run(*program, "B", source, 128, false);
}

TEST_F(MappingByName, TruncatedStringsStopAtACharacterBoundary) {
  define("struct A { string s; };\nstruct B { string<4> s; };\n");
  MappingRule cut = copy_rule("s", "s");
  cut.truncate = true;
  const auto program = compile_ok("A", "B", spec_of({cut}));
  ASSERT_NE(program, nullptr);
  Sample source(64);
  const std::string text = "ab\xC3\xA9z";  // "abéz": é is two bytes, at 2 and 3
  source.set(0, FlatSpan{16, static_cast<std::uint32_t>(text.size())});
  source.set_text(16, text);
  const Sample target = run(*program, "B", source, 64);
  EXPECT_EQ(target.text(0, 5), std::string("ab\xC3\xA9\0", 5));
  source.set_text(16, "a\xC3\xA9xyz");
  source.set(0, FlatSpan{16, 6});
  const Sample cut_target = run(*program, "B", source, 64);
  EXPECT_EQ(cut_target.text(0, 5), std::string("a\xC3\xA9x\0", 5));
  source.set_text(16, "abc\xC3\xA9z");  // cutting at 4 would split the \xC3\xA9
  const Sample backed_off = run(*program, "B", source, 64);
  EXPECT_EQ(backed_off.text(0, 5), std::string("abc\0\0", 5));
}

TEST_F(MappingByName, EnumsByEnumeratorName) {
  define("module a { enum Mode { IDLE, DRIVE, @value(7) BRAKE }; struct S { Mode mode; Mode list[2]; }; };\n"
         "module b { enum Mode { BRAKE, IDLE, DRIVE, TURBO }; struct S { Mode mode; Mode list[2]; }; };\n");
  const auto program = compile_ok("a::S", "b::S");
  ASSERT_NE(program, nullptr);
  Sample source(type("a::S").size);
  source.set(at("a::S", "mode"), std::int32_t{7});       // BRAKE
  source.set(at("a::S", "list[0]"), std::int32_t{1});    // DRIVE
  source.set(at("a::S", "list[1]"), std::int32_t{0});    // IDLE
  const Sample target = run(*program, "b::S", source);
  EXPECT_EQ(target.get<std::int32_t>(at("b::S", "mode")), 0);  // BRAKE
  EXPECT_EQ(target.get<std::int32_t>(at("b::S", "list[0]")), 2);
  EXPECT_EQ(target.get<std::int32_t>(at("b::S", "list[1]")), 1);
  // A value that is no enumerator is a malformed sample.
  source.set(at("a::S", "mode"), std::int32_t{5});
  run(*program, "b::S", source, 0, false);
}

TEST_F(MappingByName, ByNameFalseLeavesUnnamedFieldsZero) {
  define("struct A { double x; double y; };\nstruct B { double x; double y; double z; };\n");
  const auto program = compile_ok("A", "B", spec_of({copy_rule("z", "x")}, false));
  ASSERT_NE(program, nullptr);
  Sample source(type("A").size);
  source.set(0, 1.0);
  source.set(8, 2.0);
  const Sample target = run(*program, "B", source);
  EXPECT_EQ(target.get<double>(at("B", "x")), 0.0);
  EXPECT_EQ(target.get<double>(at("B", "y")), 0.0);
  EXPECT_EQ(target.get<double>(at("B", "z")), 1.0);
}

TEST_F(MappingByName, TypedefsResolveToTheirTypes) {
  define("typedef double Meters;\ntypedef double Vec3[3];\n"
         "struct A { Meters d; Vec3 v; };\nstruct B { double d; double v[3]; };\n");
  const auto program = compile_ok("A", "B");
  ASSERT_NE(program, nullptr);
  EXPECT_EQ(program->describe(), std::vector<std::string>{"copy 32 bytes @0 -> @0 (the whole sample)"});
}

// ---------------------------------------------------------------------------------------

class MappingRules : public MappingFixture {};

TEST_F(MappingRules, RenamesFromNestedAndIndexedPaths) {
  define("struct In { double a; double c; };\nstruct Mid { In b[2]; };\nstruct Src { Mid a; double w[3]; };\n"
         "struct Dst { double first; double second; double w[3]; };\n");
  const auto program = compile_ok("Src", "Dst", spec_of({copy_rule("first", "a.b[1].c"), copy_rule("second", "w[2]")}));
  ASSERT_NE(program, nullptr);
  Sample source(type("Src").size);
  source.set(at("Src", "a.b[1].c"), 11.0);
  source.set(at("Src", "w[0]"), 1.0);
  source.set(at("Src", "w[1]"), 2.0);
  source.set(at("Src", "w[2]"), 3.0);
  const Sample target = run(*program, "Dst", source);
  EXPECT_EQ(target.get<double>(at("Dst", "first")), 11.0);
  EXPECT_EQ(target.get<double>(at("Dst", "second")), 3.0);
  EXPECT_EQ(target.get<double>(at("Dst", "w[2]")), 3.0);
}

TEST_F(MappingRules, ARenamedStructWithAFinerRuleInside) {
  define("struct V { double x; double y; };\nstruct W { double x; double y; };\n"
         "struct Src { V position; double yy; };\nstruct Dst { W pose; W other[2]; };\n");
  const auto program = compile_ok(
      "Src", "Dst",
      spec_of({copy_rule("pose", "position"), copy_rule("pose.y", "yy"), copy_rule("other", "position"),
               copy_rule("other[0]", "position"), copy_rule("other[1].x", "yy"), copy_rule("other[1].y", "yy")}));
  // `other` (W[2]) cannot take `position` (a V) as a whole, but the finer rules give every
  // element a source.
  ASSERT_NE(program, nullptr);
  Sample source(type("Src").size);
  source.set(at("Src", "position.x"), 1.0);
  source.set(at("Src", "position.y"), 2.0);
  source.set(at("Src", "yy"), 9.0);
  const Sample target = run(*program, "Dst", source);
  EXPECT_EQ(target.get<double>(at("Dst", "pose.x")), 1.0);
  EXPECT_EQ(target.get<double>(at("Dst", "pose.y")), 9.0);
  EXPECT_EQ(target.get<double>(at("Dst", "other[0].x")), 1.0);
  EXPECT_EQ(target.get<double>(at("Dst", "other[0].y")), 2.0);
  EXPECT_EQ(target.get<double>(at("Dst", "other[1].x")), 9.0);
}

TEST_F(MappingRules, ScaleAndOffset) {
  define("struct A { double v; float arr[2]; long n; };\nstruct B { double v; double arr[2]; double n; };\n");
  MappingRule v = copy_rule("v", "v");
  v.scale = 2.0;
  v.offset = -1.0;
  MappingRule arr = copy_rule("arr", "arr");
  arr.scale = 10.0;
  MappingRule n = copy_rule("n", "n");
  n.offset = 0.5;
  const auto program = compile_ok("A", "B", spec_of({v, arr, n}));
  ASSERT_NE(program, nullptr);
  Sample source(type("A").size);
  source.set(at("A", "v"), 3.0);
  source.set(at("A", "arr[0]"), 0.5f);
  source.set(at("A", "arr[1]"), -0.25f);
  source.set(at("A", "n"), std::int32_t{4});
  const Sample target = run(*program, "B", source);
  EXPECT_EQ(target.get<double>(at("B", "v")), 5.0);
  EXPECT_EQ(target.get<double>(at("B", "arr[0]")), 5.0);
  EXPECT_EQ(target.get<double>(at("B", "arr[1]")), -2.5);
  EXPECT_EQ(target.get<double>(at("B", "n")), 4.5);
}

TEST_F(MappingRules, EveryUnitFamily) {
  define("struct A { double v; };\nstruct B { double v; };\n");
  struct Case {
    const char* from;
    const char* to;
    double in;
    double out;
  };
  const Case cases[] = {
      {"deg", "rad", 180.0, 3.14159265358979323846},
      {"rad", "deg", 1.0, 57.29577951308232},
      {"m", "cm", 1.5, 150.0},
      {"mm", "m", 2500.0, 2.5},
      {"km", "m", 1.2, 1200.0},
      {"cm", "mm", 3.0, 30.0},
      {"s", "ms", 1.5, 1500.0},
      {"ms", "us", 2.0, 2000.0},
      {"ns", "s", 5e8, 0.5},
      {"us", "ns", 3.0, 3000.0},
      {"km/h", "m/s", 36.0, 10.0},
      {"mph", "m/s", 10.0, 4.4704},
      {"m/s", "km/h", 1.0, 3.6},
      {"rad/s", "deg/s", 3.14159265358979323846, 180.0},
      {"rpm", "rad/s", 60.0, 2 * 3.14159265358979323846},
      {"deg/s", "rpm", 360.0, 60.0},
      {"kg", "g", 1.25, 1250.0},
      {"g", "kg", 500.0, 0.5},
      {"degC", "K", 25.0, 298.15},
      {"K", "degC", 0.0, -273.15},
      {"degF", "degC", 212.0, 100.0},
      {"degC", "degF", -40.0, -40.0},
      {"degF", "K", 32.0, 273.15},
      {"Pa", "kPa", 1500.0, 1.5},
      {"bar", "Pa", 1.0, 1e5},
      {"psi", "kPa", 1.0, 6.894757293168361},
      {"kPa", "bar", 250.0, 2.5},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(std::string(c.from) + " -> " + c.to);
    MappingRule rule = copy_rule("v", "v");
    rule.from_unit = c.from;
    rule.to_unit = c.to;
    const auto program = compile_ok("A", "B", spec_of({rule}));
    ASSERT_NE(program, nullptr);
    Sample source(8);
    source.set(0, c.in);
    EXPECT_NEAR(run(*program, "B", source).get<double>(0), c.out, 1e-9 * std::max(1.0, std::abs(c.out)));
  }
}

TEST_F(MappingRules, UnitsThenScaleAndOffset) {
  define("struct A { double v; };\nstruct B { double v; };\n");
  MappingRule rule = copy_rule("v", "v");
  rule.from_unit = "km";
  rule.to_unit = "m";
  rule.scale = 2.0;
  rule.offset = 1.0;
  const auto program = compile_ok("A", "B", spec_of({rule}));
  ASSERT_NE(program, nullptr);
  Sample source(8);
  source.set(0, 1.5);
  EXPECT_EQ(run(*program, "B", source).get<double>(0), 3001.0);  // (1.5 km -> 1500 m) * 2 + 1
}

TEST_F(MappingRules, Constants) {
  define("module m { enum Color { RED, GREEN, @value(5) BLUE }; };\n"
         "struct A { double unused; };\n"
         "struct B { long n; octet o; boolean on; boolean off; char c; double d; float f; m::Color c1; m::Color c2;"
         " string<8> name; string label; unsigned long long big; short neg; };\n");
  const auto program = compile_ok(
      "A", "B",
      spec_of({constant_rule("n", "-12"), constant_rule("o", "255"), constant_rule("on", "true"),
               constant_rule("off", "0"), constant_rule("c", "x"), constant_rule("d", "-2.5e3"),
               constant_rule("f", "0.25"), constant_rule("c1", "BLUE"), constant_rule("c2", "m::Color::GREEN"),
               constant_rule("name", "robot"), constant_rule("label", "a longer label"),
               constant_rule("big", "18446744073709551615"), constant_rule("neg", "+7")},
              false));
  ASSERT_NE(program, nullptr);
  const Sample target = run(*program, "B", Sample(8), 128);
  EXPECT_EQ(target.get<std::int32_t>(at("B", "n")), -12);
  EXPECT_EQ(target.get<std::uint8_t>(at("B", "o")), 255);
  EXPECT_EQ(target.get<std::uint8_t>(at("B", "on")), 1);
  EXPECT_EQ(target.get<std::uint8_t>(at("B", "off")), 0);
  EXPECT_EQ(target.get<char>(at("B", "c")), 'x');
  EXPECT_EQ(target.get<double>(at("B", "d")), -2500.0);
  EXPECT_EQ(target.get<float>(at("B", "f")), 0.25f);
  EXPECT_EQ(target.get<std::int32_t>(at("B", "c1")), 5);
  EXPECT_EQ(target.get<std::int32_t>(at("B", "c2")), 1);
  EXPECT_EQ(target.text(at("B", "name"), 9), std::string("robot\0\0\0\0", 9));
  const auto label = target.get<FlatSpan>(at("B", "label"));
  EXPECT_EQ(target.text(label.offset, label.count + 1), std::string("a longer label\0", 15));
  EXPECT_EQ(target.get<std::uint64_t>(at("B", "big")), std::numeric_limits<std::uint64_t>::max());
  EXPECT_EQ(target.get<std::int16_t>(at("B", "neg")), 7);
}

// ---------------------------------------------------------------------------------------

class MappingNumbers : public MappingFixture {};

TEST_F(MappingNumbers, WideningIsAlwaysAllowed) {
  define("struct A { long a; float b; short c; unsigned long d; int8 e; uint16 f; long long g; octet h; };\n"
         "struct B { long long a; double b; double c; long long d; float e; long f; double g; uint16 h; };\n");
  const auto program = compile_ok("A", "B");
  ASSERT_NE(program, nullptr);
  Sample source(type("A").size);
  source.set(at("A", "a"), std::int32_t{-5});
  source.set(at("A", "b"), 1.25f);
  source.set(at("A", "c"), std::int16_t{-300});
  source.set(at("A", "d"), std::uint32_t{4000000000u});
  source.set(at("A", "e"), std::int8_t{-8});
  source.set(at("A", "f"), std::uint16_t{65535});
  source.set(at("A", "g"), std::int64_t{1} << 40);
  source.set(at("A", "h"), std::uint8_t{200});
  const Sample target = run(*program, "B", source);
  EXPECT_EQ(target.get<std::int64_t>(at("B", "a")), -5);
  EXPECT_EQ(target.get<double>(at("B", "b")), 1.25);
  EXPECT_EQ(target.get<double>(at("B", "c")), -300.0);
  EXPECT_EQ(target.get<std::int64_t>(at("B", "d")), 4000000000);
  EXPECT_EQ(target.get<float>(at("B", "e")), -8.0f);
  EXPECT_EQ(target.get<std::int32_t>(at("B", "f")), 65535);
  EXPECT_EQ(target.get<double>(at("B", "g")), 1099511627776.0);
  EXPECT_EQ(target.get<std::uint16_t>(at("B", "h")), 200);
}

TEST_F(MappingNumbers, NarrowingIsRefusedThenAllowed) {
  define("struct A { double a; double b; long long c; long d; unsigned long e; long f; };\n"
         "struct B { float a; long b; long c; unsigned long d; long e; float f; };\n");
  expect_errors("A", "B", {},
                {"narrowing source 'a' ('double') to target 'a' ('float') needs allow_narrowing=\"true\"",
                 "narrowing source 'b' ('double') to target 'b' ('long') needs allow_narrowing=\"true\"",
                 "narrowing source 'c' ('long long') to target 'c' ('long') needs allow_narrowing=\"true\"",
                 "narrowing source 'd' ('long') to target 'd' ('unsigned long') needs allow_narrowing=\"true\"",
                 "narrowing source 'e' ('unsigned long') to target 'e' ('long') needs allow_narrowing=\"true\"",
                 "narrowing source 'f' ('long') to target 'f' ('float') needs allow_narrowing=\"true\""});
  std::vector<MappingRule> rules;
  for (const char* name : {"a", "b", "c", "d", "e", "f"}) {
    MappingRule rule = copy_rule(name, name);
    rule.allow_narrowing = true;
    rules.push_back(rule);
  }
  const auto program = compile_ok("A", "B", spec_of(rules));
  ASSERT_NE(program, nullptr);
  Sample source(type("A").size);
  source.set(at("A", "a"), 1e300);
  source.set(at("A", "b"), -2.5);
  source.set(at("A", "c"), std::int64_t{1} << 40);
  source.set(at("A", "d"), std::int32_t{-1});
  source.set(at("A", "e"), std::uint32_t{3000000000u});
  source.set(at("A", "f"), std::int32_t{16777217});
  const Sample target = run(*program, "B", source);
  EXPECT_EQ(target.get<float>(at("B", "a")), std::numeric_limits<float>::max());
  EXPECT_EQ(target.get<std::int32_t>(at("B", "b")), -3);  // half away from zero
  EXPECT_EQ(target.get<std::int32_t>(at("B", "c")), std::numeric_limits<std::int32_t>::max());
  EXPECT_EQ(target.get<std::uint32_t>(at("B", "d")), 0u);
  EXPECT_EQ(target.get<std::int32_t>(at("B", "e")), std::numeric_limits<std::int32_t>::max());
  EXPECT_EQ(target.get<float>(at("B", "f")), 16777216.0f);
}

TEST_F(MappingNumbers, FloatToIntegerRoundsToNearestAndSaturates) {
  define("struct A { double v[8]; };\nstruct B { long i[4]; octet o[2]; long long l[2]; };\n"
         "struct C { double i[4]; double o[2]; double l[2]; };\n");
  std::vector<MappingRule> rules;
  for (const char* name : {"i", "o", "l"}) {
    MappingRule rule = copy_rule(name, name);
    rule.allow_narrowing = true;
    rules.push_back(rule);
  }
  const auto program = compile_ok("C", "B", spec_of(rules));
  ASSERT_NE(program, nullptr);
  Sample source(type("C").size);
  const double values[] = {2.5, -2.5, 1e20, std::nan(""), -3.0, 300.0, 9.3e18, -9.3e18};
  for (int k = 0; k < 8; ++k) source.set(8 * k, values[k]);
  const Sample target = run(*program, "B", source);
  EXPECT_EQ(target.get<std::int32_t>(at("B", "i[0]")), 3);
  EXPECT_EQ(target.get<std::int32_t>(at("B", "i[1]")), -3);
  EXPECT_EQ(target.get<std::int32_t>(at("B", "i[2]")), std::numeric_limits<std::int32_t>::max());
  EXPECT_EQ(target.get<std::int32_t>(at("B", "i[3]")), 0);  // NaN
  EXPECT_EQ(target.get<std::uint8_t>(at("B", "o[0]")), 0);
  EXPECT_EQ(target.get<std::uint8_t>(at("B", "o[1]")), 255);
  EXPECT_EQ(target.get<std::int64_t>(at("B", "l[0]")), std::numeric_limits<std::int64_t>::max());
  EXPECT_EQ(target.get<std::int64_t>(at("B", "l[1]")), std::numeric_limits<std::int64_t>::min());
}

TEST_F(MappingNumbers, AScaledValueIntoAnIntegerIsNarrowing) {
  define("struct A { long mm; };\nstruct B { long cm; };\n");
  MappingRule rule = copy_rule("cm", "mm");
  rule.from_unit = "mm";
  rule.to_unit = "cm";
  expect_errors("A", "B", spec_of({rule}),
                {"narrowing source 'mm' ('long') to target 'cm' ('long') needs allow_narrowing=\"true\" (scaled "
                 "values are computed as double)"});
  rule.allow_narrowing = true;
  const auto program = compile_ok("A", "B", spec_of({rule}));
  ASSERT_NE(program, nullptr);
  Sample source(4);
  source.set(0, std::int32_t{125});
  EXPECT_EQ(run(*program, "B", source).get<std::int32_t>(0), 13);
}

// ---------------------------------------------------------------------------------------

class MappingTransforms : public MappingFixture {
 protected:
  void SetUp() override {
    define("struct V2 { double x; double y; };\nstruct V3 { double x; double y; double z; };\n"
           "struct V3f { float x; float y; float z; };\n"
           "struct Src { V2 p2; double p3[3]; double p4[4]; V3f f3; };\n"
           "struct Dst { double q2[2]; V3 q3; double q4[4]; double r3[3]; V3f f3; };\n");
  }
  static MappingRule narrowing(MappingRule rule) {
    rule.allow_narrowing = true;
    return rule;
  }
};

TEST_F(MappingTransforms, LinearAndAffineOfEverySquareSizeAndANonSquareOne) {
  const auto program = compile_ok(
      "Src", "Dst",
      spec_of({transform_rule(Kind::linear, "q2", "p2", 2, 2, {0, -1, 1, 0}),
               transform_rule(Kind::affine, "q3", "p3", 3, 3, {1, 0, 0, 0, 2, 0, 0, 0, 3}, {10, 20, 30}),
               transform_rule(Kind::linear, "q4", "p4", 4, 4, {0, 0, 0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 0}),
               transform_rule(Kind::affine, "r3", "p2", 3, 2, {1, 0, 0, 1, 1, 1}, {0, 0, 0.5}),
               narrowing(transform_rule(Kind::linear, "f3", "f3", 3, 3, {0, 1, 0, 1, 0, 0, 0, 0, 1}))}));
  ASSERT_NE(program, nullptr);
  Sample source(type("Src").size);
  source.set(at("Src", "p2.x"), 1.0);
  source.set(at("Src", "p2.y"), 2.0);
  for (int i = 0; i < 3; ++i) source.set(at("Src", "p3[" + std::to_string(i) + "]"), i + 1.0);
  for (int i = 0; i < 4; ++i) source.set(at("Src", "p4[" + std::to_string(i) + "]"), i + 1.0);
  source.set(at("Src", "f3.x"), 1.5f);
  source.set(at("Src", "f3.y"), 2.5f);
  source.set(at("Src", "f3.z"), 3.5f);
  const Sample target = run(*program, "Dst", source);
  EXPECT_EQ(target.get<double>(at("Dst", "q2[0]")), -2.0);  // rotation by 90 degrees
  EXPECT_EQ(target.get<double>(at("Dst", "q2[1]")), 1.0);
  EXPECT_EQ(target.get<double>(at("Dst", "q3.x")), 11.0);
  EXPECT_EQ(target.get<double>(at("Dst", "q3.y")), 24.0);
  EXPECT_EQ(target.get<double>(at("Dst", "q3.z")), 39.0);
  for (int i = 0; i < 4; ++i) EXPECT_EQ(target.get<double>(at("Dst", "q4[" + std::to_string(i) + "]")), 4.0 - i);
  EXPECT_EQ(target.get<double>(at("Dst", "r3[0]")), 1.0);
  EXPECT_EQ(target.get<double>(at("Dst", "r3[1]")), 2.0);
  EXPECT_EQ(target.get<double>(at("Dst", "r3[2]")), 3.5);
  EXPECT_EQ(target.get<float>(at("Dst", "f3.x")), 2.5f);
  EXPECT_EQ(target.get<float>(at("Dst", "f3.y")), 1.5f);
  EXPECT_EQ(target.get<float>(at("Dst", "f3.z")), 3.5f);
}

TEST_F(MappingTransforms, Errors) {
  expect_errors("Src", "Dst",
                spec_of({transform_rule(Kind::linear, "q2", "p3", 2, 2, {1, 0, 0, 1}),
                         transform_rule(Kind::affine, "q3", "p3", 3, 3, {1, 0, 0, 0, 1, 0, 0, 0, 1}, {1, 2}),
                         transform_rule(Kind::linear, "q4", "p4", 4, 4, std::vector<double>(16, 1.0), {1, 2, 3, 4}),
                         transform_rule(Kind::linear, "r3", "p2.x", 1, 1, {1}),
                         transform_rule(Kind::linear, "f3", "f3", 3, 3, {1, 0, 0, 0, 1, 0, 0, 0, 1})},
                        false),
                {"matrix is 2x2, but target 'q2' has 2 elements and source 'p3' has 3: expected 2x3",
                 "translation has 2 entries, but target 'q3' has 3 elements",
                 "a translation needs transform=\"affine\"",
                 "source 'p2.x' ('double') is not a vector field (a fixed array of 1 to 6 numbers, or a struct of 1 "
                 "to 6 numeric fields)",
                 "a transform computes in double: writing target 'f3' ('V3f') is narrowing and needs "
                 "allow_narrowing=\"true\""});
}

// ---------------------------------------------------------------------------------------

class MappingErrors : public MappingFixture {
 protected:
  void SetUp() override {
    define("module m { enum Color { RED, GREEN }; enum Shade { RED, DARK, GREEN, LIGHT }; };\n"
           "struct In { double x; double y; };\n"
           "struct Src { double speed; string name; In pose; double arr[3]; sequence<double> seq; m::Shade shade;"
           " long count; };\n"
           "struct Out { double x; double y; double z; };\n"
           "struct Dst { double speed; double name; Out pose; double arr[4]; m::Color shade; string<4> label;"
           " long count; double missing; double absent; };\n");
  }
};

TEST_F(MappingErrors, WhatTheTypesCannotDoByName) {
  expect_errors("Src", "Dst", {},
                {"cannot map source 'name' ('string') to target 'name' ('double')",
                 "target field 'pose.z' of 'Dst' has no source in 'Src' (fields of source 'pose': x, y)",
                 "cannot map source 'arr' ('double[3]') to target 'arr' ('double[4]'): the lengths differ",
                 "cannot map source 'shade' ('m::Shade') to target 'shade' ('m::Color'): no enumerator 'DARK', "
                 "'LIGHT' in 'm::Color'",
                 "target fields 'label', 'missing', 'absent' of 'Dst' have no source in 'Src' (source fields: "
                 "speed, name, pose, arr, seq, shade, count)"});
}

TEST_F(MappingErrors, OneMissingTargetField) {
  define("struct T1 { double a; double b; };\nstruct T2 { double a; double x; };\n");
  expect_errors("T1", "T2", {}, {"target field 'x' of 'T2' has no source in 'T1' (source fields: a, b)"});
}

TEST_F(MappingErrors, BadPaths) {
  expect_errors("Src", "Dst",
                spec_of({copy_rule("pose..x", "speed"), copy_rule("speed", "pose.x["),
                         copy_rule("pose.w", "speed"), copy_rule("speed.v", "speed"),
                         copy_rule("pose[1]", "speed"), copy_rule("arr[4]", "speed"),
                         copy_rule("count", "seq[0]"), copy_rule("missing", "pose.q"),
                         copy_rule("absent", "")},
                        false),
                {"bad target path 'pose..x' (expected names and [index], e.g. a.b[1].c)",
                 "bad source path 'pose.x[' (expected names and [index], e.g. a.b[1].c)",
                 "target 'pose.w' not found in 'Dst' (fields of 'pose': x, y, z)",
                 "target 'speed.v' not found in 'Dst' ('speed' is 'double', which has no fields)",
                 "target 'pose[1]' not found in 'Dst' ('pose' is 'Out'; an index needs a fixed array)",
                 "target 'arr[4]' not found in 'Dst' ('arr' is 'double[4]')",
                 "source 'seq[0]' not found in 'Src' ('seq' is 'sequence<double>'; an index needs a fixed array)",
                 "source 'pose.q' not found in 'Src' (fields of 'pose': x, y)",
                 "rule for target 'absent' has no source"});
}

TEST_F(MappingErrors, RulesThatCollide) {
  MappingRule first = constant_rule("pose", "1");
  first.where.line = 4;
  MappingRule second = copy_rule("speed", "speed");
  second.where.line = 5;
  MappingRule again = copy_rule("speed", "count");
  expect_errors("Src", "Dst", spec_of({first, second, again, copy_rule("pose.x", "speed")}, false),
                {"duplicate rule for target 'speed': already given at line 5",
                 "rule for target 'pose.x' is inside 'pose', which the rule at line 4 sets as a whole",
                 "a constant needs a number, boolean, char, enum or string target; 'pose' is 'Out'"});
}

TEST_F(MappingErrors, Units) {
  MappingRule unknown = copy_rule("speed", "speed");
  unknown.from_unit = "furlong";
  unknown.to_unit = "m";
  MappingRule incompatible = copy_rule("pose.x", "pose.x");
  incompatible.from_unit = "deg";
  incompatible.to_unit = "m";
  MappingRule alone = copy_rule("pose.y", "pose.y");
  alone.to_unit = "m";
  MappingRule on_text = copy_rule("label", "name");
  on_text.scale = 2.0;
  MappingRule on_struct = copy_rule("pose", "pose");
  on_struct.from_unit = "m";
  on_struct.to_unit = "cm";
  expect_errors("Src", "Dst", spec_of({unknown, incompatible, alone, on_text}, false),
                {"unknown unit 'furlong' (known: rad, deg, m, cm, mm, km, s, ms, us, ns, m/s, km/h, mph, rad/s, "
                 "deg/s, rpm, kg, g, K, degC, degF, Pa, kPa, bar, psi)",
                 "cannot convert 'deg' (angle) to 'm' (length)", "from_unit and to_unit go together",
                 "scale, offset and units apply to numbers: target 'label' is 'string<4>'"});
  expect_errors("Src", "Dst", spec_of({on_struct}, false),
                {"scale, offset and units apply to numbers: target 'pose' is 'Out'"});
}

TEST_F(MappingErrors, ScaleOnAConstantOrATransform) {
  MappingRule constant = constant_rule("speed", "1");
  constant.scale = 2.0;
  MappingRule transform = transform_rule(Kind::linear, "arr", "arr", 4, 3, std::vector<double>(12, 0.0));
  transform.offset = 1.0;
  expect_errors("Src", "Dst", spec_of({constant, transform}, false),
                {"scale, offset and units apply to copies, not to a constant",
                 "scale, offset and units apply to copies, not to a transform"});
}

TEST_F(MappingErrors, Constants) {
  define("struct C { double d; octet o; long l; boolean b; char c; m::Color e; string<3> s; In in; };\n");
  expect_errors("Src", "C",
                spec_of({constant_rule("d", "fast"), constant_rule("o", "256"), constant_rule("l", "2.5"),
                         constant_rule("b", "yes"), constant_rule("c", "ab"), constant_rule("e", "BLUE"),
                         constant_rule("s", "four"), constant_rule("in", "0")},
                        false),
                {"bad constant 'fast' for target 'd' ('double'): expected a finite number",
                 "constant '256' is out of range for target 'o' ('octet')",
                 "bad constant '2.5' for target 'l' ('long'): expected an integer",
                 "bad constant 'yes' for target 'b' ('boolean'): expected true, false, 1 or 0",
                 "bad constant 'ab' for target 'c' ('char'): expected one character",
                 "'BLUE' is not an enumerator of 'm::Color' (enumerators: RED, GREEN)",
                 "constant of 4 characters does not fit target 's' ('string<3>')",
                 "a constant needs a number, boolean, char, enum or string target; 'in' is 'In'"});
}

TEST_F(MappingErrors, ARenameWhoseSourceLacksAField) {
  MappingRule rule = copy_rule("pose", "pose");
  expect_errors("Src", "Dst", spec_of({rule}, false),
                {"target field 'pose.z' of 'Dst' has no source in 'Src' (fields of source 'pose': x, y)"});
  ASSERT_EQ(problems_.size(), 1u);
  EXPECT_NE(problems_[0].rule, nullptr);  // the rule's problem, reported at the rule
}

TEST_F(MappingErrors, TheDiagnosticsFormPutsRuleProblemsAtTheirRules) {
  MappingSpec spec = spec_of({copy_rule("pose", "pose")});
  spec.where = {"app.xml", 10, 7};
  spec.element_path = "/application_profile/port_connections/port_connection/mapping";
  spec.rules[0].where = {"app.xml", 11, 9};
  spec.rules[0].element_path = spec.element_path + "/field";
  Diagnostics diagnostics;
  EXPECT_EQ(MappingProgram::compile(type("Src"), type("Dst"), spec, diagnostics), nullptr);
  std::vector<std::string> rendered;
  for (const Diagnostic& item : diagnostics.all()) rendered.push_back(item.to_string());
  EXPECT_EQ(rendered.size(), 5u);
  const auto has = [&](const std::string& text) {
    return std::find(rendered.begin(), rendered.end(), text) != rendered.end();
  };
  EXPECT_TRUE(has("app.xml:11:9: /application_profile/port_connections/port_connection/mapping/field: target "
                  "field 'pose.z' of 'Dst' has no source in 'Src' (fields of source 'pose': x, y)"))
      << ::testing::PrintToString(rendered);
  EXPECT_TRUE(has("app.xml:10:7: /application_profile/port_connections/port_connection/mapping: cannot map "
                  "source 'name' ('string') to target 'name' ('double')"))
      << ::testing::PrintToString(rendered);
}

// ---------------------------------------------------------------------------------------

class MappingRun : public MappingFixture {};

TEST_F(MappingRun, MalformedSourcesAndSmallTargetsReturnFalse) {
  define("module a { enum E { X, Y }; };\n"
         "struct A { double v; sequence<long, 2> b; sequence<long> u; string s; a::E e; };\n"
         "struct B { double v; sequence<long, 2> b; sequence<long> u; string s; a::E e; };\n");
  const auto program = compile_ok("A", "B");
  ASSERT_NE(program, nullptr);
  const std::uint32_t fixed = type("A").size;
  Sample good(fixed + 32, std::byte{0});
  good.set(at("A", "u"), FlatSpan{fixed, 2});
  good.set(at("A", "s"), FlatSpan{fixed + 8, 3});
  good.set_text(fixed + 8, "abc");
  const auto run_with = [&](const Sample& source, std::uint32_t source_size, std::uint32_t capacity) {
    Sample target(capacity);
    std::uint32_t size = 0;
    return program->run(source.data(), source_size, target.data(), capacity, size);
  };
  EXPECT_TRUE(run_with(good, good.size(), 128));
  EXPECT_FALSE(run_with(good, fixed - 1, 128));            // shorter than the fixed part
  EXPECT_FALSE(run_with(good, fixed + 7, 128));            // the sequence's elements are cut off
  EXPECT_FALSE(run_with(good, good.size(), fixed - 1));    // target smaller than its fixed part
  EXPECT_FALSE(run_with(good, good.size(), fixed + 8));    // no room for the string in the tail
  Sample bad = good;
  bad.set(at("A", "b"), std::uint32_t{3});                 // longer than its own bound
  EXPECT_FALSE(run_with(bad, bad.size(), 128));
  bad = good;
  bad.set(at("A", "u"), FlatSpan{0xFFFFFFF0u, 4});         // a span outside the sample
  EXPECT_FALSE(run_with(bad, bad.size(), 128));
  bad = good;
  bad.set(at("A", "s"), FlatSpan{fixed + 30, 5});
  EXPECT_FALSE(run_with(bad, bad.size(), 128));
  std::uint32_t size = 0;
  Sample target(128);
  EXPECT_FALSE(program->run(nullptr, 0, target.data(), 128, size));
}

TEST_F(MappingRun, DescribeListsTheStepsInWords) {
  define("module a { enum E { X, Y }; };\nmodule b { enum E { Y, X }; };\n"
         "struct A { float f; double d; a::E e; sequence<float, 2> s; double v[2]; };\n"
         "struct B { double f; double d; b::E e; sequence<double> s; double w[2]; long k; };\n");
  MappingRule scaled = copy_rule("d", "d");
  scaled.from_unit = "deg";
  scaled.to_unit = "rad";
  const auto program = compile_ok(
      "A", "B",
      spec_of({scaled, transform_rule(Kind::linear, "w", "v", 2, 2, {1, 0, 0, 1}), constant_rule("k", "3")}));
  ASSERT_NE(program, nullptr);
  EXPECT_EQ(program->describe(),
            (std::vector<std::string>{
                "zero 4 bytes @28",
                "zero 4 bytes @52",
                "convert float -> double @0 -> @0 (f)",
                "scale double -> double: y = x * 0.017453292519943295 + 0 @8 -> @8 (d)",
                "enum by name 'a::E' -> 'b::E' (2 values) @16 -> @16 (e)",
                "sequence <=2 -> unbounded, into the target's tail @20 -> @20 (s), per element:",
                "  convert float -> double @0 -> @0 (s[])",
                "linear 2x2 transform (v -> w)",
                "constant '3' -> @48 (k)",
            }));
}

// ---------------------------------------------------------------------------------------
// LCM length members: `int32_t nsamples; double samples[nsamples];` in a target struct is set
// from the count of the target sequence, whatever the source has.

class MappingLcmLengths : public MappingFixture {
 protected:
  void SetUp() override {
    // As tests/dds_peers/peer.idl and tests/lcm_e2e/lcm/peer.lcm declare them.
    define("module peer { struct Pose { long id; double x; float heading; boolean valid; string<15> frame;\n"
           "  sequence<double, 8> samples; short quad[4]; }; };\n");
    define_lcm("package peer;\n"
               "struct pose_t { int32_t id; double x; float heading; boolean valid; string frame;\n"
               "  int32_t nsamples; double samples[nsamples]; int16_t quad[4]; }\n");
  }

  // A peer::Pose with `count` samples 0.5, 1.0, ...
  Sample pose(std::uint32_t count) {
    Sample source(type("peer::Pose").size, std::byte{0});
    source.set(at("peer::Pose", "id"), std::int32_t{7});
    source.set(at("peer::Pose", "x"), 1.25);
    source.set(at("peer::Pose", "heading"), 0.5f);
    source.set(at("peer::Pose", "valid"), std::uint8_t{1});
    source.set_text(at("peer::Pose", "frame"), "map");
    const std::uint32_t samples = at("peer::Pose", "samples");
    source.set(samples, count);
    for (std::uint32_t i = 0; i < count; ++i) source.set(samples + 8 + 8 * i, 0.5 * (i + 1));
    for (std::uint32_t i = 0; i < 4; ++i) {
      source.set(at("peer::Pose", "quad") + 2 * i, static_cast<std::int16_t>(static_cast<int>(i) - 2));
    }
    return source;
  }

  std::unique_ptr<Codec> lcm_codec(std::string_view name) {
    auto made = make_lcm_codec(type(name));
    if (!made.ok()) {
      ADD_FAILURE() << made.error().message;
      return nullptr;
    }
    return std::move(made).value();
  }

  // Encodes a flat sample of `name` (of last_size_ bytes) with the LCM codec and decodes it
  // back; the decoded sample, or an empty one when either fails.
  Sample through_lcm(std::string_view name, const Sample& flat) {
    const auto codec = lcm_codec(name);
    if (codec == nullptr) return Sample(0);
    std::vector<std::byte> wire(codec->max_wire_size(last_size_));
    const CodecResult encoded =
        codec->encode(flat.data(), last_size_, wire.data(), static_cast<std::uint32_t>(wire.size()));
    EXPECT_TRUE(encoded.ok()) << to_string(encoded.error);
    if (!encoded.ok()) return Sample(0);
    Sample decoded(1024, std::byte{0});
    const CodecResult result = codec->decode(wire.data(), encoded.size, decoded.data(), decoded.size());
    EXPECT_TRUE(result.ok()) << to_string(result.error);
    if (!result.ok()) return Sample(0);
    return decoded;
  }

  std::vector<double> doubles(const Sample& sample, FlatSpan span) {
    std::vector<double> out;
    for (std::uint32_t i = 0; i < span.count; ++i) out.push_back(sample.get<double>(span.offset + 8 * i));
    return out;
  }
};

TEST_F(MappingLcmLengths, AnIdlPoseOntoAnLcmPoseCountsItsSamples) {
  const auto program = compile_ok("peer::Pose", "peer::pose_t");
  ASSERT_NE(program, nullptr);
  const auto described = program->describe();
  EXPECT_NE(std::find(described.begin(), described.end(), "nsamples = count(samples)"), described.end())
      << ::testing::PrintToString(described);
  for (const std::uint32_t count : {0u, 1u, 8u}) {
    SCOPED_TRACE("count " + std::to_string(count));
    const Sample target = run(*program, "peer::pose_t", pose(count), 256);
    EXPECT_EQ(target.get<std::int32_t>(at("peer::pose_t", "nsamples")), static_cast<std::int32_t>(count));
    const auto samples = target.get<FlatSpan>(at("peer::pose_t", "samples"));
    ASSERT_EQ(samples.count, count);
    std::vector<double> expected;
    for (std::uint32_t i = 0; i < count; ++i) expected.push_back(0.5 * (i + 1));
    EXPECT_EQ(doubles(target, samples), expected);

    // The LCM codec accepts it (it refuses a length member that disagrees with the count),
    // and the message decodes to the same values.
    const Sample decoded = through_lcm("peer::pose_t", target);
    if (decoded.size() == 0) continue;
    EXPECT_EQ(decoded.get<std::int32_t>(at("peer::pose_t", "id")), 7);
    EXPECT_EQ(decoded.get<double>(at("peer::pose_t", "x")), 1.25);
    EXPECT_EQ(decoded.get<float>(at("peer::pose_t", "heading")), 0.5f);
    EXPECT_EQ(decoded.get<std::uint8_t>(at("peer::pose_t", "valid")), 1);
    const auto frame = decoded.get<FlatSpan>(at("peer::pose_t", "frame"));
    EXPECT_EQ(decoded.text(frame.offset, frame.count), "map");
    EXPECT_EQ(decoded.get<std::int32_t>(at("peer::pose_t", "nsamples")), static_cast<std::int32_t>(count));
    EXPECT_EQ(doubles(decoded, decoded.get<FlatSpan>(at("peer::pose_t", "samples"))), expected);
    for (std::uint32_t i = 0; i < 4; ++i) {
      EXPECT_EQ(decoded.get<std::int16_t>(at("peer::pose_t", "quad") + 2 * i), static_cast<std::int16_t>(static_cast<int>(i) - 2));
    }
  }
}

TEST_F(MappingLcmLengths, TheCountWinsOverASourceFieldOfTheSameNameButNotOverARule) {
  define("module other { struct Pose { long nsamples; sequence<double> samples; }; };\n");
  define_lcm("package other;\nstruct pose_t { int32_t nsamples; double samples[nsamples]; }\n");
  Sample source(64, std::byte{0});
  source.set(at("other::Pose", "nsamples"), std::int32_t{5});  // what the source claims
  source.set(at("other::Pose", "samples"), FlatSpan{32, 2});
  source.set(32, 1.0);
  source.set(40, 2.0);
  const auto by_name = compile_ok("other::Pose", "other::pose_t");
  ASSERT_NE(by_name, nullptr);
  EXPECT_EQ(run(*by_name, "other::pose_t", source, 64).get<std::int32_t>(at("other::pose_t", "nsamples")), 2);

  // A rule for the member is kept as written (the LCM codec then checks it).
  const auto ruled = compile_ok("other::Pose", "other::pose_t", spec_of({constant_rule("nsamples", "3")}));
  ASSERT_NE(ruled, nullptr);
  EXPECT_EQ(run(*ruled, "other::pose_t", source, 64).get<std::int32_t>(at("other::pose_t", "nsamples")), 3);
}

TEST_F(MappingLcmLengths, ThroughRulesAndInsideSequencesOfStructs) {
  define("module peer { struct Readings { sequence<double, 8> values; long id; };\n"
         "  struct Track { long id; sequence<Pose> poses; }; };\n");
  define_lcm("package peer;\nstruct track_t { int32_t id; int16_t n; pose_t poses[n]; }\n");

  // A rule renames the sequence; by_name="false" leaves the rest zero; the length follows.
  const auto renamed = compile_ok("peer::Readings", "peer::pose_t",
                                  spec_of({copy_rule("samples", "values"), copy_rule("id", "id")}, false));
  ASSERT_NE(renamed, nullptr);
  Sample readings(type("peer::Readings").size, std::byte{0});
  readings.set(at("peer::Readings", "values"), std::uint32_t{3});
  for (std::uint32_t i = 0; i < 3; ++i) readings.set(at("peer::Readings", "values") + 8 + 8 * i, 1.0 + i);
  const Sample target = run(*renamed, "peer::pose_t", readings, 256);
  EXPECT_EQ(target.get<std::int32_t>(at("peer::pose_t", "nsamples")), 3);
  EXPECT_EQ(target.get<FlatSpan>(at("peer::pose_t", "samples")).count, 3u);
  EXPECT_EQ(through_lcm("peer::pose_t", target).get<std::int32_t>(at("peer::pose_t", "nsamples")), 3);

  // Each element of a sequence of structs counts its own samples, and the outer length its
  // elements.
  const auto track = compile_ok("peer::Track", "peer::track_t");
  ASSERT_NE(track, nullptr);
  const std::uint32_t pose_size = type("peer::Pose").size;
  const std::uint32_t first = 64;
  Sample source(first + 2 * pose_size, std::byte{0});
  source.set(at("peer::Track", "poses"), FlatSpan{first, 2});
  for (std::uint32_t i = 0; i < 2; ++i) {
    const Sample element = pose(i == 0 ? 2 : 5);
    std::memcpy(source.data() + first + i * pose_size, element.data(), pose_size);
  }
  const Sample tracked = run(*track, "peer::track_t", source, 1024);
  EXPECT_EQ(tracked.get<std::int16_t>(at("peer::track_t", "n")), 2);
  const auto poses = tracked.get<FlatSpan>(at("peer::track_t", "poses"));
  ASSERT_EQ(poses.count, 2u);
  for (std::uint32_t i = 0; i < 2; ++i) {
    const std::uint32_t element = poses.offset + i * type("peer::pose_t").size;
    EXPECT_EQ(tracked.get<std::int32_t>(element + at("peer::pose_t", "nsamples")), i == 0 ? 2 : 5);
    EXPECT_EQ(tracked.get<FlatSpan>(element + at("peer::pose_t", "samples")).count, i == 0 ? 2u : 5u);
  }
  const Sample decoded = through_lcm("peer::track_t", tracked);
  if (decoded.size() != 0) {
    const auto decoded_poses = decoded.get<FlatSpan>(at("peer::track_t", "poses"));
    ASSERT_EQ(decoded_poses.count, 2u);
    const std::uint32_t second = decoded_poses.offset + type("peer::pose_t").size;
    EXPECT_EQ(doubles(decoded, decoded.get<FlatSpan>(second + at("peer::pose_t", "samples"))),
              (std::vector<double>{0.5, 1.0, 1.5, 2.0, 2.5}));
  }
}

TEST_F(MappingLcmLengths, ACountBeyondTheMembersRangeFailsTheRun) {
  define("module small { struct Free { sequence<octet> data; }; struct Capped { sequence<octet, 100> data; }; };\n");
  define_lcm("package small;\nstruct bytes_t { int8_t n; byte data[n]; }\n");
  const auto free = compile_ok("small::Free", "small::bytes_t");
  ASSERT_NE(free, nullptr);
  EXPECT_EQ(free->describe().back(), "n = count(data), fails above 127");
  for (const std::uint32_t count : {127u, 128u}) {
    Sample source(8 + count, std::byte{0});
    source.set(0, FlatSpan{8, count});
    const Sample target = run(*free, "small::bytes_t", source, 256, count == 127);
    if (count == 127) {
      EXPECT_EQ(target.get<std::int8_t>(at("small::bytes_t", "n")), 127);
    }
  }
  // A bound the member holds needs no words about it (the check stays, and never fails).
  const auto capped = compile_ok("small::Capped", "small::bytes_t");
  ASSERT_NE(capped, nullptr);
  EXPECT_EQ(capped->describe().back(), "n = count(data)");
}

TEST_F(MappingLcmLengths, TwoSequencesOfOneLengthMustAgree) {
  // The LCM parser lets several arrays share a length member.
  define("module shared { struct Two { sequence<double> a; sequence<float, 4> b; }; };\n");
  define_lcm("package shared;\nstruct two_t { int16_t n; double a[n]; float b[n]; }\n");
  const auto program = compile_ok("shared::Two", "shared::two_t");
  ASSERT_NE(program, nullptr);
  const auto described = program->describe();
  ASSERT_GE(described.size(), 2u);
  EXPECT_EQ(described[described.size() - 2], "n = count(a), fails above 32767");
  EXPECT_EQ(described.back(), "check n == count(b), fails if they differ");
  Sample source(type("shared::Two").size + 32, std::byte{0});
  source.set(at("shared::Two", "a"), FlatSpan{type("shared::Two").size, 2});
  source.set(at("shared::Two", "b"), std::uint32_t{2});
  const Sample target = run(*program, "shared::two_t", source, 256);
  EXPECT_EQ(target.get<std::int16_t>(at("shared::two_t", "n")), 2);
  EXPECT_EQ(through_lcm("shared::two_t", target).get<std::int16_t>(at("shared::two_t", "n")), 2);
  source.set(at("shared::Two", "b"), std::uint32_t{3});
  run(*program, "shared::two_t", source, 256, false);
}

TEST_F(MappingLcmLengths, InnerDimensionsAreNotCounted) {
  define("module grid { typedef sequence<boolean> Flags; struct Grid { sequence<sequence<double>> m; };\n"
         "  struct Sized { long cols; sequence<sequence<double>> m; }; struct Bits { Flags bits[2]; }; };\n");
  define_lcm("package grid;\nstruct grid_t { int32_t rows; int32_t cols; double m[rows][cols]; }\n"
             "struct bits_t { int8_t k; boolean bits[2][k]; }\n");
  expect_errors("grid::Grid", "grid::grid_t", {},
                {"target field 'cols' of 'grid::grid_t' has no source in 'grid::Grid' and is not derived: it is the "
                 "length of an inner dimension of 'm', and a mapping counts only outermost ones (give it a rule or a "
                 "source field of its name)"});
  expect_errors("grid::Bits", "grid::bits_t", {},
                {"target field 'k' of 'grid::bits_t' has no source in 'grid::Bits' and is not derived: it is the "
                 "length of an inner dimension of 'bits', and a mapping counts only outermost ones (give it a rule "
                 "or a source field of its name)"});
  // With a source field of its name it is copied, as any other field (the codec checks it).
  const auto sized = compile_ok("grid::Sized", "grid::grid_t");
  ASSERT_NE(sized, nullptr);
  const auto described = sized->describe();
  EXPECT_EQ(described.back(), "rows = count(m)");
  // Under a rule the message is the rule's.
  define("module grid { struct Outer { Grid g; }; };\n");
  define_lcm("package grid;\nstruct outer_t { grid_t g; }\n");
  MappingSpec spec = spec_of({copy_rule("g", "g")}, false);
  expect_errors("grid::Outer", "grid::outer_t", spec,
                {"target field 'g.cols' of 'grid::outer_t' has no source in 'grid::Outer' and is not derived: it is "
                 "the length of an inner dimension of 'g.m', and a mapping counts only outermost ones (give it a "
                 "rule or a source field of its name)"});
  ASSERT_EQ(problems_.size(), 1u);
  EXPECT_NE(problems_[0].rule, nullptr);
}

}  // namespace
