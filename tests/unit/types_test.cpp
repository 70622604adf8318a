#include "polyport/types/types.hpp"

#include <gtest/gtest.h>

#include "../support/type_lookup.hpp"
#include <unistd.h>

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "polyport/base/diagnostics.hpp"

namespace {

using namespace polyport;

// Parses IDL text into a fresh registry and keeps the rendered diagnostics.
class IdlFixture : public ::testing::Test {
 protected:
  bool parse(std::string_view idl, const std::string& file = "test.idl") {
    return registry_.add_idl_text(idl, file, diagnostics_);
  }

  std::vector<std::string> messages() const {
    std::vector<std::string> out;
    for (const Diagnostic& item : diagnostics_.all()) out.push_back(item.to_string());
    return out;
  }

  // Parses text that must be valid and returns the named type.
  const Type& parse_ok(std::string_view idl, std::string_view name) {
    EXPECT_TRUE(parse(idl)) << ::testing::PrintToString(messages());
    EXPECT_TRUE(diagnostics_.all().empty()) << ::testing::PrintToString(messages());
    return test::type_or_fail(registry_, name);
  }

  const Field& field(const Type& type, std::string_view name) { return test::field_or_fail(type, name); }

  std::vector<std::string> errors_for(std::string_view idl) {
    EXPECT_FALSE(parse(idl));
    return messages();
  }

  TypeRegistry registry_;
  Diagnostics diagnostics_;
};

using Messages = std::vector<std::string>;

// ---- diagnostics rendering -------------------------------------------------------------

TEST(DiagnosticsFormat, RendersLocationPathAndSeverity) {
  Diagnostics diagnostics;
  diagnostics.error({"a.idl", 3, 7}, "", "unknown type 'X'");
  diagnostics.error({"p.xml", 10, 2}, "/application_profile/port", "bad");
  diagnostics.warning({"p.xml", 1, 1}, "/x", "unused");
  diagnostics.error({"missing.idl", 0, 0}, "", "cannot open file");
  diagnostics.error({"f.idl", 4, 0}, "", "no column");
  diagnostics.error({}, "/p", "no location");
  ASSERT_EQ(diagnostics.all().size(), 6u);
  EXPECT_EQ(diagnostics.all()[0].to_string(), "a.idl:3:7: unknown type 'X'");
  EXPECT_EQ(diagnostics.all()[1].to_string(), "p.xml:10:2: /application_profile/port: bad");
  EXPECT_EQ(diagnostics.all()[2].to_string(), "p.xml:1:1: /x: warning: unused");
  EXPECT_EQ(diagnostics.all()[3].to_string(), "missing.idl: cannot open file");
  EXPECT_EQ(diagnostics.all()[4].to_string(), "f.idl:4: no column");
  EXPECT_EQ(diagnostics.all()[5].to_string(), "/p: no location");
  EXPECT_EQ(diagnostics.error_count(), 5u);
}

TEST(DiagnosticsFormat, CollectsAndCountsErrors) {
  Diagnostics diagnostics;
  EXPECT_FALSE(diagnostics.has_errors());
  diagnostics.warning({"f", 1, 2}, "", "w");
  EXPECT_FALSE(diagnostics.has_errors());
  diagnostics.error({"f", 3, 4}, "/p", "e");
  Diagnostic added;
  added.where.file = "g";
  added.where.line = 5;
  added.where.column = 6;
  added.message = "e2";
  diagnostics.add(added);
  EXPECT_TRUE(diagnostics.has_errors());
  EXPECT_EQ(diagnostics.error_count(), 2u);
  ASSERT_EQ(diagnostics.all().size(), 3u);
  std::ostringstream out;
  diagnostics.print(out);
  EXPECT_EQ(out.str(), "f:1:2: warning: w\nf:3:4: /p: e\ng:5:6: e2\n");
}

// ---- the registry ----------------------------------------------------------------------

TEST(TypeRegistryBasics, RegistersPrimitivesUnderIdlNames) {
  TypeRegistry registry;
  struct Expected {
    const char* name;
    TypeKind kind;
    std::uint32_t size;
  };
  const Expected expected[] = {
      {"boolean", TypeKind::boolean, 1}, {"char", TypeKind::char8, 1},
      {"octet", TypeKind::octet, 1},     {"int8", TypeKind::int8, 1},
      {"uint8", TypeKind::uint8, 1},     {"short", TypeKind::int16, 2},
      {"int16", TypeKind::int16, 2},     {"unsigned short", TypeKind::uint16, 2},
      {"uint16", TypeKind::uint16, 2},   {"long", TypeKind::int32, 4},
      {"int32", TypeKind::int32, 4},     {"unsigned long", TypeKind::uint32, 4},
      {"uint32", TypeKind::uint32, 4},   {"long long", TypeKind::int64, 8},
      {"int64", TypeKind::int64, 8},     {"unsigned long long", TypeKind::uint64, 8},
      {"uint64", TypeKind::uint64, 8},   {"float", TypeKind::float32, 4},
      {"float32", TypeKind::float32, 4}, {"double", TypeKind::float64, 8},
      {"float64", TypeKind::float64, 8},
  };
  for (const Expected& item : expected) {
    const Type* type = registry.find(item.name);
    ASSERT_NE(type, nullptr) << item.name;
    EXPECT_EQ(type->kind, item.kind) << item.name;
    EXPECT_EQ(type->size, item.size) << item.name;
    EXPECT_EQ(type->align, item.size) << item.name;
    EXPECT_TRUE(type->is_primitive()) << item.name;
    EXPECT_EQ(type, registry.primitive(item.kind)) << item.name;
    EXPECT_EQ(type->name, kind_name(item.kind)) << item.name;
  }
  const Type* string_type = registry.find("string");
  ASSERT_NE(string_type, nullptr);
  EXPECT_EQ(string_type->kind, TypeKind::string);
  EXPECT_EQ(string_type->size, sizeof(FlatSpan));
  EXPECT_EQ(string_type->align, alignof(FlatSpan));
  EXPECT_FALSE(string_type->is_primitive());
  EXPECT_EQ(registry.primitive(TypeKind::string), string_type);
  EXPECT_EQ(registry.primitive(TypeKind::structure), nullptr);
  EXPECT_EQ(registry.find("::double"), registry.find("double"));
  EXPECT_EQ(registry.find("Double"), nullptr);
  EXPECT_EQ(registry.find("nope::T"), nullptr);
  EXPECT_TRUE(registry.declared().empty());
}

TEST(TypeRegistryBasics, KindNames) {
  EXPECT_EQ(kind_name(TypeKind::float64), "double");
  EXPECT_EQ(kind_name(TypeKind::uint32), "unsigned long");
  EXPECT_EQ(kind_name(TypeKind::uint64), "unsigned long long");
  EXPECT_EQ(kind_name(TypeKind::char8), "char");
  EXPECT_EQ(kind_name(TypeKind::structure), "struct");
  EXPECT_EQ(kind_name(TypeKind::enumeration), "enum");
  EXPECT_EQ(kind_name(TypeKind::sequence), "sequence");
  EXPECT_EQ(kind_name(TypeKind::array), "array");
  EXPECT_EQ(kind_name(TypeKind::alias), "typedef");
  EXPECT_EQ(kind_name(TypeKind::string), "string");
}

// ---- layout ----------------------------------------------------------------------------

struct CBasic {
  double a;
  std::int32_t b;
  std::uint8_t c;
  double d[3];
};

struct CMixed {
  std::uint8_t a;
  std::int16_t b;
  std::int64_t c;
  bool d;
  float e;
  char f;
  std::uint16_t g;
  std::int8_t h;
  std::uint64_t i;
  std::uint8_t j;
};

struct CInner {
  std::uint8_t tag;
  float value;
};

struct COuter {
  std::uint8_t first;
  CInner inner;
  double matrix[3][4];
  CInner pair[2];
  std::int16_t last;
};

using TypeLayout = IdlFixture;

TEST_F(TypeLayout, BasicStructMatchesCStruct) {
  const Type& type = parse_ok(R"(
    struct Basic { double a; int32 b; octet c; double d[3]; };
  )",
                              "Basic");
  EXPECT_EQ(type.kind, TypeKind::structure);
  EXPECT_EQ(type.size, sizeof(CBasic));
  EXPECT_EQ(type.align, alignof(CBasic));
  ASSERT_EQ(type.fields.size(), 4u);
  EXPECT_EQ(field(type, "a").offset, offsetof(CBasic, a));
  EXPECT_EQ(field(type, "b").offset, offsetof(CBasic, b));
  EXPECT_EQ(field(type, "c").offset, offsetof(CBasic, c));
  EXPECT_EQ(field(type, "d").offset, offsetof(CBasic, d));
  EXPECT_EQ(field(type, "d").type->name, "double[3]");
  EXPECT_EQ(field(type, "d").type->kind, TypeKind::array);
  EXPECT_EQ(field(type, "d").type->bound, 3u);
  EXPECT_EQ(field(type, "d").type->size, 24u);
  EXPECT_EQ(field(type, "b").type->name, "long");
  EXPECT_EQ(field(type, "a").where.line, 2u);
  EXPECT_EQ(field(type, "a").where.column, 27u);
  EXPECT_EQ(type.where.file, "test.idl");
  EXPECT_EQ(type.where.line, 2u);
  EXPECT_EQ(type.where.column, 12u);
}

