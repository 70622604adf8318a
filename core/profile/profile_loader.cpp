// Loads OPRoS-shaped application and component profiles (see docs/PROFILES.md and
// config/polyport.xsd). The loader never stops at the first problem: it reads as much as it
// can and reports every problem as `file:line:col: element path: message`, so a user fixes a
// profile in one round. Set-up code only; nothing here runs on the forwarding path.
//
// A <mapping> inside a <port_connection> is read here and compiled by MappingProgram (see
// mapping.hpp) once the types are known; connections whose ends have different types get a
// by-name mapping even without one.
//
// Element paths follow libxml2's xmlGetNodePath: an element gets a 1-based `[n]` only when its
// parent has more than one child element of that name (`/.../port_connection[2]/source`,
// but `/.../ports/data_port` when there is one). Attributes are addressed as `/@name`.

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <sstream>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <pugixml.hpp>

#include "polyport/base/diagnostics.hpp"
#include "polyport/profile/profile.hpp"
#include "polyport/types/types.hpp"

namespace polyport {

namespace fs = std::filesystem;

namespace {

// A buffer or circular queue without an explicit size gets this many samples: enough to ride
// out a few missed periods of a 10 ms reader without hiding a reader that has stopped.
constexpr std::uint32_t kDefaultDepth = 16;
// CPU_SETSIZE on Linux; a profile may be checked on another machine than the one it runs on,
// so the real CPU count is checked when the execution context pins its thread, not here.
constexpr int kMaxCpu = 1023;
constexpr int kMinRtPriority = 1;
constexpr int kMaxRtPriority = 99;

// ---------------------------------------------------------------------------------------
// Small text helpers

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

// Case-sensitive on purpose: the XSD's enumerations are, and both must accept the same files.
constexpr Spelling<QueuePolicy> kQueuePolicies[] = {
    {"data", QueuePolicy::data},           {"LAST", QueuePolicy::data},
    {"OPROS_LAST", QueuePolicy::data},     {"buffer", QueuePolicy::buffer},
    {"circular", QueuePolicy::circular},   {"FIFO", QueuePolicy::circular},
    {"OPROS_FIFO", QueuePolicy::circular},
};
constexpr Spelling<ExecutionType> kExecutionTypes[] = {
    {"periodic", ExecutionType::periodic},
    {"periodic-shared", ExecutionType::periodic},
    {"periodic-exclusive", ExecutionType::periodic_exclusive},
    {"aperiodic", ExecutionType::aperiodic},
    {"non-periodic", ExecutionType::aperiodic},
    {"passive", ExecutionType::passive},
};
constexpr Spelling<SchedPolicy> kSchedPolicies[] = {
    {"SCHED_OTHER", SchedPolicy::other}, {"SCHED_FIFO", SchedPolicy::fifo},
    {"SCHED_RR", SchedPolicy::rr},       {"OTHER", SchedPolicy::other},
    {"FIFO", SchedPolicy::fifo},         {"RR", SchedPolicy::rr},
};
constexpr Spelling<InitialState> kLifecycleTypes[] = {
    {"start", InitialState::active},      {"stop", InitialState::inactive},
    {"active", InitialState::active},     {"running", InitialState::active},
    {"ACTIVE", InitialState::active},     {"inactive", InitialState::inactive},
    {"stopped", InitialState::inactive},  {"READY", InitialState::inactive},
    {"INACTIVE", InitialState::inactive},
};
constexpr Spelling<PortKind> kPortTypes[] = {
    {"data", PortKind::data},
    {"service", PortKind::service},
    {"event", PortKind::event},
    {"method", PortKind::service},  // OPRoS's name for service connections
};
constexpr Spelling<PortDirection> kDataUsages[] = {
    {"input", PortDirection::input},
    {"output", PortDirection::output},
};
constexpr Spelling<PortDirection> kServiceUsages[] = {
    {"required", PortDirection::required},
    {"provided", PortDirection::provided},
};
constexpr Spelling<bool> kBooleans[] = {
    {"true", true},
    {"false", false},
    {"1", true},
    {"0", false},
};

std::string_view sched_policy_name(SchedPolicy policy) {
  switch (policy) {
    case SchedPolicy::fifo: return "SCHED_FIFO";
    case SchedPolicy::rr: return "SCHED_RR";
    case SchedPolicy::other: break;
  }
  return "SCHED_OTHER";
}

bool is_periodic(ExecutionType type) {
  return type == ExecutionType::periodic || type == ExecutionType::periodic_exclusive;
}

std::string port_noun(const PortSpec& port) {
  return std::string(port.kind == PortKind::event ? "an " : "a ") +
         std::string(to_string(port.kind)) + " port";
}

std::string direction_noun(PortDirection direction) {
  const bool vowel = direction == PortDirection::input || direction == PortDirection::output;
  return std::string(vowel ? "an " : "a ") + std::string(to_string(direction)) + " port";
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
    text_ = std::move(bytes).str();
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
    return true;
  }

  pugi::xml_node root() const { return doc_.document_element(); }
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

std::string element_path(pugi::xml_node element) {
  std::vector<std::string> parts;
  for (pugi::xml_node node = element; node && node.type() == pugi::node_element;
       node = node.parent()) {
    std::string part = node.name();
    const pugi::xml_node parent = node.parent();
    int count = 0;
    int index = 0;
    for (pugi::xml_node sibling = parent.child(node.name()); sibling;
         sibling = sibling.next_sibling(node.name())) {
      ++count;
      if (sibling == node) index = count;
    }
    if (count > 1) part += "[" + std::to_string(index) + "]";
    parts.push_back(std::move(part));
  }
  std::string path;
  for (auto it = parts.rbegin(); it != parts.rend(); ++it) path += "/" + *it;
  return path;
}

std::string attribute_path(pugi::xml_node element, std::string_view attribute) {
  return element_path(element) + "/@" + std::string(attribute);
}

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

// ---------------------------------------------------------------------------------------
// Child scanning: each element's accepted children (with their aliases) are one table, so
// unknown elements (typos) warn and repeated single elements are errors in one place.

struct ChildRule {
  ChildRule(std::string_view what, std::vector<std::string_view> names, bool may_repeat = false,
            std::vector<std::string_view> attribute_names = {})
      : key(what),
        tags(std::move(names)),
        repeated(may_repeat),
        attributes(std::move(attribute_names)) {}

