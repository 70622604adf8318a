// The runtime type registry. Types come from files a profile names (OMG IDL now; `.lcm`
// and DBC files later) and every sample of a type lives in one flat block of bytes whose
// layout is computed here, C-struct style, so that a sample is copied with memcpy and never
// owns per-field heap objects.
//
// Flat layout rules (the contract between the registry, codecs and component plugins):
//  - primitives: natural size and alignment (boolean, char, octet: 1 byte); an enum is an
//    int32_t.
//  - struct: members in declaration order, each at the next offset aligned to its own
//    alignment; the size is rounded up to the struct's alignment (the largest member's).
//  - fixed array T[N] (and T[N][M], row-major): N elements inline.
//  - bounded string<N>: char[N + 1], NUL-terminated, alignment 1.
//  - bounded sequence<T, N>: FlatBoundedSequence: a uint32_t length, then N elements of T
//    at the next offset aligned to T's alignment.
//  - unbounded string and sequence<T>: a FlatSpan {uint32_t offset; uint32_t count;} whose
//    elements live in the sample's tail, `offset` bytes from the start of the sample (a
//    string's count excludes its NUL, which is stored too). A sample's buffer is sized for
//    the fixed part plus the tail capacity of the port that carries it.
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "polyport/base/diagnostics.hpp"

namespace polyport {

enum class TypeKind : std::uint8_t {
  boolean, char8, octet,
  int8, uint8, int16, uint16, int32, uint32, int64, uint64,
  float32, float64,
  string,       // bound == 0: unbounded
  enumeration,
  structure,
  sequence,     // bound == 0: unbounded; element set
  array,        // bound = element count; element set (nested for more dimensions)
  alias,        // a typedef: element is the aliased type; size/align copied from it
};

struct Type;
struct DbcMessage;  // dbc.hpp

enum class TypeOrigin : std::uint8_t { builtin, idl, lcm, dbc };
// XTypes extensibility (IDL @final / @appendable / @mutable); decides the XCDR2 encoding.
enum class Extensibility : std::uint8_t { final_, appendable, mutable_ };

struct Field {
  std::string name;
  const Type* type = nullptr;
  std::uint32_t offset = 0;
  SourceLocation where;
  // LCM variable-size dimensions: for each sequence level of `type`, outermost first, the
  // name of the sibling integer field that holds its length (empty for other fields).
  std::vector<std::string> length_fields;
};

struct Enumerator {
  std::string name;
  std::int32_t value = 0;
};

struct Type {
  TypeKind kind = TypeKind::int32;
  std::string name;            // fully qualified with `::` ("wheelchair::Reference"), or the
                               // IDL spelling for primitives and anonymous types ("double",
                               // "sequence<double, 4>", "string<16>", "double[3]")
  std::uint32_t size = 0;      // bytes of the flat layout (fixed part)
  std::uint32_t align = 1;
  std::uint32_t bound = 0;     // string/sequence bound (0 = unbounded), array length
  const Type* element = nullptr;   // sequence, array, alias
  std::vector<Field> fields;       // structure
  std::vector<Enumerator> enumerators;  // enumeration
  SourceLocation where;        // declaration; empty for built-ins
  TypeOrigin origin = TypeOrigin::builtin;
  Extensibility extensibility = Extensibility::final_;  // structs from IDL
  std::uint64_t lcm_fingerprint = 0;  // structs from .lcm files: the hash lcm-gen computes
  const DbcMessage* dbc = nullptr;    // structs from DBC files: the message's frame layout

  // Follows aliases down to the real type.
  const Type& resolved() const noexcept;
  const Field* find_field(std::string_view field_name) const noexcept;
  bool is_primitive() const noexcept;
};

// Integers (octet included) and floating-point kinds: what can be read as a number.
bool is_number(TypeKind kind) noexcept;

// Whether an unbounded string or sequence is anywhere inside the type (through arrays,
// bounded sequences and structs): such members live in a sample's tail, so the type has no
// largest size of its own.
bool has_unbounded(const Type& type) noexcept;

// The flat representations named in the layout rules above.
struct FlatSpan {
  std::uint32_t offset;
  std::uint32_t count;
};

using ConstValue = std::variant<std::int64_t, double, std::string, bool>;

// A named type a file declares but that cannot be used, and why (a DBC message whose
// signals overlap, for instance). The file still loads: only a profile that names the type
// fails, with this reason.
struct UnusableType {
  std::string name;
  SourceLocation where;  // the problem in the type file
  std::string reason;
};

class TypeRegistry {
 public:
  TypeRegistry();  // registers the primitive types
  TypeRegistry(const TypeRegistry&) = delete;
  TypeRegistry& operator=(const TypeRegistry&) = delete;

  // Parses an IDL file and registers what it declares. Every problem goes to diagnostics
  // as file:line:col; returns false if there was any error (what parsed cleanly before the
  // error may still be registered). A file already added (same canonical path) is skipped.
  bool add_idl_file(const std::filesystem::path& file, Diagnostics& diagnostics);
  bool add_idl_text(std::string_view text, const std::string& file_name, Diagnostics& diagnostics);
  // LCM type files (lcm_parser.hpp) and DBC files (dbc_parser.hpp), same contract.
  bool add_lcm_file(const std::filesystem::path& file, Diagnostics& diagnostics);
  bool add_lcm_text(std::string_view text, const std::string& file_name, Diagnostics& diagnostics);
  bool add_dbc_file(const std::filesystem::path& file, Diagnostics& diagnostics);
  bool add_dbc_text(std::string_view text, const std::string& file_name, Diagnostics& diagnostics);
  // Chooses by extension, in any case: .idl, .lcm, .dbc (.DBC); anything else is an error.
  bool add_type_file(const std::filesystem::path& file, Diagnostics& diagnostics);