TEST_F(TypeLayout, EveryPrimitiveMatchesCStruct) {
  const Type& type = parse_ok(R"(
    struct Mixed {
      octet a; short b; long long c; boolean d; float e; char f;
      unsigned short g; int8 h; unsigned long long i; uint8 j;
    };
  )",
                              "Mixed");
  EXPECT_EQ(type.size, sizeof(CMixed));
  EXPECT_EQ(type.align, alignof(CMixed));
  EXPECT_EQ(field(type, "a").offset, offsetof(CMixed, a));
  EXPECT_EQ(field(type, "b").offset, offsetof(CMixed, b));
  EXPECT_EQ(field(type, "c").offset, offsetof(CMixed, c));
  EXPECT_EQ(field(type, "d").offset, offsetof(CMixed, d));
  EXPECT_EQ(field(type, "e").offset, offsetof(CMixed, e));
  EXPECT_EQ(field(type, "f").offset, offsetof(CMixed, f));
  EXPECT_EQ(field(type, "g").offset, offsetof(CMixed, g));
  EXPECT_EQ(field(type, "h").offset, offsetof(CMixed, h));
  EXPECT_EQ(field(type, "i").offset, offsetof(CMixed, i));
  EXPECT_EQ(field(type, "j").offset, offsetof(CMixed, j));
  EXPECT_EQ(field(type, "c").type->kind, TypeKind::int64);
  EXPECT_EQ(field(type, "i").type->kind, TypeKind::uint64);
  EXPECT_EQ(field(type, "g").type->kind, TypeKind::uint16);
}

TEST_F(TypeLayout, SizedIntegerSpellings) {
  const Type& type = parse_ok(R"(
    struct S { int16 a; uint16 b; int32 c; uint32 d; int64 e; uint64 f; unsigned long g; };
  )",
                              "S");
  EXPECT_EQ(field(type, "a").type, registry_.primitive(TypeKind::int16));
  EXPECT_EQ(field(type, "b").type, registry_.primitive(TypeKind::uint16));
  EXPECT_EQ(field(type, "c").type, registry_.primitive(TypeKind::int32));
  EXPECT_EQ(field(type, "d").type, registry_.primitive(TypeKind::uint32));
  EXPECT_EQ(field(type, "e").type, registry_.primitive(TypeKind::int64));
  EXPECT_EQ(field(type, "f").type, registry_.primitive(TypeKind::uint64));
  EXPECT_EQ(field(type, "g").type, registry_.primitive(TypeKind::uint32));
  EXPECT_EQ(type.size, 40u);  // 36 rounded up to the alignment of 8
}

TEST_F(TypeLayout, NestedStructsAndMultiDimensionalArraysMatchCStruct) {
  const Type& outer = parse_ok(R"(
    struct Inner { octet tag; float value; };
    struct Outer { octet first; Inner inner; double matrix[3][4]; Inner pair[2]; short last; };
  )",
                               "Outer");
  EXPECT_EQ(outer.size, sizeof(COuter));
  EXPECT_EQ(outer.align, alignof(COuter));
  EXPECT_EQ(field(outer, "inner").offset, offsetof(COuter, inner));
  EXPECT_EQ(field(outer, "matrix").offset, offsetof(COuter, matrix));
  EXPECT_EQ(field(outer, "pair").offset, offsetof(COuter, pair));
  EXPECT_EQ(field(outer, "last").offset, offsetof(COuter, last));

  const Type* matrix = field(outer, "matrix").type;
  EXPECT_EQ(matrix->name, "double[3][4]");
  EXPECT_EQ(matrix->kind, TypeKind::array);
  EXPECT_EQ(matrix->bound, 3u);
  EXPECT_EQ(matrix->size, sizeof(double[3][4]));
  ASSERT_NE(matrix->element, nullptr);
  EXPECT_EQ(matrix->element->name, "double[4]");
  EXPECT_EQ(matrix->element->bound, 4u);
  EXPECT_EQ(matrix->element->size, sizeof(double[4]));
  EXPECT_EQ(matrix->element->element, registry_.primitive(TypeKind::float64));
  const Type* pair = field(outer, "pair").type;
  EXPECT_EQ(pair->name, "Inner[2]");
  EXPECT_EQ(pair->element, registry_.find("Inner"));
  EXPECT_EQ(pair->align, alignof(CInner));
}

