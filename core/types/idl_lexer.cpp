// The IDL lexer: splits IDL text into tokens (idl_lexer.hpp) for the IDL parser. It skips
// white space, comments and preprocessor lines, decodes string and character literals and
// numbers, and reports malformed ones (as tokens of kind `invalid`, so the parser does not
// report them again).
#include <charconv>
#include <cstdint>
#include <limits>
#include <string>
#include <string_view>
#include <system_error>
#include <utility>
#include <vector>

#include "idl_lexer.hpp"

namespace polyport::idl_detail {

namespace {

bool is_ident_start(char c) { return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || c == '_'; }
bool is_digit(char c) { return c >= '0' && c <= '9'; }
bool is_ident_char(char c) { return is_ident_start(c) || is_digit(c); }
bool is_hex_digit(char c) {
  return is_digit(c) || (c >= 'a' && c <= 'f') || (c >= 'A' && c <= 'F');
}
int hex_value(char c) {
  if (is_digit(c)) return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  return c - 'A' + 10;
}

std::string printable(char c) {
  const auto byte = static_cast<unsigned char>(c);
  if (byte >= 0x20 && byte < 0x7F) return std::string(1, c);
  constexpr char kHex[] = "0123456789ABCDEF";
  return std::string("\\x") + kHex[byte >> 4] + kHex[byte & 0xF];
}

void append_utf8(std::string& out, std::uint32_t code_point) {
  if (code_point < 0x80) {
    out += static_cast<char>(code_point);
  } else if (code_point < 0x800) {
    out += static_cast<char>(0xC0 | (code_point >> 6));
    out += static_cast<char>(0x80 | (code_point & 0x3F));
  } else {
    out += static_cast<char>(0xE0 | (code_point >> 12));
    out += static_cast<char>(0x80 | ((code_point >> 6) & 0x3F));
    out += static_cast<char>(0x80 | (code_point & 0x3F));
  }
}

class Lexer {
 public:
  Lexer(std::string_view text, std::vector<RawDiagnostic>& diagnostics)
      : text_(text), diagnostics_(diagnostics) {
    if (text_.starts_with("\xEF\xBB\xBF")) pos_ = 3;  // UTF-8 byte order mark
  }

  std::vector<Token> run() {
    std::vector<Token> tokens;
    std::uint32_t end_line = 1;
    std::uint32_t end_column = 1;
    while (skip_blanks()) {
      Token token;
      token.line = line_;
      token.column = column_;
      if (lex_token(token)) {
        end_line = line_;
        end_column = column_;
        tokens.push_back(std::move(token));
      }
    }
    // The end sits right after the last token, where a missing `;` or `}` belongs.
    Token end;
    end.kind = TokenKind::end;
    end.line = tokens.empty() ? 1 : end_line;
    end.column = tokens.empty() ? 1 : end_column;
    tokens.push_back(std::move(end));
    return tokens;
  }

 private:
  bool at_end() const { return pos_ >= text_.size(); }
  char peek(std::size_t ahead = 0) const {
    return pos_ + ahead < text_.size() ? text_[pos_ + ahead] : '\0';
  }
  void advance() {
    if (at_end()) return;
    if (text_[pos_] == '\n') {
      ++line_;
      column_ = 1;
      line_start_ = true;
    } else {
      ++column_;
      if (text_[pos_] != ' ' && text_[pos_] != '\t' && text_[pos_] != '\r') line_start_ = false;
    }
    ++pos_;
  }
  void error(std::uint32_t line, std::uint32_t column, std::string message) {
    diagnostics_.push_back({line, column, std::move(message)});
  }

