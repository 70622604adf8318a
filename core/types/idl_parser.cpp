// An OMG IDL subset for data types: modules, structs, enums, typedefs, constants, fixed
// arrays, sequences and strings. Everything else in IDL (interfaces, unions, valuetypes,
// ...) is reported as unsupported. The parser reports every error it finds, resynchronising
// at the next `;` or `}` of the current nesting level after each one.
#include <algorithm>
#include <charconv>
#include <cstdint>
#include <fstream>
#include <limits>
#include <optional>
#include <set>
#include <sstream>
#include <string>
#include <string_view>
#include <system_error>
#include <utility>
#include <vector>

#include "polyport/types/types.hpp"

namespace polyport {

namespace {

constexpr std::uint64_t kMaxTypeSize = std::numeric_limits<std::uint32_t>::max();
// Recursion limits, so hostile input ends in an error instead of a stack overflow.
constexpr std::size_t kMaxModuleDepth = 100;
constexpr int kMaxTypeDepth = 100;
constexpr int kMaxExpressionDepth = 200;

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

// Words that cannot name a module, type, member or constant. IDL reserves more; only the
// ones this subset gives a meaning to, or reports as unsupported, are refused, so that
// field names like `port` or `context` keep working.
const std::set<std::string, std::less<>> kReserved = {
    "module",   "struct", "enum",    "typedef",   "const",     "sequence",  "string",
    "wstring",  "char",   "wchar",   "boolean",   "octet",     "short",     "long",
    "unsigned", "float",  "double",  "int8",      "uint8",     "int16",     "uint16",
    "int32",    "uint32", "int64",   "uint64",    "TRUE",      "FALSE",     "union",
    "switch",   "case",   "default", "interface", "exception", "valuetype", "any",
    "fixed",    "native", "map",     "bitset",    "bitmask",   "void",      "Object",
};

// Declarations this subset does not support; each gets its own message.
const std::set<std::string, std::less<>> kUnsupportedDeclarations = {
    "union",  "interface", "exception", "valuetype", "abstract",   "local",
    "custom", "eventtype", "component", "home",      "porttype",   "connector",
    "native", "bitset",    "bitmask",   "typeid",    "typeprefix", "import",
};

const std::set<std::string, std::less<>> kUnsupportedTypes = {
    "wstring", "wchar", "any", "fixed", "map", "Object", "ValueBase", "void",
};

struct ScopedName {
  std::string spelled;  // as written, for messages
  std::string joined;   // without a leading `::`
  bool absolute = false;
};

std::string join_scope(const std::vector<std::string>& scope, std::size_t count) {
  std::string out;
  for (std::size_t i = 0; i < count; ++i) {
    if (!out.empty()) out += "::";
    out += scope[i];
  }
  return out;
}

std::uint64_t align_up(std::uint64_t value, std::uint64_t alignment) {
  if (alignment <= 1) return value;
  return (value + alignment - 1) / alignment * alignment;
}

bool is_integer_kind(TypeKind kind) {
  return kind == TypeKind::octet || (kind >= TypeKind::int8 && kind <= TypeKind::uint64);
}

bool in_range(TypeKind kind, std::int64_t value) {
  switch (kind) {
    case TypeKind::octet:
    case TypeKind::uint8: return value >= 0 && value <= 0xFF;
    case TypeKind::int8: return value >= -128 && value <= 127;
    case TypeKind::int16: return value >= -32768 && value <= 32767;
    case TypeKind::uint16: return value >= 0 && value <= 0xFFFF;
    case TypeKind::int32:
      return value >= std::numeric_limits<std::int32_t>::min() &&
             value <= std::numeric_limits<std::int32_t>::max();
    case TypeKind::uint32: return value >= 0 && value <= 0xFFFFFFFFLL;
    case TypeKind::int64: return true;
    case TypeKind::uint64: return value >= 0;
    default: return false;
  }
}

}  // namespace

class IdlParser {
 public:
  IdlParser(TypeRegistry& registry, std::string file_name)
      : registry_(registry), file_(std::move(file_name)) {}

  bool parse(std::string_view text, Diagnostics& diagnostics) {
    tokens_ = Lexer(text, raw_).run();
    parse_definitions(false);
    // Lexer errors are found before parser errors; report them all in source order.
    std::stable_sort(raw_.begin(), raw_.end(), [](const RawDiagnostic& a, const RawDiagnostic& b) {
      return a.line != b.line ? a.line < b.line : a.column < b.column;
    });
    for (RawDiagnostic& item : raw_) {
      diagnostics.error(SourceLocation{file_, item.line, item.column}, std::string(),
                        std::move(item.message));
    }
    return raw_.empty();
  }

 private:
  // Counts recursion for as long as a parse function runs, also when it throws.
  struct DepthGuard {
    explicit DepthGuard(int& depth) : depth_(depth) { ++depth_; }
    ~DepthGuard() { --depth_; }
    DepthGuard(const DepthGuard&) = delete;
    DepthGuard& operator=(const DepthGuard&) = delete;
    int& depth_;
  };
  struct FlagGuard {
    FlagGuard(bool& flag, bool value) : flag_(flag), saved_(flag) { flag_ = value; }
    ~FlagGuard() { flag_ = saved_; }
    FlagGuard(const FlagGuard&) = delete;
    FlagGuard& operator=(const FlagGuard&) = delete;
    bool& flag_;
    bool saved_;
  };

