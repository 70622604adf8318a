// DBC files as a type source: the frame layout of every CAN message a DBC file declares.
//
// parse_dbc (dbc_parser.hpp), behind TypeRegistry::add_dbc_file, turns each message into a
// struct type named "<db>::<Message>" (<db> = the file stem as an identifier) with one
// `double` field per signal, in declaration order, holding the physical value (raw * factor
// + offset). The type's `dbc` member points at the DbcMessage below, which make_dbc_codec
// (dbc_codec.cpp) uses to pack and unpack frames. Everything here is built once at load time and immutable
// afterwards; the registry keeps it alive (TypeRegistry::retain).
//
// Multiplexed messages are flat too: every signal is a field. A multiplexer (switch) field
// selects which multiplexed signals are in the frame: decode writes NaN to the fields of the
// ones that are absent, and encode packs only the ones that are present (the others are
// ignored, whatever they hold). Plain multiplexing: one `M` switch, and `m<N>` signals present
// when its raw value is N. Extended multiplexing (SG_MUL_VAL_): a multiplexed signal names its
// switch and the ranges of raw values that select it, and a switch may itself be multiplexed
// (`m<N>M`), so switches nest; a signal is present when its switch is present and holds one of
// its values (DbcSignal::mux_parent, mux_ranges).
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "polyport/base/diagnostics.hpp"
#include "polyport/types/types.hpp"

namespace polyport {

// SocketCAN's canid_t flag for a 29-bit id; DBC files mark extended ids with the same bit.
inline constexpr std::uint32_t kCanExtendedFlag = 0x80000000u;
inline constexpr std::uint32_t kCanStandardIdMask = 0x7FFu;
inline constexpr std::uint32_t kCanExtendedIdMask = 0x1FFFFFFFu;
inline constexpr std::uint32_t kCanMaxDataLength = 64;  // CAN FD; classic CAN carries 8
// What the DBC codec carries in one message (it keeps the switches' values on the stack and
// numbers signals and value ranges in 16 bits); the loader declares a message past them unusable.
inline constexpr std::size_t kDbcMaxSwitches = 64;
inline constexpr std::size_t kDbcMaxSignals = 65535;
inline constexpr std::size_t kDbcMaxMuxRanges = 65535;

// CAN FD maps DLC codes 9..15 to 12, 16, 20, 24, 32, 48, 64 data bytes; 0..8 are lengths.
constexpr std::uint32_t can_dlc_to_length(std::uint32_t dlc) noexcept {
  constexpr std::uint8_t kFdLengths[] = {12, 16, 20, 24, 32, 48, 64};
  return dlc <= 8 ? dlc : dlc <= 15 ? kFdLengths[dlc - 9] : kCanMaxDataLength;
}
// The smallest DLC code whose frame holds `length` bytes (a CAN FD frame pads up to it).
constexpr std::uint32_t can_length_to_dlc(std::uint32_t length) noexcept {
  std::uint32_t dlc = 0;
  while (dlc < 15 && can_dlc_to_length(dlc) < length) ++dlc;
  return dlc;
}
// A data length a CAN or CAN FD frame can have exactly (0..8, 12, 16, 20, 24, 32, 48, 64).
constexpr bool is_can_data_length(std::uint32_t length) noexcept {
  return length <= kCanMaxDataLength && can_dlc_to_length(can_length_to_dlc(length)) == length;
}

// DBC numbers bits "sawtooth" style: bit b of byte B is 8B + b, bit 7 being the byte's MSB.
// The network bit is the same bit counted from the MSB of byte 0 (the payload read as one
// big-endian bit string). The mapping is its own inverse.
constexpr std::uint32_t dbc_network_bit(std::uint32_t sawtooth_bit) noexcept {
  return (sawtooth_bit & ~7u) + 7u - (sawtooth_bit & 7u);
}

enum class DbcByteOrder : std::uint8_t {
  intel,     // `@1`: little-endian, the start bit is the LSB
  motorola,  // `@0`: big-endian, the start bit is the MSB
};

enum class DbcFloatKind : std::uint8_t {
  none,     // an integer (SIG_VALTYPE_ 0 or none)
  float32,  // SIG_VALTYPE_ 1: IEEE 754 single, 32 bits
  float64,  // SIG_VALTYPE_ 2: IEEE 754 double, 64 bits
};

enum class DbcMuxRole : std::uint8_t {
  none,
  multiplexer,  // `M`: a switch (in every frame, unless an SG_MUL_VAL_ puts it under another)
  multiplexed,  // `m<N>` or `m<N>M`: in the frame only when its switch selects it
};

// Raw values of a switch, both ends included.
struct DbcMuxRange {
  std::int64_t low = 0;
  std::int64_t high = 0;
  bool operator==(const DbcMuxRange&) const = default;
};

struct DbcSignal {
  std::string name;
  std::uint32_t start_bit = 0;  // as written: the LSB (Intel) or the MSB (Motorola)
  std::uint32_t length = 0;     // bits, 1..64
  DbcByteOrder byte_order = DbcByteOrder::intel;
  bool is_signed = false;       // two's complement (`-`)
  DbcFloatKind float_kind = DbcFloatKind::none;
  double factor = 1.0;
  double offset = 0.0;
  double minimum = 0.0;  // physical; a range only when minimum < maximum ([0|0] is "none")
  double maximum = 0.0;
  std::string unit;
  std::vector<std::string> receivers;  // without Vector__XXX
  DbcMuxRole mux_role = DbcMuxRole::none;
  bool mux_switch = false;             // `m<N>M`: multiplexed, and a switch of others itself
  std::int64_t mux_value = 0;          // multiplexed: N as written in `m<N>`
  // Multiplexed: the index of the switch that selects it and that switch's raw values that do
  // (as the switch's raw integer, signed if the switch is: a signed switch's negative values
  // select nothing, ranges being non-negative). An SG_MUL_VAL_ line gives both; without one an
  // `m<N>` signal belongs to the message's one `M` with the value N. -1 and none for a signal
  // in every frame. Set for every multiplexed signal of a usable message.
  std::int32_t mux_parent = -1;
  std::vector<DbcMuxRange> mux_ranges;
  std::map<std::int64_t, std::string> value_table;  // VAL_: raw value -> description
  std::string comment;
  SourceLocation where;  // the signal's name in the SG_ line