TEST_F(TypeLayout, BoundedSequences) {
  const Type& type = parse_ok(R"(
    struct S {
      octet head;
      sequence<double, 4> d;
      sequence<octet, 3> o;
      sequence<short, 3> s;
      sequence<long long, 2> ll;
    };
  )",
                              "S");
  const Type* d = field(type, "d").type;
  EXPECT_EQ(d->name, "sequence<double, 4>");
  EXPECT_EQ(d->kind, TypeKind::sequence);
  EXPECT_EQ(d->bound, 4u);
  EXPECT_EQ(d->element, registry_.primitive(TypeKind::float64));
  EXPECT_EQ(d->size, 8u + 4 * 8);  // length, padding to 8, 4 doubles
  EXPECT_EQ(d->align, 8u);
  EXPECT_EQ(field(type, "d").offset, 8u);

  const Type* o = field(type, "o").type;
  EXPECT_EQ(o->name, "sequence<octet, 3>");
  EXPECT_EQ(o->size, 8u);  // 4 + 3, rounded to the length's alignment
  EXPECT_EQ(o->align, 4u);
  EXPECT_EQ(field(type, "o").offset, 48u);

  const Type* s = field(type, "s").type;
  EXPECT_EQ(s->size, 12u);  // 4 + 6, rounded to 4
  EXPECT_EQ(s->align, 4u);
  EXPECT_EQ(field(type, "s").offset, 56u);

  EXPECT_EQ(field(type, "ll").offset, 72u);
  EXPECT_EQ(field(type, "ll").type->size, 24u);
  EXPECT_EQ(type.size, 96u);
  EXPECT_EQ(type.align, 8u);
}

// A C++ picture of a bounded sequence<double, 4>, to check the rule against the compiler.
struct CBoundedDoubles {
  std::uint32_t length;
  double items[4];
};

TEST_F(TypeLayout, BoundedSequenceMatchesCStruct) {
  const Type& type = parse_ok("struct S { sequence<double, 4> v; };", "S");
  const Type* sequence = field(type, "v").type;
  EXPECT_EQ(sequence->size, sizeof(CBoundedDoubles));
  EXPECT_EQ(sequence->align, alignof(CBoundedDoubles));
  EXPECT_EQ(offsetof(CBoundedDoubles, items), 8u);
}

// has_unbounded: anywhere inside, through arrays, bounded sequences, structs and typedefs.
TEST_F(TypeLayout, UnboundedMembersAreFoundAtAnyDepth) {
  const Type& bounded = parse_ok(R"(
    struct Inner { string<8> tag; sequence<short, 4> s; };
    struct Bounded { long a; double v[3]; Inner inner[2]; sequence<Inner, 2> more; };
  )",
                                 "Bounded");
  EXPECT_FALSE(has_unbounded(bounded));
  const Type& deep = parse_ok(R"(
    struct Leaf { sequence<long> open; };
    typedef Leaf Leaves[2];
    struct Deep { long a; sequence<Leaves, 3> leaves; };
  )",
                              "Deep");
  EXPECT_TRUE(has_unbounded(deep));
  EXPECT_TRUE(has_unbounded(parse_ok("struct T { string<4> a; string b; };", "T")));
  EXPECT_TRUE(has_unbounded(*registry_.primitive(TypeKind::string)));
  EXPECT_FALSE(has_unbounded(*registry_.primitive(TypeKind::float64)));
}

TEST_F(TypeLayout, StringsAndUnboundedSequences) {
  const Type& type = parse_ok(R"(
    struct S {
      octet a;
      string<16> name;
      string text;
      sequence<double> values;
      octet b;
      sequence<sequence<long, 2>> nested;
      sequence<string<4>, 2> labels;
    };
  )",
                              "S");
  const Type* name = field(type, "name").type;
  EXPECT_EQ(name->name, "string<16>");
  EXPECT_EQ(name->kind, TypeKind::string);
  EXPECT_EQ(name->bound, 16u);
  EXPECT_EQ(name->size, 17u);
  EXPECT_EQ(name->align, 1u);
  EXPECT_EQ(field(type, "name").offset, 1u);

  const Type* text = field(type, "text").type;
  EXPECT_EQ(text, registry_.primitive(TypeKind::string));
  EXPECT_EQ(text->bound, 0u);
  EXPECT_EQ(field(type, "text").offset, 20u);

  const Type* values = field(type, "values").type;
  EXPECT_EQ(values->name, "sequence<double>");
  EXPECT_EQ(values->bound, 0u);
  EXPECT_EQ(values->size, sizeof(FlatSpan));
  EXPECT_EQ(values->align, alignof(FlatSpan));
  EXPECT_EQ(field(type, "values").offset, 28u);
  EXPECT_EQ(field(type, "b").offset, 36u);

  const Type* nested = field(type, "nested").type;
  EXPECT_EQ(nested->name, "sequence<sequence<long, 2>>");
  EXPECT_EQ(nested->element->name, "sequence<long, 2>");
  EXPECT_EQ(nested->element->size, 12u);
  EXPECT_EQ(field(type, "nested").offset, 40u);

  const Type* labels = field(type, "labels").type;
  EXPECT_EQ(labels->name, "sequence<string<4>, 2>");
  EXPECT_EQ(labels->size, 4u + 2 * 5 + 2);  // length, two char[5], padding to 4
  EXPECT_EQ(field(type, "labels").offset, 48u);
  EXPECT_EQ(type.size, 64u);
  EXPECT_EQ(type.align, 4u);
}

TEST_F(TypeLayout, AnonymousTypesAreShared) {
  const Type& type = parse_ok(R"(
    struct A { double x[3]; sequence<long, 2> s; string<5> t; };
    struct B { double y[3]; sequence<long, 2> s; string<5> t; double m[2][3]; };
  )",
                              "B");
  const Type* a = registry_.find("A");
  ASSERT_NE(a, nullptr);
  EXPECT_EQ(field(*a, "x").type, field(type, "y").type);
  EXPECT_EQ(field(*a, "s").type, field(type, "s").type);
  EXPECT_EQ(field(*a, "t").type, field(type, "t").type);
  EXPECT_EQ(field(type, "m").type->element, field(type, "y").type);
  // Anonymous types are not declared names.
  EXPECT_EQ(registry_.find("double[3]"), nullptr);
  EXPECT_EQ(registry_.declared().size(), 2u);
}

TEST_F(TypeLayout, EnumsAreFourBytes) {
  const Type& type = parse_ok(R"(
    enum Color { RED, GREEN, BLUE };
    enum Sparse { A, @value(10) B, C, @value(-1) D };
    struct S { octet a; Color c; Sparse s[2]; };
  )",
                              "S");
  const Type* color = registry_.find("Color");
  ASSERT_NE(color, nullptr);
  EXPECT_EQ(color->kind, TypeKind::enumeration);
  EXPECT_EQ(color->size, 4u);
  EXPECT_EQ(color->align, 4u);
  ASSERT_EQ(color->enumerators.size(), 3u);
  EXPECT_EQ(color->enumerators[0].name, "RED");
  EXPECT_EQ(color->enumerators[0].value, 0);
  EXPECT_EQ(color->enumerators[2].name, "BLUE");
  EXPECT_EQ(color->enumerators[2].value, 2);
  const Type* sparse = registry_.find("Sparse");
  ASSERT_NE(sparse, nullptr);
  ASSERT_EQ(sparse->enumerators.size(), 4u);
  EXPECT_EQ(sparse->enumerators[0].value, 0);
  EXPECT_EQ(sparse->enumerators[1].value, 10);
  EXPECT_EQ(sparse->enumerators[2].value, 11);
  EXPECT_EQ(sparse->enumerators[3].value, -1);
  EXPECT_EQ(field(type, "c").offset, 4u);
  EXPECT_EQ(field(type, "s").offset, 8u);
  EXPECT_EQ(type.size, 16u);
}

