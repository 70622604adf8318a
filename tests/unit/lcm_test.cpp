// LCM type files (lcm_parser.cpp) and the LCM codec (lcm_codec.cpp). The fingerprints and
// byte vectors written out here were produced by lcm-gen 1.3.1's generated C code; the
// cross tests (tests/cross/lcm) check the same against lcm-gen at every build.
#include <gtest/gtest.h>

#include "../support/type_lookup.hpp"
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "polyport/codecs/codec.hpp"
#include "polyport/base/diagnostics.hpp"
#include "polyport/types/types.hpp"

namespace {

using namespace polyport;
using Messages = std::vector<std::string>;

class LcmFixture : public ::testing::Test {
 protected:
  bool parse(std::string_view text, const std::string& file = "t.lcm") {
    return registry_.add_lcm_text(text, file, diagnostics_);
  }

  Messages messages() const {
    Messages out;
    for (const Diagnostic& item : diagnostics_.all()) out.push_back(item.to_string());
    return out;
  }

  const Type& parse_ok(std::string_view text, std::string_view name) {
    EXPECT_TRUE(parse(text)) << ::testing::PrintToString(messages());
    return get(name);
  }

  const Type& get(std::string_view name) { return test::type_or_fail(registry_, name); }

  const Field& field(const Type& type, std::string_view name) { return test::field_or_fail(type, name); }

  Messages errors_for(std::string_view text) {
    EXPECT_FALSE(parse(text));
    return messages();
  }

  TypeRegistry registry_;
  Diagnostics diagnostics_;
};

// ---- parser: constructs ------------------------------------------------------------------

TEST_F(LcmFixture, PackageQualifiesStructNamesWithColons) {
  const Type& type = parse_ok("package a.b;\nstruct t { int32_t x; }\n", "a::b::t");
  EXPECT_EQ(type.name, "a::b::t");
  EXPECT_EQ(type.kind, TypeKind::structure);
  EXPECT_EQ(type.origin, TypeOrigin::lcm);
  EXPECT_EQ(type.where.file, "t.lcm");
  EXPECT_EQ(type.where.line, 2u);
  EXPECT_EQ(type.where.column, 8u);
  EXPECT_EQ(registry_.find("a.b.t"), &type);    // LCM's dotted spelling
  EXPECT_EQ(registry_.find("::a::b::t"), &type);
  EXPECT_EQ(registry_.find("a.b.missing"), nullptr);
}

TEST_F(LcmFixture, NoPackageMeansTheRootScope) {
  const Type& type = parse_ok("struct plain_t { double v; }", "plain_t");
  EXPECT_EQ(type.name, "plain_t");
}

TEST_F(LcmFixture, PrimitivesMapToFlatKinds) {
  const Type& type = parse_ok(R"(
    struct p {
      int8_t a; int16_t b; int32_t c; int64_t d; byte e; float f; double g; string h; boolean i;
    })",
                              "p");
  const std::pair<const char*, TypeKind> kExpected[] = {
      {"a", TypeKind::int8},    {"b", TypeKind::int16},   {"c", TypeKind::int32},
      {"d", TypeKind::int64},   {"e", TypeKind::octet},   {"f", TypeKind::float32},
      {"g", TypeKind::float64}, {"h", TypeKind::string},  {"i", TypeKind::boolean},
  };
  for (const auto& [name, kind] : kExpected) {
    ASSERT_NE(field(type, name).type, nullptr) << name;
    EXPECT_EQ(field(type, name).type->kind, kind) << name;
    EXPECT_TRUE(field(type, name).length_fields.empty()) << name;
  }
  EXPECT_EQ(field(type, "h").type->bound, 0u);  // unbounded string: a FlatSpan
  EXPECT_EQ(field(type, "h").type->size, sizeof(FlatSpan));
  // C layout: a@0 b@2 c@4 d@8 e@16 f@20 g@24 h@32 i@40, size 48.
  EXPECT_EQ(field(type, "b").offset, 2u);
  EXPECT_EQ(field(type, "d").offset, 8u);
  EXPECT_EQ(field(type, "f").offset, 20u);
  EXPECT_EQ(field(type, "h").offset, 32u);
  EXPECT_EQ(field(type, "i").offset, 40u);
  EXPECT_EQ(type.size, 48u);
}

TEST_F(LcmFixture, FixedArraysAreArraysRowMajor) {
  const Type& type = parse_ok("struct f { double v[3]; int16_t g[2][0x3]; byte o[010]; }", "f");
  const Type& v = *field(type, "v").type;
  EXPECT_EQ(v.kind, TypeKind::array);
  EXPECT_EQ(v.bound, 3u);
  EXPECT_EQ(v.element->kind, TypeKind::float64);
  const Type& g = *field(type, "g").type;
  EXPECT_EQ(g.kind, TypeKind::array);
  EXPECT_EQ(g.bound, 2u);
  EXPECT_EQ(g.element->kind, TypeKind::array);
  EXPECT_EQ(g.element->bound, 3u);
  EXPECT_EQ(g.size, 12u);
  EXPECT_EQ(field(type, "o").type->bound, 8u);  // octal, as C reads it
}

TEST_F(LcmFixture, MemberSizedArraysAreUnboundedSequencesWithTheirLengthMember) {
  const Type& type = parse_ok("struct s { int32_t n; int8_t k; double v[n]; string names[k]; }", "s");
  const Field& v = field(type, "v");
  EXPECT_EQ(v.type->kind, TypeKind::sequence);
  EXPECT_EQ(v.type->bound, 0u);
  EXPECT_EQ(v.type->element->kind, TypeKind::float64);
  EXPECT_EQ(v.length_fields, Messages{"n"});
  EXPECT_EQ(field(type, "names").type->element->kind, TypeKind::string);
  EXPECT_EQ(field(type, "names").length_fields, Messages{"k"});
}

