// One element of a profile file, as the loader hands it to a model that reads its own
// elements (see model_section.hpp): its text and attributes, its children checked against a
// table of rules, and reporting at its exact place, `file:line:col: element path: message`,
// the same way the loader reports its own elements. Set-up code only.
#pragma once

#include <filesystem>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "polyport/base/diagnostics.hpp"
#include "polyport/profile/profile_text.hpp"

namespace pugi {
struct xml_node_struct;
}

namespace polyport {

namespace detail {
class XmlFile;
}

// The children an element accepts: one rule per child, with its aliases, whether it may
// repeat, and the attributes it accepts. Unknown children and attributes warn (typos); a
// repeated single child is an error.
struct ElementRule {
  ElementRule(std::string_view what, std::vector<std::string_view> names, bool may_repeat = false,
              std::vector<std::string_view> attribute_names = {})
      : key(what), tags(std::move(names)), repeated(may_repeat), attributes(std::move(attribute_names)) {}

  std::string_view key;                      // what the reader calls it; empty: accepted, ignored
  std::vector<std::string_view> tags;        // the accepted element names (aliases)
  bool repeated = false;
  std::vector<std::string_view> attributes;  // accepted attributes (others warn)
};

class ProfileChildren;

class ProfileElement {
 public:
  ProfileElement() = default;
  ProfileElement(const detail::XmlFile& file, pugi::xml_node_struct* node) : file_(&file), node_(node) {}

  explicit operator bool() const noexcept { return node_ != nullptr; }
  std::string_view name() const;
  std::string text() const;  // trimmed
  bool has_attribute(std::string_view attribute) const;
  std::string attribute(std::string_view attribute) const;  // trimmed; empty when absent
  // The profile file, and its folder (where relative paths in it are resolved).
  std::filesystem::path file() const;
  std::filesystem::path folder() const;

  SourceLocation location() const;       // the element's '<'
  SourceLocation text_location() const;  // the first non-blank character of its text
  std::string path() const;              // `/component_profile/ports/data_port[2]/qos`
  SourceLocation attribute_location(std::string_view attribute) const;  // its value
  std::string attribute_path(std::string_view attribute) const;         // `.../@name`

  // Its children by `rules` (unknown elements and attributes warn, a repeated single child
  // is an error), keyed by the rules' keys.
  ProfileChildren children(const std::vector<ElementRule>& rules) const;

  void error(std::string message) const;       // at the element
  void warning(std::string message) const;
  void error_text(std::string message) const;  // at its text
  void warning_text(std::string message) const;
  void error_attribute(std::string_view attribute, std::string message) const;  // at the value

 private:
  const detail::XmlFile* file_ = nullptr;
  pugi::xml_node_struct* node_ = nullptr;
};

class ProfileChildren {
 public:
  ProfileElement one(std::string_view key) const {
    const auto it = by_key_.find(key);
    return it == by_key_.end() || it->second.empty() ? ProfileElement() : it->second.front();
  }
  const std::vector<ProfileElement>& all(std::string_view key) const {
    static const std::vector<ProfileElement> kNone;
    const auto it = by_key_.find(key);
    return it == by_key_.end() ? kNone : it->second;
  }
  bool empty() const noexcept { return by_key_.empty(); }
  void add(std::string_view key, ProfileElement element) { by_key_[key].push_back(element); }

 private:
  std::map<std::string_view, std::vector<ProfileElement>, std::less<>> by_key_;
};

// An enumerated element's text, looked up in `table`; a bad value is reported at the text
// with the accepted spellings ("bad reliability 'x' (accepted: reliable, best_effort)").
template <class Enum, std::size_t N>
std::optional<Enum> enum_text(const ProfileElement& element, const text::Spelling<Enum> (&table)[N],
                              std::string_view what) {
  const std::string value = element.text();
  const auto found = text::lookup(table, value);
  if (!found) {
    element.error_text("bad " + std::string(what) + " " + text::in_quotes(value) + " (accepted: " +
                       text::accepted(table) + ")");
  }
  return found;
}

}  // namespace polyport
