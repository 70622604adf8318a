// The DBC parser's resolution pass (DbcParser, dbc_parser_impl.hpp), run once the whole file
// is read: comments, attributes (cycle time, CAN FD, bit rate switch), value descriptions,
// signal value types and SG_MUL_VAL_ are applied to the messages and signals they name, so
// their order in the file does not matter; then each message's multiplexing is checked and
// every multiplexed signal given its switch and values (plain and extended alike).
#include <algorithm>
#include <bitset>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "dbc_lexer.hpp"
#include "dbc_parser_impl.hpp"
#include "polyport/types/dbc.hpp"

namespace polyport::dbc_detail {

ParsedMessage* DbcParser::resolve_message(const Reference& reference) {
  auto it = message_ids_.find(reference.dbc_id);
  if (it == message_ids_.end()) {
    dangling(reference.id_token, "no message has id " + std::string(reference.id_token.text));
    return nullptr;
  }
  return &messages_[it->second];
}

DbcSignal* DbcParser::resolve_signal(ParsedMessage& parsed, const Reference& reference) {
  for (DbcSignal& signal : parsed.message.signals) {
    if (signal.name == reference.signal) return &signal;
  }
  // A signal whose line had an error is not in the list; that error is reported already.
  if (!parsed.broken) {
    dangling(reference.signal_token,
             "message '" + parsed.message.name + "' has no signal '" + reference.signal + "'");
  }
  return nullptr;
}

void DbcParser::resolve() {
  for (const Reference& reference : message_references_) resolve_message(reference);

  for (const PendingComment& comment : comments_) {
    if (comment.kind == ObjectKind::node) {
      auto node = std::find_if(database_->nodes.begin(), database_->nodes.end(),
                               [&](const DbcNode& item) { return item.name == comment.node; });
      if (node == database_->nodes.end()) {
        dangling(comment.node_token, "no node is named '" + comment.node + "'");
      } else {
        node->comment = comment.text;
      }
      continue;
    }
    if (comment.kind != ObjectKind::message && comment.kind != ObjectKind::signal) continue;
    ParsedMessage* parsed = resolve_message(comment.target);
    if (parsed == nullptr) continue;
    if (comment.kind == ObjectKind::message) {
      parsed->message.comment = comment.text;
    } else if (DbcSignal* signal = resolve_signal(*parsed, comment.target)) {
      signal->comment = comment.text;
    }
  }

  // Attributes the frames depend on; defaults first, then the per-message values. A bad
  // value is ignored with a warning (once per file): the frame layout does not depend on it.
  const auto bad_value = [&](const Token& value, std::string message) {
    once("attribute value", value, std::move(message) + "; the value is ignored");
  };
  const auto enum_label = [&](const AttributeDefinition& definition, const Token& value) -> std::string {
    if (value.kind == TokenKind::string) return value.value;
    double index = -1;
    if (!parse_double(value.text, index) || index < 0 || index != std::floor(index) ||
        index >= static_cast<double>(definition.labels.size())) {
      bad_value(value, "enum value " + std::string(value.text) + " is out of range");
      return {};
    }
    return definition.labels[static_cast<std::size_t>(index)];
  };
  // Applies one message attribute; returns false (reported) when the value is bad.
  const auto apply = [&](DbcMessage& message, std::string_view name, const Token& value) {
    auto definition = attribute_definitions_.find(name);
    if (name == "GenMsgCycleTime") {
      double ms = -1;
      if (value.kind != TokenKind::number || !parse_double(value.text, ms) || ms < 0 ||
          ms != std::floor(ms) || ms > 0xFFFFFFFFu) {
        bad_value(value, "GenMsgCycleTime must be a whole number of milliseconds, found " + describe(value));
        return;
      }
      message.cycle_time_ms = static_cast<std::uint32_t>(ms);
    } else if (name == "VFrameFormat" && definition != attribute_definitions_.end()) {
      // Vector's values: 0 StandardCAN, 1 ExtendedCAN, 14 StandardCAN_FD, 15 ExtendedCAN_FD;
      // some files define it as an INT instead of an ENUM.
      double number = -1;
      const bool fd = definition->second.type == "ENUM"
                          ? enum_label(definition->second, value).find("FD") != std::string::npos
                          : value.kind == TokenKind::number && parse_double(value.text, number) &&
                                (number == 14 || number == 15);
      message.fd = message.length > 8 || fd;
    } else if (name == "CANFD_BRS" && definition != attribute_definitions_.end()) {
      const std::string label = definition->second.labels.empty() ? std::string(value.text)
                                                                  : enum_label(definition->second, value);
      message.bit_rate_switch = label == "1";
    }
  };
  // A default is checked once, on a stand-in, then copied to every message.
  DbcMessage defaults;
  bool default_fd = false;
  for (const auto& [name, definition] : attribute_definitions_) {
    if (definition.kind != ObjectKind::message || !definition.has_default) continue;
    apply(defaults, name, definition.default_value);
    if (name == "VFrameFormat") default_fd = defaults.fd;
  }
  for (ParsedMessage& parsed : messages_) {
    parsed.message.cycle_time_ms = defaults.cycle_time_ms;
    parsed.message.fd = parsed.message.fd || default_fd;
    parsed.message.bit_rate_switch = defaults.bit_rate_switch;
  }
  for (const PendingAttribute& attribute : attributes_) {
    if (attribute_definitions_.find(attribute.name) == attribute_definitions_.end()) {
      once("BA_ undefined", attribute.name_token, "attribute '" + attribute.name + "' is not defined (BA_DEF_)");
    }
    if (attribute.kind != ObjectKind::message && attribute.kind != ObjectKind::signal) continue;
    ParsedMessage* parsed = resolve_message(attribute.target);
    if (parsed == nullptr) continue;
    if (attribute.kind == ObjectKind::signal) {
      resolve_signal(*parsed, attribute.target);
      continue;
    }
    apply(parsed->message, attribute.name, attribute.value);
  }

  for (PendingValues& values : values_) {
    ParsedMessage* parsed = resolve_message(values.target);
    if (parsed == nullptr) continue;
    if (DbcSignal* signal = resolve_signal(*parsed, values.target)) {
      signal->value_table = std::move(values.values);
    }
  }

  for (const PendingValueType& type : value_types_) {
    ParsedMessage* parsed = resolve_message(type.target);
    if (parsed == nullptr) continue;
    DbcSignal* signal = resolve_signal(*parsed, type.target);
    if (signal == nullptr) continue;
    signal->float_kind = type.kind == 1 ? DbcFloatKind::float32
                         : type.kind == 2 ? DbcFloatKind::float64 : DbcFloatKind::none;
    const std::uint32_t needed = type.kind == 1 ? 32 : type.kind == 2 ? 64 : 0;
    if (needed != 0 && signal->length != needed) {
      message_problem(*parsed, type.value,
                      std::string(type.kind == 1 ? "a float" : "a double") + " signal needs " +
                          std::to_string(needed) + " bits; '" + signal->name + "' has " +
                          std::to_string(signal->length));
    } else if (needed != 0 && signal->is_switch()) {
      message_problem(*parsed, type.value, "multiplexer '" + signal->name + "' must be an integer signal");
    }
  }

  for (const PendingMuxValues& mux : mux_values_) {
    ParsedMessage* parsed = resolve_message(mux.target);
    if (parsed == nullptr) continue;
    DbcSignal* signal = resolve_signal(*parsed, mux.target);
    if (signal == nullptr) continue;
    DbcMessage& message = parsed->message;
    const auto named = std::find_if(message.signals.begin(), message.signals.end(),
                                    [&](const DbcSignal& item) { return item.name == mux.multiplexer; });
    if (named == message.signals.end()) {
      // A switch whose own line had an error is not in the list; that error is reported already.
      if (!parsed->broken) {
        message_problem(*parsed, mux.multiplexer_token,
                        "SG_MUL_VAL_ names multiplexer '" + mux.multiplexer + "', which message '" + message.name +
                            "' does not have");
      }
      continue;
    }
    const auto parent = static_cast<std::int32_t>(named - message.signals.begin());
    if (!named->is_switch()) {
      message_problem(*parsed, mux.multiplexer_token,
                      "SG_MUL_VAL_ makes '" + mux.multiplexer + "' the multiplexer of '" + signal->name +
                          "', but it is not a multiplexer (M or m<N>M)");
      continue;
    }
    if (signal->mux_parent >= 0 && signal->mux_parent != parent) {
      message_problem(*parsed, mux.multiplexer_token,
                      "signal '" + signal->name + "' has SG_MUL_VAL_ lines naming two multiplexers, '" +
                          message.signals[static_cast<std::size_t>(signal->mux_parent)].name + "' and '" +
                          mux.multiplexer + "'");
      continue;
    }
    if (mux.ranges.empty()) {
      message_problem(*parsed, mux.target.signal_token, "SG_MUL_VAL_ of signal '" + signal->name + "' lists no values");
      continue;
    }
    const auto empty = std::find_if(mux.ranges.begin(), mux.ranges.end(),
                                    [](const DbcMuxRange& range) { return range.high < range.low; });
    if (empty != mux.ranges.end()) {
      message_problem(*parsed, mux.target.signal_token,
                      "SG_MUL_VAL_ of signal '" + signal->name + "' has the empty range " +
                          std::to_string(empty->low) + "-" + std::to_string(empty->high));
      continue;
    }
    const bool restates_plain = signal->mux_role == DbcMuxRole::multiplexed && !signal->mux_switch &&
                                parent == message.multiplexer && mux.ranges.size() == 1 &&
                                mux.ranges[0] == DbcMuxRange{signal->mux_value, signal->mux_value};
    if (!restates_plain) parsed->extended = true;
    // A switch (`M`) or a plain signal given a switch of its own is multiplexed from now on.
    if (signal->mux_role == DbcMuxRole::multiplexer) signal->mux_switch = true;
    signal->mux_role = DbcMuxRole::multiplexed;
    signal->mux_parent = parent;
    signal->mux_ranges.insert(signal->mux_ranges.end(), mux.ranges.begin(), mux.ranges.end());
  }
}

void DbcParser::check_message(ParsedMessage& parsed) {
  if (!parsed.extended) {
    // Plain: the SG_ lines' checks stand, in line order with the message's other problems.
    for (ParsedMessage::Deferred& problem : parsed.plain_problems) {
      const bool earlier = parsed.problem.empty() || problem.at.line < parsed.problem_line ||
                           (problem.at.line == parsed.problem_line && problem.at.column < parsed.problem_column);
      parsed.broken = true;
      if (!earlier) {
        ++parsed.more_problems;
        continue;
      }
      if (!parsed.problem.empty()) ++parsed.more_problems;
      parsed.problem = std::move(problem.message);
      parsed.problem_line = problem.at.line;
      parsed.problem_column = problem.at.column;
    }
  }
  // A broken message is not registered; its multiplexer may be the line that was bad.
  if (!parsed.broken) check_multiplexing(parsed);
}

namespace {

Token token_at(const SourceLocation& where) {
  Token at;
  at.line = where.line;
  at.column = where.column;
  return at;
}

}  // namespace

void DbcParser::check_multiplexing(ParsedMessage& parsed) {
  DbcMessage& message = parsed.message;
  std::vector<DbcSignal>& signals = message.signals;
  // Switches selecting each other (SG_MUL_VAL_ in a loop, extended multiplexing only):
  // following the parents from any signal must end.
  for (const DbcSignal& signal : signals) {
    std::int32_t at = signal.mux_parent;
    std::size_t steps = 0;
    while (at >= 0 && steps <= signals.size()) {
      at = signals[static_cast<std::size_t>(at)].mux_parent;
      ++steps;
    }
    if (at >= 0) {
      message_problem(parsed, token_at(signal.where),
                      "the multiplexers of signal '" + signal.name + "' select each other (a loop of SG_MUL_VAL_)");
      return;
    }
  }
  // One switch in every frame (an `M` no SG_MUL_VAL_ puts under another); an m<N> (or m<N>M)
  // that no SG_MUL_VAL_ names belongs to it.
  std::vector<std::int32_t> top;
  std::size_t switches = 0;
  std::size_t ranges = 0;
  for (std::size_t i = 0; i < signals.size(); ++i) {
    if (signals[i].mux_role == DbcMuxRole::multiplexer) top.push_back(static_cast<std::int32_t>(i));
    if (signals[i].is_switch()) ++switches;
  }
  if (top.size() > 1) {
    const DbcSignal& second = signals[static_cast<std::size_t>(top[1])];
    message_problem(parsed, token_at(second.where),
                    already_has_multiplexer(message, signals[static_cast<std::size_t>(top[0])]));
    return;
  }
  for (DbcSignal& signal : signals) {
    if (signal.mux_role == DbcMuxRole::multiplexed && signal.mux_parent < 0) {
      if (top.empty()) {
        message_problem(parsed, token_at(signal.where), "signal '" + signal.name + "' is multiplexed but message '" +
                                                            message.name + "' has no multiplexer (M) signal");
        return;
      }
      signal.mux_parent = top[0];
      signal.mux_ranges = {{signal.mux_value, signal.mux_value}};
    }
    ranges += signal.mux_ranges.size();
  }
  message.multiplexer = top.empty() ? -1 : top[0];
  // What the codec carries (kDbcMax*).
  if (switches > kDbcMaxSwitches || signals.size() > kDbcMaxSignals || ranges > kDbcMaxMuxRanges) {
    message_problem(parsed, token_at(message.where),
                    "message '" + message.name + "' has more than " +
                        (switches > kDbcMaxSwitches     ? std::to_string(kDbcMaxSwitches) + " multiplexers"
                         : signals.size() > kDbcMaxSignals ? std::to_string(kDbcMaxSignals) + " signals"
                                                           : std::to_string(kDbcMaxMuxRanges) + " multiplexer value ranges"));
    return;
  }
  warn_values_no_switch_holds(parsed.message);
  // A plain message's overlaps were found by its SG_ lines (plain_problems).
  if (parsed.extended) check_extended_overlaps(parsed);
}

// Values a switch cannot hold select nothing (its raw integer: 0 up to 2^length - 1, or up to
// 2^(length - 1) - 1 when signed, negative ones matching no range): the message stays usable,
// the file's author is told once.
void DbcParser::warn_values_no_switch_holds(const DbcMessage& message) {
  const std::vector<DbcSignal>& signals = message.signals;
  for (const DbcSignal& signal : signals) {
    if (signal.mux_parent < 0) continue;
    const DbcSignal& multiplexer = signals[static_cast<std::size_t>(signal.mux_parent)];
    const std::uint32_t value_bits = multiplexer.is_signed ? multiplexer.length - 1 : multiplexer.length;
    const std::int64_t highest =
        value_bits >= 63 ? std::numeric_limits<std::int64_t>::max() : (std::int64_t{1} << value_bits) - 1;
    for (const DbcMuxRange& range : signal.mux_ranges) {
      if (range.low >= 0 && range.high <= highest) continue;
      const std::string values =
          range.low == range.high ? std::to_string(range.low) : std::to_string(range.low) + "-" + std::to_string(range.high);
      once("multiplexer value out of range", token_at(signal.where),
           "signal '" + signal.name + "' is selected by the value(s) " + values + " of multiplexer '" +
               multiplexer.name + "', which holds 0-" + std::to_string(highest) + " (" +
               std::to_string(multiplexer.length) + " bits" + (multiplexer.is_signed ? ", signed" : "") +
               "): those values never select it");
      break;
    }
  }
}

// Two signals may share bits only if no frame holds both: somewhere up their chains of
// switches they need one switch to hold values that no range of the one shares with the other.
void DbcParser::check_extended_overlaps(ParsedMessage& parsed) {
  const std::vector<DbcSignal>& signals = parsed.message.signals;
  const auto bits_of = [](const DbcSignal& signal) {
    std::bitset<kMaxFrameBits> bits;
    const bool intel = signal.byte_order == DbcByteOrder::intel;
    const std::uint32_t first = intel ? signal.start_bit : dbc_network_bit(signal.start_bit);
    for (std::uint32_t i = 0; i < signal.length; ++i) bits.set(intel ? first + i : dbc_network_bit(first + i));
    return bits;
  };
  const auto disjoint = [](const std::vector<DbcMuxRange>& a, const std::vector<DbcMuxRange>& b) {
    for (const DbcMuxRange& x : a) {
      for (const DbcMuxRange& y : b) {
        if (x.low <= y.high && y.low <= x.high) return false;
      }
    }
    return true;
  };
  // Never in one frame: a switch both need with values apart.
  const auto exclusive = [&](std::size_t a, std::size_t b) {
    for (std::size_t x = a; signals[x].mux_parent >= 0; x = static_cast<std::size_t>(signals[x].mux_parent)) {
      for (std::size_t y = b; signals[y].mux_parent >= 0; y = static_cast<std::size_t>(signals[y].mux_parent)) {
        if (signals[x].mux_parent == signals[y].mux_parent && disjoint(signals[x].mux_ranges, signals[y].mux_ranges)) {
          return true;
        }
      }
    }
    return false;
  };
  std::vector<std::bitset<kMaxFrameBits>> bits;
  for (const DbcSignal& signal : signals) bits.push_back(bits_of(signal));
  for (std::size_t b = 1; b < signals.size(); ++b) {
    for (std::size_t a = 0; a < b; ++a) {
      if ((bits[a] & bits[b]).none() || exclusive(a, b)) continue;
      message_problem(parsed, token_at(signals[b].where),
                      "signal '" + signals[b].name + "' overlaps signal '" + signals[a].name + "'");
      return;
    }
  }
}

}  // namespace polyport::dbc_detail
