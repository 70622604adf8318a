#include "polyport/profile/profile_text.hpp"

#include <cmath>

namespace polyport::text {

namespace fs = std::filesystem;

std::string_view trim(std::string_view text) {
  constexpr std::string_view kSpace = " \t\r\n";
  const auto first = text.find_first_not_of(kSpace);
  if (first == std::string_view::npos) return {};
  const auto last = text.find_last_not_of(kSpace);
  return text.substr(first, last - first + 1);
}

std::string in_quotes(std::string_view text) { return "'" + std::string(text) + "'"; }

std::string join(const std::vector<std::string>& items, std::string_view separator) {
  std::string out;
  for (const auto& item : items) {
    if (!out.empty()) out += separator;
    out += item;
  }
  return out;
}

// Decimals as xs:decimal writes them (no exponent, no inf/nan), so the XSD and the loader
// accept the same spellings.
std::optional<double> parse_decimal(std::string_view text) {
  std::string_view digits = text;
  if (!digits.empty() && (digits.front() == '+' || digits.front() == '-')) digits.remove_prefix(1);
  bool seen_digit = false;
  bool seen_point = false;
  for (const char c : digits) {
    if (c >= '0' && c <= '9') {
      seen_digit = true;
    } else if (c == '.' && !seen_point) {
      seen_point = true;
    } else {
      return std::nullopt;
    }
  }
  if (!seen_digit) return std::nullopt;
  if (!text.empty() && text.front() == '+') text.remove_prefix(1);
  double value = 0.0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (ec != std::errc{} || end != text.data() + text.size()) return std::nullopt;
  return value;
}

// Numbers in mapping rules: a decimal with an optional exponent ("2", "-0.5", "1e-3"), the
// grammar of the XSD's Number type; no inf/nan, nothing from_chars alone would also take.
std::optional<double> parse_number(std::string_view text) {
  std::size_t i = 0;
  const auto digits = [&] {
    const std::size_t start = i;
    while (i < text.size() && text[i] >= '0' && text[i] <= '9') ++i;
    return i - start;
  };
  if (i < text.size() && (text[i] == '+' || text[i] == '-')) ++i;
  std::size_t mantissa = digits();
  if (i < text.size() && text[i] == '.') {
    ++i;
    mantissa += digits();
  }
  if (mantissa == 0) return std::nullopt;
  if (i < text.size() && (text[i] == 'e' || text[i] == 'E')) {
    ++i;
    if (i < text.size() && (text[i] == '+' || text[i] == '-')) ++i;
    if (digits() == 0) return std::nullopt;
  }
  if (i != text.size()) return std::nullopt;
  if (text.front() == '+') text.remove_prefix(1);
  double value = 0.0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (ec != std::errc{} || end != text.data() + text.size() || !std::isfinite(value)) return std::nullopt;
  return value;
}

// A list of numbers separated by blanks or commas ("1 0 0", "1, 0, 0"); the XSD's NumberList.
// Returns the entries, or the first entry that is not a number in `bad`.
std::optional<std::vector<double>> parse_numbers(std::string_view text, std::string& bad) {
  std::vector<double> values;
  std::size_t i = 0;
  const auto is_blank = [&](std::size_t k) {
    return text[k] == ' ' || text[k] == '\t' || text[k] == '\r' || text[k] == '\n';
  };
  const auto skip_blanks = [&] {
    while (i < text.size() && is_blank(i)) ++i;
  };
  skip_blanks();
  while (true) {
    const std::size_t start = i;
    while (i < text.size() && !is_blank(i) && text[i] != ',') ++i;
    const std::string_view entry = text.substr(start, i - start);
    const auto value = parse_number(entry);
    if (!value) {
      bad = std::string(entry);
      return std::nullopt;
    }
    values.push_back(*value);
    skip_blanks();
    if (i >= text.size()) break;
    if (text[i] == ',') {
      ++i;
      skip_blanks();
    }
  }
  return values;
}

fs::path absolute_path(const fs::path& path) {
  std::error_code ec;
  fs::path canonical = fs::weakly_canonical(path, ec);
  if (ec) canonical = fs::absolute(path, ec).lexically_normal();
  return canonical;
}

}  // namespace polyport::text
