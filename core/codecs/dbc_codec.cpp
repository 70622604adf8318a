// The DBC codec: between a DBC message's flat struct (one double per signal, physical
// units) and a CAN frame's data bytes (WireFormat::dbc).
//
// Buffers and threads: the caller owns `wire` and `flat` for the duration of one call;
// the codec keeps no pointer to either. decode and encode run on whichever thread
// forwards the frame, any number at once: the codec is immutable after make_dbc_codec,
// and they touch nothing but the caller's buffers and their own stack (no allocation, no
// lock, no exception). Frames shorter than 8 bytes are worked on in an 8-byte stack copy.
//
// Every signal's bits are a run in one 64-bit window of the frame (loaded little-endian
// for Intel, big-endian for Motorola), plus a few bits of a ninth byte when a long signal
// starts mid-byte. The window, shift and mask are worked out once, here, from the DBC
// start bit; pack and unpack are then a load, a shift and a mask per signal.
//
// Multiplexed messages (plain and extended): decode writes NaN to the field of every
// multiplexed signal its switch does not select; encode packs only the signals their switches
// select and ignores the other fields. Switches come before the signals they select (the
// evaluation order, worked out here), so one pass decides presence from the switches' raw
// values already read or packed; a message without switches skips all of it.
#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "polyport/codecs/codec.hpp"
#include "polyport/types/dbc.hpp"