TEST_F(LcmFixture, MixedDimensionsNestOutermostFirst) {
  const Type& type = parse_ok(
      "struct m { int32_t rows; int64_t cols; boolean cells[2][rows][3][cols]; double r[rows][2]; }", "m");
  const Field& cells = field(type, "cells");
  EXPECT_EQ(cells.length_fields, (Messages{"rows", "cols"}));
  const Type* level = cells.type;
  EXPECT_EQ(level->kind, TypeKind::array);
  EXPECT_EQ(level->bound, 2u);
  level = level->element;
  EXPECT_EQ(level->kind, TypeKind::sequence);
  level = level->element;
  EXPECT_EQ(level->kind, TypeKind::array);
  EXPECT_EQ(level->bound, 3u);
  level = level->element;
  EXPECT_EQ(level->kind, TypeKind::sequence);
  EXPECT_EQ(level->element->kind, TypeKind::boolean);
  const Field& r = field(type, "r");
  EXPECT_EQ(r.type->kind, TypeKind::sequence);
  EXPECT_EQ(r.type->element->kind, TypeKind::array);
  EXPECT_EQ(r.length_fields, Messages{"rows"});
}

TEST_F(LcmFixture, SeveralMembersPerDeclarationEachWithItsOwnDimensions) {
  const Type& type = parse_ok("struct d { int16_t n, v[n], w[2]; }", "d");
  ASSERT_EQ(type.fields.size(), 3u);
  EXPECT_EQ(field(type, "n").type->kind, TypeKind::int16);
  EXPECT_EQ(field(type, "v").type->kind, TypeKind::sequence);
  EXPECT_EQ(field(type, "w").type->kind, TypeKind::array);
}

TEST_F(LcmFixture, NestedStructsResolveAsLcmGenDoes) {
  ASSERT_TRUE(parse("package other;\nstruct far_t { int8_t x; }\n", "other.lcm"));
  const Type& type = parse_ok(R"(
    package here;
    struct user_t {
      near_t a;           // unqualified: this package, declared later in this file
      here.near_t b[2];   // qualified
      other.far_t c;      // from a file loaded before
      int32_t n;
      near_t d[n];
    }
    struct near_t { double v; }
  )",
                              "here.user_t");
  EXPECT_EQ(field(type, "a").type, &get("here::near_t"));
  EXPECT_EQ(field(type, "b").type->element, &get("here::near_t"));
  EXPECT_EQ(field(type, "c").type, &get("other::far_t"));
  EXPECT_EQ(field(type, "d").type->element, &get("here::near_t"));
  // Registered in dependency order.
  const std::vector<const Type*> declared = registry_.declared();
  ASSERT_EQ(declared.size(), 3u);
  EXPECT_EQ(declared[1]->name, "here::near_t");
  EXPECT_EQ(declared[2]->name, "here::user_t");
}

TEST_F(LcmFixture, PackageAppliesToTheStructsAfterIt) {
  ASSERT_TRUE(parse("struct a_t { int8_t x; }\npackage p;\nstruct b_t { int8_t x; }\npackage q.r;\nstruct c_t { p.b_t b; }"));
  EXPECT_NE(registry_.find("a_t"), nullptr);
  EXPECT_NE(registry_.find("p::b_t"), nullptr);
  EXPECT_NE(registry_.find("q::r::c_t"), nullptr);
}

TEST_F(LcmFixture, ConstantsAreRegisteredUnderTheStruct) {
  parse_ok(R"(
    package k;
    struct c {
      const int8_t SMALL = -0x7f;
      const int16_t OCT = 0777, NEG = -32768;
      const int32_t A = 1, B = 2;
      const int64_t BIG = 9223372036854775807;
      const float HALF = 0.5;
      const double PI = 3.25, TINY = -2.5e-3, EXP = 1e+10;
      int32_t x;
    })",
           "k::c");
  EXPECT_EQ(registry_.constant("k::c::SMALL"), ConstValue(std::int64_t{-127}));
  EXPECT_EQ(registry_.constant("k::c::OCT"), ConstValue(std::int64_t{511}));
  EXPECT_EQ(registry_.constant("k::c::NEG"), ConstValue(std::int64_t{-32768}));
  EXPECT_EQ(registry_.constant("k::c::A"), ConstValue(std::int64_t{1}));
  EXPECT_EQ(registry_.constant("k::c::B"), ConstValue(std::int64_t{2}));
  EXPECT_EQ(registry_.constant("k::c::BIG"), ConstValue(std::int64_t{9223372036854775807}));
  EXPECT_EQ(registry_.constant("k::c::HALF"), ConstValue(0.5));
  EXPECT_EQ(registry_.constant("k::c::PI"), ConstValue(3.25));
  EXPECT_EQ(registry_.constant("k::c::TINY"), ConstValue(-2.5e-3));
  EXPECT_EQ(registry_.constant("k::c::EXP"), ConstValue(1e10));
  EXPECT_EQ(get("k::c").fields.size(), 1u);  // constants are not members
}

TEST_F(LcmFixture, CommentsAnywhere) {
  const Type& type = parse_ok(
      "// leading\n/* block\n over lines */ package /* in */ c; // trailing\n"
      "struct /**/ t // x\n{ /* a */ int32_t /* b */ n /* c */; double v[ /* d */ n ]; } // end",
      "c::t");
  EXPECT_EQ(type.fields.size(), 2u);
}

TEST_F(LcmFixture, EmptyStructIsAllowed) {
  const Type& type = parse_ok("struct e { }", "e");
  EXPECT_TRUE(type.fields.empty());
  EXPECT_EQ(type.size, 0u);
}

TEST_F(LcmFixture, MemberLocationsAreRecorded) {
  const Type& type = parse_ok("struct t {\n  int32_t  first;\n  double x, second;\n}", "t");
  EXPECT_EQ(field(type, "first").where.line, 2u);
  EXPECT_EQ(field(type, "first").where.column, 12u);
  EXPECT_EQ(field(type, "second").where.line, 3u);
  EXPECT_EQ(field(type, "second").where.column, 13u);
}

