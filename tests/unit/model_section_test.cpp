// A model the loader has never heard of reads its own profile elements through its section
// (model_section.hpp), with no change to core: the elements reach its reader with their
// locations, its settings come back in the component profile, the type names it reports are
// checked like core's, and on a component of another model its elements are ignored with a
// warning after it has checked them.

#include <gtest/gtest.h>

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "dds_model.hpp"
#include "polyport/profile/model_section.hpp"
#include "polyport/profile/profile.hpp"
#include "polyport/runtime/model.hpp"
#include "polyport/types/types.hpp"

namespace polyport {
namespace {

namespace fs = std::filesystem;

struct ProbeSettings final : ModelSettings {
  int rate = 1;
  std::map<std::string, std::string> channels;  // port -> channel
  std::map<std::string, std::string> replies;   // operation -> reply type
  std::vector<std::string> ports_seen;
};

class ProbeReader final : public ComponentSectionReader {
 public:
  void read_component_element(const ProfileElement& element) override {
    const ProfileChildren children = element.children({{"rate", {"rate"}}});
    if (const ProfileElement rate = children.one("rate")) {
      const auto value = text::parse_integer<int>(rate.text());
      if (!value) {
        rate.error_text("bad rate " + text::in_quotes(rate.text()));
      } else {
        settings_->rate = *value;
      }
    }
  }
  void read_port(const PortSpec& port, const ProfileChildren& elements) override {
    settings_->ports_seen.push_back(port.name);
    if (const ProfileElement channel = elements.one("channel")) settings_->channels[port.name] = channel.text();
  }
  void read_operation(const PortSpec&, const OperationSpec& operation, const ProfileElement& element,
                      std::vector<TypeUse>& uses) override {
    const std::string reply = element.attribute("probe_reply");
    settings_->replies[operation.name] = reply;
    uses.push_back({reply, element.attribute_location("probe_reply"), element.attribute_path("probe_reply")});
  }
  std::shared_ptr<const ModelSettings> finish() override { return settings_; }

 private:
  std::shared_ptr<ProbeSettings> settings_ = std::make_shared<ProbeSettings>();
};

class ProbeSection final : public ModelSection {
 public:
  const ModelVocabulary& vocabulary() const noexcept override {
    static const ModelVocabulary kVocabulary{{"probe"}, {"channel"}, {"probe_reply"}};
    return kVocabulary;
  }
  std::unique_ptr<ComponentSectionReader> reader(std::string_view) const override {
    return std::make_unique<ProbeReader>();
  }
};

class ProbeModel final : public Model {
 public:
  std::string_view name() const noexcept override { return "probe"; }
  const ModelSection* profile_section() const noexcept override { return &section_; }
  std::optional<Proxy> create_proxy(const Subcomponent&, ModelContext&, Diagnostics&) override {
    return std::nullopt;
  }

 private:
  ProbeSection section_;
};

fs::path data_dir() { return fs::weakly_canonical(fs::path(POLYPORT_TEST_DATA) / "profiles" / "sections"); }

class ModelSectionTest : public ::testing::Test {
 protected:
  ModelSectionTest() {
    models_.add(std::make_unique<dds::DdsModel>("cyclonedds", dds::DdsModel::DomainFactory(), ""));
    models_.add(std::make_unique<ProbeModel>());
    options_.models = &models_;
  }
  std::optional<ApplicationProfile> load(const std::string& file) {
    return load_application_profile(data_dir() / file, types_, options_, diagnostics_);
  }
  std::vector<std::string> messages() const {
    std::vector<std::string> out;
    const std::string prefix = data_dir().string() + "/";
    for (const Diagnostic& d : diagnostics_.all()) {
      std::string text = d.to_string();
      if (text.rfind(prefix, 0) == 0) text.erase(0, prefix.size());
      out.push_back(text);
    }
    return out;
  }

