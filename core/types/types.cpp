#include "polyport/types/types.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstring>
#include <utility>

namespace polyport {

namespace {

struct PrimitiveInfo {
  TypeKind kind;
  std::uint32_t size;
};

constexpr PrimitiveInfo kPrimitives[] = {
    {TypeKind::boolean, 1}, {TypeKind::char8, 1}, {TypeKind::octet, 1},  {TypeKind::int8, 1},
    {TypeKind::uint8, 1},   {TypeKind::int16, 2}, {TypeKind::uint16, 2}, {TypeKind::int32, 4},
    {TypeKind::uint32, 4},  {TypeKind::int64, 8}, {TypeKind::uint64, 8}, {TypeKind::float32, 4},
    {TypeKind::float64, 8},
};

// Other spellings find() accepts for the primitives (IDL 4 sized names and the float
// names profiles use); the parser itself only takes IDL keywords.
constexpr std::pair<std::string_view, std::string_view> kSynonyms[] = {
    {"int16", "short"},          {"uint16", "unsigned short"}, {"int32", "long"},
    {"uint32", "unsigned long"}, {"int64", "long long"},       {"uint64", "unsigned long long"},
    {"float32", "float"},        {"float64", "double"},
};

std::string_view strip_global(std::string_view name) noexcept {
  if (name.starts_with("::")) name.remove_prefix(2);
  return name;
}

// Follows aliases a bounded number of hops, so a malformed hand-built cycle cannot hang.
constexpr int kMaxAliasHops = 256;
constexpr int kMaxJsonDepth = 256;

// The length of the valid UTF-8 sequence starting at s[i], or 0 if it is not valid.
std::size_t utf8_length(std::string_view s, std::size_t i) noexcept {
  const auto byte = [&](std::size_t k) { return static_cast<unsigned char>(s[k]); };
  const unsigned char lead = byte(i);
  std::size_t length = 0;
  unsigned char low = 0x80;
  unsigned char high = 0xBF;
  if (lead >= 0xC2 && lead <= 0xDF) {
    length = 2;
  } else if (lead >= 0xE0 && lead <= 0xEF) {
    length = 3;
    if (lead == 0xE0) low = 0xA0;   // overlong
    if (lead == 0xED) high = 0x9F;  // surrogates
  } else if (lead >= 0xF0 && lead <= 0xF4) {
    length = 4;
    if (lead == 0xF0) low = 0x90;   // overlong
    if (lead == 0xF4) high = 0x8F;  // beyond U+10FFFF
  } else {
    return 0;
  }
  if (i + length > s.size()) return 0;
  if (byte(i + 1) < low || byte(i + 1) > high) return 0;
  for (std::size_t k = 2; k < length; ++k) {
    if (byte(i + k) < 0x80 || byte(i + k) > 0xBF) return 0;
  }
  return length;
}

void append_escaped_byte(std::string& out, unsigned char c) {
  constexpr char kHex[] = "0123456789abcdef";
  out += "\\u00";
  out += kHex[c >> 4];
  out += kHex[c & 0xF];
}

void append_json_string(std::string& out, std::string_view text) {
  out += '"';
  std::size_t i = 0;
  while (i < text.size()) {
    const auto c = static_cast<unsigned char>(text[i]);
    if (c >= 0x80) {
      const std::size_t length = utf8_length(text, i);
      if (length == 0) {
        // JSON must be UTF-8; a stray byte becomes the replacement character.
        out += "\\ufffd";
        ++i;
      } else {
        out.append(text.substr(i, length));
        i += length;
      }
      continue;
    }
    switch (c) {
      case '"': out += "\\\""; break;
      case '\\': out += "\\\\"; break;
      case '\b': out += "\\b"; break;
      case '\f': out += "\\f"; break;
      case '\n': out += "\\n"; break;
      case '\r': out += "\\r"; break;
      case '\t': out += "\\t"; break;
      default:
        if (c < 0x20) {
          append_escaped_byte(out, c);
        } else {
          out += static_cast<char>(c);
        }
    }
    ++i;
  }
  out += '"';
}

std::uint64_t align_up(std::uint64_t value, std::uint64_t alignment) noexcept {
  if (alignment <= 1) return value;
  return (value + alignment - 1) / alignment * alignment;
}

class JsonWriter {
 public:
  JsonWriter(const std::byte* sample, std::size_t size) : sample_(sample), size_(size) {}

