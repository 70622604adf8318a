// IDL constant expressions, for the IDL parser (IdlParser, idl_parser_impl.hpp): literals,
// constant names, unary and binary operators with IDL's precedence, evaluated as they are read.
// Integer arithmetic is exact (overflow is an error); a floating operand makes the
// operation floating. Inside `<...>` a `>` ends the expression, so shifts need
// parentheses there.
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <variant>

#include "idl_parser_impl.hpp"
#include "polyport/types/types.hpp"

namespace polyport::idl_detail {

ConstValue IdlParser::parse_expression(bool in_template) {
  const FlagGuard guard(in_template_, in_template);
  return parse_binary(0);
}

// The binary operator at the current token, if any, with its precedence.
std::optional<IdlParser::Operator> IdlParser::peek_operator() const {
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

ConstValue IdlParser::parse_binary(int min_precedence) {
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

ConstValue IdlParser::parse_unary() {
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

ConstValue IdlParser::parse_primary() {
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

ConstValue IdlParser::apply(std::string_view op, const ConstValue& left, const ConstValue& right,
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

std::int64_t IdlParser::apply_integer(std::string_view op, std::int64_t a, std::int64_t b,
                                      const Token& at) {
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

}  // namespace polyport::idl_detail
