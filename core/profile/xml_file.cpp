#include "xml_file.hpp"

namespace polyport::detail {

using text::trim;

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

}  // namespace polyport::detail