  std::string_view key;                // what the loader calls it; empty: ignored
  std::vector<std::string_view> tags;  // the accepted element names (aliases)
  bool repeated = false;
  std::vector<std::string_view> attributes;  // accepted attributes (others warn)
};

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
                      const std::vector<std::string_view>& accepted_names, bool is_root) {
  for (pugi::xml_attribute attribute : element.attributes()) {
    const std::string_view name = attribute.name();
    // Editors attach the schema with xmlns / xsi attributes on the root; they are not ours.
    if (is_root && (name == "xmlns" || name.starts_with("xmlns:") || name.starts_with("xsi:"))) {
      continue;
    }
    if (std::find(accepted_names.begin(), accepted_names.end(), name) != accepted_names.end()) {
      continue;
    }
    report.warning_attribute(element, name, "unknown attribute '" + std::string(name) + "'");
  }
}

Children scan(const Reporter& report, pugi::xml_node parent, const std::vector<ChildRule>& rules) {
  Children children;
  for (pugi::xml_node child : parent.children()) {
    if (child.type() != pugi::node_element) continue;
    const std::string_view tag = child.name();
    const ChildRule* match = nullptr;
    for (const auto& rule : rules) {
      if (std::find(rule.tags.begin(), rule.tags.end(), tag) != rule.tags.end()) {
        match = &rule;
        break;
      }
    }
    if (match == nullptr) {
      report.warning(child, "unknown element <" + std::string(tag) + ">");
      continue;
    }
    if (match->key.empty()) continue;  // accepted for OPRoS compatibility, not used
    if (!match->repeated) {
      const pugi::xml_node first = children.one(match->key);
      if (first) {
        const auto line = std::to_string(report.xml().at(first).line);
        if (std::string_view(first.name()) == tag) {
          report.error(child,
                       "duplicate <" + std::string(tag) + ">: already given at line " + line);
        } else {
          report.error(child, "duplicate <" + std::string(tag) + ">: already given as <" +
                                  first.name() + "> at line " + line);
        }
        continue;
      }
    }
    check_attributes(report, child, match->attributes, false);
    children.add(match->key, child);
  }
  return children;
}

std::string text_of(pugi::xml_node element) { return std::string(trim(element.text().get())); }

// The text of a child the profile must have; reports it missing or empty.
std::optional<std::string> required_text(const Reporter& report, pugi::xml_node parent,
                                         const Children& children, std::string_view key,
                                         std::string_view tag) {
  const pugi::xml_node element = children.one(key);
  if (!element) {
    report.error(parent, "missing <" + std::string(tag) + ">");
    return std::nullopt;
  }
  std::string text = text_of(element);
  if (text.empty()) {
    report.error(element, "empty <" + std::string(element.name()) + ">");
    return std::nullopt;
  }
  return text;
}

std::optional<std::string> optional_text(const Children& children, std::string_view key) {
  const pugi::xml_node element = children.one(key);
  if (!element) return std::nullopt;
  return text_of(element);
}

// Reads an enumerated element's text; `what` names it in the message, `context` follows
// the bad value (" for a data port").
template <class Enum, std::size_t N>
std::optional<Enum> enum_text(const Reporter& report, pugi::xml_node element,
                              const Spelling<Enum> (&table)[N], std::string_view what,
                              std::string_view context = {}) {
  const std::string text = text_of(element);
  const auto value = lookup(table, text);
  if (!value) {
    report.error_text(element, "bad " + std::string(what) + " " + in_quotes(text) +
                                   std::string(context) + " (accepted: " + accepted(table) + ")");
  }
  return value;
}

std::optional<std::uint32_t> depth_value(std::string_view text) {
  const auto value = parse_integer<std::uint32_t>(text);
  if (!value || *value == 0) return std::nullopt;
  return value;
}

const std::string kDepthExpected = "expected an integer from 1 to 4294967295";

// ---------------------------------------------------------------------------------------
// Child tables, one per element kind.

const std::vector<ChildRule> kApplicationRules = {
    {"name", {"name"}},
    {"description", {"description"}},
    {"", {"id", "copyright"}},
    {"types", {"types"}},
    {"subcomponents", {"subcomponents"}},
    {"port_connections", {"port_connections"}},
};
const std::vector<ChildRule> kTypesRules = {{"file", {"file"}, true}};
const std::vector<ChildRule> kSubcomponentsRules = {{"subcomponent", {"subcomponent"}, true}};
const std::vector<ChildRule> kSubcomponentRules = {
    {"name", {"name"}},
    {"reference", {"reference"}},
    {"", {"id", "type", "node_id"}},
};
const std::vector<ChildRule> kConnectionsRules = {
    {"port_connection", {"port_connection"}, true, {"port_type", "policy", "depth"}},
};
const std::vector<ChildRule> kConnectionRules = {
    {"source", {"source"}, false, {"component_name", "port_name"}},
    {"target", {"target"}, false, {"component_name", "port_name"}},
    {"mapping", {"mapping"}, false, {"by_name"}},
};
const std::vector<ChildRule> kMappingRules = {
    {"field",
     {"field"},
     true,
     {"target", "source", "value", "scale", "offset", "from_unit", "to_unit", "allow_narrowing", "truncate",
      "transform", "matrix", "translation"}},
};
constexpr Spelling<MappingRule::Kind> kTransforms[] = {
    {"linear", MappingRule::Kind::linear},
    {"affine", MappingRule::Kind::affine},
};
// A matrix has at most this many rows and columns: vector fields have 1 to 6 elements.
constexpr std::size_t kMaxMatrixSide = 6;
const std::vector<ChildRule> kComponentRules = {
    {"name", {"name"}},
    {"description", {"description"}},
    {"", {"id", "copyright"}},
    {"model", {"model"}},
    {"execution_environment", {"execution_environment"}},
    {"execution_semantics", {"execution_semantics"}},
    {"dds", {"dds"}},
    {"types", {"types"}},
    {"properties", {"properties"}},
    {"ports", {"ports"}},
};
const std::vector<ChildRule> kDdsRules = {
    {"domain", {"domain"}},
    {"config", {"config"}},
    {"qos", {"qos"}},
    {"max_calls_in_flight", {"max_calls_in_flight"}},
    {"call_timeout", {"call_timeout_ms"}},
};
const std::vector<ChildRule> kQosRules = {
    {"reliability", {"reliability"}},
    {"durability", {"durability"}},
    {"history", {"history"}},
    {"depth", {"depth"}},
    {"deadline", {"deadline_ms"}},
    {"lifespan", {"lifespan_ms"}},
    {"liveliness", {"liveliness"}},
    {"lease", {"lease_ms"}},
    {"partition", {"partition"}, true},
};
constexpr Spelling<DdsQos::Reliability> kReliabilities[] = {
    {"reliable", DdsQos::Reliability::reliable},
    {"best_effort", DdsQos::Reliability::best_effort},
};
constexpr Spelling<DdsQos::Durability> kDurabilities[] = {
    {"volatile", DdsQos::Durability::volatile_},
    {"transient_local", DdsQos::Durability::transient_local},
};
constexpr Spelling<DdsQos::History> kHistories[] = {
    {"keep_last", DdsQos::History::keep_last},
    {"keep_all", DdsQos::History::keep_all},
};
constexpr Spelling<DdsQos::Liveliness> kLivelinesses[] = {
    {"automatic", DdsQos::Liveliness::automatic},
    {"manual_by_participant", DdsQos::Liveliness::manual_by_participant},
    {"manual_by_topic", DdsQos::Liveliness::manual_by_topic},
};
// Calls in flight per DDS service port: enough for any sane client, bounded for the tables.
constexpr std::uint32_t kMaxDdsCallsInFlight = 4096;
// DDS domain ids: 0..232 (the RTPS port mapping with its default parameters).
constexpr std::uint32_t kMaxDdsDomain = 232;
bool is_dds_model(std::string_view model) { return model == "cyclonedds" || model == "fastdds"; }
const std::vector<ChildRule> kEnvironmentRules = {
    {"library_type", {"library_type"}},
    {"library_name", {"library_name"}},
    {"class_name", {"class_name"}},
    {"", {"os", "cpu", "impl_language", "compiler"}},
};
const std::vector<ChildRule> kSemanticsRules = {
    {"type", {"type"}},
    {"period", {"period"}},
    {"priority", {"priority"}},
    {"policy", {"policy"}},
    {"cpu", {"cpu_affinity", "cpu"}},
    {"lifecycle_type", {"lifecycle_type"}},
    {"", {"creation_type", "instance_creation"}},
};
const std::vector<ChildRule> kPropertiesRules = {
    {"property", {"property"}, true, {"name", "type"}},
};
const std::vector<ChildRule> kPortsRules = {
    {"port", {"data_port", "event_port", "service_port"}, true},
};
const std::vector<ChildRule> kDataPortRules = {
    {"name", {"name"}},
    {"", {"description"}},
    {"data_type", {"data_type"}},
    {"usage", {"usage"}},
    {"policy", {"queueing_policy", "policy"}},
    {"depth", {"queue_size", "queueing_size"}},
    {"policy_param", {"policy_param"}, true, {"name"}},
    {"topic", {"topic"}},
    {"qos", {"qos"}},
};
const std::vector<ChildRule> kServicePortRules = {
    {"name", {"name"}},
    {"", {"description", "reference"}},
    {"type", {"type"}},
    {"usage", {"usage"}},
    {"topic", {"topic"}},
    {"qos", {"qos"}},
    {"operation", {"operation"}, true, {"name", "request", "reply", "oneway", "dds_request", "dds_reply"}},
};

// ---------------------------------------------------------------------------------------
// The loader

// A name that must resolve in the type registry once every type file is loaded.
struct TypeUse {
  std::string name;
  SourceLocation where;
  std::string path;
};

struct LoadedComponent {
  bool readable = false;  // the file was parsed and had the right root
  ComponentProfile profile;
  std::vector<TypeUse> type_uses;
  std::set<std::string, std::less<>> incomplete_ports;  // kind/direction unknown: not checked
};

class Loader {
 public:
  Loader(TypeRegistry& types, const LoadOptions& options, Diagnostics& diagnostics)
      : types_(types), options_(options), diagnostics_(diagnostics) {}

