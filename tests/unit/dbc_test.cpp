// DBC files as a type source (dbc_parser.cpp) and the DBC frame codec (dbc_codec.cpp).
//
// The independent checks are the worked examples of the reference (can-lcm-components.md
// section 2.7) and a bit walker below that follows that section's wording one bit at a
// time; the codec's shift-and-mask windows are compared against it on random layouts.
#include "polyport/types/dbc.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <bit>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <memory>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "polyport/codecs/codec.hpp"
#include "polyport/base/diagnostics.hpp"
#include "polyport/types/types.hpp"

namespace {

using namespace polyport;

using Bytes = std::vector<std::uint8_t>;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

std::string dbc_path(const std::string& name) { return std::string(POLYPORT_TEST_DATA) + "/dbc/" + name; }

std::vector<std::string> rendered(const Diagnostics& diagnostics) {
  std::vector<std::string> out;
  for (const Diagnostic& item : diagnostics.all()) out.push_back(item.to_string());
  return out;
}

std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

// ---------------------------------------------------------------------------------------
// The reference's bit numbering, walked one bit at a time (section 2.7): Intel starts at
// the LSB and counts upward, carrying into the next byte; Motorola starts at the MSB and
// counts downward within a byte, and after bit 0 of byte B comes bit 7 of byte B + 1.

std::uint32_t walk_next(std::uint32_t position, bool motorola) {
  if (!motorola) return position + 1;
  return position % 8 == 0 ? position + 15 : position - 1;
}

void walk_insert(Bytes& frame, std::uint32_t start, std::uint32_t length, bool motorola, std::uint64_t raw) {
  std::uint32_t position = start;
  for (std::uint32_t k = 0; k < length; ++k) {
    const std::uint32_t bit = motorola ? length - 1 - k : k;  // which bit of raw sits here
    if (((raw >> bit) & 1u) != 0) frame.at(position / 8) |= static_cast<std::uint8_t>(1u << (position % 8));
    position = walk_next(position, motorola);
  }
}

std::uint64_t walk_extract(const Bytes& frame, std::uint32_t start, std::uint32_t length, bool motorola) {
  std::uint64_t raw = 0;
  std::uint32_t position = start;
  for (std::uint32_t k = 0; k < length; ++k) {
    const std::uint32_t bit = motorola ? length - 1 - k : k;
    if (((frame.at(position / 8) >> (position % 8)) & 1u) != 0) raw |= std::uint64_t{1} << bit;
    position = walk_next(position, motorola);
  }
  return raw;
}

// Every bit the walker visits, or false when it leaves a frame of `bytes` bytes.
bool walk_bits(std::uint32_t start, std::uint32_t length, bool motorola, std::uint32_t bytes,
               std::vector<std::uint32_t>& out) {
  std::uint32_t position = start;
  for (std::uint32_t k = 0; k < length; ++k) {
    if (position >= bytes * 8) return false;
    out.push_back(position);
    position = walk_next(position, motorola);
  }
  return true;
}

// ---------------------------------------------------------------------------------------

class DbcFixture : public ::testing::Test {
 protected:
  bool load(std::string_view text, const std::string& file = "test.dbc") {
    return registry_.add_dbc_text(text, file, diagnostics_);
  }
  void load_ok(std::string_view text, const std::string& file = "test.dbc") {
    EXPECT_TRUE(load(text, file)) << ::testing::PrintToString(rendered(diagnostics_));
    EXPECT_TRUE(diagnostics_.all().empty()) << ::testing::PrintToString(rendered(diagnostics_));
  }
  // vehicle.dbc uses every statement; those polyport does not model give one warning per kind.
  void load_vehicle() {
    ASSERT_TRUE(registry_.add_dbc_file(dbc_path("vehicle.dbc"), diagnostics_))
        << ::testing::PrintToString(rendered(diagnostics_));
    const std::string file = dbc_path("vehicle.dbc");
    std::vector<std::string> expected;
    for (const char* warning : {
             ":87:1: warning: BO_TX_BU_ statements (more transmitters of a message) are not used by polyport "
             "and are ignored (1 in this file)",
             ":89:1: warning: EV_ statements are not used by polyport and are ignored (1 in this file)",
             ":97:5: warning: comments on environment variables (CM_ EV_) are not used by polyport and are "
             "ignored (1 in this file)",
             ":106:1: warning: BA_DEF_REL_ statements are not used by polyport and are ignored (1 in this file)",
             ":114:1: warning: BA_DEF_DEF_REL_ statements are not used by polyport and are ignored (1 in this "
             "file)",
             ":126:1: warning: BA_REL_ statements are not used by polyport and are ignored (1 in this file)",
             ":130:6: warning: value descriptions of environment variables (VAL_) are not used by polyport and "
             "are ignored (1 in this file)",
             ":131:1: warning: SIG_GROUP_ statements are not used by polyport and are ignored (1 in this file)",
         }) {
      expected.push_back(file + warning);
    }
    ASSERT_EQ(rendered(diagnostics_), expected);
    diagnostics_ = Diagnostics();
  }
  // The problems of text that must be refused.
  std::vector<std::string> errors_for(std::string_view text) {
    EXPECT_FALSE(load(text, "bad.dbc"));
    return rendered(diagnostics_);
  }
  // The warnings of text that loads (problems confined to messages, ignored statements).
  std::vector<std::string> warnings_for(std::string_view text, const std::string& file = "odd.dbc") {
    EXPECT_TRUE(load(text, file)) << ::testing::PrintToString(rendered(diagnostics_));
    return rendered(diagnostics_);
  }
  // Why a message of the file cannot be used ("" when the registry does not say).
  std::string unusable(std::string_view name) {
    const UnusableType* found = registry_.find_unusable(name);
    if (found == nullptr) return "";
    return found->where.file + ":" + std::to_string(found->where.line) + ":" +
           std::to_string(found->where.column) + ": " + found->reason;
  }

  const Type& type(std::string_view name) {
    const Type* found = registry_.find(name);
    if (found == nullptr) {
      ADD_FAILURE() << "type " << name << " not found";
      return *registry_.primitive(TypeKind::octet);
    }
    return *found;
  }
  const DbcMessage& message(std::string_view name) {
    const DbcMessage* found = type(name).dbc;
    if (found == nullptr) {
      ADD_FAILURE() << name << " has no DBC message";
      static const DbcMessage kNone;
      return kNone;
    }
    return *found;
  }
  const DbcSignal& signal(std::string_view type_name, std::string_view signal_name) {
    const DbcSignal* found = message(type_name).find_signal(signal_name);
    if (found == nullptr) {
      ADD_FAILURE() << "no signal " << signal_name << " in " << type_name;
      static const DbcSignal kNone;
      return kNone;
    }
    return *found;
  }
  std::unique_ptr<Codec> codec(std::string_view name) {
    auto made = make_dbc_codec(type(name));
    if (!made.ok()) {
      ADD_FAILURE() << made.error().message;
      return nullptr;
    }
    return std::move(made).value();
  }

  TypeRegistry registry_;
  Diagnostics diagnostics_;
};

// A flat sample: one double per signal, by field name.
class Sample {
 public:
  explicit Sample(const Type& type) : type_(type), bytes_(type.size) {}
  void set(std::string_view field, double value) {
    const Field* found = type_.find_field(field);
    ASSERT_NE(found, nullptr) << field;
    std::memcpy(bytes_.data() + found->offset, &value, sizeof value);
  }
  double get(std::string_view field) const {
    const Field* found = type_.find_field(field);
    if (found == nullptr) {
      ADD_FAILURE() << "no field " << field;
      return kNaN;
    }
    double value;
    std::memcpy(&value, bytes_.data() + found->offset, sizeof value);
    return value;
  }
  std::byte* data() { return bytes_.data(); }
  const std::byte* data() const { return bytes_.data(); }
  std::uint32_t size() const { return static_cast<std::uint32_t>(bytes_.size()); }