  // Thrown after the problem was reported (or was caused by an earlier, reported one);
  // caught where the parser resynchronises.
  struct Failed {};

  // ---- tokens ---------------------------------------------------------------------------

  const Token& peek(std::size_t ahead = 0) const {
    const std::size_t index = std::min(pos_ + ahead, tokens_.size() - 1);
    return tokens_[index];
  }
  const Token& next() {
    const Token& token = tokens_[pos_];
    if (pos_ + 1 < tokens_.size()) ++pos_;
    return token;
  }
  static bool is_punct(const Token& token, std::string_view text) {
    return token.kind == TokenKind::punct && token.text == text;
  }
  static bool is_word(const Token& token, std::string_view word) {
    return token.kind == TokenKind::identifier && token.text == word;
  }
  bool at_end() const { return peek().kind == TokenKind::end; }
  bool accept(std::string_view punct) {
    if (!is_punct(peek(), punct)) return false;
    next();
    return true;
  }
  // Two adjacent single-character tokens, for `<<` and `>>`, which the lexer leaves split
  // so that `sequence<sequence<long>>` closes two templates.
  bool is_pair(std::string_view punct) const {
    const Token& first = peek();
    const Token& second = peek(1);
    return is_punct(first, punct) && is_punct(second, punct) && first.line == second.line &&
           second.column == first.column + 1;
  }
  SourceLocation location(const Token& token) const {
    return SourceLocation{file_, token.line, token.column};
  }

  // ---- diagnostics ----------------------------------------------------------------------

  void error(const Token& at, std::string message) {
    if (at.kind == TokenKind::invalid) return;  // the lexer has reported this token
    raw_.push_back({at.line, at.column, std::move(message)});
  }
  [[noreturn]] void fail(const Token& at, std::string message) {
    error(at, std::move(message));
    throw Failed{};
  }
  void expect(std::string_view punct, std::string message) {
    if (!accept(punct)) fail(peek(), std::move(message));
  }

  // Skips the rest of a broken declaration: through the next `;` of this nesting level, or
  // up to (not through) the `}` that closes the enclosing body.
  void synchronize() {
    int depth = 0;
    while (!at_end()) {
      const Token& token = peek();
      if (is_punct(token, "{")) {
        ++depth;
      } else if (is_punct(token, "}")) {
        if (depth == 0) return;
        --depth;
      } else if (is_punct(token, ";") && depth == 0) {
        next();
        return;
      }
      next();
    }
  }

  // ---- names ----------------------------------------------------------------------------

  std::string expect_name(std::string message) {
    const Token& token = peek();
    if (token.kind != TokenKind::identifier) fail(token, std::move(message));
    if (kReserved.contains(token.text))
      fail(token, std::move(message) + " ('" + token.text + "' is a keyword)");
    std::string name = token.text;
    // IDL's escaped identifiers: `_module` names a member `module`.
    if (name.size() > 1 && name[0] == '_' && kReserved.contains(std::string_view(name).substr(1))) {
      name.erase(0, 1);
    }
    next();
    return name;
  }

  std::string qualify(const std::string& name) const {
    std::string scope = join_scope(scope_, scope_.size());
    return scope.empty() ? name : scope + "::" + name;
  }

  // A failed declaration still takes its name: a second one is a redefinition.
  bool name_taken(std::string_view qualified) const {
    return registry_.by_name_.contains(qualified) || registry_.constants_.contains(qualified) ||
           registry_.modules_.contains(qualified) || failed_names_.contains(qualified);
  }

  void check_new_name(const Token& at, const std::string& qualified) {
    if (name_taken(qualified)) fail(at, "redefinition of '" + qualified + "'");
  }

  ScopedName parse_scoped_name() {
    ScopedName name;
    if (accept("::")) {
      name.absolute = true;
      name.spelled = "::";
    }
    while (true) {
      const Token& token = peek();
      if (token.kind != TokenKind::identifier || kReserved.contains(token.text)) {
        fail(token, "expected an identifier after '::'");
      }
      name.spelled += token.text;
      if (!name.joined.empty()) name.joined += "::";
      name.joined += token.text;
      next();
      if (!is_punct(peek(), "::")) break;
      next();
      name.spelled += "::";
    }
    return name;
  }

  // The qualified names a scoped name may refer to, innermost scope first, as IDL resolves
  // a relative name by searching the enclosing scopes outward.
  std::vector<std::string> candidates(const ScopedName& name) const {
    if (name.absolute) return {name.joined};
    std::vector<std::string> out;
    for (std::size_t count = scope_.size() + 1; count-- > 0;) {
      const std::string prefix = join_scope(scope_, count);
      out.push_back(prefix.empty() ? name.joined : prefix + "::" + name.joined);
    }
    return out;
  }

