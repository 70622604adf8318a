// LCM type files (`.lcm`): `package a.b;`, any number of `struct NAME { ... }`, members of
// the nine LCM primitives or of other LCM structs, fixed and member-sized array dimensions,
// and `const` declarations. Each struct is registered as `a::b::NAME` with origin `lcm` and
// the fingerprint lcm-gen computes for it, so a message encoded here is accepted by code
// lcm-gen generated from the same file, and the other way round.
//
// Two passes: the text is parsed into declarations first, then the declarations are
// registered in dependency order, so a struct may use one declared later in the same file
// (lcm-gen allows that too). Every problem is reported as file:line:col and parsing goes
// on: a member error skips to the next `;` or `}`, a top-level error to the next `struct`
// or `package`. A struct with an error is not registered; structs that use it are then
// left out without a second message.
#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <system_error>
#include <utility>
#include <vector>

#include "polyport/types/lcm_parser.hpp"
#include "polyport/types/types.hpp"

namespace polyport {

namespace {

// Bounds on hostile input: dimensions per member, so building array type names stays cheap.
constexpr std::size_t kMaxDimensions = 32;

// ---- lcm-gen's fingerprint -------------------------------------------------------------
//
// lcm-gen hashes with signed 64-bit arithmetic and a signed `char` (x86): the shift right is
// arithmetic and every added byte is sign-extended. Unsigned arithmetic gives the same bits
// for the left shift and the sum without C++'s signed-overflow rules.
std::uint64_t hash_update(std::uint64_t v, std::uint8_t byte) {
  const auto arithmetic_shift = static_cast<std::uint64_t>(static_cast<std::int64_t>(v) >> 55);
  const auto signed_byte = static_cast<std::uint64_t>(static_cast<std::int64_t>(static_cast<std::int8_t>(byte)));
  return ((v << 8) ^ arithmetic_shift) + signed_byte;
}

// A string counts as its length (truncated to one byte, as lcm-gen passes strlen() as a
// char), then its bytes.
std::uint64_t hash_string(std::uint64_t v, std::string_view text) {
  v = hash_update(v, static_cast<std::uint8_t>(text.size() & 0xFF));
  for (char c : text) v = hash_update(v, static_cast<std::uint8_t>(c));
  return v;
}

std::uint64_t rotate_left_1(std::uint64_t v) { return (v << 1) | (v >> 63); }

// ---- the language -------------------------------------------------------------------------

struct LcmPrimitive {
  std::string_view name;
  TypeKind kind;
  bool dimension;  // may size an array
  bool constant;   // may be the type of a `const`
};

constexpr LcmPrimitive kLcmPrimitives[] = {
    {"int8_t", TypeKind::int8, true, true},        {"int16_t", TypeKind::int16, true, true},
    {"int32_t", TypeKind::int32, true, true},      {"int64_t", TypeKind::int64, true, true},
    {"byte", TypeKind::octet, false, false},       {"float", TypeKind::float32, false, true},
    {"double", TypeKind::float64, false, true},    {"string", TypeKind::string, false, false},
    {"boolean", TypeKind::boolean, false, false},
};

const LcmPrimitive* find_primitive(std::string_view name) {
  for (const LcmPrimitive& primitive : kLcmPrimitives) {
    if (primitive.name == name) return &primitive;
  }
  return nullptr;
}

bool is_ident_start(char c) { return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || c == '_'; }
bool is_digit(char c) { return c >= '0' && c <= '9'; }
bool is_ident_char(char c) { return is_ident_start(c) || is_digit(c); }
// Words hold names, dotted names, numbers and constant values ("-1.5e+3").
bool is_word_char(char c) { return is_ident_char(c) || c == '.' || c == '+' || c == '-'; }
bool is_punct(char c) {
  return c == '{' || c == '}' || c == '[' || c == ']' || c == ';' || c == ',' || c == '=';
}

bool is_identifier(std::string_view text) {
  if (text.empty() || !is_ident_start(text.front())) return false;
  return std::all_of(text.begin(), text.end(), is_ident_char);
}

// `a`, `a.b.c`: identifiers joined by single dots.
bool is_dotted_name(std::string_view text) {
  while (true) {
    const std::size_t dot = text.find('.');
    if (!is_identifier(text.substr(0, dot))) return false;
    if (dot == std::string_view::npos) return true;
    text.remove_prefix(dot + 1);
  }
}

std::string printable(char c) {
  const auto byte = static_cast<unsigned char>(c);
  if (byte >= 0x20 && byte < 0x7F) return std::string(1, c);
  constexpr char kHex[] = "0123456789ABCDEF";
  return std::string("\\x") + kHex[byte >> 4] + kHex[byte & 0xF];
}

// "a.b.t" -> "a::b::t", the registry's spelling.
std::string to_qualified(std::string_view dotted) {
  std::string out;
  out.reserve(dotted.size() + 8);
  for (char c : dotted) {
    if (c == '.') {
      out += "::";
    } else {
      out += c;
    }
  }
  return out;
}

// An integer as C's strtoll(text, .., 0) reads it (optional sign, 0x hex, leading-0 octal),
// except that the whole text must be the number and overflow is reported, not clamped.
enum class IntegerText : std::uint8_t { ok, invalid, out_of_range };

IntegerText parse_c_integer(std::string_view text, std::int64_t& value) {
  bool negative = false;
  if (!text.empty() && (text.front() == '-' || text.front() == '+')) {
    negative = text.front() == '-';
    text.remove_prefix(1);
  }
  int base = 10;
  if (text.size() > 1 && text[0] == '0' && (text[1] == 'x' || text[1] == 'X')) {
    base = 16;
    text.remove_prefix(2);
  } else if (text.size() > 1 && text[0] == '0') {
    base = 8;
    text.remove_prefix(1);
  }
  if (text.empty()) return IntegerText::invalid;
  std::uint64_t magnitude = 0;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), magnitude, base);
  if (end != text.data() + text.size()) return IntegerText::invalid;
  if (error == std::errc::result_out_of_range) return IntegerText::out_of_range;
  if (error != std::errc()) return IntegerText::invalid;
  constexpr auto kMax = static_cast<std::uint64_t>(std::numeric_limits<std::int64_t>::max());
  if (magnitude > (negative ? kMax + 1 : kMax)) return IntegerText::out_of_range;
  value = negative ? static_cast<std::int64_t>(0 - magnitude) : static_cast<std::int64_t>(magnitude);
  return IntegerText::ok;
}

