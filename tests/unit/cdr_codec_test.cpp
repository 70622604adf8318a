// The CDR codec against byte vectors worked out by hand from the XCDR rules (the layouts
// are the ones Cyclone DDS 0.10.2 writes; tests/cross/cdr checks that against the vendors
// themselves), in both versions and both byte orders, every error it reports, and round
// trips of random samples.
#include <gtest/gtest.h>

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <random>
#include <string>
#include <string_view>
#include <vector>

#include "polyport/codecs/codec.hpp"
#include "polyport/base/diagnostics.hpp"
#include "polyport/types/types.hpp"

namespace {

using namespace polyport;

using Bytes = std::vector<std::uint8_t>;

// "00 01 | 0a ff" -> bytes; spaces and bars only separate.
Bytes hex(std::string_view text) {
  Bytes out;
  int high = -1;
  for (char c : text) {
    int digit = -1;
    if (c >= '0' && c <= '9') digit = c - '0';
    if (c >= 'a' && c <= 'f') digit = c - 'a' + 10;
    if (c >= 'A' && c <= 'F') digit = c - 'A' + 10;
    if (digit < 0) continue;
    if (high < 0) {
      high = digit;
    } else {
      out.push_back(static_cast<std::uint8_t>(high << 4 | digit));
      high = -1;
    }
  }
  EXPECT_EQ(high, -1) << "odd number of hex digits in " << text;
  return out;
}

std::string to_hex(const Bytes& bytes) {
  static constexpr char kDigits[] = "0123456789abcdef";
  std::string out;
  for (std::size_t i = 0; i < bytes.size(); ++i) {
    if (i > 0) out += (i % 4 == 0) ? " | " : " ";
    out += kDigits[bytes[i] >> 4];
    out += kDigits[bytes[i] & 15];
  }
  return out;
}

// A flat sample under construction: the fixed part, then a tail handed out in order.
class Flat {
 public:
  explicit Flat(const Type& type, std::uint32_t capacity = 0)
      : bytes_(std::max(type.size, capacity)), used_(type.size) {}

  template <class T>
  void put(std::uint32_t offset, T value) {
    ASSERT_LE(offset + sizeof(T), bytes_.size());
    std::memcpy(bytes_.data() + offset, &value, sizeof value);
  }
  template <class T>
  T get(std::uint32_t offset) const {
    T value{};
    if (offset + sizeof(T) <= bytes_.size())
      std::memcpy(&value, bytes_.data() + offset, sizeof value);
    return value;
  }
  // Room for `size` bytes in the tail, aligned; returns its offset.
  std::uint32_t alloc(std::uint32_t size, std::uint32_t align) {
    used_ = (used_ + align - 1) / align * align;
    const std::uint32_t at = used_;
    used_ += size;
    if (used_ > bytes_.size()) bytes_.resize(used_);
    return at;
  }
  // An unbounded string: its characters and NUL in the tail, the span at `offset`.
  void put_string(std::uint32_t offset, std::string_view text) {
    const std::uint32_t at = alloc(static_cast<std::uint32_t>(text.size() + 1), 1);
    std::memcpy(bytes_.data() + at, text.data(), text.size());
    bytes_[at + text.size()] = std::byte{0};
    put(offset, FlatSpan{at, static_cast<std::uint32_t>(text.size())});
  }
  void put_chars(std::uint32_t offset, std::string_view text) {
    std::memcpy(bytes_.data() + offset, text.data(), text.size());
  }
  // An unbounded sequence of primitives: the elements in the tail, the span at `offset`.
  template <class T>
  void put_sequence(std::uint32_t offset, const std::vector<T>& values) {
    const std::uint32_t at =
        alloc(static_cast<std::uint32_t>(values.size() * sizeof(T)), alignof(T));
    if (!values.empty()) std::memcpy(bytes_.data() + at, values.data(), values.size() * sizeof(T));
    put(offset, FlatSpan{at, static_cast<std::uint32_t>(values.size())});
  }
  std::string string_at(std::uint32_t offset) const {
    const auto span = get<FlatSpan>(offset);
    if (span.offset + span.count > bytes_.size()) return "<outside>";
    return std::string(reinterpret_cast<const char*>(bytes_.data() + span.offset), span.count);
  }

  // After a decode: the sample's size is what decode reported.
  void set_size(std::uint32_t size) { used_ = size; }

  std::byte* data() { return bytes_.data(); }
  const std::byte* data() const { return bytes_.data(); }
  std::uint32_t size() const { return used_; }
  std::uint32_t capacity() const { return static_cast<std::uint32_t>(bytes_.size()); }

 private:
  std::vector<std::byte> bytes_;
  std::uint32_t used_;
};

class CdrCodecTest : public ::testing::Test {
 protected:
  const Type& parse(std::string_view idl, std::string_view name) {
    Diagnostics diagnostics;
    const bool ok =
        registry_.add_idl_text(idl, "test" + std::to_string(++files_) + ".idl", diagnostics);
    EXPECT_TRUE(ok);
    for (const Diagnostic& item : diagnostics.all()) ADD_FAILURE() << item.to_string();
    const Type* type = registry_.find(name);
    if (type == nullptr) {
      ADD_FAILURE() << "no type " << name;
      return *registry_.primitive(TypeKind::octet);
    }
    return *type;
  }

  std::uint32_t offset_of(const Type& type, std::string_view path) {
    const Type* current = &type;
    std::uint32_t offset = 0;
    while (!path.empty()) {
      const std::size_t dot = path.find('.');
      const std::string_view name = path.substr(0, dot);
      const Field* field = current->find_field(name);
      if (field == nullptr) {
        ADD_FAILURE() << "no field " << name << " in " << current->name;
        return 0;
      }
      offset += field->offset;
      current = field->type;
      path = dot == std::string_view::npos ? std::string_view() : path.substr(dot + 1);
    }
    return offset;
  }

  const Codec& codec(const Type& type, WireFormat format) {
    auto made = make_cdr_codec(type, format);
    if (!made.ok()) {
      ADD_FAILURE() << made.error().message;
      made = make_cdr_codec(*registry_.primitive(TypeKind::octet), format);
    }
    codecs_.push_back(std::move(made).value());
    return *codecs_.back();
  }

  static Bytes encode(const Codec& codec, const Flat& flat, CodecError expected = CodecError::ok) {
    Bytes wire(codec.max_wire_size(flat.size()) + 16);
    const CodecResult result =
        codec.encode(flat.data(), flat.size(), reinterpret_cast<std::byte*>(wire.data()),
                     static_cast<std::uint32_t>(wire.size()));
    EXPECT_EQ(to_string(result.error), to_string(expected));
    EXPECT_LE(result.size, codec.max_wire_size(flat.size()));
    wire.resize(result.size);
    return wire;
  }

  // Decodes into a fresh sample (fixed part plus `tail` bytes of room, garbage-filled so
  // that anything decode leaves unwritten shows).
  static CodecResult decode(const Codec& codec, const Bytes& wire, Flat& out) {
    std::memset(out.data(), 0xA5, out.capacity());
    const CodecResult result =
        codec.decode(reinterpret_cast<const std::byte*>(wire.data()),
                     static_cast<std::uint32_t>(wire.size()), out.data(), out.capacity());
    if (result.ok()) out.set_size(result.size);
    return result;
  }

  static CodecError decode_error(const Codec& codec, const Bytes& wire, std::uint32_t tail = 256) {
    Flat out(codec.type(), codec.type().size + tail);
    return decode(codec, wire, out).error;
  }

  std::string json(const Type& type, const Flat& flat, std::uint32_t size) {
    return sample_to_json(type, flat.data(), size);
  }

  TypeRegistry registry_;
  int files_ = 0;
  std::vector<std::unique_ptr<Codec>> codecs_;
};

#define EXPECT_BYTES(actual, expected_hex) EXPECT_EQ(to_hex(actual), to_hex(hex(expected_hex)))
#define EXPECT_CODEC_ERROR(actual, expected) EXPECT_EQ(to_string(actual), to_string(expected))

// ---- primitives ---------------------------------------------------------------------------

constexpr std::string_view kPrimitivesIdl = R"(
  struct P {
    boolean b; char c; octet o; int8 i8; uint8 u8; short s; unsigned short us;
    long l; unsigned long ul; long long ll; unsigned long long ull; float f; double d;
  };
)";

class CdrCodecPrimitives : public CdrCodecTest {
 protected:
  void SetUp() override { type_ = &parse(kPrimitivesIdl, "P"); }

