// DBC files as a type source (dbc.hpp): TypeRegistry::add_dbc_file / add_dbc_text.
//
// Set-up code, run once per file. It reports every problem it finds as file:line:col
// (columns count bytes) and keeps going: after an error it skips to the next `;` or the
// next line that starts with a DBC keyword. Statements that point at a message or signal
// (CM_, BA_, VAL_, SIG_VALTYPE_, ...) are resolved after the whole file is read, so their
// order in the file does not matter, and the problems are reported sorted by position.
// Only messages without errors are registered as types.
#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <memory>
#include <sstream>
#include <string>
#include <string_view>
#include <vector>

#include "polyport/types/dbc.hpp"
#include "polyport/types/types.hpp"

namespace polyport {

namespace {

constexpr std::string_view kNoNode = "Vector__XXX";
// Vector's pseudo message that holds signals belonging to no message; never a frame.
constexpr std::string_view kIndependentSignals = "VECTOR__INDEPENDENT_SIG_MSG";
constexpr std::uint32_t kMaxFrameBits = kCanMaxDataLength * 8;

// Every keyword that may start a statement. Recovery stops at one of these when it starts
// a line, so one bad statement does not swallow the next.
constexpr std::string_view kKeywords[] = {
    "VERSION", "NS_", "NS_DESC_", "CM_", "BA_DEF_", "BA_", "VAL_", "CAT_DEF_", "CAT_",
    "FILTER", "BA_DEF_DEF_", "EV_DATA_", "ENVVAR_DATA_", "SGTYPE_", "SGTYPE_VAL_",
    "BA_DEF_SGTYPE_", "BA_SGTYPE_", "SIG_TYPE_REF_", "VAL_TABLE_", "SIG_GROUP_",
    "SIG_VALTYPE_", "SIGTYPE_VALTYPE_", "BO_TX_BU_", "BA_DEF_REL_", "BA_REL_",
    "BA_DEF_DEF_REL_", "BU_SG_REL_", "BU_EV_REL_", "BU_BO_REL_", "SG_MUL_VAL_", "BS_", "BU_",
    "BO_", "SG_", "EV_"};
// Statements accepted and not modelled: skipped up to their `;`.
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

bool is_identifier_start(char c) {
  return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || c == '_';
}
bool is_digit(char c) { return c >= '0' && c <= '9'; }
bool is_identifier_char(char c) { return is_identifier_start(c) || is_digit(c); }

// Upper case ending in `_`, as every DBC keyword is: recovery also stops at one it does not
// know, so an unknown statement gets its own error instead of vanishing in the skip.
bool looks_like_keyword(std::string_view word) {
  if (word.size() < 2 || word.back() != '_') return false;
  return std::all_of(word.begin(), word.end(),
                     [](char c) { return (c >= 'A' && c <= 'Z') || c == '_' || is_digit(c); });
}

// ---------------------------------------------------------------------------------------
// Lexing

enum class TokenKind : std::uint8_t { identifier, number, string, punct, end };

struct Token {
  TokenKind kind = TokenKind::end;
  std::string_view text;  // the source text (a string's, with its quotes)
  std::string value;      // a string's contents, escapes resolved
  std::uint32_t line = 0;
  std::uint32_t column = 0;
  bool first_on_line = false;

  bool is(char c) const { return kind == TokenKind::punct && text.size() == 1 && text[0] == c; }
  bool is_word(std::string_view word) const { return kind == TokenKind::identifier && text == word; }
};

struct Problem {
  std::uint32_t line = 0;
  std::uint32_t column = 0;
  Severity severity = Severity::error;
  std::string message;
};

std::string describe(const Token& token) {
  switch (token.kind) {
    case TokenKind::end: return "end of file";
    case TokenKind::string: return "a string";
    default: return "'" + std::string(token.text) + "'";
  }
}

std::string hex(std::uint64_t value) {
  char buffer[24];
  std::snprintf(buffer, sizeof buffer, "0x%llX", static_cast<unsigned long long>(value));
  return buffer;
}

class Lexer {
 public:
  Lexer(std::string_view text, std::vector<Problem>& problems) : text_(text), problems_(problems) {}