  std::optional<ApplicationProfile> run(const fs::path& requested) {
    const std::size_t errors_before = diagnostics_.error_count();
    const fs::path file = absolute_path(requested);
    XmlFile xml;
    if (!xml.load(file, "application profile", SourceLocation{file.string(), 0, 0}, "",
                  diagnostics_)) {
      return std::nullopt;
    }
    const Reporter report(xml);
    const pugi::xml_node root = xml.root();
    if (std::string_view(root.name()) != "application_profile") {
      report.error(root, "expected root element <application_profile>, found <" +
                             std::string(root.name()) + ">");
      return std::nullopt;
    }
    check_attributes(report, root, {}, true);

    ApplicationProfile app;
    app.file = file;
    const Children children = scan(report, root, kApplicationRules);
    if (auto name = required_text(report, root, children, "name", "name")) app.name = *name;
    if (auto description = optional_text(children, "description")) app.description = *description;
    if (const auto types = children.one("types")) read_type_files(report, types, app.type_files);
    if (const auto subcomponents = children.one("subcomponents")) {
      read_subcomponents(report, subcomponents, app);
    }
    std::vector<pugi::xml_node> connection_nodes;
    if (const auto connections = children.one("port_connections")) {
      read_connections(report, connections, app, connection_nodes);
    }

    load_type_files();
    for (const LoadedComponent* component : load_order_) check_types(*component);
    for (auto& subcomponent : app.components) {
      const auto it = components_.find(subcomponent.reference);
      if (it != components_.end() && it->second->readable) {
        subcomponent.profile = it->second->profile;
      }
    }
    check_connections(report, app, connection_nodes);

    if (diagnostics_.error_count() != errors_before) return std::nullopt;
    return app;
  }

 private:
  // -- shared ----------------------------------------------------------------------------

  void read_type_files(const Reporter& report, pugi::xml_node types, std::vector<fs::path>& out) {
    const Children children = scan(report, types, kTypesRules);
    const fs::path base = fs::path(report.xml().name()).parent_path();
    for (const pugi::xml_node element : children.all("file")) {
      const std::string text = text_of(element);
      if (text.empty()) {
        report.error(element, "empty <file>");
        continue;
      }
      const fs::path file = absolute_path(base / text);
      out.push_back(file);
      std::error_code ec;
      if (!fs::exists(file, ec)) {
        report.error_text(element, "type file " + in_quotes(file.string()) + " not found");
        continue;
      }
      if (file.extension() != ".idl") {
        report.error_text(
            element, "unsupported type file " + in_quotes(file.string()) + " (supported: .idl)");
        continue;
      }
      pending_type_files_.push_back(file);
    }
  }

  void load_type_files() {
    // Type files may name each other's types, so all are read before any name is checked.
    std::set<fs::path> loaded;
    for (const auto& file : pending_type_files_) {
      if (!loaded.insert(file).second) continue;
      types_.add_type_file(file, diagnostics_);
    }
  }

  void check_types(const LoadedComponent& component) {
    if (!component.readable) return;
    for (const auto& use : component.type_uses) {
      if (types_.find(use.name) == nullptr) {
        diagnostics_.error(use.where, use.path, "unknown type " + in_quotes(use.name));
      }
    }
  }

  // -- application profile ---------------------------------------------------------------

  void read_subcomponents(const Reporter& report, pugi::xml_node element, ApplicationProfile& app) {
    const Children children = scan(report, element, kSubcomponentsRules);
    const fs::path base = app.file.parent_path();
    std::map<std::string, pugi::xml_node, std::less<>> seen;
    for (const pugi::xml_node node : children.all("subcomponent")) {
      const Children fields = scan(report, node, kSubcomponentRules);
      Subcomponent subcomponent;
      subcomponent.where = report.xml().at(node);
      const auto name = required_text(report, node, fields, "name", "name");
      const auto reference = required_text(report, node, fields, "reference", "reference");
      bool usable = name.has_value();
      if (name) {
        subcomponent.name = *name;
        const auto [it, inserted] = seen.emplace(*name, fields.one("name"));
        if (!inserted) {
          report.error_text(fields.one("name"),
                            "duplicate subcomponent name " + in_quotes(*name) +
                                ": already used at line " +
                                std::to_string(report.xml().at(it->second).line));
          usable = false;
        }
      }
      if (reference) {
        subcomponent.reference = absolute_path(base / *reference);
        const pugi::xml_node reference_node = fields.one("reference");
        load_component(subcomponent.reference, report.xml().at_text(reference_node),
                       element_path(reference_node));
      }
      // A duplicate stays out of the list so connections resolve against the first one.
      if (usable) app.components.push_back(std::move(subcomponent));
    }
  }

  void read_connections(const Reporter& report, pugi::xml_node element, ApplicationProfile& app,
                        std::vector<pugi::xml_node>& nodes) {
    const Children children = scan(report, element, kConnectionsRules);
    for (const pugi::xml_node node : children.all("port_connection")) {
      ConnectionSpec connection;
      connection.where = report.xml().at(node);
      // OPRoS: a port_connection without port_type is a "method" (service) connection.
      connection.kind = PortKind::service;
      if (const auto port_type = node.attribute("port_type")) {
        const std::string text(trim(port_type.value()));
        if (const auto kind = lookup(kPortTypes, text)) {
          connection.kind = *kind;
        } else {
          report.error_attribute(
              node, "port_type",
              "bad port_type " + in_quotes(text) + " (accepted: " + accepted(kPortTypes) + ")");
        }
      }
      if (const auto policy = node.attribute("policy")) {
        const std::string text(trim(policy.value()));
        connection.policy = lookup(kQueuePolicies, text);
        if (!connection.policy) {
          report.error_attribute(
              node, "policy",
              "bad policy " + in_quotes(text) + " (accepted: " + accepted(kQueuePolicies) + ")");
        }
      }
      if (const auto depth = node.attribute("depth")) {
        const std::string text(trim(depth.value()));
        connection.depth = depth_value(text);
        if (!connection.depth) {
          report.error_attribute(node, "depth",
                                 "bad depth " + in_quotes(text) + ": " + kDepthExpected);
        }
      }
      const Children ends = scan(report, node, kConnectionRules);
      read_end(report, node, ends.one("source"), "source", connection.source);
      read_end(report, node, ends.one("target"), "target", connection.target);
      bool mapping_readable = true;
      if (const auto mapping = ends.one("mapping")) {
        const std::size_t errors_before = diagnostics_.error_count();
        connection.mapping = read_mapping(report, mapping);
        mapping_readable = diagnostics_.error_count() == errors_before;
      }
      app.connections.push_back(std::move(connection));
      nodes.push_back(node);
      mapping_readable_.push_back(mapping_readable);
    }
  }

  void read_end(const Reporter& report, pugi::xml_node connection, pugi::xml_node end,
                std::string_view tag, ConnectionEnd& out) {
    if (!end) {
      report.error(connection, "missing <" + std::string(tag) + ">");
      return;
    }
    out.where = report.xml().at(end);
    for (const std::string_view attribute : {"component_name", "port_name"}) {
      const std::string value(trim(end.attribute(attribute.data()).value()));
      if (value.empty()) {
        if (end.attribute(attribute.data())) {
          report.error_attribute(end, attribute,
                                 "empty attribute '" + std::string(attribute) + "'");
        } else {
          report.error(end, "missing attribute '" + std::string(attribute) + "'");
        }
      }
      (attribute == "component_name" ? out.component : out.port) = value;
    }
  }

  // -- mappings --------------------------------------------------------------------------

  MappingSpec read_mapping(const Reporter& report, pugi::xml_node element) {
    MappingSpec spec;
    spec.where = report.xml().at(element);
    spec.element_path = element_path(element);
    if (const auto by_name = element.attribute("by_name")) {
      const std::string text(trim(by_name.value()));
      if (const auto value = lookup(kBooleans, text)) {
        spec.by_name = *value;
      } else {
        report.error_attribute(element, "by_name",
                               "bad by_name " + in_quotes(text) + " (accepted: " + accepted(kBooleans) + ")");
      }
    }
    const Children children = scan(report, element, kMappingRules);
    for (const pugi::xml_node field : children.all("field")) {
      if (auto rule = read_rule(report, field)) spec.rules.push_back(std::move(*rule));
    }
    return spec;
  }

