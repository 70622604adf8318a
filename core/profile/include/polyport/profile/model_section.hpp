// A model's own part of the profiles. Core reads what every model shares (components, ports,
// connections, policies, mappings, types, execution); each model reads its own elements (a
// DDS component's <dds>, its ports' <topic> and <qos>, ...) through this interface and
// returns settings that core keeps with the component and never looks into: the model's
// create_proxy reads them back (ComponentProfile::model_settings).
//
// The loader accepts the names in every known model's vocabulary (any other name is a typo
// and warns), hands those of the component's own model to that model's reader, and warns
// that those of another model are ignored (that model still reads them, so a bad value is
// reported wherever it is written).
#pragma once

#include <memory>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "polyport/base/diagnostics.hpp"
#include "polyport/profile/profile_element.hpp"

namespace polyport {

struct PortSpec;
struct OperationSpec;

class ModelSettings {
 public:
  virtual ~ModelSettings() = default;
};

// A type name written in a model's element: looked up once every type file is loaded, and
// reported at its place when the registry does not know it.
struct TypeUse {
  std::string name;
  SourceLocation where;
  std::string path;
};

// The names a model owns in component profiles.
struct ModelVocabulary {
  std::vector<std::string_view> component_elements;    // children of <component_profile>
  std::vector<std::string_view> port_elements;         // children of <data_port>, <event_port>, <service_port>
  std::vector<std::string_view> operation_attributes;  // attributes of a service port's <operation>
};

// Reads the model's elements of one component profile, in the loader's order: component
// elements first, then each port and each of its operations, then finish().
class ComponentSectionReader {
 public:
  virtual ~ComponentSectionReader() = default;
  // One component-level element of the vocabulary.
  virtual void read_component_element(const ProfileElement& element) = 0;
  // A port, with its children among the vocabulary's port elements (`elements` is keyed by
  // tag). The component's own model sees every port; another model only ports that carry
  // its elements. Name, kind and direction are set as far as they were readable.
  virtual void read_port(const PortSpec& port, const ProfileChildren& elements) = 0;
  // An operation of a service port (only for the component's own model). Type names the
  // model's attributes give go to `uses`.
  virtual void read_operation(const PortSpec& port, const OperationSpec& operation, const ProfileElement& element,
                              std::vector<TypeUse>& uses) = 0;
  // The settings made from all of it.
  virtual std::shared_ptr<const ModelSettings> finish() = 0;
};

class ModelSection {
 public:
  virtual ~ModelSection() = default;
  virtual const ModelVocabulary& vocabulary() const noexcept = 0;
  // A reader for one component profile of model `model`.
  virtual std::unique_ptr<ComponentSectionReader> reader(std::string_view model) const = 0;
};

// The models the loader knows (the daemon's model registry).
class ModelSections {
 public:
  virtual ~ModelSections() = default;
  // Every model that owns elements, in registration order.
  virtual std::vector<std::pair<std::string_view, const ModelSection*>> sections() const = 0;
};

}  // namespace polyport