std::optional<double> parse_floating(std::string_view text) {
  if (!text.empty() && text.front() == '+') text.remove_prefix(1);
  if (text.empty()) return std::nullopt;
  double value = 0;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (error != std::errc() || end != text.data() + text.size()) return std::nullopt;
  return value;
}

// ---- declarations (the result of the first pass) --------------------------------------------

struct DimensionDecl {
  bool variable = false;  // sized by an earlier member (LCM_VAR) or a number (LCM_CONST)
  std::string size;       // as written: lcm-gen hashes the text, not the number ("0x10")
  std::uint32_t length = 0;
};

struct MemberDecl {
  std::string name;
  std::string type_name;  // a primitive's name, or the struct's full dotted name
  const LcmPrimitive* primitive = nullptr;
  std::vector<DimensionDecl> dimensions;
  SourceLocation where;       // the member's name
  SourceLocation type_where;  // its type
};

struct ConstantDecl {
  std::string name;
  ConstValue value;
};

struct StructDecl {
  std::string dotted_name;  // "a.b.t"
  SourceLocation where;
  std::vector<MemberDecl> members;
  std::vector<ConstantDecl> constants;
  bool valid = true;
};

struct Token {
  enum Kind : std::uint8_t { word, punct, end } kind = end;
  std::string_view text;
  std::uint32_t line = 1;
  std::uint32_t column = 1;
};

// Splits the text into words and punctuators; skips whitespace and comments.
class Lexer {
 public:
  Lexer(std::string_view text, const std::string& file, Diagnostics& diagnostics)
      : text_(text), file_(file), diagnostics_(diagnostics) {}