  Flat sample() {
    Flat flat(*type_);
    flat.put<std::uint8_t>(offset_of(*type_, "b"), 1);
    flat.put<char>(offset_of(*type_, "c"), 'A');
    flat.put<std::uint8_t>(offset_of(*type_, "o"), 0xFE);
    flat.put<std::int8_t>(offset_of(*type_, "i8"), -2);
    flat.put<std::uint8_t>(offset_of(*type_, "u8"), 0x80);
    flat.put<std::int16_t>(offset_of(*type_, "s"), -2);
    flat.put<std::uint16_t>(offset_of(*type_, "us"), 0x1234);
    flat.put<std::int32_t>(offset_of(*type_, "l"), -3);
    flat.put<std::uint32_t>(offset_of(*type_, "ul"), 0xA1B2C3D4u);
    flat.put<std::int64_t>(offset_of(*type_, "ll"), -4);
    flat.put<std::uint64_t>(offset_of(*type_, "ull"), 0x0102030405060708ull);
    flat.put<float>(offset_of(*type_, "f"), 1.5f);
    flat.put<double>(offset_of(*type_, "d"), -2.0);
    return flat;
  }

  const Type* type_ = nullptr;
};

// XCDR1: every primitive at a multiple of its size, 8-byte ones at 8.
constexpr std::string_view kPrimitivesXcdr1Le =
    "00 01 00 00 | 01 41 fe fe 80 00 fe ff | 34 12 00 00 fd ff ff ff | d4 c3 b2 a1 00 00 00 00"
    "| fc ff ff ff ff ff ff ff | 08 07 06 05 04 03 02 01 | 00 00 c0 3f 00 00 00 00"
    "| 00 00 00 00 00 00 00 c0";
constexpr std::string_view kPrimitivesXcdr1Be =
    "00 00 00 00 | 01 41 fe fe 80 00 ff fe | 12 34 00 00 ff ff ff fd | a1 b2 c3 d4 00 00 00 00"
    "| ff ff ff ff ff ff ff fc | 01 02 03 04 05 06 07 08 | 3f c0 00 00 00 00 00 00"
    "| c0 00 00 00 00 00 00 00";
// XCDR2: 8-byte primitives only at multiples of 4.
constexpr std::string_view kPrimitivesXcdr2Le =
    "00 07 00 00 | 01 41 fe fe 80 00 fe ff | 34 12 00 00 fd ff ff ff | d4 c3 b2 a1"
    "| fc ff ff ff ff ff ff ff | 08 07 06 05 04 03 02 01 | 00 00 c0 3f | 00 00 00 00 00 00 00 c0";
constexpr std::string_view kPrimitivesXcdr2Be =
    "00 06 00 00 | 01 41 fe fe 80 00 ff fe | 12 34 00 00 ff ff ff fd | a1 b2 c3 d4"
    "| ff ff ff ff ff ff ff fc | 01 02 03 04 05 06 07 08 | 3f c0 00 00 | c0 00 00 00 00 00 00 00";

TEST_F(CdrCodecPrimitives, EncodesXcdr1) {
  EXPECT_BYTES(encode(codec(*type_, WireFormat::xcdr1), sample()), kPrimitivesXcdr1Le);
}

TEST_F(CdrCodecPrimitives, EncodesXcdr2) {
  EXPECT_BYTES(encode(codec(*type_, WireFormat::xcdr2), sample()), kPrimitivesXcdr2Le);
}

TEST_F(CdrCodecPrimitives, DecodesBothByteOrders) {
  const Flat expected = sample();
  struct Case {
    WireFormat format;
    std::string_view bytes;
  };
  for (const Case& item :
       {Case{WireFormat::xcdr1, kPrimitivesXcdr1Le}, Case{WireFormat::xcdr1, kPrimitivesXcdr1Be},
        Case{WireFormat::xcdr2, kPrimitivesXcdr2Le}, Case{WireFormat::xcdr2, kPrimitivesXcdr2Be}}) {
    Flat out(*type_);
    const CodecResult result = decode(codec(*type_, item.format), hex(item.bytes), out);
    EXPECT_CODEC_ERROR(result.error, CodecError::ok);
    EXPECT_EQ(result.size, type_->size);
    EXPECT_EQ(json(*type_, out, result.size), json(*type_, expected, expected.size()))
        << item.bytes;
    // The padding between fields is zeroed, so equal samples are equal bytes.
    EXPECT_EQ(std::memcmp(out.data(), expected.data(), type_->size), 0) << item.bytes;
  }
}

TEST_F(CdrCodecPrimitives, EightDoublesAreCopiedAsTheyAre) {
  const Type& type = parse("struct D8 { double a, b, c, d, e, f, g, h; };", "D8");
  ASSERT_EQ(type.size, 64u);
  Flat flat(type);
  for (std::uint32_t i = 0; i < 8; ++i) flat.put<double>(8 * i, 0.5 * i);
  for (WireFormat format : {WireFormat::xcdr1, WireFormat::xcdr2}) {
    const Codec& cdr = codec(type, format);
    const Bytes wire = encode(cdr, flat);
    ASSERT_EQ(wire.size(), 68u);
    EXPECT_EQ(std::memcmp(wire.data() + 4, flat.data(), 64), 0);
    Flat out(type);
    EXPECT_CODEC_ERROR(decode(cdr, wire, out).error, CodecError::ok);
    EXPECT_EQ(std::memcmp(out.data(), flat.data(), 64), 0);
  }
}

TEST_F(CdrCodecPrimitives, BooleansOtherThanZeroOrOneAreBadValues) {
  Bytes wire = hex(kPrimitivesXcdr1Le);
  wire[4] = 2;
  EXPECT_CODEC_ERROR(decode_error(codec(*type_, WireFormat::xcdr1), wire), CodecError::bad_value);
  Flat flat = sample();
  flat.put<std::uint8_t>(offset_of(*type_, "b"), 0xFF);
  encode(codec(*type_, WireFormat::xcdr2), flat, CodecError::bad_value);
}

TEST_F(CdrCodecPrimitives, TruncatedAtEveryLength) {
  const Codec& cdr = codec(*type_, WireFormat::xcdr1);
  const Bytes wire = hex(kPrimitivesXcdr1Le);
  for (std::size_t size = 0; size < wire.size(); ++size) {
    EXPECT_CODEC_ERROR(
        decode_error(cdr, Bytes(wire.begin(), wire.begin() + static_cast<long>(size))),
        CodecError::truncated)
        << size << " bytes";
  }
}

TEST_F(CdrCodecPrimitives, OutputTooSmallAtEveryCapacity) {
  const Codec& cdr = codec(*type_, WireFormat::xcdr2);
  const Flat flat = sample();
  Bytes wire(64);
  for (std::uint32_t capacity = 0; capacity < 52; ++capacity) {
    const CodecResult result =
        cdr.encode(flat.data(), flat.size(), reinterpret_cast<std::byte*>(wire.data()), capacity);
    EXPECT_CODEC_ERROR(result.error, CodecError::output_too_small) << capacity;
    EXPECT_EQ(result.size, 0u);
  }
  std::vector<std::byte> small(type_->size - 1);
  const Bytes good = hex(kPrimitivesXcdr2Le);
  EXPECT_CODEC_ERROR(cdr.decode(reinterpret_cast<const std::byte*>(good.data()),
                                static_cast<std::uint32_t>(good.size()), small.data(),
                                static_cast<std::uint32_t>(small.size()))
                         .error,
                     CodecError::output_too_small);
}

TEST_F(CdrCodecPrimitives, FlatSampleSmallerThanTheTypeIsABadValue) {
  const Flat flat = sample();
  Bytes wire(128);
  const CodecResult result =
      codec(*type_, WireFormat::xcdr1)
          .encode(flat.data(), type_->size - 1, reinterpret_cast<std::byte*>(wire.data()), 128);
  EXPECT_CODEC_ERROR(result.error, CodecError::bad_value);
}

// ---- the encapsulation header and trailing padding -----------------------------------------

class CdrCodecHeader : public CdrCodecTest {
 protected:
  void SetUp() override {
    final_ = &parse("struct One { octet x; }; @appendable struct App { octet x; };", "One");
    appendable_ = registry_.find("App");
    ASSERT_NE(appendable_, nullptr);
  }
  const Type* final_ = nullptr;
  const Type* appendable_ = nullptr;
};

// The body is padded to a multiple of 4 and the options say by how much (as Cyclone does).
TEST_F(CdrCodecHeader, IdentifiersAndPadding) {
  Flat one(*final_);
  one.put<std::uint8_t>(0, 0x11);
  EXPECT_BYTES(encode(codec(*final_, WireFormat::xcdr1), one), "00 01 00 03 | 11 00 00 00");
  EXPECT_BYTES(encode(codec(*final_, WireFormat::xcdr2), one), "00 07 00 03 | 11 00 00 00");
  Flat app(*appendable_);
  app.put<std::uint8_t>(0, 0x22);
  // XCDR1 writes appendable types like final ones; XCDR2 delimits them (D_CDR2).
  EXPECT_BYTES(encode(codec(*appendable_, WireFormat::xcdr1), app), "00 01 00 03 | 22 00 00 00");
  EXPECT_BYTES(encode(codec(*appendable_, WireFormat::xcdr2), app),
               "00 09 00 03 | 01 00 00 00 | 22 00 00 00");
}