  // Skips white space, comments and preprocessor lines; false at the end of the text.
  bool skip_blanks() {
    while (!at_end()) {
      const char c = peek();
      if (c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\f' || c == '\v') {
        advance();
      } else if (c == '/' && peek(1) == '/') {
        while (!at_end() && peek() != '\n') advance();
      } else if (c == '/' && peek(1) == '*') {
        const std::uint32_t line = line_;
        const std::uint32_t column = column_;
        advance();
        advance();
        while (!at_end() && !(peek() == '*' && peek(1) == '/')) advance();
        if (at_end()) {
          error(line, column, "unterminated comment");
          return false;
        }
        advance();
        advance();
      } else if (c == '#' && line_start_) {
        // #include, #pragma, include guards: the types come from the files the profile
        // names, so preprocessor lines are ignored (continuation lines included).
        while (!at_end() && peek() != '\n') {
          if (peek() == '\\' && peek(1) == '\n') advance();
          advance();
        }
      } else {
        return true;
      }
    }
    return false;
  }

  bool lex_token(Token& token) {
    const char c = peek();
    if (is_ident_start(c)) {
      token.kind = TokenKind::identifier;
      while (is_ident_char(peek())) {
        token.text += peek();
        advance();
      }
      return true;
    }
    if (is_digit(c) || (c == '.' && is_digit(peek(1)))) return lex_number(token);
    if (c == '"') return lex_string(token);
    if (c == '\'') return lex_character(token);
    if (c == ':' && peek(1) == ':') {
      token.kind = TokenKind::punct;
      token.text = "::";
      advance();
      advance();
      return true;
    }
    constexpr std::string_view kPunctuators = "{}()[]<>;,:=+-*/%|^&~@";
    if (kPunctuators.find(c) != std::string_view::npos) {
      token.kind = TokenKind::punct;
      token.text = std::string(1, c);
      advance();
      return true;
    }
    if (static_cast<unsigned char>(c) >= 0x80) {
      // One error for a run of non-ASCII bytes (a UTF-8 character), not one per byte.
      error(token.line, token.column, "unexpected non-ASCII character");
      while (!at_end() && static_cast<unsigned char>(peek()) >= 0x80) advance();
      return false;
    }
    error(token.line, token.column, "unexpected character '" + printable(c) + "'");
    advance();
    return false;
  }

  static bool invalid(Token& token) {
    token.kind = TokenKind::invalid;
    return true;
  }

  bool lex_number(Token& token) {
    const std::size_t start = pos_;
    bool floating = false;
    bool valid = true;
    std::uint64_t value = 0;
    bool overflow = false;
    const auto accumulate = [&](std::uint64_t base, int digit) {
      if (value >
          (std::numeric_limits<std::uint64_t>::max() - static_cast<std::uint64_t>(digit)) / base) {
        overflow = true;
      }
      value = value * base + static_cast<std::uint64_t>(digit);
    };
    if (peek() == '0' && (peek(1) == 'x' || peek(1) == 'X')) {
      advance();
      advance();
      if (!is_hex_digit(peek())) valid = false;
      while (is_hex_digit(peek())) {
        accumulate(16, hex_value(peek()));
        advance();
      }
    } else {
      while (is_digit(peek())) advance();
      if (peek() == '.') {
        floating = true;
        advance();
        while (is_digit(peek())) advance();
      }
      if ((peek() == 'e' || peek() == 'E') &&
          (is_digit(peek(1)) || ((peek(1) == '+' || peek(1) == '-') && is_digit(peek(2))))) {
        floating = true;
        advance();
        if (peek() == '+' || peek() == '-') advance();
        while (is_digit(peek())) advance();
      }
      if (!floating) {
        const std::string_view digits = text_.substr(start, pos_ - start);
        const bool octal = digits.size() > 1 && digits[0] == '0';
        for (char digit : digits) {
          if (octal && digit > '7') valid = false;
          accumulate(octal ? 8 : 10, digit - '0');
        }
      }
    }
    // A suffix glued to the number (`12u`, `1.5d`) makes the whole literal invalid.
    while (is_ident_char(peek()) || (floating && peek() == '.')) {
      valid = false;
      advance();
    }
    const std::string spelling(text_.substr(start, pos_ - start));
    if (!valid) {
      error(token.line, token.column, "invalid numeric literal '" + spelling + "'");
      return invalid(token);
    }
    token.text = spelling;
    if (floating) {
      token.kind = TokenKind::floating;
      const auto result =
          std::from_chars(spelling.data(), spelling.data() + spelling.size(), token.float_value);
      if (result.ec != std::errc()) {
        error(token.line, token.column,
              "floating-point literal '" + spelling + "' is out of range");
        return invalid(token);
      }
      return true;
    }
    if (overflow || value > static_cast<std::uint64_t>(std::numeric_limits<std::int64_t>::max())) {
      error(token.line, token.column, "integer literal '" + spelling + "' is too large");
      return invalid(token);
    }
    token.kind = TokenKind::integer;
    token.int_value = static_cast<std::int64_t>(value);
    return true;
  }

