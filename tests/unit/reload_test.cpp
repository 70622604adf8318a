// Reloading profiles below the admin socket: the difference between two applications
// (daemon/reload.hpp), the refusal of a changed type, and Engine::apply on a running engine:
// what changed is made or taken away while the rest runs, and a reload that fails anywhere
// leaves the running graph as it was.
#include <gtest/gtest.h>

#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "inproc_model.hpp"
#include "polyport/runtime/engine.hpp"
#include "reload.hpp"
#include "../support/engine_fixture.hpp"
#include "../support/eventually.hpp"

namespace polyport {
namespace {

namespace fs = std::filesystem;
using test::eventually;

// ---------------------------------------------------------------------------------------
// The difference, on applications made by hand: only names and definitions matter.

Subcomponent component(const std::string& name, const std::string& definition) {
  Subcomponent c;
  c.name = name;
  c.definition = definition;
  return c;
}

ConnectionSpec connection(const std::string& from, const std::string& to, const std::string& definition,
                          PortKind kind = PortKind::data) {
  ConnectionSpec c;
  c.kind = kind;
  c.source = {from.substr(0, from.find('.')), from.substr(from.find('.') + 1), {}, {}};
  c.target = {to.substr(0, to.find('.')), to.substr(to.find('.') + 1), {}, {}};
  c.definition = definition;
  return c;
}

TEST(ReloadDiff, NamesWhatWasAddedRemovedAndChanged) {
  ApplicationProfile running, next;
  running.components = {component("a", "A"), component("b", "B"), component("gone", "G")};
  running.connections = {connection("a.out", "b.in", "1"), connection("b.out", "a.in", "2"),
                         connection("gone.out", "a.in", "3")};
  next.components = {component("a", "A"), component("b", "B changed"), component("new", "N")};
  next.connections = {connection("a.out", "b.in", "1"), connection("b.out", "a.in", "2"),
                      connection("new.out", "a.in", "4"), connection("a.out", "a.in", "5")};
  const Result<daemon::GraphDiff> d = daemon::diff(running, next);
  ASSERT_TRUE(d) << d.error().message;
  const daemon::GraphDiff& diff = d.value();
  EXPECT_EQ(diff.components_added, std::vector<std::string>{"new"});
  EXPECT_EQ(diff.components_removed, std::vector<std::string>{"gone"});
  EXPECT_EQ(diff.components_changed, std::vector<std::string>{"b"});
  EXPECT_EQ(diff.connections_added, (std::vector<std::string>{"new.out -> a.in", "a.out -> a.in"}));
  EXPECT_EQ(diff.connections_removed, std::vector<std::string>{"gone.out -> a.in"});
  // Unchanged in the profile, but b is replaced: both of its connections are made again.
  EXPECT_EQ(diff.connections_changed, (std::vector<std::string>{"a.out -> b.in", "b.out -> a.in"}));
  EXPECT_EQ(diff.change.components_in.size(), 2u);
  EXPECT_EQ(diff.change.components_out, (std::vector<std::string>{"b", "gone"}));
  EXPECT_EQ(diff.change.connections_in.size(), 4u);
  EXPECT_EQ(diff.change.connections_out.size(), 3u);
  EXPECT_FALSE(diff.empty());

  const Result<daemon::GraphDiff> same = daemon::diff(running, running);
  ASSERT_TRUE(same);
  EXPECT_TRUE(same.value().empty());
  EXPECT_TRUE(same.value().change.components_in.empty() && same.value().change.connections_out.empty());
}

TEST(ReloadDiff, AConnectionChangesWithItsWatchdogsComponents) {
  ApplicationProfile running;
  running.components = {component("a", "A"), component("b", "B"), component("watch", "W")};
  ConnectionSpec watched = connection("a.out", "b.in", "1");
  watched.watchdog = WatchdogSpec{};
  watched.watchdog->event = ConnectionEnd{"watch", "events", {}, {}};
  running.connections = {watched};
  ApplicationProfile next = running;
  next.components[2].definition = "W changed";
  const Result<daemon::GraphDiff> d = daemon::diff(running, next);
  ASSERT_TRUE(d);
  EXPECT_EQ(d.value().connections_changed, std::vector<std::string>{"a.out -> b.in"});
}

TEST(ReloadDiff, ServiceConnectionsChangeLikeTheOthers) {
  ApplicationProfile running;
  running.components = {component("caller", "C"), component("adder", "A")};
  running.connections = {connection("caller.calc", "adder.calc", "s", PortKind::service)};
  ApplicationProfile next = running;
  next.components[1].definition = "A changed";  // its provider replaced: the caller is bound anew
  Result<daemon::GraphDiff> d = daemon::diff(running, next);
  ASSERT_TRUE(d) << d.error().message;
  EXPECT_EQ(d.value().connections_changed, std::vector<std::string>{"caller.calc -> adder.calc"});
  next = running;
  next.connections.clear();
  d = daemon::diff(running, next);
  ASSERT_TRUE(d) << d.error().message;
  EXPECT_EQ(d.value().connections_removed, std::vector<std::string>{"caller.calc -> adder.calc"});
}

TEST(ReloadTypes, ATypeOfAnotherShapeIsRefused) {
  TypeRegistry live, same, other;
  Diagnostics diagnostics;
  ASSERT_TRUE(live.add_idl_text("module m { struct P { long x; double y; }; };", "live.idl", diagnostics));
  ASSERT_TRUE(same.add_idl_text("// a comment moves nothing\nmodule m { struct P { long x; double y; }; struct Q { long z; }; };",
                                "same.idl", diagnostics));
  ASSERT_TRUE(other.add_idl_text("module m {\n struct P { long x; float y; }; };", "other.idl", diagnostics));
  EXPECT_EQ(daemon::changed_type(live, same), std::nullopt);
  const std::optional<std::string> changed = daemon::changed_type(live, other);
  ASSERT_TRUE(changed);
  EXPECT_NE(changed->find("other.idl:2:"), std::string::npos) << *changed;
  EXPECT_NE(changed->find("type 'm::P' differs from the one the daemon runs with"), std::string::npos) << *changed;

  // A type added to a file the daemon read is refused (the file is not read again); a type in
  // a new file is fine.
  TypeRegistry grown;
  ASSERT_TRUE(grown.add_idl_text("module m { struct P { long x; double y; }; struct R { long r; }; };", "live.idl",
                                 diagnostics));
  const std::optional<std::string> added = daemon::changed_type(live, grown);
  ASSERT_TRUE(added);
  EXPECT_NE(added->find("type 'm::R' is new in a file the daemon read at start"), std::string::npos) << *added;
}

// ---------------------------------------------------------------------------------------
// A running engine (tests/data/engine's in-process components) reloaded from a profile the
// test rewrites.

class ReloadEngine : public test::EngineFixture {
 protected:
  ReloadEngine() : EngineFixture(POLYPORT_TEST_DATA "/engine", LoadOptions{{POLYPORT_PLUGIN_DIR}}) {
    models.add(std::make_unique<inproc::InprocModel>());
    options.models = &models;
  }
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() / ("polyport-reload-" + std::to_string(getpid()) + "-" + info->name());
    fs::create_directories(dir_);
  }
  void TearDown() override {
    engine.stop();
    if (!HasFailure()) fs::remove_all(dir_);
  }
  // Writes the application profile: these subcomponents (name, component profile in
  // tests/data/engine) and connections (the elements as written).
  void write(const std::vector<std::pair<std::string, std::string>>& components, const std::string& connections) {
    std::ofstream out(file());
    out << "<?xml version=\"1.0\"?>\n<application_profile>\n  <name>reloaded</name>\n  <subcomponents>\n";
    for (const auto& [name, reference] : components) {
      const std::string path = reference.front() == '/' ? reference : POLYPORT_TEST_DATA "/engine/" + reference;
      out << "    <subcomponent><name>" << name << "</name><reference>" << path << "</reference></subcomponent>\n";
    }
    out << "  </subcomponents>\n  <port_connections>\n" << connections << "  </port_connections>\n</application_profile>\n";
  }
  fs::path file() const { return dir_ / "app.xml"; }
  // A copy of Tunable.xml with another `step`, in the test's folder; its path.
  std::string tunable(std::int64_t step) const {
    std::ifstream in(POLYPORT_TEST_DATA "/engine/Tunable.xml");
    std::stringstream text;
    text << in.rdbuf();
    std::string s = text.str();
    s.replace(s.find(">1</property>"), 13, ">" + std::to_string(step) + "</property>");
    s.replace(s.find("<file>test.idl"), 14, "<file>" POLYPORT_TEST_DATA "/engine/test.idl");
    const fs::path copy = dir_ / "Tunable.xml";
    std::ofstream(copy) << s;
    return copy.string();
  }
  static std::string data(const std::string& from, const std::string& to, const std::string& attributes = "") {
    const auto dot = [](const std::string& s) { return s.find('.'); };
    return "    <port_connection port_type=\"data\"" + attributes + ">\n      <source component_name=\"" +
           from.substr(0, dot(from)) + "\" port_name=\"" + from.substr(dot(from) + 1) +
           "\"/>\n      <target component_name=\"" + to.substr(0, dot(to)) + "\" port_name=\"" +
           to.substr(dot(to) + 1) + "\"/>\n    </port_connection>\n";
  }
  // Builds and starts the engine from the profile as written now.
  void start() {
    auto loaded = read(types, diagnostics);
    ASSERT_TRUE(loaded) << problems();
    application = std::move(*loaded);
    ASSERT_TRUE(engine.build(application, diagnostics)) << problems();
    std::vector<std::string> warnings;
    ASSERT_TRUE(engine.start(warnings));
  }
  Result<nlohmann::json> reload() {
    std::vector<std::string> warnings;
    return daemon::reload(engine, types, application, read, {}, warnings);
  }
  // "Source.port -> Target.port" of every connection the engine runs.
  std::vector<std::string> running() const {
    std::vector<std::string> out;
    for (const auto& c : engine.connections()) out.push_back(c->source().full_name() + " -> " + c->target().full_name());
    return out;
  }
  // Each running execution context's members, as `describe` lists them.
  std::vector<std::vector<std::string>> contexts() const {
    nlohmann::json graph;
    engine.describe(graph);
    std::vector<std::vector<std::string>> out;
    for (const auto& c : graph["execution_contexts"]) out.push_back(c.value("members", std::vector<std::string>{}));
    return out;
  }
  std::size_t running_contexts() const {
    return static_cast<std::size_t>(std::count_if(engine.executors().contexts().begin(), engine.executors().contexts().end(),
                                                  [](const auto& c) { return c->running(); }));
  }
  LoadOptions options{{POLYPORT_PLUGIN_DIR}};
  ApplicationProfile application;
  daemon::ProfileReader read = [this](TypeRegistry& into, Diagnostics& found) {
    return load_application_profile(file(), into, options, found);
  };