TEST_F(LcmFixture, FilesAreReadOnceAndMissingOnesReported) {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / ("lcm_test_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const std::filesystem::path file = dir / "file_t.lcm";
  std::ofstream(file) << "package f;\nstruct file_t { int64_t x; }\n";
  EXPECT_TRUE(registry_.add_lcm_file(file, diagnostics_));
  EXPECT_TRUE(registry_.add_type_file(file, diagnostics_));  // by extension; a second load is skipped
  EXPECT_NE(registry_.find("f.file_t"), nullptr);
  EXPECT_FALSE(registry_.add_lcm_file(dir / "missing.lcm", diagnostics_));
  EXPECT_EQ(messages(), Messages{(dir / "missing.lcm").string() + ": cannot open file"});
  std::filesystem::remove_all(dir);
}

// ---- parser: errors, each with its exact diagnostic -------------------------------------------

TEST_F(LcmFixture, UnknownTypeIsReportedAtTheType) {
  EXPECT_EQ(errors_for("package a;\nstruct t {\n    missing_t m;\n    b.other_t o;\n}"),
            (Messages{"t.lcm:3:5: unknown type 'a.missing_t'", "t.lcm:4:5: unknown type 'b.other_t'"}));
  EXPECT_EQ(registry_.find("a::t"), nullptr);
}

TEST_F(LcmFixture, BadDimensionsAreReportedAtTheSize) {
  EXPECT_EQ(errors_for(R"(struct t {
  double d;
  int32_t ok[2];
  const int32_t K = 3;
  double a[n];
  int32_t n;
  double b[d];
  double c[ok];
  double e[0];
  double f[3x];
  double g[K];
  double h[-1];
  byte w;
  double i[w];
  double j[99999999999];
  double k[];
})"),
            (Messages{
                "t.lcm:5:12: array size 'n' is not a member declared before 'a'",
                "t.lcm:7:12: array size 'd' must be an int8_t, int16_t, int32_t or int64_t member, not 'double'",
                "t.lcm:8:12: array size 'ok' must not be an array",
                "t.lcm:9:12: array size '0' must be > 0",
                "t.lcm:10:12: array size '3x' is not an integer",
                "t.lcm:11:12: array size 'K' is a constant; lcm-gen 1.3.1 takes only a number or an "
                "earlier integer member",
                "t.lcm:12:12: array size '-1' must be a positive number or an earlier integer member",
                "t.lcm:14:12: array size 'w' must be an int8_t, int16_t, int32_t or int64_t member, not 'byte'",
                "t.lcm:15:12: array size '99999999999' is too large",
                "t.lcm:16:12: expected an array size, found ']'",
            }));
}

TEST_F(LcmFixture, AMemberCannotSizeItself) {
  EXPECT_EQ(errors_for("struct t { int32_t n[n]; }"),
            Messages{"t.lcm:1:22: array size 'n' is not a member declared before 'n'"});
}

TEST_F(LcmFixture, DuplicateMembersAndConstants) {
  EXPECT_EQ(errors_for("struct t {\n  int32_t x;\n  double x;\n  const int8_t C = 1, x = 2;\n  int8_t C;\n}"),
            (Messages{"t.lcm:3:10: duplicate member 'x'", "t.lcm:4:23: duplicate member 'x'",
                      "t.lcm:5:10: duplicate member 'C'"}));
  EXPECT_EQ(registry_.find("t"), nullptr);
}

TEST_F(LcmFixture, SyntaxErrors) {
  EXPECT_EQ(errors_for("struct t { int32_t x }"), Messages{"t.lcm:1:22: expected ';', found '}'"});
}

TEST_F(LcmFixture, SyntaxErrorsAtTopLevelAndEndOfFile) {
  EXPECT_EQ(errors_for("packge a;\nstruct ok_t { int8_t x; }\nstruct t {\n  int32_t x;\n"),
            (Messages{"t.lcm:1:1: expected 'package' or 'struct', found 'packge'",
                      "t.lcm:5:1: expected '}', found end of file"}));
  EXPECT_NE(registry_.find("ok_t"), nullptr);  // the parser went on after the first error
}

TEST_F(LcmFixture, LexicalErrors) {
  EXPECT_EQ(errors_for("struct t {\n  int32_t x; @@\n  string s = \"x\";\n}\n/* open"),
            (Messages{"t.lcm:2:14: unexpected character '@'", "t.lcm:3:12: expected ';', found '='",
                      "t.lcm:3:14: unexpected character '\"'", "t.lcm:3:16: unexpected character '\"'",
                      "t.lcm:5:1: unterminated comment"}));
}

TEST_F(LcmFixture, MalformedNamesAndDeclarations) {
  EXPECT_EQ(errors_for("package 1a;\nstruct 2t { }\nstruct t {\n  int32_t 9x;\n  a..b y;\n  struct u { }\n  "
                       "const string S = 1;\n  const int8_t T = 300, U = 1.5, V = x;\n  const float W = 1e39;\n}\n"
                       "enum e { A, B }\nstruct after_t { int8_t x; }"),
            (Messages{"t.lcm:1:9: invalid package name '1a'",
                      "t.lcm:2:8: invalid struct name '2t'",
                      "t.lcm:4:11: invalid member name '9x'",
                      "t.lcm:5:3: invalid type name 'a..b'",
                      "t.lcm:6:3: nested declarations are not supported",
                      "t.lcm:7:9: invalid type for a constant 'string' (int8_t, int16_t, int32_t, int64_t, float or "
                      "double)",
                      "t.lcm:8:20: value '300' is out of range for int8_t",
                      "t.lcm:9:19: value '1e39' is out of range for float",
                      "t.lcm:11:1: enums are not supported (lcm-gen 1.3.1 only keeps them for old files)"}));
  EXPECT_NE(registry_.find("after_t"), nullptr);
}

TEST_F(LcmFixture, ConstantValuesMustParse) {
  EXPECT_EQ(errors_for("struct t {\n  const int32_t A = 1.5;\n  const double B = x;\n  const int64_t C = "
                       "9223372036854775808;\n}"),
            (Messages{"t.lcm:2:21: value '1.5' is not an integer", "t.lcm:3:20: value 'x' is not a floating point number",
                      "t.lcm:4:21: value '9223372036854775808' is out of range for int64_t"}));
}

TEST_F(LcmFixture, RecursiveTypesAreRefused) {
  EXPECT_EQ(errors_for("struct a_t {\n  int32_t n;\n  b_t b[n];\n}\nstruct b_t {\n  a_t a;\n}\nstruct self_t { int8_t "
                       "n; self_t kids[n]; }"),
            (Messages{"t.lcm:6:3: type 'a_t' contains itself (recursive LCM types are not supported)",
                      "t.lcm:8:27: type 'self_t' contains itself (recursive LCM types are not supported)"}));
  EXPECT_EQ(registry_.find("a_t"), nullptr);
  EXPECT_EQ(registry_.find("b_t"), nullptr);
}

