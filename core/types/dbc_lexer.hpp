// The DBC lexer's tokens (dbc_lexer.cpp) and the problem list every DBC pass appends to;
// shared by the DBC parser's files, private to the types layer.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "polyport/base/diagnostics.hpp"

namespace polyport::dbc_detail {

inline bool is_identifier_start(char c) {
  return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || c == '_';
}
inline bool is_digit(char c) { return c >= '0' && c <= '9'; }
inline bool is_identifier_char(char c) { return is_identifier_start(c) || is_digit(c); }

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

// How a message names a token: "end of file", "a string" or the quoted text.
std::string describe(const Token& token);
std::string hex(std::uint64_t value);  // "0x1F"

// Splits DBC text into tokens; the last one is of kind `end`. Stray characters and
// unterminated strings are appended to `problems`, and a warning when the text is not
// UTF-8 (its strings are then read as Windows-1252 and kept as UTF-8).
std::vector<Token> lex_dbc(std::string_view text, std::vector<Problem>& problems);

}  // namespace polyport::dbc_detail
