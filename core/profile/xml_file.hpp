// A profile file as the loader reads it: its bytes, the pugixml tree, line starts for
// `line:col`, element paths as libxml2 writes them, reporting bound to the file, and the
// child scanning every element goes through. Private to core/profile.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <optional>
#include <sstream>
#include <string>
#include <string_view>
#include <vector>

#include <pugixml.hpp>

#include "polyport/base/diagnostics.hpp"
#include "polyport/profile/profile_element.hpp"
#include "polyport/profile/profile_text.hpp"

namespace polyport::detail {

namespace fs = std::filesystem;
using text::in_quotes;

// An element as text, attributes and children, without the whitespace between elements: what
// a reload compares to tell whether a profile changed it.
inline std::string element_text(pugi::xml_node node) {
  std::ostringstream out;
  node.print(out, "", pugi::format_raw);
  return std::move(out).str();
}

// A file's bytes; empty when it cannot be read (the loader reports that on its own).
inline std::string file_text(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  std::ostringstream bytes;
  if (in) bytes << in.rdbuf();
  return std::move(bytes).str();
}

// ---------------------------------------------------------------------------------------
// One XML file: its bytes, the pugixml tree and a table of line starts, so every node and
// attribute can be reported as line:col in the file the user edits.

class XmlFile {
 public:
  // Reads and parses `file`. `what` names the file in messages ("component profile");
  // `referenced_at` is where a missing file is reported (the referencing element).
  bool load(const fs::path& file, std::string_view what, const SourceLocation& referenced_at,
            const std::string& referenced_path, Diagnostics& diagnostics) {
    file_ = file.string();
    diagnostics_ = &diagnostics;
    std::error_code ec;
    if (!fs::exists(file, ec)) {
      diagnostics.error(referenced_at, referenced_path,
                        std::string(what) + " " + in_quotes(file_) + " not found");
      return false;
    }
    std::ifstream in(file, std::ios::binary);
    std::ostringstream bytes;
    if (in) bytes << in.rdbuf();
    if (!in || fs::is_directory(file, ec)) {
      diagnostics.error(referenced_at, referenced_path,
                        "cannot read " + std::string(what) + " " + in_quotes(file_));
      return false;
    }
    return parse(file_, std::move(bytes).str(), diagnostics);
  }

  // Parses `text` as the contents of a document named `name` (a profile fragment made in
  // memory, e.g. a connection asked for at run time).
  bool parse(std::string name, std::string text, Diagnostics& diagnostics) {
    file_ = std::move(name);
    diagnostics_ = &diagnostics;
    text_ = std::move(text);
    line_starts_.assign(1, 0);
    for (std::size_t i = 0; i < text_.size(); ++i) {
      if (text_[i] == '\n') line_starts_.push_back(i + 1);
    }
    // UTF-8 only: pugixml reports offsets into the buffer it parsed, and a converted
    // (UTF-16) buffer would make every reported column wrong.
    const pugi::xml_parse_result result =
        doc_.load_buffer(text_.data(), text_.size(), pugi::parse_default, pugi::encoding_utf8);
    if (!result) {
      diagnostics.error(at_offset(result.offset), "",
                        std::string("XML syntax error: ") + result.description());
      return false;
    }
    return comments_well_formed();
  }

  pugi::xml_node root() const { return doc_.document_element(); }