  Token next() {
    while (true) {
      skip_space_and_comments();
      Token token;
      token.line = line_;
      token.column = column_;
      if (pos_ >= text_.size()) return token;
      const char c = text_[pos_];
      if (is_punct(c)) {
        token.kind = Token::punct;
        token.text = text_.substr(pos_, 1);
        advance();
        return token;
      }
      if (is_word_char(c)) {
        const std::size_t start = pos_;
        while (pos_ < text_.size() && is_word_char(text_[pos_])) advance();
        token.kind = Token::word;
        token.text = text_.substr(start, pos_ - start);
        return token;
      }
      // One report for a run of stray characters, then carry on after it.
      diagnostics_.error(SourceLocation{file_, line_, column_}, {},
                         "unexpected character '" + printable(c) + "'");
      while (pos_ < text_.size() && !is_punct(text_[pos_]) && !is_word_char(text_[pos_]) &&
             !is_space(text_[pos_]) && text_[pos_] != '/') {
        advance();
      }
      if (pos_ < text_.size() && text_[pos_] == '/' && !starts_comment()) advance();
    }
  }

 private:
  static bool is_space(char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\f' || c == '\v'; }

  bool starts_comment() const {
    return pos_ + 1 < text_.size() && text_[pos_] == '/' && (text_[pos_ + 1] == '/' || text_[pos_ + 1] == '*');
  }

  void advance() {
    if (text_[pos_] == '\n') {
      ++line_;
      column_ = 1;
    } else {
      ++column_;
    }
    ++pos_;
  }

  void skip_space_and_comments() {
    while (pos_ < text_.size()) {
      if (is_space(text_[pos_])) {
        advance();
      } else if (starts_comment() && text_[pos_ + 1] == '/') {
        while (pos_ < text_.size() && text_[pos_] != '\n') advance();
      } else if (starts_comment()) {
        const SourceLocation start{file_, line_, column_};
        advance();
        advance();
        while (pos_ < text_.size() && !(text_[pos_] == '*' && pos_ + 1 < text_.size() && text_[pos_ + 1] == '/')) {
          advance();
        }
        if (pos_ >= text_.size()) {
          diagnostics_.error(start, {}, "unterminated comment");
          return;
        }
        advance();
        advance();
      } else {
        return;
      }
    }
  }

  std::string_view text_;
  const std::string& file_;
  Diagnostics& diagnostics_;
  std::size_t pos_ = 0;
  std::uint32_t line_ = 1;
  std::uint32_t column_ = 1;
};

class LcmParser {
 public:
  LcmParser(std::string_view text, const std::string& file, Diagnostics& diagnostics)
      : lexer_(text, file, diagnostics), file_(file), diagnostics_(diagnostics) {
    current_ = lexer_.next();
  }

  std::vector<StructDecl> parse() {
    while (current_.kind != Token::end) {
      if (is_word("package")) {
        parse_package();
      } else if (is_word("struct")) {
        parse_struct();
      } else if (is_word("enum")) {
        error_here("enums are not supported (lcm-gen 1.3.1 only keeps them for old files)");
        skip_past_block();
      } else {
        error_expected("'package' or 'struct'");
        skip_to_top_level_keyword();
      }
    }
    return std::move(structs_);
  }

 private:
  // Thrown to abandon one member or one top-level declaration; never leaves this file.
  struct Abandon {};

  bool is_word(std::string_view text) const { return current_.kind == Token::word && current_.text == text; }
  bool is_punct(char c) const {
    return current_.kind == Token::punct && current_.text.size() == 1 && current_.text[0] == c;
  }
  SourceLocation here() const { return SourceLocation{file_, current_.line, current_.column}; }
  void advance() { current_ = lexer_.next(); }

  void error_at(const SourceLocation& where, std::string message) {
    diagnostics_.error(where, {}, std::move(message));
  }
  void error_here(std::string message) { error_at(here(), std::move(message)); }

