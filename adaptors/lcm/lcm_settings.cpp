// Reads the LCM model's elements of a component profile, each problem at its place.
#include "lcm_settings.hpp"

#include "polyport/profile/profile_text.hpp"

namespace polyport::lcm {

namespace {

using text::in_quotes;

const std::vector<ElementRule> kLcmRules = {
    {"url", {"url", "provider"}},
    {"max_message_bytes", {"max_message_bytes"}},
    max_calls_rule(),
    call_timeout_rule(),
    receive_thread_rule(),
};
// 2^28 bytes: the largest message LCM's UDP multicast provider reassembles.
constexpr std::uint32_t kMaxMessageBytes = 1U << 28;

// The providers LCM 1.3 has and polyport accepts: udpm (UDP multicast, the default), memq
// (in-process), file (a log file, read or written).
bool known_provider(std::string_view url) {
  for (const std::string_view scheme : {"udpm://", "memq://", "file://"}) {
    if (url.starts_with(scheme)) return true;
  }
  return false;
}

// A channel is matched by LCM as an anchored regular expression; polyport subscribes to it
// literally (escaped), so any printable text without blanks is a channel.
}  // namespace

std::string bad_channel(std::string_view channel) {
  if (channel.empty()) return "empty <channel>";
  if (channel.size() > kMaxChannelLength) {
    return "channel " + in_quotes(channel) + " is longer than LCM's " + std::to_string(kMaxChannelLength) +
           " characters";
  }
  for (const char c : channel) {
    if (c <= ' ' || c == 0x7f) return "channel " + in_quotes(channel) + " has a blank or control character";
  }
  return {};
}

namespace {

class LcmReader final : public ComponentSectionReader {
 public:
  void read_component_element(const ProfileElement& element) override {
    settings_->where = element.location();
    const ProfileChildren children = element.children(kLcmRules);
    if (const ProfileElement url = children.one("url")) {
      const std::string written = url.text();
      if (!known_provider(written)) {
        url.error_text("bad LCM provider URL " + in_quotes(written) +
                       " (accepted: udpm://GROUP:PORT?ttl=N, memq://, file://PATH?mode=r|w)");
      } else {
        settings_->url = written;
      }
    }
    if (const ProfileElement max = children.one("max_message_bytes")) {
      const std::string written = max.text();
      const auto value = text::parse_integer<std::uint32_t>(written);
      if (!value || *value < 8 || *value > kMaxMessageBytes) {
        max.error_text("bad max_message_bytes " + in_quotes(written) + ": expected an integer from 8 to " +
                       std::to_string(kMaxMessageBytes));
      } else {
        settings_->max_message_bytes = *value;
      }
    }
    read_call_limits(children, *settings_);
    settings_->receive_thread = read_receive_thread(children);
  }

  void read_port(const PortSpec& port, const ProfileChildren& elements) override {
    const ProfileElement channel = elements.one("channel");
    if (!channel) return;
    const std::string written = channel.text();
    if (const std::string why = bad_channel(written); !why.empty()) {
      channel.error_text(why);
      return;
    }
    settings_->channels.emplace(port.name, written);
  }

  void read_operation(const PortSpec& port, const OperationSpec& operation, const ProfileElement& element,
                      std::vector<TypeUse>& uses) override {
    OperationSettings op{element.attribute("lcm_request"), element.attribute("lcm_reply"),
                         element.attribute("lcm_request_channel"), element.attribute("lcm_reply_channel")};
    if (op.request_type.empty()) {
      element.error("missing attribute 'lcm_request': the struct an LCM application publishes on the request "
                    "channel (a polyport.rpc_request_header_t, then the request)");
    }
    if (!operation.oneway && op.reply_type.empty()) {
      element.error("missing attribute 'lcm_reply': the struct an LCM application publishes on the reply "
                    "channel (a polyport.rpc_reply_header_t, then the reply)");
    }
    for (const std::string_view attribute : {"lcm_reply", "lcm_reply_channel"}) {
      if (operation.oneway && element.has_attribute(attribute)) {
        element.error_attribute(attribute, "a oneway operation has no reply");
      }
    }
    for (const std::string_view attribute : {"lcm_request_channel", "lcm_reply_channel"}) {
      if (!element.has_attribute(attribute)) continue;
      if (const std::string why = bad_channel(element.attribute(attribute)); !why.empty()) {
        element.error_attribute(attribute, why);
      }
    }
    for (const std::string_view attribute : {"lcm_request", "lcm_reply"}) {
      const std::string& name = attribute == "lcm_request" ? op.request_type : op.reply_type;
      if (name.empty()) continue;
      uses.push_back({name, element.attribute_location(attribute), element.attribute_path(attribute)});
    }
    settings_->operations[port.name].emplace(operation.name, std::move(op));  // a repeated name: the first counts
  }

  std::shared_ptr<const ModelSettings> finish() override { return settings_; }

 private:
  std::shared_ptr<LcmSettings> settings_ = std::make_shared<LcmSettings>();
};

}  // namespace

std::string LcmSettings::channel(std::string_view port) const {
  const auto it = channels.find(port);
  return it != channels.end() ? it->second : std::string(port);
}

const OperationSettings* LcmSettings::operation(std::string_view port, std::string_view name) const {
  const auto it = operations.find(port);
  if (it == operations.end()) return nullptr;
  const auto op = it->second.find(name);
  return op == it->second.end() ? nullptr : &op->second;
}

std::shared_ptr<const LcmSettings> lcm_settings(const ComponentProfile& profile) {
  if (auto settings = std::dynamic_pointer_cast<const LcmSettings>(profile.model_settings)) return settings;
  static const auto kDefaults = std::make_shared<const LcmSettings>();
  return kDefaults;
}

const ModelVocabulary& LcmSection::vocabulary() const noexcept {
  static const ModelVocabulary kVocabulary{
      {"lcm"}, {"channel"}, {"lcm_request", "lcm_reply", "lcm_request_channel", "lcm_reply_channel"}};
  return kVocabulary;
}

std::unique_ptr<ComponentSectionReader> LcmSection::reader(std::string_view /*model*/) const {
  return std::make_unique<LcmReader>();
}

}  // namespace polyport::lcm