  std::string take() { return std::move(out_); }

  void render(const Type& declared, std::uint64_t at, int depth) {
    const Type& type = declared.resolved();
    if (depth > kMaxJsonDepth || type.kind == TypeKind::alias || !fits(at, type.size)) {
      out_ += "null";
      return;
    }
    switch (type.kind) {
      case TypeKind::boolean: out_ += read<std::uint8_t>(at) != 0 ? "true" : "false"; break;
      case TypeKind::char8: render_char(read<unsigned char>(at)); break;
      case TypeKind::octet:
      case TypeKind::uint8: append_integer(read<std::uint8_t>(at)); break;
      case TypeKind::int8: append_integer(read<std::int8_t>(at)); break;
      case TypeKind::int16: append_integer(read<std::int16_t>(at)); break;
      case TypeKind::uint16: append_integer(read<std::uint16_t>(at)); break;
      case TypeKind::int32: append_integer(read<std::int32_t>(at)); break;
      case TypeKind::uint32: append_integer(read<std::uint32_t>(at)); break;
      case TypeKind::int64: append_integer(read<std::int64_t>(at)); break;
      case TypeKind::uint64: append_integer(read<std::uint64_t>(at)); break;
      case TypeKind::float32: append_float(read<float>(at)); break;
      case TypeKind::float64: append_float(read<double>(at)); break;
      case TypeKind::string: render_string(type, at); break;
      case TypeKind::enumeration: render_enum(type, at); break;
      case TypeKind::structure: render_struct(type, at, depth); break;
      case TypeKind::array: render_array(type, at, depth); break;
      case TypeKind::sequence: render_sequence(type, at, depth); break;
      case TypeKind::alias: out_ += "null"; break;
    }
  }

 private:
  bool fits(std::uint64_t at, std::uint64_t bytes) const noexcept {
    return at <= size_ && bytes <= size_ - at;
  }

  // Callers check fits() first; memcpy because sample fields need not be aligned in memory.
  template <class T>
  T read(std::uint64_t at) const noexcept {
    T value;
    std::memcpy(&value, sample_ + at, sizeof value);
    return value;
  }

  template <class T>
  void append_integer(T value) {
    char buffer[32];
    const auto result = std::to_chars(buffer, buffer + sizeof buffer, value);
    out_.append(buffer, result.ptr);
  }

  template <class T>
  void append_float(T value) {
    if (!std::isfinite(value)) {
      out_ += "null";
      return;
    }
    // The shortest text that reads back as the same value.
    char buffer[64];
    const auto result = std::to_chars(buffer, buffer + sizeof buffer, value);
    out_.append(buffer, result.ptr);
  }

  void render_char(unsigned char c) {
    if (c >= 0x80) {
      // An IDL char is one byte; above ASCII it is taken as Latin-1.
      out_ += '"';
      append_escaped_byte(out_, c);
      out_ += '"';
      return;
    }
    const char text = static_cast<char>(c);
    append_json_string(out_, std::string_view(&text, 1));
  }

  void render_string(const Type& type, std::uint64_t at) {
    if (type.bound > 0) {
      const char* chars = reinterpret_cast<const char*>(sample_ + at);
      // The N + 1st byte should be the NUL; without one the text stops at the bound.
      const std::size_t length = strnlen(chars, type.bound);
      append_json_string(out_, std::string_view(chars, length));
      return;
    }
    const auto span = read<FlatSpan>(at);
    if (!fits(span.offset, span.count)) {
      out_ += "null";
      return;
    }
    append_json_string(
        out_, std::string_view(reinterpret_cast<const char*>(sample_ + span.offset), span.count));
  }

  void render_enum(const Type& type, std::uint64_t at) {
    const auto value = read<std::int32_t>(at);
    for (const Enumerator& enumerator : type.enumerators) {
      if (enumerator.value == value) {
        append_json_string(out_, enumerator.name);
        return;
      }
    }
    append_integer(value);  // not one of the enumerators: show the raw value
  }