TEST_F(LcmFixture, StructsUsingABrokenStructFailQuietly) {
  // One error for bad_t; user_t is not registered but gets no second message.
  EXPECT_EQ(errors_for("struct user_t { bad_t b; }\nstruct bad_t { nope_t x; }\nstruct fine_t { int8_t x; }"),
            Messages{"t.lcm:2:16: unknown type 'nope_t'"});
  EXPECT_EQ(registry_.find("user_t"), nullptr);
  EXPECT_NE(registry_.find("fine_t"), nullptr);
}

TEST_F(LcmFixture, RedefinitionIsReported) {
  ASSERT_TRUE(parse("package p;\nstruct t { int8_t x; }"));
  EXPECT_EQ(errors_for("package p;\nstruct t { int16_t x; }"), Messages{"t.lcm:2:8: redefinition of 'p::t'"});
}

TEST_F(LcmFixture, OnlyLcmStructsCanBeMembers) {
  ASSERT_TRUE(registry_.add_idl_text("module m { struct idl_t { long x; }; };", "m.idl", diagnostics_));
  EXPECT_EQ(errors_for("struct t { m.idl_t a; int32 b; }"),
            (Messages{"t.lcm:1:12: type 'm.idl_t' is not an LCM struct", "t.lcm:1:23: unknown type 'int32'"}));
}

TEST_F(LcmFixture, TooManyDimensions) {
  std::string text = "struct t { double v";
  for (int i = 0; i < 33; ++i) text += "[1]";
  text += "; }";
  EXPECT_EQ(errors_for(text), Messages{"t.lcm:1:117: too many array dimensions (at most 32)"});
}

TEST_F(LcmFixture, HostileInputEndsInErrorsNotHangs) {
  // Each of these must come back (with errors) rather than loop or crash.
  const char* const kInputs[] = {"", "}", "struct", "struct {", "struct t {", "struct t { int32_t", "struct t { int32_t x[",
                                 "struct t { int32_t x[2", "package", "package ;", "/", "/*", "\x01\xff",
                                 "struct t { const", "struct t { const int8_t", "struct t { const int8_t X =",
                                 "{{{{{{{{", ";;;;", "enum", "enum {", "struct t { ] ] ] }"};
  for (const char* input : kInputs) {
    TypeRegistry registry;
    Diagnostics diagnostics;
    registry.add_lcm_text(input, "h.lcm", diagnostics);
    EXPECT_TRUE(diagnostics.has_errors() || std::string_view(input).empty()) << input;
  }
  // Comments and nothing else are an empty, valid file.
  Diagnostics diagnostics;
  EXPECT_TRUE(registry_.add_lcm_text("// only\n/* comments */", "c.lcm", diagnostics));
}

TEST_F(LcmFixture, FindTakesDottedNamesOnlyForQualifiedTypes) {
  parse_ok("package a.b;\nstruct t { int8_t x; }", "a::b::t");
  EXPECT_NE(registry_.find("a.b.t"), nullptr);
  EXPECT_EQ(registry_.find("a.b::t"), nullptr);
  EXPECT_EQ(registry_.find("a.b"), nullptr);
  EXPECT_NE(registry_.find("double"), nullptr);  // primitives unaffected
}

// ---- fingerprints ----------------------------------------------------------------------------

