// IDL type specifiers, for the IDL parser (IdlParser, idl_parser_impl.hpp): the primitive
// keywords, scoped type names, string<N>, sequence<T, N> and array declarators, and the
// anonymous types they make (shared by their IDL spelling) with their flat layout.
#include <algorithm>
#include <cstdint>
#include <iterator>
#include <set>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "idl_parser_impl.hpp"
#include "polyport/types/types.hpp"

namespace polyport::idl_detail {

namespace {

const std::set<std::string, std::less<>> kUnsupportedTypes = {
    "wstring", "wchar", "any", "fixed", "map", "Object", "ValueBase", "void",
};

std::uint64_t align_up(std::uint64_t value, std::uint64_t alignment) {
  if (alignment <= 1) return value;
  return (value + alignment - 1) / alignment * alignment;
}

}  // namespace

const Type* IdlParser::builtin(std::string_view name) const {
  return registry_.find_exact(name);
}

const Type* IdlParser::parse_type_spec() {
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

bool IdlParser::accept_word(std::string_view word) {
  if (!is_word(peek(), word)) return false;
  next();
  return true;
}

std::uint32_t IdlParser::parse_bound(const std::string& what, std::uint64_t max, bool in_template) {
  const Token& start = peek();
  const ConstValue value = parse_expression(in_template);
  const auto* number = std::get_if<std::int64_t>(&value);
  if (number == nullptr || *number <= 0)
    fail(start, what + " must be a positive integer constant");
  if (static_cast<std::uint64_t>(*number) > max) fail(start, what + " is too large");
  return static_cast<std::uint32_t>(*number);
}

// `name[2][3]`: an array of 2 arrays of 3, so indexing peels the outer dimension first.
const Type* IdlParser::parse_array_declarator(const Type* element) {
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

const Type* IdlParser::bounded_string(std::uint32_t bound) {
  return anonymous("string<" + std::to_string(bound) + ">", [&](Type& type) {
    type.kind = TypeKind::string;
    type.size = bound + 1;
    type.align = 1;
    type.bound = bound;
  });
}

const Type* IdlParser::sequence(const Type* element, std::uint32_t bound, const Token& at) {
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
const Type* IdlParser::anonymous(const std::string& name, Init&& init) {
  if (const Type* shared = registry_.find_anonymous(name)) return shared;
  Type& type = registry_.make_type();
  type.name = name;
  init(type);
  registry_.add_anonymous(type);
  return &type;
}

}  // namespace polyport::idl_detail