  // Reads one <field>: its attributes' syntax and which go together. Whether the paths,
  // units and sizes fit the types is the mapping compiler's to say, once types are loaded.
  static std::optional<MappingRule> read_rule(const Reporter& report, pugi::xml_node field) {
    MappingRule rule;
    rule.where = report.xml().at(field);
    rule.element_path = element_path(field);
    bool ok = true;
    const auto text = [&](const char* name) { return std::string(trim(field.attribute(name).value())); };
    const auto has = [&](const char* name) { return static_cast<bool>(field.attribute(name)); };
    const auto not_for = [&](std::initializer_list<const char*> names, const std::string& what) {
      for (const char* name : names) {
        if (!has(name)) continue;
        report.error_attribute(field, name, std::string(name) + " does not apply to " + what);
        ok = false;
      }
    };

    rule.target = text("target");
    if (rule.target.empty()) {
      report.error(field, has("target") ? "empty attribute 'target'" : "missing attribute 'target'");
      ok = false;
    }
    if (has("source") && has("value")) {
      report.error_attribute(field, "value", "source and value exclude each other");
      ok = false;
    } else if (!has("source") && !has("value")) {
      report.error(field, "missing attribute 'source' or 'value'");
      ok = false;
    } else if (has("source")) {
      rule.source = text("source");
      if (rule.source.empty()) {
        report.error_attribute(field, "source", "empty attribute 'source'");
        ok = false;
      }
    }

    for (const char* name : {"scale", "offset"}) {
      if (!has(name)) continue;
      const std::string value = text(name);
      if (const auto number = parse_number(value)) {
        (std::string_view(name) == "scale" ? rule.scale : rule.offset) = *number;
      } else {
        report.error_attribute(field, name, "bad " + std::string(name) + " " + in_quotes(value) + ": expected a number");
        ok = false;
      }
    }
    for (const char* name : {"allow_narrowing", "truncate"}) {
      if (!has(name)) continue;
      const std::string value = text(name);
      if (const auto flag = lookup(kBooleans, value)) {
        (std::string_view(name) == "truncate" ? rule.truncate : rule.allow_narrowing) = *flag;
      } else {
        report.error_attribute(field, name,
                               "bad " + std::string(name) + " " + in_quotes(value) + " (accepted: " +
                                   accepted(kBooleans) + ")");
        ok = false;
      }
    }
    rule.from_unit = text("from_unit");
    rule.to_unit = text("to_unit");

    if (has("value")) {
      rule.kind = MappingRule::Kind::constant;
      // Not trimmed: a string constant may begin or end with blanks.
      rule.value = field.attribute("value").value();
      not_for({"scale", "offset", "from_unit", "to_unit", "allow_narrowing", "truncate", "transform", "matrix",
               "translation"},
              "a constant (value)");
      return ok ? std::optional<MappingRule>(std::move(rule)) : std::nullopt;
    }
    if (!has("transform")) {
      for (const char* name : {"matrix", "translation"}) {
        if (has(name)) {
          report.error_attribute(field, name, std::string(name) + " needs transform=\"linear\" or \"affine\"");
          ok = false;
        }
      }
      return ok ? std::optional<MappingRule>(std::move(rule)) : std::nullopt;
    }
    const std::string transform = text("transform");
    if (const auto kind = lookup(kTransforms, transform)) {
      rule.kind = *kind;
    } else {
      report.error_attribute(field, "transform",
                             "bad transform " + in_quotes(transform) + " (accepted: " + accepted(kTransforms) + ")");
      return std::nullopt;
    }
    not_for({"scale", "offset", "from_unit", "to_unit", "truncate"}, "a transform (fold it into the matrix)");
    if (!has("matrix")) {
      report.error(field, "missing attribute 'matrix' (needed by a transform)");
      ok = false;
    } else if (!read_matrix(report, field, rule)) {
      ok = false;
    }
    if (rule.kind == MappingRule::Kind::affine && !has("translation")) {
      report.error(field, "missing attribute 'translation' (needed by transform=\"affine\")");
      ok = false;
    } else if (rule.kind == MappingRule::Kind::linear && has("translation")) {
      report.error_attribute(field, "translation", "a translation needs transform=\"affine\"");
      ok = false;
    } else if (has("translation")) {
      std::string bad;
      if (auto values = parse_numbers(field.attribute("translation").value(), bad)) {
        rule.translation = std::move(*values);
      } else {
        report.error_attribute(field, "translation", "bad translation: " + not_a_number(bad));
        ok = false;
      }
    }
    return ok ? std::optional<MappingRule>(std::move(rule)) : std::nullopt;
  }

  static std::string not_a_number(const std::string& entry) {
    return entry.empty() ? "an entry is missing" : in_quotes(entry) + " is not a number";
  }

  // matrix="m11 m12; m21 m22": rows separated by ';', the entries of a row by blanks or commas.
  static bool read_matrix(const Reporter& report, pugi::xml_node field, MappingRule& rule) {
    const std::string_view text = field.attribute("matrix").value();
    std::size_t rows = 0;
    std::size_t cols = 0;
    std::size_t start = 0;
    while (true) {
      const std::size_t end = std::min(text.find(';', start), text.size());
      std::string bad;
      const auto row = parse_numbers(text.substr(start, end - start), bad);
      if (!row) {
        report.error_attribute(field, "matrix", "bad matrix: " + not_a_number(bad));
        return false;
      }
      ++rows;
      if (rows == 1) {
        cols = row->size();
      } else if (row->size() != cols) {
        report.error_attribute(field, "matrix",
                               "bad matrix: row " + std::to_string(rows) + " has " + std::to_string(row->size()) +
                                   " entries but row 1 has " + std::to_string(cols));
        return false;
      }
      rule.matrix.insert(rule.matrix.end(), row->begin(), row->end());
      if (end == text.size()) break;
      start = end + 1;
    }
    if (rows > kMaxMatrixSide || cols > kMaxMatrixSide) {
      report.error_attribute(field, "matrix",
                             "bad matrix: " + std::to_string(rows) + "x" + std::to_string(cols) +
                                 " (at most 6 rows and 6 columns)");
      return false;
    }
    rule.matrix_rows = static_cast<std::uint32_t>(rows);
    rule.matrix_cols = static_cast<std::uint32_t>(cols);
    return true;
  }

  // Compiles the mapping of a data or event connection whose ends are both known: the
  // profile's <mapping>, or a by-name one when the types differ. A mapping that cannot work
  // is one "type mismatch" at the connection (when the types differ) that says why, and the
  // problems a rule causes at that rule's <field>.
  void compile_mapping(const Reporter& report, pugi::xml_node node, ConnectionSpec& spec,
                       const std::string& source_type, const std::string& target_type, bool readable) {
    const pugi::xml_node mapping_node = node.child("mapping");
    if (source_type.empty() || target_type.empty()) {
      // An event without a payload: there is nothing to map (a mismatch is not an error).
      if (spec.mapping) report.error(mapping_node, "a mapping needs a data type on both ports");
      return;
    }
    const Type* from = types_.find(source_type);
    const Type* to = types_.find(target_type);
    if (from == nullptr || to == nullptr) return;  // reported at the port
    const bool same = from == to;
    if (same && !spec.mapping) return;
    if (!readable) return;  // its rules' problems are reported; compiling would repeat them
    const MappingSpec by_name;
    const MappingSpec& mapping = spec.mapping ? *spec.mapping : by_name;
    std::vector<MappingProblem> problems;
    auto program = MappingProgram::compile(*from, *to, mapping, problems);
    if (program) {
      spec.program = std::move(program);
      return;
    }
    std::vector<std::string> reasons;
    std::set<const MappingRule*> faulty_rules;
    for (const MappingProblem& problem : problems) {
      if (problem.rule == nullptr) {
        reasons.push_back(problem.message);
      } else {
        faulty_rules.insert(problem.rule);
      }
    }
    if (!faulty_rules.empty()) {
      reasons.push_back(faulty_rules.size() == 1
                            ? std::string("1 rule of the <mapping> is at fault (reported at its <field>)")
                            : std::to_string(faulty_rules.size()) +
                                  " rules of the <mapping> are at fault (reported at their <field>s)");
    }
    const std::string source_name = spec.source.component + "." + spec.source.port;
    const std::string target_name = spec.target.component + "." + spec.target.port;
    if (!same) {
      report.error(node, "type mismatch: " + source_name + " is " + in_quotes(source_type) + " but " + target_name +
                             " is " + in_quotes(target_type) + ": " + join(reasons, "; "));
    } else if (faulty_rules.size() != problems.size()) {
      // The same type on both ends always maps by name; only rules can fail, but say so if not.
      report.error(mapping_node, "the mapping from " + source_name + " to " + target_name +
                                     " does not compile: " + join(reasons, "; "));
    }
    for (const MappingProblem& problem : problems) {
      if (problem.rule != nullptr) {
        diagnostics_.error(problem.rule->where, problem.rule->element_path, problem.message);
      }
    }
  }

  // -- component profiles ----------------------------------------------------------------