 private:
  // XML forbids "--" inside a comment (and a comment ending in "-"); pugixml accepts both,
  // xmllint and every other parser refuse the file. Such a profile is refused here too, so
  // `polyportd check` never passes a file the schema check or another tool rejects. A second,
  // comment-keeping parse, only when the text has a comment.
  bool comments_well_formed() {
    if (text_.find("<!--") == std::string::npos) return true;
    pugi::xml_document with_comments;
    if (!with_comments.load_buffer(text_.data(), text_.size(), pugi::parse_default | pugi::parse_comments,
                                   pugi::encoding_utf8)) {
      return true;  // parsed once already; nothing more to say
    }
    bool ok = true;
    struct Walker : pugi::xml_tree_walker {
      std::function<void(pugi::xml_node)> visit;
      bool for_each(pugi::xml_node& node) override {
        if (node.type() == pugi::node_comment) visit(node);
        return true;
      }
    } walker;
    walker.visit = [&](pugi::xml_node comment) {
      // Searched in the file's own bytes from where the comment's text starts: the parse
      // squeezed each CRLF in the value to LF, so offsets in the value are not the file's.
      const auto start = static_cast<std::size_t>(comment.offset_debug());
      const std::size_t dashes = text_.find("--", start);
      if (dashes == std::string::npos) return;
      std::size_t at = dashes;  // "--" inside the comment
      if (dashes + 2 < text_.size() && text_[dashes + 2] == '>') {
        if (dashes == start || text_[dashes - 1] != '-') return;  // its own "-->": fine
        at = dashes - 1;  // "--->": a '-' right before the end
      }
      diagnostics_->error(at_offset(static_cast<std::ptrdiff_t>(at)), "",
                          "XML syntax error: '--' is not allowed inside a comment (nor a '-' right before its '-->')");
      ok = false;
    };
    with_comments.traverse(walker);
    return ok;
  }

 public:
  const std::string& name() const { return file_; }
  Diagnostics& diagnostics() const { return *diagnostics_; }

  SourceLocation at_offset(std::ptrdiff_t offset) const {
    SourceLocation where{file_, 0, 0};
    if (offset < 0 || line_starts_.empty()) return where;
    const auto position = std::min(static_cast<std::size_t>(offset), text_.size());
    const auto next = std::upper_bound(line_starts_.begin(), line_starts_.end(), position);
    const auto line_index = static_cast<std::size_t>(next - line_starts_.begin()) - 1;
    std::size_t start = line_starts_[line_index];
    if (line_index == 0 && text_.compare(0, 3, "\xEF\xBB\xBF") == 0 && position >= 3) start = 3;
    // Columns count characters, not bytes: skip UTF-8 continuation bytes.
    std::uint32_t column = 1;
    for (std::size_t i = start; i < position; ++i) {
      if ((static_cast<unsigned char>(text_[i]) & 0xC0) != 0x80) ++column;
    }
    where.line = static_cast<std::uint32_t>(line_index + 1);
    where.column = column;
    return where;
  }

  // The element's `<`.
  SourceLocation at(pugi::xml_node element) const {
    const std::ptrdiff_t offset = element.offset_debug();
    return at_offset(offset > 0 ? offset - 1 : offset);
  }

  // The first non-blank character of the element's text, or the element when it has none.
  SourceLocation at_text(pugi::xml_node element) const {
    for (pugi::xml_node child = element.first_child(); child; child = child.next_sibling()) {
      if (child.type() != pugi::node_pcdata && child.type() != pugi::node_cdata) continue;
      auto offset = static_cast<std::size_t>(child.offset_debug());
      while (offset < text_.size() && (text_[offset] == ' ' || text_[offset] == '\t' ||
                                       text_[offset] == '\r' || text_[offset] == '\n')) {
        ++offset;
      }
      return at_offset(static_cast<std::ptrdiff_t>(offset));
    }
    return at(element);
  }

  // The first character of the attribute's value, or of its name when `at_name` (pugixml
  // keeps no offsets for attributes, so the start tag is scanned again from the element's name).
  SourceLocation at_attribute(pugi::xml_node element, std::string_view attribute,
                              bool at_name = false) const {
    std::ptrdiff_t offset = element.offset_debug();
    if (offset < 0) return at(element);
    auto i = static_cast<std::size_t>(offset);
    const auto is_space = [this](std::size_t k) {
      return text_[k] == ' ' || text_[k] == '\t' || text_[k] == '\r' || text_[k] == '\n';
    };
    const auto is_name_end = [this, &is_space](std::size_t k) {
      return is_space(k) || text_[k] == '=' || text_[k] == '>' || text_[k] == '/';
    };
    while (i < text_.size() && !is_name_end(i)) ++i;  // the element's name
    while (i < text_.size()) {
      while (i < text_.size() && is_space(i)) ++i;
      if (i >= text_.size() || text_[i] == '>' || text_[i] == '/') break;
      const std::size_t name_start = i;
      while (i < text_.size() && !is_name_end(i)) ++i;
      const std::string_view name(text_.data() + name_start, i - name_start);
      while (i < text_.size() && is_space(i)) ++i;
      if (i >= text_.size() || text_[i] != '=') break;
      ++i;
      while (i < text_.size() && is_space(i)) ++i;
      if (i >= text_.size() || (text_[i] != '"' && text_[i] != '\'')) break;
      const char quote = text_[i++];
      const std::size_t value_start = i;
      while (i < text_.size() && text_[i] != quote) ++i;
      if (name == attribute) {
        return at_offset(static_cast<std::ptrdiff_t>(at_name ? name_start : value_start));
      }
      ++i;
    }
    return at(element);
  }

