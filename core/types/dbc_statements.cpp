// The DBC parser's statements (DbcParser, dbc_parser_impl.hpp) other than BO_ and SG_
// (dbc_messages.cpp): the dispatch on the keyword, recovery after an error, the readers of
// numbers, strings and message / signal references, and VERSION, NS_, BS_, BU_, CM_, BA_DEF_,
// BA_DEF_DEF_, BA_, VAL_TABLE_, VAL_, SIG_VALTYPE_ and SG_MUL_VAL_. Statements that point at
// a message or signal are only recorded here; dbc_resolve.cpp resolves them.
#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <iterator>
#include <map>
#include <string>
#include <string_view>
#include <system_error>
#include <utility>
#include <vector>

#include "dbc_lexer.hpp"
#include "dbc_parser_impl.hpp"

namespace polyport::dbc_detail {

namespace {

// Every keyword that may start a statement. Recovery stops at one of these when it starts
// a line, so one bad statement does not swallow the next.
constexpr std::string_view kKeywords[] = {
    "VERSION", "NS_", "NS_DESC_", "CM_", "BA_DEF_", "BA_", "VAL_", "CAT_DEF_", "CAT_",
    "FILTER", "BA_DEF_DEF_", "EV_DATA_", "ENVVAR_DATA_", "SGTYPE_", "SGTYPE_VAL_",
    "BA_DEF_SGTYPE_", "BA_SGTYPE_", "SIG_TYPE_REF_", "VAL_TABLE_", "SIG_GROUP_",
    "SIG_VALTYPE_", "SIGTYPE_VALTYPE_", "BO_TX_BU_", "BA_DEF_REL_", "BA_REL_",
    "BA_DEF_DEF_REL_", "BU_SG_REL_", "BU_EV_REL_", "BU_BO_REL_", "SG_MUL_VAL_", "BS_", "BU_",
    "BO_", "SG_", "EV_"};
// Statements accepted and not modelled: skipped up to their `;`, one warning per keyword.
constexpr std::string_view kIgnoredStatements[] = {
    "NS_DESC_", "CAT_DEF_", "CAT_", "FILTER", "EV_DATA_", "ENVVAR_DATA_", "SGTYPE_",
    "SGTYPE_VAL_", "BA_DEF_SGTYPE_", "BA_SGTYPE_", "SIG_TYPE_REF_", "SIG_GROUP_",
    "SIGTYPE_VALTYPE_", "BA_DEF_REL_", "BA_REL_", "BA_DEF_DEF_REL_", "BU_SG_REL_",
    "BU_EV_REL_", "BU_BO_REL_", "EV_"};

bool is_keyword(std::string_view word) {
  return std::find(std::begin(kKeywords), std::end(kKeywords), word) != std::end(kKeywords);
}

bool is_ignored_statement(std::string_view word) {
  return std::find(std::begin(kIgnoredStatements), std::end(kIgnoredStatements), word) !=
         std::end(kIgnoredStatements);
}

// Upper case ending in `_`, as every DBC keyword is: recovery also stops at one it does not
// know, so an unknown statement gets its own error instead of vanishing in the skip.
bool looks_like_keyword(std::string_view word) {
  if (word.size() < 2 || word.back() != '_') return false;
  return std::all_of(word.begin(), word.end(),
                     [](char c) { return (c >= 'A' && c <= 'Z') || c == '_' || is_digit(c); });
}

ObjectKind object_kind(const Token& token) {
  if (token.is_word("BU_")) return ObjectKind::node;
  if (token.is_word("BO_")) return ObjectKind::message;
  if (token.is_word("SG_")) return ObjectKind::signal;
  if (token.is_word("EV_")) return ObjectKind::env_var;
  return ObjectKind::none;
}

}  // namespace

bool DbcParser::at_statement_start() const {
  const Token& token = peek();
  return token.kind == TokenKind::end ||
         (token.first_on_line && token.kind == TokenKind::identifier &&
          (is_keyword(token.text) || looks_like_keyword(token.text)));
}

void DbcParser::recover() {
  while (!at_end() && !at_statement_start()) {
    if (next().is(';')) return;
  }
}

void DbcParser::skip_rest_of_line() {
  while (!at_end() && !peek().first_on_line) next();
}

bool DbcParser::expect(char punct, std::string_view context) {
  if (peek().is(punct)) {
    next();
    return true;
  }
  error(peek(), "expected '" + std::string(1, punct) + "' " + std::string(context) + ", found " +
                    describe(peek()));
  return false;
}

bool DbcParser::expect_identifier(std::string_view what, const Token*& out) {
  if (peek().kind != TokenKind::identifier) {
    error(peek(), "expected " + std::string(what) + ", found " + describe(peek()));
    return false;
  }
  out = &next();
  return true;
}

bool DbcParser::expect_string(std::string_view what, const Token*& out) {
  if (peek().kind != TokenKind::string) {
    error(peek(), "expected " + std::string(what) + " (a quoted string), found " + describe(peek()));
    return false;
  }
  out = &next();
  return true;
}

bool parse_double(std::string_view text, double& out) {
  if (!text.empty() && text[0] == '+') text.remove_prefix(1);
  const auto [end, status] = std::from_chars(text.data(), text.data() + text.size(), out);
  return status == std::errc() && end == text.data() + text.size() && std::isfinite(out);
}

bool DbcParser::number(std::string_view what, double& out, const Token** token) {
  const Token& at = peek();
  if (at.kind != TokenKind::number) {
    error(at, "expected " + std::string(what) + " (a number), found " + describe(at));
    return false;
  }
  next();
  if (token != nullptr) *token = &at;
  if (!parse_double(at.text, out)) {
    error(at, "number '" + std::string(at.text) + "' is out of range");
    return false;
  }
  return true;
}

bool DbcParser::unsigned_integer(std::string_view what, std::uint64_t& out, const Token** token) {
  const Token& at = peek();
  if (at.kind != TokenKind::number) {
    error(at, "expected " + std::string(what) + " (an unsigned integer), found " + describe(at));
    return false;
  }
  next();
  if (token != nullptr) *token = &at;
  const auto [end, status] = std::from_chars(at.text.data(), at.text.data() + at.text.size(), out);
  if (end != at.text.data() + at.text.size() || status == std::errc::invalid_argument) {
    error(at, "expected " + std::string(what) + " (an unsigned integer), found " + describe(at));
    return false;
  }
  if (status != std::errc()) {
    error(at, std::string(what) + " " + std::string(at.text) + " is out of range");
    return false;
  }
  return true;
}

// Value descriptions and enum indices: integers that fit int64 (written `1` or `1.0`).
bool DbcParser::integer_value(const Token& token, std::string_view what, std::int64_t& out) {
  std::string_view text = token.text;
  if (!text.empty() && text[0] == '+') text.remove_prefix(1);
  const auto [end, status] = std::from_chars(text.data(), text.data() + text.size(), out);
  if (status == std::errc() && end == text.data() + text.size()) return true;
  double value = 0;
  if (token.kind == TokenKind::number && parse_double(token.text, value) &&
      value == std::floor(value) && std::fabs(value) < 9.2e18) {
    out = static_cast<std::int64_t>(value);
    return true;
  }
  error(token, std::string(what) + " must be an integer, found " + describe(token));
  return false;
}

bool DbcParser::message_reference(Reference& out) {
  const Token* token = nullptr;
  if (!unsigned_integer("a message id", out.dbc_id, &token)) return false;
  out.id_token = *token;
  return true;
}

bool DbcParser::signal_reference(Reference& out) {
  if (!message_reference(out)) return false;
  const Token* token = nullptr;
  if (!expect_identifier("a signal name", token)) return false;
  out.signal = std::string(token->text);
  out.signal_token = *token;
  return true;
}

// ---------------------------------------------------------------------------------------
// Statements

void DbcParser::statement() {
  const Token& keyword = peek();
  if (keyword.kind != TokenKind::identifier) {
    error(keyword, "expected a DBC keyword, found " + describe(keyword));
    next();
    recover();
    return;
  }
  const std::string_view word = keyword.text;
  next();
  // Another statement ends the current message's signal list (an unknown word does not,
  // so one typo does not turn the following SG_ lines into strays).
  if (is_keyword(word) && word != "SG_") {
    current_ = -1;
    in_message_ = false;
  }
  bool ok = true;
  if (word == "VERSION") ok = version();
  else if (word == "NS_") ok = namespace_block();
  else if (word == "BS_") ok = bit_timing();
  else if (word == "BU_") ok = nodes();
  else if (word == "BO_") ok = message();
  else if (word == "SG_") ok = signal();
  else if (word == "CM_") ok = comment();
  else if (word == "BA_DEF_") ok = attribute_definition();
  else if (word == "BA_DEF_DEF_") ok = attribute_default();
  else if (word == "BA_") ok = attribute();
  else if (word == "VAL_TABLE_") ok = value_table();
  else if (word == "VAL_") ok = values();
  else if (word == "SIG_VALTYPE_") ok = value_type();
  else if (word == "SG_MUL_VAL_") ok = mux_values();
  else if (word == "BO_TX_BU_") {
    Reference reference;
    if (message_reference(reference)) message_references_.push_back(std::move(reference));
    once(word, keyword,
         "BO_TX_BU_ statements (more transmitters of a message) are not used by polyport and are ignored");
    recover();
  } else if (is_ignored_statement(word)) {
    once(word, keyword, std::string(word) + " statements are not used by polyport and are ignored");
    recover();
  } else if (looks_like_keyword(word)) {
    // A newer tool's statement: skipped like the ones polyport does not use.
    once(word, keyword, "unknown statement '" + std::string(word) + "' is ignored");
    recover();
  } else {
    error(keyword, "unknown keyword '" + std::string(word) + "'");
    recover();
  }
  if (!ok) recover();
}

bool DbcParser::version() {
  const Token* text = nullptr;
  if (!expect_string("the version", text)) return false;
  database_->version = text->value;
  return true;
}

// `NS_ :` lists the keywords the file may use, often one per line: a line made only of
// identifiers belongs to the list. Every statement after it has something else on its
// first line (`BS_:`, `BU_:`, a number, a string).
bool DbcParser::namespace_block() {
  const bool ok = expect(':', "after NS_");
  skip_rest_of_line();
  while (peek().kind == TokenKind::identifier) {
    std::size_t ahead = 0;
    bool only_identifiers = true;
    do {
      if (peek(ahead).kind != TokenKind::identifier) only_identifiers = false;
      ++ahead;
    } while (peek(ahead).kind != TokenKind::end && !peek(ahead).first_on_line);
    if (!only_identifiers) break;
    for (std::size_t i = 0; i < ahead; ++i) next();
  }
  return ok;
}

bool DbcParser::bit_timing() {
  const bool ok = expect(':', "after BS_");
  skip_rest_of_line();  // the obsolete baud rate and BTR values
  return ok;
}

bool DbcParser::nodes() {
  if (!expect(':', "after BU_")) return false;
  while (peek().kind == TokenKind::identifier && !at_statement_start()) {
    const Token& name = next();
    const bool known = std::any_of(database_->nodes.begin(), database_->nodes.end(),
                                   [&](const DbcNode& node) { return node.name == name.text; });
    if (known) {  // harmless to the frames: the first one stands
      warning(name, "node '" + std::string(name.text) + "' is already defined; the second is ignored");
      continue;
    }
    database_->nodes.push_back({std::string(name.text), {}});
  }
  return true;
}

bool DbcParser::comment() {
  PendingComment pending;
  const Token& kind = peek();
  if (kind.kind == TokenKind::string) {
    database_->comment = next().value;
    return expect(';', "after the comment");
  }
  if (kind.is_word("BU_") || kind.is_word("EV_")) {
    if (kind.is_word("EV_")) {
      once("CM_ EV_", kind,
           "comments on environment variables (CM_ EV_) are not used by polyport and are ignored");
    }
    next();
    const Token* name = nullptr;
    if (!expect_identifier(kind.is_word("BU_") ? "a node name" : "an environment variable name", name)) {
      return false;
    }
    pending.kind = kind.is_word("BU_") ? ObjectKind::node : ObjectKind::env_var;
    pending.node = std::string(name->text);
    pending.node_token = *name;
  } else if (kind.is_word("BO_")) {
    next();
    pending.kind = ObjectKind::message;
    if (!message_reference(pending.target)) return false;
  } else if (kind.is_word("SG_")) {
    next();
    pending.kind = ObjectKind::signal;
    if (!signal_reference(pending.target)) return false;
  } else {
    error(kind, "expected a comment string or BU_, BO_, SG_, EV_ after CM_, found " + describe(kind));
    return false;
  }
  const Token* text = nullptr;
  if (!expect_string("the comment", text)) return false;
  pending.text = text->value;
  comments_.push_back(std::move(pending));
  return expect(';', "after the comment");
}

bool DbcParser::attribute_definition() {
  AttributeDefinition definition;
  definition.kind = object_kind(peek());
  if (definition.kind != ObjectKind::none) next();
  const Token* name = nullptr;
  if (!expect_string("the attribute name", name)) return false;
  const Token* type = nullptr;
  if (!expect_identifier("the attribute type (INT, HEX, FLOAT, STRING, ENUM)", type)) return false;
  definition.type = std::string(type->text);
  double bound = 0;
  if (definition.type == "INT" || definition.type == "HEX" || definition.type == "FLOAT") {
    if (!number("the attribute minimum", bound) || !number("the attribute maximum", bound)) return false;
  } else if (definition.type == "ENUM") {
    while (peek().kind == TokenKind::string) {
      definition.labels.push_back(next().value);
      if (!peek().is(',')) break;
      next();
    }
  } else if (definition.type != "STRING") {
    error(*type, "unknown attribute type '" + definition.type +
                     "' (expected INT, HEX, FLOAT, STRING or ENUM)");
    return false;
  }
  if (!expect(';', "after the attribute definition")) return false;
  // A second definition of a name changes nothing: the first one stands.
  attribute_definitions_.try_emplace(name->value, std::move(definition));
  return true;
}

bool DbcParser::attribute_default() {
  const Token* name = nullptr;
  if (!expect_string("the attribute name", name)) return false;
  const Token& value = peek();
  if (value.kind != TokenKind::number && value.kind != TokenKind::string) {
    error(value, "expected the attribute's default value, found " + describe(value));
    return false;
  }
  next();
  auto it = attribute_definitions_.find(name->value);
  if (it == attribute_definitions_.end()) {
    once("BA_DEF_DEF_ undefined", *name, "default for undefined attribute '" + name->value + "' is ignored");
  } else {
    it->second.default_value = value;
    it->second.has_default = true;
  }
  return expect(';', "after the attribute default");
}

bool DbcParser::attribute() {
  PendingAttribute pending;
  const Token* name = nullptr;
  if (!expect_string("the attribute name", name)) return false;
  pending.name = name->value;
  pending.name_token = *name;
  pending.kind = object_kind(peek());
  if (pending.kind != ObjectKind::none) next();
  switch (pending.kind) {
    case ObjectKind::message:
      if (!message_reference(pending.target)) return false;
      break;
    case ObjectKind::signal:
      if (!signal_reference(pending.target)) return false;
      break;
    case ObjectKind::node:
    case ObjectKind::env_var: {
      const Token* object = nullptr;
      if (!expect_identifier("a name", object)) return false;
      break;
    }
    case ObjectKind::none: break;
  }
  const Token& value = peek();
  if (value.kind != TokenKind::number && value.kind != TokenKind::string) {
    error(value, "expected the attribute value, found " + describe(value));
    return false;
  }
  pending.value = next();
  attributes_.push_back(std::move(pending));
  return expect(';', "after the attribute value");
}

// `<value> "<description>"` pairs up to the `;`.
bool DbcParser::value_descriptions(std::map<std::int64_t, std::string>& out) {
  while (!peek().is(';')) {
    const Token& value = peek();
    if (value.kind != TokenKind::number) {
      error(value, "expected a value or ';', found " + describe(value));
      return false;
    }
    next();
    std::int64_t key = 0;
    if (!integer_value(value, "a described value", key)) return false;
    const Token* text = nullptr;
    if (!expect_string("the value's description", text)) return false;
    out[key] = text->value;
  }
  next();
  return true;
}

bool DbcParser::value_table() {
  const Token* name = nullptr;
  if (!expect_identifier("the value table name", name)) return false;
  std::map<std::int64_t, std::string> table;
  if (!value_descriptions(table)) return false;
  if (!database_->value_tables.try_emplace(std::string(name->text), std::move(table)).second) {
    warning(*name, "value table '" + std::string(name->text) + "' is already defined; the second is ignored");
  }
  return true;
}

bool DbcParser::values() {
  if (peek().kind == TokenKind::identifier) {  // an environment variable's values
    once("VAL_ EV_", next(),
         "value descriptions of environment variables (VAL_) are not used by polyport and are ignored");
    std::map<std::int64_t, std::string> ignored;
    return value_descriptions(ignored);
  }
  PendingValues pending;
  if (!signal_reference(pending.target)) return false;
  if (!value_descriptions(pending.values)) return false;
  values_.push_back(std::move(pending));
  return true;
}

bool DbcParser::value_type() {
  PendingValueType pending;
  if (!signal_reference(pending.target)) return false;
  if (peek().is(':')) next();
  const Token* value = nullptr;
  if (!unsigned_integer("the signal value type (0, 1 or 2)", pending.kind, &value)) return false;
  pending.value = *value;
  if (pending.kind > 2) {
    error(*value,
          "signal value type must be 0 (integer), 1 (float) or 2 (double), found " + describe(*value));
    return false;
  }
  value_types_.push_back(std::move(pending));
  return expect(';', "after the signal value type");
}

// SG_MUL_VAL_ <id> <signal> <multiplexer> <lo>-<hi>, ... ; extended multiplexing: the switch
// that selects the signal and the switch's raw values that do (applied in resolve()).
bool DbcParser::mux_values() {
  PendingMuxValues pending;
  if (!signal_reference(pending.target)) return false;
  const Token* multiplexer = nullptr;
  if (!expect_identifier("the multiplexer signal", multiplexer)) return false;
  pending.multiplexer = std::string(multiplexer->text);
  pending.multiplexer_token = *multiplexer;
  while (!peek().is(';')) {
    const Token& low = peek();
    std::uint64_t lo = 0;
    std::uint64_t hi = 0;
    if (!unsigned_integer("a multiplexer value", lo)) return false;
    // `1-3` reads as the numbers 1 and -3.
    if (peek().kind == TokenKind::number && peek().text[0] == '-') {
      std::int64_t negated = 0;
      if (!integer_value(next(), "a multiplexer value", negated)) return false;
      if (negated == INT64_MIN) negated = INT64_MIN + 1;  // reported as out of range below
      hi = static_cast<std::uint64_t>(-negated);
    } else {
      if (!expect('-', "in a multiplexer value range")) return false;
      if (!unsigned_integer("a multiplexer value", hi)) return false;
    }
    if (lo > static_cast<std::uint64_t>(INT64_MAX) || hi > static_cast<std::uint64_t>(INT64_MAX)) {
      error(low, "multiplexer value range is out of range");
      return false;
    }
    pending.ranges.push_back({static_cast<std::int64_t>(lo), static_cast<std::int64_t>(hi)});
    if (peek().is(',')) next();
  }
  next();
  mux_values_.push_back(std::move(pending));
  return true;
}

}  // namespace polyport::dbc_detail