  const Type* resolve_type(const ScopedName& name, const Token& at) {
    for (const std::string& candidate : candidates(name)) {
      // Built-in names are keywords, which never reach here, so every hit is a user type.
      if (auto it = registry_.by_name_.find(candidate); it != registry_.by_name_.end()) {
        return it->second;
      }
      if (candidate == defining_) fail(at, "struct '" + candidate + "' cannot contain itself");
      if (failed_names_.contains(candidate)) throw Failed{};  // already reported
      if (forward_declared_.contains(candidate)) fail(at, "incomplete type '" + candidate + "'");
      if (registry_.constants_.contains(candidate) || registry_.modules_.contains(candidate)) {
        fail(at, "'" + name.spelled + "' is not a type");
      }
    }
    fail(at, "unknown type '" + name.spelled + "'");
  }

  const ConstValue& resolve_constant(const ScopedName& name, const Token& at) {
    for (const std::string& candidate : candidates(name)) {
      if (auto it = registry_.constants_.find(candidate); it != registry_.constants_.end()) {
        return it->second;
      }
      if (failed_names_.contains(candidate)) throw Failed{};
      if (registry_.by_name_.contains(candidate) || registry_.modules_.contains(candidate)) {
        fail(at, "'" + name.spelled + "' is not a constant");
      }
    }
    fail(at, "unknown constant '" + name.spelled + "'");
  }

  // ---- annotations ----------------------------------------------------------------------

  struct Annotation {
    std::string name;
    std::size_t at = 0;          // the token after the `@`, for messages
    std::size_t args_begin = 0;  // token range inside the parentheses
    std::size_t args_end = 0;
    bool has_args = false;
  };

  // Reads `@name` and `@name(...)` annotations; the parser ignores all but `@value`.
  std::vector<Annotation> parse_annotations() {
    std::vector<Annotation> out;
    while (is_punct(peek(), "@") && !is_word(peek(1), "annotation")) {
      next();
      Annotation annotation;
      annotation.at = pos_;
      annotation.name = parse_annotation_name();
      if (is_punct(peek(), "(")) {
        next();
        annotation.has_args = true;
        annotation.args_begin = pos_;
        int depth = 1;
        while (true) {
          // Arguments never hold these, so one means the `)` is missing.
          if (at_end() || is_punct(peek(), ";") || is_punct(peek(), "{") || is_punct(peek(), "}")) {
            fail(peek(), "expected ')' after annotation arguments");
          }
          if (is_punct(peek(), "(")) ++depth;
          if (is_punct(peek(), ")") && --depth == 0) break;
          next();
        }
        annotation.args_end = pos_;
        next();
      }
      out.push_back(std::move(annotation));
    }
    return out;
  }

  std::string parse_annotation_name() {
    std::string name;
    if (accept("::")) name = "::";
    while (true) {
      const Token& token = peek();
      if (token.kind != TokenKind::identifier) fail(token, "expected annotation name after '@'");
      name += token.text;
      next();
      if (!accept("::")) return name;
      name += "::";
    }
  }

  // `@annotation name { ... };` declares an annotation type: skipped whole.
  void skip_annotation_declaration() {
    next();  // @
    next();  // annotation
    while (!at_end() && !is_punct(peek(), "{") && !is_punct(peek(), ";")) next();
    if (is_punct(peek(), "{")) {
      int depth = 0;
      while (!at_end()) {
        if (is_punct(peek(), "{")) ++depth;
        if (is_punct(peek(), "}") && --depth == 0) {
          next();
          break;
        }
        next();
      }
    }
    accept(";");
  }

  // ---- definitions ----------------------------------------------------------------------

  bool starts_definition(const Token& token) const {
    static constexpr std::string_view kStarts[] = {"module", "struct", "enum", "typedef", "const"};
    if (token.kind == TokenKind::end || is_punct(token, "}") || is_punct(token, "@")) return true;
    return token.kind == TokenKind::identifier &&
           (std::find(std::begin(kStarts), std::end(kStarts), token.text) != std::end(kStarts) ||
            kUnsupportedDeclarations.contains(token.text));
  }

  // The `;` after a `}`. Without it the definition still counts; what follows is skipped
  // up to the next `;` unless it starts a new definition (`} s;` would otherwise give a
  // second error for `s`).
  void expect_definition_end(std::string message) {
    if (accept(";")) return;
    error(peek(), std::move(message));
    if (!starts_definition(peek())) synchronize();
  }

  void parse_definitions(bool in_module) {
    while (!at_end()) {
      if (is_punct(peek(), "}")) {
        if (in_module) return;
        error(peek(), "unexpected '}'");
        next();
        continue;
      }
      const std::size_t start = pos_;
      try {
        parse_definition();
      } catch (const Failed&) {
        synchronize();
      }
      if (pos_ == start) next();  // never stall on a token nothing consumes
    }
  }

  void parse_definition() {
    if (is_punct(peek(), "@") && is_word(peek(1), "annotation")) {
      skip_annotation_declaration();
      return;
    }
    const std::vector<Annotation> annotations = parse_annotations();
    const Token& token = peek();
    if (is_word(token, "module")) {
      parse_module();
    } else if (is_word(token, "struct")) {
      parse_struct(annotations);
    } else if (is_word(token, "enum")) {
      parse_enum();
    } else if (is_word(token, "typedef")) {
      parse_typedef();
    } else if (is_word(token, "const")) {
      parse_const();
    } else if (is_punct(token, ";")) {
      next();  // a stray `;` is harmless
    } else if (token.kind == TokenKind::identifier &&
               kUnsupportedDeclarations.contains(token.text)) {
      fail(token, "unsupported declaration '" + token.text + "'");
    } else {
      fail(token, "expected a declaration");
    }
  }

