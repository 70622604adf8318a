// A node of the application graph: a name, the model it belongs to, and its ports. For an
// in-process component it is the component's own face; for a foreign one it is the
// adaptor, "an ordinary component with the same ports as the foreign component".
#pragma once

#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "polyport/runtime/port.hpp"
#include "polyport/runtime/service.hpp"

namespace polyport {

class Component {
 public:
  Component(std::string name, std::string model);
  Component(const Component&) = delete;
  Component& operator=(const Component&) = delete;
  virtual ~Component();

  const std::string& name() const noexcept { return name_; }
  const std::string& model() const noexcept { return model_; }

  template <class P, class... Args>
  P& add_port(Args&&... args) {
    auto port = std::make_unique<P>(*this, std::forward<Args>(args)...);
    P& ref = *port;
    ports_.push_back(std::move(port));
    return ref;
  }
  Port* find_port(std::string_view port_name) const noexcept;
  const std::vector<std::unique_ptr<Port>>& ports() const noexcept { return ports_; }

 private:
  std::string name_;
  std::string model_;
  std::vector<std::unique_ptr<Port>> ports_;
};

}  // namespace polyport