TEST_F(TypeLayout, TypedefChainsAndArrayTypedefs) {
  const Type& type = parse_ok(R"(
    module geo {
      typedef double Vec3[3];
      typedef Vec3 Position;
      typedef Position Matrix3[3];
      typedef long Id, IdPair[2];
      typedef sequence<Vec3, 8> Path;
      typedef string<31> Name;
      struct Pose { Position p; Matrix3 r; Id id; IdPair ids; Path path; Name name; };
    };
  )",
                              "geo::Pose");
  const Type* vec3 = registry_.find("geo::Vec3");
  ASSERT_NE(vec3, nullptr);
  EXPECT_EQ(vec3->kind, TypeKind::alias);
  EXPECT_EQ(vec3->size, 24u);
  EXPECT_EQ(vec3->align, 8u);
  ASSERT_NE(vec3->element, nullptr);
  EXPECT_EQ(vec3->element->name, "double[3]");
  EXPECT_EQ(vec3->resolved().kind, TypeKind::array);

  const Type* position = registry_.find("geo::Position");
  ASSERT_NE(position, nullptr);
  EXPECT_EQ(position->element, vec3);
  EXPECT_EQ(&position->resolved(), vec3->element);
  EXPECT_EQ(position->size, 24u);

  const Type* matrix = registry_.find("geo::Matrix3");
  ASSERT_NE(matrix, nullptr);
  EXPECT_EQ(matrix->size, 72u);
  EXPECT_EQ(matrix->element->name, "geo::Position[3]");
  EXPECT_EQ(matrix->resolved().element, position);

  EXPECT_EQ(registry_.find("geo::Id")->resolved().kind, TypeKind::int32);
  EXPECT_EQ(registry_.find("geo::IdPair")->size, 8u);
  EXPECT_EQ(registry_.find("geo::Path")->resolved().name, "sequence<geo::Vec3, 8>");
  EXPECT_EQ(registry_.find("geo::Path")->size, 8u + 8 * 24);
  EXPECT_EQ(registry_.find("geo::Name")->size, 32u);

  EXPECT_EQ(field(type, "p").offset, 0u);
  EXPECT_EQ(field(type, "r").offset, 24u);
  EXPECT_EQ(field(type, "id").offset, 96u);
  EXPECT_EQ(field(type, "ids").offset, 100u);
  EXPECT_EQ(field(type, "path").offset, 112u);
  EXPECT_EQ(field(type, "name").offset, 312u);
  EXPECT_EQ(type.size, 344u);
  EXPECT_EQ(field(type, "p").type, position);

  // declared() lists the user types in declaration order.
  std::vector<std::string> names;
  for (const Type* declared : registry_.declared()) names.push_back(declared->name);
  EXPECT_EQ(names,
            (std::vector<std::string>{"geo::Vec3", "geo::Position", "geo::Matrix3", "geo::Id",
                                      "geo::IdPair", "geo::Path", "geo::Name", "geo::Pose"}));
}

TEST_F(TypeLayout, AliasHelpers) {
  const Type& type = parse_ok(R"(
    struct P { double x; };
    typedef P Q;
    typedef Q R;
  )",
                              "R");
  EXPECT_EQ(type.kind, TypeKind::alias);
  EXPECT_EQ(&type.resolved(), registry_.find("P"));
  EXPECT_NE(type.find_field("x"), nullptr);
  EXPECT_EQ(type.find_field("y"), nullptr);
  EXPECT_FALSE(type.is_primitive());
  EXPECT_EQ(type.size, 8u);
}

// ---- the parser: modules, names, constants, annotations ---------------------------------

using IdlParser = IdlFixture;

