// The DBC parser (parse_dbc, polyport/types/dbc_parser.hpp) as a class shared by the files
// that hold its passes: dbc_statements.cpp and dbc_messages.cpp read the statements,
// dbc_resolve.cpp resolves what they refer to, dbc_parser.cpp drives them and registers the
// types. Private to the types layer.
#pragma once

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "dbc_lexer.hpp"
#include "polyport/base/diagnostics.hpp"
#include "polyport/types/dbc.hpp"

namespace polyport::dbc_detail {

inline constexpr std::string_view kNoNode = "Vector__XXX";
// Vector's pseudo message that holds signals belonging to no message; never a frame.
inline constexpr std::string_view kIndependentSignals = "VECTOR__INDEPENDENT_SIG_MSG";
inline constexpr std::uint32_t kMaxFrameBits = kCanMaxDataLength * 8;

// ---------------------------------------------------------------------------------------
// What the parser collects before the references are resolved

enum class ObjectKind : std::uint8_t { none, node, message, signal, env_var };

struct ParsedMessage {
  DbcMessage message;
  bool broken = false;    // not registered: a syntax error in its lines, or `problem`
  bool pseudo = false;    // VECTOR__INDEPENDENT_SIG_MSG: accepted, never registered
  // A problem confined to this message (overlapping signals, a signal beyond its length,
  // a multiplexer loop, ...): the file still loads, the message is declared unusable
  // (TypeRegistry::declare_unusable) and only a profile that names it fails.
  std::string problem;
  std::uint32_t problem_line = 0;
  std::uint32_t problem_column = 0;
  std::uint32_t more_problems = 0;
  // Extended multiplexing (an `m<N>M` switch, or an SG_MUL_VAL_ that says more than an
  // `m<N>`): which signals can share a frame is known only once the SG_MUL_VAL_ lines are
  // read, so check_message decides overlaps then. What the SG_ lines found under the plain
  // rules (an overlap within one value of the `M`, a second `M`) waits in `plain_problems`
  // and becomes the message's problem only if the message turns out plain.
  bool extended = false;
  struct Deferred {
    Token at;
    std::string message;
  };
  std::vector<Deferred> plain_problems;
};

// Constructs reported once per kind and file: the first one's place, and how many there are.
struct Occurrences {
  std::string kind;
  std::uint32_t line = 0;
  std::uint32_t column = 0;
  std::string message;
  std::size_t count = 0;
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
  std::vector<DbcMuxRange> ranges;
};

struct AttributeDefinition {
  ObjectKind kind = ObjectKind::none;
  std::string type;  // INT, HEX, FLOAT, STRING, ENUM
  std::vector<std::string> labels;  // ENUM
  Token default_value;
  bool has_default = false;
};

// The problem of a second `M` that no SG_MUL_VAL_ puts under another switch.
inline std::string already_has_multiplexer(const DbcMessage& message, const DbcSignal& first) {
  return "message '" + message.name + "' already has a multiplexer, '" + first.name + "'";
}

// Reads all of `text` as a finite double (a leading `+` allowed); false if it is not one
// (dbc_statements.cpp).
bool parse_double(std::string_view text, double& out);

class DbcParser {
 public:
  explicit DbcParser(std::string file_name) : file_(std::move(file_name)) {}

  // The parser is a set of passes over one file that parse_dbc (dbc_parser.cpp) drives, so
  // its state is open to it (this class is private to the types layer).
  std::vector<Token> tokens_;
  std::size_t pos_ = 0;
  std::vector<Problem> problems_;

  // Statements (dbc_statements.cpp; BO_ and SG_ in dbc_messages.cpp)
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

  // Resolution after the file is read (dbc_resolve.cpp)
  ParsedMessage* resolve_message(const Reference& reference);
  DbcSignal* resolve_signal(ParsedMessage& message, const Reference& reference);
  void resolve();
  void check_message(ParsedMessage& parsed);
  void check_multiplexing(ParsedMessage& parsed);
  void check_extended_overlaps(ParsedMessage& parsed);
  void warn_values_no_switch_holds(const DbcMessage& message);

  // Token helpers (those defined out of the class are in dbc_statements.cpp)
  const Token& peek(std::size_t ahead = 0) const {
    return tokens_[std::min(pos_ + ahead, tokens_.size() - 1)];
  }
  const Token& next() {
    const Token& token = tokens_[pos_];
    if (pos_ + 1 < tokens_.size()) ++pos_;
    return token;
  }
  bool at_end() const { return tokens_[pos_].kind == TokenKind::end; }
  bool at_statement_start() const;
  void recover();
  void skip_rest_of_line();
  void error(const Token& at, std::string message) {
    problems_.push_back({at.line, at.column, Severity::error, std::move(message)});
  }
  void warning(const Token& at, std::string message) {
    problems_.push_back({at.line, at.column, Severity::warning, std::move(message)});
  }
  // One warning per `kind` and file, at the first occurrence, ending in "(N in this file)".
  void once(std::string_view kind, const Token& at, std::string message) {
    for (Occurrences& item : occurrences_) {
      if (item.kind != kind) continue;
      ++item.count;
      // Statements are resolved after the file is read, not in file order: keep the first.
      if (at.line < item.line || (at.line == item.line && at.column < item.column)) {
        item.line = at.line;
        item.column = at.column;
        item.message = std::move(message);
      }
      return;
    }
    occurrences_.push_back({std::string(kind), at.line, at.column, std::move(message), 1});
  }
  // A problem confined to one message (ParsedMessage::problem); the first one is kept.
  void message_problem(ParsedMessage& parsed, const Token& at, std::string message) {
    parsed.broken = true;
    if (!parsed.problem.empty()) {
      ++parsed.more_problems;
      return;
    }
    parsed.problem = std::move(message);
    parsed.problem_line = at.line;
    parsed.problem_column = at.column;
  }
  // The SG_ lines' plain-multiplexing problems (ParsedMessage::plain_problems): kept until
  // check_message knows whether the message is plain.
  void plain_problem(ParsedMessage& parsed, const Token& at, std::string message) {
    parsed.plain_problems.push_back({at, std::move(message)});
  }
  // A statement naming a message, signal or node the file does not define: ignored.
  void dangling(const Token& at, const std::string& message) {
    once("dangling", at, message + "; statements naming what the file does not define are ignored");
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
  std::vector<Occurrences> occurrences_;
  std::map<std::string, AttributeDefinition, std::less<>> attribute_definitions_;
};

}  // namespace polyport::dbc_detail