  std::vector<Token> run() {
    std::vector<Token> tokens;
    if (text_.substr(0, 3) == "\xEF\xBB\xBF") advance(3);  // UTF-8 byte order mark
    while (pos_ < text_.size()) {
      const char c = text_[pos_];
      if (c == '\n') {
        ++pos_;
        ++line_;
        column_ = 1;
        line_has_token_ = false;
      } else if (c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f') {
        advance(1);
      } else if (c == '/' && peek(1) == '/') {  // not in the DBC spec, but tools write them
        while (pos_ < text_.size() && text_[pos_] != '\n') advance(1);
      } else if (c == '"') {
        tokens.push_back(string_token());
      } else if (is_identifier_start(c)) {
        Token token = start(TokenKind::identifier);
        const std::size_t begin = pos_;
        while (pos_ < text_.size() && is_identifier_char(text_[pos_])) advance(1);
        token.text = text_.substr(begin, pos_ - begin);
        tokens.push_back(std::move(token));
      } else if (starts_number()) {
        tokens.push_back(number_token());
      } else if (std::string_view(":;|@()[],+-").find(c) != std::string_view::npos) {
        Token token = start(TokenKind::punct);
        token.text = text_.substr(pos_, 1);
        advance(1);
        tokens.push_back(std::move(token));
      } else {
        const auto byte = static_cast<unsigned char>(c);
        std::string shown = byte >= 0x20 && byte < 0x7F ? "'" + std::string(1, c) + "'"
                                                        : "byte " + hex(byte);
        problems_.push_back({line_, column_, Severity::error, "unexpected character " + shown});
        advance(1);
      }
    }
    Token end;
    end.line = line_;
    end.column = column_;
    end.first_on_line = true;
    tokens.push_back(std::move(end));
    return tokens;
  }

 private:
  char peek(std::size_t ahead) const {
    return pos_ + ahead < text_.size() ? text_[pos_ + ahead] : '\0';
  }
  void advance(std::size_t count) {
    pos_ += count;
    column_ += static_cast<std::uint32_t>(count);
  }
  Token start(TokenKind kind) {
    Token token;
    token.kind = kind;
    token.line = line_;
    token.column = column_;
    token.first_on_line = !line_has_token_;
    line_has_token_ = true;
    return token;
  }

  // A sign belongs to a number only when a digit follows, so `@1-` stays punctuation.
  bool starts_number() const {
    std::size_t at = 0;
    if (peek(0) == '+' || peek(0) == '-') at = 1;
    if (is_digit(peek(at))) return true;
    return peek(at) == '.' && is_digit(peek(at + 1));
  }

  Token number_token() {
    Token token = start(TokenKind::number);
    const std::size_t begin = pos_;
    if (peek(0) == '+' || peek(0) == '-') advance(1);
    while (is_digit(peek(0))) advance(1);
    if (peek(0) == '.') {
      advance(1);
      while (is_digit(peek(0))) advance(1);
    }
    if (peek(0) == 'e' || peek(0) == 'E') {
      const std::size_t sign = (peek(1) == '+' || peek(1) == '-') ? 1 : 0;
      if (is_digit(peek(1 + sign))) {
        advance(1 + sign);
        while (is_digit(peek(0))) advance(1);
      }
    }
    token.text = text_.substr(begin, pos_ - begin);
    return token;
  }

