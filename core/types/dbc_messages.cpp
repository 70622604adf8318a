// The DBC parser's BO_ and SG_ statements (DbcParser, dbc_parser_impl.hpp): a message's id,
// length and transmitter, and each signal's place in the frame: start bit, length, byte
// order, the bytes it covers, multiplexing, and overlaps with the signals before it.
#include <algorithm>
#include <array>
#include <charconv>
#include <cstdint>
#include <string>
#include <string_view>
#include <system_error>
#include <utility>

#include "dbc_lexer.hpp"
#include "dbc_parser_impl.hpp"
#include "polyport/types/dbc.hpp"

namespace polyport::dbc_detail {

bool DbcParser::message() {
  const Token* id_token = nullptr;
  std::uint64_t dbc_id = 0;
  in_message_ = true;  // its SG_ lines follow even when this line is bad
  if (!unsigned_integer("the message id", dbc_id, &id_token)) return false;
  const Token* name = nullptr;
  if (!expect_identifier("the message name", name)) return false;

  // Known by id and name from here on, so statements that refer to it do not add errors
  // of their own when the rest of the line is bad.
  ParsedMessage parsed;
  DbcMessage& message = parsed.message;
  message.name = std::string(name->text);
  message.where = where(*name);
  parsed.pseudo = name->text == kIndependentSignals;
  const Token* length_token = nullptr;
  const Token* transmitter = nullptr;
  std::uint64_t length = 0;
  bool line_ok = expect(':', "after the message name") &&
                 unsigned_integer("the message length in bytes", length, &length_token) &&
                 expect_identifier("the transmitting node", transmitter);
  if (line_ok && !peek().first_on_line) {
    error(peek(), "unexpected " + describe(peek()) + " after the message's transmitter");
    line_ok = false;
  }
  if (!line_ok) {
    parsed.broken = true;
  } else {
    message.transmitter = transmitter->text == kNoNode ? std::string() : std::string(transmitter->text);
  }
  if (line_ok && !parsed.pseudo) {
    message.extended = (dbc_id & kCanExtendedFlag) != 0;
    const std::uint64_t id = dbc_id & ~static_cast<std::uint64_t>(kCanExtendedFlag);
    if (dbc_id > 0xFFFFFFFFu || (message.extended && id > kCanExtendedIdMask)) {
      message_problem(parsed, *id_token, "message id " + std::string(id_token->text) +
                                             " is not a CAN id (29 bits, plus bit 31 for extended frames)");
    } else if (!message.extended && id > kCanStandardIdMask) {
      message_problem(parsed, *id_token, "standard frame id " + hex(id) +
                                             " does not fit in 11 bits (extended ids have bit 31 set: " +
                                             std::to_string(id | kCanExtendedFlag) + ")");
    }
    message.frame_id = static_cast<std::uint32_t>(id & 0xFFFFFFFFu);
    if (length > kCanMaxDataLength) {
      message_problem(parsed, *length_token, "message length " + std::string(length_token->text) +
                                                 " is more than the 64 bytes of a CAN FD frame");
    } else if (!is_can_data_length(static_cast<std::uint32_t>(length))) {
      if (length <= 15) {
        // Some tools write the CAN FD DLC code instead of the length.
        const std::uint32_t bytes = can_dlc_to_length(static_cast<std::uint32_t>(length));
        warning(*length_token, "length " + std::string(length_token->text) +
                                   " read as a CAN FD DLC code: " + std::to_string(bytes) + " bytes");
        length = bytes;
      } else {
        message_problem(parsed, *length_token,
                        "message length " + std::string(length_token->text) +
                            " is not a CAN FD frame length (0-8, 12, 16, 20, 24, 32, 48, 64)");
      }
    }
    message.length = static_cast<std::uint32_t>(std::min<std::uint64_t>(length, kCanMaxDataLength));
    message.fd = message.length > 8;
  }

  if (auto it = message_names_.find(message.name); it != message_names_.end()) {
    message_problem(parsed, *name, "message '" + message.name + "' is already defined at line " +
                                       std::to_string(messages_[it->second].message.where.line));
  }
  if (auto it = message_ids_.find(dbc_id); it != message_ids_.end()) {
    message_problem(parsed, *id_token, "message id " + std::string(id_token->text) +
                                           " is already used by message '" +
                                           messages_[it->second].message.name + "'");
  }
  const std::size_t index = messages_.size();
  message_names_.emplace(message.name, index);
  message_ids_.emplace(dbc_id, index);
  messages_.push_back(std::move(parsed));
  // After a bad line its signals are only read, not checked against a length it lacks.
  current_ = line_ok ? static_cast<std::int64_t>(index) : -1;
  plain_owner_.fill(-1);
  muxed_owner_.fill(-1);
  group_owner_.clear();
  return line_ok;
}

bool DbcParser::signal() {
  ParsedMessage* parsed = current_ >= 0 ? &messages_[static_cast<std::size_t>(current_)] : nullptr;
  if (!in_message_) {
    error(tokens_[pos_ - 1], "SG_ outside a message (it must follow a BO_ line)");
    return false;
  }
  // Any problem in the line leaves the message unregistered.
  const auto fail = [&] {
    if (parsed != nullptr) parsed->broken = true;
    return false;
  };
  DbcSignal signal;
  const Token* name = nullptr;
  if (!expect_identifier("the signal name", name)) return fail();
  signal.name = std::string(name->text);
  signal.where = where(*name);
  if (peek().kind == TokenKind::identifier) {
    const Token& mux = next();
    const std::string_view text = mux.text;
    if (text == "M") {
      signal.mux_role = DbcMuxRole::multiplexer;
    } else if (text.size() > 1 && text[0] == 'm' && is_digit(text[1])) {
      std::size_t digits = 1;
      while (digits < text.size() && is_digit(text[digits])) ++digits;
      if (digits + 1 == text.size() && text.back() == 'M') {
        signal.mux_switch = true;  // `m<N>M`: multiplexed, and a switch itself
      } else if (digits < text.size()) {
        error(mux, "expected 'M', 'm<value>' or ':' after the signal name, found " + describe(mux));
        return fail();
      }
      std::uint64_t value = 0;
      const auto [end, status] = std::from_chars(text.data() + 1, text.data() + digits, value);
      if (status != std::errc() || value > static_cast<std::uint64_t>(INT64_MAX)) {
        error(mux, "multiplexer value in '" + std::string(text) + "' is out of range");
        return fail();
      }
      signal.mux_role = DbcMuxRole::multiplexed;
      signal.mux_value = static_cast<std::int64_t>(value);
    } else {
      error(mux, "expected 'M', 'm<value>' or ':' after the signal name, found " + describe(mux));
      return fail();
    }
  }
  if (!expect(':', "after the signal name")) return fail();

  const Token* start_token = nullptr;
  const Token* length_token = nullptr;
  std::uint64_t start = 0;
  std::uint64_t length = 0;
  if (!unsigned_integer("the start bit", start, &start_token)) return fail();
  if (!expect('|', "after the start bit")) return fail();
  if (!unsigned_integer("the signal length", length, &length_token)) return fail();
  if (!expect('@', "after the signal length")) return fail();
  bool layout_ok = true;
  const Token& order = peek();
  if (order.kind == TokenKind::number && (order.text == "0" || order.text == "1")) {
    signal.byte_order = order.text == "1" ? DbcByteOrder::intel : DbcByteOrder::motorola;
    next();
  } else if (order.kind == TokenKind::number) {
    error(order, "byte order must be 0 (Motorola, big-endian) or 1 (Intel, little-endian), found " +
                     describe(order));
    next();
    layout_ok = false;
  } else {
    error(order, "expected the byte order (0 or 1) after '@', found " + describe(order));
    return fail();
  }
  if (peek().is('+') || peek().is('-')) {
    signal.is_signed = next().is('-');
  } else {
    error(peek(), "expected '+' (unsigned) or '-' (signed) after the byte order, found " + describe(peek()));
    return fail();
  }
  const Token* factor_token = nullptr;
  if (!expect('(', "before the factor")) return fail();
  if (!number("the factor", signal.factor, &factor_token)) return fail();
  if (!expect(',', "after the factor")) return fail();
  if (!number("the offset", signal.offset)) return fail();
  if (!expect(')', "after the offset")) return fail();
  if (!expect('[', "before the minimum")) return fail();
  if (!number("the minimum", signal.minimum)) return fail();
  if (!expect('|', "after the minimum")) return fail();
  if (!number("the maximum", signal.maximum)) return fail();
  if (!expect(']', "after the maximum")) return fail();
  const Token* unit = nullptr;
  if (!expect_string("the unit", unit)) return fail();
  signal.unit = unit->value;
  while (!peek().first_on_line) {
    const Token& receiver = next();
    if (receiver.is(',')) continue;
    if (receiver.kind != TokenKind::identifier) {
      error(receiver, "expected a receiving node, found " + describe(receiver));
      return fail();
    }
    if (receiver.text != kNoNode) signal.receivers.emplace_back(receiver.text);
  }
  if (parsed == nullptr) return true;  // the message line was bad: syntax checked only

  // Layout, in the order a reader checks a signal line. A problem here is the message's
  // own (message_problem): the file loads, the message is unusable.
  if (signal.mux_switch) parsed->extended = true;
  if (signal.factor == 0) {
    message_problem(*parsed, *factor_token, "the factor of signal '" + signal.name + "' must not be 0");
    layout_ok = false;
  }
  if (length < 1 || length > 64) {
    message_problem(*parsed, *length_token,
                    "signal length must be 1 to 64 bits, found " + std::string(length_token->text));
    layout_ok = false;
  }
  if (start >= kMaxFrameBits) {
    message_problem(*parsed, *start_token,
                    "start bit " + std::string(start_token->text) + " is outside a 64-byte frame");
    layout_ok = false;
  }
  DbcMessage& message = parsed->message;
  for (const DbcSignal& other : message.signals) {
    if (other.name == signal.name) {
      message_problem(*parsed, *name,
                      "signal '" + signal.name + "' is already defined in message '" + message.name + "'");
      layout_ok = false;
      break;
    }
  }
  if (signal.mux_role == DbcMuxRole::multiplexer && message.multiplexer >= 0) {
    // Extended multiplexing may put it under another switch (SG_MUL_VAL_).
    plain_problem(*parsed, *name,
                  already_has_multiplexer(message, message.signals[static_cast<std::size_t>(message.multiplexer)]));
  }
  // From here on the line has been read to its end: an error marks the message, and the
  // next line is parsed normally.
  const auto reject = [&] {
    parsed->broken = true;
    return true;
  };
  if (!layout_ok) return reject();

  signal.start_bit = static_cast<std::uint32_t>(start);
  signal.length = static_cast<std::uint32_t>(length);
  // Both orders cover a run of network bits (the payload as one big-endian bit string)
  // for Motorola, or of sawtooth bits (little-endian) for Intel.
  std::uint32_t first = 0;  // in that numbering
  if (signal.byte_order == DbcByteOrder::intel) {
    first = signal.start_bit;
    signal.lsb_bit = first;
    signal.msb_bit = first + signal.length - 1;
  } else {
    first = dbc_network_bit(signal.start_bit);
    signal.msb_bit = signal.start_bit;
    signal.lsb_bit = dbc_network_bit(first + signal.length - 1);
  }
  signal.first_byte = first / 8;
  signal.last_byte = (first + signal.length - 1) / 8;
  if (parsed->pseudo) {
    message.signals.push_back(std::move(signal));
    return true;
  }
  if (first + signal.length > message.length * 8) {
    message_problem(*parsed, *name, "signal '" + signal.name + "' does not fit in the " +
                                        std::to_string(message.length) + "-byte message '" + message.name + "'");
    return reject();
  }

  const auto index = static_cast<std::int32_t>(message.signals.size());
  std::array<std::int32_t, kMaxFrameBits>* group = nullptr;
  if (signal.mux_role == DbcMuxRole::multiplexed) {
    auto [it, inserted] = group_owner_.try_emplace(signal.mux_value);
    if (inserted) it->second.fill(-1);
    group = &it->second;
  }
  // The sawtooth number (a physical bit) of the signal's i-th bit in its own numbering.
  const auto bit_at = [&](std::uint32_t i) {
    return signal.byte_order == DbcByteOrder::intel ? first + i : dbc_network_bit(first + i);
  };
  std::int32_t overlapped = -1;
  for (std::uint32_t i = 0; i < signal.length && overlapped < 0; ++i) {
    const std::uint32_t bit = bit_at(i);
    if (plain_owner_[bit] >= 0) overlapped = plain_owner_[bit];
    else if (group != nullptr && (*group)[bit] >= 0) overlapped = (*group)[bit];
    else if (group == nullptr && muxed_owner_[bit] >= 0) overlapped = muxed_owner_[bit];
  }
  if (overlapped >= 0) {
    // Under extended multiplexing the values name other switches: check_message decides.
    plain_problem(*parsed, *name, "signal '" + signal.name + "' overlaps signal '" +
                                      message.signals[static_cast<std::size_t>(overlapped)].name + "'");
    message.signals.push_back(std::move(signal));
    return true;
  }
  for (std::uint32_t i = 0; i < signal.length; ++i) {
    const std::uint32_t bit = bit_at(i);
    if (group != nullptr) {
      (*group)[bit] = index;
      if (muxed_owner_[bit] < 0) muxed_owner_[bit] = index;
    } else {
      plain_owner_[bit] = index;
    }
  }
  if (signal.mux_role == DbcMuxRole::multiplexer && message.multiplexer < 0) message.multiplexer = index;
  message.signals.push_back(std::move(signal));
  return true;
}

}  // namespace polyport::dbc_detail