  void parse_module() {
    next();  // module
    const Token& name_token = peek();
    const std::string name = expect_name("expected module name");
    const std::string qualified = qualify(name);
    if (!registry_.modules_.contains(qualified)) check_new_name(name_token, qualified);
    expect("{", "expected '{' after module name");
    if (scope_.size() >= kMaxModuleDepth) fail(name_token, "modules nested too deeply");
    registry_.modules_.emplace(qualified, location(name_token));
    scope_.push_back(name);
    parse_definitions(true);
    scope_.pop_back();
    if (!accept("}")) {
      error(peek(), "expected '}' at end of module '" + qualified + "'");
      return;
    }
    expect_definition_end("expected ';' after module definition");
  }

  // The XTypes extensibility a struct's annotations give: @final, @appendable, @mutable or
  // @extensibility(FINAL | APPENDABLE | MUTABLE). Without one a struct is FINAL, as idlc
  // (Cyclone DDS 0.10, its -x default) and fastddsgen 2.3 (Fast DDS 2.9, which has no
  // XCDR2) treat it, although the XTypes spec says APPENDABLE: both ends of a bridge must
  // agree, and these are the peers polyport meets. When several are given the last one
  // counts (idlc refuses that; this parser has always accepted the annotations).
  Extensibility extensibility_of(const std::vector<Annotation>& annotations) {
    Extensibility extensibility = Extensibility::final_;
    for (const Annotation& annotation : annotations) {
      std::string_view name = annotation.name;
      if (name.starts_with("::")) name.remove_prefix(2);
      if (name == "final") {
        extensibility = Extensibility::final_;
      } else if (name == "appendable") {
        extensibility = Extensibility::appendable;
      } else if (name == "mutable") {
        extensibility = Extensibility::mutable_;
      } else if (name == "extensibility") {
        const Token& argument = tokens_[std::min(annotation.args_begin, tokens_.size() - 1)];
        const bool one_word = annotation.has_args &&
                              annotation.args_end == annotation.args_begin + 1 &&
                              argument.kind == TokenKind::identifier;
        if (one_word && argument.text == "FINAL") {
          extensibility = Extensibility::final_;
        } else if (one_word && argument.text == "APPENDABLE") {
          extensibility = Extensibility::appendable;
        } else if (one_word && argument.text == "MUTABLE") {
          extensibility = Extensibility::mutable_;
        } else {
          const bool has_argument =
              annotation.has_args && annotation.args_end > annotation.args_begin;
          error(has_argument ? argument : tokens_[annotation.at],
                "@extensibility needs FINAL, APPENDABLE or MUTABLE");
        }
      }
    }
    return extensibility;
  }

  void parse_struct(const std::vector<Annotation>& annotations) {
    next();  // struct
    const Token& name_token = peek();
    const std::string name = expect_name("expected struct name");
    const std::string qualified = qualify(name);
    if (accept(";")) {
      // A forward declaration: the type only becomes usable once it is defined.
      if (!registry_.by_name_.contains(qualified)) {
        if (name_taken(qualified)) fail(name_token, "redefinition of '" + qualified + "'");
        forward_declared_.insert(qualified);
      }
      return;
    }
    if (is_punct(peek(), ":")) fail(peek(), "struct inheritance is not supported");
    check_new_name(name_token, qualified);
    expect("{", "expected '{' after struct name");
    defining_ = qualified;

    Type type;
    type.kind = TypeKind::structure;
    type.name = qualified;
    type.where = location(name_token);
    type.origin = TypeOrigin::idl;
    type.extensibility = extensibility_of(annotations);
    bool ok = true;
    bool closed = false;
    while (true) {
      const Token& token = peek();
      if (accept("}")) {
        closed = true;
        break;
      }
      if (at_end() || is_word(token, "module") || is_word(token, "typedef") ||
          is_word(token, "const")) {
        error(token, "expected '}' at end of struct '" + qualified + "'");
        ok = false;
        break;
      }
      const std::size_t start = pos_;
      try {
        if (!parse_member(type)) ok = false;
      } catch (const Failed&) {
        ok = false;
        synchronize();
      }
      if (pos_ == start) next();
    }
    defining_.clear();
    if (closed) expect_definition_end("expected ';' after struct definition");
    if (ok && type.fields.empty()) {
      error(name_token, "struct '" + qualified + "' has no members");
      ok = false;
    }
    if (ok && !layout_struct(type)) {
      error(name_token, "struct '" + qualified + "' is too large");
      ok = false;
    }
    if (!ok) {
      failed_names_.insert(qualified);
      return;
    }
    forward_declared_.erase(qualified);
    Type& stored = registry_.make_type();
    stored = std::move(type);
    registry_.declare(stored);
  }

