// An OMG IDL subset for data types: modules, structs, enums, typedefs, constants, fixed
// arrays, sequences and strings. Everything else in IDL (interfaces, unions, valuetypes,
// ...) is reported as unsupported. The parser reports every error it finds, resynchronising
// at the next `;` or `}` of the current nesting level after each one.
//
// This file holds the parser's driver, scoped names, annotations and the declarations
// (modules, structs, enums, typedefs, constants); the tokens come from idl_lexer.cpp, type
// specifiers from idl_type_spec.cpp and constant expressions from idl_const_expr.cpp.
#include <algorithm>
#include <cstdint>
#include <limits>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <utility>
#include <variant>
#include <vector>

#include "idl_parser_impl.hpp"
#include "polyport/types/idl_parser.hpp"
#include "polyport/types/types.hpp"

namespace polyport {

namespace idl_detail {

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

namespace {

// Declarations this subset does not support; each gets its own message.
const std::set<std::string, std::less<>> kUnsupportedDeclarations = {
    "union",  "interface", "exception", "valuetype", "abstract",   "local",
    "custom", "eventtype", "component", "home",      "porttype",   "connector",
    "native", "bitset",    "bitmask",   "typeid",    "typeprefix", "import",
};

std::string join_scope(const std::vector<std::string>& scope, std::size_t count) {
  std::string out;
  for (std::size_t i = 0; i < count; ++i) {
    if (!out.empty()) out += "::";
    out += scope[i];
  }
  return out;
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

bool IdlParser::parse(std::string_view text, Diagnostics& diagnostics) {
  tokens_ = lex_idl(text, raw_);
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

// ---- error recovery -------------------------------------------------------------------

// Skips the rest of a broken declaration: through the next `;` of this nesting level, or
// up to (not through) the `}` that closes the enclosing body.
void IdlParser::synchronize() {
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

std::string IdlParser::expect_name(std::string message) {
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

std::string IdlParser::qualify(const std::string& name) const {
  std::string scope = join_scope(scope_, scope_.size());
  return scope.empty() ? name : scope + "::" + name;
}

// A failed declaration still takes its name: a second one is a redefinition.
bool IdlParser::name_taken(std::string_view qualified) const {
  return registry_.find_exact(qualified) != nullptr ||
         registry_.constant(qualified).has_value() || registry_.has_module(qualified) ||
         failed_names_.contains(qualified);
}

void IdlParser::check_new_name(const Token& at, const std::string& qualified) {
  if (name_taken(qualified)) fail(at, "redefinition of '" + qualified + "'");
}

ScopedName IdlParser::parse_scoped_name() {
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
std::vector<std::string> IdlParser::candidates(const ScopedName& name) const {
  if (name.absolute) return {name.joined};
  std::vector<std::string> out;
  for (std::size_t count = scope_.size() + 1; count-- > 0;) {
    const std::string prefix = join_scope(scope_, count);
    out.push_back(prefix.empty() ? name.joined : prefix + "::" + name.joined);
  }
  return out;
}

const Type* IdlParser::resolve_type(const ScopedName& name, const Token& at) {
  for (const std::string& candidate : candidates(name)) {
    // Built-in names are keywords, which never reach here, so every hit is a user type.
    if (const Type* type = registry_.find_exact(candidate)) return type;
    if (candidate == defining_) fail(at, "struct '" + candidate + "' cannot contain itself");
    if (failed_names_.contains(candidate)) throw Failed{};  // already reported
    if (forward_declared_.contains(candidate)) fail(at, "incomplete type '" + candidate + "'");
    if (registry_.constant(candidate).has_value() || registry_.has_module(candidate)) {
      fail(at, "'" + name.spelled + "' is not a type");
    }
  }
  fail(at, "unknown type '" + name.spelled + "'");
}

ConstValue IdlParser::resolve_constant(const ScopedName& name, const Token& at) {
  for (const std::string& candidate : candidates(name)) {
    if (std::optional<ConstValue> value = registry_.constant(candidate)) return *std::move(value);
    if (failed_names_.contains(candidate)) throw Failed{};
    if (registry_.find_exact(candidate) != nullptr || registry_.has_module(candidate)) {
      fail(at, "'" + name.spelled + "' is not a constant");
    }
  }
  fail(at, "unknown constant '" + name.spelled + "'");
}

// ---- annotations ----------------------------------------------------------------------

// Reads `@name` and `@name(...)` annotations; the parser ignores all but `@value`.
std::vector<IdlParser::Annotation> IdlParser::parse_annotations() {
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

std::string IdlParser::parse_annotation_name() {
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
void IdlParser::skip_annotation_declaration() {
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

bool IdlParser::starts_definition(const Token& token) const {
  static constexpr std::string_view kStarts[] = {"module", "struct", "enum", "typedef", "const"};
  if (token.kind == TokenKind::end || is_punct(token, "}") || is_punct(token, "@")) return true;
  return token.kind == TokenKind::identifier &&
         (std::find(std::begin(kStarts), std::end(kStarts), token.text) != std::end(kStarts) ||
          kUnsupportedDeclarations.contains(token.text));
}

// The `;` after a `}`. Without it the definition still counts; what follows is skipped
// up to the next `;` unless it starts a new definition (`} s;` would otherwise give a
// second error for `s`).
void IdlParser::expect_definition_end(std::string message) {
  if (accept(";")) return;
  error(peek(), std::move(message));
  if (!starts_definition(peek())) synchronize();
}

void IdlParser::parse_definitions(bool in_module) {
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

void IdlParser::parse_definition() {
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

void IdlParser::parse_module() {
  next();  // module
  const Token& name_token = peek();
  const std::string name = expect_name("expected module name");
  const std::string qualified = qualify(name);
  if (!registry_.has_module(qualified)) check_new_name(name_token, qualified);
  expect("{", "expected '{' after module name");
  if (scope_.size() >= kMaxModuleDepth) fail(name_token, "modules nested too deeply");
  registry_.add_module(qualified, location(name_token));
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
Extensibility IdlParser::extensibility_of(const std::vector<Annotation>& annotations) {
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

void IdlParser::parse_struct(const std::vector<Annotation>& annotations) {
  next();  // struct
  const Token& name_token = peek();
  const std::string name = expect_name("expected struct name");
  const std::string qualified = qualify(name);
  if (accept(";")) {
    // A forward declaration: the type only becomes usable once it is defined.
    if (registry_.find_exact(qualified) == nullptr) {
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
bool IdlParser::parse_member(Type& type) {
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

bool IdlParser::layout_struct(Type& type) {
  return TypeRegistry::layout_struct(type);
}

void IdlParser::parse_enum() {
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

std::int64_t IdlParser::evaluate_annotation_integer(const Annotation& annotation) {
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

void IdlParser::parse_typedef() {
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

void IdlParser::parse_const() {
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
    registry_.set_constant(qualified, std::move(value));
  } catch (const Failed&) {
    failed_names_.insert(qualified);
    throw;
  }
}

ConstValue IdlParser::convert_constant(ConstValue value, const Type& declared_type,
                                       const Token& at) {
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

}  // namespace idl_detail

bool parse_idl(std::string_view text, const std::string& file_name, TypeRegistry& registry,
               Diagnostics& diagnostics) {
  idl_detail::IdlParser parser(registry, file_name);
  return parser.parse(text, diagnostics);
}

}  // namespace polyport
