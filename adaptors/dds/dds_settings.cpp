// Reads the DDS models' elements of a component profile. Every problem is reported where it
// is written, and reading goes on, exactly as the loader does with core's elements.
#include "dds_settings.hpp"

#include <system_error>

#include "polyport/profile/call_limits.hpp"
#include "polyport/profile/profile_text.hpp"

namespace polyport::dds {

namespace {

using text::in_quotes;
using text::Spelling;
namespace fs = std::filesystem;

const std::vector<ElementRule> kDdsRules = {
    {"domain", {"domain"}},
    {"config", {"config"}},
    {"qos", {"qos"}},
    max_calls_rule(),
    call_timeout_rule(),
    receive_thread_rule(),
};
const std::vector<ElementRule> kQosRules = {
    {"reliability", {"reliability"}},
    {"durability", {"durability"}},
    {"history", {"history"}},
    {"depth", {"depth"}},
    {"deadline", {"deadline_ms"}},
    {"lifespan", {"lifespan_ms"}},
    {"liveliness", {"liveliness"}},
    {"lease", {"lease_ms"}},
    {"partition", {"partition"}, true},
    {"data_sharing", {"data_sharing"}},
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
constexpr Spelling<DdsQos::DataSharing> kDataSharings[] = {
    {"auto", DdsQos::DataSharing::automatic},
    {"off", DdsQos::DataSharing::off},
};
// DDS domain ids: 0..232 (the RTPS port mapping with its default parameters).
constexpr std::uint32_t kMaxDomain = 232;

// <qos>: each child present overrides that field of `qos` (the component's defaults, or
// the model's).
void read_qos(const ProfileElement& element, std::string_view model, DdsQos& qos) {
  const ProfileChildren children = element.children(kQosRules);
  if (const auto node = children.one("reliability")) {
    if (auto value = enum_text(node, kReliabilities, "reliability")) qos.reliability = *value;
  }
  if (const auto node = children.one("durability")) {
    if (auto value = enum_text(node, kDurabilities, "durability")) qos.durability = *value;
  }
  if (const auto node = children.one("history")) {
    if (auto value = enum_text(node, kHistories, "history")) qos.history = *value;
  }
  if (const auto node = children.one("depth")) {
    const std::string written = node.text();
    const auto value = text::parse_integer<std::int32_t>(written);
    if (!value || *value <= 0) {
      node.error_text("bad history depth " + in_quotes(written) + ": expected an integer from 1 to 2147483647");
    } else {
      qos.depth = *value;
    }
  }
  if (const auto node = children.one("deadline")) {
    if (const auto ns = milliseconds_text(node, "deadline_ms")) qos.deadline_ns = *ns > 0 ? ns : std::nullopt;
  }
  if (const auto node = children.one("lifespan")) {
    if (const auto ns = milliseconds_text(node, "lifespan_ms")) qos.lifespan_ns = *ns > 0 ? ns : std::nullopt;
  }
  if (const auto node = children.one("liveliness")) {
    if (auto value = enum_text(node, kLivelinesses, "liveliness")) qos.liveliness = *value;
  }
  if (const auto node = children.one("lease")) {
    if (const auto ns = milliseconds_text(node, "lease_ms")) qos.lease_ns = *ns > 0 ? ns : std::nullopt;
  }
  if (!children.all("partition").empty()) qos.partitions.clear();  // a port's list replaces the component's
  for (const ProfileElement& node : children.all("partition")) qos.partitions.push_back(node.text());
  if (const auto node = children.one("data_sharing")) {
    if (auto value = enum_text(node, kDataSharings, "data_sharing")) {
      if (model == "fastdds") {
        qos.data_sharing = *value;
      } else {
        node.warning("data_sharing is a Fast DDS setting: ignored");
      }
    }
  }
  if (qos.deadline_ns && qos.lifespan_ns && *qos.lifespan_ns < *qos.deadline_ns) {
    // Legal in DDS, but samples then expire before the next is due: say so.
    element.warning("lifespan_ms is shorter than deadline_ms: readers may miss every deadline");
  }
}

class DdsReader final : public ComponentSectionReader {
 public:
  explicit DdsReader(std::string_view model) : model_(model) {}

  void read_component_element(const ProfileElement& dds) override {
    settings_->where = dds.location();
    const ProfileChildren children = dds.children(kDdsRules);
    if (const auto domain = children.one("domain")) {
      const std::string written = domain.text();
      const auto value = text::parse_integer<std::uint32_t>(written);
      if (!value || *value > kMaxDomain) {
        domain.error_text("bad DDS domain " + in_quotes(written) + ": expected an integer from 0 to " +
                          std::to_string(kMaxDomain));
      } else {
        settings_->domain = *value;
      }
    }
    if (const auto config = children.one("config")) {
      const std::string written = config.text();
      if (written.empty()) {
        settings_->config = fs::path();  // the SDK's own defaults
      } else {
        const fs::path file = text::absolute_path(config.folder() / written);
        settings_->config = file;
        std::error_code ec;
        if (!fs::is_regular_file(file, ec)) {
          config.error_text("DDS configuration file " + in_quotes(file.string()) + " not found");
        }
      }
    }
    if (const auto qos = children.one("qos")) read_qos(qos, model_, settings_->qos);
    read_call_limits(children, *settings_);
    settings_->receive_threads = read_receive_thread(children);
    if (const ProfileElement thread = children.one("receive_thread"); thread && settings_->receive_threads) {
      if (model_ == "fastdds") {
        thread.warning("Fast DDS 2.9 has no setting for the scheduling of its threads: ignored");
        settings_->receive_threads.reset();
      } else if (settings_->receive_threads->cpu) {
        thread.warning("Cyclone DDS 0.10 does not pin its threads: cpu ignored");
        settings_->receive_threads->cpu.reset();
      }
    }
  }

  void read_port(const PortSpec& port, const ProfileChildren& elements) override {
    PortSettings settings;
    settings.qos = settings_->qos;
    if (const auto topic = elements.one("topic")) {
      settings.topic = topic.text();
      if (settings.topic.empty()) topic.error("empty <topic>");
    }
    if (const auto qos = elements.one("qos")) read_qos(qos, model_, settings.qos);
    settings_->ports.emplace(port.name, std::move(settings));  // a repeated name: the first counts
  }

  void read_operation(const PortSpec& port, const OperationSpec& operation, const ProfileElement& element,
                      std::vector<TypeUse>& uses) override {
    OperationTypes types{element.attribute("dds_request"), element.attribute("dds_reply")};
    if (types.request_type.empty()) {
      element.error("missing attribute 'dds_request': the struct a DDS application writes on the "
                    "request topic (a polyport::rpc::RequestHeader, then the request)");
    }
    if (!operation.oneway && types.reply_type.empty()) {
      element.error("missing attribute 'dds_reply': the struct a DDS application writes on the "
                    "reply topic (a polyport::rpc::ReplyHeader, then the reply)");
    }
    if (operation.oneway && !types.reply_type.empty()) {
      element.error_attribute("dds_reply", "a oneway operation has no reply");
    }
    for (const std::string_view attribute : {"dds_request", "dds_reply"}) {
      const std::string& name = attribute == "dds_request" ? types.request_type : types.reply_type;
      if (name.empty()) continue;
      uses.push_back({name, element.attribute_location(attribute), element.attribute_path(attribute)});
    }
    const auto it = settings_->ports.find(port.name);
    if (it != settings_->ports.end()) it->second.operations.emplace(operation.name, std::move(types));
  }

  std::shared_ptr<const ModelSettings> finish() override {
    settings_->defaults.qos = settings_->qos;
    return settings_;
  }

 private:
  std::string model_;
  std::shared_ptr<DdsSettings> settings_ = std::make_shared<DdsSettings>();
};

}  // namespace

const OperationTypes* PortSettings::operation(std::string_view name) const {
  const auto it = operations.find(name);
  return it == operations.end() ? nullptr : &it->second;
}

const PortSettings& DdsSettings::port(std::string_view name) const {
  const auto it = ports.find(name);
  return it != ports.end() ? it->second : defaults;
}

std::shared_ptr<const DdsSettings> dds_settings(const ComponentProfile& profile) {
  if (auto settings = std::dynamic_pointer_cast<const DdsSettings>(profile.model_settings)) return settings;
  static const auto kDefaults = std::make_shared<const DdsSettings>();
  return kDefaults;
}

const ModelVocabulary& DdsSection::vocabulary() const noexcept {
  static const ModelVocabulary kVocabulary{{"dds"}, {"topic", "qos"}, {"dds_request", "dds_reply"}};
  return kVocabulary;
}

std::unique_ptr<ComponentSectionReader> DdsSection::reader(std::string_view model) const {
  return std::make_unique<DdsReader>(model);
}

}  // namespace polyport::dds