TEST_F(LcmFixture, FingerprintsMatchTheReferenceVectors) {
  ASSERT_TRUE(parse(R"(package demo;
struct temperature_t { int64_t utime; double degCelsius; }
struct pair_t { int32_t n; demo.temperature_t t[n]; string name; })"));
  EXPECT_EQ(get("demo.temperature_t").lcm_fingerprint, 0xa07fa3d64cbea6eaull);
  EXPECT_EQ(get("demo.pair_t").lcm_fingerprint, 0x330f6433f27afd2eull);
}

TEST_F(LcmFixture, FingerprintsMatchLcmGen) {
  // Values from lcm-gen 1.3.1's generated __t_<name>_get_hash().
  ASSERT_TRUE(parse(R"(package t;
struct eight_t { double a, b, c, d, e, f, g, h; }
struct mixed_t { boolean ok; byte b; int16_t n; string s; int8_t m; int32_t grid[n][2]; boolean bits[2][m]; }
struct renamed_t { int64_t utime; double degCelsius; }
struct sized_hex_t { double v[0x10]; }
struct sized_dec_t { double v[16]; }
struct empty_t { }
struct outer_t { t.inner_t a; t.inner_t b[2]; }
struct inner_t { int32_t n; double v[n]; })"));
  EXPECT_EQ(get("t.eight_t").lcm_fingerprint, 0xc72316d72784def1ull);
  EXPECT_EQ(get("t.mixed_t").lcm_fingerprint, 0x1f515dd5e90a5ee0ull);
  // The struct's name is not hashed: renamed_t is temperature_t under another name.
  EXPECT_EQ(get("t.renamed_t").lcm_fingerprint, 0xa07fa3d64cbea6eaull);
  // The size's text is hashed, not its value.
  EXPECT_EQ(get("t.sized_hex_t").lcm_fingerprint, 0xcfda199b508a25d0ull);
  EXPECT_EQ(get("t.sized_dec_t").lcm_fingerprint, 0xe1473025e668b0f3ull);
  EXPECT_EQ(get("t.empty_t").lcm_fingerprint, 0x000000002468acf0ull);  // 0x12345678 rotated
  EXPECT_EQ(get("t.inner_t").lcm_fingerprint, 0x740511e46f308d88ull);
  // Each struct member adds its type's fingerprint (once per member, whatever its dimensions).
  EXPECT_EQ(get("t.outer_t").lcm_fingerprint, 0x92144a9e901c1888ull);
}

TEST_F(LcmFixture, FingerprintsHashLongNamesLengthAsASignedChar) {
  // lcm-gen passes strlen() to its hash as a (signed) char: 128 and 200 add -128 and -56.
  // lcm-gen 1.3.1's C emitter aborts on names this long; these base hashes are from its
  // Python emitter (`lcm-gen -p`), rotated once as for any struct without struct members.
  ASSERT_TRUE(parse("struct a_t { int8_t m" + std::string(127, 'x') + "; }\nstruct b_t { int8_t m" +
                    std::string(199, 'x') + "; }"));
  EXPECT_EQ(get("a_t").lcm_fingerprint, 0x870b10ce8d1fffafull);  // base 0xc3858867468fffd7
  EXPECT_EQ(get("b_t").lcm_fingerprint, 0x42130b5dba7d4900ull);  // base 0x210985aedd3ea480
}

TEST_F(LcmFixture, FingerprintsDependOnMemberNamesTypesAndDimensions) {
  ASSERT_TRUE(parse(R"(
struct base_t { int32_t x; }
struct name_t { int32_t y; }
struct kind_t { int64_t x; }
struct dims_t { int32_t x[1]; }
struct holder_a_t { base_t m; }
struct holder_b_t { name_t m; })"));
  const std::uint64_t base = get("base_t").lcm_fingerprint;
  EXPECT_NE(get("name_t").lcm_fingerprint, base);
  EXPECT_NE(get("kind_t").lcm_fingerprint, base);
  EXPECT_NE(get("dims_t").lcm_fingerprint, base);
  EXPECT_NE(get("holder_a_t").lcm_fingerprint, get("holder_b_t").lcm_fingerprint);
}

// ---- codec -------------------------------------------------------------------------------

// A flat sample written by offsets, with a tail for strings and member-sized arrays.
class Flat {
 public:
  explicit Flat(const Type& type) : bytes_(type.size) {}
  template <class T>
  Flat& put(std::uint32_t at, T value) {
    std::memcpy(bytes_.data() + at, &value, sizeof value);
    return *this;
  }
  std::uint32_t reserve(std::size_t size, std::size_t align) {
    const std::size_t at = (bytes_.size() + align - 1) / align * align;
    bytes_.resize(at + size);
    return static_cast<std::uint32_t>(at);
  }
  Flat& string(std::uint32_t at, std::string_view text) {
    const std::uint32_t offset = reserve(text.size() + 1, 1);
    std::memcpy(bytes_.data() + offset, text.data(), text.size());
    return put(at, FlatSpan{offset, static_cast<std::uint32_t>(text.size())});
  }
  template <class T>
  Flat& array(std::uint32_t at, const std::vector<T>& values, std::uint32_t count) {
    const std::uint32_t offset = reserve(values.size() * sizeof(T), alignof(T));
    if (!values.empty()) std::memcpy(bytes_.data() + offset, values.data(), values.size() * sizeof(T));
    return put(at, FlatSpan{offset, count});
  }
  std::vector<std::byte>& bytes() { return bytes_; }
  const std::byte* data() const { return bytes_.data(); }
  std::uint32_t size() const { return static_cast<std::uint32_t>(bytes_.size()); }

 private:
  std::vector<std::byte> bytes_;
};

std::vector<std::byte> from_hex(std::string_view hex) {
  std::vector<std::byte> out;
  for (std::size_t i = 0; i + 1 < hex.size(); i += 2) {
    out.push_back(static_cast<std::byte>(std::stoi(std::string(hex.substr(i, 2)), nullptr, 16)));
  }
  return out;
}

std::string to_hex(const std::byte* data, std::size_t size) {
  static constexpr char kDigits[] = "0123456789abcdef";
  std::string out;
  for (std::size_t i = 0; i < size; ++i) {
    out += kDigits[std::to_integer<unsigned>(data[i]) >> 4];
    out += kDigits[std::to_integer<unsigned>(data[i]) & 0xF];
  }
  return out;
}

class LcmCodecFixture : public LcmFixture {
 protected:
  void SetUp() override {
    ASSERT_TRUE(parse(R"(package t;
struct eight_t { double a, b, c, d, e, f, g, h; }
struct mixed_t { boolean ok; byte b; int16_t n; string s; int8_t m; int32_t grid[n][2]; boolean bits[2][m]; }
struct temperature_t { int64_t utime; double degCelsius; }
struct pair_t { int32_t n; temperature_t t[n]; string name; }
struct inner_t { int16_t k; string words[k]; }
struct outer_t { int8_t tag; inner_t fixed[2]; int32_t n; inner_t seq[n]; })"))
        << ::testing::PrintToString(messages());
  }

  std::unique_ptr<Codec> codec(std::string_view name) {
    auto made = make_lcm_codec(get(name));
    if (!made.ok()) {
      ADD_FAILURE() << made.error().message;
      return nullptr;
    }
    return std::move(made).value();
  }

  std::string encode(const Codec& codec, const Flat& flat) {
    std::vector<std::byte> wire(codec.max_wire_size(flat.size()));
    const CodecResult result = codec.encode(flat.data(), flat.size(), wire.data(), static_cast<std::uint32_t>(wire.size()));
    if (!result.ok()) return std::string("error: ") + std::string(to_string(result.error));
    return to_hex(wire.data(), result.size);
  }

  CodecError decode_error(const Codec& codec, const std::vector<std::byte>& wire, std::uint32_t capacity = 4096) {
    std::vector<std::byte> flat(capacity);
    return codec.decode(wire.data(), static_cast<std::uint32_t>(wire.size()), flat.data(), capacity).error;
  }

  std::string decode_json(const Codec& codec, const std::vector<std::byte>& wire) {
    std::vector<std::byte> flat(4096);
    const CodecResult result = codec.decode(wire.data(), static_cast<std::uint32_t>(wire.size()), flat.data(), 4096);
    if (!result.ok()) return std::string("error: ") + std::string(to_string(result.error));
    return sample_to_json(codec.type(), flat.data(), result.size);
  }

  // mixed_t: ok=true b=0xab n=1 s="hi" m=2 grid=[[1,-1]] bits=[[1,0],[0,1]], as lcm-gen encodes it.
  static constexpr std::string_view kMixedWire =
      "1f515dd5e90a5ee0" "01" "ab" "0001" "00000003" "686900" "02" "00000001" "ffffffff" "0100" "0001";

  Flat mixed_flat() {
    const Type& type = get("t.mixed_t");
    Flat flat(type);
    flat.put(field(type, "ok").offset, std::uint8_t{1})
        .put(field(type, "b").offset, std::uint8_t{0xAB})
        .put(field(type, "n").offset, std::int16_t{1})
        .string(field(type, "s").offset, "hi")
        .put(field(type, "m").offset, std::int8_t{2})
        .array(field(type, "grid").offset, std::vector<std::int32_t>{1, -1}, 1)
        .array(field(type, "bits").offset, std::vector<std::uint8_t>{1, 0}, 2)
        .array(field(type, "bits").offset + 8, std::vector<std::uint8_t>{0, 1}, 2);
    return flat;
  }
};

TEST_F(LcmCodecFixture, EncodesEightDoublesAsLcmGen) {
  const Type& type = get("t.eight_t");
  Flat flat(type);
  for (std::uint32_t i = 0; i < 8; ++i) flat.put(i * 8, double(i + 1));
  auto eight = codec("t.eight_t");
  ASSERT_NE(eight, nullptr);
  const std::string expected =
      "c72316d72784def1" "3ff0000000000000" "4000000000000000" "4008000000000000" "4010000000000000"
      "4014000000000000" "4018000000000000" "401c000000000000" "4020000000000000";
  EXPECT_EQ(encode(*eight, flat), expected);
  EXPECT_EQ(decode_json(*eight, from_hex(expected)), R"({"a":1,"b":2,"c":3,"d":4,"e":5,"f":6,"g":7,"h":8})");
  EXPECT_EQ(eight->format(), WireFormat::lcm);
  EXPECT_EQ(&eight->type(), &type);
}

TEST_F(LcmCodecFixture, EncodesTheReferencePair) {
  const Type& pair = get("t.pair_t");
  Flat flat(pair);
  flat.put(field(pair, "n").offset, std::int32_t{1});
  const std::uint32_t t = flat.reserve(16, 8);
  flat.put(field(pair, "t").offset, FlatSpan{t, 1}).put(t, std::int64_t{1}).put(t + 8, 2.5);
  flat.string(field(pair, "name").offset, "ab");
  auto codec_pair = codec("t.pair_t");
  ASSERT_NE(codec_pair, nullptr);
  const std::string expected = "330f6433f27afd2e" "00000001" "0000000000000001" "4004000000000000" "00000003" "616200";
  EXPECT_EQ(encode(*codec_pair, flat), expected);
  EXPECT_EQ(decode_json(*codec_pair, from_hex(expected)), R"({"n":1,"t":[{"utime":1,"degCelsius":2.5}],"name":"ab"})");
}

TEST_F(LcmCodecFixture, EncodesMixedDimensionsBooleansBytesAndStringsAsLcmGen) {
  auto mixed = codec("t.mixed_t");
  ASSERT_NE(mixed, nullptr);
  EXPECT_EQ(encode(*mixed, mixed_flat()), kMixedWire);
  EXPECT_EQ(decode_json(*mixed, from_hex(kMixedWire)),
            R"({"ok":true,"b":171,"n":1,"s":"hi","m":2,"grid":[[1,-1]],"bits":[[true,false],[false,true]]})");
}

TEST_F(LcmCodecFixture, NestedStructsWithTheirOwnLengthsRoundTrip) {
  // outer_t: tag, two inline inner_t, then n inner_t in the tail; each inner_t sizes its own
  // words by its own k, so lengths are looked up in the right frame.
  const Type& outer = get("t.outer_t");
  const Type& inner = get("t.inner_t");
  Flat flat(outer);
  flat.put(field(outer, "tag").offset, std::int8_t{-1});
  const auto fill_inner = [&](std::uint32_t at, std::vector<std::string_view> words) {
    flat.put(at + field(inner, "k").offset, static_cast<std::int16_t>(words.size()));
    const std::uint32_t spans = flat.reserve(words.size() * sizeof(FlatSpan), alignof(FlatSpan));
    flat.put(at + field(inner, "words").offset, FlatSpan{spans, static_cast<std::uint32_t>(words.size())});
    for (std::size_t i = 0; i < words.size(); ++i) flat.string(spans + static_cast<std::uint32_t>(i * 8), words[i]);
  };
  fill_inner(field(outer, "fixed").offset, {"a"});
  fill_inner(field(outer, "fixed").offset + inner.size, {});
  flat.put(field(outer, "n").offset, std::int32_t{2});
  const std::uint32_t seq = flat.reserve(2 * inner.size, inner.align);
  flat.put(field(outer, "seq").offset, FlatSpan{seq, 2});
  fill_inner(seq, {"bc", "", "d"});
  fill_inner(seq + inner.size, {"e"});

  auto outer_codec = codec("t.outer_t");
  ASSERT_NE(outer_codec, nullptr);
  const std::string wire = encode(*outer_codec, flat);
  EXPECT_EQ(wire.substr(16), "ff" "0001" "00000002" "6100" "0000" "00000002"
                             "0003" "00000003" "626300" "00000001" "00" "00000002" "6400"
                             "0001" "00000002" "6500");
  EXPECT_EQ(decode_json(*outer_codec, from_hex(wire)),
            R"({"tag":-1,"fixed":[{"k":1,"words":["a"]},{"k":0,"words":[]}],"n":2,)"
            R"("seq":[{"k":3,"words":["bc","","d"]},{"k":1,"words":["e"]}]})");
}

TEST_F(LcmCodecFixture, DecodeLeavesNoStaleBytes) {
  // temperature_t has no padding, pair_t has (int32 n before 8-aligned spans).
  auto pair = codec("t.pair_t");
  ASSERT_NE(pair, nullptr);
  const std::vector<std::byte> wire =
      from_hex("330f6433f27afd2e" "00000001" "0000000000000001" "4004000000000000" "00000003" "616200");
  std::vector<std::byte> first(256, std::byte{0xAA});
  std::vector<std::byte> second(256, std::byte{0x55});
  const CodecResult a = pair->decode(wire.data(), static_cast<std::uint32_t>(wire.size()), first.data(), 256);
  const CodecResult b = pair->decode(wire.data(), static_cast<std::uint32_t>(wire.size()), second.data(), 256);
  ASSERT_TRUE(a.ok() && b.ok());
  ASSERT_EQ(a.size, b.size);
  EXPECT_EQ(std::memcmp(first.data(), second.data(), a.size), 0);
}

// ---- codec errors ----------------------------------------------------------------------------

TEST_F(LcmCodecFixture, DecodeRefusesAnotherFingerprint) {
  auto mixed = codec("t.mixed_t");
  ASSERT_NE(mixed, nullptr);
  std::vector<std::byte> wire = from_hex(kMixedWire);
  wire[7] ^= std::byte{1};
  EXPECT_EQ(decode_error(*mixed, wire), CodecError::fingerprint_mismatch);
}

TEST_F(LcmCodecFixture, DecodeRefusesEveryTruncation) {
  auto mixed = codec("t.mixed_t");
  ASSERT_NE(mixed, nullptr);
  const std::vector<std::byte> wire = from_hex(kMixedWire);
  for (std::size_t size = 0; size < wire.size(); ++size) {
    const std::vector<std::byte> cut(wire.begin(), wire.begin() + static_cast<std::ptrdiff_t>(size));
    EXPECT_EQ(decode_error(*mixed, cut), CodecError::truncated) << size;
  }
}

TEST_F(LcmCodecFixture, DecodeRefusesTrailingBytes) {
  auto mixed = codec("t.mixed_t");
  ASSERT_NE(mixed, nullptr);
  std::vector<std::byte> wire = from_hex(kMixedWire);
  wire.push_back(std::byte{0});
  EXPECT_EQ(decode_error(*mixed, wire), CodecError::trailing_bytes);
}

TEST_F(LcmCodecFixture, DecodeRefusesBadLengthsStringsAndBooleans) {
  auto mixed = codec("t.mixed_t");
  ASSERT_NE(mixed, nullptr);
  // Offsets into kMixedWire: ok 8, b 9, n 10-11, string length 12-15, text 16-18, m 19.
  const auto with = [](std::size_t at, std::string_view hex) {
    std::vector<std::byte> wire = from_hex(kMixedWire);
    const std::vector<std::byte> patch = from_hex(hex);
    std::copy(patch.begin(), patch.end(), wire.begin() + static_cast<std::ptrdiff_t>(at));
    return wire;
  };
  EXPECT_EQ(decode_error(*mixed, with(8, "02")), CodecError::bad_value);         // boolean 2
  EXPECT_EQ(decode_error(*mixed, with(10, "ffff")), CodecError::bad_value);      // n = -1
  EXPECT_EQ(decode_error(*mixed, with(10, "7fff")), CodecError::truncated);      // n larger than the message
  EXPECT_EQ(decode_error(*mixed, with(12, "00000000")), CodecError::bad_value);  // no room for the NUL
  EXPECT_EQ(decode_error(*mixed, with(12, "ffffffff")), CodecError::bad_value);  // negative string length
  EXPECT_EQ(decode_error(*mixed, with(12, "7fffffff")), CodecError::truncated);  // longer than the message
  EXPECT_EQ(decode_error(*mixed, with(18, "21")), CodecError::bad_value);        // the NUL is not there
  EXPECT_EQ(decode_error(*mixed, with(19, "80")), CodecError::bad_value);        // m = -128
  EXPECT_EQ(decode_error(*mixed, with(19, "7f")), CodecError::truncated);        // m larger than the message
  EXPECT_EQ(decode_error(*mixed, with(28, "02")), CodecError::bad_value);        // a boolean of bits
}

TEST_F(LcmCodecFixture, DecodeRefusesASampleTooSmall) {
  auto mixed = codec("t.mixed_t");
  ASSERT_NE(mixed, nullptr);
  const std::vector<std::byte> wire = from_hex(kMixedWire);
  const std::uint32_t fixed = get("t.mixed_t").size;
  EXPECT_EQ(decode_error(*mixed, wire, fixed - 1), CodecError::output_too_small);
  EXPECT_EQ(decode_error(*mixed, wire, fixed + 2), CodecError::output_too_small);  // the string's 3 bytes
  // The whole tail: "hi\0", grid (8, aligned to 4), two bit spans (16, aligned to 8), 2 + 2 bits.
  std::vector<std::byte> flat(4096);
  const CodecResult full = mixed->decode(wire.data(), static_cast<std::uint32_t>(wire.size()), flat.data(), 4096);
  ASSERT_TRUE(full.ok());
  EXPECT_EQ(decode_error(*mixed, wire, full.size), CodecError::ok);
  EXPECT_EQ(decode_error(*mixed, wire, full.size - 1), CodecError::output_too_small);
}

TEST_F(LcmCodecFixture, EncodeRefusesCountsThatDisagreeWithTheLengthMember) {
  auto mixed = codec("t.mixed_t");
  ASSERT_NE(mixed, nullptr);
  const Type& type = get("t.mixed_t");
  Flat flat = mixed_flat();
  flat.put(field(type, "n").offset, std::int16_t{2});  // grid's span still holds 1
  EXPECT_EQ(encode(*mixed, flat), "error: bad_value");
  flat = mixed_flat();
  flat.put(field(type, "m").offset, std::int8_t{1});  // the bits rows hold 2
  EXPECT_EQ(encode(*mixed, flat), "error: bad_value");
  flat = mixed_flat();
  flat.put(field(type, "n").offset, std::int16_t{-1});
  flat.put(field(type, "grid").offset, FlatSpan{0, 0xFFFFFFFF});
  EXPECT_EQ(encode(*mixed, flat), "error: bad_value");
}

TEST_F(LcmCodecFixture, EncodeRefusesSpansOutsideTheSample) {
  auto mixed = codec("t.mixed_t");
  ASSERT_NE(mixed, nullptr);
  const Type& type = get("t.mixed_t");
  Flat flat = mixed_flat();
  flat.put(field(type, "s").offset, FlatSpan{flat.size() - 1, 2});
  EXPECT_EQ(encode(*mixed, flat), "error: bad_value");
  flat = mixed_flat();
  flat.put(field(type, "grid").offset, FlatSpan{flat.size() - 4, 1});  // 8 bytes needed
  EXPECT_EQ(encode(*mixed, flat), "error: bad_value");
  flat = mixed_flat();
  flat.put(field(type, "bits").offset, FlatSpan{0xFFFFFFF0, 2});
  EXPECT_EQ(encode(*mixed, flat), "error: bad_value");
}

TEST_F(LcmCodecFixture, EncodeRefusesBooleansOtherThanZeroOrOne) {
  auto mixed = codec("t.mixed_t");
  ASSERT_NE(mixed, nullptr);
  Flat flat = mixed_flat();
  flat.put(field(get("t.mixed_t"), "ok").offset, std::uint8_t{2});
  EXPECT_EQ(encode(*mixed, flat), "error: bad_value");
}

TEST_F(LcmCodecFixture, EncodeRefusesSmallOutputsAndShortSamples) {
  auto mixed = codec("t.mixed_t");
  ASSERT_NE(mixed, nullptr);
  const Flat flat = mixed_flat();
  const std::size_t needed = kMixedWire.size() / 2;
  std::vector<std::byte> wire(needed);
  for (std::uint32_t capacity = 0; capacity < needed; ++capacity) {
    EXPECT_EQ(mixed->encode(flat.data(), flat.size(), wire.data(), capacity).error, CodecError::output_too_small)
        << capacity;
  }
  EXPECT_TRUE(mixed->encode(flat.data(), flat.size(), wire.data(), static_cast<std::uint32_t>(needed)).ok());
  EXPECT_EQ(mixed->encode(flat.data(), get("t.mixed_t").size - 1, wire.data(), 64).error, CodecError::truncated);
}

TEST_F(LcmCodecFixture, MaxWireSizeBoundsTheEncoding) {
  auto mixed = codec("t.mixed_t");
  ASSERT_NE(mixed, nullptr);
  const Flat flat = mixed_flat();
  EXPECT_GE(mixed->max_wire_size(flat.size()), kMixedWire.size() / 2);
  // Fixed part alone: 8 + ok, b, n, an empty string (5), m.
  EXPECT_EQ(mixed->max_wire_size(get("t.mixed_t").size), 8u + 1 + 1 + 2 + 5 + 1);
}

TEST_F(LcmCodecFixture, MakeCodecRefusesTypesThatAreNotLcmStructs) {
  ASSERT_TRUE(registry_.add_idl_text("struct idl_t { long x; };", "i.idl", diagnostics_));
  auto idl = make_lcm_codec(get("idl_t"));
  ASSERT_FALSE(idl.ok());
  EXPECT_EQ(idl.error().message,
            "no lcm codec for 'idl_t': only structs declared in .lcm files have an LCM fingerprint and layout");
  EXPECT_FALSE(make_lcm_codec(*registry_.primitive(TypeKind::float64)).ok());
}

TEST_F(LcmCodecFixture, MakeCodecRefusesMembersLcmCannotCarry) {
  // Built by hand through the registry's API, as another type source could.
  std::vector<Field> fields(2);
  fields[0].name = "u";
  fields[0].type = registry_.primitive(TypeKind::uint32);
  fields[1].name = "v";
  fields[1].type = registry_.sequence_of(registry_.primitive(TypeKind::float64), 0);
  fields[1].length_fields = {"u"};
  const Type* bad = registry_.declare_struct("hand::bad_t", fields, {}, diagnostics_);
  ASSERT_NE(bad, nullptr);
  const_cast<Type*>(bad)->origin = TypeOrigin::lcm;
  auto made = make_lcm_codec(*bad);
  ASSERT_FALSE(made.ok());
  EXPECT_EQ(made.error().message, "no lcm codec for 'hand::bad_t': member 'u' of 'hand::bad_t': LCM has no 'unsigned long'");

  std::vector<Field> no_length(1);
  no_length[0].name = "v";
  no_length[0].type = registry_.sequence_of(registry_.primitive(TypeKind::float64), 0);
  const Type* missing = registry_.declare_struct("hand::missing_t", no_length, {}, diagnostics_);
  ASSERT_NE(missing, nullptr);
  const_cast<Type*>(missing)->origin = TypeOrigin::lcm;
  made = make_lcm_codec(*missing);
  ASSERT_FALSE(made.ok());
  EXPECT_EQ(made.error().message,
            "no lcm codec for 'hand::missing_t': member 'v' of 'hand::missing_t': a variable dimension without a "
            "length member");
}

TEST_F(LcmCodecFixture, MakeCodecRefusesMemberSizedArraysOfEmptyStructs) {
  ASSERT_TRUE(parse("struct nothing_t { }\nstruct many_t { int32_t n; nothing_t v[n]; }"));
  auto made = make_lcm_codec(get("many_t"));
  ASSERT_FALSE(made.ok());
  EXPECT_EQ(made.error().message,
            "no lcm codec for 'many_t': member 'v' of 'many_t': a member-sized array of 'nothing_t', which has no "
            "members");
}

TEST_F(LcmCodecFixture, ArraysOfArraysSizedByZeroAreBoundedByTheSample) {
  // rows elements of zero bytes each on the wire: the flat sample's room bounds `rows`.
  ASSERT_TRUE(parse("struct g_t { int32_t rows; int32_t cols; byte g[rows][cols]; }"));
  auto grid = make_lcm_codec(get("g_t"));
  ASSERT_TRUE(grid.ok()) << grid.error().message;
  // fingerprint, rows = 2^31 - 1, cols = 0: 16 bytes in all.
  std::vector<std::byte> wire(16);
  for (int i = 0; i < 8; ++i) wire[i] = static_cast<std::byte>(get("g_t").lcm_fingerprint >> (56 - 8 * i));
  wire[8] = std::byte{0x7F};
  wire[9] = wire[10] = wire[11] = std::byte{0xFF};
  EXPECT_EQ(decode_error(*grid.value(), wire, 1 << 20), CodecError::output_too_small);
  wire[8] = wire[9] = wire[10] = std::byte{0};
  wire[11] = std::byte{3};  // rows = 3, cols = 0
  EXPECT_EQ(decode_json(*grid.value(), wire), R"({"rows":3,"cols":0,"g":[[],[],[]]})");
}

}  // namespace