  ModelRegistry models_;
  LoadOptions options_;
  TypeRegistry types_;
  Diagnostics diagnostics_;
};

TEST_F(ModelSectionTest, ANewModelReadsItsOwnElements) {
  const auto app = load("section_app.xml");
  ASSERT_TRUE(app.has_value()) << ::testing::PrintToString(messages());
  // <topic> belongs to the DDS models: on a probe component it is ignored.
  EXPECT_EQ(messages(), (std::vector<std::string>{
      "Probe.xml:8:102: /component_profile/ports/data_port[2]/topic: warning: <topic> is ignored by model 'probe'",
  }));
  const auto settings = std::dynamic_pointer_cast<const ProbeSettings>(app->find_component("probe")->profile.model_settings);
  ASSERT_NE(settings, nullptr);
  EXPECT_EQ(settings->rate, 50);
  EXPECT_EQ(settings->channels, (std::map<std::string, std::string>{{"out", "POSE"}, {"in", "IN"}}));
  EXPECT_EQ(settings->ports_seen, (std::vector<std::string>{"out", "in", "svc"}));  // every port, in order
  EXPECT_EQ(settings->replies, (std::map<std::string, std::string>{{"op", "q::Pose"}}));
}

TEST_F(ModelSectionTest, AnotherModelsElementsAreCheckedThenIgnored) {
  EXPECT_FALSE(load("mixed_app.xml").has_value());
  EXPECT_EQ(messages(), (std::vector<std::string>{
      "DdsWithProbe.xml:5:3: /component_profile/probe: warning: <probe> is ignored by model 'cyclonedds'",
      "DdsWithProbe.xml:5:16: /component_profile/probe/rate: bad rate 'fast'",
      "DdsWithProbe.xml:7:83: /component_profile/ports/data_port/channel: warning: <channel> is ignored by model "
      "'cyclonedds'",
  }));
}

TEST_F(ModelSectionTest, WithoutTheModelItsElementsAreUnknown) {
  options_.models = nullptr;
  const auto app = load("section_app.xml");
  ASSERT_TRUE(app.has_value());
  const std::vector<std::string> all = messages();
  ASSERT_EQ(all.size(), 5u) << ::testing::PrintToString(all);
  EXPECT_EQ(all[0], "Probe.xml:5:3: /component_profile/probe: warning: unknown element <probe>");
  EXPECT_EQ(app->find_component("probe")->profile.model_settings, nullptr);
}

TEST_F(ModelSectionTest, TypeNamesAModelReportsAreCheckedLikeCores) {
  // probe_reply names a type: a name the registry does not know is reported at the attribute.
  const fs::path dir = fs::temp_directory_path() / ("polyport_section_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  std::string probe;
  {
    std::ifstream in(data_dir() / "Probe.xml");
    probe.assign(std::istreambuf_iterator<char>(in), {});
  }
  const std::string written = "probe_reply=\"q::Pose\"";
  ASSERT_NE(probe.find(written), std::string::npos);
  probe.replace(probe.find(written), written.size(), "probe_reply=\"q::None\"");
  std::ofstream(dir / "Probe.xml") << probe;
  std::ofstream(dir / "app.xml") << "<application_profile><name>a</name><types><file>"
                                 << (data_dir().parent_path() / "dds" / "types.idl").string()
                                 << "</file></types><subcomponents><subcomponent><name>probe</name>"
                                    "<reference>Probe.xml</reference></subcomponent></subcomponents>"
                                    "</application_profile>";
  EXPECT_FALSE(load_application_profile(dir / "app.xml", types_, options_, diagnostics_).has_value());
  std::vector<std::string> errors;
  for (const Diagnostic& d : diagnostics_.all()) {
    if (d.severity == Severity::error) errors.push_back(d.path + ": " + d.message);
  }
  EXPECT_EQ(errors, (std::vector<std::string>{
      "/component_profile/ports/service_port/operation/@probe_reply: unknown type 'q::None'"}));
  fs::remove_all(dir);
}

}  // namespace
}  // namespace polyport