  // DBC strings may span lines; `\"` and `\\` are the only escapes (as Vector's tools and
  // cantools write them), any other backslash is kept.
  Token string_token() {
    Token token = start(TokenKind::string);
    const std::size_t begin = pos_;
    advance(1);
    bool closed = false;
    while (pos_ < text_.size()) {
      const char c = text_[pos_];
      if (c == '"') {
        advance(1);
        closed = true;
        break;
      }
      if (c == '\\' && (peek(1) == '"' || peek(1) == '\\')) {
        token.value += peek(1);
        advance(2);
        continue;
      }
      token.value += c;
      if (c == '\n') {
        ++pos_;
        ++line_;
        column_ = 1;
      } else {
        advance(1);
      }
    }
    if (!closed) problems_.push_back({token.line, token.column, Severity::error, "unterminated string"});
    token.text = text_.substr(begin, pos_ - begin);
    return token;
  }

  std::string_view text_;
  std::vector<Problem>& problems_;
  std::size_t pos_ = 0;
  std::uint32_t line_ = 1;
  std::uint32_t column_ = 1;
  bool line_has_token_ = false;
};

// ---------------------------------------------------------------------------------------
// What the parser collects before the references are resolved

enum class ObjectKind : std::uint8_t { none, node, message, signal, env_var };

struct ParsedMessage {
  DbcMessage message;
  bool broken = false;    // has an error of its own: not registered
  bool pseudo = false;    // VECTOR__INDEPENDENT_SIG_MSG: accepted, never registered
};

// A statement that names a message (and maybe a signal), resolved after the file is read.
struct Reference {
  std::uint64_t dbc_id = 0;
  Token id_token;
  std::string signal;
  Token signal_token;
};

struct PendingComment {
  ObjectKind kind = ObjectKind::none;
  Reference target;
  std::string node;
  Token node_token;
  std::string text;
};

struct PendingAttribute {
  std::string name;
  Token name_token;
  ObjectKind kind = ObjectKind::none;
  Reference target;
  Token value;
};

struct PendingValues {
  Reference target;
  std::map<std::int64_t, std::string> values;
};

struct PendingValueType {
  Reference target;
  Token value;
  std::uint64_t kind = 0;
};

struct PendingMuxValues {
  Reference target;
  std::string multiplexer;
  Token multiplexer_token;
  std::vector<std::pair<std::int64_t, std::int64_t>> ranges;
};

struct AttributeDefinition {
  ObjectKind kind = ObjectKind::none;
  std::string type;  // INT, HEX, FLOAT, STRING, ENUM
  std::vector<std::string> labels;  // ENUM
  Token default_value;
  bool has_default = false;
};

std::string sanitise_identifier(std::string_view text) {
  std::string out;
  for (const char c : text) out += is_identifier_char(c) ? c : '_';
  if (out.empty()) return "dbc";
  if (is_digit(out[0])) out.insert(out.begin(), '_');
  return out;
}

class DbcParser {
 public:
  explicit DbcParser(std::string file_name) : file_(std::move(file_name)) {}

  // The parser is a set of passes over one file that add_dbc_text drives, so its state
  // is open to it (this class lives in this file only).
  std::vector<Token> tokens_;
  std::size_t pos_ = 0;
  std::vector<Problem> problems_;

  // Statements
  void statement();
  bool version();
  bool namespace_block();
  bool bit_timing();
  bool nodes();
  bool message();
  bool signal();
  bool comment();
  bool attribute_definition();
  bool attribute_default();
  bool attribute();
  bool value_table();
  bool values();
  bool value_type();
  bool mux_values();
  bool value_descriptions(std::map<std::int64_t, std::string>& out);

  // Resolution after the file is read
  ParsedMessage* resolve_message(const Reference& reference);
  DbcSignal* resolve_signal(ParsedMessage& message, const Reference& reference);
  void resolve();
  void check_message(ParsedMessage& parsed);