TEST_F(CdrCodecHeader, EachCodecAcceptsOnlyItsOwnIdentifiers) {
  const Codec& x1 = codec(*final_, WireFormat::xcdr1);
  const Codec& x2 = codec(*final_, WireFormat::xcdr2);
  const Codec& x2_app = codec(*appendable_, WireFormat::xcdr2);
  EXPECT_CODEC_ERROR(decode_error(x1, hex("00 00 00 03 11 00 00 00")), CodecError::ok);
  EXPECT_CODEC_ERROR(decode_error(x1, hex("00 01 00 03 11 00 00 00")), CodecError::ok);
  EXPECT_CODEC_ERROR(decode_error(x2, hex("00 06 00 03 11 00 00 00")), CodecError::ok);
  EXPECT_CODEC_ERROR(decode_error(x2_app, hex("00 08 00 00 00 00 00 01 11 00 00 00")),
                     CodecError::ok);
  for (std::string_view wrong :
       {"00 07 00 03 11 00 00 00", "00 02 00 03 11 00 00 00", "01 01 00 03 11 00 00 00",
        "00 09 00 03 11 00 00 00", "00 0b 00 03 11 00 00 00"}) {
    EXPECT_CODEC_ERROR(decode_error(x1, hex(wrong)), CodecError::bad_header) << wrong;
  }
  EXPECT_CODEC_ERROR(decode_error(x2, hex("00 01 00 03 11 00 00 00")), CodecError::bad_header);
  EXPECT_CODEC_ERROR(decode_error(x2, hex("00 09 00 00 01 00 00 00 11 00 00 00")),
                     CodecError::bad_header);
  EXPECT_CODEC_ERROR(decode_error(x2_app, hex("00 07 00 03 11 00 00 00")), CodecError::bad_header);
}

TEST_F(CdrCodecHeader, PaddingFromTheOptionsIsDropped) {
  const Codec& x1 = codec(*final_, WireFormat::xcdr1);
  // Fast DDS 2.9 neither pads nor says so.
  EXPECT_CODEC_ERROR(decode_error(x1, hex("00 01 00 00 11")), CodecError::ok);
  // Announced padding cannot be read as the sample.
  EXPECT_CODEC_ERROR(decode_error(x1, hex("00 01 00 01 11")), CodecError::truncated);
  // More padding announced than the body holds.
  EXPECT_CODEC_ERROR(decode_error(x1, hex("00 01 00 03 11 00")), CodecError::bad_header);
  // Only the low two bits count.
  EXPECT_CODEC_ERROR(decode_error(x1, hex("00 01 ff fc 11")), CodecError::ok);
  EXPECT_CODEC_ERROR(decode_error(x1, hex("00 01")), CodecError::truncated);
  EXPECT_CODEC_ERROR(decode_error(x1, hex("00 01 00 00")), CodecError::truncated);
}

TEST_F(CdrCodecHeader, UpToThreeUnannouncedTrailingBytes) {
  const Codec& x1 = codec(*final_, WireFormat::xcdr1);
  const Codec& x2 = codec(*final_, WireFormat::xcdr2);
  EXPECT_CODEC_ERROR(decode_error(x1, hex("00 01 00 00 11 00 00 00")), CodecError::ok);
  EXPECT_CODEC_ERROR(decode_error(x1, hex("00 01 00 00 11 00 00 00 00")),
                     CodecError::trailing_bytes);
  EXPECT_CODEC_ERROR(decode_error(x2, hex("00 07 00 03 11 00 00 00 00 00 00 00")),
                     CodecError::trailing_bytes);
  // An appendable type in XCDR1: what follows is a newer version's members.
  const Codec& app = codec(*appendable_, WireFormat::xcdr1);
  Flat out(*appendable_);
  EXPECT_CODEC_ERROR(decode(app, hex("00 01 00 00 33 00 00 00 01 02 03 04 05"), out).error,
                     CodecError::ok);
  EXPECT_EQ(out.get<std::uint8_t>(0), 0x33);
  // In XCDR2 the DHEADER says where it ends; bytes after it still count.
  const Codec& app2 = codec(*appendable_, WireFormat::xcdr2);
  EXPECT_CODEC_ERROR(decode_error(app2, hex("00 09 00 00 05 00 00 00 33 01 02 03 04")),
                     CodecError::ok);
  EXPECT_CODEC_ERROR(decode_error(app2, hex("00 09 00 00 01 00 00 00 33 01 02 03 04")),
                     CodecError::trailing_bytes);
}

// ---- samples taken in place (InPlaceLayout) -------------------------------------------------

class CdrCodecInPlace : public CdrCodecTest {};

// Where in_place_flat() hands out the bytes after the header, decode() accepts the sample and
// gives exactly those bytes; wherever decode() refuses it or must convert, it hands out none.
TEST_F(CdrCodecInPlace, OnlyWhereDecodeWouldCopyTheSampleAsItIs) {
  const Type& type = parse("struct Ref { double direction_deg; double speed_mps; };", "Ref");
  for (WireFormat format : {WireFormat::xcdr1, WireFormat::xcdr2}) {
    const Codec& cdr = codec(type, format);
    const InPlaceLayout layout = cdr.in_place();
    ASSERT_EQ(layout.flat_size, type.size);
    Flat flat(type);
    flat.put<double>(0, 12.5);
    flat.put<double>(8, -0.75);
    const Bytes good = encode(cdr, flat);
    ASSERT_EQ(good.size(), 4u + type.size);
    const std::uint8_t little = good[1];  // 01 (XCDR1) or 07 (XCDR2)
    Bytes big = good;
    big[1] = static_cast<std::uint8_t>(little - 1);
    for (std::size_t i = 0; i < 8; ++i) {
      big[4 + i] = good[4 + 7 - i];
      big[12 + i] = good[12 + 7 - i];
    }
    struct Case {
      const char* what;
      Bytes wire;
      bool in_place;
      CodecError decoded;
    };
    std::vector<Case> cases;
    cases.push_back({"as encoded", good, true, CodecError::ok});
    Bytes trailing = good;
    trailing.insert(trailing.end(), {0, 0, 0});
    cases.push_back({"3 unannounced trailing bytes", trailing, true, CodecError::ok});
    Bytes announced = trailing;
    announced[3] = 3;
    cases.push_back({"3 announced padding bytes", announced, true, CodecError::ok});
    trailing.push_back(0);
    cases.push_back({"4 trailing bytes", trailing, false, CodecError::trailing_bytes});
    cases.push_back({"big-endian", big, false, CodecError::ok});
    cases.push_back({"truncated", Bytes(good.begin(), good.end() - 1), false, CodecError::truncated});
    cases.push_back({"header only", Bytes(good.begin(), good.begin() + 4), false, CodecError::truncated});
    cases.push_back({"half a header", Bytes(good.begin(), good.begin() + 2), false, CodecError::truncated});
    Bytes eaten = good;
    eaten[3] = 1;
    cases.push_back({"padding eats the sample", eaten, false, CodecError::truncated});
    Bytes other = good;
    other[1] = format == WireFormat::xcdr1 ? 0x07 : 0x01;
    cases.push_back({"the other version's identifier", other, false, CodecError::bad_header});
    for (const Case& item : cases) {
      const auto* wire = reinterpret_cast<const std::byte*>(item.wire.data());
      const auto size = static_cast<std::uint32_t>(item.wire.size());
      const std::byte* in_place = in_place_flat(layout, wire, size);
      Flat out(type);
      const CodecResult result = decode(cdr, item.wire, out);
      EXPECT_CODEC_ERROR(result.error, item.decoded) << to_string(format) << ": " << item.what;
      EXPECT_EQ(in_place != nullptr, item.in_place) << to_string(format) << ": " << item.what;
      if (in_place == nullptr) continue;
      EXPECT_EQ(in_place, wire + 4);
      EXPECT_EQ(result.size, layout.flat_size);
      EXPECT_EQ(std::memcmp(in_place, out.data(), layout.flat_size), 0) << item.what;
      EXPECT_EQ(std::memcmp(in_place, flat.data(), layout.flat_size), 0) << item.what;
    }
  }
}

