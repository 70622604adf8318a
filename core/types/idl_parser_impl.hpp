// The IDL parser (parse_idl, polyport/types/idl_parser.hpp) as a class shared by the files
// that hold its parts: idl_parser.cpp (the driver, names, annotations, declarations),
// idl_type_spec.cpp (type specifiers and the anonymous types they make) and
// idl_const_expr.cpp (constant expressions). Private to the types layer.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "idl_lexer.hpp"
#include "polyport/base/diagnostics.hpp"
#include "polyport/types/types.hpp"

namespace polyport::idl_detail {

inline constexpr std::uint64_t kMaxTypeSize = std::numeric_limits<std::uint32_t>::max();
// Recursion limits, so hostile input ends in an error instead of a stack overflow.
inline constexpr std::size_t kMaxModuleDepth = 100;
inline constexpr int kMaxTypeDepth = 100;
inline constexpr int kMaxExpressionDepth = 200;

// Words that cannot name a module, type, member or constant (idl_parser.cpp).
extern const std::set<std::string, std::less<>> kReserved;

struct ScopedName {
  std::string spelled;  // as written, for messages
  std::string joined;   // without a leading `::`
  bool absolute = false;
};

class IdlParser {
 public:
  IdlParser(TypeRegistry& registry, std::string file_name)
      : registry_(registry), file_(std::move(file_name)) {}

  bool parse(std::string_view text, Diagnostics& diagnostics);

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

  // ---- idl_parser.cpp: recovery, names, annotations, definitions ------------------------

  void synchronize();

  // names
  std::string expect_name(std::string message);
  std::string qualify(const std::string& name) const;
  bool name_taken(std::string_view qualified) const;
  void check_new_name(const Token& at, const std::string& qualified);
  ScopedName parse_scoped_name();
  std::vector<std::string> candidates(const ScopedName& name) const;
  const Type* resolve_type(const ScopedName& name, const Token& at);
  ConstValue resolve_constant(const ScopedName& name, const Token& at);

  // annotations
  struct Annotation {
    std::string name;
    std::size_t at = 0;          // the token after the `@`, for messages
    std::size_t args_begin = 0;  // token range inside the parentheses
    std::size_t args_end = 0;
    bool has_args = false;
  };
  std::vector<Annotation> parse_annotations();
  std::string parse_annotation_name();
  void skip_annotation_declaration();

  // definitions
  bool starts_definition(const Token& token) const;
  void expect_definition_end(std::string message);
  void parse_definitions(bool in_module);
  void parse_definition();
  void parse_module();
  Extensibility extensibility_of(const std::vector<Annotation>& annotations);
  void parse_struct(const std::vector<Annotation>& annotations);
  bool parse_member(Type& type);
  static bool layout_struct(Type& type);
  void parse_enum();
  std::int64_t evaluate_annotation_integer(const Annotation& annotation);
  void parse_typedef();
  void parse_const();
  ConstValue convert_constant(ConstValue value, const Type& declared_type, const Token& at);

  // ---- idl_type_spec.cpp: types ---------------------------------------------------------

  const Type* builtin(std::string_view name) const;
  const Type* parse_type_spec();
  bool accept_word(std::string_view word);
  std::uint32_t parse_bound(const std::string& what, std::uint64_t max, bool in_template);
  const Type* parse_array_declarator(const Type* element);
  const Type* bounded_string(std::uint32_t bound);
  const Type* sequence(const Type* element, std::uint32_t bound, const Token& at);
  template <class Init>
  const Type* anonymous(const std::string& name, Init&& init);

  // ---- idl_const_expr.cpp: constant expressions -----------------------------------------

  ConstValue parse_expression(bool in_template);
  struct Operator {
    std::string_view text;
    int precedence;
  };
  std::optional<Operator> peek_operator() const;
  ConstValue parse_binary(int min_precedence);
  ConstValue parse_unary();
  ConstValue parse_primary();
  ConstValue apply(std::string_view op, const ConstValue& left, const ConstValue& right,
                   const Token& at);
  std::int64_t apply_integer(std::string_view op, std::int64_t a, std::int64_t b, const Token& at);

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

}  // namespace polyport::idl_detail