TEST_F(IdlParser, NestedReopenedModulesAndScopedNames) {
  ASSERT_TRUE(parse(R"(
    module outer {
      struct Shared { long v; };
      module inner {
        struct Local { octet o; };
      };
    };
    module other {
      struct Shared { double d; };   // different type, same simple name
    };
    module outer {
      module inner {
        struct UsesRelative {
          Shared a;                  // found in the enclosing module outer
          Local b;                   // found in outer::inner
          inner::Local c;            // relative name from outer
          other::Shared d;           // relative name from the global scope
          ::outer::Shared e;         // absolute name
          outer::inner::Local f;
        };
      };
      struct Back { inner::UsesRelative r; };
    };
  )")) << ::testing::PrintToString(messages());
  const Type* uses = registry_.find("outer::inner::UsesRelative");
  ASSERT_NE(uses, nullptr);
  EXPECT_EQ(field(*uses, "a").type, registry_.find("outer::Shared"));
  EXPECT_EQ(field(*uses, "b").type, registry_.find("outer::inner::Local"));
  EXPECT_EQ(field(*uses, "c").type, registry_.find("outer::inner::Local"));
  EXPECT_EQ(field(*uses, "d").type, registry_.find("other::Shared"));
  EXPECT_EQ(field(*uses, "e").type, registry_.find("outer::Shared"));
  EXPECT_EQ(field(*uses, "f").type, registry_.find("outer::inner::Local"));
  EXPECT_EQ(registry_.find("::outer::Back"), registry_.find("outer::Back"));
  EXPECT_EQ(field(*registry_.find("outer::Back"), "r").type, uses);
}

TEST_F(IdlParser, InnerScopeHidesOuterName) {
  ASSERT_TRUE(parse(R"(
    struct T { octet global; };
    module m {
      struct T { double local; };
      struct U { T t; ::T g; };
    };
  )")) << ::testing::PrintToString(messages());
  const Type* u = registry_.find("m::U");
  ASSERT_NE(u, nullptr);
  EXPECT_EQ(field(*u, "t").type, registry_.find("m::T"));
  EXPECT_EQ(field(*u, "g").type, registry_.find("T"));
}

TEST_F(IdlParser, TypesPersistAcrossFiles) {
  ASSERT_TRUE(parse("module base { struct Stamp { long long ns; }; };", "base.idl"));
  ASSERT_TRUE(parse("module app { struct Msg { base::Stamp stamp; double v; }; };", "app.idl"))
      << ::testing::PrintToString(messages());
  const Type* msg = registry_.find("app::Msg");
  ASSERT_NE(msg, nullptr);
  EXPECT_EQ(field(*msg, "stamp").type->where.file, "base.idl");
  EXPECT_EQ(msg->where.file, "app.idl");
  EXPECT_EQ(msg->size, 16u);
}

TEST_F(IdlParser, ConstantsAndConstantExpressions) {
  ASSERT_TRUE(parse(R"(
    module cfg {
      const long N = 3;
      const long M = (N + 1) * 2 - 10 / 4;     // 6
      const unsigned long MASK = 0xFF & ~0x0F;  // 240
      const long long BIG = 1 << 40;
      const octet SMALL = 017;                  // octal 15
      const short NEG = -(N * 4) % 5;           // -2
      const double PI = 3.14159;
      const float HALF = 1 / 2.0;
      const double FROM_INT = N;
      const string GREETING = "hello " "world\n";
      const string<8> SHORT_TEXT = "abc";
      const boolean ENABLED = TRUE;
      const boolean DISABLED = FALSE;
      module deep {
        const long USES_OUTER = N + cfg::M + ::cfg::N;  // 12
      };
    };
    const long TOP = cfg::deep::USES_OUTER * 2;
  )")) << ::testing::PrintToString(messages());
  EXPECT_EQ(registry_.constant("cfg::N"), ConstValue(std::int64_t{3}));
  EXPECT_EQ(registry_.constant("cfg::M"), ConstValue(std::int64_t{6}));
  EXPECT_EQ(registry_.constant("cfg::MASK"), ConstValue(std::int64_t{240}));
  EXPECT_EQ(registry_.constant("cfg::BIG"), ConstValue(std::int64_t{1} << 40));
  EXPECT_EQ(registry_.constant("cfg::SMALL"), ConstValue(std::int64_t{15}));
  EXPECT_EQ(registry_.constant("cfg::NEG"), ConstValue(std::int64_t{-2}));
  EXPECT_EQ(registry_.constant("cfg::PI"), ConstValue(3.14159));
  EXPECT_EQ(registry_.constant("cfg::HALF"), ConstValue(0.5));
  EXPECT_EQ(registry_.constant("cfg::FROM_INT"), ConstValue(3.0));
  EXPECT_EQ(registry_.constant("cfg::GREETING"), ConstValue(std::string("hello world\n")));
  EXPECT_EQ(registry_.constant("cfg::SHORT_TEXT"), ConstValue(std::string("abc")));
  EXPECT_EQ(registry_.constant("cfg::ENABLED"), ConstValue(true));
  EXPECT_EQ(registry_.constant("cfg::DISABLED"), ConstValue(false));
  EXPECT_EQ(registry_.constant("cfg::deep::USES_OUTER"), ConstValue(std::int64_t{12}));
  EXPECT_EQ(registry_.constant("::TOP"), ConstValue(std::int64_t{24}));
  EXPECT_EQ(registry_.constant("cfg::MISSING"), std::nullopt);
}

TEST_F(IdlParser, ConstantsAsBounds) {
  const Type& type = parse_ok(R"(
    module cfg {
      const long N = 4;
      const unsigned long LEN = N * 2;
    };
    module m {
      typedef long Count;
      const Count TWO = 2;
      struct S {
        double a[cfg::N];
        double b[TWO][cfg::N + 1];
        sequence<octet, cfg::LEN> s;
        string<cfg::LEN - 1> t;
        sequence<long, (1 << 2)> shifted;
        long c[1 << 1];
      };
    };
  )",
                              "m::S");
  EXPECT_EQ(field(type, "a").type->name, "double[4]");
  EXPECT_EQ(field(type, "b").type->name, "double[2][5]");
  EXPECT_EQ(field(type, "b").type->size, 80u);
  EXPECT_EQ(field(type, "s").type->name, "sequence<octet, 8>");
  EXPECT_EQ(field(type, "t").type->name, "string<7>");
  EXPECT_EQ(field(type, "t").type->size, 8u);
  EXPECT_EQ(field(type, "shifted").type->bound, 4u);
  EXPECT_EQ(field(type, "c").type->bound, 2u);
}

TEST_F(IdlParser, CommentsPreprocessorAndAnnotationsAreIgnored) {
  const Type& type = parse_ok(R"(#include "other.idl"
#pragma once
#ifndef GUARD
#define GUARD \
    continued
// line comment with struct Bogus { };
/* block comment
   struct AlsoBogus { long x; }; */
@annotation Unit { string value; };
module m {
  @topic @final
  @appendable
  @verbatim(language = "c", text = "(nested) parens")
  struct S {
    @key long id;   // trailing comment
    @range(min = 0, max = 10) @unit("m") double /* inline */ distance;
    @optional(FALSE) octet flag;
  };
};
#endif
  )",
                              "m::S");
  EXPECT_EQ(type.fields.size(), 3u);
  EXPECT_EQ(type.size, 24u);
  EXPECT_EQ(registry_.find("Bogus"), nullptr);
  EXPECT_EQ(registry_.find("AlsoBogus"), nullptr);
}

TEST_F(IdlParser, ForwardDeclarationIsAccepted) {
  const Type& type = parse_ok(R"(
    struct Later;
    struct Later { long x; };
    struct Later;
    struct User { Later l; };
  )",
                              "User");
  EXPECT_EQ(type.size, 4u);
}

TEST_F(IdlParser, EscapedIdentifiersAndContextualWords) {
  const Type& type = parse_ok("struct S { long _module; double port; octet context; };", "S");
  EXPECT_NE(type.find_field("module"), nullptr);
  EXPECT_NE(type.find_field("port"), nullptr);
  EXPECT_NE(type.find_field("context"), nullptr);
}