TEST_F(CdrCodecInPlace, OnlyStructsWhoseWireFormIsTheFlatSample) {
  struct Case {
    const char* idl;
    const char* name;
    bool xcdr1;
    bool xcdr2;
  };
  for (const Case& item : {
           Case{"struct A { double a; double b; };", "A", true, true},
           Case{"struct B { long a; unsigned long b; float c; };", "B", true, true},
           Case{"struct C { octet x; };", "C", true, true},
           Case{"struct D { long a; double b; };", "D", false, false},  // padding in flat
           Case{"struct E { float a[4]; };", "E", true, true},
           Case{"struct F { boolean b; };", "F", false, false},  // checked on decode
           Case{"enum Color { red, green }; struct G { Color c; };", "G", false, false},
           Case{"struct H { string s; };", "H", false, false},
           Case{"struct I { sequence<double, 4> v; };", "I", false, false},
           Case{"@appendable struct J { double a; };", "J", false, false},
           Case{"struct K { double a; }; struct L { K k; double b; };", "L", true, true},
       }) {
    const Type& type = parse(item.idl, item.name);
    EXPECT_EQ(codec(type, WireFormat::xcdr1).in_place().flat_size != 0, item.xcdr1) << item.idl;
    EXPECT_EQ(codec(type, WireFormat::xcdr2).in_place().flat_size != 0, item.xcdr2) << item.idl;
    if (codec(type, WireFormat::xcdr1).in_place().flat_size != 0) {
      EXPECT_EQ(codec(type, WireFormat::xcdr1).in_place().flat_size, type.size) << item.idl;
    }
  }
}

TEST_F(CdrCodecHeader, FormatsOtherThanCdrAreRefused) {
  for (WireFormat format : {WireFormat::flat, WireFormat::lcm, WireFormat::dbc}) {
    const auto made = make_cdr_codec(*final_, format);
    ASSERT_FALSE(made.ok());
    EXPECT_NE(made.error().message.find(std::string(to_string(format))), std::string::npos)
        << made.error().message;
  }
  const auto made = make_cdr_codec(*final_, WireFormat::xcdr2);
  ASSERT_TRUE(made.ok());
  EXPECT_EQ(made.value()->format(), WireFormat::xcdr2);
  EXPECT_EQ(&made.value()->type(), final_);
}

// ---- strings ------------------------------------------------------------------------------

class CdrCodecStrings : public CdrCodecTest {
 protected:
  void SetUp() override { type_ = &parse("struct S { string s; string<4> b; octet x; };", "S"); }
  Flat sample(std::string_view s, std::string_view b) {
    Flat flat(*type_, 64);
    flat.put_string(offset_of(*type_, "s"), s);
    flat.put_chars(offset_of(*type_, "b"), b);
    flat.put<std::uint8_t>(offset_of(*type_, "x"), 7);
    return flat;
  }
  const Type* type_ = nullptr;
};

constexpr std::string_view kStringsLe =
    "00 01 00 03 | 03 00 00 00 | 68 69 00 00 | 04 00 00 00 | 61 62 63 00 | 07 00 00 00";
constexpr std::string_view kStringsBe =
    "00 00 00 03 | 00 00 00 03 | 68 69 00 00 | 00 00 00 04 | 61 62 63 00 | 07 00 00 00";

TEST_F(CdrCodecStrings, LengthWithTheNulThenTheCharacters) {
  EXPECT_BYTES(encode(codec(*type_, WireFormat::xcdr1), sample("hi", "abc")), kStringsLe);
  Bytes x2 = hex(kStringsLe);
  x2[1] = 0x07;
  EXPECT_EQ(to_hex(encode(codec(*type_, WireFormat::xcdr2), sample("hi", "abc"))), to_hex(x2));
  EXPECT_BYTES(encode(codec(*type_, WireFormat::xcdr1), sample("", "")),
               "00 01 00 02 | 01 00 00 00 | 00 00 00 00 | 01 00 00 00 | 00 07 00 00");
  // A bounded string may fill its bound.
  EXPECT_BYTES(encode(codec(*type_, WireFormat::xcdr1), sample("", "abcd")),
               "00 01 00 02 | 01 00 00 00 | 00 00 00 00 | 05 00 00 00 | 61 62 63 64 | 00 07 00 00");
}

TEST_F(CdrCodecStrings, DecodesBothByteOrdersIntoTheTail) {
  for (std::string_view bytes : {kStringsLe, kStringsBe}) {
    Flat out(*type_, type_->size + 16);
    const CodecResult result = decode(codec(*type_, WireFormat::xcdr1), hex(bytes), out);
    EXPECT_CODEC_ERROR(result.error, CodecError::ok);
    EXPECT_EQ(result.size, type_->size + 3);  // "hi" and its NUL
    EXPECT_EQ(out.string_at(offset_of(*type_, "s")), "hi");
    EXPECT_EQ(out.get<FlatSpan>(offset_of(*type_, "s")).offset, type_->size);
    EXPECT_EQ(static_cast<char>(out.get<std::uint8_t>(type_->size + 2)), '\0');
    // The bounded string with its NUL, and zeros after it.
    EXPECT_EQ(std::string(reinterpret_cast<const char*>(out.data() + offset_of(*type_, "b")), 5),
              std::string("abc\0\0", 5));
    EXPECT_EQ(out.get<std::uint8_t>(offset_of(*type_, "x")), 7);
  }
}

TEST_F(CdrCodecStrings, MalformedStringsOnTheWire) {
  const Codec& cdr = codec(*type_, WireFormat::xcdr1);
  // Length 0 (not even the NUL).
  EXPECT_CODEC_ERROR(decode_error(cdr, hex("00 01 00 00 | 00 00 00 00 | 01 00 00 00 | 00 07")),
                     CodecError::bad_value);
  // No NUL at the end.
  EXPECT_CODEC_ERROR(
      decode_error(cdr, hex("00 01 00 00 | 02 00 00 00 | 68 69 00 00 | 01 00 00 00 | 00 07")),
      CodecError::bad_value);
  // A NUL inside.
  EXPECT_CODEC_ERROR(
      decode_error(cdr, hex("00 01 00 00 | 03 00 00 00 | 00 69 00 00 | 01 00 00 00 | 00 07")),
      CodecError::bad_value);
  EXPECT_CODEC_ERROR(
      decode_error(cdr,
                   hex("00 01 00 00 | 01 00 00 00 | 00 00 00 00 | 04 00 00 00 | 61 00 63 00 | 07")),
      CodecError::bad_value);
  // Longer than string<4>.
  EXPECT_CODEC_ERROR(
      decode_error(
          cdr,
          hex("00 01 00 00 | 01 00 00 00 | 00 00 00 00 | 06 00 00 00 | 61 62 63 64 65 00 | 07")),
      CodecError::bound_exceeded);
  // A length running past the end.
  EXPECT_CODEC_ERROR(decode_error(cdr, hex("00 01 00 00 | ff ff ff 7f | 68 69 00 00")),
                     CodecError::truncated);
  // The tail cannot hold the characters.
  EXPECT_CODEC_ERROR(decode_error(cdr, hex(kStringsLe), 2), CodecError::output_too_small);
  EXPECT_CODEC_ERROR(decode_error(cdr, hex(kStringsLe), 3), CodecError::ok);
}

TEST_F(CdrCodecStrings, MalformedStringsInTheSample) {
  const Codec& cdr = codec(*type_, WireFormat::xcdr2);
  Flat unterminated = sample("hi", "");
  unterminated.put_chars(offset_of(*type_, "b"), "abcde");  // fills char[5] without a NUL
  encode(cdr, unterminated, CodecError::bad_value);
  Flat outside = sample("hi", "abc");
  outside.put(offset_of(*type_, "s"), FlatSpan{outside.size() - 1, 2});
  encode(cdr, outside, CodecError::bad_value);
  Flat embedded = sample(std::string_view("h\0i", 3), "abc");
  encode(cdr, embedded, CodecError::bad_value);
}

// ---- sequences ----------------------------------------------------------------------------

class CdrCodecSequences : public CdrCodecTest {
 protected:
  void SetUp() override {
    type_ = &parse("struct Q { sequence<double> d; sequence<short, 3> s; octet x; };", "Q");
  }
  Flat sample(const std::vector<double>& d, const std::vector<std::int16_t>& s) {
    Flat flat(*type_, 128);
    flat.put_sequence(offset_of(*type_, "d"), d);
    const std::uint32_t at = offset_of(*type_, "s");
    flat.put<std::uint32_t>(at, static_cast<std::uint32_t>(s.size()));
    for (std::size_t i = 0; i < s.size(); ++i)
      flat.put<std::int16_t>(at + 4 + 2 * static_cast<std::uint32_t>(i), s[i]);
    flat.put<std::uint8_t>(offset_of(*type_, "x"), 9);
    return flat;
  }
  const Type* type_ = nullptr;
};