  void load_component(const fs::path& file, const SourceLocation& referenced_at,
                      const std::string& referenced_path) {
    // Several instances may share one component profile: read (and report) it once.
    if (components_.count(file) != 0) return;
    auto& component = *components_.emplace(file, std::make_unique<LoadedComponent>()).first->second;
    load_order_.push_back(&component);
    component.profile.file = file;
    XmlFile xml;
    if (!xml.load(file, "component profile", referenced_at, referenced_path, diagnostics_)) return;
    const Reporter report(xml);
    const pugi::xml_node root = xml.root();
    if (std::string_view(root.name()) != "component_profile") {
      report.error(root, "expected root element <component_profile>, found <" +
                             std::string(root.name()) + ">");
      return;
    }
    check_attributes(report, root, {}, true);
    component.readable = true;
    read_component(report, root, component);
  }

  void read_component(const Reporter& report, pugi::xml_node root, LoadedComponent& component) {
    ComponentProfile& profile = component.profile;
    profile.where = report.xml().at(root);
    profile.execution.where = profile.where;
    const Children children = scan(report, root, kComponentRules);
    if (auto name = required_text(report, root, children, "name", "name")) profile.name = *name;
    if (const auto model = children.one("model")) {
      const std::string text = text_of(model);
      if (text.empty()) {
        report.error(model, "empty <model>");
      } else {
        profile.model = text;
      }
    }
    const pugi::xml_node environment = children.one("execution_environment");
    const Children environment_children =
        environment ? scan(report, environment, kEnvironmentRules) : Children();
    if (auto class_name = optional_text(environment_children, "class_name");
        class_name && !class_name->empty()) {
      profile.class_name = *class_name;
    } else {
      profile.class_name = profile.name;
    }
    if (profile.model == "inproc") {
      read_library(report, root, environment, environment_children, profile);
    }
    if (const auto semantics = children.one("execution_semantics")) {
      read_execution(report, semantics, profile);
    }
    if (const auto dds = children.one("dds")) {
      if (!is_dds_model(profile.model)) {
        report.warning(dds, "<dds> is ignored by model " + in_quotes(profile.model));
      }
      read_dds(report, dds, profile);
    }
    if (const auto types = children.one("types")) {
      read_type_files(report, types, profile.type_files);
    }
    if (const auto properties = children.one("properties")) {
      read_properties(report, properties, profile);
    }
    if (const auto ports = children.one("ports")) read_ports(report, ports, component);
  }

  void read_dds(const Reporter& report, pugi::xml_node dds, ComponentProfile& profile) {
    profile.dds_where = report.xml().at(dds);
    const Children children = scan(report, dds, kDdsRules);
    if (const auto domain = children.one("domain")) {
      const std::string text = text_of(domain);
      const auto value = parse_integer<std::uint32_t>(text);
      if (!value || *value > kMaxDdsDomain) {
        report.error_text(domain, "bad DDS domain " + in_quotes(text) + ": expected an integer from 0 to " +
                                      std::to_string(kMaxDdsDomain));
      } else {
        profile.dds_domain = *value;
      }
    }
    if (const auto config = children.one("config")) {
      const std::string text = text_of(config);
      if (text.empty()) {
        profile.dds_config = fs::path();  // the SDK's own defaults
      } else {
        const fs::path file = absolute_path(fs::path(report.xml().name()).parent_path() / text);
        profile.dds_config = file;
        std::error_code ec;
        if (!fs::is_regular_file(file, ec)) {
          report.error_text(config, "DDS configuration file " + in_quotes(file.string()) + " not found");
        }
      }
    }
    if (const auto qos = children.one("qos")) read_qos(report, qos, profile.dds_qos);
    if (const auto cap = children.one("max_calls_in_flight")) {
      const std::string text = text_of(cap);
      const auto value = parse_integer<std::uint32_t>(text);
      if (!value || *value == 0 || *value > kMaxDdsCallsInFlight) {
        report.error_text(cap, "bad max_calls_in_flight " + in_quotes(text) + ": expected an integer from 1 to " +
                                   std::to_string(kMaxDdsCallsInFlight));
      } else {
        profile.dds_max_calls_in_flight = *value;
      }
    }
    if (const auto timeout = children.one("call_timeout")) {
      if (const auto ns = duration_ns(report, timeout, "call_timeout_ms"); ns && *ns > 0) {
        profile.dds_call_timeout_ns = *ns;
      } else if (ns) {
        report.error_text(timeout, "call_timeout_ms must be greater than 0");
      }
    }
  }

  // A duration in milliseconds (decimal), as nanoseconds; at most a day.
  static std::optional<std::int64_t> duration_ns(const Reporter& report, pugi::xml_node element,
                                                 std::string_view what) {
    const std::string text = text_of(element);
    const auto value = parse_decimal(text);
    constexpr double kMaxMs = 86'400'000.0;
    if (!value || *value < 0.0 || *value > kMaxMs) {
      report.error_text(element, "bad " + std::string(what) + " " + in_quotes(text) +
                                     ": expected a number of milliseconds from 0 to 86400000");
      return std::nullopt;
    }
    return static_cast<std::int64_t>(*value * 1e6 + 0.5);
  }

  // <qos>: each child present overrides that field of `qos` (the component's defaults, or
  // the model's).
  void read_qos(const Reporter& report, pugi::xml_node element, DdsQos& qos) {
    const Children children = scan(report, element, kQosRules);
    if (const auto node = children.one("reliability")) {
      if (auto value = enum_text(report, node, kReliabilities, "reliability")) qos.reliability = *value;
    }
    if (const auto node = children.one("durability")) {
      if (auto value = enum_text(report, node, kDurabilities, "durability")) qos.durability = *value;
    }
    if (const auto node = children.one("history")) {
      if (auto value = enum_text(report, node, kHistories, "history")) qos.history = *value;
    }
    if (const auto node = children.one("depth")) {
      const std::string text = text_of(node);
      const auto value = parse_integer<std::int32_t>(text);
      if (!value || *value <= 0) {
        report.error_text(node, "bad history depth " + in_quotes(text) + ": expected an integer from 1 to 2147483647");
      } else {
        qos.depth = *value;
      }
    }
    if (const auto node = children.one("deadline")) {
      if (const auto ns = duration_ns(report, node, "deadline_ms")) qos.deadline_ns = *ns > 0 ? ns : std::nullopt;
    }
    if (const auto node = children.one("lifespan")) {
      if (const auto ns = duration_ns(report, node, "lifespan_ms")) qos.lifespan_ns = *ns > 0 ? ns : std::nullopt;
    }
    if (const auto node = children.one("liveliness")) {
      if (auto value = enum_text(report, node, kLivelinesses, "liveliness")) qos.liveliness = *value;
    }
    if (const auto node = children.one("lease")) {
      if (const auto ns = duration_ns(report, node, "lease_ms")) qos.lease_ns = *ns > 0 ? ns : std::nullopt;
    }
    if (!children.all("partition").empty()) qos.partitions.clear();  // a port's list replaces the component's
    for (const pugi::xml_node node : children.all("partition")) qos.partitions.push_back(text_of(node));
    if (qos.deadline_ns && qos.lifespan_ns && *qos.lifespan_ns < *qos.deadline_ns) {
      // Legal in DDS, but samples then expire before the next is due: say so.
      report.warning(element, "lifespan_ms is shorter than deadline_ms: readers may miss every deadline");
    }
  }

  void read_library(const Reporter& report, pugi::xml_node root, pugi::xml_node environment,
                    const Children& children, ComponentProfile& profile) {
    const pugi::xml_node library = children.one("library_name");
    if (!library) {
      report.error(environment ? environment : root,
                   environment ? "missing <library_name> (needed by model 'inproc')"
                               : "missing <execution_environment> with <library_name> (needed by "
                                 "model 'inproc')");
      return;
    }
    profile.library = text_of(library);
    if (profile.library.empty()) {
      report.error(library, "empty <library_name>");
      return;
    }
    std::vector<fs::path> folders;
    folders.push_back(profile.file.parent_path());
    for (const auto& folder : options_.library_path) folders.push_back(absolute_path(folder));
    const fs::path library_file(profile.library);
    if (library_file.is_absolute()) folders.assign(1, library_file.parent_path());
    for (const auto& folder : folders) {
      const fs::path candidate = library_file.is_absolute() ? library_file : folder / library_file;
      std::error_code ec;
      if (fs::is_regular_file(candidate, ec)) {
        // Not canonical: a library is often a symlink to a versioned file, and logs should
        // show the name the profile asked for.
        profile.library_path = fs::absolute(candidate, ec).lexically_normal();
        return;
      }
    }
    std::vector<std::string> names;
    for (const auto& folder : folders) names.push_back(folder.string());
    report.error_text(library, "component library " + in_quotes(profile.library) +
                                   " not found (looked in: " + join(names, ", ") + ")");
  }