TEST_F(IdlParser, AddIdlFileLoadsOnceAndReportsMissingFiles) {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() /
                                    ("polyport_types_test_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const std::filesystem::path file = dir / "msg.idl";
  {
    std::ofstream out(file);
    out << "module f { struct M { long x; }; };\n";
  }
  EXPECT_TRUE(registry_.add_idl_file(file, diagnostics_));
  EXPECT_TRUE(registry_.add_idl_file(dir / "." / "msg.idl", diagnostics_));  // same file again
  EXPECT_TRUE(diagnostics_.all().empty()) << ::testing::PrintToString(messages());
  ASSERT_NE(registry_.find("f::M"), nullptr);
  EXPECT_EQ(registry_.find("f::M")->where.file, file.string());

  const std::filesystem::path missing = dir / "missing.idl";
  EXPECT_FALSE(registry_.add_idl_file(missing, diagnostics_));
  ASSERT_EQ(diagnostics_.all().size(), 1u);
  EXPECT_EQ(diagnostics_.all()[0].where.file, missing.string());
  EXPECT_EQ(diagnostics_.all()[0].where.line, 0u);
  EXPECT_EQ(diagnostics_.all()[0].message, "cannot open file");
  EXPECT_EQ(diagnostics_.all()[0].to_string(), missing.string() + ": cannot open file");
  std::filesystem::remove_all(dir);
}

// ---- the parser: errors ----------------------------------------------------------------

using IdlDiagnostics = IdlFixture;

TEST_F(IdlDiagnostics, UnknownType) {
  EXPECT_EQ(errors_for("module a {\n  struct B { Foo f; };\n};\n"),
            Messages{"test.idl:2:14: unknown type 'Foo'"});
  EXPECT_EQ(registry_.find("a::B"), nullptr);
}

TEST_F(IdlDiagnostics, UnknownScopedType) {
  EXPECT_EQ(errors_for("struct B {\n  long x;\n  ::a::Missing m;\n};"),
            Messages{"test.idl:3:3: unknown type '::a::Missing'"});
}

TEST_F(IdlDiagnostics, MissingSemicolonAfterMember) {
  EXPECT_EQ(errors_for("struct B {\n  long x\n  long y;\n};"),
            Messages{"test.idl:3:3: expected ';' after member declaration"});
}

TEST_F(IdlDiagnostics, DuplicateMember) {
  EXPECT_EQ(errors_for("module a {\n  struct B { long x; double x; };\n};"),
            Messages{"test.idl:2:29: duplicate member 'x' in struct 'a::B'"});
}

TEST_F(IdlDiagnostics, Redefinition) {
  EXPECT_EQ(errors_for("module a {\n  struct B { long x; };\n  enum B { X };\n};"),
            Messages{"test.idl:3:8: redefinition of 'a::B'"});
  // The first definition stays.
  ASSERT_NE(registry_.find("a::B"), nullptr);
  EXPECT_EQ(registry_.find("a::B")->kind, TypeKind::structure);
}

TEST_F(IdlDiagnostics, RedefinitionAcrossFilesAndKinds) {
  ASSERT_TRUE(parse("module a { const long N = 1; struct T { long x; }; };", "one.idl"));
  EXPECT_FALSE(parse(
      "module a {\n  typedef long N;\n  const long T = 2;\n};\nstruct a { long y; };", "two.idl"));
  EXPECT_EQ(messages(),
            (Messages{"two.idl:2:16: redefinition of 'a::N'",
                      "two.idl:3:14: redefinition of 'a::T'", "two.idl:5:8: redefinition of 'a'"}));
}

TEST_F(IdlDiagnostics, ArraySizeMustBePositive) {
  EXPECT_EQ(errors_for("const long Z = 0;\n"
                       "struct S {\n"
                       "  double a[0];\n"
                       "  double b[Z - 1];\n"
                       "  double c[2.5];\n"
                       "  double d[\"x\"];\n"
                       "};"),
            (Messages{"test.idl:3:12: array size must be a positive integer constant",
                      "test.idl:4:12: array size must be a positive integer constant",
                      "test.idl:5:12: array size must be a positive integer constant",
                      "test.idl:6:12: array size must be a positive integer constant"}));
}

TEST_F(IdlDiagnostics, BoundsMustBePositive) {
  EXPECT_EQ(errors_for("struct S {\n  sequence<long, 0> s;\n  string<-3> t;\n};"),
            (Messages{"test.idl:2:18: sequence bound must be a positive integer constant",
                      "test.idl:3:10: string bound must be a positive integer constant"}));
}

TEST_F(IdlDiagnostics, UnterminatedComment) {
  EXPECT_EQ(errors_for("struct S { long x; };\n/* never closed\nstruct T { long y; };\n"),
            Messages{"test.idl:2:1: unterminated comment"});
  EXPECT_NE(registry_.find("S"), nullptr);
}

TEST_F(IdlDiagnostics, UnknownConstantAndBadExpressions) {
  EXPECT_EQ(errors_for("const long A = B + 1;\n"
                       "const long C = 10 / (2 - 2);\n"
                       "const long D = 9223372036854775807 + 1;\n"
                       "const octet E = 256;\n"
                       "const long F = 1.5;\n"
                       "const string G = 3;\n"
                       "const long H = (1 + 2;\n"
                       "struct S { long x; };\n"
                       "const long I = S;\n"),
            (Messages{"test.idl:1:16: unknown constant 'B'",
                      "test.idl:2:19: division by zero in constant expression",
                      "test.idl:3:36: integer overflow in constant expression",
                      "test.idl:4:17: value 256 is out of range for 'octet'",
                      "test.idl:5:16: constant of type 'long' needs an integer value",
                      "test.idl:6:18: constant of type 'string' needs a string value",
                      "test.idl:7:22: expected ')' in constant expression",
                      "test.idl:9:16: 'S' is not a constant"}));
  EXPECT_EQ(registry_.constant("A"), std::nullopt);
}

TEST_F(IdlDiagnostics, UnsupportedConstructs) {
  EXPECT_EQ(errors_for("union U switch (long) { case 1: long x; };\n"
                       "interface I { void f(); };\n"
                       "struct S {\n"
                       "  wstring w;\n"
                       "  long double ld;\n"
                       "  struct Inner { long x; } inner;\n"
                       "};\n"
                       "struct D : S { long y; };\n"
                       "const char C = 'x';\n"),
            (Messages{"test.idl:1:1: unsupported declaration 'union'",
                      "test.idl:2:1: unsupported declaration 'interface'",
                      "test.idl:4:3: unsupported type 'wstring'",
                      "test.idl:5:3: unsupported type 'long double'",
                      "test.idl:6:3: nested type definitions are not supported",
                      "test.idl:8:10: struct inheritance is not supported",
                      "test.idl:9:7: unsupported constant type 'char'"}));
}

TEST_F(IdlDiagnostics, SelfReferenceAndIncompleteTypes) {
  EXPECT_EQ(errors_for("struct Node { long v; sequence<Node> children; };\n"
                       "struct Fwd;\n"
                       "struct User { Fwd f; };\n"
                       "module m { struct X { long x; }; };\n"
                       "struct W { m w; };\n"),
            (Messages{"test.idl:1:32: struct 'Node' cannot contain itself",
                      "test.idl:3:15: incomplete type 'Fwd'", "test.idl:5:12: 'm' is not a type"}));
}

TEST_F(IdlDiagnostics, LexicalErrors) {
  EXPECT_EQ(errors_for("struct S {\n"
                       "  long $x;\n"
                       "  long y = 1;\n"
                       "};\n"
                       "const string T = \"open\n"
                       "const long U = 12abc;\n"
                       "const long V = 99999999999999999999;\n"),
            (Messages{"test.idl:2:8: unexpected character '$'",
                      "test.idl:3:10: expected ';' after member declaration",
                      "test.idl:5:18: unterminated string literal",
                      "test.idl:6:16: invalid numeric literal '12abc'",
                      "test.idl:7:16: integer literal '99999999999999999999' is too large"}));
}

TEST_F(IdlDiagnostics, MissingBracesAndSemicolons) {
  EXPECT_EQ(errors_for("module a {\n"
                       "  struct S { long x; }\n"
                       "  struct T { long y; };\n"
                       "  enum E { ONE, TWO }\n"
                       "  struct U { long z;\n"
                       "  const long K = 1;\n"
                       "};\n"
                       "module b {\n"
                       "  struct V { long v; };\n"),
            (Messages{"test.idl:3:3: expected ';' after struct definition",
                      "test.idl:5:3: expected ';' after enum definition",
                      "test.idl:6:3: expected '}' at end of struct 'a::U'",
                      "test.idl:9:24: expected '}' at end of module 'b'"}));
  // What was well formed is still registered.
  EXPECT_NE(registry_.find("a::S"), nullptr);
  EXPECT_NE(registry_.find("a::T"), nullptr);
  EXPECT_NE(registry_.find("a::E"), nullptr);
  EXPECT_EQ(registry_.find("a::U"), nullptr);
  EXPECT_EQ(registry_.constant("a::K"), ConstValue(std::int64_t{1}));
  EXPECT_NE(registry_.find("b::V"), nullptr);
}

TEST_F(IdlDiagnostics, DeclaratorAfterStructAndBrokenAnnotation) {
  EXPECT_EQ(errors_for("struct S { long x; } s;\n"
                       "struct T { @range(min = 0 long y; };\n"
                       "struct U { T t; long z; };\n"),
            (Messages{"test.idl:1:22: expected ';' after struct definition",
                      "test.idl:2:33: expected ')' after annotation arguments"}));
  EXPECT_NE(registry_.find("S"), nullptr);
  EXPECT_EQ(registry_.find("U"), nullptr);
}

TEST_F(IdlDiagnostics, EnumErrors) {
  EXPECT_EQ(errors_for("enum E { A, B, A };\n"
                       "enum F { X, };\n"
                       "enum G { P Q };\n"
                       "enum H { };\n"
                       "struct After { E e; long ok; };\n"),
            (Messages{"test.idl:1:16: duplicate enumerator 'A' in enum 'E'",
                      "test.idl:2:13: expected enumerator name",
                      "test.idl:3:12: expected ',' or '}' after enumerator",
                      "test.idl:4:10: expected enumerator name"}));
  // Uses of a failed declaration are not reported again.
  EXPECT_EQ(registry_.find("After"), nullptr);
}

TEST_F(IdlDiagnostics, ManyErrorsInOneFile) {
  EXPECT_EQ(
      errors_for(R"(module nav {
  const long N = 4;
  struct Good { double x[N]; };
  struct Bad1 { Unknown u; double d; };
  struct Bad2 { long a; long a; };
  struct Uses { Bad1 b; };
  struct Good2 { Good g; sequence<long, N> s; };
  struct Good { long again; };
  struct Bad3 { string<0> s; long };
  typedef Missing Alias;
  struct Bad4 { double m[2][0]; };
  foo bar;
  struct Good3 { Good2 g2; };
};
)"),
      (Messages{"test.idl:4:17: unknown type 'Unknown'",
                "test.idl:5:30: duplicate member 'a' in struct 'nav::Bad2'",
                "test.idl:8:10: redefinition of 'nav::Good'",
                "test.idl:9:24: string bound must be a positive integer constant",
                "test.idl:9:35: expected member name", "test.idl:10:11: unknown type 'Missing'",
                "test.idl:11:29: array size must be a positive integer constant",
                "test.idl:12:3: expected a declaration"}));
  EXPECT_EQ(diagnostics_.error_count(), 8u);
  // The good declarations around the errors are all there.
  EXPECT_NE(registry_.find("nav::Good"), nullptr);
  EXPECT_NE(registry_.find("nav::Good2"), nullptr);
  ASSERT_NE(registry_.find("nav::Good3"), nullptr);
  EXPECT_EQ(registry_.find("nav::Good3")->size, 56u);  // 32 + 20, rounded up to 8
  EXPECT_EQ(registry_.find("nav::Bad1"), nullptr);
  EXPECT_EQ(registry_.find("nav::Uses"), nullptr);
}