namespace polyport {

namespace {

enum class RawKind : std::uint8_t { unsigned_int, signed_int, float32, float64 };

struct SignalSlot {
  std::uint64_t mask = 0;       // the signal's low `length` bits
  double factor = 1.0;
  double offset = 0.0;
  double minimum = 0.0;
  double maximum = 0.0;
  double raw_low = 0.0;         // integers: the smallest raw value
  double raw_end = 0.0;         // integers: one past the largest raw value (exact in double)
  std::int64_t raw_low_int = 0;
  std::uint64_t raw_high = 0;   // the largest raw value, as bits
  std::uint32_t field_offset = 0;
  std::int16_t parent_switch = -1;  // the number of the switch that selects it; -1: always there
  std::int16_t own_switch = -1;     // its number as a switch; -1: not one
  std::uint16_t ranges_begin = 0;   // the parent's raw values that select it: DbcCodec::ranges_
  std::uint16_t ranges_end = 0;
  std::uint32_t window = 0;     // index of the first byte of the 8-byte window
  std::uint8_t shift = 0;       // right shift that brings the LSB to bit 0 (no spill)
  std::uint8_t spill = 0;       // bits in the byte after the window (0: none)
  std::uint8_t sign_shift = 0;  // 64 - length, for sign extension
  bool motorola = false;
  bool has_range = false;
  RawKind kind = RawKind::unsigned_int;
};

inline std::uint64_t load_le(const std::uint8_t* bytes) noexcept {
  std::uint64_t word;
  std::memcpy(&word, bytes, sizeof word);
  if constexpr (std::endian::native == std::endian::big) word = __builtin_bswap64(word);
  return word;
}
inline std::uint64_t load_be(const std::uint8_t* bytes) noexcept {
  std::uint64_t word;
  std::memcpy(&word, bytes, sizeof word);
  if constexpr (std::endian::native == std::endian::little) word = __builtin_bswap64(word);
  return word;
}
inline void store_le(std::uint8_t* bytes, std::uint64_t word) noexcept {
  if constexpr (std::endian::native == std::endian::big) word = __builtin_bswap64(word);
  std::memcpy(bytes, &word, sizeof word);
}
inline void store_be(std::uint8_t* bytes, std::uint64_t word) noexcept {
  if constexpr (std::endian::native == std::endian::little) word = __builtin_bswap64(word);
  std::memcpy(bytes, &word, sizeof word);
}

inline std::uint64_t extract(const SignalSlot& slot, const std::uint8_t* bytes) noexcept {
  if (!slot.motorola) {
    std::uint64_t raw = load_le(bytes + slot.window) >> slot.shift;
    // Spill only happens with shift >= 1, so the left shift stays below 64.
    if (slot.spill != 0) raw |= static_cast<std::uint64_t>(bytes[slot.window + 8]) << (64 - slot.shift);
    return raw & slot.mask;
  }
  const std::uint64_t word = load_be(bytes + slot.window);
  if (slot.spill != 0) {
    return ((word << slot.spill) | (bytes[slot.window + 8] >> (8 - slot.spill))) & slot.mask;
  }
  return (word >> slot.shift) & slot.mask;
}

// ORs `raw` (already masked) into a zeroed frame.
inline void insert(const SignalSlot& slot, std::uint8_t* bytes, std::uint64_t raw) noexcept {
  std::uint8_t* window = bytes + slot.window;
  if (!slot.motorola) {
    store_le(window, load_le(window) | (raw << slot.shift));
    if (slot.spill != 0) window[8] |= static_cast<std::uint8_t>(raw >> (64 - slot.shift));
    return;
  }
  if (slot.spill != 0) {
    store_be(window, load_be(window) | (raw >> slot.spill));
    window[8] |= static_cast<std::uint8_t>(raw << (8 - slot.spill));
    return;
  }
  store_be(window, load_be(window) | (raw << slot.shift));
}

inline std::int64_t signed_raw(const SignalSlot& slot, std::uint64_t raw) noexcept {
  return static_cast<std::int64_t>(raw << slot.sign_shift) >> slot.sign_shift;
}

inline double to_physical(const SignalSlot& slot, std::uint64_t raw) noexcept {
  switch (slot.kind) {
    case RawKind::unsigned_int: return static_cast<double>(raw) * slot.factor + slot.offset;
    case RawKind::signed_int: return static_cast<double>(signed_raw(slot, raw)) * slot.factor + slot.offset;
    case RawKind::float32:
      return static_cast<double>(std::bit_cast<float>(static_cast<std::uint32_t>(raw))) * slot.factor +
             slot.offset;
    case RawKind::float64: return std::bit_cast<double>(raw) * slot.factor + slot.offset;
  }
  return 0.0;
}

// physical -> raw bits; false for NaN. Counts at most one clamp per signal.
inline bool to_raw(const SignalSlot& slot, double physical, std::uint64_t& raw,
                   std::uint32_t& clamped) noexcept {
  if (std::isnan(physical)) return false;
  bool was_clamped = false;
  if (slot.has_range) {
    if (physical < slot.minimum) {
      physical = slot.minimum;
      was_clamped = true;
    } else if (physical > slot.maximum) {
      physical = slot.maximum;
      was_clamped = true;
    }
  }
  double scaled = (physical - slot.offset) / slot.factor;
  switch (slot.kind) {
    case RawKind::float32: {
      // Finite values beyond float's range are clamped; infinities are IEEE values.
      constexpr double kMax = std::numeric_limits<float>::max();
      if (std::isfinite(scaled) && std::fabs(scaled) > kMax) {
        scaled = scaled > 0 ? kMax : -kMax;
        was_clamped = true;
      }
      raw = std::bit_cast<std::uint32_t>(static_cast<float>(scaled));
      break;
    }
    case RawKind::float64: raw = std::bit_cast<std::uint64_t>(scaled); break;
    case RawKind::unsigned_int:
    case RawKind::signed_int: {
      const double rounded = std::round(scaled);
      if (rounded < slot.raw_low) {  // also -infinity
        raw = static_cast<std::uint64_t>(slot.raw_low_int);
        was_clamped = true;
      } else if (rounded >= slot.raw_end) {  // also +infinity
        raw = slot.raw_high;
        was_clamped = true;
      } else if (slot.kind == RawKind::signed_int) {
        raw = static_cast<std::uint64_t>(static_cast<std::int64_t>(rounded));
      } else {
        raw = static_cast<std::uint64_t>(rounded);
      }
      break;
    }
  }
  raw &= slot.mask;
  clamped += was_clamped ? 1u : 0u;
  return true;
}

// Switches a message may have (their raw values are kept on the stack while a frame is worked on).
constexpr std::size_t kMaxSwitches = kDbcMaxSwitches;

struct Multiplexing {
  std::vector<std::uint16_t> order;  // slots, every switch before the signals it selects
  std::vector<DbcMuxRange> ranges;
};

class DbcCodec final : public Codec {
 public:
  DbcCodec(const Type& type, const Type& layout, std::uint32_t length, std::vector<SignalSlot> slots,
           Multiplexing multiplexing)
      : type_(type), layout_size_(layout.size), length_(length), slots_(std::move(slots)),
        order_(std::move(multiplexing.order)), ranges_(std::move(multiplexing.ranges)) {}

