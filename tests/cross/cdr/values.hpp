// The values of cdr_cross.idl as plain C++: what the cross test fills into Cyclone's C
// structs, Fast DDS's classes and polyport's flat samples alike, and what it reads back
// from each of them. Also the named samples the tests run with.
#pragma once

#include <array>
#include <cstdint>
#include <limits>
#include <string>
#include <utility>
#include <vector>

namespace cdr_values {

enum class Mode : std::int32_t { idle = 0, run = 1, fault = 2 };

struct Primitives {
  bool flag = false;
  char letter = 0;
  std::uint8_t raw = 0;
  std::int8_t small = 0;
  std::uint8_t usmall = 0;
  std::int16_t i16 = 0;
  std::uint16_t u16 = 0;
  std::int32_t i32 = 0;
  std::uint32_t u32 = 0;
  std::int64_t i64 = 0;
  std::uint64_t u64 = 0;
  float f32 = 0;
  double f64 = 0;
};

struct Inner {
  std::int16_t id = 0;
  double value = 0;
};

using Vec3 = std::array<double, 3>;

struct Composite {
  Primitives prims;
  Mode state = Mode::idle;
  std::array<Mode, 2> states{};
  Inner center;
  std::array<Inner, 2> inners{};
  std::array<Vec3, 2> matrix{};
  Vec3 position{};
  std::array<Vec3, 2> corners{};
  std::array<std::array<Inner, 2>, 2> pairs{};
  std::vector<double> bounded_doubles;  // at most 4
  std::vector<std::int32_t> longs;
  std::vector<std::int32_t> aliased_longs;
  std::string text;
  std::string short_text;  // at most 8
  std::string tag;         // at most 8
  std::vector<Inner> inner_seq;
  std::vector<Inner> inner_bseq;  // at most 3
  std::vector<std::string> texts;
  std::vector<std::string> short_texts;  // at most 2, each at most 4
  std::vector<bool> flags;
  std::vector<Mode> state_seq;
  std::vector<std::vector<std::int16_t>> nested;
  std::vector<Vec3> path;
  std::uint8_t last = 0;
};

struct Labels {
  std::uint8_t before = 0;
  std::array<std::string, 2> names;
  std::array<std::string, 3> codes;  // each at most 4
  std::uint8_t after = 0;
};

struct Header {
  std::uint32_t seq = 0;
  std::string frame;
};

struct Stamped {
  Header head;
  Inner pose;
  std::vector<Header> history;
  std::array<double, 2> values{};
  std::uint8_t tail = 0;
};

struct Envelope {
  std::uint8_t kind = 0;
  Stamped body;
  std::vector<Stamped> more;  // at most 2
};

template <class T>
using Samples = std::vector<std::pair<std::string, T>>;

inline Samples<Primitives> primitives_samples() {
  Primitives zeros;
  Primitives extremes;
  extremes.flag = true;
  extremes.letter = '~';
  extremes.raw = 0xFF;
  extremes.small = std::numeric_limits<std::int8_t>::min();
  extremes.usmall = 0xFF;
  extremes.i16 = std::numeric_limits<std::int16_t>::min();
  extremes.u16 = 0xFFFF;
  extremes.i32 = std::numeric_limits<std::int32_t>::min();
  extremes.u32 = 0xFFFFFFFFu;
  extremes.i64 = std::numeric_limits<std::int64_t>::min();
  extremes.u64 = 0xFFFFFFFFFFFFFFFFull;
  extremes.f32 = std::numeric_limits<float>::max();
  extremes.f64 = std::numeric_limits<double>::lowest();
  Primitives specials;  // values whose bits matter: compared bit for bit
  specials.letter = 'A';
  specials.raw = 0x5A;
  specials.small = 127;
  specials.i16 = 0x1234;
  specials.u16 = 0xFEDC;
  specials.i32 = -123456789;
  specials.u32 = 0xA1B2C3D4u;
  specials.i64 = 0x0102030405060708ll;
  specials.u64 = 0x8877665544332211ull;
  specials.f32 = -0.0f;
  specials.f64 = std::numeric_limits<double>::quiet_NaN();
  Primitives infinities = specials;
  infinities.f32 = std::numeric_limits<float>::infinity();
  infinities.f64 = -std::numeric_limits<double>::denorm_min();
  return {
      {"zeros", zeros}, {"extremes", extremes}, {"specials", specials}, {"infinities", infinities}};
}

inline Composite typical_composite() {
  Composite c;
  c.prims = primitives_samples()[2].second;
  c.prims.f64 = 2.5;
  c.state = Mode::run;
  c.states = {Mode::fault, Mode::idle};
  c.center = {7, -1.25};
  c.inners = {Inner{1, 0.5}, Inner{-2, 1e300}};
  c.matrix = {Vec3{1, 2, 3}, Vec3{4, 5, 6}};
  c.position = {0.1, 0.2, 0.3};
  c.corners = {Vec3{-1, -2, -3}, Vec3{10, 20, 30}};
  c.pairs = {std::array<Inner, 2>{Inner{11, 1.1}, Inner{12, 1.2}},
             std::array<Inner, 2>{Inner{21, 2.1}, Inner{22, 2.2}}};
  c.bounded_doubles = {3.5, -4.5};
  c.longs = {1, -2, 3};
  c.aliased_longs = {0x7FFFFFFF};
  c.text = "hello, world";
  c.short_text = "short";
  c.tag = "tag";
  c.inner_seq = {Inner{100, 100.5}, Inner{-100, -100.5}};
  c.inner_bseq = {Inner{3, 3.0}};
  c.texts = {"a", "", "bcd", "efgh"};
  c.short_texts = {"ab", "wxyz"};
  c.flags = {true, false, true};
  c.state_seq = {Mode::idle, Mode::fault};
  c.nested = {{1, 2}, {}, {-3}};
  c.path = {Vec3{1, 1, 1}, Vec3{2, 2, 2}};
  c.last = 0xEE;
  return c;
}

inline Samples<Composite> composite_samples() {
  Composite empty;  // every sequence and string empty: no element alignment at all
  empty.last = 1;
  Composite full = typical_composite();  // every bound reached
  full.bounded_doubles = {1, 2, 3, 4};
  full.short_text = "12345678";
  full.tag = "abcdefgh";
  full.inner_bseq = {Inner{1, 1}, Inner{2, 2}, Inner{3, 3}};
  full.short_texts = {"abcd", "efgh"};
  full.text = std::string(300, 'x');
  full.longs.assign(100, -7);
  Composite odd = typical_composite();  // odd lengths everywhere: padding after each
  odd.text = "odd";
  odd.texts = {"a", "bc", "def"};
  odd.flags = {true};
  odd.nested = {{5}};
  odd.path = {};
  odd.longs = {};
  odd.inner_seq = {Inner{1, 2}};
  return {{"typical", typical_composite()}, {"empty", empty}, {"full", full}, {"odd", odd}};
}

inline Samples<Labels> labels_samples() {
  Labels empty;
  Labels some;
  some.before = 0xB0;
  some.names = {"first", "x"};
  some.codes = {"abcd", "", "xyz"};
  some.after = 0xA0;
  return {{"empty", empty}, {"some", some}};
}

inline Stamped typical_stamped() {
  Stamped s;
  s.head = {42, "base_link"};
  s.pose = {5, 0.125};
  s.history = {Header{1, "a"}, Header{2, ""}, Header{3, "odom"}};
  s.values = {-1.5, 1e-10};
  s.tail = 0x7F;
  return s;
}

inline Samples<Stamped> stamped_samples() {
  Stamped empty;
  Stamped odd = typical_stamped();
  odd.head.frame = "ab";
  odd.history = {Header{9, "xyz"}};
  return {{"typical", typical_stamped()}, {"empty", empty}, {"odd", odd}};
}

inline Samples<Envelope> envelope_samples() {
  Envelope none;
  none.kind = 3;
  none.body = typical_stamped();
  Envelope two = none;
  two.more = {stamped_samples()[2].second, Stamped{}};
  return {{"none", none}, {"two", two}};
}

}  // namespace cdr_values