  // One member declaration with its declarators; false if a declarator was rejected.
  bool parse_member(Type& type) {
    parse_annotations();
    const Type* member_type = parse_type_spec();
    bool ok = true;
    do {
      const Token& name_token = peek();
      const std::string name = expect_name("expected member name");
      const Type* field_type = parse_array_declarator(member_type);
      const bool duplicate = std::any_of(type.fields.begin(), type.fields.end(),
                                         [&](const Field& field) { return field.name == name; });
      if (duplicate) {
        error(name_token, "duplicate member '" + name + "' in struct '" + type.name + "'");
        ok = false;
        continue;
      }
      type.fields.push_back(Field{name, field_type, 0, location(name_token), {}});
    } while (accept(","));
    expect(";", "expected ';' after member declaration");
    return ok;
  }

  static bool layout_struct(Type& type) { return TypeRegistry::layout_struct(type); }

  void parse_enum() {
    next();  // enum
    const Token& name_token = peek();
    const std::string name = expect_name("expected enum name");
    const std::string qualified = qualify(name);
    check_new_name(name_token, qualified);
    expect("{", "expected '{' after enum name");

    Type type;
    type.kind = TypeKind::enumeration;
    type.name = qualified;
    type.origin = TypeOrigin::idl;
    type.size = 4;
    type.align = 4;
    type.where = location(name_token);
    bool ok = true;
    try {
      std::int64_t next_value = 0;
      while (true) {
        const std::vector<Annotation> annotations = parse_annotations();
        const Token& enumerator_token = peek();
        const std::string enumerator = expect_name("expected enumerator name");
        std::int64_t value = next_value;
        for (const Annotation& annotation : annotations) {
          if (annotation.name == "value" && annotation.has_args) {
            value = evaluate_annotation_integer(annotation);
          }
        }
        if (value < std::numeric_limits<std::int32_t>::min() ||
            value > std::numeric_limits<std::int32_t>::max()) {
          error(enumerator_token, "value of enumerator '" + enumerator + "' is out of range");
          ok = false;
        }
        const bool duplicate =
            std::any_of(type.enumerators.begin(), type.enumerators.end(),
                        [&](const Enumerator& existing) { return existing.name == enumerator; });
        if (duplicate) {
          error(enumerator_token,
                "duplicate enumerator '" + enumerator + "' in enum '" + qualified + "'");
          ok = false;
        } else {
          type.enumerators.push_back(Enumerator{enumerator, static_cast<std::int32_t>(value)});
        }
        next_value = value + 1;
        if (accept(",")) continue;
        if (accept("}")) break;
        fail(peek(), "expected ',' or '}' after enumerator");
      }
    } catch (const Failed&) {
      // Skip to the enum's closing brace, or to a `;` if the brace is missing.
      int depth = 0;
      while (!at_end()) {
        if (is_punct(peek(), "{")) ++depth;
        if (is_punct(peek(), ";") && depth == 0) break;
        if (is_punct(peek(), "}") && depth-- == 0) {
          next();
          break;
        }
        next();
      }
      accept(";");
      failed_names_.insert(qualified);
      return;
    }
    expect_definition_end("expected ';' after enum definition");
    if (!ok) {
      failed_names_.insert(qualified);
      return;
    }
    Type& stored = registry_.make_type();
    stored = std::move(type);
    registry_.declare(stored);
  }

  std::int64_t evaluate_annotation_integer(const Annotation& annotation) {
    const std::size_t saved = pos_;
    pos_ = annotation.args_begin;
    const Token& start = peek();
    ConstValue value;
    try {
      value = parse_expression(false);
    } catch (const Failed&) {
      pos_ = saved;
      throw;
    }
    const bool whole = pos_ == annotation.args_end;
    pos_ = saved;
    if (!whole || !std::holds_alternative<std::int64_t>(value)) {
      fail(start, "@value needs an integer constant");
    }
    return std::get<std::int64_t>(value);
  }

  void parse_typedef() {
    next();  // typedef
    const Type* target = parse_type_spec();
    do {
      const Token& name_token = peek();
      const std::string name = expect_name("expected typedef name");
      const Type* aliased = parse_array_declarator(target);
      const std::string qualified = qualify(name);
      if (name_taken(qualified)) {
        error(name_token, "redefinition of '" + qualified + "'");
        continue;
      }
      Type& type = registry_.make_type();
      type.kind = TypeKind::alias;
      type.name = qualified;
      type.origin = TypeOrigin::idl;
      type.size = aliased->size;
      type.align = aliased->align;
      type.element = aliased;
      type.where = location(name_token);
      registry_.declare(type);
    } while (accept(","));
    expect(";", "expected ';' after typedef");
  }

  void parse_const() {
    next();  // const
    const Token& type_token = peek();
    const Type* declared_type = parse_type_spec();
    const Type& type = declared_type->resolved();
    const bool supported = is_integer_kind(type.kind) || type.kind == TypeKind::float32 ||
                           type.kind == TypeKind::float64 || type.kind == TypeKind::boolean ||
                           type.kind == TypeKind::string;
    if (!supported) fail(type_token, "unsupported constant type '" + declared_type->name + "'");
    const Token& name_token = peek();
    const std::string name = expect_name("expected constant name");
    const std::string qualified = qualify(name);
    check_new_name(name_token, qualified);
    try {
      expect("=", "expected '=' after constant name");
      const Token& value_token = peek();
      ConstValue value = parse_expression(false);
      value = convert_constant(std::move(value), *declared_type, value_token);
      expect(";", "expected ';' after constant definition");
      registry_.constants_.emplace(qualified, std::move(value));
    } catch (const Failed&) {
      failed_names_.insert(qualified);
      throw;
    }
  }