  WireFormat format() const noexcept override { return WireFormat::dbc; }
  const Type& type() const noexcept override { return type_; }
  const void* program_data() const noexcept override { return slots_.data(); }
  std::uint32_t max_wire_size(std::uint32_t) const noexcept override { return length_; }

  CodecResult decode(const std::byte* wire, std::uint32_t wire_size, std::byte* flat,
                     std::uint32_t flat_capacity) const noexcept override {
    if (wire_size != length_) return {CodecError::wrong_size, 0, 0};
    if (flat_capacity < layout_size_) return {CodecError::output_too_small, 0, 0};
    const auto* bytes = reinterpret_cast<const std::uint8_t*>(wire);
    std::uint8_t short_frame[8];
    if (length_ < 8) {
      std::memset(short_frame, 0, sizeof short_frame);
      if (length_ != 0) std::memcpy(short_frame, bytes, length_);
      bytes = short_frame;
    }
    if (order_.empty()) {
      for (const SignalSlot& slot : slots_) {
        const double value = to_physical(slot, extract(slot, bytes));
        std::memcpy(flat + slot.field_offset, &value, sizeof value);
      }
      return {CodecError::ok, layout_size_, 0};
    }
    Switches switches;
    for (const std::uint16_t index : order_) {
      const SignalSlot& slot = slots_[index];
      double value = std::numeric_limits<double>::quiet_NaN();
      const bool present = switches.selects(*this, slot);
      std::uint64_t raw = 0;
      if (present) {
        raw = extract(slot, bytes);
        value = to_physical(slot, raw);
      }
      switches.set(slot, present, raw);
      std::memcpy(flat + slot.field_offset, &value, sizeof value);
    }
    return {CodecError::ok, layout_size_, 0};
  }

  CodecResult encode(const std::byte* flat, std::uint32_t flat_size, std::byte* wire,
                     std::uint32_t wire_capacity) const noexcept override {
    if (flat_size < layout_size_) return {CodecError::truncated, 0, 0};
    if (wire_capacity < length_) return {CodecError::output_too_small, 0, 0};
    std::uint8_t short_frame[8];
    auto* bytes = length_ < 8 ? short_frame : reinterpret_cast<std::uint8_t*>(wire);
    std::memset(bytes, 0, length_ < 8 ? sizeof short_frame : length_);
    std::uint32_t clamped = 0;
    std::uint64_t raw = 0;
    if (order_.empty()) {
      for (const SignalSlot& slot : slots_) {
        if (!to_raw(slot, field(flat, slot), raw, clamped)) return {CodecError::bad_value, 0, 0};
        insert(slot, bytes, raw);
      }
    } else {
      // A switch's (clamped) raw value decides what it selects.
      Switches switches;
      for (const std::uint16_t index : order_) {
        const SignalSlot& slot = slots_[index];
        const bool present = switches.selects(*this, slot);
        if (present) {
          if (!to_raw(slot, field(flat, slot), raw, clamped)) return {CodecError::bad_value, 0, 0};
          insert(slot, bytes, raw);
        }
        switches.set(slot, present, raw);
      }
    }
    if (length_ < 8 && length_ != 0) std::memcpy(wire, short_frame, length_);
    return {CodecError::ok, length_, clamped};
  }

 private:
  // The switches' state while one frame is worked on: which are in the frame, and their values.
  // Every switch is written before what it selects reads it (the order), so `value` needs no
  // zeroing; `present` is zeroed as a guard (64 bytes).
  struct Switches {
    std::array<std::int64_t, kMaxSwitches> value;
    std::array<bool, kMaxSwitches> present{};

    bool selects(const DbcCodec& codec, const SignalSlot& slot) const noexcept {
      if (slot.parent_switch < 0) return true;
      const auto parent = static_cast<std::size_t>(slot.parent_switch);
      if (!present[parent]) return false;
      for (std::uint16_t i = slot.ranges_begin; i < slot.ranges_end; ++i) {
        const DbcMuxRange& range = codec.ranges_[i];
        if (value[parent] >= range.low && value[parent] <= range.high) return true;
      }
      return false;
    }
    void set(const SignalSlot& slot, bool in_frame, std::uint64_t raw) noexcept {
      if (slot.own_switch < 0) return;
      const auto own = static_cast<std::size_t>(slot.own_switch);
      present[own] = in_frame;
      value[own] = slot.kind == RawKind::signed_int ? signed_raw(slot, raw) : static_cast<std::int64_t>(raw);
    }
  };