 private:
  std::string file_;
  std::string text_;
  std::vector<std::size_t> line_starts_;
  pugi::xml_document doc_;
  Diagnostics* diagnostics_ = nullptr;
};


std::string element_path(pugi::xml_node element);
std::string attribute_path(pugi::xml_node element, std::string_view attribute);

// Reporting helpers bound to one file.
class Reporter {
 public:
  explicit Reporter(const XmlFile& xml) : xml_(xml) {}

  const XmlFile& xml() const { return xml_; }

  void error(pugi::xml_node element, std::string message) const {
    xml_.diagnostics().error(xml_.at(element), element_path(element), std::move(message));
  }
  void warning(pugi::xml_node element, std::string message) const {
    xml_.diagnostics().warning(xml_.at(element), element_path(element), std::move(message));
  }
  void error_text(pugi::xml_node element, std::string message) const {
    xml_.diagnostics().error(xml_.at_text(element), element_path(element), std::move(message));
  }
  void warning_text(pugi::xml_node element, std::string message) const {
    xml_.diagnostics().warning(xml_.at_text(element), element_path(element), std::move(message));
  }
  void error_attribute(pugi::xml_node element, std::string_view attribute,
                       std::string message) const {
    xml_.diagnostics().error(xml_.at_attribute(element, attribute),
                             attribute_path(element, attribute), std::move(message));
  }
  // Points at the attribute's name: for attributes that should not be there at all.
  void warning_attribute(pugi::xml_node element, std::string_view attribute,
                         std::string message) const {
    xml_.diagnostics().warning(xml_.at_attribute(element, attribute, true),
                               attribute_path(element, attribute), std::move(message));
  }

 private:
  const XmlFile& xml_;
};


using ChildRule = ElementRule;

class Children {
 public:
  pugi::xml_node one(std::string_view key) const {
    const auto it = by_key_.find(key);
    return it == by_key_.end() || it->second.empty() ? pugi::xml_node() : it->second.front();
  }
  const std::vector<pugi::xml_node>& all(std::string_view key) const {
    static const std::vector<pugi::xml_node> kNone;
    const auto it = by_key_.find(key);
    return it == by_key_.end() ? kNone : it->second;
  }
  void add(std::string_view key, pugi::xml_node node) { by_key_[key].push_back(node); }

 private:
  std::map<std::string_view, std::vector<pugi::xml_node>, std::less<>> by_key_;
};


void check_attributes(const Reporter& report, pugi::xml_node element,
                      const std::vector<std::string_view>& accepted_names, bool is_root);
Children scan(const Reporter& report, pugi::xml_node parent, const std::vector<ChildRule>& rules);
std::string text_of(pugi::xml_node element);
// The text of a child the profile must have; reports it missing or empty.
std::optional<std::string> required_text(const Reporter& report, pugi::xml_node parent,
                                         const Children& children, std::string_view key,
                                         std::string_view tag);
std::optional<std::string> optional_text(const Children& children, std::string_view key);

template <class Enum, std::size_t N>
std::optional<Enum> enum_text(const Reporter& report, pugi::xml_node element,
                              const text::Spelling<Enum> (&table)[N], std::string_view what,
                              std::string_view context = {}) {
  const std::string written = text_of(element);
  const auto value = text::lookup(table, written);
  if (!value) {
    report.error_text(element, "bad " + std::string(what) + " " + in_quotes(written) +
                                   std::string(context) + " (accepted: " + text::accepted(table) + ")");
  }
  return value;
}

}  // namespace polyport::detail