  // Where the bits are, precomputed by the loader from start_bit, length and byte_order
  // (sawtooth numbers; bytes are indices into the frame's data).
  std::uint32_t lsb_bit = 0;
  std::uint32_t msb_bit = 0;
  std::uint32_t first_byte = 0;  // the lowest and highest byte holding any of its bits
  std::uint32_t last_byte = 0;

  bool has_range() const noexcept { return minimum < maximum; }
  // A switch: `M`, or `m<N>M`.
  bool is_switch() const noexcept { return mux_role == DbcMuxRole::multiplexer || mux_switch; }
};

struct DbcDatabase;

struct DbcMessage {
  std::uint32_t frame_id = 0;  // the 11- or 29-bit identifier, without flags
  bool extended = false;       // bit 31 of the DBC id
  std::string name;
  std::uint32_t length = 0;    // data bytes (DBC writes the length, not the DLC code), 0..64
  bool fd = false;             // a CAN FD frame: longer than 8 bytes, or VFrameFormat *_FD
  bool bit_rate_switch = false;  // CANFD_BRS
  std::string transmitter;     // empty for Vector__XXX
  std::vector<DbcSignal> signals;  // declaration order = the type's field order
  std::int32_t multiplexer = -1;   // index of the (first) `M` signal, or -1
  std::uint32_t cycle_time_ms = 0;  // GenMsgCycleTime (or its default); 0: none
  std::string comment;
  SourceLocation where;        // the message's name in the BO_ line
  const Type* type = nullptr;  // the registered struct (null if its name was taken)
  const DbcDatabase* database = nullptr;

  // The id as SocketCAN's canid_t spells it (kCanExtendedFlag for 29-bit ids).
  std::uint32_t can_id() const noexcept { return frame_id | (extended ? kCanExtendedFlag : 0u); }
  const DbcSignal* find_signal(std::string_view signal_name) const noexcept;
};

struct DbcNode {
  std::string name;
  std::string comment;
};

struct DbcDatabase {
  std::string name;     // the types' namespace: the file stem as an identifier
  std::string file;
  std::string version;  // VERSION
  std::string comment;  // the global CM_
  std::vector<DbcNode> nodes;  // BU_
  std::map<std::string, std::map<std::int64_t, std::string>, std::less<>> value_tables;  // VAL_TABLE_
  std::vector<DbcMessage> messages;  // file order; never resized after loading
  // (can_id(), index into messages), sorted, so a frame finds its message without a scan.
  std::vector<std::pair<std::uint32_t, std::uint32_t>> by_can_id;

  // By the id in a received frame: `can_id` is a canid_t (kCanExtendedFlag for 29-bit ids;
  // the RTR and error flags are ignored). No allocation, no lock: usable per frame.
  const DbcMessage* find_message(std::uint32_t can_id) const noexcept;
  const DbcMessage* find_message(std::string_view message_name) const noexcept;
};

// The DBC files a registry has loaded (those with at least one registered message), in
// load order, and one of them by its name (the types' namespace).
std::vector<const DbcDatabase*> dbc_databases(const TypeRegistry& registry);
const DbcDatabase* find_dbc_database(const TypeRegistry& registry, std::string_view name);

}  // namespace polyport