  ConstValue convert_constant(ConstValue value, const Type& declared_type, const Token& at) {
    const Type& type = declared_type.resolved();
    const std::string type_name = "'" + declared_type.name + "'";
    if (is_integer_kind(type.kind)) {
      if (!std::holds_alternative<std::int64_t>(value)) {
        fail(at, "constant of type " + type_name + " needs an integer value");
      }
      const std::int64_t number = std::get<std::int64_t>(value);
      if (!in_range(type.kind, number)) {
        fail(at, "value " + std::to_string(number) + " is out of range for " + type_name);
      }
      return value;
    }
    if (type.kind == TypeKind::float32 || type.kind == TypeKind::float64) {
      if (const auto* number = std::get_if<std::int64_t>(&value))
        return static_cast<double>(*number);
      if (!std::holds_alternative<double>(value)) {
        fail(at, "constant of type " + type_name + " needs a numeric value");
      }
      return value;
    }
    if (type.kind == TypeKind::boolean) {
      if (!std::holds_alternative<bool>(value)) {
        fail(at, "constant of type " + type_name + " needs TRUE or FALSE");
      }
      return value;
    }
    if (!std::holds_alternative<std::string>(value)) {
      fail(at, "constant of type " + type_name + " needs a string value");
    }
    if (type.bound > 0 && std::get<std::string>(value).size() > type.bound) {
      fail(at, "string constant is longer than the bound of " + type_name);
    }
    return value;
  }

  // ---- types ----------------------------------------------------------------------------

  const Type* builtin(std::string_view name) const { return registry_.by_name_.find(name)->second; }

  const Type* parse_type_spec() {
    parse_annotations();
    const Token& token = peek();
    if (is_punct(token, "::") ||
        (token.kind == TokenKind::identifier && !kReserved.contains(token.text))) {
      const ScopedName name = parse_scoped_name();
      return resolve_type(name, token);
    }
    if (token.kind != TokenKind::identifier) fail(token, "expected a type");
    const std::string& word = token.text;
    static constexpr std::string_view kSimple[] = {"boolean", "char",   "octet", "short", "float",
                                                   "double",  "int8",   "uint8", "int16", "uint16",
                                                   "int32",   "uint32", "int64", "uint64"};
    if (std::find(std::begin(kSimple), std::end(kSimple), word) != std::end(kSimple)) {
      next();
      return registry_.find(word);  // find() knows the sized spellings too
    }
    if (word == "long") {
      next();
      if (accept_word("long")) return builtin("long long");
      if (is_word(peek(), "double")) fail(token, "unsupported type 'long double'");
      return builtin("long");
    }
    if (word == "unsigned") {
      next();
      if (accept_word("short")) return builtin("unsigned short");
      if (accept_word("long"))
        return builtin(accept_word("long") ? "unsigned long long" : "unsigned long");
      fail(peek(), "expected 'short' or 'long' after 'unsigned'");
    }
    if (word == "string") {
      next();
      if (!accept("<")) return builtin("string");
      const std::uint32_t bound = parse_bound("string bound", kMaxTypeSize - 1, true);
      expect(">", "expected '>' after string bound");
      return bounded_string(bound);
    }
    if (word == "sequence") {
      next();
      expect("<", "expected '<' after 'sequence'");
      const DepthGuard guard(type_depth_);
      if (type_depth_ > kMaxTypeDepth) fail(token, "type nested too deeply");
      const Type* element = parse_type_spec();
      std::uint32_t bound = 0;
      if (accept(",")) {
        bound = parse_bound("sequence bound", kMaxTypeSize, true);
        expect(">", "expected '>' after sequence bound");
      } else {
        expect(">", "expected ',' or '>' after sequence element type");
      }
      return sequence(element, bound, token);
    }
    if (word == "struct" || word == "enum" || word == "union") {
      fail(token, "nested type definitions are not supported");
    }
    if (kUnsupportedTypes.contains(word)) fail(token, "unsupported type '" + word + "'");
    fail(token, "expected a type");
  }

  bool accept_word(std::string_view word) {
    if (!is_word(peek(), word)) return false;
    next();
    return true;
  }

  std::uint32_t parse_bound(const std::string& what, std::uint64_t max, bool in_template) {
    const Token& start = peek();
    const ConstValue value = parse_expression(in_template);
    const auto* number = std::get_if<std::int64_t>(&value);
    if (number == nullptr || *number <= 0)
      fail(start, what + " must be a positive integer constant");
    if (static_cast<std::uint64_t>(*number) > max) fail(start, what + " is too large");
    return static_cast<std::uint32_t>(*number);
  }