  void render_struct(const Type& type, std::uint64_t at, int depth) {
    out_ += '{';
    bool first = true;
    for (const Field& field : type.fields) {
      if (!first) out_ += ',';
      first = false;
      append_json_string(out_, field.name);
      out_ += ':';
      if (field.type == nullptr) {
        out_ += "null";
      } else {
        render(*field.type, at + field.offset, depth + 1);
      }
    }
    out_ += '}';
  }

  void render_elements(const Type* element, std::uint64_t first, std::uint64_t count, int depth) {
    out_ += '[';
    for (std::uint64_t i = 0; i < count; ++i) {
      if (i > 0) out_ += ',';
      render(*element, first + i * element->size, depth + 1);
    }
    out_ += ']';
  }

  // Elements must lie inside the sample; a zero-sized element still counts one byte so a
  // corrupt count cannot make the output unbounded.
  bool elements_fit(const Type* element, std::uint64_t first, std::uint64_t count) const {
    if (first > size_) return false;
    const std::uint64_t stride = element->size == 0 ? 1 : element->size;
    return count <= (size_ - first) / stride;
  }

  void render_array(const Type& type, std::uint64_t at, int depth) {
    if (type.element == nullptr || !elements_fit(type.element, at, type.bound)) {
      out_ += "null";
      return;
    }
    render_elements(type.element, at, type.bound, depth);
  }

  void render_sequence(const Type& type, std::uint64_t at, int depth) {
    if (type.element == nullptr) {
      out_ += "null";
      return;
    }
    std::uint64_t first = 0;
    std::uint64_t count = 0;
    if (type.bound > 0) {
      count = read<std::uint32_t>(at);
      first = at + align_up(sizeof(std::uint32_t), type.element->align);
      if (count > type.bound) {
        out_ += "null";
        return;
      }
    } else {
      const auto span = read<FlatSpan>(at);
      first = span.offset;
      count = span.count;
    }
    if (!elements_fit(type.element, first, count)) {
      out_ += "null";
      return;
    }
    render_elements(type.element, first, count, depth);
  }

