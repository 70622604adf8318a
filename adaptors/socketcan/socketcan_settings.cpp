// Reads the SocketCAN model's element of a component profile, each problem at its place.
#include "socketcan_settings.hpp"

#include "polyport/profile/profile_text.hpp"

namespace polyport::socketcan {

namespace {

using text::in_quotes;

const std::vector<ElementRule> kSocketCanRules = {
    {"interface", {"interface"}},
    {"fd", {"fd"}},
    receive_thread_rule(),
};

class SocketCanReader final : public ComponentSectionReader {
 public:
  void read_component_element(const ProfileElement& element) override {
    settings_->where = element.location();
    const ProfileChildren children = element.children(kSocketCanRules);
    if (const ProfileElement interface = children.one("interface")) {
      const std::string written = interface.text();
      if (const std::string why = bad_interface_name(written); !why.empty()) {
        interface.error_text(why);
      } else {
        settings_->interface = written;
      }
    }
    if (const ProfileElement fd = children.one("fd")) {
      if (const auto value = enum_text(fd, text::kBooleans, "fd")) settings_->fd = *value;
    }
    settings_->receive_thread = read_receive_thread(children);
  }

  // The message of a port is its data_type; a port polyport sends may have a <cycle_ms>.
  void read_port(const PortSpec& port, const ProfileChildren& elements) override {
    const ProfileElement cycle = elements.one("cycle_ms");
    if (!cycle) return;
    if (port.direction != PortDirection::input) {
      cycle.error_text("<cycle_ms> is for a port polyport sends (usage input); port '" + port.name +
                       "' receives frames from the bus");
      return;
    }
    const std::string written = cycle.text();
    const auto value = text::parse_integer<std::uint32_t>(written);
    if (!value || *value > kMaxCycleMs) {
      cycle.error_text("bad cycle_ms " + in_quotes(written) + ": expected whole milliseconds from 0 to " +
                       std::to_string(kMaxCycleMs));
      return;
    }
    settings_->cycle_ms[port.name] = *value;
  }
  void read_operation(const PortSpec&, const OperationSpec&, const ProfileElement&, std::vector<TypeUse>&) override {}

  std::shared_ptr<const ModelSettings> finish() override { return settings_; }

 private:
  std::shared_ptr<SocketCanSettings> settings_ = std::make_shared<SocketCanSettings>();
};

}  // namespace

std::string bad_interface_name(std::string_view name) {
  if (name.empty()) return "empty <interface>";
  if (name.size() > kMaxInterfaceName) {
    return "interface " + in_quotes(name) + " is longer than the kernel's " + std::to_string(kMaxInterfaceName) +
           " characters";
  }
  if (name == "." || name == "..") return "interface " + in_quotes(name) + " is not a name the kernel accepts";
  for (const char c : name) {
    if (c <= ' ' || c == 0x7f || c == '/' || c == ':') {
      return "interface " + in_quotes(name) + " has a blank, '/', ':' or control character";
    }
  }
  return {};
}

std::shared_ptr<const SocketCanSettings> socketcan_settings(const ComponentProfile& profile) {
  if (auto settings = std::dynamic_pointer_cast<const SocketCanSettings>(profile.model_settings)) return settings;
  static const auto kDefaults = std::make_shared<const SocketCanSettings>();
  return kDefaults;
}

const ModelVocabulary& SocketCanSection::vocabulary() const noexcept {
  static const ModelVocabulary kVocabulary{{"socketcan"}, {"cycle_ms"}, {}};
  return kVocabulary;
}

std::unique_ptr<ComponentSectionReader> SocketCanSection::reader(std::string_view /*model*/) const {
  return std::make_unique<SocketCanReader>();
}

}  // namespace polyport::socketcan