  // `name[2][3]`: an array of 2 arrays of 3, so indexing peels the outer dimension first.
  const Type* parse_array_declarator(const Type* element) {
    std::vector<std::pair<std::uint32_t, const Token*>> dimensions;
    while (accept("[")) {
      const Token& start = peek();
      const std::uint32_t size = parse_bound("array size", kMaxTypeSize, false);
      expect("]", "expected ']' after array size");
      dimensions.emplace_back(size, &start);
    }
    if (dimensions.empty()) return element;
    const Type* type = element;
    for (std::size_t i = dimensions.size(); i-- > 0;) {
      std::string name = element->name;
      for (std::size_t k = i; k < dimensions.size(); ++k) {
        name += '[';
        name += std::to_string(dimensions[k].first);
        name += ']';
      }
      const std::uint64_t size = static_cast<std::uint64_t>(dimensions[i].first) * type->size;
      if (size > kMaxTypeSize) fail(*dimensions[i].second, "type '" + name + "' is too large");
      const Type* inner = type;
      type = anonymous(name, [&](Type& array) {
        array.kind = TypeKind::array;
        array.size = static_cast<std::uint32_t>(size);
        array.align = inner->align;
        array.bound = dimensions[i].first;
        array.element = inner;
      });
    }
    return type;
  }

  const Type* bounded_string(std::uint32_t bound) {
    return anonymous("string<" + std::to_string(bound) + ">", [&](Type& type) {
      type.kind = TypeKind::string;
      type.size = bound + 1;
      type.align = 1;
      type.bound = bound;
    });
  }

  const Type* sequence(const Type* element, std::uint32_t bound, const Token& at) {
    if (bound == 0) {
      return anonymous("sequence<" + element->name + ">", [&](Type& type) {
        type.kind = TypeKind::sequence;
        type.size = sizeof(FlatSpan);
        type.align = alignof(FlatSpan);
        type.element = element;
      });
    }
    const std::string name = "sequence<" + element->name + ", " + std::to_string(bound) + ">";
    const std::uint32_t align = std::max<std::uint32_t>(alignof(std::uint32_t), element->align);
    const std::uint64_t first = align_up(sizeof(std::uint32_t), element->align);
    const std::uint64_t size =
        align_up(first + static_cast<std::uint64_t>(bound) * element->size, align);
    if (size > kMaxTypeSize) fail(at, "type '" + name + "' is too large");
    return anonymous(name, [&](Type& type) {
      type.kind = TypeKind::sequence;
      type.size = static_cast<std::uint32_t>(size);
      type.align = align;
      type.bound = bound;
      type.element = element;
    });
  }

  // Anonymous types are shared: every `double[3]` is the same Type.
  template <class Init>
  const Type* anonymous(const std::string& name, Init&& init) {
    if (auto it = registry_.anonymous_.find(name); it != registry_.anonymous_.end())
      return it->second;
    Type& type = registry_.make_type();
    type.name = name;
    init(type);
    registry_.anonymous_.emplace(name, &type);
    return &type;
  }

  // ---- constant expressions -------------------------------------------------------------
  // Integer arithmetic is exact (overflow is an error); a floating operand makes the
  // operation floating. Inside `<...>` a `>` ends the expression, so shifts need
  // parentheses there.

  ConstValue parse_expression(bool in_template) {
    const FlagGuard guard(in_template_, in_template);
    return parse_binary(0);
  }

  struct Operator {
    std::string_view text;
    int precedence;
  };

  // The binary operator at the current token, if any, with its precedence.
  std::optional<Operator> peek_operator() const {
    if (!in_template_ && is_pair(">")) return Operator{">>", 3};
    if (!in_template_ && is_pair("<")) return Operator{"<<", 3};
    const Token& token = peek();
    if (token.kind != TokenKind::punct) return std::nullopt;
    if (token.text == "|") return Operator{"|", 0};
    if (token.text == "^") return Operator{"^", 1};
    if (token.text == "&") return Operator{"&", 2};
    if (token.text == "+" || token.text == "-") return Operator{token.text, 4};
    if (token.text == "*" || token.text == "/" || token.text == "%") return Operator{token.text, 5};
    return std::nullopt;
  }

  ConstValue parse_binary(int min_precedence) {
    ConstValue left = parse_unary();
    while (true) {
      const std::optional<Operator> op = peek_operator();
      if (!op || op->precedence < min_precedence) return left;
      const Token& op_token = next();
      if (op->text.size() == 2) next();  // the second half of `<<` / `>>`
      const ConstValue right = parse_binary(op->precedence + 1);
      left = apply(op->text, left, right, op_token);
    }
  }

  ConstValue parse_unary() {
    const Token& token = peek();
    if (is_punct(token, "-") || is_punct(token, "+") || is_punct(token, "~")) {
      next();
      const DepthGuard guard(expression_depth_);
      if (expression_depth_ > kMaxExpressionDepth)
        fail(token, "constant expression nested too deeply");
      const ConstValue operand = parse_unary();
      if (const auto* number = std::get_if<std::int64_t>(&operand)) {
        if (token.text == "+") return *number;
        if (token.text == "~") return ~*number;
        if (*number == std::numeric_limits<std::int64_t>::min()) {
          fail(token, "integer overflow in constant expression");
        }
        return -*number;
      }
      if (const auto* number = std::get_if<double>(&operand);
          number != nullptr && token.text != "~") {
        return token.text == "-" ? -*number : *number;
      }
      fail(token, "invalid operand for '" + token.text + "' in constant expression");
    }
    return parse_primary();
  }

