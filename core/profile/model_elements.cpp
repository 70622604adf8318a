// The models' own elements (model_section.hpp): the component's model reads its own; another
// model's elements are ignored with a warning, after that model has checked them.

#include "loader.hpp"

namespace polyport::detail {

// The reader of another model's elements on this component, made on first use.
ComponentSectionReader& Loader::foreign_reader(LoadedComponent& component, const ModelSection* section) {
  auto& reader = component.foreign_readers[section];
  if (!reader) {
    for (const auto& [model, candidate] : rules_.sections) {
      if (candidate == section) {
        reader = section->reader(model);
        break;
      }
    }
  }
  return *reader;
}

// The component-level elements of every model: the own model reads its own; another
// model's are ignored with a warning, after that model has checked them.
void Loader::read_model_elements(const Reporter& report, const Children& children, LoadedComponent& component) {
  const std::string& model = component.profile.model;
  const ModelSection* own = rules_.section_of(model);
  for (const ChildRule& rule : rules_.component) {
    const pugi::xml_node node = children.one(rule.key);
    if (!node || !rules_.owner_of(rule.key, &ModelVocabulary::component_elements)) continue;
    const ProfileElement element(report.xml(), node.internal_object());
    if (owns(own, rule.key, &ModelVocabulary::component_elements)) {
      component.own_reader->read_component_element(element);
      continue;
    }
    report.warning(node, "<" + std::string(rule.key) + "> is ignored by model " + in_quotes(model));
    foreign_reader(component, rules_.owner_of(rule.key, &ModelVocabulary::component_elements))
        .read_component_element(element);
  }
}

// A port's model elements, the same way.
void Loader::read_model_port(const Reporter& report, const Children& fields, const PortSpec& port,
                     LoadedComponent& component) {
  const std::string& model = component.profile.model;
  const ModelSection* own = rules_.section_of(model);
  ProfileChildren own_elements;
  std::map<const ModelSection*, ProfileChildren> foreign;
  for (const ChildRule& rule : port.kind == PortKind::service ? rules_.service_port : rules_.data_port) {
    const ModelSection* owner = rules_.owner_of(rule.key, &ModelVocabulary::port_elements);
    const pugi::xml_node node = fields.one(rule.key);
    if (owner == nullptr || !node) continue;
    const ProfileElement element(report.xml(), node.internal_object());
    if (owns(own, rule.key, &ModelVocabulary::port_elements)) {
      own_elements.add(rule.key, element);
      continue;
    }
    report.warning(node, "<" + std::string(rule.key) + "> is ignored by model " + in_quotes(model));
    foreign[owner].add(rule.key, element);
  }
  if (component.own_reader) component.own_reader->read_port(port, own_elements);
  for (const auto& [section, elements] : foreign) foreign_reader(component, section).read_port(port, elements);
}

// An operation's model attributes: the own model reads them; another model's are ignored
// with one warning that names them all.
void Loader::read_model_operation(const Reporter& report, pugi::xml_node element, const PortSpec& port,
                          const OperationSpec& operation, LoadedComponent& component,
                          std::vector<TypeUse>& uses) {
  const std::string& model = component.profile.model;
  const ModelSection* own = rules_.section_of(model);
  for (const auto& [name, section] : rules_.sections) {
    if (section == own) continue;
    const auto& attributes = section->vocabulary().operation_attributes;
    const bool present = std::any_of(attributes.begin(), attributes.end(), [&](std::string_view attribute) {
      return static_cast<bool>(element.attribute(std::string(attribute).c_str())) &&
             !owns(own, attribute, &ModelVocabulary::operation_attributes);
    });
    if (!present || section != rules_.owner_of(attributes.front(), &ModelVocabulary::operation_attributes)) {
      continue;
    }
    std::vector<std::string> names(attributes.begin(), attributes.end());
    report.warning(element, join(names, " / ") + " are ignored by model " + in_quotes(model));
  }
  if (component.own_reader) {
    component.own_reader->read_operation(port, operation, ProfileElement(report.xml(), element.internal_object()),
                                         uses);
  }
}

}  // namespace polyport::detail