  // Token helpers
  const Token& peek(std::size_t ahead = 0) const {
    return tokens_[std::min(pos_ + ahead, tokens_.size() - 1)];
  }
  const Token& next() {
    const Token& token = tokens_[pos_];
    if (pos_ + 1 < tokens_.size()) ++pos_;
    return token;
  }
  bool at_end() const { return tokens_[pos_].kind == TokenKind::end; }
  bool at_statement_start() const {
    const Token& token = peek();
    return token.kind == TokenKind::end ||
           (token.first_on_line && token.kind == TokenKind::identifier &&
            (is_keyword(token.text) || looks_like_keyword(token.text)));
  }
  void recover();
  void skip_rest_of_line();
  void error(const Token& at, std::string message) {
    problems_.push_back({at.line, at.column, Severity::error, std::move(message)});
  }
  void warning(const Token& at, std::string message) {
    problems_.push_back({at.line, at.column, Severity::warning, std::move(message)});
  }
  SourceLocation where(const Token& token) const { return {file_, token.line, token.column}; }

  bool expect(char punct, std::string_view context);
  bool expect_identifier(std::string_view what, const Token*& out);
  bool expect_string(std::string_view what, const Token*& out);
  bool number(std::string_view what, double& out, const Token** token = nullptr);
  bool unsigned_integer(std::string_view what, std::uint64_t& out, const Token** token = nullptr);
  bool integer_value(const Token& token, std::string_view what, std::int64_t& out);
  bool message_reference(Reference& out);
  bool signal_reference(Reference& out);

  std::string file_;
  std::shared_ptr<DbcDatabase> database_ = std::make_shared<DbcDatabase>();
  std::vector<ParsedMessage> messages_;
  std::map<std::string, std::size_t, std::less<>> message_names_;
  std::map<std::uint64_t, std::size_t> message_ids_;  // by the id as written
  // The message that SG_ lines attach to, or -1. `in_message_` is also true after a BO_
  // line with errors: its SG_ lines are then read (syntax only) instead of being strays.
  std::int64_t current_ = -1;
  bool in_message_ = false;
  // Which signal owns each bit of the current message, to find overlaps: the signals in
  // every frame (plain and the multiplexer), any multiplexed one, and per multiplexer value.
  std::array<std::int32_t, kMaxFrameBits> plain_owner_{};
  std::array<std::int32_t, kMaxFrameBits> muxed_owner_{};
  std::map<std::int64_t, std::array<std::int32_t, kMaxFrameBits>> group_owner_;