  static double field(const std::byte* flat, const SignalSlot& slot) noexcept {
    double value;
    std::memcpy(&value, flat + slot.field_offset, sizeof value);
    return value;
  }

  const Type& type_;
  std::uint32_t layout_size_;
  std::uint32_t length_;
  std::vector<SignalSlot> slots_;
  std::vector<std::uint16_t> order_;  // empty: no switches, the slots in their order
  std::vector<DbcMuxRange> ranges_;
};

// Works out where a signal's bits are; the message's checks have passed.
SignalSlot make_slot(const DbcSignal& signal, std::uint32_t length, const Field& field) {
  SignalSlot slot;
  slot.field_offset = field.offset;
  slot.factor = signal.factor;
  slot.offset = signal.offset;
  slot.minimum = signal.minimum;
  slot.maximum = signal.maximum;
  slot.has_range = signal.has_range();
  slot.motorola = signal.byte_order == DbcByteOrder::motorola;
  slot.mask = signal.length == 64 ? ~std::uint64_t{0} : (std::uint64_t{1} << signal.length) - 1;
  slot.sign_shift = static_cast<std::uint8_t>(64 - signal.length);
  switch (signal.float_kind) {
    case DbcFloatKind::float32: slot.kind = RawKind::float32; break;
    case DbcFloatKind::float64: slot.kind = RawKind::float64; break;
    case DbcFloatKind::none:
      slot.kind = signal.is_signed ? RawKind::signed_int : RawKind::unsigned_int;
      break;
  }
  if (slot.kind == RawKind::signed_int) {
    slot.raw_low = -std::ldexp(1.0, static_cast<int>(signal.length) - 1);
    slot.raw_end = std::ldexp(1.0, static_cast<int>(signal.length) - 1);
    slot.raw_low_int = signal.length == 64 ? std::numeric_limits<std::int64_t>::min()
                                           : -(std::int64_t{1} << (signal.length - 1));
    slot.raw_high = slot.mask >> 1;
  } else {
    slot.raw_low = 0.0;
    slot.raw_end = std::ldexp(1.0, static_cast<int>(signal.length));
    slot.raw_high = slot.mask;
  }
  // The window stays inside the frame when the frame has 8 bytes or more (so the frame
  // is read in place); a shorter frame is copied into 8 bytes first.
  const std::uint32_t first = slot.motorola ? dbc_network_bit(signal.start_bit) : signal.start_bit;
  const std::uint32_t first_byte = first / 8;
  slot.window = length >= 8 ? std::min(first_byte, length - 8) : 0;
  const std::uint32_t offset = first - 8 * slot.window;  // bits before the signal in the window
  if (offset + signal.length > 64) {
    slot.spill = static_cast<std::uint8_t>(offset + signal.length - 64);
    slot.shift = static_cast<std::uint8_t>(offset);  // Intel: the LSB's position
  } else {
    slot.shift = static_cast<std::uint8_t>(slot.motorola ? 64 - offset - signal.length : offset);
  }
  return slot;
}

}  // namespace

Result<std::unique_ptr<Codec>> make_dbc_codec(const Type& type) {
  const Type& layout = type.resolved();
  const DbcMessage* message = layout.dbc;
  if (layout.origin != TypeOrigin::dbc || message == nullptr || layout.kind != TypeKind::structure) {
    return make_error("type '" + type.name +
                      "' does not come from a DBC file; only DBC messages travel as CAN frames");
  }
  const std::string where = "DBC message '" + message->name + "' (type '" + type.name + "')";
  if (message->length > kCanMaxDataLength) {
    return make_error(where + ": length " + std::to_string(message->length) + " is more than 64 bytes");
  }
  if (layout.fields.size() != message->signals.size()) {
    return make_error(where + ": the type has " + std::to_string(layout.fields.size()) + " fields for " +
                      std::to_string(message->signals.size()) + " signals");
  }
  std::vector<SignalSlot> slots;
  slots.reserve(message->signals.size());
  std::vector<std::int16_t> switch_of(message->signals.size(), -1);
  std::int16_t switches = 0;
  for (std::size_t i = 0; i < message->signals.size(); ++i) {
    const DbcSignal& signal = message->signals[i];
    const Field& field = layout.fields[i];
    const std::string what = where + ": signal '" + signal.name + "'";
    const bool is_double = field.type != nullptr && field.type->resolved().kind == TypeKind::float64;
    if (field.name != signal.name || !is_double || field.offset + sizeof(double) > layout.size) {
      return make_error(what + ": field " + std::to_string(i) + " of the type is not its double");
    }
    if (signal.length < 1 || signal.length > 64) return make_error(what + ": length must be 1 to 64 bits");
    const std::uint32_t first =
        signal.byte_order == DbcByteOrder::motorola ? dbc_network_bit(signal.start_bit) : signal.start_bit;
    if (signal.start_bit >= 8 * kCanMaxDataLength || first + signal.length > 8 * message->length) {
      return make_error(what + ": does not fit in the " + std::to_string(message->length) + "-byte frame");
    }
    const std::uint32_t float_bits = signal.float_kind == DbcFloatKind::float32   ? 32
                                     : signal.float_kind == DbcFloatKind::float64 ? 64
                                                                                  : signal.length;
    if (float_bits != signal.length) return make_error(what + ": a float signal needs 32 bits, a double 64");
    if (!(signal.factor != 0.0) || !std::isfinite(signal.factor) || !std::isfinite(signal.offset)) {
      return make_error(what + ": the factor must be finite and not 0, the offset finite");
    }
    if (signal.is_switch()) {
      if (signal.float_kind != DbcFloatKind::none) return make_error(what + ": a multiplexer must be an integer");
      if (static_cast<std::size_t>(switches) == kMaxSwitches) {
        return make_error(where + ": more than " + std::to_string(kMaxSwitches) + " multiplexers");
      }
      switch_of[i] = switches++;
    }
    slots.push_back(make_slot(signal, message->length, field));
    slots.back().own_switch = switch_of[i];
  }
  Multiplexing multiplexing;
  if (switches == 0) {
    for (const DbcSignal& signal : message->signals) {
      if (signal.mux_role == DbcMuxRole::multiplexed) {
        return make_error(where + ": signal '" + signal.name + "' is multiplexed but there is no multiplexer");
      }
    }
    return std::unique_ptr<Codec>(std::make_unique<DbcCodec>(type, layout, message->length, std::move(slots),
                                                             std::move(multiplexing)));
  }
  // How deep each signal sits under switches; the loader refuses loops, this only guards.
  const std::size_t count = message->signals.size();
  std::vector<std::size_t> depth(count, 0);
  for (std::size_t i = 0; i < count; ++i) {
    const DbcSignal& signal = message->signals[i];
    if (signal.mux_role != DbcMuxRole::multiplexed) continue;
    const std::string what = where + ": signal '" + signal.name + "'";
    const std::int32_t parent = signal.mux_parent;
    if (parent < 0 || static_cast<std::size_t>(parent) >= count || switch_of[static_cast<std::size_t>(parent)] < 0 ||
        signal.mux_ranges.empty()) {
      return make_error(what + ": is multiplexed but has no multiplexer");
    }
    for (std::int32_t at = parent; at >= 0; at = message->signals[static_cast<std::size_t>(at)].mux_parent) {
      if (static_cast<std::size_t>(at) >= count || ++depth[i] > count) {
        return make_error(what + ": its multiplexers select each other");
      }
    }
    SignalSlot& slot = slots[i];
    slot.parent_switch = switch_of[static_cast<std::size_t>(parent)];
    if (multiplexing.ranges.size() + signal.mux_ranges.size() > kDbcMaxMuxRanges) {
      return make_error(where + ": too many multiplexer value ranges");
    }
    slot.ranges_begin = static_cast<std::uint16_t>(multiplexing.ranges.size());
    multiplexing.ranges.insert(multiplexing.ranges.end(), signal.mux_ranges.begin(), signal.mux_ranges.end());
    slot.ranges_end = static_cast<std::uint16_t>(multiplexing.ranges.size());
  }
  if (count > kDbcMaxSignals) return make_error(where + ": too many signals");
  for (std::size_t i = 0; i < count; ++i) multiplexing.order.push_back(static_cast<std::uint16_t>(i));
  std::stable_sort(multiplexing.order.begin(), multiplexing.order.end(),
                   [&](std::uint16_t a, std::uint16_t b) { return depth[a] < depth[b]; });
  return std::unique_ptr<Codec>(std::make_unique<DbcCodec>(type, layout, message->length, std::move(slots),
                                                           std::move(multiplexing)));
}

}  // namespace polyport