TEST_F(IdlDiagnostics, KeywordsAsNames) {
  EXPECT_EQ(errors_for("struct S { long module; };\nstruct long { octet x; };\n"),
            (Messages{"test.idl:1:17: expected member name ('module' is a keyword)",
                      "test.idl:2:8: expected struct name ('long' is a keyword)"}));
}

TEST_F(IdlDiagnostics, TooLargeTypes) {
  EXPECT_EQ(errors_for("struct S { double a[1000000][1000000]; };\n"
                       "struct T { double b[300000000]; double c[300000000]; };\n"
                       "struct U { string<4294967295> s; };\n"),
            (Messages{"test.idl:1:21: type 'double[1000000][1000000]' is too large",
                      "test.idl:2:8: struct 'T' is too large",
                      "test.idl:3:19: string bound is too large"}));
}

TEST_F(IdlDiagnostics, StrayClosingBraceAndEmptyStruct) {
  EXPECT_EQ(errors_for("struct E { };\n}\nstruct F { long x; };\n"),
            (Messages{"test.idl:1:8: struct 'E' has no members", "test.idl:2:1: unexpected '}'"}));
  EXPECT_NE(registry_.find("F"), nullptr);
}

// Arbitrary input must end in diagnostics, never a hang or a crash (run under sanitizers).
TEST_F(IdlDiagnostics, SurvivesArbitraryInput) {
  const std::string valid = R"(
    module m { const long N = 2 * (3 + 1);
      @final struct A { double x[N][2]; sequence<string<4>, N> s; string t; };
      enum E { X, @value(3) Y };
      typedef A Arr[2];
    };
  )";
  // Every prefix of a valid file.
  for (std::size_t length = 0; length < valid.size(); ++length) {
    TypeRegistry registry;
    Diagnostics diagnostics;
    registry.add_idl_text(valid.substr(0, length), "prefix.idl", diagnostics);
  }
  // Random token soup.
  const char* pieces[] = {
      "module",   "struct", "enum",  "typedef", "const",    "sequence", "string", "long", "double",
      "unsigned", "x",      "N",     "::",      "{",        "}",        "(",      ")",    "[",
      "]",        "<",      ">",     ";",       ",",        "=",        "+",      "-",    "*",
      "/",        "@",      "key",   "0",       "3",        "1.5",      "\"s\"",  "/*",   "*/",
      "//",       "\n",     "#",     "'",       "\"",       "TRUE",     "%",      "~",    "|",
      "&",        "^",      "union", "\\",      "\xC3\xA9", "$"};
  std::mt19937 random(12345);
  std::uniform_int_distribution<std::size_t> pick(0, std::size(pieces) - 1);
  for (int round = 0; round < 300; ++round) {
    std::string text;
    const int count = 1 + round % 60;
    for (int i = 0; i < count; ++i) {
      text += pieces[pick(random)];
      text += ' ';
    }
    TypeRegistry registry;
    Diagnostics diagnostics;
    registry.add_idl_text(text, "soup.idl", diagnostics);
  }
}

TEST_F(IdlDiagnostics, DeepNestingIsAnErrorNotACrash) {
  std::string modules;
  for (int i = 0; i < 5000; ++i) modules += "module m { ";
  EXPECT_FALSE(parse(modules));
  EXPECT_TRUE(diagnostics_.has_errors());

  TypeRegistry registry;
  Diagnostics diagnostics;
  std::string expression = "const long X = ";
  for (int i = 0; i < 100000; ++i) expression += "(";
  expression += "1;";
  EXPECT_FALSE(registry.add_idl_text(expression, "deep.idl", diagnostics));
  EXPECT_TRUE(diagnostics.has_errors());

  std::string sequences = "struct S { ";
  for (int i = 0; i < 5000; ++i) sequences += "sequence<";
  sequences += "long x; };";
  EXPECT_FALSE(registry.add_idl_text(sequences, "deep2.idl", diagnostics));
}

// ---- samples as JSON -------------------------------------------------------------------

