// The DBC parser's resolution pass (DbcParser, dbc_parser_impl.hpp), run once the whole file
// is read: comments, attributes (cycle time, CAN FD, bit rate switch), value descriptions,
// signal value types and SG_MUL_VAL_ are applied to the messages and signals they name, so
// their order in the file does not matter; then each message's multiplexing is checked.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <string_view>
#include <utility>

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
    } else if (needed != 0 && signal->mux_role == DbcMuxRole::multiplexer) {
      message_problem(*parsed, type.value, "multiplexer '" + signal->name + "' must be an integer signal");
    }
  }

  for (const PendingMuxValues& mux : mux_values_) {
    ParsedMessage* parsed = resolve_message(mux.target);
    if (parsed == nullptr) continue;
    DbcSignal* signal = resolve_signal(*parsed, mux.target);
    if (signal == nullptr) {
      // Dropped for a problem of its own (a second multiplexer, say): extended multiplexing.
      if (parsed->broken) {
        message_problem(*parsed, mux.target.signal_token, "extended multiplexing (SG_MUL_VAL_) is not supported",
                        true);
      }
      continue;
    }
    const DbcMessage& message = parsed->message;
    const bool restates_plain = signal->mux_role == DbcMuxRole::multiplexed && message.multiplexer >= 0 &&
                                message.signals[static_cast<std::size_t>(message.multiplexer)].name ==
                                    mux.multiplexer &&
                                mux.ranges.size() == 1 && mux.ranges[0].first == signal->mux_value &&
                                mux.ranges[0].second == signal->mux_value;
    if (!restates_plain) {
      message_problem(*parsed, mux.target.signal_token, "extended multiplexing (SG_MUL_VAL_) is not supported",
                      true);
    }
  }
}

void DbcParser::check_message(ParsedMessage& parsed) {
  DbcMessage& message = parsed.message;
  // A broken message is not registered; its multiplexer may be the line that was bad.
  if (message.multiplexer >= 0 || parsed.broken) return;
  for (const DbcSignal& signal : message.signals) {
    if (signal.mux_role != DbcMuxRole::multiplexed) continue;
    Token at;
    at.line = signal.where.line;
    at.column = signal.where.column;
    message_problem(parsed, at, "signal '" + signal.name + "' is multiplexed but message '" + message.name +
                                    "' has no multiplexer (M) signal");
    return;
  }
}

}  // namespace polyport::dbc_detail
