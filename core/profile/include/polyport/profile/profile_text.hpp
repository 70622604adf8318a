// Text as profiles write it: trimming, quoting, integers and decimals as XML Schema spells
// them, and enumerations given as tables of spellings (so a message can list what is
// accepted). For the loader and for every model that reads its own profile elements.
#pragma once

#include <charconv>
#include <cstddef>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

namespace polyport::text {

std::string_view trim(std::string_view text);
std::string in_quotes(std::string_view text);
std::string join(const std::vector<std::string>& items, std::string_view separator);

// Integers as XML Schema writes them: optional sign, decimal digits, nothing else.
template <class Int>
std::optional<Int> parse_integer(std::string_view text) {
  if (!text.empty() && text.front() == '+') text.remove_prefix(1);
  if (text.empty() || text.front() == '+') return std::nullopt;
  Int value{};
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (ec != std::errc{} || end != text.data() + text.size()) return std::nullopt;
  return value;
}

// Decimals as xs:decimal writes them (no exponent, no inf/nan), so the XSD and the loader
// accept the same spellings.
std::optional<double> parse_decimal(std::string_view text);
// Numbers in mapping rules: a decimal with an optional exponent ("2", "-0.5", "1e-3"), the
// grammar of the XSD's Number type; no inf/nan, nothing from_chars alone would also take.
std::optional<double> parse_number(std::string_view text);
// A list of numbers separated by blanks or commas ("1 0 0", "1, 0, 0"); the XSD's NumberList.
// Returns the entries, or the first entry that is not a number in `bad`.
std::optional<std::vector<double>> parse_numbers(std::string_view text, std::string& bad);
// The path made absolute and normal (canonical where it exists).
std::filesystem::path absolute_path(const std::filesystem::path& path);

// A token with the spellings that mean it, so the error message can list what is accepted.
template <class Enum>
struct Spelling {
  std::string_view text;
  Enum value;
};

template <class Enum, std::size_t N>
std::optional<Enum> lookup(const Spelling<Enum> (&table)[N], std::string_view text) {
  for (const auto& entry : table) {
    if (entry.text == text) return entry.value;
  }
  return std::nullopt;
}

template <class Enum, std::size_t N>
std::string accepted(const Spelling<Enum> (&table)[N]) {
  std::string out;
  for (const auto& entry : table) {
    if (!out.empty()) out += ", ";
    out += entry.text;
  }
  return out;
}

constexpr Spelling<bool> kBooleans[] = {
    {"true", true},
    {"false", false},
    {"1", true},
    {"0", false},
};

}  // namespace polyport::text
