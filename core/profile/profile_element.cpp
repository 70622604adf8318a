#include "polyport/profile/profile_element.hpp"

#include "xml_file.hpp"

namespace polyport {

namespace {
pugi::xml_node node_of(pugi::xml_node_struct* node) { return pugi::xml_node(node); }
}  // namespace

std::string_view ProfileElement::name() const { return node_of(node_).name(); }

std::string ProfileElement::text() const { return detail::text_of(node_of(node_)); }

bool ProfileElement::has_attribute(std::string_view attribute) const {
  return static_cast<bool>(node_of(node_).attribute(std::string(attribute).c_str()));
}

std::string ProfileElement::attribute(std::string_view attribute) const {
  return std::string(text::trim(node_of(node_).attribute(std::string(attribute).c_str()).value()));
}

std::filesystem::path ProfileElement::file() const { return file_->name(); }

std::filesystem::path ProfileElement::folder() const { return file().parent_path(); }

SourceLocation ProfileElement::location() const { return file_->at(node_of(node_)); }

SourceLocation ProfileElement::text_location() const { return file_->at_text(node_of(node_)); }

std::string ProfileElement::path() const { return detail::element_path(node_of(node_)); }

SourceLocation ProfileElement::attribute_location(std::string_view attribute) const {
  return file_->at_attribute(node_of(node_), attribute);
}

std::string ProfileElement::attribute_path(std::string_view attribute) const {
  return detail::attribute_path(node_of(node_), attribute);
}

ProfileChildren ProfileElement::children(const std::vector<ElementRule>& rules) const {
  const detail::Children found = detail::scan(detail::Reporter(*file_), node_of(node_), rules);
  ProfileChildren out;
  for (const ElementRule& rule : rules) {
    if (rule.key.empty()) continue;
    for (const pugi::xml_node child : found.all(rule.key)) out.add(rule.key, ProfileElement(*file_, child.internal_object()));
  }
  return out;
}

void ProfileElement::error(std::string message) const {
  detail::Reporter(*file_).error(node_of(node_), std::move(message));
}

void ProfileElement::warning(std::string message) const {
  detail::Reporter(*file_).warning(node_of(node_), std::move(message));
}

void ProfileElement::error_text(std::string message) const {
  detail::Reporter(*file_).error_text(node_of(node_), std::move(message));
}

void ProfileElement::warning_text(std::string message) const {
  detail::Reporter(*file_).warning_text(node_of(node_), std::move(message));
}

void ProfileElement::error_attribute(std::string_view attribute, std::string message) const {
  detail::Reporter(*file_).error_attribute(node_of(node_), attribute, std::move(message));
}

}  // namespace polyport