  void read_execution(const Reporter& report, pugi::xml_node element, ComponentProfile& profile) {
    ExecutionSemantics& execution = profile.execution;
    execution.where = report.xml().at(element);
    const Children children = scan(report, element, kSemanticsRules);
    if (const auto type = children.one("type")) {
      if (auto value = enum_text(report, type, kExecutionTypes, "execution type")) {
        execution.type = *value;
      }
    }
    if (const auto period = children.one("period")) {
      const std::string text = text_of(period);
      const auto value = parse_decimal(text);
      if (!value || *value < 0.0) {
        report.error_text(period, "bad period " + in_quotes(text) +
                                      ": expected a number of milliseconds, 0 or more");
      } else {
        execution.period_ms = *value;
        if (is_periodic(execution.type) && *value <= 0.0) {
          report.error_text(period, "period must be greater than 0 ms for a periodic component");
        }
      }
    }
    const pugi::xml_node priority = children.one("priority");
    if (priority) {
      const std::string text = text_of(priority);
      if (const auto value = parse_integer<int>(text)) {
        execution.priority = *value;
      } else {
        report.error_text(priority, "bad priority " + in_quotes(text) + ": expected an integer");
      }
    }
    const pugi::xml_node policy = children.one("policy");
    bool policy_ok = true;
    if (policy) {
      const auto value = enum_text(report, policy, kSchedPolicies, "scheduling policy");
      policy_ok = value.has_value();
      if (value) execution.policy = *value;
    }
    // Real-time policies need a real-time priority; SCHED_OTHER ignores it (OPRoS profiles
    // use it to group components onto shared executors).
    if (policy_ok && execution.policy != SchedPolicy::other) {
      const std::string name(sched_policy_name(execution.policy));
      if (!priority) {
        report.error(policy, name + " needs a <priority> from " + std::to_string(kMinRtPriority) +
                                 " to " + std::to_string(kMaxRtPriority));
      } else if (parse_integer<int>(text_of(priority)) &&
                 (execution.priority < kMinRtPriority || execution.priority > kMaxRtPriority)) {
        report.error_text(priority, "priority " + std::to_string(execution.priority) +
                                        " is out of range for " + name + " (" +
                                        std::to_string(kMinRtPriority) + " to " +
                                        std::to_string(kMaxRtPriority) + ")");
      }
    }
    if (const auto cpu = children.one("cpu")) {
      const std::string text = text_of(cpu);
      const auto value = parse_integer<int>(text);
      if (!value || *value < 0 || *value > kMaxCpu) {
        report.error_text(cpu, "bad " + std::string(cpu.name()) + " " + in_quotes(text) +
                                   ": expected an integer from 0 to " + std::to_string(kMaxCpu));
      } else {
        execution.cpu = *value;
      }
    }
    if (const auto lifecycle = children.one("lifecycle_type")) {
      if (auto value = enum_text(report, lifecycle, kLifecycleTypes, "lifecycle_type")) {
        profile.initial_state = *value;
      }
    }
  }

  void read_properties(const Reporter& report, pugi::xml_node element, ComponentProfile& profile) {
    const Children children = scan(report, element, kPropertiesRules);
    std::map<std::string, pugi::xml_node, std::less<>> seen;
    for (const pugi::xml_node node : children.all("property")) {
      PropertySpec property;
      property.where = report.xml().at(node);
      property.name = std::string(trim(node.attribute("name").value()));
      property.type = std::string(trim(node.attribute("type").value()));
      property.value = text_of(node);
      if (property.name.empty()) {
        report.error(
            node, node.attribute("name") ? "empty attribute 'name'" : "missing attribute 'name'");
        continue;
      }
      const auto [it, inserted] = seen.emplace(property.name, node);
      if (!inserted) {
        report.error_attribute(node, "name",
                               "duplicate property " + in_quotes(property.name) +
                                   ": already given at line " +
                                   std::to_string(report.xml().at(it->second).line));
        continue;
      }
      check_property_value(report, node, property);
      profile.properties.push_back(std::move(property));
    }
  }

  // A component reads its properties at configure time; a value that cannot be read as its
  // declared type would fail there, far from the profile, so it is checked here.
  static void check_property_value(const Reporter& report, pugi::xml_node node,
                                   const PropertySpec& property) {
    const std::string& type = property.type;
    bool ok = true;
    if (type == "int" || type == "long" || type == "short") {
      ok = parse_integer<std::int64_t>(property.value).has_value();
    } else if (type == "double" || type == "float") {
      // The XSD leaves property text free, so the usual C spellings (1e-3) are fine here.
      double value = 0.0;
      const char* first = property.value.data();
      const char* last = first + property.value.size();
      if (first != last && *first == '+') ++first;
      const auto [end, ec] = std::from_chars(first, last, value);
      ok = first != last && ec == std::errc{} && end == last && std::isfinite(value);
    } else if (type == "bool" || type == "boolean") {
      ok = lookup(kBooleans, property.value).has_value();
    }
    if (!ok) {
      report.error_text(node, "bad value " + in_quotes(property.value) + " for property " +
                                  in_quotes(property.name) + " of type " + in_quotes(type));
    }
  }

  void read_ports(const Reporter& report, pugi::xml_node element, LoadedComponent& component) {
    const Children children = scan(report, element, kPortsRules);
    std::map<std::string, pugi::xml_node, std::less<>> seen;
    for (const pugi::xml_node node : children.all("port")) {
      PortSpec port;
      port.where = report.xml().at(node);
      const std::string_view tag = node.name();
      port.kind = tag == "service_port" ? PortKind::service
                  : tag == "event_port" ? PortKind::event
                                        : PortKind::data;
      bool complete = false;
      const Children fields =
          scan(report, node, port.kind == PortKind::service ? kServicePortRules : kDataPortRules);
      const auto name = required_text(report, node, fields, "name", "name");
      if (port.kind == PortKind::service) {
        complete = read_service_port(report, node, fields, port, component);
      } else {
        complete = read_data_port(report, node, fields, port, component);
      }
      if (!name) continue;
      port.name = *name;
      const auto [it, inserted] = seen.emplace(port.name, fields.one("name"));
      if (!inserted) {
        report.error_text(fields.one("name"), "duplicate port name " + in_quotes(port.name) +
                                                  ": already used at line " +
                                                  std::to_string(report.xml().at(it->second).line));
        continue;
      }
      if (!complete) component.incomplete_ports.insert(port.name);
      component.profile.ports.push_back(std::move(port));
    }
  }

  // Returns whether the port's kind and direction are known (so connections can be checked).
  bool read_data_port(const Reporter& report, pugi::xml_node node, const Children& fields,
                      PortSpec& port, LoadedComponent& component) {
    bool complete = true;
    if (const auto data_type = fields.one("data_type")) {
      port.data_type = text_of(data_type);
      if (port.data_type.empty()) {
        if (port.kind == PortKind::data) report.error(data_type, "empty <data_type>");
      } else {
        component.type_uses.push_back(
            {port.data_type, report.xml().at_text(data_type), element_path(data_type)});
      }
    } else if (port.kind == PortKind::data) {
      report.error(node, "missing <data_type>");
    }
    if (const auto usage = required_text(report, node, fields, "usage", "usage")) {
      const std::string context = " for " + port_noun(port);
      if (auto direction = enum_text(report, fields.one("usage"), kDataUsages, "usage", context)) {
        port.direction = *direction;
      } else {
        complete = false;
      }
    } else {
      complete = false;
    }

    read_dds_port(report, fields, port, component.profile);

    const pugi::xml_node policy = fields.one("policy");
    if (policy) {
      port.policy = enum_text(report, policy, kQueuePolicies, "queueing policy");
    }
    // The depth comes from <queue_size>, <queueing_size> or <policy_param name="size">.
    pugi::xml_node depth = fields.one("depth");
    for (const pugi::xml_node param : fields.all("policy_param")) {
      const std::string param_name(trim(param.attribute("name").value()));
      if (param_name != "size") {
        report.warning(param, "unknown policy_param " + in_quotes(param_name) + " (known: size)");
        continue;
      }
      if (depth) {
        report.error(param, "duplicate <policy_param name=\"size\">: depth already given at line " +
                                std::to_string(report.xml().at(depth).line));
        continue;
      }
      depth = param;
    }
    if (depth) {
      const std::string text = text_of(depth);
      port.depth = depth_value(text);
      if (!port.depth) {
        report.error_text(depth, "bad depth " + in_quotes(text) + ": " + kDepthExpected);
      }
    }
    if (complete && port.direction == PortDirection::output) {
      // The queue lives on the reading side. OPRoS editors write `data` on outputs too, which
      // is harmless; asking an output for a queue is a misunderstanding worth a warning.
      if (policy && port.policy && *port.policy != QueuePolicy::data) {
        report.warning(policy,
                       "a queueing policy on an output port is ignored (the input port "
                       "or the connection sets it)");
      }
      if (depth) {
        report.warning(depth,
                       "a queue size on an output port is ignored (the input port or "
                       "the connection sets it)");
      }
      port.policy.reset();
      port.depth.reset();
      return complete;
    }
    if (port.policy == QueuePolicy::data && port.depth) {
      // OPRoS writes "LAST with size 1" for the latest value; more than one is a contradiction.
      if (*port.depth != 1) {
        report.error_text(depth, "a depth of " + std::to_string(*port.depth) +
                                     " contradicts the data policy (latest value only); use "
                                     "buffer or circular for a queue");
      }
      port.depth.reset();
    }
    if (port.policy && port.policy != QueuePolicy::data && !port.depth) port.depth = kDefaultDepth;
    return complete;
  }

