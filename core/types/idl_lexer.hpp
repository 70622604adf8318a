// The IDL lexer's tokens (idl_lexer.cpp), shared by the IDL parser's files; private to the
// types layer.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace polyport::idl_detail {

// `invalid` stands for a malformed literal the lexer already reported; the parser fails
// quietly on it instead of adding a second error for the same text.
enum class TokenKind : std::uint8_t {
  identifier,
  integer,
  floating,
  string,
  character,
  punct,
  invalid,
  end
};

struct Token {
  TokenKind kind = TokenKind::end;
  std::string text;  // identifier, punctuator, or the decoded string / character literal
  std::uint32_t line = 0;
  std::uint32_t column = 0;
  std::int64_t int_value = 0;
  double float_value = 0.0;
};

struct RawDiagnostic {
  std::uint32_t line;
  std::uint32_t column;
  std::string message;
};

// Splits IDL text into tokens; the last one is of kind `end`, placed right after the last
// real token. Problems are appended to `diagnostics` in the order they are found.
std::vector<Token> lex_idl(std::string_view text, std::vector<RawDiagnostic>& diagnostics);

}  // namespace polyport::idl_detail