  const std::byte* sample_;
  std::size_t size_;
  std::string out_;
};

}  // namespace

std::string_view kind_name(TypeKind kind) noexcept {
  switch (kind) {
    case TypeKind::boolean: return "boolean";
    case TypeKind::char8: return "char";
    case TypeKind::octet: return "octet";
    case TypeKind::int8: return "int8";
    case TypeKind::uint8: return "uint8";
    case TypeKind::int16: return "short";
    case TypeKind::uint16: return "unsigned short";
    case TypeKind::int32: return "long";
    case TypeKind::uint32: return "unsigned long";
    case TypeKind::int64: return "long long";
    case TypeKind::uint64: return "unsigned long long";
    case TypeKind::float32: return "float";
    case TypeKind::float64: return "double";
    case TypeKind::string: return "string";
    case TypeKind::enumeration: return "enum";
    case TypeKind::structure: return "struct";
    case TypeKind::sequence: return "sequence";
    case TypeKind::array: return "array";
    case TypeKind::alias: return "typedef";
  }
  return "unknown";
}

const Type& Type::resolved() const noexcept {
  const Type* type = this;
  for (int hops = 0;
       type->kind == TypeKind::alias && type->element != nullptr && hops < kMaxAliasHops; ++hops) {
    type = type->element;
  }
  return *type;
}

const Field* Type::find_field(std::string_view field_name) const noexcept {
  for (const Field& field : resolved().fields) {
    if (field.name == field_name) return &field;
  }
  return nullptr;
}

bool is_number(TypeKind kind) noexcept {
  switch (kind) {
    case TypeKind::int8: case TypeKind::uint8: case TypeKind::int16: case TypeKind::uint16:
    case TypeKind::int32: case TypeKind::uint32: case TypeKind::int64: case TypeKind::uint64:
    case TypeKind::float32: case TypeKind::float64: case TypeKind::octet:
      return true;
    default:
      return false;
  }
}

bool has_unbounded(const Type& type) noexcept {
  const Type& t = type.resolved();
  switch (t.kind) {
    case TypeKind::string:
    case TypeKind::sequence:
      if (t.bound == 0) return true;
      return t.element != nullptr && has_unbounded(*t.element);
    case TypeKind::array:
      return t.element != nullptr && has_unbounded(*t.element);
    case TypeKind::structure:
      return std::any_of(t.fields.begin(), t.fields.end(),
                         [](const Field& f) { return f.type != nullptr && has_unbounded(*f.type); });
    default:
      return false;
  }
}

bool Type::is_primitive() const noexcept {
  return kind >= TypeKind::boolean && kind <= TypeKind::float64;
}

TypeRegistry::TypeRegistry() {
  for (const PrimitiveInfo& info : kPrimitives) {
    Type& type = make_type();
    type.kind = info.kind;
    type.name = std::string(kind_name(info.kind));
    type.size = info.size;
    type.align = info.size;
    by_name_.emplace(type.name, &type);
  }
  Type& string_type = make_type();
  string_type.kind = TypeKind::string;
  string_type.name = "string";
  string_type.size = sizeof(FlatSpan);
  string_type.align = alignof(FlatSpan);
  by_name_.emplace(string_type.name, &string_type);
}

const Type* TypeRegistry::find(std::string_view name) const noexcept {
  name = strip_global(name);
  if (auto it = by_name_.find(name); it != by_name_.end()) return it->second;
  for (const auto& [synonym, canonical] : kSynonyms) {
    if (synonym == name) {
      auto it = by_name_.find(canonical);
      return it == by_name_.end() ? nullptr : it->second;
    }
  }
  // LCM spells qualified names with dots ("a.b.t" is registered as "a::b::t").
  if (name.find('.') != std::string_view::npos && name.find(':') == std::string_view::npos) {
    try {
      std::string qualified;
      qualified.reserve(name.size() * 2);
      for (char c : name) {
        if (c == '.') {
          qualified += "::";
        } else {
          qualified += c;
        }
      }
      auto it = by_name_.find(qualified);
      return it == by_name_.end() ? nullptr : it->second;
    } catch (...) {  // out of memory: find() is noexcept and "not found" is a safe answer
      return nullptr;
    }
  }
  return nullptr;
}

const Type* TypeRegistry::primitive(TypeKind kind) const noexcept {
  const bool has_builtin =
      (kind >= TypeKind::boolean && kind <= TypeKind::float64) || kind == TypeKind::string;
  if (!has_builtin) return nullptr;
  auto it = by_name_.find(kind_name(kind));
  return it == by_name_.end() ? nullptr : it->second;
}

std::vector<const Type*> TypeRegistry::declared() const { return declared_; }

std::optional<ConstValue> TypeRegistry::constant(std::string_view qualified_name) const {
  auto it = constants_.find(strip_global(qualified_name));
  if (it == constants_.end()) return std::nullopt;
  return it->second;
}

Type& TypeRegistry::make_type() { return storage_.emplace_back(); }

namespace {
constexpr std::uint64_t kLayoutLimit = 0xFFFFFFFFu;
std::uint64_t align_to(std::uint64_t value, std::uint64_t align) { return (value + align - 1) / align * align; }
}  // namespace

bool TypeRegistry::layout_struct(Type& type) noexcept {
  std::uint64_t offset = 0;
  std::uint32_t align = 1;
  for (Field& field : type.fields) {
    offset = align_to(offset, field.type->align);
    if (offset > kLayoutLimit) return false;
    field.offset = static_cast<std::uint32_t>(offset);
    offset += field.type->size;
    align = std::max(align, field.type->align);
  }
  const std::uint64_t size = align_to(offset, align);
  if (size > kLayoutLimit) return false;
  type.size = static_cast<std::uint32_t>(size);
  type.align = align;
  return true;
}

const Type* TypeRegistry::array_of(const Type* element, std::uint32_t length) {
  // Multi-dimensional arrays read as IDL writes them: an array of double[4] is double[3][4].
  const Type* innermost = element;
  while (innermost->kind == TypeKind::array) innermost = innermost->element;
  const std::string name = innermost->name + "[" + std::to_string(length) + "]" +
                           element->name.substr(innermost->name.size());
  if (auto it = anonymous_.find(name); it != anonymous_.end()) return it->second;
  const std::uint64_t size = static_cast<std::uint64_t>(length) * element->size;
  if (size > kLayoutLimit) return nullptr;
  Type& type = make_type();
  type.kind = TypeKind::array;
  type.name = name;
  type.size = static_cast<std::uint32_t>(size);
  type.align = element->align;
  type.bound = length;
  type.element = element;
  anonymous_.emplace(name, &type);
  return &type;
}

const Type* TypeRegistry::sequence_of(const Type* element, std::uint32_t bound) {
  const std::string name =
      "sequence<" + element->name + (bound ? ", " + std::to_string(bound) : std::string()) + ">";
  if (auto it = anonymous_.find(name); it != anonymous_.end()) return it->second;
  std::uint64_t size = sizeof(FlatSpan);
  std::uint32_t align = alignof(FlatSpan);
  if (bound != 0) {
    align = std::max<std::uint32_t>(alignof(std::uint32_t), element->align);
    size = align_to(align_to(sizeof(std::uint32_t), element->align) + static_cast<std::uint64_t>(bound) * element->size,
                    align);
    if (size > kLayoutLimit) return nullptr;
  }
  Type& type = make_type();
  type.kind = TypeKind::sequence;
  type.name = name;
  type.size = static_cast<std::uint32_t>(size);
  type.align = align;
  type.bound = bound;
  type.element = element;
  anonymous_.emplace(name, &type);
  return &type;
}

const Type* TypeRegistry::string_of(std::uint32_t bound) {
  if (bound == 0) return find("string");
  const std::string name = "string<" + std::to_string(bound) + ">";
  if (auto it = anonymous_.find(name); it != anonymous_.end()) return it->second;
  if (bound >= kLayoutLimit) return nullptr;
  Type& type = make_type();
  type.kind = TypeKind::string;
  type.name = name;
  type.size = bound + 1;
  type.align = 1;
  type.bound = bound;
  anonymous_.emplace(name, &type);
  return &type;
}

Type* TypeRegistry::declare_struct(const std::string& qualified_name, std::vector<Field> fields,
                                   const SourceLocation& where, Diagnostics& diagnostics) {
  if (by_name_.count(qualified_name) != 0) {
    diagnostics.error(where, {}, "redefinition of '" + qualified_name + "'");
    return nullptr;
  }
  Type type;
  type.kind = TypeKind::structure;
  type.name = qualified_name;
  type.fields = std::move(fields);
  type.where = where;
  if (!layout_struct(type)) {
    diagnostics.error(where, {}, "type '" + qualified_name + "' is too large");
    return nullptr;
  }
  Type& stored = make_type();
  stored = std::move(type);
  declare(stored);
  return &stored;
}

void TypeRegistry::declare(Type& type) {
  by_name_.emplace(type.name, &type);
  declared_.push_back(&type);
}

void TypeRegistry::add_anonymous(Type& type) { anonymous_.emplace(type.name, &type); }

const UnusableType* TypeRegistry::find_unusable(std::string_view name) const noexcept {
  auto it = unusable_.find(strip_global(name));
  return it == unusable_.end() ? nullptr : &it->second;
}

void TypeRegistry::declare_unusable(UnusableType unusable) {
  std::string name = unusable.name;
  unusable_.try_emplace(std::move(name), std::move(unusable));
}

const Type* TypeRegistry::find_exact(std::string_view name) const noexcept {
  auto it = by_name_.find(name);
  return it == by_name_.end() ? nullptr : it->second;
}

const Type* TypeRegistry::find_anonymous(std::string_view name) const noexcept {
  auto it = anonymous_.find(name);
  return it == anonymous_.end() ? nullptr : it->second;
}

void TypeRegistry::set_constant(std::string qualified_name, ConstValue value) {
  constants_.insert_or_assign(std::move(qualified_name), std::move(value));
}

bool TypeRegistry::has_module(std::string_view qualified_name) const noexcept {
  return modules_.contains(qualified_name);
}

void TypeRegistry::add_module(const std::string& qualified_name, const SourceLocation& where) {
  modules_.emplace(qualified_name, where);
}

std::string sample_to_json(const Type& type, const std::byte* sample, std::size_t size) {
  if (sample == nullptr) size = 0;
  JsonWriter writer(sample, size);
  writer.render(type, 0, 0);
  return writer.take();
}

}  // namespace polyport