  // <topic> and <qos> of a port (DDS models only).
  void read_dds_port(const Reporter& report, const Children& fields, PortSpec& port,
                     const ComponentProfile& profile) {
    port.qos = profile.dds_qos;
    const bool dds = is_dds_model(profile.model);
    if (const auto topic = fields.one("topic")) {
      port.topic = text_of(topic);
      if (port.topic.empty()) {
        report.error(topic, "empty <topic>");
      } else if (!dds) {
        report.warning(topic, "<topic> is ignored by model " + in_quotes(profile.model));
      }
    }
    if (const auto qos = fields.one("qos")) {
      if (!dds) report.warning(qos, "<qos> is ignored by model " + in_quotes(profile.model));
      read_qos(report, qos, port.qos);
    }
  }

  bool read_service_port(const Reporter& report, pugi::xml_node node, const Children& fields,
                         PortSpec& port, LoadedComponent& component) {
    bool complete = true;
    read_dds_port(report, fields, port, component.profile);
    const bool dds = is_dds_model(component.profile.model);
    if (auto type = optional_text(fields, "type")) port.service_type = *type;
    if (const auto usage = required_text(report, node, fields, "usage", "usage")) {
      if (auto direction = enum_text(report, fields.one("usage"), kServiceUsages, "usage",
                                     " for a service port")) {
        port.direction = *direction;
      } else {
        complete = false;
      }
    } else {
      complete = false;
    }
    std::map<std::string, pugi::xml_node, std::less<>> seen;
    for (const pugi::xml_node element : fields.all("operation")) {
      OperationSpec operation;
      operation.where = report.xml().at(element);
      operation.name = std::string(trim(element.attribute("name").value()));
      operation.request_type = std::string(trim(element.attribute("request").value()));
      operation.reply_type = std::string(trim(element.attribute("reply").value()));
      if (const auto oneway = element.attribute("oneway")) {
        const std::string text(trim(oneway.value()));
        if (const auto value = lookup(kBooleans, text)) {
          operation.oneway = *value;
        } else {
          report.error_attribute(
              element, "oneway",
              "bad oneway " + in_quotes(text) + " (accepted: " + accepted(kBooleans) + ")");
        }
      }
      if (operation.oneway && !operation.reply_type.empty()) {
        report.error_attribute(element, "reply", "a oneway operation has no reply");
      }
      operation.dds_request_type = std::string(trim(element.attribute("dds_request").value()));
      operation.dds_reply_type = std::string(trim(element.attribute("dds_reply").value()));
      if (!dds && (element.attribute("dds_request") || element.attribute("dds_reply"))) {
        report.warning(element, "dds_request / dds_reply are ignored by model " + in_quotes(component.profile.model));
        operation.dds_request_type.clear();
        operation.dds_reply_type.clear();
      }
      if (dds && operation.dds_request_type.empty()) {
        report.error(element, "missing attribute 'dds_request': the struct a DDS application writes on the "
                              "request topic (a polyport::rpc::RequestHeader, then the request)");
      }
      if (dds && !operation.oneway && operation.dds_reply_type.empty()) {
        report.error(element, "missing attribute 'dds_reply': the struct a DDS application writes on the "
                              "reply topic (a polyport::rpc::ReplyHeader, then the reply)");
      }
      if (dds && operation.oneway && !operation.dds_reply_type.empty()) {
        report.error_attribute(element, "dds_reply", "a oneway operation has no reply");
      }
      for (const std::string_view attribute : {"request", "reply", "dds_request", "dds_reply"}) {
        const std::string& type_name = attribute == "request"       ? operation.request_type
                                       : attribute == "reply"       ? operation.reply_type
                                       : attribute == "dds_request" ? operation.dds_request_type
                                                                    : operation.dds_reply_type;
        if (type_name.empty()) continue;
        component.type_uses.push_back({type_name, report.xml().at_attribute(element, attribute),
                                       attribute_path(element, attribute)});
      }
      if (operation.name.empty()) {
        report.error(element, element.attribute("name") ? "empty attribute 'name'"
                                                        : "missing attribute 'name'");
        continue;
      }
      const auto [it, inserted] = seen.emplace(operation.name, element);
      if (!inserted) {
        report.error_attribute(element, "name",
                               "duplicate operation " + in_quotes(operation.name) +
                                   ": already given at line " +
                                   std::to_string(report.xml().at(it->second).line));
        continue;
      }
      port.operations.push_back(std::move(operation));
    }
    return complete;
  }

  // -- connections -----------------------------------------------------------------------

  struct ResolvedEnd {
    const Subcomponent* component = nullptr;
    const PortSpec* port = nullptr;
    bool checkable = false;  // port known with a known kind and direction
  };

  ResolvedEnd resolve(const Reporter& report, const ApplicationProfile& app, pugi::xml_node end,
                      const ConnectionEnd& spec) {
    ResolvedEnd resolved;
    if (!end || spec.component.empty()) return resolved;
    resolved.component = app.find_component(spec.component);
    // Reported at the end element, like every other problem of a connection end: the end is
    // the pair (component_name, port_name), and its path reads as `.../source`.
    if (resolved.component == nullptr) {
      report.error(end, "unknown component " + in_quotes(spec.component));
      return resolved;
    }
    const auto it = components_.find(resolved.component->reference);
    // Its profile could not be read: that is reported already, its ports are unknown.
    if (it == components_.end() || !it->second->readable || spec.port.empty()) return resolved;
    resolved.port = resolved.component->profile.find_port(spec.port);
    if (resolved.port == nullptr) {
      report.error(end, "component " + in_quotes(spec.component) + " has no port " +
                            in_quotes(spec.port));
      return resolved;
    }
    resolved.checkable = it->second->incomplete_ports.count(spec.port) == 0;
    return resolved;
  }

  // Checks that `end` is a `kind` port facing the right way; returns whether it is.
  bool check_end(const Reporter& report, pugi::xml_node connection, pugi::xml_node end,
                 const ConnectionSpec& spec, const ConnectionEnd& end_spec,
                 const ResolvedEnd& resolved, bool is_source) {
    if (!resolved.checkable) return false;
    const std::string name = end_spec.component + "." + end_spec.port;
    const PortSpec& port = *resolved.port;
    const std::string kind(to_string(spec.kind));
    if (port.kind != spec.kind) {
      std::string message = name + " is " + port_noun(port) + "; this is " +
                            (spec.kind == PortKind::event ? "an " : "a ") + kind + " connection";
      if (!connection.attribute("port_type")) {
        message += " (port_type is missing: OPRoS's default is a service connection)";
      }
      report.error(end, message);
      return false;
    }
    PortDirection wanted = PortDirection::input;
    if (spec.kind == PortKind::service) {
      wanted = is_source ? PortDirection::required : PortDirection::provided;
    } else if (is_source) {
      wanted = PortDirection::output;
    }
    if (port.direction != wanted) {
      report.error(end, name + " is " + direction_noun(port.direction) + "; " +
                            (spec.kind == PortKind::event ? "an " : "a ") + kind +
                            " connection's " + (is_source ? "source" : "target") + " must be " +
                            direction_noun(wanted));
      return false;
    }
    return true;
  }