  std::string describe_current() const {
    if (current_.kind == Token::end) return "end of file";
    return "'" + std::string(current_.text) + "'";
  }
  void error_expected(std::string_view what) {
    error_here("expected " + std::string(what) + ", found " + describe_current());
  }

  void expect_punct(char c) {
    if (!is_punct(c)) {
      error_expected(std::string("'") + c + "'");
      throw Abandon{};
    }
    advance();
  }

  // A word token, consumed; reports and abandons otherwise.
  Token expect_word(std::string_view what) {
    if (current_.kind != Token::word) {
      error_expected(what);
      throw Abandon{};
    }
    Token token = current_;
    advance();
    return token;
  }

  void skip_to_top_level_keyword() {
    while (current_.kind != Token::end && !is_word("struct") && !is_word("package")) advance();
  }

  // After `enum`: up to and including the closing brace of its body, if there is one.
  void skip_past_block() {
    advance();
    while (current_.kind != Token::end && !is_punct('{') && !is_word("struct") && !is_word("package")) advance();
    if (!is_punct('{')) return;
    while (current_.kind != Token::end && !is_punct('}')) advance();
    if (is_punct('}')) advance();
  }

  // After a nested `struct x { ... }`: past its closing brace (and a `;`), so the rest of
  // the enclosing struct is still read as members.
  void skip_nested_block() {
    while (current_.kind != Token::end && !is_punct('{') && !is_punct(';') && !is_punct('}')) advance();
    if (is_punct(';')) {
      advance();
      return;
    }
    if (!is_punct('{')) return;
    int depth = 0;
    while (current_.kind != Token::end) {
      if (is_punct('{')) ++depth;
      if (is_punct('}') && --depth == 0) {
        advance();
        break;
      }
      advance();
    }
    if (is_punct(';')) advance();
  }

  void parse_package() {
    try {
      advance();
      const Token name = expect_word("a package name");
      if (!is_dotted_name(name.text)) {
        error_at(location(name), "invalid package name '" + std::string(name.text) + "'");
        throw Abandon{};
      }
      // Taken even if the `;` is missing, so the structs after it do not cascade errors.
      package_ = std::string(name.text);
      expect_punct(';');
    } catch (const Abandon&) {
      skip_to_top_level_keyword();
    }
  }

  SourceLocation location(const Token& token) const { return SourceLocation{file_, token.line, token.column}; }

  // Unqualified names are in the current package, as lcm-gen resolves them.
  std::string qualify(std::string_view name) const {
    if (name.find('.') != std::string_view::npos || package_.empty()) return std::string(name);
    return package_ + "." + std::string(name);
  }

  void parse_struct() {
    StructDecl decl;
    try {
      advance();
      const Token name = expect_word("a struct name");
      if (!is_dotted_name(name.text)) {
        error_at(location(name), "invalid struct name '" + std::string(name.text) + "'");
        throw Abandon{};
      }
      decl.dotted_name = qualify(name.text);
      decl.where = location(name);
      expect_punct('{');
    } catch (const Abandon&) {
      skip_to_top_level_keyword();
      return;
    }
    while (!is_punct('}')) {
      if (current_.kind == Token::end) {
        error_expected("'}'");
        decl.valid = false;
        break;
      }
      try {
        parse_member(decl);
      } catch (const Abandon&) {
        decl.valid = false;
        // Resynchronise at the end of this member, or stop at the struct's end.
        while (current_.kind != Token::end && !is_punct(';') && !is_punct('}')) advance();
        if (is_punct(';')) advance();
      }
    }
    if (is_punct('}')) advance();
    structs_.push_back(std::move(decl));
  }

  bool name_taken(const StructDecl& decl, std::string_view name) const {
    for (const MemberDecl& member : decl.members) {
      if (member.name == name) return true;
    }
    for (const ConstantDecl& constant : decl.constants) {
      if (constant.name == name) return true;
    }
    return false;
  }