// XCDR1 aligns the doubles to 8, XCDR2 to 4.
constexpr std::string_view kSequencesXcdr1 =
    "00 01 00 03 | 01 00 00 00 | 00 00 00 00 | 00 00 00 00 00 00 f0 3f | 02 00 00 00 | 01 00 ff ff "
    "| 09 00 00 00";
constexpr std::string_view kSequencesXcdr1Be =
    "00 00 00 03 | 00 00 00 01 | 00 00 00 00 | 3f f0 00 00 00 00 00 00 | 00 00 00 02 | 00 01 ff ff "
    "| 09 00 00 00";
constexpr std::string_view kSequencesXcdr2 =
    "00 07 00 03 | 01 00 00 00 | 00 00 00 00 00 00 f0 3f | 02 00 00 00 | 01 00 ff ff | 09 00 00 00";
constexpr std::string_view kSequencesXcdr2Be =
    "00 06 00 03 | 00 00 00 01 | 3f f0 00 00 00 00 00 00 | 00 00 00 02 | 00 01 ff ff | 09 00 00 00";

TEST_F(CdrCodecSequences, CountThenAlignedElements) {
  EXPECT_BYTES(encode(codec(*type_, WireFormat::xcdr1), sample({1.0}, {1, -1})), kSequencesXcdr1);
  EXPECT_BYTES(encode(codec(*type_, WireFormat::xcdr2), sample({1.0}, {1, -1})), kSequencesXcdr2);
}

// An empty sequence is not aligned for its elements (as Cyclone and Fast DDS do it).
TEST_F(CdrCodecSequences, EmptySequencesAreNotAligned) {
  EXPECT_BYTES(encode(codec(*type_, WireFormat::xcdr1), sample({}, {})),
               "00 01 00 03 | 00 00 00 00 | 00 00 00 00 | 09 00 00 00");
  EXPECT_BYTES(encode(codec(*type_, WireFormat::xcdr2), sample({}, {})),
               "00 07 00 03 | 00 00 00 00 | 00 00 00 00 | 09 00 00 00");
}

TEST_F(CdrCodecSequences, DecodesBothByteOrders) {
  struct Case {
    WireFormat format;
    std::string_view bytes;
  };
  for (const Case& item :
       {Case{WireFormat::xcdr1, kSequencesXcdr1}, Case{WireFormat::xcdr1, kSequencesXcdr1Be},
        Case{WireFormat::xcdr2, kSequencesXcdr2}, Case{WireFormat::xcdr2, kSequencesXcdr2Be}}) {
    Flat out(*type_, type_->size + 16);
    const CodecResult result = decode(codec(*type_, item.format), hex(item.bytes), out);
    EXPECT_CODEC_ERROR(result.error, CodecError::ok);
    EXPECT_EQ(result.size, type_->size + 8);
    const auto span = out.get<FlatSpan>(offset_of(*type_, "d"));
    EXPECT_EQ(span.count, 1u);
    EXPECT_EQ(span.offset % alignof(double), 0u);
    EXPECT_EQ(out.get<double>(span.offset), 1.0);
    const std::uint32_t s = offset_of(*type_, "s");
    EXPECT_EQ(out.get<std::uint32_t>(s), 2u);
    EXPECT_EQ(out.get<std::int16_t>(s + 4), 1);
    EXPECT_EQ(out.get<std::int16_t>(s + 6), -1);
    EXPECT_EQ(out.get<std::int16_t>(s + 8), 0);  // the unused slot is zero
    EXPECT_EQ(out.get<std::uint8_t>(offset_of(*type_, "x")), 9);
  }
}

TEST_F(CdrCodecSequences, BoundsOnBothSides) {
  const Codec& cdr = codec(*type_, WireFormat::xcdr1);
  EXPECT_CODEC_ERROR(
      decode_error(cdr,
                   hex("00 01 00 00 | 00 00 00 00 | 04 00 00 00 | 01 00 02 00 03 00 04 00 | 09")),
      CodecError::bound_exceeded);
  Flat too_long = sample({}, {1, 2, 3});
  too_long.put<std::uint32_t>(offset_of(*type_, "s"), 4);
  encode(cdr, too_long, CodecError::bound_exceeded);
  Flat outside = sample({1.0, 2.0}, {});
  outside.put(offset_of(*type_, "d"), FlatSpan{outside.size() - 8, 2});
  encode(cdr, outside, CodecError::bad_value);
}

TEST_F(CdrCodecSequences, CountsLargerThanTheInput) {
  const Codec& cdr = codec(*type_, WireFormat::xcdr1);
  EXPECT_CODEC_ERROR(decode_error(cdr, hex("00 01 00 00 | ff ff ff ff | 00 00 00 00")),
                     CodecError::truncated);
  EXPECT_CODEC_ERROR(
      decode_error(cdr, hex("00 01 00 00 | 02 00 00 00 | 00 00 00 00 | 00 00 00 00 00 00 f0 3f")),
      CodecError::truncated);
  // The elements fit the input but not the sample's tail.
  EXPECT_CODEC_ERROR(decode_error(cdr, hex(kSequencesXcdr1), 7), CodecError::output_too_small);
  EXPECT_CODEC_ERROR(decode_error(cdr, hex(kSequencesXcdr1), 8), CodecError::ok);
}

TEST_F(CdrCodecSequences, BooleansHaveNoDheader) {
  const Type& type = parse("struct B { boolean a; sequence<boolean> f; };", "B");
  Flat flat(type, 64);
  flat.put<std::uint8_t>(offset_of(type, "a"), 1);
  flat.put_sequence<std::uint8_t>(offset_of(type, "f"), {1, 0, 1});
  EXPECT_BYTES(encode(codec(type, WireFormat::xcdr1), flat),
               "00 01 00 01 | 01 00 00 00 | 03 00 00 00 | 01 00 01 00");
  EXPECT_BYTES(encode(codec(type, WireFormat::xcdr2), flat),
               "00 07 00 01 | 01 00 00 00 | 03 00 00 00 | 01 00 01 00");
  EXPECT_CODEC_ERROR(decode_error(codec(type, WireFormat::xcdr2),
                                  hex("00 07 00 01 | 01 00 00 00 | 03 00 00 00 | 01 02 01 00")),
                     CodecError::bad_value);
  flat.put_sequence<std::uint8_t>(offset_of(type, "f"), {1, 7});
  encode(codec(type, WireFormat::xcdr1), flat, CodecError::bad_value);
}

// Sequences of non-primitive elements get a DHEADER in XCDR2.
TEST_F(CdrCodecSequences, StringsAndNestedSequences) {
  const Type& type = parse("struct T { sequence<string> t; sequence<sequence<short> > n; };", "T");
  Flat flat(type, 128);
  const std::uint32_t strings = flat.alloc(2 * sizeof(FlatSpan), 4);
  flat.put(offset_of(type, "t"), FlatSpan{strings, 2});
  flat.put_string(strings, "a");
  flat.put_string(strings + 8, "bc");
  const std::uint32_t rows = flat.alloc(3 * sizeof(FlatSpan), 4);
  flat.put(offset_of(type, "n"), FlatSpan{rows, 3});
  flat.put_sequence<std::int16_t>(rows, {1, 2});
  flat.put_sequence<std::int16_t>(rows + 8, {});
  flat.put_sequence<std::int16_t>(rows + 16, {3});
  const Bytes x1 = encode(codec(type, WireFormat::xcdr1), flat);
  EXPECT_BYTES(
      x1,
      "00 01 00 02 | 02 00 00 00 | 02 00 00 00 | 61 00 00 00 | 03 00 00 00 | 62 63 00 00"
      "| 03 00 00 00 | 02 00 00 00 | 01 00 02 00 | 00 00 00 00 | 01 00 00 00 | 03 00 00 00");
  const Bytes x2 = encode(codec(type, WireFormat::xcdr2), flat);
  EXPECT_BYTES(x2,
               "00 07 00 02 | 13 00 00 00 | 02 00 00 00 | 02 00 00 00 | 61 00 00 00 | 03 00 00 00 "
               "| 62 63 00 00"
               "| 16 00 00 00 | 03 00 00 00 | 02 00 00 00 | 01 00 02 00 | 00 00 00 00 | 01 00 00 "
               "00 | 03 00 00 00");
  for (const Bytes* wire : {&x1, &x2}) {
    const Codec& cdr = codec(type, wire == &x1 ? WireFormat::xcdr1 : WireFormat::xcdr2);
    Flat out(type, 128);
    const CodecResult result = decode(cdr, *wire, out);
    ASSERT_EQ(to_string(result.error), "ok");
    EXPECT_EQ(json(type, out, result.size), R"({"t":["a","bc"],"n":[[1,2],[],[3]]})");
  }
}