  // Keeps an object alive as long as the registry (format-specific facts about types that
  // Type points to, such as DBC frame layouts).
  void retain(std::shared_ptr<const void> object) { retained_.push_back(std::move(object)); }

  // Looks a type up by qualified name: "a::b::T", "::a::b::T" and the primitive IDL names
  // ("double", "long", "unsigned long long", "int32", "uint8", "float64", ...).
  const Type* find(std::string_view name) const noexcept;
  const Type* primitive(TypeKind kind) const noexcept;
  // A name find() does not know because its declaration cannot be used (same spellings as
  // find() for declared names); null otherwise. Type-file parsers record them with
  // declare_unusable.
  const UnusableType* find_unusable(std::string_view name) const noexcept;
  void declare_unusable(UnusableType unusable);

  // The user-declared named types (structs, enums, typedefs), in declaration order.
  std::vector<const Type*> declared() const;
  std::optional<ConstValue> constant(std::string_view qualified_name) const;

  // Building types from sources other than IDL (`.lcm` and DBC files). Anonymous types are
  // shared by their IDL spelling ("double[3]", "sequence<long>", "string<8>"); null when
  // the type would exceed the size limit.
  const Type* array_of(const Type* element, std::uint32_t length);
  const Type* sequence_of(const Type* element, std::uint32_t bound);  // 0: unbounded
  const Type* string_of(std::uint32_t bound);                         // 0: unbounded
  // Lays out a struct of these fields (their offsets are computed) and registers it under
  // `qualified_name`. Reports and returns null when the name is taken or it is too large.
  // The caller may still set format-specific facts (origin, fingerprint) on the new type
  // before it hands the registry to anyone else.
  Type* declare_struct(const std::string& qualified_name, std::vector<Field> fields,
                       const SourceLocation& where, Diagnostics& diagnostics);
  // Computes field offsets, size and alignment of a struct by the layout rules above.
  static bool layout_struct(Type& type) noexcept;

  // The building blocks the type-file parsers (idl_parser.hpp, lcm_parser.hpp,
  // dbc_parser.hpp) register what they read with. A parser fills in a Type from make_type()
  // and then publishes it with declare() or add_anonymous(). Neither checks anything: the
  // parser reports a name already taken (find_exact, constant, has_module) or a type that
  // is too large, as declare_struct does for its caller.
  //
  // A new Type owned by the registry, at an address that never changes. Unpublished, it is
  // found by nothing.
  Type& make_type();
  // Publishes a named type (struct, enum, typedef) under type.name: find() and declared()
  // see it from now on.
  void declare(Type& type);
  // Publishes an anonymous type under type.name, its IDL spelling ("double[3]"), so that
  // every later use of the spelling shares it (array_of, sequence_of and string_of too).
  void add_anonymous(Type& type);
  // The primitive or declared type registered under exactly `name`: unlike find(), no
  // leading "::", no other spellings of the primitives ("int32") and no LCM dots.
  const Type* find_exact(std::string_view name) const noexcept;
  // The anonymous type with this IDL spelling, if one was published.
  const Type* find_anonymous(std::string_view name) const noexcept;
  // Defines a constant (qualified name without a leading "::"), replacing one of that name.
  void set_constant(std::string qualified_name, ConstValue value);
  // IDL modules by qualified name, so that a module and a type or constant cannot share a
  // name. A module opened again keeps the location of its first declaration.
  bool has_module(std::string_view qualified_name) const noexcept;
  void add_module(const std::string& qualified_name, const SourceLocation& where);

 private:
  // Reads a type file once (by canonical path) and hands its text to one of add_*_text.
  using AddText = bool (TypeRegistry::*)(std::string_view, const std::string&, Diagnostics&);
  bool add_file(const std::filesystem::path& file, Diagnostics& diagnostics, AddText add_text);

  std::deque<Type> storage_;
  std::vector<std::shared_ptr<const void>> retained_;
  std::map<std::string, const Type*, std::less<>> by_name_;
  std::vector<const Type*> declared_;
  std::map<std::string, ConstValue, std::less<>> constants_;
  std::vector<std::filesystem::path> loaded_files_;
  // Anonymous types ("sequence<double, 4>", "double[3]") by their IDL spelling, shared by
  // every use; kept apart from by_name_ so find() only sees declared and primitive names.
  std::map<std::string, const Type*, std::less<>> anonymous_;
  // Qualified module names, so a module cannot reuse a type's or constant's name.
  std::map<std::string, SourceLocation, std::less<>> modules_;
  std::map<std::string, UnusableType, std::less<>> unusable_;
};

// Renders a flat sample as JSON text (for traces and tools; not for the forwarding path).
// `size` bounds every access: a span pointing outside the sample renders as null.
std::string sample_to_json(const Type& type, const std::byte* sample, std::size_t size);

// The name of a kind as IDL spells it ("double", "unsigned long", "struct", ...).
std::string_view kind_name(TypeKind kind) noexcept;

}  // namespace polyport