  ConstValue parse_primary() {
    const Token& token = peek();
    switch (token.kind) {
      case TokenKind::integer: next(); return token.int_value;
      case TokenKind::floating: next(); return token.float_value;
      case TokenKind::string: {
        std::string text;
        while (peek().kind == TokenKind::string) text += next().text;  // "a" "b" is "ab"
        return text;
      }
      case TokenKind::character: fail(token, "character constants are not supported");
      case TokenKind::end:
      case TokenKind::invalid: fail(token, "expected a constant expression");
      case TokenKind::punct:
      case TokenKind::identifier: break;
    }
    if (is_punct(token, "(")) {
      next();
      const DepthGuard guard(expression_depth_);
      if (expression_depth_ > kMaxExpressionDepth)
        fail(token, "constant expression nested too deeply");
      ConstValue value = parse_expression(false);  // `>` is a shift again inside parentheses
      expect(")", "expected ')' in constant expression");
      return value;
    }
    if (is_word(token, "TRUE") || is_word(token, "true")) {
      next();
      return true;
    }
    if (is_word(token, "FALSE") || is_word(token, "false")) {
      next();
      return false;
    }
    if (is_punct(token, "::") ||
        (token.kind == TokenKind::identifier && !kReserved.contains(token.text))) {
      const ScopedName name = parse_scoped_name();
      return resolve_constant(name, token);
    }
    fail(token, "expected a constant expression");
  }

  ConstValue apply(std::string_view op, const ConstValue& left, const ConstValue& right,
                   const Token& at) {
    const auto* a = std::get_if<std::int64_t>(&left);
    const auto* b = std::get_if<std::int64_t>(&right);
    const std::string op_text(op);
    if (a != nullptr && b != nullptr) return apply_integer(op, *a, *b, at);
    const bool numeric = (a != nullptr || std::holds_alternative<double>(left)) &&
                         (b != nullptr || std::holds_alternative<double>(right));
    if (!numeric) fail(at, "invalid operands to '" + op_text + "' in constant expression");
    const double x = a != nullptr ? static_cast<double>(*a) : std::get<double>(left);
    const double y = b != nullptr ? static_cast<double>(*b) : std::get<double>(right);
    if (op == "+") return x + y;
    if (op == "-") return x - y;
    if (op == "*") return x * y;
    if (op == "/") {
      if (y == 0.0) fail(at, "division by zero in constant expression");
      return x / y;
    }
    fail(at, "operator '" + op_text + "' needs integer operands");
  }

  std::int64_t apply_integer(std::string_view op, std::int64_t a, std::int64_t b, const Token& at) {
    std::int64_t result = 0;
    bool overflow = false;
    if (op == "+") {
      overflow = __builtin_add_overflow(a, b, &result);
    } else if (op == "-") {
      overflow = __builtin_sub_overflow(a, b, &result);
    } else if (op == "*") {
      overflow = __builtin_mul_overflow(a, b, &result);
    } else if (op == "/" || op == "%") {
      if (b == 0) fail(at, "division by zero in constant expression");
      overflow = a == std::numeric_limits<std::int64_t>::min() && b == -1;
      if (!overflow) result = op == "/" ? a / b : a % b;
    } else if (op == "|") {
      result = a | b;
    } else if (op == "^") {
      result = a ^ b;
    } else if (op == "&") {
      result = a & b;
    } else if (op == "<<" || op == ">>") {
      if (b < 0 || b > 63) fail(at, "shift count out of range in constant expression");
      if (op == ">>") {
        result = a >> b;
      } else {
        overflow = a < 0 || (b > 0 && (static_cast<std::uint64_t>(a) >> (63 - b)) != 0);
        if (!overflow) result = static_cast<std::int64_t>(static_cast<std::uint64_t>(a) << b);
      }
    }
    if (overflow) fail(at, "integer overflow in constant expression");
    return result;
  }

  TypeRegistry& registry_;
  std::string file_;
  std::vector<Token> tokens_;
  std::size_t pos_ = 0;
  std::vector<RawDiagnostic> raw_;
  std::vector<std::string> scope_;
  // Names whose declaration failed: using them fails quietly, since the cause was reported.
  std::set<std::string, std::less<>> failed_names_;
  std::set<std::string, std::less<>> forward_declared_;
  std::string defining_;  // the struct whose members are being parsed
  int type_depth_ = 0;
  int expression_depth_ = 0;
  bool in_template_ = false;
};

bool TypeRegistry::add_idl_text(std::string_view text, const std::string& file_name,
                                Diagnostics& diagnostics) {
  IdlParser parser(*this, file_name);
  return parser.parse(text, diagnostics);
}

bool TypeRegistry::add_idl_file(const std::filesystem::path& file, Diagnostics& diagnostics) {
  return add_file(file, diagnostics, &TypeRegistry::add_idl_text);
}

}  // namespace polyport