// ---- arrays -------------------------------------------------------------------------------

class CdrCodecArrays : public CdrCodecTest {};

TEST_F(CdrCodecArrays, MultiDimensionalAndTypedefArraysAreOneArray) {
  const Type& type = parse(R"(
    typedef short Row[2];
    struct M { octet a; short m[2][2]; Row r[2]; };
  )",
                           "M");
  Flat flat(type);
  for (std::uint32_t i = 0; i < 4; ++i) {
    flat.put<std::int16_t>(offset_of(type, "m") + 2 * i, static_cast<std::int16_t>(i + 1));
    flat.put<std::int16_t>(offset_of(type, "r") + 2 * i, static_cast<std::int16_t>(i + 5));
  }
  flat.put<std::uint8_t>(0, 0xAA);
  const std::string_view expected =
      "00 07 00 02 | aa 00 01 00 | 02 00 03 00 | 04 00 05 00 | 06 00 07 00 | 08 00 00 00";
  EXPECT_BYTES(encode(codec(type, WireFormat::xcdr2), flat), expected);
  Flat out(type);
  EXPECT_CODEC_ERROR(
      decode(
          codec(type, WireFormat::xcdr2),
          hex("00 06 00 02 | aa 00 00 01 | 00 02 00 03 | 00 04 00 05 | 00 06 00 07 | 00 08 00 00"),
          out)
          .error,
      CodecError::ok);
  EXPECT_EQ(std::memcmp(out.data(), flat.data(), type.size), 0);
}

TEST_F(CdrCodecArrays, StructElementsGetOneDheaderInXcdr2) {
  const Type& type = parse("struct Inner { short id; double v; }; struct A { Inner p[2]; };", "A");
  Flat flat(type);
  flat.put<std::int16_t>(0, 1);
  flat.put<double>(8, 2.0);
  flat.put<std::int16_t>(16, -1);
  flat.put<double>(24, -2.0);
  const std::string_view x1 =
      "00 01 00 00 | 01 00 00 00 00 00 00 00 | 00 00 00 00 00 00 00 40 | ff ff 00 00 00 00 00 00 | "
      "00 00 00 00 00 00 00 c0";
  const std::string_view x2 =
      "00 07 00 00 | 18 00 00 00 | 01 00 00 00 | 00 00 00 00 00 00 00 40 | ff ff 00 00 | 00 00 00 "
      "00 00 00 00 c0";
  EXPECT_BYTES(encode(codec(type, WireFormat::xcdr1), flat), x1);
  EXPECT_BYTES(encode(codec(type, WireFormat::xcdr2), flat), x2);
  for (WireFormat format : {WireFormat::xcdr1, WireFormat::xcdr2}) {
    Flat out(type);
    EXPECT_CODEC_ERROR(
        decode(codec(type, format), hex(format == WireFormat::xcdr1 ? x1 : x2), out).error,
        CodecError::ok);
    EXPECT_EQ(json(type, out, type.size), R"({"p":[{"id":1,"v":2},{"id":-1,"v":-2}]})");
  }
  // A DHEADER the elements overrun.
  EXPECT_CODEC_ERROR(decode_error(codec(type, WireFormat::xcdr2),
                                  hex("00 07 00 00 | 10 00 00 00 | 01 00 00 00 | 00 00 00 00 00 00 "
                                      "00 40 | ff ff 00 00 | 00 00 00 00 00 00 00 c0")),
                     CodecError::bad_value);
  // A DHEADER beyond the input.
  EXPECT_CODEC_ERROR(
      decode_error(codec(type, WireFormat::xcdr2), hex("00 07 00 00 | 40 00 00 00 | 01 00 00 00")),
      CodecError::truncated);
}

TEST_F(CdrCodecArrays, StringElements) {
  const Type& type = parse("struct N { string<3> names[2]; string all[2]; };", "N");
  Flat flat(type, 64);
  flat.put_chars(offset_of(type, "names"), "ab");
  flat.put_chars(offset_of(type, "names") + 4, "c");
  flat.put_string(offset_of(type, "all"), "");
  flat.put_string(offset_of(type, "all") + 8, "xyz");
  EXPECT_BYTES(encode(codec(type, WireFormat::xcdr1), flat),
               "00 01 00 00 | 03 00 00 00 | 61 62 00 00 | 02 00 00 00 | 63 00 00 00 | 01 00 00 00 "
               "| 00 00 00 00 | 04 00 00 00 | 78 79 7a 00");
  EXPECT_BYTES(encode(codec(type, WireFormat::xcdr2), flat),
               "00 07 00 00 | 0e 00 00 00 | 03 00 00 00 | 61 62 00 00 | 02 00 00 00 | 63 00 00 00"
               "| 10 00 00 00 | 01 00 00 00 | 00 00 00 00 | 04 00 00 00 | 78 79 7a 00");
}

// ---- enumerations -------------------------------------------------------------------------

class CdrCodecEnums : public CdrCodecTest {
 protected:
  void SetUp() override {
    type_ = &parse(R"(
      enum Color { RED, GREEN, BLUE };
      enum Sparse { LOW, @value(10) HIGH };
      struct E { Color c; Sparse s; Color cs[2]; sequence<Color> q; };
    )",
                   "E");
  }
  Flat sample() {
    Flat flat(*type_, 64);
    flat.put<std::int32_t>(offset_of(*type_, "c"), 2);
    flat.put<std::int32_t>(offset_of(*type_, "s"), 10);
    flat.put<std::int32_t>(offset_of(*type_, "cs"), 1);
    flat.put<std::int32_t>(offset_of(*type_, "cs") + 4, 0);
    flat.put_sequence<std::int32_t>(offset_of(*type_, "q"), {2});
    return flat;
  }
  const Type* type_ = nullptr;
};

constexpr std::string_view kEnumsXcdr1 =
    "00 01 00 00 | 02 00 00 00 | 0a 00 00 00 | 01 00 00 00 | 00 00 00 00 | 01 00 00 00 | 02 00 00 "
    "00";
// Like Cyclone 0.10.2: arrays and sequences of enums are not primitive, so they get a DHEADER.
constexpr std::string_view kEnumsXcdr2 =
    "00 07 00 00 | 02 00 00 00 | 0a 00 00 00 | 08 00 00 00 | 01 00 00 00 | 00 00 00 00 | 08 00 00 "
    "00 | 01 00 00 00 | 02 00 00 00";
constexpr std::string_view kEnumsXcdr2Be =
    "00 06 00 00 | 00 00 00 02 | 00 00 00 0a | 00 00 00 08 | 00 00 00 01 | 00 00 00 00 | 00 00 00 "
    "08 | 00 00 00 01 | 00 00 00 02";

TEST_F(CdrCodecEnums, Int32OnTheWire) {
  EXPECT_BYTES(encode(codec(*type_, WireFormat::xcdr1), sample()), kEnumsXcdr1);
  EXPECT_BYTES(encode(codec(*type_, WireFormat::xcdr2), sample()), kEnumsXcdr2);
  for (std::string_view bytes : {kEnumsXcdr2, kEnumsXcdr2Be}) {
    Flat out(*type_, 64);
    const CodecResult result = decode(codec(*type_, WireFormat::xcdr2), hex(bytes), out);
    EXPECT_CODEC_ERROR(result.error, CodecError::ok);
    EXPECT_EQ(json(*type_, out, result.size),
              R"({"c":"BLUE","s":"HIGH","cs":["GREEN","RED"],"q":["BLUE"]})");
  }
}

TEST_F(CdrCodecEnums, ValuesThatAreNotEnumeratorsAreBadValues) {
  const Codec& x1 = codec(*type_, WireFormat::xcdr1);
  for (std::size_t at : {4u, 8u, 12u, 16u, 24u}) {
    for (std::uint8_t value : {3, 5, 0xFF}) {
      Bytes wire = hex(kEnumsXcdr1);
      wire[at] = value;
      EXPECT_CODEC_ERROR(decode_error(x1, wire), CodecError::bad_value) << at << " " << int{value};
    }
  }
  Flat bad = sample();
  bad.put<std::int32_t>(offset_of(*type_, "s"), 1);  // between LOW and HIGH
  encode(x1, bad, CodecError::bad_value);
  bad = sample();
  bad.put_sequence<std::int32_t>(offset_of(*type_, "q"), {0, -1});
  encode(codec(*type_, WireFormat::xcdr2), bad, CodecError::bad_value);
  bad = sample();
  bad.put<std::int32_t>(offset_of(*type_, "cs") + 4, 3);
  encode(x1, bad, CodecError::bad_value);
}

// ---- appendable structs -------------------------------------------------------------------