 private:
  const Type& type_;
  std::vector<std::byte> bytes_;
};

CodecResult encode(const Codec& codec, const Sample& sample, Bytes& frame) {
  frame.assign(codec.max_wire_size(sample.size()), 0xEE);  // not zero: encode must clear
  return codec.encode(sample.data(), sample.size(), reinterpret_cast<std::byte*>(frame.data()),
                      static_cast<std::uint32_t>(frame.size()));
}

CodecResult decode(const Codec& codec, const Bytes& frame, Sample& sample) {
  return codec.decode(reinterpret_cast<const std::byte*>(frame.data()),
                      static_cast<std::uint32_t>(frame.size()), sample.data(), sample.size());
}

// Decodes `frame` and checks the named fields (NaN: the signal is not in the frame).
void expect_decoded(const Codec& codec, const Type& type, const Bytes& frame,
                    std::initializer_list<std::pair<const char*, double>> want) {
  Sample sample(type);
  ASSERT_TRUE(decode(codec, frame, sample).ok()) << ::testing::PrintToString(frame);
  for (const auto& [field, value] : want) {
    if (std::isnan(value)) {
      EXPECT_TRUE(std::isnan(sample.get(field))) << field << " in " << ::testing::PrintToString(frame);
    } else {
      EXPECT_DOUBLE_EQ(sample.get(field), value) << field << " in " << ::testing::PrintToString(frame);
    }
  }
}

// ---------------------------------------------------------------------------------------
// Parsing a realistic file

TEST_F(DbcFixture, DbcParserRegistersEveryMessageAsAStructOfDoubles) {
  load_vehicle();
  const Type& engine = type("vehicle::EngineData");
  EXPECT_EQ(engine.kind, TypeKind::structure);
  EXPECT_EQ(engine.origin, TypeOrigin::dbc);
  EXPECT_EQ(engine.where.line, 42u);
  EXPECT_EQ(engine.where.column, 9u);
  ASSERT_EQ(engine.fields.size(), 6u);
  const char* names[] = {"EngineSpeed", "CoolantTemp", "Torque", "Gear", "ThrottlePos", "EngineRunning"};
  for (std::size_t i = 0; i < 6; ++i) {
    EXPECT_EQ(engine.fields[i].name, names[i]);
    EXPECT_EQ(engine.fields[i].type, registry_.primitive(TypeKind::float64));
    EXPECT_EQ(engine.fields[i].offset, 8 * i);
  }
  EXPECT_EQ(engine.size, 48u);
  EXPECT_EQ(engine.dbc, &message("vehicle::EngineData"));
  EXPECT_EQ(engine.dbc->type, &engine);
  for (const char* name : {"vehicle::BrakeStatus", "vehicle::ImuData", "vehicle::GpsPosition",
                           "vehicle::DiagMux", "vehicle::BatteryFD"}) {
    EXPECT_NE(registry_.find(name), nullptr) << name;
  }
  // Vector's pseudo message for independent signals is accepted but is no frame.
  EXPECT_EQ(registry_.find("vehicle::VECTOR__INDEPENDENT_SIG_MSG"), nullptr);
}

TEST_F(DbcFixture, DbcParserReadsMessageFacts) {
  load_vehicle();
  const DbcMessage& engine = message("vehicle::EngineData");
  EXPECT_EQ(engine.frame_id, 0x100u);
  EXPECT_FALSE(engine.extended);
  EXPECT_EQ(engine.can_id(), 0x100u);
  EXPECT_EQ(engine.length, 8u);
  EXPECT_FALSE(engine.fd);
  EXPECT_FALSE(engine.bit_rate_switch);
  EXPECT_EQ(engine.transmitter, "Engine");
  EXPECT_EQ(engine.cycle_time_ms, 10u);
  EXPECT_EQ(engine.comment, "Engine state, every 10 ms.");
  EXPECT_EQ(engine.multiplexer, -1);

  const DbcMessage& imu = message("vehicle::ImuData");
  EXPECT_EQ(imu.frame_id, 0x18FF1020u);
  EXPECT_TRUE(imu.extended);
  EXPECT_EQ(imu.can_id(), 0x98FF1020u);
  EXPECT_FALSE(imu.fd);
  EXPECT_EQ(imu.cycle_time_ms, 0u);  // the default

  const DbcMessage& gps = message("vehicle::GpsPosition");
  EXPECT_EQ(gps.length, 16u);
  EXPECT_TRUE(gps.fd);

  const DbcMessage& battery = message("vehicle::BatteryFD");
  EXPECT_EQ(battery.length, 64u);
  EXPECT_TRUE(battery.fd);
  EXPECT_TRUE(battery.bit_rate_switch);
  EXPECT_EQ(battery.signals.size(), 8u);

  EXPECT_EQ(message("vehicle::BrakeStatus").cycle_time_ms, 20u);
  EXPECT_EQ(message("vehicle::DiagMux").cycle_time_ms, 100u);
  EXPECT_EQ(message("vehicle::DiagMux").transmitter, "Logger");
}

TEST_F(DbcFixture, DbcParserReadsSignalFacts) {
  load_vehicle();
  const DbcSignal& speed = signal("vehicle::EngineData", "EngineSpeed");
  EXPECT_EQ(speed.start_bit, 0u);
  EXPECT_EQ(speed.length, 16u);
  EXPECT_EQ(speed.byte_order, DbcByteOrder::intel);
  EXPECT_FALSE(speed.is_signed);
  EXPECT_EQ(speed.factor, 0.25);
  EXPECT_EQ(speed.offset, 0.0);
  EXPECT_EQ(speed.minimum, 0.0);
  EXPECT_EQ(speed.maximum, 16383.75);
  EXPECT_EQ(speed.unit, "rpm");
  EXPECT_EQ(speed.receivers, (std::vector<std::string>{"Dashboard", "Logger"}));
  EXPECT_EQ(speed.comment, "Crankshaft speed.\nSecond line, with \"quotes\".");
  EXPECT_EQ(speed.where.line, 43u);
  EXPECT_EQ(speed.where.column, 6u);

  const DbcSignal& coolant = signal("vehicle::EngineData", "CoolantTemp");
  EXPECT_EQ(coolant.offset, -40.0);
  EXPECT_EQ(coolant.unit, "degC");
  const DbcSignal& torque = signal("vehicle::EngineData", "Torque");
  EXPECT_TRUE(torque.is_signed);
  EXPECT_TRUE(signal("vehicle::EngineData", "ThrottlePos").receivers.empty());  // Vector__XXX

  const DbcSignal& gear = signal("vehicle::EngineData", "Gear");
  const std::map<std::int64_t, std::string> gears{{0, "Park"}, {1, "Reverse"}, {2, "Neutral"}, {3, "Drive"}};
  EXPECT_EQ(gear.value_table, gears);

  const DbcSignal& brake = signal("vehicle::BrakeStatus", "BrakeTemp");
  EXPECT_EQ(brake.byte_order, DbcByteOrder::motorola);
  EXPECT_TRUE(brake.is_signed);
  EXPECT_EQ(brake.msb_bit, 27u);
  EXPECT_EQ(brake.lsb_bit, 32u);  // byte 4 bit 0
  EXPECT_EQ(brake.first_byte, 3u);
  EXPECT_EQ(brake.last_byte, 4u);
  EXPECT_TRUE(brake.has_range());
  EXPECT_FALSE(signal("vehicle::BrakeStatus", "Counter").has_range());

  EXPECT_EQ(signal("vehicle::ImuData", "YawRate").float_kind, DbcFloatKind::float32);
  EXPECT_EQ(signal("vehicle::ImuData", "AccelX").float_kind, DbcFloatKind::float32);
  EXPECT_EQ(signal("vehicle::GpsPosition", "Latitude").float_kind, DbcFloatKind::float64);
  EXPECT_EQ(signal("vehicle::GpsPosition", "Longitude").float_kind, DbcFloatKind::float64);
  EXPECT_EQ(signal("vehicle::EngineData", "Torque").float_kind, DbcFloatKind::none);

  const DbcSignal& odometer = signal("vehicle::BatteryFD", "Odometer");
  EXPECT_EQ(odometer.first_byte, 40u);
  EXPECT_EQ(odometer.last_byte, 48u);
  EXPECT_EQ(odometer.lsb_bit, 388u);
  const DbcSignal& energy = signal("vehicle::BatteryFD", "Energy");
  EXPECT_EQ(energy.first_byte, 49u);
  EXPECT_EQ(energy.last_byte, 57u);
  EXPECT_EQ(energy.msb_bit, 459u);
}

TEST_F(DbcFixture, DbcParserReadsMultiplexing) {
  load_vehicle();
  const DbcMessage& mux = message("vehicle::DiagMux");
  ASSERT_EQ(mux.multiplexer, 0);
  EXPECT_EQ(mux.signals[0].mux_role, DbcMuxRole::multiplexer);
  EXPECT_EQ(mux.signals[0].comment, "Selects the page.");
  const std::map<std::int64_t, std::string> modes{{1, "Electrical"}, {2, "Thermal"}};
  EXPECT_EQ(mux.signals[0].value_table, modes);
  EXPECT_EQ(signal("vehicle::DiagMux", "Voltage").mux_role, DbcMuxRole::multiplexed);
  EXPECT_EQ(signal("vehicle::DiagMux", "Voltage").mux_value, 1);
  EXPECT_EQ(signal("vehicle::DiagMux", "ModuleTemp").mux_value, 2);
  EXPECT_EQ(signal("vehicle::DiagMux", "Sequence").mux_role, DbcMuxRole::none);
  EXPECT_EQ(type("vehicle::DiagMux").fields.size(), 6u);  // every signal is a field
}

TEST_F(DbcFixture, DbcParserReadsDatabaseFacts) {
  load_vehicle();
  const DbcDatabase* database = find_dbc_database(registry_, "vehicle");
  ASSERT_NE(database, nullptr);
  EXPECT_EQ(database->version, "1.2");
  EXPECT_EQ(database->comment, "Test bus of a small vehicle.");
  ASSERT_EQ(database->nodes.size(), 4u);
  EXPECT_EQ(database->nodes[0].name, "Engine");
  EXPECT_EQ(database->nodes[0].comment, "Engine control unit");
  EXPECT_EQ(database->nodes[3].name, "Logger");
  ASSERT_EQ(database->value_tables.count("GearTable"), 1u);
  EXPECT_EQ(database->value_tables.at("GearTable").at(3), "Drive");
  EXPECT_EQ(database->value_tables.at("OnOff").size(), 2u);
  EXPECT_EQ(database->messages.size(), 6u);
  EXPECT_EQ(dbc_databases(registry_), std::vector<const DbcDatabase*>{database});
  EXPECT_EQ(message("vehicle::EngineData").database, database);
}

TEST_F(DbcFixture, DbcLookupFindsMessagesByCanIdAndName) {
  load_vehicle();
  const DbcDatabase* database = find_dbc_database(registry_, "vehicle");
  ASSERT_NE(database, nullptr);
  EXPECT_EQ(database->find_message(0x100u), &message("vehicle::EngineData"));
  EXPECT_EQ(database->find_message(0x18FF1020u | kCanExtendedFlag), &message("vehicle::ImuData"));
  // The same number as a standard id is another frame.
  EXPECT_EQ(database->find_message(0x020u), nullptr);
  EXPECT_EQ(database->find_message(0x100u | kCanExtendedFlag), nullptr);
  // RTR (0x40000000) and error (0x20000000) flags are not part of the id.
  EXPECT_EQ(database->find_message(0x1A0u | 0x40000000u), &message("vehicle::BrakeStatus"));
  EXPECT_EQ(database->find_message(0x18FEF31Cu | kCanExtendedFlag | 0x40000000u),
            &message("vehicle::GpsPosition"));
  EXPECT_EQ(database->find_message("DiagMux"), &message("vehicle::DiagMux"));
  EXPECT_EQ(database->find_message("Nothing"), nullptr);
  EXPECT_EQ(find_dbc_database(registry_, "other"), nullptr);
}

TEST_F(DbcFixture, DbcParserLoadsAFileOnceAndThroughAddTypeFile) {
  ASSERT_TRUE(registry_.add_type_file(dbc_path("vehicle.dbc"), diagnostics_));
  const std::size_t warnings = diagnostics_.all().size();  // the ignored statements (load_vehicle)
  EXPECT_TRUE(registry_.add_dbc_file(dbc_path("vehicle.dbc"), diagnostics_));  // skipped, no redefinition
  EXPECT_FALSE(diagnostics_.has_errors()) << ::testing::PrintToString(rendered(diagnostics_));
  EXPECT_EQ(diagnostics_.all().size(), warnings);
  EXPECT_EQ(dbc_databases(registry_).size(), 1u);
  EXPECT_NE(registry_.find("::vehicle::BatteryFD"), nullptr);
}

TEST_F(DbcFixture, DbcParserReportsAMissingFile) {
  const std::string path = dbc_path("no_such_file.dbc");
  EXPECT_FALSE(registry_.add_dbc_file(path, diagnostics_));
  EXPECT_EQ(rendered(diagnostics_), std::vector<std::string>{path + ": cannot open file"});
}

TEST_F(DbcFixture, DbcParserNamesTypesAfterTheSanitisedFileStem) {
  const std::string text = "BO_ 1 M: 1 N\n SG_ S : 0|8@1+ (1,0) [0|0] \"\" N\n";
  load_ok(text, "/some/dir/my-car 2.dbc");
  load_ok(text, "2024.dbc");
  EXPECT_NE(registry_.find("my_car_2::M"), nullptr);
  EXPECT_NE(registry_.find("_2024::M"), nullptr);
  // The same stem twice is a redefinition of its messages.
  EXPECT_FALSE(load(text, "other/2024.dbc"));
  EXPECT_EQ(rendered(diagnostics_),
            std::vector<std::string>{"other/2024.dbc:1:7: redefinition of '_2024::M'"});
}

TEST_F(DbcFixture, DbcParserAcceptsStatementsInAnyOrderAndWithoutNewlinesBetweenThem) {
  load_ok(
      "CM_ SG_ 5 A \"before the message\"; VAL_ 5 A 1 \"one\" ;\n"
      "BO_ 5 M: 2 N\n"
      " SG_ A : 0|8@1+ (1,0) [0|0] \"\" N\n"
      " SG_ B : 15|8@0- (2,1) [0|0] \"\"\n"  // no receivers at all
      "BA_DEF_ BO_ \"GenMsgCycleTime\" INT 0 1000; BA_ \"GenMsgCycleTime\" BO_ 5 50;\n");
  EXPECT_EQ(signal("test::M", "A").comment, "before the message");
  EXPECT_EQ(signal("test::M", "A").value_table.at(1), "one");
  EXPECT_EQ(signal("test::M", "B").factor, 2.0);
  EXPECT_EQ(message("test::M").cycle_time_ms, 50u);
}

TEST_F(DbcFixture, DbcParserReadsACanFdDlcCodeAsALengthWithAWarning) {
  EXPECT_TRUE(load("BO_ 1 M: 15 N\n SG_ S : 500|8@1+ (1,0) [0|0] \"\" N\n", "fd.dbc"));
  EXPECT_EQ(rendered(diagnostics_),
            std::vector<std::string>{"fd.dbc:1:10: warning: length 15 read as a CAN FD DLC code: 64 bytes"});
  EXPECT_EQ(message("fd::M").length, 64u);
}

// ---------------------------------------------------------------------------------------
// Invalid files: every problem with its exact location, and the rest still read

TEST_F(DbcFixture, DbcErrorSyntax) {
  EXPECT_EQ(errors_for("BO_ 100 Foo 8 Node\n"
                       " SG_ A : 0|8@1+ (1,0) [0|0] \"\" Node\n"
                       "BO_ 101 Bar: 8 Node\n"
                       " SG_ B : 0|8@1+ (1 0) [0|0] \"\" Node\n"
                       " SG_ C : 8|8@1+ (1,0) [0|0] Node\n"),
            (std::vector<std::string>{
                "bad.dbc:1:13: expected ':' after the message name, found '8'",
                "bad.dbc:4:20: expected ',' after the factor, found '0'",
                "bad.dbc:5:29: expected the unit (a quoted string), found 'Node'",
            }));
  // Neither message is registered: one has a bad line, the other a bad signal.
  EXPECT_EQ(registry_.find("bad::Foo"), nullptr);
  EXPECT_EQ(registry_.find("bad::Bar"), nullptr);
}

TEST_F(DbcFixture, DbcMessageWithASignalOutsideTheFrameIsUnusableAndTheFileLoads) {
  EXPECT_EQ(warnings_for("BO_ 1 Short: 2 Node\n"
                         " SG_ Big : 8|16@1+ (1,0) [0|0] \"\" Node\n"
                         "BO_ 2 Moto: 2 Node\n"
                         " SG_ Moto : 7|17@0+ (1,0) [0|0] \"\" Node\n"
                         "BO_ 3 Far: 8 Node\n"
                         " SG_ Far : 600|8@1+ (1,0) [0|0] \"\" Node\n"
                         "BO_ 4 Long: 8 Node\n"
                         " SG_ Long : 0|65@1+ (1,0) [0|0] \"\" Node\n"
                         "BO_ 5 Empty: 8 Node\n"
                         " SG_ Empty : 0|0@1+ (1,0) [0|0] \"\" Node\n"
                         " SG_ Big : 8|16@1+ (1,0) [0|0] \"\" Node\n"
                         "BO_ 6 Ok: 2 Node\n"
                         " SG_ Moto : 7|16@0+ (1,0) [0|0] \"\" Node\n"),
            (std::vector<std::string>{
                "odd.dbc:2:6: warning: message 'Short' cannot be used: signal 'Big' does not fit in the 2-byte "
                "message 'Short'",
                "odd.dbc:4:6: warning: message 'Moto' cannot be used: signal 'Moto' does not fit in the 2-byte "
                "message 'Moto'",
                "odd.dbc:6:12: warning: message 'Far' cannot be used: start bit 600 is outside a 64-byte frame",
                "odd.dbc:8:15: warning: message 'Long' cannot be used: signal length must be 1 to 64 bits, found 65",
                "odd.dbc:10:16: warning: message 'Empty' cannot be used: signal length must be 1 to 64 bits, found 0",
            }));
  EXPECT_EQ(registry_.find("odd::Short"), nullptr);
  EXPECT_EQ(unusable("odd::Short"), "odd.dbc:2:6: signal 'Big' does not fit in the 2-byte message 'Short'");
  EXPECT_EQ(unusable("::odd::Far"), "odd.dbc:6:12: start bit 600 is outside a 64-byte frame");
  EXPECT_NE(registry_.find("odd::Ok"), nullptr);
  EXPECT_EQ(unusable("odd::Ok"), "");
  EXPECT_EQ(unusable("odd::Nothing"), "");
}

TEST_F(DbcFixture, DbcMessageWithOverlappingSignalsIsUnusableAndTheFileLoads) {
  EXPECT_EQ(warnings_for("BO_ 1 M1: 8 Node\n"
                         " SG_ A : 0|8@1+ (1,0) [0|0] \"\" Node\n"
                         " SG_ B : 7|8@0+ (1,0) [0|0] \"\" Node\n"            // byte 0 again
                         "BO_ 2 M2: 8 Node\n"
                         " SG_ C : 12|8@1+ (1,0) [0|0] \"\" Node\n"           // byte 1 high nibble
                         " SG_ D : 15|4@0+ (1,0) [0|0] \"\" Node\n"           // also there
                         "BO_ 3 X1: 8 Node\n"
                         " SG_ Sel M : 0|8@1+ (1,0) [0|0] \"\" Node\n"
                         " SG_ P m1 : 8|8@1+ (1,0) [0|0] \"\" Node\n"
                         " SG_ Q m2 : 8|16@1+ (1,0) [0|0] \"\" Node\n"        // other page: fine
                         " SG_ R m1 : 15|2@1+ (1,0) [0|0] \"\" Node\n"        // same page as P
                         "BO_ 4 X2: 8 Node\n"
                         " SG_ Sel M : 0|8@1+ (1,0) [0|0] \"\" Node\n"
                         " SG_ Q m2 : 8|16@1+ (1,0) [0|0] \"\" Node\n"
                         " SG_ S : 20|8@1+ (1,0) [0|0] \"\" Node\n"           // under Q's page
                         "BO_ 5 X3: 8 Node\n"
                         " SG_ Sel M : 0|8@1+ (1,0) [0|0] \"\" Node\n"
                         " SG_ T m3 : 4|8@1+ (1,0) [0|0] \"\" Node\n"         // under the multiplexer
                         "BO_ 6 Twice: 8 Node\n"
                         " SG_ A : 0|8@1+ (1,0) [0|0] \"\" Node\n"
                         " SG_ B : 0|8@1+ (1,0) [0|0] \"\" Node\n"
                         " SG_ C : 4|8@1+ (1,0) [0|0] \"\" Node\n"
                         " SG_ D : 8|8@1+ (1,0) [0|0] \"\" Node\n"
                         "BO_ 7 Fine: 8 Node\n"
                         " SG_ Sel M : 0|8@1+ (1,0) [0|0] \"\" Node\n"
                         " SG_ P m1 : 8|8@1+ (1,0) [0|0] \"\" Node\n"
                         " SG_ Q m2 : 8|16@1+ (1,0) [0|0] \"\" Node\n"),
            (std::vector<std::string>{
                "odd.dbc:3:6: warning: message 'M1' cannot be used: signal 'B' overlaps signal 'A'",
                "odd.dbc:6:6: warning: message 'M2' cannot be used: signal 'D' overlaps signal 'C'",
                "odd.dbc:11:6: warning: message 'X1' cannot be used: signal 'R' overlaps signal 'P'",
                "odd.dbc:15:6: warning: message 'X2' cannot be used: signal 'S' overlaps signal 'Q'",
                "odd.dbc:18:6: warning: message 'X3' cannot be used: signal 'T' overlaps signal 'Sel'",
                // One warning per message, with how many more problems it has.
                "odd.dbc:21:6: warning: message 'Twice' cannot be used: signal 'B' overlaps signal 'A' (and 1 "
                "more problem)",
            }));
  for (const char* name : {"odd::M1", "odd::M2", "odd::X1", "odd::X2", "odd::X3", "odd::Twice"}) {
    EXPECT_EQ(registry_.find(name), nullptr) << name;
  }
  EXPECT_EQ(unusable("odd::X3"), "odd.dbc:18:6: signal 'T' overlaps signal 'Sel'");
  EXPECT_EQ(message("odd::Fine").signals.size(), 3u);
}

TEST_F(DbcFixture, DbcErrorByteOrderAndSign) {
  EXPECT_EQ(errors_for("BO_ 1 M: 8 Node\n"
                       " SG_ A : 0|8@2+ (1,0) [0|0] \"\" Node\n"
                       " SG_ B : 8|8@1* (1,0) [0|0] \"\" Node\n"
                       " SG_ C : 16|8@x+ (1,0) [0|0] \"\" Node\n"
                       "BO_ 2 Z: 8 Node\n"
                       " SG_ D : 24|8@1+ (0,0) [0|0] \"\" Node\n"),
            (std::vector<std::string>{
                "bad.dbc:2:14: byte order must be 0 (Motorola, big-endian) or 1 (Intel, little-endian), found '2'",
                "bad.dbc:3:15: unexpected character '*'",
                "bad.dbc:3:17: expected '+' (unsigned) or '-' (signed) after the byte order, found '('",
                "bad.dbc:4:15: expected the byte order (0 or 1) after '@', found 'x'",
                // A factor of 0 is the message's own problem, not a syntax error.
                "bad.dbc:6:19: warning: message 'Z' cannot be used: the factor of signal 'D' must not be 0",
            }));
}

TEST_F(DbcFixture, DbcDuplicatesAreWarnings) {
  // A node or value table twice changes no frame; a message twice makes that message unusable.
  EXPECT_EQ(warnings_for("BU_: A B A\n"
                         "BO_ 100 Foo: 8 A\n"
                         " SG_ S : 0|8@1+ (1,0) [0|0] \"\" B\n"
                         " SG_ S : 8|8@1+ (1,0) [0|0] \"\" B\n"
                         "BO_ 101 Foo: 8 A\n"
                         "BO_ 100 Bar: 8 A\n"
                         "BO_ 2147483748 Ext: 8 A\n"  // 100 as an extended id: another frame
                         "VAL_TABLE_ T 0 \"a\" ;\n"
                         "VAL_TABLE_ T 1 \"b\" ;\n",
                         "bad.dbc"),
            (std::vector<std::string>{
                "bad.dbc:1:10: warning: node 'A' is already defined; the second is ignored",
                "bad.dbc:4:6: warning: message 'Foo' cannot be used: signal 'S' is already defined in message 'Foo'",
                "bad.dbc:5:9: warning: message 'Foo' cannot be used: message 'Foo' is already defined at line 2",
                "bad.dbc:6:5: warning: message 'Bar' cannot be used: message id 100 is already used by message "
                "'Foo'",
                "bad.dbc:9:12: warning: value table 'T' is already defined; the second is ignored",
            }));
  EXPECT_NE(registry_.find("bad::Ext"), nullptr);
  EXPECT_EQ(registry_.find("bad::Bar"), nullptr);
  EXPECT_EQ(registry_.find("bad::Foo"), nullptr);
  // The first reason stands for a name declared twice.
  EXPECT_EQ(unusable("bad::Foo"), "bad.dbc:4:6: signal 'S' is already defined in message 'Foo'");
}

TEST_F(DbcFixture, DbcErrorValueTypeLengthMismatch) {
  EXPECT_EQ(errors_for("BO_ 100 M: 12 Node\n"
                       " SG_ F : 0|16@1- (1,0) [0|0] \"\" Node\n"
                       " SG_ Ok : 55|32@0- (1,0) [0|0] \"\" Node\n"
                       "BO_ 101 N: 8 Node\n"
                       " SG_ D : 16|32@1- (1,0) [0|0] \"\" Node\n"
                       "SIG_VALTYPE_ 100 F : 1;\n"
                       "SIG_VALTYPE_ 101 D : 2;\n"
                       "SIG_VALTYPE_ 100 Ok : 1;\n"
                       "SIG_VALTYPE_ 100 Ok : 3;\n"),
            (std::vector<std::string>{
                "bad.dbc:6:22: warning: message 'M' cannot be used: a float signal needs 32 bits; 'F' has 16",
                "bad.dbc:7:22: warning: message 'N' cannot be used: a double signal needs 64 bits; 'D' has 32",
                "bad.dbc:9:23: signal value type must be 0 (integer), 1 (float) or 2 (double), found '3'",
            }));
  EXPECT_EQ(registry_.find("bad::M"), nullptr);
  EXPECT_EQ(registry_.find("bad::N"), nullptr);
}

TEST_F(DbcFixture, DbcStatementsNamingWhatTheFileDoesNotDefineAreIgnoredWithOneWarning) {
  // Real files keep comments and value tables of messages they no longer define (or that
  // another file defines, as opendbc's generated files do).
  EXPECT_EQ(warnings_for("BU_: Node\n"
                         "BO_ 100 M: 8 Node\n"
                         " SG_ A : 0|8@1+ (1,0) [0|0] \"\" Node\n"
                         "CM_ BO_ 200 \"no such message\";\n"
                         "CM_ SG_ 100 Missing \"no such signal\";\n"
                         "CM_ BU_ Nobody \"no such node\";\n"
                         "BA_DEF_ BO_ \"GenMsgCycleTime\" INT 0 65535;\n"
                         "BA_ \"GenMsgCycleTime\" BO_ 300 10;\n"
                         "BA_ \"GenMsgCycleTime\" BO_ 100 -5;\n"
                         "VAL_ 100 Gone 0 \"x\" ;\n"
                         "SIG_VALTYPE_ 7 A : 1;\n"
                         "BO_TX_BU_ 8 : Node;\n"),
            (std::vector<std::string>{
                "odd.dbc:4:9: warning: no message has id 200; statements naming what the file does not define "
                "are ignored (7 in this file)",
                "odd.dbc:9:31: warning: GenMsgCycleTime must be a whole number of milliseconds, found '-5'; the "
                "value is ignored (1 in this file)",
                "odd.dbc:12:1: warning: BO_TX_BU_ statements (more transmitters of a message) are not used by "
                "polyport and are ignored (1 in this file)",
            }));
  // Problems in statements about a message do not unregister it.
  EXPECT_NE(registry_.find("odd::M"), nullptr);
  EXPECT_EQ(message("odd::M").cycle_time_ms, 0u);
}

TEST_F(DbcFixture, DbcErrorFrameIdsAndLengths) {
  EXPECT_EQ(errors_for("BO_ 2048 TooBig: 8 N\n"
                       "BO_ 4026531840 NotCan: 8 N\n"
                       "BO_ 1 Long: 65 N\n"
                       "BO_ 2 Odd: 17 N\n"
                       "BO_ 3 Huge: 99999999999999999999 N\n"),
            (std::vector<std::string>{
                "bad.dbc:1:5: warning: message 'TooBig' cannot be used: standard frame id 0x800 does not fit in 11 "
                "bits (extended ids have bit 31 set: 2147485696)",
                "bad.dbc:2:5: warning: message 'NotCan' cannot be used: message id 4026531840 is not a CAN id (29 "
                "bits, plus bit 31 for extended frames)",
                "bad.dbc:3:13: warning: message 'Long' cannot be used: message length 65 is more than the 64 bytes "
                "of a CAN FD frame",
                "bad.dbc:4:12: warning: message 'Odd' cannot be used: message length 17 is not a CAN FD frame "
                "length (0-8, 12, 16, 20, 24, 32, 48, 64)",
                // A number no DBC writer produces is a syntax error.
                "bad.dbc:5:13: the message length in bytes 99999999999999999999 is out of range",
            }));
  EXPECT_TRUE(registry_.declared().empty());
}

TEST_F(DbcFixture, DbcErrorMultiplexing) {
  EXPECT_EQ(errors_for("BO_ 1 NoSelector: 8 N\n"
                       " SG_ P m1 : 8|8@1+ (1,0) [0|0] \"\" N\n"
                       "BO_ 2 TwoSelectors: 8 N\n"
                       " SG_ A M : 0|8@1+ (1,0) [0|0] \"\" N\n"
                       " SG_ B M : 8|8@1+ (1,0) [0|0] \"\" N\n"
                       "BO_ 3 Extended: 8 N\n"
                       " SG_ A M : 0|8@1+ (1,0) [0|0] \"\" N\n"
                       " SG_ B m1M : 8|8@1+ (1,0) [0|0] \"\" N\n"
                       " SG_ C m2 : 16|8@1+ (1,0) [0|0] \"\" N\n"
                       " SG_ D x : 24|8@1+ (1,0) [0|0] \"\" N\n"
                       "BO_ 4 FloatSelector: 8 N\n"
                       " SG_ F M : 0|32@1+ (1,0) [0|0] \"\" N\n"
                       "SIG_VALTYPE_ 4 F : 1;\n"
                       "SG_MUL_VAL_ 3 C A 2-3;\n"),
            (std::vector<std::string>{
                "bad.dbc:2:6: warning: message 'NoSelector' cannot be used: signal 'P' is multiplexed but message "
                "'NoSelector' has no multiplexer (M) signal",
                "bad.dbc:5:6: warning: message 'TwoSelectors' cannot be used: message 'TwoSelectors' already has a "
                "multiplexer, 'A'",
                "bad.dbc:10:8: expected 'M', 'm<value>' or ':' after the signal name, found 'x'",
                "bad.dbc:13:20: warning: message 'FloatSelector' cannot be used: multiplexer 'F' must be an "
                "integer signal",
            }));
  EXPECT_TRUE(registry_.declared().empty());
  EXPECT_EQ(unusable("bad::Extended"), "");  // its syntax error is the file's, not the message's
}

TEST_F(DbcFixture, DbcErrorStrayTokensAndStatements) {
  EXPECT_EQ(errors_for(" SG_ Early : 0|8@1+ (1,0) [0|0] \"\" N\n"
                       "BU_: N\n"
                       "42\n"
                       "FOO_ 1 2 3;\n"
                       "BO_ 1 M: 8 N extra\n"
                       "BO_ 2 Good: 1 N\n"
                       " SG_ S : 0|8@1+ (1,0) [0|0] \"\" N\n"
                       "CM_ XX_ 1 \"?\";\n"
                       "BA_DEF_ BO_ \"Weird\" LIST 1 2;\n"
                       "VERSION \"never closed\n"
                       "BO_ 3 Lost: 8 N\n"),
            (std::vector<std::string>{
                "bad.dbc:1:2: SG_ outside a message (it must follow a BO_ line)",
                "bad.dbc:3:1: expected a DBC keyword, found '42'",
                "bad.dbc:4:1: warning: unknown statement 'FOO_' is ignored (1 in this file)",
                "bad.dbc:5:14: unexpected 'extra' after the message's transmitter",
                "bad.dbc:8:5: expected a comment string or BU_, BO_, SG_, EV_ after CM_, found 'XX_'",
                "bad.dbc:9:21: unknown attribute type 'LIST' (expected INT, HEX, FLOAT, STRING or ENUM)",
                "bad.dbc:10:9: unterminated string",
            }));
  // What parsed cleanly is registered; the message after the open string is swallowed.
  EXPECT_NE(registry_.find("bad::Good"), nullptr);
  EXPECT_EQ(registry_.find("bad::M"), nullptr);
  EXPECT_EQ(registry_.find("bad::Lost"), nullptr);
}

TEST_F(DbcFixture, DbcParserSurvivesEveryTruncationOfARealFile) {
  // vehicle.dbc, and candb_export.dbc for the Windows-1252 and ignored-statement paths.
  for (const char* name : {"vehicle.dbc", "candb_export.dbc"}) {
    const std::string text = read_file(dbc_path(name));
    ASSERT_GT(text.size(), 1000u) << name;
    const auto lines = static_cast<std::uint32_t>(std::count(text.begin(), text.end(), '\n')) + 1;
    for (std::size_t size = 0; size <= text.size(); ++size) {
      TypeRegistry registry;
      Diagnostics diagnostics;
      registry.add_dbc_text(std::string_view(text).substr(0, size), "cut.dbc", diagnostics);
      for (const Diagnostic& item : diagnostics.all()) {
        ASSERT_GE(item.where.line, 1u) << name << " " << size << ": " << item.to_string();
        ASSERT_LE(item.where.line, lines) << name << " " << size << ": " << item.to_string();
        ASSERT_GE(item.where.column, 1u) << name << " " << size << ": " << item.to_string();
      }
      // Whatever registered can be coded.
      for (const Type* declared : registry.declared()) {
        ASSERT_TRUE(make_dbc_codec(*declared).ok()) << name << " " << size;
      }
    }
  }
}

// ---------------------------------------------------------------------------------------
// The codec: the reference's worked examples

constexpr std::string_view kWorkedExample =
    "BO_ 496 ExampleMessage: 8 PCM1\n"
    " SG_ Temperature : 0|12@0- (0.01,250) [229.52|270.47] \"degK\" PCM1,FOO\n"
    "BO_ 497 IntelExample: 8 PCM1\n"
    " SG_ Temperature : 0|12@1- (0.01,250) [229.52|270.47] \"degK\" PCM1,FOO\n";

TEST_F(DbcFixture, DbcCodecMotorolaWorkedExample) {
  load_ok(kWorkedExample, "example.dbc");
  auto motorola = codec("example::ExampleMessage");
  ASSERT_NE(motorola, nullptr);
  Sample sample(type("example::ExampleMessage"));
  sample.set("Temperature", 249.90);
  Bytes frame;
  const CodecResult encoded = encode(*motorola, sample, frame);
  ASSERT_TRUE(encoded.ok()) << to_string(encoded.error);
  EXPECT_EQ(encoded.size, 8u);
  EXPECT_EQ(encoded.clamped, 0u);
  EXPECT_EQ(frame, (Bytes{0x01, 0xFE, 0xC0, 0x00, 0x00, 0x00, 0x00, 0x00}));

  // The cantools README's cross-check: raw 0x250.
  Sample decoded(type("example::ExampleMessage"));
  ASSERT_TRUE(decode(*motorola, Bytes{0x80, 0x4A, 0x0F, 0x00, 0x00, 0x00, 0x00, 0x00}, decoded).ok());
  EXPECT_DOUBLE_EQ(decoded.get("Temperature"), 255.92);
  ASSERT_TRUE(decode(*motorola, Bytes{0x01, 0xFE, 0xC0, 0x00, 0x00, 0x00, 0x00, 0x00}, decoded).ok());
  EXPECT_DOUBLE_EQ(decoded.get("Temperature"), 249.90);
}

TEST_F(DbcFixture, DbcCodecIntelWorkedExample) {
  load_ok(kWorkedExample, "example.dbc");
  auto intel = codec("example::IntelExample");
  ASSERT_NE(intel, nullptr);
  Sample sample(type("example::IntelExample"));
  sample.set("Temperature", 249.90);
  Bytes frame;
  ASSERT_TRUE(encode(*intel, sample, frame).ok());
  EXPECT_EQ(frame, (Bytes{0xF6, 0x0F, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00}));
  Sample decoded(type("example::IntelExample"));
  ASSERT_TRUE(decode(*intel, Bytes{0x50, 0x02, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00}, decoded).ok());
  EXPECT_DOUBLE_EQ(decoded.get("Temperature"), 255.92);
}

// ---------------------------------------------------------------------------------------
// The codec: every signal kind

TEST_F(DbcFixture, DbcCodecRoundTripsIntelAndMotorolaIntegers) {
  load_vehicle();
  for (const char* name : {"vehicle::EngineData", "vehicle::BrakeStatus"}) {
    SCOPED_TRACE(name);
    auto engine = codec(name);
    ASSERT_NE(engine, nullptr);
    std::mt19937_64 random(7);
    const DbcMessage& dbc = message(name);
    for (int round = 0; round < 200; ++round) {
      // Random raw values in range, placed by the walker: decode must give raw*factor+offset
      // and encode must give the same bytes back.
      Bytes frame(8, 0);
      std::vector<double> expected;
      for (const DbcSignal& item : dbc.signals) {
        std::uint64_t raw = random() & ((std::uint64_t{1} << item.length) - 1);
        double physical = 0;
        if (item.is_signed) {
          const auto shift = 64 - item.length;
          physical = static_cast<double>(static_cast<std::int64_t>(raw << shift) >> shift);
        } else {
          physical = static_cast<double>(raw);
        }
        physical = physical * item.factor + item.offset;
        if (item.has_range() && (physical < item.minimum || physical > item.maximum)) {
          raw = 0;  // out of the DBC range: encode would clamp it
          physical = item.offset;
          if (item.has_range() && (physical < item.minimum || physical > item.maximum)) continue;
        }
        walk_insert(frame, item.start_bit, item.length, item.byte_order == DbcByteOrder::motorola, raw);
        expected.push_back(physical);
      }
      ASSERT_EQ(expected.size(), dbc.signals.size());
      Sample sample(type(name));
      ASSERT_TRUE(decode(*engine, frame, sample).ok());
      for (std::size_t i = 0; i < expected.size(); ++i) {
        EXPECT_EQ(sample.get(dbc.signals[i].name), expected[i]) << dbc.signals[i].name;
      }
      Bytes again;
      const CodecResult encoded = encode(*engine, sample, again);
      ASSERT_TRUE(encoded.ok());
      EXPECT_EQ(encoded.clamped, 0u);
      EXPECT_EQ(again, frame);
    }
  }
}

TEST_F(DbcFixture, DbcCodecPacksFloatsAsIeeeBits) {
  load_vehicle();
  auto imu = codec("vehicle::ImuData");
  ASSERT_NE(imu, nullptr);
  Sample sample(type("vehicle::ImuData"));
  sample.set("YawRate", 1.5);
  sample.set("AccelX", -9.8100004196166992);  // exactly a float
  Bytes frame;
  ASSERT_TRUE(encode(*imu, sample, frame).ok());
  // 1.5f = 0x3FC00000, little-endian in bytes 0..3; -9.81f = 0xC11CF5C3, big-endian in 4..7.
  EXPECT_EQ(frame, (Bytes{0x00, 0x00, 0xC0, 0x3F, 0xC1, 0x1C, 0xF5, 0xC3}));
  Sample decoded(type("vehicle::ImuData"));
  ASSERT_TRUE(decode(*imu, frame, decoded).ok());
  EXPECT_EQ(decoded.get("YawRate"), 1.5);
  EXPECT_EQ(decoded.get("AccelX"), static_cast<double>(-9.81f));

  auto gps = codec("vehicle::GpsPosition");
  ASSERT_NE(gps, nullptr);
  Sample position(type("vehicle::GpsPosition"));
  position.set("Latitude", 48.8566);
  position.set("Longitude", -2.3522);
  ASSERT_TRUE(encode(*gps, position, frame).ok());
  ASSERT_EQ(frame.size(), 16u);
  const auto latitude = std::bit_cast<std::uint64_t>(48.8566);
  const auto longitude = std::bit_cast<std::uint64_t>(-2.3522);
  for (int i = 0; i < 8; ++i) {
    EXPECT_EQ(frame[i], static_cast<std::uint8_t>(latitude >> (8 * i))) << i;
    EXPECT_EQ(frame[8 + i], static_cast<std::uint8_t>(longitude >> (56 - 8 * i))) << i;
  }
  Sample back(type("vehicle::GpsPosition"));
  ASSERT_TRUE(decode(*gps, frame, back).ok());
  EXPECT_EQ(back.get("Latitude"), 48.8566);
  EXPECT_EQ(back.get("Longitude"), -2.3522);
}

TEST_F(DbcFixture, DbcCodecRoundTripsA64ByteCanFdFrame) {
  load_vehicle();
  auto battery = codec("vehicle::BatteryFD");
  ASSERT_NE(battery, nullptr);
  EXPECT_EQ(battery->max_wire_size(0), 64u);
  const Type& layout = type("vehicle::BatteryFD");
  Sample sample(layout);
  sample.set("Cell01", 3.301);
  sample.set("Cell02", 3.302);
  sample.set("Cell03", 0.0);
  sample.set("Cell16", 65.535);
  sample.set("StateOfCharge", 87.5);
  // 9-byte signals, exact in a double: Odometer's low bits and Energy's high bits are in
  // the ninth byte.
  sample.set("Odometer", 0x000123456789ABCDp0);  // Motorola
  sample.set("Energy", 0xFEDCBA9876543000p0);    // Intel
  sample.set("PackCurrent", -1234.567);
  Bytes frame;
  const CodecResult encoded = encode(*battery, sample, frame);
  ASSERT_TRUE(encoded.ok());
  EXPECT_EQ(encoded.size, 64u);
  EXPECT_EQ(encoded.clamped, 0u);
  Bytes expected(64, 0);
  walk_insert(expected, 0, 16, false, 3301);
  walk_insert(expected, 16, 16, false, 3302);
  walk_insert(expected, 240, 16, false, 65535);
  walk_insert(expected, 263, 8, true, 175);
  walk_insert(expected, 323, 64, true, 0x000123456789ABCDu);
  walk_insert(expected, 396, 64, false, 0xFEDCBA9876543000u);
  walk_insert(expected, 480, 32, false, static_cast<std::uint32_t>(-1234567));
  EXPECT_EQ(frame, expected);
  Sample back(layout);
  ASSERT_TRUE(decode(*battery, frame, back).ok());
  for (const Field& field : layout.fields) {
    EXPECT_DOUBLE_EQ(back.get(field.name), sample.get(field.name)) << field.name;
  }
  EXPECT_EQ(back.get("Odometer"), 0x000123456789ABCDp0);
  EXPECT_EQ(back.get("Energy"), 0xFEDCBA9876543000p0);
}

TEST_F(DbcFixture, DbcCodecMatchesTheBitWalkerOnRandomLayouts) {
  std::mt19937_64 random(2024);
  const std::uint32_t lengths[] = {1, 2, 3, 5, 7, 8, 12, 16, 20, 24, 32, 48, 64};
  for (int trial = 0; trial < 300; ++trial) {
    SCOPED_TRACE(trial);
    const std::uint32_t bytes = lengths[random() % std::size(lengths)];
    struct Placed {
      std::uint32_t start, length;
      bool motorola, is_signed;
    };
    std::vector<Placed> placed;
    std::vector<bool> used(bytes * 8, false);
    for (int attempt = 0; attempt < 40 && placed.size() < 10; ++attempt) {
      Placed item{static_cast<std::uint32_t>(random() % (bytes * 8)),
                  1 + static_cast<std::uint32_t>(random() % std::min<std::uint32_t>(64, bytes * 8)),
                  (random() & 1) != 0, (random() & 1) != 0};
      std::vector<std::uint32_t> bits;
      if (!walk_bits(item.start, item.length, item.motorola, bytes, bits)) continue;
      if (std::any_of(bits.begin(), bits.end(), [&](std::uint32_t bit) { return used[bit]; })) continue;
      for (const std::uint32_t bit : bits) used[bit] = true;
      placed.push_back(item);
    }
    std::string text = "BO_ 1 M: " + std::to_string(bytes) + " N\n";
    for (std::size_t i = 0; i < placed.size(); ++i) {
      text += " SG_ S" + std::to_string(i) + " : " + std::to_string(placed[i].start) + "|" +
              std::to_string(placed[i].length) + "@" + (placed[i].motorola ? "0" : "1") +
              (placed[i].is_signed ? "-" : "+") + " (1,0) [0|0] \"\" N\n";
    }
    TypeRegistry registry;
    Diagnostics diagnostics;
    ASSERT_TRUE(registry.add_dbc_text(text, "random.dbc", diagnostics)) << text << rendered(diagnostics)[0];
    const Type& layout = *registry.find("random::M");
    auto made = make_dbc_codec(layout);
    ASSERT_TRUE(made.ok()) << made.error().message;
    const Codec& random_codec = *made.value();

    // A random frame decodes to what the walker reads.
    Bytes frame(bytes);
    for (auto& byte : frame) byte = static_cast<std::uint8_t>(random());
    Sample sample(layout);
    ASSERT_TRUE(decode(random_codec, frame, sample).ok());
    // The same values made exact in a double (signals over 53 bits lose their low bits in
    // even trials, their high bits in odd ones), and nothing but the signals: encode must
    // give exactly these bytes.
    Bytes exact(bytes, 0);
    for (std::size_t i = 0; i < placed.size(); ++i) {
      const Placed& item = placed[i];
      std::uint64_t raw = walk_extract(frame, item.start, item.length, item.motorola);
      const auto shift = 64 - item.length;
      const double expected = item.is_signed
                                  ? static_cast<double>(static_cast<std::int64_t>(raw << shift) >> shift)
                                  : static_cast<double>(raw);
      ASSERT_EQ(sample.get("S" + std::to_string(i)), expected) << text;
      if (item.length > 53 && trial % 2 == 0) {
        raw &= ~((std::uint64_t{1} << (item.length - 53)) - 1);
      }
      if (item.length > 53 && trial % 2 == 1) {
        const std::uint64_t low = (std::uint64_t{1} << 52) - 1;
        const bool negative = item.is_signed && ((raw >> (item.length - 1)) & 1u) != 0;
        const std::uint64_t mask =
            item.length == 64 ? ~std::uint64_t{0} : (std::uint64_t{1} << item.length) - 1;
        raw = negative ? (raw | ~low) & mask : raw & low;
      }
      walk_insert(exact, item.start, item.length, item.motorola, raw);
    }
    Sample exact_sample(layout);
    ASSERT_TRUE(decode(random_codec, exact, exact_sample).ok());
    Bytes again;
    const CodecResult encoded = encode(random_codec, exact_sample, again);
    ASSERT_TRUE(encoded.ok());
    ASSERT_EQ(encoded.clamped, 0u);
    ASSERT_EQ(again, exact) << text;
  }
}

// ---------------------------------------------------------------------------------------
// The codec: multiplexing

TEST_F(DbcFixture, DbcCodecDecodesOnlyTheSelectedMultiplexedSignals) {
  load_vehicle();
  auto mux = codec("vehicle::DiagMux");
  ASSERT_NE(mux, nullptr);
  Sample sample(type("vehicle::DiagMux"));
  // Mode 1: Voltage 0x3039 = 12.345 V, Current -2.5 A (0xFF06), Sequence 9.
  ASSERT_TRUE(decode(*mux, Bytes{0x01, 0x39, 0x30, 0x06, 0xFF, 0x00, 0x00, 0x09}, sample).ok());
  EXPECT_EQ(sample.get("Mode"), 1.0);
  EXPECT_DOUBLE_EQ(sample.get("Voltage"), 12.345);
  EXPECT_DOUBLE_EQ(sample.get("Current"), -2.5);
  EXPECT_TRUE(std::isnan(sample.get("ModuleTemp")));
  EXPECT_TRUE(std::isnan(sample.get("Status")));
  EXPECT_EQ(sample.get("Sequence"), 9.0);
  // Mode 2: the same bytes are ModuleTemp 0x39 = 57 and Status 0x30 = 48.
  ASSERT_TRUE(decode(*mux, Bytes{0x02, 0x39, 0x30, 0x06, 0xFF, 0x00, 0x00, 0x09}, sample).ok());
  EXPECT_TRUE(std::isnan(sample.get("Voltage")));
  EXPECT_TRUE(std::isnan(sample.get("Current")));
  EXPECT_EQ(sample.get("ModuleTemp"), 57.0);
  EXPECT_EQ(sample.get("Status"), 48.0);
  // No page 3: only the plain signals.
  ASSERT_TRUE(decode(*mux, Bytes{0x03, 0x39, 0x30, 0x06, 0xFF, 0x00, 0x00, 0x09}, sample).ok());
  for (const char* name : {"Voltage", "Current", "ModuleTemp", "Status"}) {
    EXPECT_TRUE(std::isnan(sample.get(name))) << name;
  }
  EXPECT_EQ(sample.get("Sequence"), 9.0);
}

TEST_F(DbcFixture, DbcCodecEncodesOnlyTheSelectedMultiplexedSignals) {
  load_vehicle();
  auto mux = codec("vehicle::DiagMux");
  ASSERT_NE(mux, nullptr);
  Sample sample(type("vehicle::DiagMux"));
  sample.set("Mode", 2);
  sample.set("Voltage", kNaN);  // not on page 2: ignored, even NaN
  sample.set("Current", 300.0);
  sample.set("ModuleTemp", -3);
  sample.set("Status", 200);
  sample.set("Sequence", 255);
  Bytes frame;
  CodecResult encoded = encode(*mux, sample, frame);
  ASSERT_TRUE(encoded.ok()) << to_string(encoded.error);
  EXPECT_EQ(frame, (Bytes{0x02, 0xFD, 0xC8, 0x00, 0x00, 0x00, 0x00, 0xFF}));
  sample.set("Mode", 1);  // now Voltage is packed, and NaN is refused
  EXPECT_EQ(encode(*mux, sample, frame).error, CodecError::bad_value);
  sample.set("Voltage", 5.0);
  encoded = encode(*mux, sample, frame);
  ASSERT_TRUE(encoded.ok());
  EXPECT_EQ(frame, (Bytes{0x01, 0x88, 0x13, 0x30, 0x75, 0x00, 0x00, 0xFF}));
  // A round trip of each page gives the page's values and NaN elsewhere.
  Sample back(type("vehicle::DiagMux"));
  ASSERT_TRUE(decode(*mux, frame, back).ok());
  EXPECT_DOUBLE_EQ(back.get("Voltage"), 5.0);
  EXPECT_DOUBLE_EQ(back.get("Current"), 300.0);
  EXPECT_TRUE(std::isnan(back.get("ModuleTemp")));
}

// ---------------------------------------------------------------------------------------
// The codec: ranges, sizes and bad values

TEST_F(DbcFixture, DbcCodecClampsAndCountsOutOfRangeValues) {
  load_vehicle();
  auto engine = codec("vehicle::EngineData");
  ASSERT_NE(engine, nullptr);
  Sample sample(type("vehicle::EngineData"));
  sample.set("EngineSpeed", 20000);  // above [0|16383.75]
  sample.set("CoolantTemp", -100);   // below [-40|215]
  sample.set("Torque", 1023.5);      // the maximum itself: not clamped
  sample.set("Gear", 2);
  sample.set("ThrottlePos", 100.1);  // above [0|100]
  sample.set("EngineRunning", 1);
  Bytes frame;
  CodecResult encoded = encode(*engine, sample, frame);
  ASSERT_TRUE(encoded.ok());
  EXPECT_EQ(encoded.clamped, 3u);
  Sample back(type("vehicle::EngineData"));
  ASSERT_TRUE(decode(*engine, frame, back).ok());
  EXPECT_EQ(back.get("EngineSpeed"), 16383.75);
  EXPECT_EQ(back.get("CoolantTemp"), -40.0);
  EXPECT_EQ(back.get("Torque"), 1023.5);
  EXPECT_DOUBLE_EQ(back.get("ThrottlePos"), 100.0);

  // Without a DBC range ([0|0]) the raw range clamps, never wraps; infinities too.
  auto brake = codec("vehicle::BrakeStatus");
  ASSERT_NE(brake, nullptr);
  Sample status(type("vehicle::BrakeStatus"));
  status.set("BrakePressure", 10);
  status.set("WheelSpeedFL", 10);
  status.set("BrakeTemp", 250);
  status.set("AbsActive", 0);
  status.set("Counter", 16);  // 4 bits: 15 at most
  status.set("Checksum", -std::numeric_limits<double>::infinity());
  encoded = encode(*brake, status, frame);
  ASSERT_TRUE(encoded.ok());
  EXPECT_EQ(encoded.clamped, 2u);
  Sample decoded(type("vehicle::BrakeStatus"));
  ASSERT_TRUE(decode(*brake, frame, decoded).ok());
  EXPECT_EQ(decoded.get("Counter"), 15.0);
  EXPECT_EQ(decoded.get("Checksum"), 0.0);
  status.set("Counter", 3);
  status.set("Checksum", std::numeric_limits<double>::infinity());
  encoded = encode(*brake, status, frame);
  EXPECT_EQ(encoded.clamped, 1u);
  ASSERT_TRUE(decode(*brake, frame, decoded).ok());
  EXPECT_EQ(decoded.get("Checksum"), 255.0);
}

TEST_F(DbcFixture, DbcCodecClampsToTheRawRangeInsideAWiderDbcRange) {
  load_ok("BO_ 1 M: 2 N\n"
          " SG_ U : 0|8@1+ (1,0) [0|1000] \"\" N\n"
          " SG_ S : 8|8@1- (0.5,0) [-1000|1000] \"\" N\n",
          "wide.dbc");
  auto wide = codec("wide::M");
  ASSERT_NE(wide, nullptr);
  Sample sample(type("wide::M"));
  sample.set("U", 300);
  sample.set("S", -64.25);  // raw -128.5 rounds to -129: one past the low end
  Bytes frame;
  const CodecResult encoded = encode(*wide, sample, frame);
  ASSERT_TRUE(encoded.ok());
  EXPECT_EQ(encoded.clamped, 2u);
  EXPECT_EQ(frame, (Bytes{0xFF, 0x80}));
  sample.set("U", 254.5);  // rounds half away from zero: 255, in range
  sample.set("S", 63.5);
  ASSERT_TRUE(encode(*wide, sample, frame).ok());
  EXPECT_EQ(frame, (Bytes{0xFF, 0x7F}));
}

TEST_F(DbcFixture, DbcCodecRefusesNaNAndWrongSizes) {
  load_vehicle();
  auto engine = codec("vehicle::EngineData");
  ASSERT_NE(engine, nullptr);
  Sample sample(type("vehicle::EngineData"));
  Bytes frame;
  ASSERT_TRUE(encode(*engine, sample, frame).ok());  // zeros, with CoolantTemp 0 degC in range
  sample.set("Torque", kNaN);
  EXPECT_EQ(encode(*engine, sample, frame).error, CodecError::bad_value);

  Bytes seven(7, 0);
  Bytes nine(9, 0);
  EXPECT_EQ(decode(*engine, seven, sample).error, CodecError::wrong_size);
  EXPECT_EQ(decode(*engine, nine, sample).error, CodecError::wrong_size);
  Bytes eight(8, 0);
  auto* wire = reinterpret_cast<std::byte*>(eight.data());
  EXPECT_EQ(engine->decode(wire, 8, sample.data(), sample.size() - 1).error, CodecError::output_too_small);
  EXPECT_EQ(engine->encode(sample.data(), sample.size() - 1, wire, 8).error, CodecError::truncated);
  sample.set("Torque", 0);
  EXPECT_EQ(engine->encode(sample.data(), sample.size(), wire, 7).error, CodecError::output_too_small);

  auto battery = codec("vehicle::BatteryFD");
  ASSERT_NE(battery, nullptr);
  Sample fd(type("vehicle::BatteryFD"));
  EXPECT_EQ(decode(*battery, eight, fd).error, CodecError::wrong_size);
  Bytes sixty_four(64, 0);
  EXPECT_TRUE(decode(*battery, sixty_four, fd).ok());
}

TEST_F(DbcFixture, DbcCodecHandlesFramesShorterThanEightBytes) {
  load_ok("BO_ 1 Three: 3 N\n"
          " SG_ A : 4|12@1+ (1,0) [0|0] \"\" N\n"
          " SG_ B : 23|8@0- (1,0) [0|0] \"\" N\n"
          "BO_ 2 Empty: 0 N\n",
          "short.dbc");
  auto three = codec("short::Three");
  ASSERT_NE(three, nullptr);
  EXPECT_EQ(three->max_wire_size(0), 3u);
  Sample sample(type("short::Three"));
  sample.set("A", 0xABC);
  sample.set("B", -2);
  Bytes frame;
  ASSERT_TRUE(encode(*three, sample, frame).ok());
  EXPECT_EQ(frame, (Bytes{0xC0, 0xAB, 0xFE}));
  Sample back(type("short::Three"));
  ASSERT_TRUE(decode(*three, frame, back).ok());
  EXPECT_EQ(back.get("A"), 0xABC);
  EXPECT_EQ(back.get("B"), -2.0);

  auto empty = codec("short::Empty");
  ASSERT_NE(empty, nullptr);
  Sample none(type("short::Empty"));
  EXPECT_EQ(empty->decode(nullptr, 0, none.data(), none.size()).error, CodecError::ok);
  EXPECT_EQ(empty->encode(none.data(), none.size(), nullptr, 0).size, 0u);
}

TEST_F(DbcFixture, DbcCodecRefusesTypesThatAreNotDbcMessages) {
  ASSERT_TRUE(registry_.add_idl_text("module m { struct S { double x; }; };", "m.idl", diagnostics_));
  auto from_idl = make_dbc_codec(*registry_.find("m::S"));
  ASSERT_FALSE(from_idl.ok());
  EXPECT_EQ(from_idl.error().message,
            "type 'm::S' does not come from a DBC file; only DBC messages travel as CAN frames");
  EXPECT_FALSE(make_dbc_codec(*registry_.primitive(TypeKind::float64)).ok());

  load_vehicle();
  auto dispatched = make_codec(WireFormat::dbc, type("vehicle::EngineData"));
  ASSERT_TRUE(dispatched.ok());
  EXPECT_EQ(dispatched.value()->format(), WireFormat::dbc);
  EXPECT_EQ(&dispatched.value()->type(), &type("vehicle::EngineData"));
}

// ---------------------------------------------------------------------------------------
// DBC files as real vehicle and robot projects write them. The files in tests/data/dbc are
// our own, each reproducing the constructs and quirks met in public DBC files (Vector
// CANdb++ exports, openpilot's opendbc, cantools' test files, J1939 exporters): each loads,
// with exactly one warning per construct kind polyport ignores, and decodes right.

// The diagnostics without the data folder, so that they read as "file.dbc:line:col: ...".
std::vector<std::string> relative(const Diagnostics& diagnostics) {
  const std::string prefix = dbc_path("");
  std::vector<std::string> out;
  for (std::string line : rendered(diagnostics)) {
    if (line.rfind(prefix, 0) == 0) line.erase(0, prefix.size());
    out.push_back(std::move(line));
  }
  return out;
}

const std::vector<std::string> kCandbWarnings = {
    "candb_export.dbc:3:57: warning: the file is not UTF-8: its text is read as Windows-1252 (Latin-1)",
    "candb_export.dbc:55:1: warning: BO_TX_BU_ statements (more transmitters of a message) are not used by "
    "polyport and are ignored (1 in this file)",
    "candb_export.dbc:57:1: warning: EV_ statements are not used by polyport and are ignored (2 in this file)",
    "candb_export.dbc:60:1: warning: ENVVAR_DATA_ statements are not used by polyport and are ignored (1 in "
    "this file)",
    "candb_export.dbc:62:1: warning: SGTYPE_ statements are not used by polyport and are ignored (1 in this "
    "file)",
    "candb_export.dbc:63:1: warning: SIG_TYPE_REF_ statements are not used by polyport and are ignored (1 in "
    "this file)",
    "candb_export.dbc:65:1: warning: CAT_DEF_ statements are not used by polyport and are ignored (1 in this "
    "file)",
    "candb_export.dbc:66:1: warning: CAT_ statements are not used by polyport and are ignored (1 in this file)",
    "candb_export.dbc:67:1: warning: FILTER statements are not used by polyport and are ignored (1 in this "
    "file)",
    "candb_export.dbc:73:5: warning: comments on environment variables (CM_ EV_) are not used by polyport and "
    "are ignored (1 in this file)",
    "candb_export.dbc:81:1: warning: BA_DEF_REL_ statements are not used by polyport and are ignored (2 in "
    "this file)",
    "candb_export.dbc:90:1: warning: BA_DEF_DEF_REL_ statements are not used by polyport and are ignored (2 "
    "in this file)",
    "candb_export.dbc:99:1: warning: BA_REL_ statements are not used by polyport and are ignored (2 in this "
    "file)",
    "candb_export.dbc:102:6: warning: value descriptions of environment variables (VAL_) are not used by "
    "polyport and are ignored (1 in this file)",
    "candb_export.dbc:103:1: warning: SIG_GROUP_ statements are not used by polyport and are ignored (2 in "
    "this file)",
};

TEST_F(DbcFixture, DbcRealCandbExportLoadsWithOneWarningPerIgnoredKind) {
  ASSERT_TRUE(registry_.add_dbc_file(dbc_path("candb_export.dbc"), diagnostics_))
      << ::testing::PrintToString(rendered(diagnostics_));
  EXPECT_EQ(relative(diagnostics_), kCandbWarnings);

  // What polyport models is all there; Windows-1252 text arrives as UTF-8.
  const DbcSignal& temperature = signal("candb_export::MotorStatus", "Temperature");
  EXPECT_EQ(temperature.unit, "\xC2\xB0" "C");
  EXPECT_EQ(temperature.comment, "Winding temperature \xE2\x80\x93 measured, not estimated.");
  EXPECT_EQ(temperature.receivers, (std::vector<std::string>{"Controller", "Display"}));
  EXPECT_EQ(signal("candb_export::MotorStatus", "State").value_table.at(2), "Running");
  EXPECT_EQ(message("candb_export::MotorStatus").cycle_time_ms, 10u);
  EXPECT_EQ(message("candb_export::MotorStatus").comment, "Motor status, every 10 ms.");
  const DbcMessage& setpoint = message("candb_export::Setpoint");
  EXPECT_TRUE(setpoint.extended);
  EXPECT_EQ(setpoint.frame_id, 0x18FEFEFEu);
  EXPECT_EQ(setpoint.transmitter, "Controller");
  EXPECT_EQ(setpoint.cycle_time_ms, 20u);
  EXPECT_FALSE(setpoint.fd);
  EXPECT_EQ(signal("candb_export::Setpoint", "Torque").float_kind, DbcFloatKind::float32);
  const DbcDatabase* database = find_dbc_database(registry_, "candb_export");
  ASSERT_NE(database, nullptr);
  EXPECT_EQ(database->value_tables.at("OnOff").at(1), "On");
  EXPECT_EQ(database->nodes.at(0).comment, "Motor controller");

  auto status = codec("candb_export::MotorStatus");
  ASSERT_NE(status, nullptr);
  Sample decoded(type("candb_export::MotorStatus"));
  ASSERT_TRUE(decode(*status, Bytes{0x64, 0x38, 0xFF, 0x02, 0x30, 0x39, 0x00, 0x00}, decoded).ok());
  EXPECT_DOUBLE_EQ(decoded.get("Temperature"), 60.0);
  EXPECT_DOUBLE_EQ(decoded.get("Current"), -2.0);
  EXPECT_DOUBLE_EQ(decoded.get("State"), 2.0);
  EXPECT_DOUBLE_EQ(decoded.get("Voltage"), 12.345);
  auto torque = codec("candb_export::Setpoint");
  ASSERT_NE(torque, nullptr);
  Sample command(type("candb_export::Setpoint"));
  ASSERT_TRUE(decode(*torque, Bytes{0x00, 0x00, 0x48, 0x41, 0x01, 0x00, 0x00, 0x00}, command).ok());
  EXPECT_DOUBLE_EQ(command.get("Torque"), 12.5);
  EXPECT_DOUBLE_EQ(command.get("Enable"), 1.0);
}

TEST_F(DbcFixture, DbcRealCrlfLineEndingsReadTheSame) {
  // CANdb++ on Windows writes CRLF; the same file with CRLF gives the same warnings and types.
  std::string text = read_file(dbc_path("candb_export.dbc"));
  ASSERT_GT(text.size(), 1000u);
  std::string crlf;
  for (const char c : text) {
    if (c == '\n') crlf += '\r';
    crlf += c;
  }
  ASSERT_TRUE(load(crlf, "candb_export.dbc")) << ::testing::PrintToString(rendered(diagnostics_));
  EXPECT_EQ(rendered(diagnostics_), kCandbWarnings);
  EXPECT_EQ(signal("candb_export::MotorStatus", "Temperature").unit, "\xC2\xB0" "C");
  EXPECT_EQ(message("candb_export::MotorStatus").signals.size(), 4u);
  EXPECT_EQ(message("candb_export::Setpoint").cycle_time_ms, 20u);

  // A comment over two lines reads the same from either file: the line break is "\n".
  std::string vehicle;
  for (const char c : read_file(dbc_path("vehicle.dbc"))) {
    if (c == '\n') vehicle += '\r';
    vehicle += c;
  }
  ASSERT_TRUE(load(vehicle, "vehicle.dbc")) << ::testing::PrintToString(rendered(diagnostics_));
  EXPECT_EQ(signal("vehicle::EngineData", "EngineSpeed").comment,
            "Crankshaft speed.\nSecond line, with \"quotes\".");
}

TEST_F(DbcFixture, DbcRealLatin1UnitIsReadAsWindows1252AndKeptAsUtf8) {
  // A unit as Latin-1 bytes ("\xB0" is the degree sign), and one of Windows-1252's own
  // characters ("\x80", the euro sign).
  EXPECT_EQ(warnings_for("BO_ 1 M: 2 N\n"
                         " SG_ T : 0|8@1+ (1,-40) [-40|215] \"\xB0" "C\" N\n"
                         " SG_ P : 8|8@1+ (1,0) [0|0] \"\x80/h\" N\n",
                         "latin.dbc"),
            std::vector<std::string>{
                "latin.dbc:2:36: warning: the file is not UTF-8: its text is read as Windows-1252 (Latin-1)"});
  EXPECT_EQ(signal("latin::M", "T").unit, "\xC2\xB0" "C");
  EXPECT_EQ(signal("latin::M", "P").unit, "\xE2\x82\xAC/h");
  // The same unit in UTF-8 is taken as it is, without a warning.
  diagnostics_ = Diagnostics();
  load_ok("BO_ 1 M: 1 N\n SG_ T : 0|8@1+ (1,-40) [-40|215] \"\xC2\xB0" "C\" N\n", "utf8.dbc");
  EXPECT_EQ(signal("utf8::M", "T").unit, "\xC2\xB0" "C");
}

TEST_F(DbcFixture, DbcRealOpendbcStyleFileLoadsAndOnlyTheBrokenMessageIsUnusable) {
  ASSERT_TRUE(registry_.add_dbc_file(dbc_path("opendbc_style.dbc"), diagnostics_))
      << ::testing::PrintToString(rendered(diagnostics_));
  EXPECT_EQ(relative(diagnostics_),
            (std::vector<std::string>{
                "opendbc_style.dbc:18:7: warning: message 'STEER_STATUS' cannot be used: signal "
                "'INTERNAL_ANGLE' overlaps signal 'HANDS_ON' (and 1 more problem)",
                "opendbc_style.dbc:26:9: warning: no message has id 806; statements naming what the file does "
                "not define are ignored (2 in this file)",
            }));
  EXPECT_EQ(registry_.find("opendbc_style::STEER_STATUS"), nullptr);
  const UnusableType* steer = registry_.find_unusable("opendbc_style::STEER_STATUS");
  ASSERT_NE(steer, nullptr);
  EXPECT_EQ(steer->reason, "signal 'INTERNAL_ANGLE' overlaps signal 'HANDS_ON'");
  EXPECT_EQ(steer->where.line, 18u);
  EXPECT_EQ(steer->where.column, 7u);

  auto motors = codec("opendbc_style::MOTORS_DATA");
  ASSERT_NE(motors, nullptr);
  Sample decoded(type("opendbc_style::MOTORS_DATA"));
  ASSERT_TRUE(decode(*motors, Bytes{0xFF, 0x9C, 0x00, 0x64, 0x00, 0x00, 0x07, 0xAB}, decoded).ok());
  EXPECT_DOUBLE_EQ(decoded.get("SPEED_L"), -100.0);
  EXPECT_DOUBLE_EQ(decoded.get("SPEED_R"), 100.0);
  EXPECT_DOUBLE_EQ(decoded.get("COUNTER"), 7.0);
  EXPECT_DOUBLE_EQ(decoded.get("CHECKSUM"), 171.0);
  EXPECT_EQ(signal("opendbc_style::MOTORS_DATA", "COUNTER").value_table.at(15), "wrap");
  EXPECT_EQ(message("opendbc_style::MOTORS_DATA").transmitter, "XXX");
  const DbcMessage& radar = message("opendbc_style::RADAR_TRACK");
  EXPECT_EQ(radar.length, 64u);
  EXPECT_TRUE(radar.fd);
}

TEST_F(DbcFixture, DbcRealExtendedMultiplexingDecodesAndEncodesNestedSwitches) {
  ASSERT_TRUE(registry_.add_dbc_file(dbc_path("extended_mux.dbc"), diagnostics_))
      << ::testing::PrintToString(rendered(diagnostics_));
  // The one message whose signals meet in a frame (A = 1, B = 2 holds C and D on one byte).
  EXPECT_EQ(relative(diagnostics_),
            std::vector<std::string>{
                "extended_mux.dbc:46:6: warning: message 'Clash' cannot be used: signal 'D' overlaps signal 'C'"});
  EXPECT_EQ(registry_.find("extended_mux::Clash"), nullptr);
  ASSERT_NE(registry_.find_unusable("extended_mux::Clash"), nullptr);

  // The tree the SG_MUL_VAL_ lines describe.
  const DbcMessage& cascaded = message("extended_mux::Cascaded");
  EXPECT_EQ(cascaded.multiplexer, 0);
  EXPECT_TRUE(signal("extended_mux::Cascaded", "MuxB").is_switch());
  EXPECT_EQ(signal("extended_mux::Cascaded", "MuxB").mux_parent, 0);
  EXPECT_EQ(signal("extended_mux::Cascaded", "Value").mux_parent, 1);
  EXPECT_EQ(signal("extended_mux::Ranges", "Flag").mux_ranges,
            (std::vector<DbcMuxRange>{{8, 8}, {16, 16}, {24, 24}}));
  EXPECT_EQ(signal("extended_mux::TwoMultiplexers", "S1").mux_parent, 0);  // an M put under S0

  // Ranges: Flag is in frames whose Page is 8, 16 or 24.
  auto ranges = codec("extended_mux::Ranges");
  ASSERT_NE(ranges, nullptr);
  for (const std::uint8_t page : {8, 16, 24}) {
    expect_decoded(*ranges, type("extended_mux::Ranges"), Bytes{page, 0x01, 0, 0, 0, 0, 0, 0}, {{"Flag", 1.0}});
  }
  expect_decoded(*ranges, type("extended_mux::Ranges"), Bytes{9, 0x01, 0, 0, 0, 0, 0, 0}, {{"Flag", kNaN}});

  // Cascaded: Value needs MuxB = 0, and MuxB needs MuxA = 2; a switch that is not in the
  // frame selects nothing.
  auto nested = codec("extended_mux::Cascaded");
  ASSERT_NE(nested, nullptr);
  const char* cascaded_name = "extended_mux::Cascaded";
  expect_decoded(*nested, type(cascaded_name), Bytes{2, 0, 42, 0, 0, 0, 0, 0}, {{"MuxA", 2}, {"MuxB", 0}, {"Value", 42}});
  expect_decoded(*nested, type(cascaded_name), Bytes{2, 1, 42, 0, 0, 0, 0, 0}, {{"MuxB", 1}, {"Value", kNaN}});
  expect_decoded(*nested, type(cascaded_name), Bytes{3, 0, 42, 0, 0, 0, 0, 0}, {{"MuxB", kNaN}, {"Value", kNaN}});

  Sample out(type(cascaded_name));
  out.set("MuxA", 2.0);
  out.set("MuxB", 0.0);
  out.set("Value", 42.0);
  Bytes frame;
  ASSERT_TRUE(encode(*nested, out, frame).ok());
  EXPECT_EQ(frame, (Bytes{2, 0, 42, 0, 0, 0, 0, 0}));
  out.set("MuxA", 3.0);  // MuxB and Value are not in such a frame: not packed, whatever they hold
  ASSERT_TRUE(encode(*nested, out, frame).ok());
  EXPECT_EQ(frame, (Bytes{3, 0, 0, 0, 0, 0, 0, 0}));
  out.set("MuxA", 2.0);
  out.set("MuxB", kNaN);  // a switch in the frame needs a value
  EXPECT_EQ(encode(*nested, out, frame).error, CodecError::bad_value);
  out.set("MuxB", 1.0);
  out.set("Value", kNaN);  // not selected: its NaN does not matter
  ASSERT_TRUE(encode(*nested, out, frame).ok());
  EXPECT_EQ(frame, (Bytes{2, 1, 0, 0, 0, 0, 0, 0}));

  // Two M, the second under the first.
  auto two = codec("extended_mux::TwoMultiplexers");
  ASSERT_NE(two, nullptr);
  const char* two_name = "extended_mux::TwoMultiplexers";
  expect_decoded(*two, type(two_name), Bytes{0x00, 7, 0, 0, 0, 0, 0, 0}, {{"S1", 0}, {"S2", 7}});
  expect_decoded(*two, type(two_name), Bytes{0x10, 7, 0, 0, 0, 0, 0, 0}, {{"S1", 1}, {"S2", kNaN}});
  expect_decoded(*two, type(two_name), Bytes{0x01, 7, 0, 0, 0, 0, 0, 0}, {{"S1", kNaN}, {"S2", kNaN}});

  // Diagnostics: signals share bits where no frame holds both (Speed / Rpm under two Pids,
  // Dtc under another Service than Pid).
  auto diagnostics = codec("extended_mux::Diagnostics");
  ASSERT_NE(diagnostics, nullptr);
  const char* diag = "extended_mux::Diagnostics";
  expect_decoded(*diagnostics, type(diag), Bytes{1, 12, 0x20, 0x4E, 0, 0, 0, 0},
                 {{"Rpm", 5000.0}, {"Speed", kNaN}, {"Dtc", kNaN}});  // 0x4E20 * 0.25 rpm
  expect_decoded(*diagnostics, type(diag), Bytes{1, 13, 88, 0, 0, 0, 0, 0}, {{"Speed", 88}, {"Rpm", kNaN}});
  expect_decoded(*diagnostics, type(diag), Bytes{3, 0x34, 0x12, 0, 0, 0, 0, 0},
                 {{"Dtc", 0x1234}, {"Pid", kNaN}, {"Speed", kNaN}});
  Sample d(type(diag));
  d.set("Service", 1.0);
  d.set("Pid", 13.0);
  d.set("Speed", 88.0);
  d.set("Rpm", 1.0);  // not selected by Pid 13: its bits stay Speed's
  ASSERT_TRUE(encode(*diagnostics, d, frame).ok());
  EXPECT_EQ(frame, (Bytes{1, 13, 88, 0, 0, 0, 0, 0}));

  // SG_MUL_VAL_ that only restates m<N> is plain multiplexing.
  auto plain = codec("extended_mux::Plain");
  ASSERT_NE(plain, nullptr);
  Sample decoded(type("extended_mux::Plain"));
  ASSERT_TRUE(decode(*plain, Bytes{0x01, 0x34, 0x12, 0x00, 0x00, 0x00, 0x00, 0x00}, decoded).ok());
  EXPECT_DOUBLE_EQ(decoded.get("Page"), 1.0);
  EXPECT_DOUBLE_EQ(decoded.get("Voltage"), 46.60);
  EXPECT_TRUE(std::isnan(decoded.get("Temperature")));
  ASSERT_TRUE(decode(*plain, Bytes{0x02, 0xF6, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00}, decoded).ok());
  EXPECT_DOUBLE_EQ(decoded.get("Temperature"), -10.0);
  EXPECT_TRUE(std::isnan(decoded.get("Voltage")));
}

TEST_F(DbcFixture, DbcErrorExtendedMultiplexing) {
  EXPECT_EQ(warnings_for("BO_ 1 Loop: 8 N\n"
                         " SG_ A M : 0|8@1+ (1,0) [0|0] \"\" N\n"
                         " SG_ B m1M : 8|8@1+ (1,0) [0|0] \"\" N\n"
                         " SG_ C m1M : 16|8@1+ (1,0) [0|0] \"\" N\n"
                         "BO_ 2 Ambiguous: 8 N\n"
                         " SG_ A M : 0|8@1+ (1,0) [0|0] \"\" N\n"
                         " SG_ B M : 8|8@1+ (1,0) [0|0] \"\" N\n"
                         " SG_ C m1 : 16|8@1+ (1,0) [0|0] \"\" N\n"
                         " SG_ D m2 : 24|8@1+ (1,0) [0|0] \"\" N\n"
                         "BO_ 3 NotASwitch: 8 N\n"
                         " SG_ A M : 0|8@1+ (1,0) [0|0] \"\" N\n"
                         " SG_ B : 8|8@1+ (1,0) [0|0] \"\" N\n"
                         " SG_ C m1 : 16|8@1+ (1,0) [0|0] \"\" N\n"
                         "BO_ 4 NoSuchSwitch: 8 N\n"
                         " SG_ A M : 0|8@1+ (1,0) [0|0] \"\" N\n"
                         " SG_ C m1 : 16|8@1+ (1,0) [0|0] \"\" N\n"
                         "BO_ 5 TwoParents: 8 N\n"
                         " SG_ A M : 0|8@1+ (1,0) [0|0] \"\" N\n"
                         " SG_ B m1M : 8|8@1+ (1,0) [0|0] \"\" N\n"
                         " SG_ C m1 : 16|8@1+ (1,0) [0|0] \"\" N\n"
                         "BO_ 6 Empty: 8 N\n"
                         " SG_ A M : 0|8@1+ (1,0) [0|0] \"\" N\n"
                         " SG_ C m1 : 16|8@1+ (1,0) [0|0] \"\" N\n"
                         "BO_ 7 FloatSwitch: 8 N\n"
                         " SG_ A M : 0|8@1+ (1,0) [0|0] \"\" N\n"
                         " SG_ B m1M : 8|32@1+ (1,0) [0|0] \"\" N\n"
                         "SIG_VALTYPE_ 7 B : 1;\n"
                         "BO_ 8 NoValues: 8 N\n"
                         " SG_ A M : 0|8@1+ (1,0) [0|0] \"\" N\n"
                         " SG_ C m1 : 16|8@1+ (1,0) [0|0] \"\" N\n"
                         "BO_ 9 PlainTwice: 8 N\n"
                         " SG_ A M : 0|8@1+ (1,0) [0|0] \"\" N\n"
                         " SG_ B M : 8|8@1+ (1,0) [0|0] \"\" N\n"
                         " SG_ C m1 : 16|8@1+ (1,0) [0|0] \"\" N\n"
                         "BO_ 10 BrokenSwitch: 8 N\n"
                         " SG_ A M : 0|8@1+ (1,0) [0|0] \"\" N\n"
                         " SG_ B m1M : 8|8@1+ (0,0) [0|0] \"\" N\n"
                         " SG_ C m1 : 16|8@1+ (1,0) [0|0] \"\" N\n"
                         "SG_MUL_VAL_ 1 B C 1-1;\n"
                         "SG_MUL_VAL_ 1 C B 1-1;\n"
                         "SG_MUL_VAL_ 2 C A 1-2;\n"
                         "SG_MUL_VAL_ 3 C B 1-1;\n"
                         "SG_MUL_VAL_ 4 C Z 1-1;\n"
                         "SG_MUL_VAL_ 5 C A 1-1;\n"
                         "SG_MUL_VAL_ 5 C B 1-1;\n"
                         "SG_MUL_VAL_ 6 C A 3-1;\n"
                         "SG_MUL_VAL_ 8 C A ;\n"
                         "SG_MUL_VAL_ 9 C A 1-1;\n"  // restates m1 under the first M: plain
                         "SG_MUL_VAL_ 10 C B 1-1;\n"),
            (std::vector<std::string>{
                "odd.dbc:3:6: warning: message 'Loop' cannot be used: the multiplexers of signal 'B' select each "
                "other (a loop of SG_MUL_VAL_)",
                // A second M no SG_MUL_VAL_ puts under another, whatever else the message says.
                "odd.dbc:7:6: warning: message 'Ambiguous' cannot be used: message 'Ambiguous' already has a "
                "multiplexer, 'A'",
                "odd.dbc:27:20: warning: message 'FloatSwitch' cannot be used: multiplexer 'B' must be an integer "
                "signal",
                "odd.dbc:33:6: warning: message 'PlainTwice' cannot be used: message 'PlainTwice' already has a "
                "multiplexer, 'A'",
                // The switch's own problem, and nothing about the SG_MUL_VAL_ that names it.
                "odd.dbc:37:22: warning: message 'BrokenSwitch' cannot be used: the factor of signal 'B' must not "
                "be 0",
                "odd.dbc:42:17: warning: message 'NotASwitch' cannot be used: SG_MUL_VAL_ makes 'B' the multiplexer "
                "of 'C', but it is not a multiplexer (M or m<N>M)",
                "odd.dbc:43:17: warning: message 'NoSuchSwitch' cannot be used: SG_MUL_VAL_ names multiplexer 'Z', "
                "which message 'NoSuchSwitch' does not have",
                "odd.dbc:45:17: warning: message 'TwoParents' cannot be used: signal 'C' has SG_MUL_VAL_ lines "
                "naming two multiplexers, 'A' and 'B'",
                "odd.dbc:46:15: warning: message 'Empty' cannot be used: SG_MUL_VAL_ of signal 'C' has the empty "
                "range 3-1",
                "odd.dbc:47:15: warning: message 'NoValues' cannot be used: SG_MUL_VAL_ of signal 'C' lists no "
                "values",
            }));
  EXPECT_TRUE(registry_.declared().empty());
}

// A Motorola, signed switch with value ranges: a negative raw value selects nothing, and a
// clamped switch value decides what is packed.
TEST_F(DbcFixture, DbcExtendedMultiplexingSignedMotorolaSwitchWithRanges) {
  EXPECT_EQ(warnings_for("BO_ 1 Mixed: 8 N\n"
                         " SG_ Sel M : 7|8@0- (1,0) [0|0] \"\" N\n"
                         " SG_ Low m1 : 15|8@0+ (1,0) [0|0] \"\" N\n"
                         " SG_ High m6 : 15|8@0+ (1,0) [0|0] \"\" N\n"
                         "SG_MUL_VAL_ 1 Low Sel 1-5;\n"
                         "SG_MUL_VAL_ 1 High Sel 6-20, 100-127;\n"),
            std::vector<std::string>{});  // Low and High share a byte: their ranges are apart
  auto mixed = codec("odd::Mixed");
  ASSERT_NE(mixed, nullptr);
  const Type& t = type("odd::Mixed");
  expect_decoded(*mixed, t, Bytes{3, 9, 0, 0, 0, 0, 0, 0}, {{"Sel", 3}, {"Low", 9}, {"High", kNaN}});
  expect_decoded(*mixed, t, Bytes{20, 9, 0, 0, 0, 0, 0, 0}, {{"High", 9}, {"Low", kNaN}});
  expect_decoded(*mixed, t, Bytes{21, 9, 0, 0, 0, 0, 0, 0}, {{"High", kNaN}, {"Low", kNaN}});
  expect_decoded(*mixed, t, Bytes{0xFF, 9, 0, 0, 0, 0, 0, 0}, {{"Sel", -1}, {"High", kNaN}, {"Low", kNaN}});

  Sample out(t);
  out.set("Sel", 300.0);  // clamped to 127, which selects High
  out.set("Low", 1.0);
  out.set("High", 2.0);
  Bytes frame;
  const CodecResult encoded = encode(*mixed, out, frame);
  ASSERT_TRUE(encoded.ok());
  EXPECT_EQ(encoded.clamped, 1u);
  EXPECT_EQ(frame, (Bytes{127, 2, 0, 0, 0, 0, 0, 0}));
  out.set("Sel", 4.0);
  ASSERT_TRUE(encode(*mixed, out, frame).ok());
  EXPECT_EQ(frame, (Bytes{4, 1, 0, 0, 0, 0, 0, 0}));
}

// Values a switch cannot hold (past its bits, or a plain m<N> past them) select nothing: one
// warning for the file, the message stays usable and its other signals decode.
TEST_F(DbcFixture, DbcMultiplexerValuesPastTheSwitchAreWarnedOnce) {
  EXPECT_EQ(warnings_for("BO_ 1 Pids: 8 N\n"
                         " SG_ Sel M : 0|4@1- (1,0) [0|0] \"\" N\n"
                         " SG_ Low m1 : 8|8@1+ (1,0) [0|0] \"\" N\n"
                         " SG_ Far m2 : 16|8@1+ (1,0) [0|0] \"\" N\n"
                         " SG_ Plain m40 : 24|8@1+ (1,0) [0|0] \"\" N\n"
                         "SG_MUL_VAL_ 1 Far Sel 2-3, 6-9;\n"),
            std::vector<std::string>{"odd.dbc:4:6: warning: signal 'Far' is selected by the value(s) 6-9 of "
                                     "multiplexer 'Sel', which holds 0-7 (4 bits, signed): those values never "
                                     "select it (2 in this file)"});
  auto pids = codec("odd::Pids");
  ASSERT_NE(pids, nullptr);
  const Type& t = type("odd::Pids");
  expect_decoded(*pids, t, Bytes{1, 5, 6, 7, 0, 0, 0, 0}, {{"Sel", 1}, {"Low", 5}, {"Far", kNaN}, {"Plain", kNaN}});
  expect_decoded(*pids, t, Bytes{3, 5, 6, 7, 0, 0, 0, 0}, {{"Low", kNaN}, {"Far", 6}, {"Plain", kNaN}});
  diagnostics_ = Diagnostics();
  EXPECT_EQ(warnings_for("BO_ 1 Fits: 8 N\n"
                         " SG_ Sel M : 0|8@1+ (1,0) [0|0] \"\" N\n"
                         " SG_ Top m255 : 8|8@1+ (1,0) [0|0] \"\" N\n",
                         "fits.dbc"),
            std::vector<std::string>{});  // 255 is the last value of an unsigned byte
}

// More switches than the codec carries (kDbcMaxSwitches): unusable, with the reason.
TEST_F(DbcFixture, DbcExtendedMultiplexingPastTheCodecsLimitIsUnusable) {
  std::string text = "BO_ 1 Many: 8 N\n SG_ A M : 0|8@1+ (1,0) [0|0] \"\" N\n";
  for (std::size_t i = 0; i < kDbcMaxSwitches; ++i) {  // with A: one more than the limit
    text += " SG_ S" + std::to_string(i) + " m" + std::to_string(i) + "M : 8|1@1+ (1,0) [0|0] \"\" N\n";
  }
  EXPECT_EQ(warnings_for(text),
            std::vector<std::string>{"odd.dbc:1:7: warning: message 'Many' cannot be used: message 'Many' has more "
                                     "than 64 multiplexers"});
  EXPECT_EQ(registry_.find("odd::Many"), nullptr);
}

TEST_F(DbcFixture, DbcRealIntegerVFrameFormatAndDlcCodeLength) {
  ASSERT_TRUE(registry_.add_dbc_file(dbc_path("int_vframeformat.dbc"), diagnostics_))
      << ::testing::PrintToString(rendered(diagnostics_));
  EXPECT_EQ(relative(diagnostics_),
            std::vector<std::string>{
                "int_vframeformat.dbc:10:20: warning: length 10 read as a CAN FD DLC code: 16 bytes"});
  EXPECT_FALSE(message("int_vframeformat::Classic").fd);  // 3: J1939PG, the default
  EXPECT_EQ(message("int_vframeformat::Fd").length, 16u);
  EXPECT_TRUE(message("int_vframeformat::Fd").fd);
  EXPECT_TRUE(message("int_vframeformat::FdShort").fd);  // 14: StandardCAN_FD on 8 bytes
  EXPECT_EQ(message("int_vframeformat::FdShort").length, 8u);
}

TEST_F(DbcFixture, DbcRealUpperCaseExtensionIsADbcFile) {
  // Tools on Windows write ".DBC"; add_type_file (what the profile loader calls) takes it.
  const std::filesystem::path file =
      std::filesystem::path(::testing::TempDir()) / ("polyport_Upper_" + std::to_string(::getpid()) + ".DBC");
  {
    std::ofstream out(file, std::ios::binary);
    out << "BO_ 1 M: 1 N\n SG_ S : 0|8@1+ (1,0) [0|0] \"\" N\n";
  }
  EXPECT_TRUE(registry_.add_type_file(file, diagnostics_)) << ::testing::PrintToString(rendered(diagnostics_));
  EXPECT_TRUE(diagnostics_.all().empty()) << ::testing::PrintToString(rendered(diagnostics_));
  EXPECT_EQ(dbc_databases(registry_).size(), 1u);
  std::filesystem::remove(file);
}

TEST_F(DbcFixture, DbcRealUnknownStatementOfANewerToolIsSkippedWithOneWarning) {
  EXPECT_EQ(warnings_for("BO_ 1 M: 1 N\n SG_ S : 0|8@1+ (1,0) [0|0] \"\" N\n"
                         "NEW_THING_ 1 \"a\" 2;\nNEW_THING_ 2 \"b\";\nSIG_GROUP_ 1 G 1 : S;\n"),
            (std::vector<std::string>{
                "odd.dbc:3:1: warning: unknown statement 'NEW_THING_' is ignored (2 in this file)",
                "odd.dbc:5:1: warning: SIG_GROUP_ statements are not used by polyport and are ignored (1 in this "
                "file)",
            }));
  EXPECT_NE(registry_.find("odd::M"), nullptr);
}

TEST(DbcHelpers, CanFdLengthsAndNetworkBits) {
  EXPECT_EQ(can_dlc_to_length(8), 8u);
  EXPECT_EQ(can_dlc_to_length(9), 12u);
  EXPECT_EQ(can_dlc_to_length(13), 32u);
  EXPECT_EQ(can_dlc_to_length(15), 64u);
  EXPECT_EQ(can_length_to_dlc(8), 8u);
  EXPECT_EQ(can_length_to_dlc(9), 9u);  // padded up to 12
  EXPECT_EQ(can_length_to_dlc(33), 14u);
  EXPECT_EQ(can_length_to_dlc(64), 15u);
  EXPECT_TRUE(is_can_data_length(48));
  EXPECT_FALSE(is_can_data_length(9));
  EXPECT_FALSE(is_can_data_length(65));
  // Section 2.7: n = 8*(s/8) + 7 - s%8.
  EXPECT_EQ(dbc_network_bit(0), 7u);
  EXPECT_EQ(dbc_network_bit(7), 0u);
  EXPECT_EQ(dbc_network_bit(27), 28u);
  EXPECT_EQ(dbc_network_bit(dbc_network_bit(300)), 300u);
}

}  // namespace