  // Two type names match when they name the same registered type, however spelled
  // ("::a::T" and "a::T"); an empty name (no payload) matches only another empty one. A name
  // the registry does not know is reported at its port already, so it matches anything here.
  bool same_type(std::string_view a, std::string_view b) const {
    if (a.empty() || b.empty()) return a.empty() && b.empty();
    const Type* type_a = types_.find(a);
    const Type* type_b = types_.find(b);
    if (type_a == nullptr || type_b == nullptr) return true;
    return type_a == type_b;
  }

  static std::string signature(const OperationSpec& operation) {
    std::string text = "(" + operation.request_type + ")";
    if (operation.oneway) return text + " oneway";
    return text + " -> " + (operation.reply_type.empty() ? "()" : operation.reply_type);
  }

  void check_connections(const Reporter& report, ApplicationProfile& app,
                         const std::vector<pugi::xml_node>& nodes) {
    // Required service port ("A.p") -> the connection that uses it first (target, line).
    std::map<std::string, std::pair<std::string, std::uint32_t>, std::less<>> required_used;
    for (std::size_t i = 0; i < app.connections.size(); ++i) {
      ConnectionSpec& spec = app.connections[i];
      const pugi::xml_node node = nodes[i];
      const pugi::xml_node source_node = node.child("source");
      const pugi::xml_node target_node = node.child("target");
      const ResolvedEnd source = resolve(report, app, source_node, spec.source);
      const ResolvedEnd target = resolve(report, app, target_node, spec.target);
      const pugi::xml_attribute port_type = node.attribute("port_type");
      // With a bad port_type (reported already) kinds, directions and policies mean nothing.
      if (port_type && !lookup(kPortTypes, trim(port_type.value()))) continue;
      const bool source_ok = check_end(report, node, source_node, spec, spec.source, source, true);
      const bool target_ok = check_end(report, node, target_node, spec, spec.target, target, false);
      const std::string source_name = spec.source.component + "." + spec.source.port;
      const std::string target_name = spec.target.component + "." + spec.target.port;

      if (spec.kind == PortKind::service) {
        for (const std::string_view attribute : {"policy", "depth"}) {
          if (node.attribute(attribute.data())) {
            report.error_attribute(
                node, attribute,
                std::string(attribute) + " applies only to data and event connections");
          }
        }
        spec.policy.reset();
        spec.depth.reset();
        if (spec.mapping) {
          report.error(node.child("mapping"), "a mapping applies only to data and event connections");
          spec.mapping.reset();
        }
        if (source_ok) {
          const auto line = report.xml().at(node).line;
          const auto [it, inserted] =
              required_used.emplace(source_name, std::make_pair(target_name, line));
          if (!inserted) {
            report.error(source_node, "required port " + source_name + " is already connected to " +
                                          it->second.first + " (line " +
                                          std::to_string(it->second.second) + ")");
          }
        }
        if (source_ok && target_ok) {
          check_service_pair(report, node, spec, *source.port, *target.port);
        }
        continue;
      }

      // An event may carry no payload: types are mapped only when both ends name one (a
      // data port without <data_type> is reported already).
      if (source_ok && target_ok) {
        compile_mapping(report, node, spec, source.port->data_type, target.port->data_type, mapping_readable_[i]);
      }
      resolve_policy(report, node, spec, target_ok ? target.port : nullptr);
    }
  }

  // Leaves the connection with its effective policy and depth: the connection's own, else the
  // input port's, else the default: data (latest value) for data connections, circular for
  // events, which are notifications that a newer one must not silently replace. A queue
  // without a size gets the input port's size, else kDefaultDepth.
  static void resolve_policy(const Reporter& report, pugi::xml_node node, ConnectionSpec& spec,
                             const PortSpec* target) {
    if (node.attribute("policy") && !spec.policy) return;  // a bad policy, reported already
    const bool policy_given = spec.policy.has_value();
    const bool depth_given = spec.depth.has_value();
    if (!spec.policy) {
      if (target == nullptr) return;  // the input port is unknown (reported already)
      spec.policy = target->policy ? *target->policy
                                   : (spec.kind == PortKind::event ? QueuePolicy::circular
                                                                   : QueuePolicy::data);
    }
    if (*spec.policy == QueuePolicy::data) {
      if (depth_given) {
        report.error_attribute(node, "depth",
                               std::string("a depth needs a buffer or circular policy, but ") +
                                   (policy_given ? "this connection"
                                                 : "the input port " + spec.target.component + "." +
                                                       spec.target.port) +
                                   " uses the data policy (latest value only)");
      }
      spec.depth.reset();
      return;
    }
    if (!spec.depth) {
      spec.depth = target != nullptr && target->depth ? *target->depth : kDefaultDepth;
    }
  }

  void check_service_pair(const Reporter& report, pugi::xml_node node, const ConnectionSpec& spec,
                          const PortSpec& required, const PortSpec& provided) {
    const std::string source_name = spec.source.component + "." + spec.source.port;
    const std::string target_name = spec.target.component + "." + spec.target.port;
    if (!required.service_type.empty() && !provided.service_type.empty() &&
        required.service_type != provided.service_type) {
      report.error(node, "service interface mismatch: " + source_name + " is " +
                             in_quotes(required.service_type) + " but " + target_name + " is " +
                             in_quotes(provided.service_type));
      return;
    }
    // Profiles that list no operations (OPRoS keeps them in a separate service file) are
    // matched by interface name alone.
    if (required.operations.empty() || provided.operations.empty()) return;
    for (const auto& operation : required.operations) {
      const auto match = std::find_if(
          provided.operations.begin(), provided.operations.end(),
          [&](const OperationSpec& candidate) { return candidate.name == operation.name; });
      if (match == provided.operations.end()) {
        report.error(node, "operation " + in_quotes(operation.name) + " of " + source_name +
                               " is not provided by " + target_name);
        continue;
      }
      const bool same = operation.oneway == match->oneway &&
                        same_type(operation.request_type, match->request_type) &&
                        same_type(operation.reply_type, match->reply_type);
      if (!same) {
        report.error(node, "operation " + in_quotes(operation.name) + " mismatch: " + source_name +
                               " has " + signature(operation) + " but " + target_name + " has " +
                               signature(*match));
      }
    }
  }

  TypeRegistry& types_;
  const LoadOptions& options_;
  Diagnostics& diagnostics_;
  std::map<fs::path, std::unique_ptr<LoadedComponent>> components_;
  std::vector<const LoadedComponent*> load_order_;  // so diagnostics follow the profile
  std::vector<fs::path> pending_type_files_;
  std::vector<bool> mapping_readable_;  // per connection: its <mapping> read without errors
};

}  // namespace

const PortSpec* ComponentProfile::find_port(std::string_view port_name) const noexcept {
  for (const auto& port : ports) {
    if (port.name == port_name) return &port;
  }
  return nullptr;
}

const PropertySpec* ComponentProfile::find_property(std::string_view property_name) const noexcept {
  for (const auto& property : properties) {
    if (property.name == property_name) return &property;
  }
  return nullptr;
}

const Subcomponent* ApplicationProfile::find_component(
    std::string_view instance_name) const noexcept {
  for (const auto& component : components) {
    if (component.name == instance_name) return &component;
  }
  return nullptr;
}

std::optional<ApplicationProfile> load_application_profile(const std::filesystem::path& file,
                                                           TypeRegistry& types,
                                                           const LoadOptions& options,
                                                           Diagnostics& diagnostics) {
  Loader loader(types, options, diagnostics);
  return loader.run(file);
}

std::string_view to_string(PortKind kind) noexcept {
  switch (kind) {
    case PortKind::data: return "data";
    case PortKind::service: return "service";
    case PortKind::event: return "event";
  }
  return "unknown";
}

std::string_view to_string(PortDirection direction) noexcept {
  switch (direction) {
    case PortDirection::input: return "input";
    case PortDirection::output: return "output";
    case PortDirection::provided: return "provided";
    case PortDirection::required: return "required";
  }
  return "unknown";
}

std::string_view to_string(QueuePolicy policy) noexcept {
  switch (policy) {
    case QueuePolicy::data: return "data";
    case QueuePolicy::buffer: return "buffer";
    case QueuePolicy::circular: return "circular";
  }
  return "unknown";
}

std::string_view to_string(ExecutionType type) noexcept {
  switch (type) {
    case ExecutionType::periodic: return "periodic";
    case ExecutionType::periodic_exclusive: return "periodic-exclusive";
    case ExecutionType::aperiodic: return "aperiodic";
    case ExecutionType::passive: return "passive";
  }
  return "unknown";
}

}  // namespace polyport