class CdrCodecAppendable : public CdrCodecTest {
 protected:
  void SetUp() override {
    outer_ = &parse(R"(
      @appendable struct H { unsigned long seq; string frame; };
      @final struct M { octet k; H h; };
    )",
                    "M");
    header_ = registry_.find("H");
    ASSERT_NE(header_, nullptr);
  }
  const Type* outer_ = nullptr;
  const Type* header_ = nullptr;
};

TEST_F(CdrCodecAppendable, DheaderInXcdr2Only) {
  Flat flat(*outer_, 64);
  flat.put<std::uint8_t>(offset_of(*outer_, "k"), 1);
  flat.put<std::uint32_t>(offset_of(*outer_, "h.seq"), 42);
  flat.put_string(offset_of(*outer_, "h.frame"), "ab");
  EXPECT_BYTES(encode(codec(*outer_, WireFormat::xcdr1), flat),
               "00 01 00 01 | 01 00 00 00 | 2a 00 00 00 | 03 00 00 00 | 61 62 00 00");
  EXPECT_BYTES(encode(codec(*outer_, WireFormat::xcdr2), flat),
               "00 07 00 01 | 01 00 00 00 | 0b 00 00 00 | 2a 00 00 00 | 03 00 00 00 | 61 62 00 00");
  Flat top(*header_, 64);
  top.put<std::uint32_t>(offset_of(*header_, "seq"), 42);
  top.put_string(offset_of(*header_, "frame"), "ab");
  EXPECT_BYTES(encode(codec(*header_, WireFormat::xcdr2), top),
               "00 09 00 01 | 0b 00 00 00 | 2a 00 00 00 | 03 00 00 00 | 61 62 00 00");
  Flat out(*header_, 64);
  const CodecResult result =
      decode(codec(*header_, WireFormat::xcdr2),
             hex("00 08 00 01 | 00 00 00 0b | 00 00 00 2a | 00 00 00 03 | 61 62 00 00"), out);
  EXPECT_CODEC_ERROR(result.error, CodecError::ok);
  EXPECT_EQ(json(*header_, out, result.size), R"({"seq":42,"frame":"ab"})");
}

// An older writer sent fewer members: the rest are zero. A newer one sent more: skipped.
TEST_F(CdrCodecAppendable, OlderAndNewerVersionsOfTheType) {
  const Codec& cdr = codec(*outer_, WireFormat::xcdr2);
  Flat out(*outer_, 64);
  CodecResult result =
      decode(cdr, hex("00 07 00 00 | 07 00 00 00 | 04 00 00 00 | 2a 00 00 00"), out);
  EXPECT_CODEC_ERROR(result.error, CodecError::ok);
  EXPECT_EQ(json(*outer_, out, result.size), R"({"k":7,"h":{"seq":42,"frame":""}})");
  EXPECT_EQ(out.get<FlatSpan>(offset_of(*outer_, "h.frame")).count, 0u);
  result = decode(cdr, hex("00 07 00 00 | 07 00 00 00 | 00 00 00 00"), out);
  EXPECT_CODEC_ERROR(result.error, CodecError::ok);
  EXPECT_EQ(json(*outer_, out, result.size), R"({"k":7,"h":{"seq":0,"frame":""}})");
  result = decode(cdr,
                  hex("00 07 00 00 | 07 00 00 00 | 10 00 00 00 | 2a 00 00 00 | 03 00 00 00 | 61 62 "
                      "00 00 | ef be ad de"),
                  out);
  EXPECT_CODEC_ERROR(result.error, CodecError::ok);
  EXPECT_EQ(json(*outer_, out, result.size), R"({"k":7,"h":{"seq":42,"frame":"ab"}})");
}

// An enumeration's default is its first enumerator, which need not be 0.
TEST_F(CdrCodecAppendable, AbsentEnumerationsTakeTheirFirstEnumerator) {
  const Type& type = parse(R"(
    enum Level { @value(3) LOW, @value(7) HIGH };
    struct Pair { Level a; long b; };
    @appendable struct V { octet x; Level level; Level levels[2]; Pair pair; sequence<Level> more; };
  )",
                           "V");
  const Codec& cdr = codec(type, WireFormat::xcdr2);
  Flat out(type, 64);
  CodecResult result = decode(cdr, hex("00 09 00 03 | 01 00 00 00 | 05 00 00 00"), out);
  ASSERT_EQ(to_string(result.error), "ok");
  EXPECT_EQ(json(type, out, result.size),
            R"({"x":5,"level":"LOW","levels":["LOW","LOW"],"pair":{"a":"LOW","b":0},"more":[]})");
  // The defaults are valid values: the sample encodes again, now with every member.
  EXPECT_BYTES(encode(cdr, out),
               "00 09 00 00 | 24 00 00 00 | 05 00 00 00 | 03 00 00 00 | 08 00 00 00 | 03 00 00 00 "
               "| 03 00 00 00"
               "| 03 00 00 00 | 00 00 00 00 | 04 00 00 00 | 00 00 00 00");
  result = decode(cdr, hex("00 09 00 00 | 08 00 00 00 | 05 00 00 00 | 07 00 00 00"), out);
  ASSERT_EQ(to_string(result.error), "ok");
  EXPECT_EQ(json(type, out, result.size),
            R"({"x":5,"level":"HIGH","levels":["LOW","LOW"],"pair":{"a":"LOW","b":0},"more":[]})");
}

TEST_F(CdrCodecAppendable, DheadersThatDoNotFit) {
  const Codec& cdr = codec(*outer_, WireFormat::xcdr2);
  // The string overruns its DHEADER.
  EXPECT_CODEC_ERROR(
      decode_error(
          cdr,
          hex("00 07 00 00 | 07 00 00 00 | 09 00 00 00 | 2a 00 00 00 | 03 00 00 00 | 61 62 00 00")),
      CodecError::bad_value);
  // A member cut by the DHEADER.
  EXPECT_CODEC_ERROR(
      decode_error(cdr, hex("00 07 00 00 | 07 00 00 00 | 02 00 00 00 | 2a 00 00 00")),
      CodecError::bad_value);
  // The DHEADER runs past the input.
  EXPECT_CODEC_ERROR(
      decode_error(cdr, hex("00 07 00 00 | 07 00 00 00 | 20 00 00 00 | 2a 00 00 00")),
      CodecError::truncated);
  EXPECT_CODEC_ERROR(decode_error(cdr, hex("00 07 00 00 | 07 00 00 00 | 20 00")),
                     CodecError::truncated);
}

TEST_F(CdrCodecAppendable, MutableStructsAreRefused) {
  const Type& type = parse(
      "@mutable struct Mu { long a; }; struct Holder { octet x; sequence<Mu> m; };", "Holder");
  for (WireFormat format : {WireFormat::xcdr1, WireFormat::xcdr2}) {
    const auto made = make_cdr_codec(type, format);
    ASSERT_FALSE(made.ok());
    EXPECT_EQ(made.error().message, "cannot carry 'Holder' in " + std::string(to_string(format)) +
                                        ": member 'Holder.m[]': mutable struct 'Mu' is not "
                                        "supported yet (it needs the PL_CDR encodings)");
  }
}

// ---- the parser's annotations -------------------------------------------------------------

class CdrCodecIdl : public CdrCodecTest {};

TEST_F(CdrCodecIdl, ExtensibilityAnnotations) {
  parse(R"(
    struct Plain { long a; };
    @final struct F { long a; };
    @appendable struct A { long a; };
    @mutable struct M { long a; };
    @extensibility(FINAL) struct XF { long a; };
    @extensibility(APPENDABLE) struct XA { long a; };
    @extensibility(MUTABLE) struct XM { long a; };
    @::appendable @topic struct Q { long a; };
    enum E { X };
    typedef long L;
  )",
        "Plain");
  const std::pair<const char*, Extensibility> expected[] = {
      {"Plain", Extensibility::final_}, {"F", Extensibility::final_},
      {"A", Extensibility::appendable}, {"M", Extensibility::mutable_},
      {"XF", Extensibility::final_},    {"XA", Extensibility::appendable},
      {"XM", Extensibility::mutable_},  {"Q", Extensibility::appendable},
  };
  for (const auto& [name, extensibility] : expected) {
    const Type* type = registry_.find(name);
    ASSERT_NE(type, nullptr) << name;
    EXPECT_EQ(static_cast<int>(type->extensibility), static_cast<int>(extensibility)) << name;
    EXPECT_EQ(type->origin, TypeOrigin::idl) << name;
  }
  EXPECT_EQ(registry_.find("E")->origin, TypeOrigin::idl);
  EXPECT_EQ(registry_.find("L")->origin, TypeOrigin::idl);
  EXPECT_EQ(registry_.find("double")->origin, TypeOrigin::builtin);
}