  // Reads one possibly escaped character of a string or character literal into `out`.
  void lex_literal_char(std::string& out) {
    const std::uint32_t line = line_;
    const std::uint32_t column = column_;
    if (peek() != '\\') {
      out += peek();
      advance();
      return;
    }
    advance();
    const char e = peek();
    static constexpr std::pair<char, char> kSimpleEscapes[] = {
        {'n', '\n'}, {'t', '\t'},  {'v', '\v'}, {'b', '\b'},  {'r', '\r'}, {'f', '\f'},
        {'a', '\a'}, {'\\', '\\'}, {'?', '?'},  {'\'', '\''}, {'"', '"'}};
    for (const auto& [name, value] : kSimpleEscapes) {
      if (e == name) {
        out += value;
        advance();
        return;
      }
    }
    if (e >= '0' && e <= '7') {
      int value = 0;
      for (int i = 0; i < 3 && peek() >= '0' && peek() <= '7'; ++i) {
        value = value * 8 + (peek() - '0');
        advance();
      }
      out += static_cast<char>(value & 0xFF);
      return;
    }
    if (e == 'x' || e == 'u') {
      advance();
      const int max_digits = e == 'x' ? 2 : 4;
      std::uint32_t value = 0;
      int digits = 0;
      while (digits < max_digits && is_hex_digit(peek())) {
        value = value * 16 + static_cast<std::uint32_t>(hex_value(peek()));
        advance();
        ++digits;
      }
      if (digits == 0) {
        error(line, column, std::string("invalid escape sequence '\\") + e + "'");
        return;
      }
      if (e == 'x') {
        out += static_cast<char>(value);
      } else {
        append_utf8(out, value);
      }
      return;
    }
    if (e == '\n' || e == '\0') return;  // reported by the caller as unterminated
    error(line, column, "invalid escape sequence '\\" + printable(e) + "'");
    advance();
  }

  bool lex_string(Token& token) {
    advance();  // opening quote
    while (!at_end() && peek() != '"' && peek() != '\n') lex_literal_char(token.text);
    if (peek() != '"') {
      error(token.line, token.column, "unterminated string literal");
      return invalid(token);
    }
    advance();
    token.kind = TokenKind::string;
    return true;
  }

  bool lex_character(Token& token) {
    advance();  // opening quote
    while (!at_end() && peek() != '\'' && peek() != '\n') lex_literal_char(token.text);
    if (peek() != '\'') {
      error(token.line, token.column, "unterminated character literal");
      return invalid(token);
    }
    advance();
    token.kind = TokenKind::character;
    return true;
  }

  std::string_view text_;
  std::vector<RawDiagnostic>& diagnostics_;
  std::size_t pos_ = 0;
  std::uint32_t line_ = 1;
  std::uint32_t column_ = 1;
  bool line_start_ = true;
};

}  // namespace

std::vector<Token> lex_idl(std::string_view text, std::vector<RawDiagnostic>& diagnostics) {
  return Lexer(text, diagnostics).run();
}

}  // namespace polyport::idl_detail
