// The DBC lexer: splits a DBC file into identifiers, numbers, strings and punctuation,
// marking the first token of each line (statements start a line; recovery relies on it).
// CR before LF is blank space; a file that is not UTF-8 is Windows-1252 (CANdb++ writes
// it), and its strings are converted to UTF-8 here, with one warning.
#include <cstdint>
#include <cstdio>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "dbc_lexer.hpp"

namespace polyport::dbc_detail {

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

namespace {

// The offset of the first byte that is not part of a well-formed UTF-8 sequence, or npos.
std::size_t first_non_utf8(std::string_view text) {
  std::size_t i = 0;
  while (i < text.size()) {
    const auto byte = static_cast<unsigned char>(text[i]);
    std::size_t extra = 0;
    std::uint32_t min = 0;
    if (byte < 0x80) {
      ++i;
      continue;
    }
    if ((byte & 0xE0) == 0xC0) {
      extra = 1;
      min = 0x80;
    } else if ((byte & 0xF0) == 0xE0) {
      extra = 2;
      min = 0x800;
    } else if ((byte & 0xF8) == 0xF0) {
      extra = 3;
      min = 0x10000;
    } else {
      return i;
    }
    if (i + extra >= text.size()) return i;  // cut short by the end of the text
    std::uint32_t code = byte & (0x3F >> extra);
    for (std::size_t k = 1; k <= extra; ++k) {
      const auto next = static_cast<unsigned char>(text[i + k]);
      if ((next & 0xC0) != 0x80) return i;
      code = (code << 6) | (next & 0x3F);
    }
    if (code < min || code > 0x10FFFF || (code >= 0xD800 && code <= 0xDFFF)) return i;
    i += extra + 1;
  }
  return std::string_view::npos;
}

// Windows-1252 (a superset of Latin-1 for printable characters) as UTF-8: the encoding
// Vector's CANdb++ writes, so units such as "°C" arrive as 0xB0 'C'.
void append_windows_1252(std::string& out, unsigned char byte) {
  static constexpr std::uint16_t kHigh[32] = {
      0x20AC, 0x0081, 0x201A, 0x0192, 0x201E, 0x2026, 0x2020, 0x2021, 0x02C6, 0x2030, 0x0160,
      0x2039, 0x0152, 0x008D, 0x017D, 0x008F, 0x0090, 0x2018, 0x2019, 0x201C, 0x201D, 0x2022,
      0x2013, 0x2014, 0x02DC, 0x2122, 0x0161, 0x203A, 0x0153, 0x009D, 0x017E, 0x0178};
  const std::uint32_t code = byte >= 0x80 && byte < 0xA0 ? kHigh[byte - 0x80] : byte;
  if (code < 0x80) {
    out += static_cast<char>(code);
  } else if (code < 0x800) {
    out += static_cast<char>(0xC0 | (code >> 6));
    out += static_cast<char>(0x80 | (code & 0x3F));
  } else {
    out += static_cast<char>(0xE0 | (code >> 12));
    out += static_cast<char>(0x80 | ((code >> 6) & 0x3F));
    out += static_cast<char>(0x80 | (code & 0x3F));
  }
}

class Lexer {
 public:
  Lexer(std::string_view text, std::vector<Problem>& problems) : text_(text), problems_(problems) {}

  std::vector<Token> run() {
    std::vector<Token> tokens;
    if (text_.substr(0, 3) == "\xEF\xBB\xBF") advance(3);  // UTF-8 byte order mark
    // A file that is not UTF-8 is read as Windows-1252, and its strings are kept as UTF-8.
    if (const std::size_t bad = first_non_utf8(text_); bad != std::string_view::npos) {
      windows_1252_ = true;
      std::uint32_t line = 1;
      std::size_t line_start = 0;
      for (std::size_t i = 0; i < bad; ++i) {
        if (text_[i] == '\n') {
          ++line;
          line_start = i + 1;
        }
      }
      problems_.push_back({line, static_cast<std::uint32_t>(bad - line_start + 1), Severity::warning,
                           "the file is not UTF-8: its text is read as Windows-1252 (Latin-1)"});
    }
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
      if (c == '\r' && peek(1) == '\n') {  // a CRLF file's line break is "\n" in the text too
        advance(1);
        continue;
      }
      if (windows_1252_ && static_cast<unsigned char>(c) >= 0x80) {
        append_windows_1252(token.value, static_cast<unsigned char>(c));
      } else {
        token.value += c;
      }
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
  bool windows_1252_ = false;
};

}  // namespace

std::vector<Token> lex_dbc(std::string_view text, std::vector<Problem>& problems) {
  return Lexer(text, problems).run();
}

}  // namespace polyport::dbc_detail