  // Checks a new member or constant name; a duplicate is reported but parsing goes on.
  void check_name(StructDecl& decl, const Token& name) {
    if (!is_identifier(name.text)) {
      error_at(location(name), "invalid member name '" + std::string(name.text) + "'");
      throw Abandon{};
    }
    if (name_taken(decl, name.text)) {
      error_at(location(name), "duplicate member '" + std::string(name.text) + "'");
      decl.valid = false;
    }
  }

  void parse_member(StructDecl& decl) {
    if (is_word("const")) {
      advance();
      parse_constants(decl);
      return;
    }
    if (is_word("struct") || is_word("enum")) {
      error_here("nested declarations are not supported");
      decl.valid = false;
      skip_nested_block();
      return;
    }
    const Token type = expect_word("a member type");
    if (!is_dotted_name(type.text)) {
      error_at(location(type), "invalid type name '" + std::string(type.text) + "'");
      throw Abandon{};
    }
    const LcmPrimitive* primitive = find_primitive(type.text);
    const std::string type_name = primitive != nullptr ? std::string(type.text) : qualify(type.text);
    while (true) {
      const Token name = expect_word("a member name");
      check_name(decl, name);
      MemberDecl member;
      member.name = std::string(name.text);
      member.type_name = type_name;
      member.primitive = primitive;
      member.where = location(name);
      member.type_where = location(type);
      while (is_punct('[')) {
        advance();
        parse_dimension(decl, member);
        expect_punct(']');
      }
      decl.members.push_back(std::move(member));
      if (!is_punct(',')) break;
      advance();
    }
    expect_punct(';');
  }

  void parse_dimension(StructDecl& decl, MemberDecl& member) {
    const SourceLocation where = here();
    if (member.dimensions.size() == kMaxDimensions) {
      error_here("too many array dimensions (at most " + std::to_string(kMaxDimensions) + ")");
      throw Abandon{};
    }
    const Token size = expect_word("an array size");
    const std::string text(size.text);
    DimensionDecl dimension;
    dimension.size = text;
    if (is_digit(text.front())) {
      // lcm-gen takes any text that starts with a digit; a number is what it means.
      std::int64_t value = 0;
      const IntegerText parsed = parse_c_integer(text, value);
      if (parsed == IntegerText::invalid) {
        error_at(where, "array size '" + text + "' is not an integer");
        throw Abandon{};
      }
      if (value == 0) {
        error_at(where, "array size '" + text + "' must be > 0");
        throw Abandon{};
      }
      if (parsed == IntegerText::out_of_range || value > std::numeric_limits<std::int32_t>::max()) {
        error_at(where, "array size '" + text + "' is too large");
        throw Abandon{};
      }
      dimension.length = static_cast<std::uint32_t>(value);
    } else if (!is_identifier(text)) {
      error_at(where, "array size '" + text + "' must be a positive number or an earlier integer member");
      throw Abandon{};
    } else {
      dimension.variable = true;
      const MemberDecl* length = nullptr;
      for (const MemberDecl& earlier : decl.members) {
        if (earlier.name == text) length = &earlier;
      }
      if (length == nullptr) {
        const bool is_constant = std::any_of(decl.constants.begin(), decl.constants.end(),
                                             [&](const ConstantDecl& c) { return c.name == text; });
        if (is_constant) {
          error_at(where, "array size '" + text +
                              "' is a constant; lcm-gen 1.3.1 takes only a number or an earlier "
                              "integer member");
        } else {
          error_at(where, "array size '" + text + "' is not a member declared before '" + member.name + "'");
        }
        throw Abandon{};
      }
      if (!length->dimensions.empty()) {
        error_at(where, "array size '" + text + "' must not be an array");
        throw Abandon{};
      }
      if (length->primitive == nullptr || !length->primitive->dimension) {
        error_at(where, "array size '" + text +
                            "' must be an int8_t, int16_t, int32_t or int64_t member, not '" +
                            length->type_name + "'");
        throw Abandon{};
      }
    }
    member.dimensions.push_back(std::move(dimension));
  }