class SampleJson : public IdlFixture {
 protected:
  void SetUp() override {
    ASSERT_TRUE(parse(R"(
      module demo {
        enum Mode { IDLE, DRIVE, @value(10) STOP };
        struct Point { double x; double y; };
        struct Sample {
          Point origin;
          long counts[3];
          sequence<float, 4> gains;
          string<8> label;
          Mode mode;
          string note;
          sequence<Point> path;
          boolean ok;
          char letter;
          octet raw[2][2];
        };
      };
    )")) << ::testing::PrintToString(messages());
    sample_type_ = registry_.find("demo::Sample");
    ASSERT_NE(sample_type_, nullptr);
    buffer_.assign(sample_type_->size + kTail, std::byte{0});
  }

  template <class T>
  void put(std::size_t offset, const T& value) {
    ASSERT_LE(offset + sizeof value, buffer_.size());
    std::memcpy(buffer_.data() + offset, &value, sizeof value);
  }

  std::uint32_t offset_of(std::string_view name) { return field(*sample_type_, name).offset; }

  std::string json() const { return sample_to_json(*sample_type_, buffer_.data(), buffer_.size()); }

  // Fills every field; the note and the path live in the tail after the fixed part.
  void fill() {
    put(offset_of("origin"), 1.5);
    put(offset_of("origin") + 8, -2.0);
    const std::int32_t counts[3] = {1, -2, 3};
    put(offset_of("counts"), counts);
    put(offset_of("gains"), std::uint32_t{2});
    const float gains[2] = {0.5f, 0.1f};
    put(offset_of("gains") + 4, gains);
    const char label[] = "hi \"x\"";
    static_assert(sizeof label <= 9);
    std::memcpy(buffer_.data() + offset_of("label"), label, sizeof label);
    put(offset_of("mode"), std::int32_t{10});

    std::uint32_t tail = sample_type_->size;
    const char note[] = "tail\ntext\\";
    std::memcpy(buffer_.data() + tail, note, sizeof note);
    put(offset_of("note"), FlatSpan{tail, static_cast<std::uint32_t>(sizeof note - 1)});
    tail += 16;
    put(offset_of("path"), FlatSpan{tail, 2});
    const double path[4] = {1.0, 2.0, 0.1, 1e300};
    put(tail, path);
    put(offset_of("ok"), std::uint8_t{1});
    put(offset_of("letter"), 'Z');
    const std::uint8_t raw[4] = {1, 2, 3, 255};
    put(offset_of("raw"), raw);
  }

  static constexpr std::size_t kTail = 64;
  const Type* sample_type_ = nullptr;
  std::vector<std::byte> buffer_;
};

TEST_F(SampleJson, RendersEveryKindOfField) {
  fill();
  EXPECT_EQ(json(), R"({"origin":{"x":1.5,"y":-2},"counts":[1,-2,3],"gains":[0.5,0.1],)"
                    R"("label":"hi \"x\"","mode":"STOP","note":"tail\ntext\\",)"
                    R"("path":[{"x":1,"y":2},{"x":0.1,"y":1e+300}],"ok":true,"letter":"Z",)"
                    R"("raw":[[1,2],[3,255]]})");
}

TEST_F(SampleJson, EmptyAndDefaultValues) {
  EXPECT_EQ(json(),
            R"({"origin":{"x":0,"y":0},"counts":[0,0,0],"gains":[],"label":"","mode":"IDLE",)"
            R"("note":"","path":[],"ok":false,"letter":"\u0000","raw":[[0,0],[0,0]]})");
}

TEST_F(SampleJson, BoundsAreCheckedEverywhere) {
  fill();
  // Spans pointing outside the sample, and a length beyond the bound, render as null.
  put(offset_of("note"), FlatSpan{static_cast<std::uint32_t>(buffer_.size() - 2), 3});
  put(offset_of("path"), FlatSpan{0xFFFFFFF0u, 0xFFFFFFFFu});
  put(offset_of("gains"), std::uint32_t{5});
  const std::string text = json();
  EXPECT_NE(text.find(R"("note":null)"), std::string::npos) << text;
  EXPECT_NE(text.find(R"("path":null)"), std::string::npos) << text;
  EXPECT_NE(text.find(R"("gains":null)"), std::string::npos) << text;
  // A value not among the enumerators shows as its number.
  put(offset_of("mode"), std::int32_t{7});
  EXPECT_NE(json().find(R"("mode":7)"), std::string::npos);

  // A truncated sample: what does not fit is null.
  EXPECT_EQ(sample_to_json(*sample_type_, buffer_.data(), 8), "null");
  EXPECT_EQ(sample_to_json(*sample_type_, nullptr, 0), "null");
  const Type* point = registry_.find("demo::Point");
  EXPECT_EQ(sample_to_json(*point, buffer_.data(), 16), R"({"x":1.5,"y":-2})");
  EXPECT_EQ(sample_to_json(*point, buffer_.data(), 15), "null");
}

TEST_F(SampleJson, NonFiniteFloatsAndStringEscapes) {
  put(offset_of("origin"), std::numeric_limits<double>::quiet_NaN());
  put(offset_of("origin") + 8, -std::numeric_limits<double>::infinity());
  const float gains[1] = {std::numeric_limits<float>::infinity()};
  put(offset_of("gains"), std::uint32_t{1});
  put(offset_of("gains") + 4, gains);
  // A bounded string without a terminating NUL stops at the bound; control characters and
  // invalid UTF-8 are escaped, valid UTF-8 passes through.
  const char label[9] = {'\x01', '\t', '\xC3', '\xA9', '\xFF', 'a', 'b', 'c', 'd'};
  std::memcpy(buffer_.data() + offset_of("label"), label, sizeof label);
  const std::string text = json();
  EXPECT_NE(text.find(R"("origin":{"x":null,"y":null})"), std::string::npos) << text;
  EXPECT_NE(text.find(R"("gains":[null])"), std::string::npos) << text;
  EXPECT_NE(text.find("\"label\":\"\\u0001\\t\xC3\xA9\\ufffdabc\""), std::string::npos) << text;
}

TEST_F(SampleJson, FloatsRoundTrip) {
  const double values[] = {0.1, 1.0 / 3.0, 6.02214076e23, -1e-300, 123456789.125};
  for (double value : values) {
    put(offset_of("origin"), value);
    const std::string text = json();
    const std::size_t start = text.find("\"x\":") + 4;
    const std::size_t end = text.find(',', start);
    EXPECT_EQ(std::stod(text.substr(start, end - start)), value) << text;
  }
}

TEST_F(SampleJson, PrimitivesAndAliases) {
  ASSERT_TRUE(parse(R"(
    typedef unsigned long long Big;
    struct P { Big big; int8 small; unsigned short us; long long neg; };
  )"));
  const Type* p = registry_.find("P");
  ASSERT_NE(p, nullptr);
  std::vector<std::byte> data(p->size);
  const std::uint64_t big = std::numeric_limits<std::uint64_t>::max();
  std::memcpy(data.data() + field(*p, "big").offset, &big, 8);
  const std::int8_t small = -128;
  std::memcpy(data.data() + field(*p, "small").offset, &small, 1);
  const std::uint16_t us = 65535;
  std::memcpy(data.data() + field(*p, "us").offset, &us, 2);
  const std::int64_t neg = std::numeric_limits<std::int64_t>::min();
  std::memcpy(data.data() + field(*p, "neg").offset, &neg, 8);
  EXPECT_EQ(sample_to_json(*p, data.data(), data.size()),
            R"({"big":18446744073709551615,"small":-128,"us":65535,"neg":-9223372036854775808})");
  EXPECT_EQ(sample_to_json(*registry_.find("Big"), data.data(), 8), "18446744073709551615");
}

}  // namespace