TEST_F(CdrCodecIdl, BadExtensibilityArgument) {
  Diagnostics diagnostics;
  EXPECT_FALSE(registry_.add_idl_text(
      "@extensibility(SOMETIMES) struct S { long a; };\n@extensibility struct T { long a; };",
      "x.idl", diagnostics));
  std::vector<std::string> messages;
  for (const Diagnostic& item : diagnostics.all()) messages.push_back(item.to_string());
  EXPECT_EQ(messages, (std::vector<std::string>{
                          "x.idl:1:16: @extensibility needs FINAL, APPENDABLE or MUTABLE",
                          "x.idl:2:2: @extensibility needs FINAL, APPENDABLE or MUTABLE"}));
}

// ---- round trips and size bounds ----------------------------------------------------------

constexpr std::string_view kEverythingIdl = R"(
  module rt {
    enum Mode { IDLE, RUN, @value(7) FAULT };
    struct Inner { short id; double value; };
    @appendable struct Tagged { unsigned long seq; string<6> tag; sequence<Mode> modes; };
    typedef double Vec3[3];
    @final struct All {
      boolean flag; char letter; octet raw; int8 i8; uint8 u8; short i16; unsigned short u16;
      long i32; unsigned long u32; long long i64; unsigned long long u64; float f32; double f64;
      Mode mode; Mode modes[2]; Inner inner; Inner inners[2]; double matrix[2][3]; Vec3 corners[2];
      sequence<double, 4> bounded; sequence<long> longs; string text; string<8> label;
      sequence<Inner> inner_seq; sequence<Inner, 2> inner_bseq; sequence<string> texts;
      sequence<string<4>, 2> short_texts; string names[2]; sequence<boolean> flags;
      sequence<sequence<short> > nested; sequence<Vec3> path; Tagged tagged; sequence<Tagged> more;
      octet last;
    };
  };
)";

// Fills a random but valid sample of `type` (recursively), tail included.
class RandomSample {
 public:
  RandomSample(std::mt19937& rng, Flat& flat) : rng_(rng), flat_(flat) {}

  void fill(const Type& declared, std::uint32_t at) {
    const Type& type = declared.resolved();
    switch (type.kind) {
      case TypeKind::boolean:
        flat_.put<std::uint8_t>(at, static_cast<std::uint8_t>(rng_() & 1));
        break;
      case TypeKind::char8: flat_.put<char>(at, static_cast<char>('a' + rng_() % 26)); break;
      case TypeKind::float32:
        flat_.put<float>(at, static_cast<float>(static_cast<int>(rng_() % 2000) - 1000) / 8);
        break;
      case TypeKind::float64:
        flat_.put<double>(at, static_cast<double>(static_cast<int>(rng_() % 2000) - 1000) / 16);
        break;
      case TypeKind::enumeration:
        flat_.put<std::int32_t>(at, type.enumerators[rng_() % type.enumerators.size()].value);
        break;
      case TypeKind::string:
        if (type.bound > 0) {
          flat_.put_chars(at, word(rng_() % (type.bound + 1)));
        } else {
          flat_.put_string(at, word(rng_() % 12));
        }
        break;
      case TypeKind::structure:
        for (const Field& field : type.fields) fill(*field.type, at + field.offset);
        break;
      case TypeKind::array:
        for (std::uint32_t i = 0; i < type.bound; ++i)
          fill(*type.element, at + i * type.element->size);
        break;
      case TypeKind::sequence: {
        const Type& element = *type.element;
        const std::uint32_t count =
            static_cast<std::uint32_t>(rng_() % ((type.bound > 0 ? type.bound : 4) + 1));
        std::uint32_t first = 0;
        if (type.bound > 0) {
          flat_.put<std::uint32_t>(at, count);
          first = at + (4 + element.align - 1) / element.align * element.align;
        } else {
          first = flat_.alloc(count * element.size, element.align);
          flat_.put(at, FlatSpan{first, count});
        }
        for (std::uint32_t i = 0; i < count; ++i) fill(element, first + i * element.size);
        break;
      }
      default:  // integers and octets: any bit pattern
        for (std::uint32_t i = 0; i < type.size; ++i)
          flat_.put<std::uint8_t>(at + i, static_cast<std::uint8_t>(rng_()));
        break;
    }
  }

 private:
  std::string word(std::size_t length) {
    std::string out;
    for (std::size_t i = 0; i < length; ++i) out += static_cast<char>('a' + rng_() % 26);
    return out;
  }
  std::mt19937& rng_;
  Flat& flat_;
};

class CdrCodecRoundTrip : public CdrCodecTest {};

TEST_F(CdrCodecRoundTrip, RandomSamplesSurviveBothFormats) {
  const Type& type = parse(kEverythingIdl, "rt::All");
  std::mt19937 rng(20240611);
  for (WireFormat format : {WireFormat::xcdr1, WireFormat::xcdr2}) {
    const Codec& cdr = codec(type, format);
    for (int round = 0; round < 200; ++round) {
      Flat flat(type, 16);
      RandomSample(rng, flat).fill(type, 0);
      const Bytes wire = encode(cdr, flat);
      ASSERT_FALSE(wire.empty());
      EXPECT_EQ(wire.size() % 4, 0u);
      Flat out(type, flat.size() + 64);
      const CodecResult result = decode(cdr, wire, out);
      ASSERT_EQ(to_string(result.error), "ok") << to_hex(wire);
      EXPECT_EQ(json(type, out, result.size), json(type, flat, flat.size()));
      // Encoding the decoded sample gives the same bytes.
      EXPECT_EQ(to_hex(encode(cdr, out)), to_hex(wire)) << round;
    }
  }
}

TEST_F(CdrCodecRoundTrip, MaxWireSizeBoundsEveryEncoding) {
  const Type& type = parse(kEverythingIdl, "rt::All");
  std::mt19937 rng(7);
  for (WireFormat format : {WireFormat::xcdr1, WireFormat::xcdr2}) {
    const Codec& cdr = codec(type, format);
    EXPECT_GE(cdr.max_wire_size(type.size), 4u + 8u);
    for (int round = 0; round < 100; ++round) {
      Flat flat(type, 16);
      RandomSample(rng, flat).fill(type, 0);
      Bytes wire(cdr.max_wire_size(flat.size()));
      const CodecResult result =
          cdr.encode(flat.data(), flat.size(), reinterpret_cast<std::byte*>(wire.data()),
                     static_cast<std::uint32_t>(wire.size()));
      ASSERT_EQ(to_string(result.error), "ok");
      // ... and exactly the encoded size is enough.
      const CodecResult exact = cdr.encode(flat.data(), flat.size(),
                                           reinterpret_cast<std::byte*>(wire.data()), result.size);
      EXPECT_EQ(to_string(exact.error), "ok");
      const CodecResult short_by_one = cdr.encode(
          flat.data(), flat.size(), reinterpret_cast<std::byte*>(wire.data()), result.size - 1);
      EXPECT_EQ(to_string(short_by_one.error), "output_too_small");
    }
  }
  // The fixed part alone: 8 doubles take at most 64 bytes, the header and padding.
  const Type& d8 = parse("struct D8 { double a, b, c, d, e, f, g, h; };", "D8");
  EXPECT_GE(codec(d8, WireFormat::xcdr1).max_wire_size(64), 68u);
  EXPECT_LE(codec(d8, WireFormat::xcdr1).max_wire_size(64), 68u + 16u);
  EXPECT_EQ(codec(d8, WireFormat::xcdr1).max_wire_size(1 << 20),
            codec(d8, WireFormat::xcdr1).max_wire_size(64));
}

TEST_F(CdrCodecRoundTrip, BitFlipsNeverCrashAndDecodesReencode) {
  const Type& type = parse(kEverythingIdl, "rt::All");
  std::mt19937 rng(99);
  for (WireFormat format : {WireFormat::xcdr1, WireFormat::xcdr2}) {
    const Codec& cdr = codec(type, format);
    int decoded = 0;
    for (int round = 0; round < 300; ++round) {
      Flat flat(type, 16);
      RandomSample(rng, flat).fill(type, 0);
      Bytes wire = encode(cdr, flat);
      wire[4 + rng() % (wire.size() - 4)] ^= static_cast<std::uint8_t>(1u << (rng() % 8));
      Flat out(type, 4096);
      const CodecResult result = decode(cdr, wire, out);
      if (!result.ok()) continue;
      ++decoded;
      Flat again(type, 4096);
      const Bytes reencoded = encode(cdr, out);
      const CodecResult second = decode(cdr, reencoded, again);
      ASSERT_EQ(to_string(second.error), "ok");
      EXPECT_EQ(json(type, again, second.size), json(type, out, result.size));
    }
    EXPECT_GT(decoded, 0);  // some flips land in values and still decode
  }
}

}  // namespace