  void parse_constants(StructDecl& decl) {
    const Token type = expect_word("a constant type");
    const LcmPrimitive* primitive = find_primitive(type.text);
    if (primitive == nullptr || !primitive->constant) {
      error_at(location(type), "invalid type for a constant '" + std::string(type.text) +
                                   "' (int8_t, int16_t, int32_t, int64_t, float or double)");
      throw Abandon{};
    }
    while (true) {
      const Token name = expect_word("a constant name");
      check_name(decl, name);
      expect_punct('=');
      const Token value = expect_word("a constant value");
      ConstantDecl constant;
      constant.name = std::string(name.text);
      constant.value = parse_constant_value(*primitive, value);
      decl.constants.push_back(std::move(constant));
      if (!is_punct(',')) break;
      advance();
    }
    expect_punct(';');
  }

  ConstValue parse_constant_value(const LcmPrimitive& type, const Token& token) {
    const std::string text(token.text);
    if (type.kind == TypeKind::float32 || type.kind == TypeKind::float64) {
      const std::optional<double> value = parse_floating(text);
      if (!value) {
        error_at(location(token), "value '" + text + "' is not a floating point number");
        throw Abandon{};
      }
      if (type.kind == TypeKind::float32 && std::isfinite(*value) &&
          std::fabs(*value) > std::numeric_limits<float>::max()) {
        error_at(location(token), "value '" + text + "' is out of range for float");
        throw Abandon{};
      }
      return *value;
    }
    std::int64_t value = 0;
    const IntegerText parsed = parse_c_integer(text, value);
    if (parsed == IntegerText::invalid) {
      error_at(location(token), "value '" + text + "' is not an integer");
      throw Abandon{};
    }
    std::int64_t low = std::numeric_limits<std::int64_t>::min();
    std::int64_t high = std::numeric_limits<std::int64_t>::max();
    if (type.kind == TypeKind::int8) {
      low = std::numeric_limits<std::int8_t>::min();
      high = std::numeric_limits<std::int8_t>::max();
    } else if (type.kind == TypeKind::int16) {
      low = std::numeric_limits<std::int16_t>::min();
      high = std::numeric_limits<std::int16_t>::max();
    } else if (type.kind == TypeKind::int32) {
      low = std::numeric_limits<std::int32_t>::min();
      high = std::numeric_limits<std::int32_t>::max();
    }
    if (parsed == IntegerText::out_of_range || value < low || value > high) {
      error_at(location(token), "value '" + text + "' is out of range for " + std::string(type.name));
      throw Abandon{};
    }
    return value;
  }

  Lexer lexer_;
  const std::string& file_;
  Diagnostics& diagnostics_;
  Token current_;
  std::string package_;
  std::vector<StructDecl> structs_;
};

// lcm-gen's base hash of a struct: member names, primitive type names and dimensions; not
// the struct's name and not the names of struct-typed members' types.
std::uint64_t base_hash(const StructDecl& decl) {
  std::uint64_t v = 0x12345678;
  for (const MemberDecl& member : decl.members) {
    v = hash_string(v, member.name);
    if (member.primitive != nullptr) v = hash_string(v, member.type_name);
    v = hash_update(v, static_cast<std::uint8_t>(member.dimensions.size()));
    for (const DimensionDecl& dimension : member.dimensions) {
      v = hash_update(v, dimension.variable ? 1 : 0);
      v = hash_string(v, dimension.size);
    }
  }
  return v;
}

}  // namespace

