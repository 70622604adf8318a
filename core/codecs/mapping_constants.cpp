// Constants (mapping_compiler.hpp): a rule's value, as written in the profile, parsed for its
// target (a number in range, a boolean, a char, an enumerator by name, possibly qualified, or
// a string that fits) into the bytes a constant step copies. Runs at load time.
#include "mapping_compiler.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <string>
#include <string_view>
#include <system_error>
#include <type_traits>
#include <utility>
#include <vector>

namespace polyport::mapping {

// -- constants ---------------------------------------------------------------------------

void Compiler::map_constant(const MappingRule& rule, const Place& target) {
  const Type& t = *target.type;
  const std::string& text = rule.value;
  const std::string what = "target " + in_quotes(target.path) + " (" + in_quotes(t.name) + ")";
  std::vector<std::byte> bytes;
  const auto put = [&bytes](const auto& value) {
    const auto* first = reinterpret_cast<const std::byte*>(&value);
    bytes.assign(first, first + sizeof value);
  };
  const auto bad = [&](const std::string& why) {
    problem(&rule, "bad constant " + in_quotes(text) + " for " + what + (why.empty() ? "" : ": " + why));
  };
  if (const auto kind = number_kind(t.kind)) {
    const bool ok = with_number(*kind, [&](auto type_tag) {
      using T = typename decltype(type_tag)::type;
      if constexpr (std::is_integral_v<T>) {
        std::int64_t signed_value = 0;
        std::uint64_t unsigned_value = 0;
        const char* first = text.data();
        const char* last = first + text.size();
        if (first != last && *first == '+' && last - first > 1 && first[1] != '-') ++first;
        const bool negative = first != last && *first == '-';
        const auto [end, ec] = negative ? std::from_chars(first, last, signed_value)
                                        : std::from_chars(first, last, unsigned_value);
        if (first == last || end != last || ec == std::errc::invalid_argument) {
          bad("expected an integer");
          return false;
        }
        const bool fits = ec == std::errc{} &&
                          (negative ? std::in_range<T>(signed_value) : std::in_range<T>(unsigned_value));
        if (!fits) {
          problem(&rule, "constant " + in_quotes(text) + " is out of range for " + what);
          return false;
        }
        put(negative ? static_cast<T>(signed_value) : static_cast<T>(unsigned_value));
        return true;
      } else {
        double value = 0.0;
        const char* first = text.data();
        const char* last = first + text.size();
        if (first != last && *first == '+') ++first;
        const auto [end, ec] = std::from_chars(first, last, value);
        if (first == last || end != last || ec != std::errc{} || !std::isfinite(value)) {
          bad("expected a finite number");
          return false;
        }
        if (std::abs(value) > static_cast<double>(std::numeric_limits<T>::max())) {
          problem(&rule, "constant " + in_quotes(text) + " is out of range for " + what);
          return false;
        }
        put(static_cast<T>(value));
        return true;
      }
    });
    if (!ok) return;
  } else if (t.kind == TypeKind::boolean) {
    if (text != "true" && text != "false" && text != "1" && text != "0") {
      bad("expected true, false, 1 or 0");
      return;
    }
    put(static_cast<std::uint8_t>(text == "true" || text == "1"));
  } else if (t.kind == TypeKind::char8) {
    if (text.size() != 1) {
      bad("expected one character");
      return;
    }
    put(text[0]);
  } else if (t.kind == TypeKind::enumeration) {
    // "NAME", or qualified as the IDL would ("Color::NAME", "::m::Color::NAME").
    std::string_view name = text;
    if (const auto colon = name.rfind("::"); colon != std::string_view::npos) {
      const std::string_view scope = name.substr(0, colon);
      std::string_view type_name = t.name;
      std::string_view scope_tail = scope.starts_with("::") ? scope.substr(2) : scope;
      if (!(type_name == scope_tail || type_name.ends_with("::" + std::string(scope_tail)))) name = {};
      else name = name.substr(colon + 2);
    }
    const auto match = std::find_if(t.enumerators.begin(), t.enumerators.end(),
                                    [&](const Enumerator& e) { return e.name == name; });
    if (match == t.enumerators.end()) {
      std::vector<std::string> names;
      for (const Enumerator& e : t.enumerators) names.push_back(e.name);
      problem(&rule, in_quotes(text) + " is not an enumerator of " + in_quotes(t.name) + " (enumerators: " +
                         join(names, ", ") + ")");
      return;
    }
    put(match->value);
  } else if (t.kind == TypeKind::string) {
    const std::size_t before = program_->constants_.size();
    const auto* chars = reinterpret_cast<const std::byte*>(text.data());
    Step step;
    step.dst = target.offset;
    step.pool = static_cast<std::uint32_t>(before);
    if (t.bound == 0) {
      program_->constants_.insert(program_->constants_.end(), chars, chars + text.size());
      step.op = Op::tail_constant;
      step.pool_count = static_cast<std::uint32_t>(text.size());
      emit(step, "constant " + in_quotes(text) + " into the target's tail (" + target.path + ")");
      return;
    }
    if (text.size() > t.bound) {
      problem(&rule, "constant of " + std::to_string(text.size()) + " characters does not fit " + what);
      return;
    }
    bytes.assign(chars, chars + text.size());
    bytes.resize(t.size, std::byte{0});  // NUL and the unused rest
  } else {
    problem(&rule, "a constant needs a number, boolean, char, enum or string target; " + in_quotes(target.path) +
                       " is " + in_quotes(t.name));
    return;
  }
  Step step;
  step.op = Op::constant;
  step.dst = target.offset;
  step.size = static_cast<std::uint32_t>(bytes.size());
  step.pool = static_cast<std::uint32_t>(program_->constants_.size());
  program_->constants_.insert(program_->constants_.end(), bytes.begin(), bytes.end());
  emit(step, "constant " + in_quotes(text) + " -> @" + std::to_string(step.dst) + " (" + target.path + ")");
}

}  // namespace polyport::mapping