  std::vector<PendingComment> comments_;
  std::vector<PendingAttribute> attributes_;
  std::vector<PendingValues> values_;
  std::vector<PendingValueType> value_types_;
  std::vector<PendingMuxValues> mux_values_;
  std::vector<Reference> message_references_;  // BO_TX_BU_
  std::map<std::string, AttributeDefinition, std::less<>> attribute_definitions_;
};

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
    recover();
  } else if (is_ignored_statement(word)) {
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
    if (known) {
      error(name, "node '" + std::string(name.text) + "' is already defined");
      continue;
    }
    database_->nodes.push_back({std::string(name.text), {}});
  }
  return true;
}

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
      error(*id_token, "message id " + std::string(id_token->text) +
                           " is not a CAN id (29 bits, plus bit 31 for extended frames)");
      parsed.broken = true;
    } else if (!message.extended && id > kCanStandardIdMask) {
      error(*id_token, "standard frame id " + hex(id) +
                           " does not fit in 11 bits (extended ids have bit 31 set: " +
                           std::to_string(id | kCanExtendedFlag) + ")");
      parsed.broken = true;
    }
    message.frame_id = static_cast<std::uint32_t>(id & 0xFFFFFFFFu);
    if (length > kCanMaxDataLength) {
      error(*length_token, "message length " + std::string(length_token->text) +
                               " is more than the 64 bytes of a CAN FD frame");
      parsed.broken = true;
    } else if (!is_can_data_length(static_cast<std::uint32_t>(length))) {
      if (length <= 15) {
        // Some tools write the CAN FD DLC code instead of the length.
        const std::uint32_t bytes = can_dlc_to_length(static_cast<std::uint32_t>(length));
        warning(*length_token, "length " + std::string(length_token->text) +
                                   " read as a CAN FD DLC code: " + std::to_string(bytes) + " bytes");
        length = bytes;
      } else {
        error(*length_token, "message length " + std::string(length_token->text) +
                                 " is not a CAN FD frame length (0-8, 12, 16, 20, 24, 32, 48, 64)");
        parsed.broken = true;
      }
    }
    message.length = static_cast<std::uint32_t>(std::min<std::uint64_t>(length, kCanMaxDataLength));
    message.fd = message.length > 8;
  }

  if (auto it = message_names_.find(message.name); it != message_names_.end()) {
    error(*name, "message '" + message.name + "' is already defined at line " +
                     std::to_string(messages_[it->second].message.where.line));
    parsed.broken = true;
  }
  if (auto it = message_ids_.find(dbc_id); it != message_ids_.end()) {
    error(*id_token, "message id " + std::string(id_token->text) + " is already used by message '" +
                         messages_[it->second].message.name + "'");
    parsed.broken = true;
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
      if (digits < text.size()) {
        error(mux, "extended multiplexing ('" + std::string(text) + "') is not supported");
        return fail();
      }
      std::uint64_t value = 0;
      const auto [end, status] = std::from_chars(text.data() + 1, text.data() + text.size(), value);
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

  // Layout, in the order a reader checks a signal line.
  if (signal.factor == 0) {
    error(*factor_token, "the factor of signal '" + signal.name + "' must not be 0");
    layout_ok = false;
  }
  if (length < 1 || length > 64) {
    error(*length_token, "signal length must be 1 to 64 bits, found " + std::string(length_token->text));
    layout_ok = false;
  }
  if (start >= kMaxFrameBits) {
    error(*start_token, "start bit " + std::string(start_token->text) + " is outside a 64-byte frame");
    layout_ok = false;
  }
  DbcMessage& message = parsed->message;
  for (const DbcSignal& other : message.signals) {
    if (other.name == signal.name) {
      error(*name, "signal '" + signal.name + "' is already defined in message '" + message.name + "'");
      layout_ok = false;
      break;
    }
  }
  if (signal.mux_role == DbcMuxRole::multiplexer && message.multiplexer >= 0) {
    error(*name, "message '" + message.name + "' already has a multiplexer, '" +
                     message.signals[static_cast<std::size_t>(message.multiplexer)].name + "'");
    layout_ok = false;
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
    error(*name, "signal '" + signal.name + "' does not fit in the " + std::to_string(message.length) +
                     "-byte message '" + message.name + "'");
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
    error(*name, "signal '" + signal.name + "' overlaps signal '" +
                     message.signals[static_cast<std::size_t>(overlapped)].name + "'");
    return reject();
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
  if (signal.mux_role == DbcMuxRole::multiplexer) message.multiplexer = index;
  message.signals.push_back(std::move(signal));
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

ObjectKind object_kind(const Token& token) {
  if (token.is_word("BU_")) return ObjectKind::node;
  if (token.is_word("BO_")) return ObjectKind::message;
  if (token.is_word("SG_")) return ObjectKind::signal;
  if (token.is_word("EV_")) return ObjectKind::env_var;
  return ObjectKind::none;
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
    warning(*name, "default for undefined attribute '" + name->value + "'");
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
    error(*name, "value table '" + std::string(name->text) + "' is already defined");
  }
  return true;
}

bool DbcParser::values() {
  if (peek().kind == TokenKind::identifier) {  // an environment variable's values
    next();
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

// SG_MUL_VAL_ <id> <signal> <multiplexer> <lo>-<hi>, ... ; extended multiplexing. Only the
// form that restates a plain `m<N>` signal (one range N-N) is accepted.
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
    pending.ranges.emplace_back(static_cast<std::int64_t>(lo), static_cast<std::int64_t>(hi));
    if (peek().is(',')) next();
  }
  next();
  mux_values_.push_back(std::move(pending));
  return true;
}

// ---------------------------------------------------------------------------------------
// Resolution

ParsedMessage* DbcParser::resolve_message(const Reference& reference) {
  auto it = message_ids_.find(reference.dbc_id);
  if (it == message_ids_.end()) {
    error(reference.id_token, "no message has id " + std::string(reference.id_token.text));
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
    error(reference.signal_token,
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
        error(comment.node_token, "no node is named '" + comment.node + "'");
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

  // Attributes the frames depend on; defaults first, then the per-message values.
  const auto enum_label = [&](const AttributeDefinition& definition, const Token& value) -> std::string {
    if (value.kind == TokenKind::string) return value.value;
    std::int64_t index = 0;
    if (!integer_value(value, "an enum attribute's value", index)) return {};
    if (index < 0 || static_cast<std::uint64_t>(index) >= definition.labels.size()) {
      error(value, "enum value " + std::string(value.text) + " is out of range");
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
        error(value, "GenMsgCycleTime must be a whole number of milliseconds, found " + describe(value));
        return;
      }
      message.cycle_time_ms = static_cast<std::uint32_t>(ms);
    } else if (name == "VFrameFormat" && definition != attribute_definitions_.end()) {
      const std::string label = enum_label(definition->second, value);
      message.fd = message.length > 8 || label.find("FD") != std::string::npos;
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
      warning(attribute.name_token, "attribute '" + attribute.name + "' is not defined (BA_DEF_)");
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
      error(type.value, std::string(type.kind == 1 ? "a float" : "a double") + " signal needs " +
                            std::to_string(needed) + " bits; '" + signal->name + "' has " +
                            std::to_string(signal->length));
      parsed->broken = true;
    } else if (needed != 0 && signal->mux_role == DbcMuxRole::multiplexer) {
      error(type.value, "multiplexer '" + signal->name + "' must be an integer signal");
      parsed->broken = true;
    }
  }

  for (const PendingMuxValues& mux : mux_values_) {
    ParsedMessage* parsed = resolve_message(mux.target);
    if (parsed == nullptr) continue;
    DbcSignal* signal = resolve_signal(*parsed, mux.target);
    if (signal == nullptr) continue;
    const DbcMessage& message = parsed->message;
    const bool restates_plain = signal->mux_role == DbcMuxRole::multiplexed && message.multiplexer >= 0 &&
                                message.signals[static_cast<std::size_t>(message.multiplexer)].name ==
                                    mux.multiplexer &&
                                mux.ranges.size() == 1 && mux.ranges[0].first == signal->mux_value &&
                                mux.ranges[0].second == signal->mux_value;
    if (!restates_plain) {
      error(mux.target.signal_token, "extended multiplexing (SG_MUL_VAL_) is not supported");
      parsed->broken = true;
    }
  }
}

void DbcParser::check_message(ParsedMessage& parsed) {
  DbcMessage& message = parsed.message;
  // A broken message is not registered; its multiplexer may be the line that was bad.
  if (message.multiplexer >= 0 || parsed.broken) return;
  for (const DbcSignal& signal : message.signals) {
    if (signal.mux_role != DbcMuxRole::multiplexed) continue;
    problems_.push_back({signal.where.line, signal.where.column, Severity::error,
                         "signal '" + signal.name + "' is multiplexed but message '" + message.name +
                             "' has no multiplexer (M) signal"});
    parsed.broken = true;
    return;
  }
}

}  // namespace

// ---------------------------------------------------------------------------------------

bool TypeRegistry::add_dbc_text(std::string_view text, const std::string& file_name,
                                Diagnostics& diagnostics) {
  DbcParser parser(file_name);
  parser.tokens_ = Lexer(text, parser.problems_).run();
  while (!parser.at_end()) parser.statement();
  parser.resolve();
  for (ParsedMessage& parsed : parser.messages_) {
    if (!parsed.pseudo) parser.check_message(parsed);
  }

  std::shared_ptr<DbcDatabase> database = parser.database_;
  database->file = file_name;
  database->name = sanitise_identifier(std::filesystem::path(file_name).stem().string());
  for (ParsedMessage& parsed : parser.messages_) {
    if (parsed.pseudo || parsed.broken) continue;
    parsed.message.database = database.get();
    database->messages.push_back(std::move(parsed.message));
  }
  // Registered only once the vector is complete: each type points into it.
  const Type* float64 = primitive(TypeKind::float64);
  for (std::uint32_t i = 0; i < database->messages.size(); ++i) {
    DbcMessage& message = database->messages[i];
    database->by_can_id.emplace_back(message.can_id(), i);
    const std::string name = database->name + "::" + message.name;
    if (by_name_.count(name) != 0) {
      parser.problems_.push_back({message.where.line, message.where.column, Severity::error,
                                  "redefinition of '" + name + "'"});
      continue;
    }
    Type type;
    type.kind = TypeKind::structure;
    type.name = name;
    type.where = message.where;
    type.origin = TypeOrigin::dbc;
    type.dbc = &message;
    for (const DbcSignal& signal : message.signals) {
      Field field;
      field.name = signal.name;
      field.type = float64;
      field.where = signal.where;
      type.fields.push_back(std::move(field));
    }
    layout_struct(type);  // at most 512 doubles: cannot exceed the size limit
    Type& stored = make_type();
    stored = std::move(type);
    declare(stored);
    message.type = &stored;
  }
  std::sort(database->by_can_id.begin(), database->by_can_id.end());
  retain(database);

  std::stable_sort(parser.problems_.begin(), parser.problems_.end(), [](const Problem& a, const Problem& b) {
    return a.line != b.line ? a.line < b.line : a.column < b.column;
  });
  bool ok = true;
  for (Problem& problem : parser.problems_) {
    SourceLocation location{file_name, problem.line, problem.column};
    if (problem.severity == Severity::error) {
      ok = false;
      diagnostics.error(std::move(location), {}, std::move(problem.message));
    } else {
      diagnostics.warning(std::move(location), {}, std::move(problem.message));
    }
  }
  return ok;
}

bool TypeRegistry::add_dbc_file(const std::filesystem::path& file, Diagnostics& diagnostics) {
  return add_file(file, diagnostics, &TypeRegistry::add_dbc_text);
}

// ---------------------------------------------------------------------------------------
// Look-ups

const DbcSignal* DbcMessage::find_signal(std::string_view signal_name) const noexcept {
  for (const DbcSignal& signal : signals) {
    if (signal.name == signal_name) return &signal;
  }
  return nullptr;
}

const DbcMessage* DbcDatabase::find_message(std::uint32_t can_id) const noexcept {
  // RTR and error flags are not part of the identity; the extended flag is.
  const std::uint32_t key = (can_id & kCanExtendedFlag) != 0
                                ? can_id & (kCanExtendedFlag | kCanExtendedIdMask)
                                : can_id & kCanStandardIdMask;
  auto it = std::lower_bound(by_can_id.begin(), by_can_id.end(), key,
                             [](const std::pair<std::uint32_t, std::uint32_t>& item, std::uint32_t value) {
                               return item.first < value;
                             });
  if (it == by_can_id.end() || it->first != key) return nullptr;
  return &messages[it->second];
}

const DbcMessage* DbcDatabase::find_message(std::string_view message_name) const noexcept {
  for (const DbcMessage& message : messages) {
    if (message.name == message_name) return &message;
  }
  return nullptr;
}

std::vector<const DbcDatabase*> dbc_databases(const TypeRegistry& registry) {
  std::vector<const DbcDatabase*> out;
  for (const Type* type : registry.declared()) {
    if (type->origin != TypeOrigin::dbc || type->dbc == nullptr) continue;
    const DbcDatabase* database = type->dbc->database;
    if (database != nullptr && std::find(out.begin(), out.end(), database) == out.end()) {
      out.push_back(database);
    }
  }
  return out;
}

const DbcDatabase* find_dbc_database(const TypeRegistry& registry, std::string_view name) {
  for (const DbcDatabase* database : dbc_databases(registry)) {
    if (database->name == name) return database;
  }
  return nullptr;
}

}  // namespace polyport