bool parse_lcm(std::string_view text, const std::string& file_name, TypeRegistry& registry,
               Diagnostics& diagnostics) {
  const std::size_t errors_before = diagnostics.error_count();
  std::vector<StructDecl> decls = LcmParser(text, file_name, diagnostics).parse();

  // The first declaration of each name in this file; a second one is reported as a
  // redefinition when it is registered.
  std::map<std::string, std::size_t, std::less<>> local;
  for (std::size_t i = 0; i < decls.size(); ++i) local.emplace(decls[i].dotted_name, i);

  enum class State : std::uint8_t { pending, visiting, done, failed };
  std::vector<State> state(decls.size(), State::pending);
  std::vector<const Type*> registered(decls.size(), nullptr);

  // Registers decls[index] once every struct it uses is registered. Depth-first with an
  // explicit stack, so a long chain of structs cannot overflow the call stack.
  const auto register_decl = [&](std::size_t index) {
    StructDecl& decl = decls[index];
    bool ok = decl.valid;
    std::vector<Field> fields;
    std::uint64_t member_hashes = 0;
    for (const MemberDecl& member : decl.members) {
      const Type* type = nullptr;
      if (member.primitive != nullptr) {
        type = registry.primitive(member.primitive->kind);
      } else if (auto it = local.find(member.type_name); it != local.end()) {
        type = registered[it->second];  // null if it failed: already reported there
        if (type == nullptr) ok = false;
      } else {
        const Type* found = registry.find(to_qualified(member.type_name));
        // find() also knows primitives by other spellings ("int32"); LCM does not.
        if (found == nullptr || found->origin == TypeOrigin::builtin) {
          diagnostics.error(member.type_where, {}, "unknown type '" + member.type_name + "'");
          ok = false;
        } else if (found->origin != TypeOrigin::lcm || found->kind != TypeKind::structure) {
          diagnostics.error(member.type_where, {}, "type '" + member.type_name + "' is not an LCM struct");
          ok = false;
        } else {
          type = found;
        }
      }
      if (type == nullptr) continue;
      if (type->kind == TypeKind::structure) member_hashes += type->lcm_fingerprint;
      Field field;
      field.name = member.name;
      field.where = member.where;
      // Innermost dimension first: T v[a][b] is an a-sized array of b-sized arrays of T.
      for (auto dimension = member.dimensions.rbegin(); dimension != member.dimensions.rend() && type != nullptr;
           ++dimension) {
        type = dimension->variable ? registry.sequence_of(type, 0)
                                   : registry.array_of(type, dimension->length);
      }
      if (type == nullptr) {
        diagnostics.error(member.where, {}, "member '" + member.name + "' is too large");
        ok = false;
        continue;
      }
      for (const DimensionDecl& dimension : member.dimensions) {
        if (dimension.variable) field.length_fields.push_back(dimension.size);
      }
      field.type = type;
      fields.push_back(std::move(field));
    }
    if (!ok) return false;
    Type* type =
        registry.declare_struct(to_qualified(decl.dotted_name), std::move(fields), decl.where, diagnostics);
    if (type == nullptr) return false;
    // The LCM facts are set once here, before anyone else can see the type.
    type->origin = TypeOrigin::lcm;
    type->lcm_fingerprint = rotate_left_1(base_hash(decl) + member_hashes);
    for (ConstantDecl& constant : decl.constants) {
      registry.set_constant(type->name + "::" + constant.name, std::move(constant.value));
    }
    registered[index] = type;
    return true;
  };

  struct Visit {
    std::size_t index;
    std::size_t next_member;
  };
  std::vector<Visit> stack;
  for (std::size_t root = 0; root < decls.size(); ++root) {
    if (state[root] != State::pending) continue;
    state[root] = State::visiting;
    stack.push_back({root, 0});
    while (!stack.empty()) {
      Visit& visit = stack.back();
      StructDecl& decl = decls[visit.index];
      if (visit.next_member < decl.members.size()) {
        const MemberDecl& member = decl.members[visit.next_member++];
        if (member.primitive != nullptr) continue;
        const auto it = local.find(member.type_name);
        if (it == local.end()) continue;
        if (state[it->second] == State::visiting) {
          diagnostics.error(member.type_where, {},
                            "type '" + member.type_name + "' contains itself (recursive LCM types are not supported)");
          decl.valid = false;
        } else if (state[it->second] == State::pending) {
          state[it->second] = State::visiting;
          stack.push_back({it->second, 0});  // `visit` is not used after this
        }
        continue;
      }
      state[visit.index] = register_decl(visit.index) ? State::done : State::failed;
      stack.pop_back();
    }
  }
  return diagnostics.error_count() == errors_before;
}

}  // namespace polyport