 private:
  fs::path dir_;
};

TEST_F(ReloadEngine, ConnectionsAndComponentsComeAndGoWhileTheRestRuns) {
  write({{"ticker", "Ticker.xml"}, {"collector", "Collector.xml"}}, data("ticker.count", "collector.in"));
  ASSERT_NO_FATAL_FAILURE(start());
  const Connection* kept = engine.connections().front().get();
  // A second ticker and its connection: a component added while the application runs.
  write({{"ticker", "Ticker.xml"}, {"collector", "Collector.xml"}, {"ticker2", "Ticker.xml"}},
        data("ticker.count", "collector.in") + data("ticker2.count", "collector.in"));
  Result<nlohmann::json> done = reload();
  ASSERT_TRUE(done) << done.error().message;
  EXPECT_EQ(done.value()["components"]["added"], nlohmann::json::array({"ticker2"}));
  EXPECT_EQ(done.value()["connections"]["added"], nlohmann::json::array({"ticker2.count -> collector.in"}));
  EXPECT_EQ(running(), (std::vector<std::string>{"ticker.count -> collector.in", "ticker2.count -> collector.in"}));
  EXPECT_EQ(engine.connections().front().get(), kept) << "an unchanged connection is the same connection";
  const Connection* added = engine.connections().back().get();
  ASSERT_NE(engine.find_interceptor("ticker2"), nullptr);
  EXPECT_EQ(engine.find_interceptor("ticker2")->status().state, "active");
  // The new ticker runs on an execution context of its own: its samples arrive.
  EXPECT_TRUE(eventually([&] { return added->counters().received.load() > 3; })) << "ticker2 does not run";
  const std::uint64_t before = kept->counters().delivered.load();
  EXPECT_TRUE(eventually([&] { return kept->counters().delivered.load() > before; })) << "the kept connection stopped";

  // The first ticker leaves, and its connection with it.
  write({{"collector", "Collector.xml"}, {"ticker2", "Ticker.xml"}}, data("ticker2.count", "collector.in"));
  done = reload();
  ASSERT_TRUE(done) << done.error().message;
  EXPECT_EQ(done.value()["components"]["removed"], nlohmann::json::array({"ticker"}));
  EXPECT_EQ(done.value()["connections"]["removed"], nlohmann::json::array({"ticker.count -> collector.in"}));
  EXPECT_EQ(engine.find_component("ticker"), nullptr);
  EXPECT_EQ(running(), std::vector<std::string>{"ticker2.count -> collector.in"});
  EXPECT_EQ(application.components.size(), 2u) << "the application is the new one";

  // Nothing changed: nothing is done.
  done = reload();
  ASSERT_TRUE(done) << done.error().message;
  EXPECT_TRUE(done.value()["unchanged"].get<bool>());
  EXPECT_EQ(engine.connections().front().get(), added);
}

TEST_F(ReloadEngine, AChangedConnectionIsMadeAgainWithItsNewPolicy) {
  write({{"ticker", "Ticker.xml"}, {"collector", "Collector.xml"}}, data("ticker.count", "collector.in"));
  ASSERT_NO_FATAL_FAILURE(start());
  EXPECT_EQ(engine.connections().front()->policy(), QueuePolicy::buffer);
  write({{"ticker", "Ticker.xml"}, {"collector", "Collector.xml"}},
        data("ticker.count", "collector.in", " policy=\"circular\" depth=\"4\""));
  const Result<nlohmann::json> done = reload();
  ASSERT_TRUE(done) << done.error().message;
  EXPECT_EQ(done.value()["connections"]["changed"], nlohmann::json::array({"ticker.count -> collector.in"}));
  ASSERT_EQ(engine.connections().size(), 1u);
  EXPECT_EQ(engine.connections().front()->policy(), QueuePolicy::circular);
  EXPECT_EQ(engine.connections().front()->depth(), 4u);
}

TEST_F(ReloadEngine, ABrokenProfileChangesNothing) {
  write({{"ticker", "Ticker.xml"}, {"collector", "Collector.xml"}}, data("ticker.count", "collector.in"));
  ASSERT_NO_FATAL_FAILURE(start());
  const Connection* kept = engine.connections().front().get();
  // A new component, and a connection to a port that does not exist (line 16 of the file).
  write({{"ticker", "Ticker.xml"}, {"collector", "Collector.xml"}, {"ticker2", "Ticker.xml"}},
        data("ticker.count", "collector.in") + data("ticker2.count", "collector.nothing"));
  const Result<nlohmann::json> done = reload();
  ASSERT_FALSE(done);
  EXPECT_NE(done.error().message.find(file().string() + ":16:7: /application_profile/port_connections/port_connection[2]/target"), std::string::npos) << done.error().message;
  EXPECT_NE(done.error().message.find("no port 'nothing'"), std::string::npos) << done.error().message;
  EXPECT_EQ(engine.find_component("ticker2"), nullptr);
  EXPECT_EQ(running(), std::vector<std::string>{"ticker.count -> collector.in"});
  EXPECT_EQ(engine.connections().front().get(), kept);
  EXPECT_EQ(application.components.size(), 2u) << "the application is the old one";
  const std::uint64_t before = kept->counters().delivered.load();
  EXPECT_TRUE(eventually([&] { return kept->counters().delivered.load() > before; })) << "the kept connection stopped";
}

TEST_F(ReloadEngine, AComponentThatCannotBeMadeIsRefused) {
  write({{"ticker", "Ticker.xml"}, {"collector", "Collector.xml"}}, data("ticker.count", "collector.in"));
  ASSERT_NO_FATAL_FAILURE(start());
  // WrongSize's port is declared with another C++ type than its profile's: no proxy.
  write({{"ticker", "Ticker.xml"}, {"collector", "Collector.xml"}, {"wrong", "WrongSize.xml"}},
        data("ticker.count", "collector.in") + data("wrong.count", "collector.in"));
  const Result<nlohmann::json> done = reload();
  ASSERT_FALSE(done);
  EXPECT_NE(done.error().message.find("WrongSize.xml:"), std::string::npos) << done.error().message;
  EXPECT_NE(done.error().message.find("component class 'WrongSize' uses a C++ type of size 4"), std::string::npos)
      << done.error().message;
  EXPECT_EQ(engine.find_component("wrong"), nullptr);
  EXPECT_EQ(running(), std::vector<std::string>{"ticker.count -> collector.in"});
  EXPECT_EQ(application.components.size(), 2u);
}

TEST_F(ReloadEngine, AChangedComponentIsReplacedAndOneThatDoesNotStartIsTakenBack) {
  write({{"tunable", tunable(1)}, {"collector", "Collector.xml"}}, data("tunable.step", "collector.in"));
  ASSERT_NO_FATAL_FAILURE(start());
  using Members = std::vector<std::vector<std::string>>;
  EXPECT_EQ(contexts(), (Members{{"tunable", "collector"}})) << "one context of the same period";
  Interceptor* first = engine.find_interceptor("tunable");
  // Its profile now says step 7: a new instance with the new value, its connection made again.
  write({{"tunable", tunable(7)}, {"collector", "Collector.xml"}}, data("tunable.step", "collector.in"));
  Result<nlohmann::json> done = reload();
  ASSERT_TRUE(done) << done.error().message;
  EXPECT_EQ(done.value()["components"]["changed"], nlohmann::json::array({"tunable"}));
  EXPECT_EQ(done.value()["connections"]["changed"], nlohmann::json::array({"tunable.step -> collector.in"}));
  Interceptor* second = engine.find_interceptor("tunable");
  ASSERT_NE(second, nullptr);
  EXPECT_NE(second, first);
  EXPECT_EQ(first->status().state, "finalized") << "the old instance stopped";
  EXPECT_EQ(second->status().state, "active");
  ASSERT_NE(second->properties(), nullptr);
  EXPECT_EQ(second->properties()->at("step"), "7");
  const Connection* remade = engine.connections().front().get();
  EXPECT_TRUE(eventually([&] { return remade->counters().received.load() > 3; })) << "the new instance does not run";
  // The collector's context runs on without the old instance; the new one has its own.
  EXPECT_EQ(contexts(), (Members{{"collector"}, {"tunable"}}));
  EXPECT_EQ(running_contexts(), 2u);

  // step -1 fails its initialization: the running instance stays, with its connection.
  write({{"tunable", tunable(-1)}, {"collector", "Collector.xml"}}, data("tunable.step", "collector.in"));
  done = reload();
  ASSERT_FALSE(done);
  EXPECT_NE(done.error().message.find("component 'tunable' did not start"), std::string::npos) << done.error().message;
  EXPECT_EQ(engine.find_interceptor("tunable"), second);
  EXPECT_EQ(second->status().state, "active");
  ASSERT_EQ(engine.connections().size(), 1u);
  EXPECT_EQ(engine.connections().front().get(), remade);
  const std::uint64_t before = remade->counters().received.load();
  EXPECT_TRUE(eventually([&] { return remade->counters().received.load() > before; })) << "the kept instance stopped";
  EXPECT_EQ(contexts(), (Members{{"collector"}, {"tunable"}})) << "the failed instance's context is gone";
  EXPECT_EQ(running_contexts(), 2u);

  // Replaced again: the context the replaced instance had alone is retired, its thread ends.
  write({{"tunable", tunable(9)}, {"collector", "Collector.xml"}}, data("tunable.step", "collector.in"));
  done = reload();
  ASSERT_TRUE(done) << done.error().message;
  EXPECT_EQ(contexts(), (Members{{"collector"}, {"tunable"}}));
  EXPECT_EQ(running_contexts(), 2u);
}

}  // namespace
}  // namespace polyport
