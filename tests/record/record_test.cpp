// The recorder on an engine built from the in-process wheelchair profile and not started, so
// the test thread is the only writer: the hand-off on the forwarding path allocates nothing
// (counted on the writing thread, the recorder's writer running meanwhile); a tap that is not
// drained drops and counts while the connection goes on delivering; the log read back with
// liblcm's own reader holds the values written, in their flat layout (wheelchair.idl is not an
// LCM type), on the channel named after the connection; in-process samples of an LCM type
// (tests/record/data) are recorded LCM-encoded.
#include <gtest/gtest.h>
#include <lcm/eventlog.h>

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <unistd.h>

#include "../support/eventually.hpp"
#include "../support/malloc_counter.hpp"
#include "inproc_model.hpp"
#include "polyport/runtime/connection.hpp"
#include "polyport/runtime/engine.hpp"
#include "polyport/types/types.hpp"
#include "polyport/codecs/codec.hpp"
#include "recorder.hpp"

namespace polyport {
namespace {

namespace fs = std::filesystem;
using test::eventually;

struct Reference {  // wheelchair.idl's Reference, in-process layout
  double direction_deg;
  double speed_mps;
};

constexpr const char* kConnection = "Joystick.reference->Control.reference";

class Recording : public ::testing::Test {
 protected:
  void SetUp() override {
    models_.add(std::make_unique<inproc::InprocModel>());
    Diagnostics diagnostics;
    auto profile = load_application_profile(profile_path(), types_, LoadOptions{{POLYPORT_PLUGIN_DIR}}, diagnostics);
    ASSERT_TRUE(profile) << (diagnostics.all().empty() ? "" : diagnostics.all().front().to_string());
    engine_ = std::make_unique<Engine>(models_, types_);
    ASSERT_TRUE(engine_->build(*profile, diagnostics));
    out_ = dynamic_cast<DataOutPort*>(engine_->find_port(source_port()));
    ASSERT_NE(out_, nullptr);
    for (const auto& c : engine_->connections()) {
      if (&c->source() == out_) link_ = c.get();
    }
    ASSERT_NE(link_, nullptr);
    log_ = fs::temp_directory_path() /
           ("polyport-record-" + std::to_string(getpid()) + "-" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name() + ".lcmlog");
  }
  virtual const char* profile_path() const { return POLYPORT_SOURCE_DIR "/profiles/wheelchair_inproc.xml"; }
  virtual const char* source_port() const { return "Joystick.reference"; }
  void TearDown() override {
    if (engine_) engine_->stop();
    recorder_.stop();
    if (!HasFailure()) fs::remove(log_);
  }
  void write(int i) {
    const Reference r{static_cast<double>(i), i * 0.5};
    ASSERT_EQ(out_->write(&r, sizeof r), Status::ok);
  }
  nlohmann::json stats() const {
    nlohmann::json out;
    engine_->stats(out);
    recorder_.stats(out);
    return out;
  }
  // The events of the log, read with liblcm's reader.
  struct Event {
    std::string channel;
    std::int64_t timestamp_us;
    std::vector<std::byte> data;
  };
  std::vector<Event> events() const {
    std::vector<Event> out;
    lcm_eventlog_t* log = lcm_eventlog_create(log_.c_str(), "r");
    EXPECT_NE(log, nullptr) << log_;
    if (log == nullptr) return out;
    while (lcm_eventlog_event_t* e = lcm_eventlog_read_next_event(log)) {
      const auto* bytes = static_cast<const std::byte*>(e->data);
      out.push_back(Event{std::string(e->channel, static_cast<std::size_t>(e->channellen)), e->timestamp,
                          std::vector<std::byte>(bytes, bytes + e->datalen)});
      lcm_eventlog_free_event(e);
    }
    lcm_eventlog_destroy(log);
    return out;
  }
  // wheelchair.idl is not an LCM type: its samples are recorded in their flat layout.
  static Reference decode(const std::vector<std::byte>& flat) {
    Reference r{};
    EXPECT_EQ(flat.size(), sizeof r);
    if (flat.size() == sizeof r) std::memcpy(&r, flat.data(), sizeof r);
    return r;
  }

  TypeRegistry types_;
  ModelRegistry models_;
  std::unique_ptr<Engine> engine_;
  DataOutPort* out_ = nullptr;
  Connection* link_ = nullptr;
  fs::path log_;
  daemon::Recorder recorder_;
};

TEST_F(Recording, HandOffOnTheForwardingPathAllocatesNothing) {
  ASSERT_TRUE(recorder_.open(*engine_, log_.string(), {kConnection}, 64));
  recorder_.start();
  constexpr int kSamples = 20'000;
  const std::int64_t wall_before_us = wall_now().ns / 1000;
  const std::uint64_t before = test::g_polyport_allocations.load();
  for (int i = 0; i < kSamples; ++i) {
    test::Scope inside(true);  // this thread's writes: the forwarding path with its tap
    write(i);
  }
  const std::uint64_t during = test::g_polyport_allocations.load() - before;
  EXPECT_EQ(during, 0u) << "allocations on the writing thread over " << kSamples << " recorded samples";
  recorder_.stop();
  const std::int64_t wall_after_us = wall_now().ns / 1000;

  const nlohmann::json s = stats();
  const auto& r = s["recording"]["connections"][0];
  EXPECT_EQ(r["connection"], "Joystick.reference -> Control.reference");
  EXPECT_EQ(r["channel"], kConnection);
  EXPECT_EQ(r["encoding"], "flat");
  // Every sample that entered the tap was written or counted as dropped.
  EXPECT_EQ(r["recorded"].get<std::uint64_t>() + r["dropped"].get<std::uint64_t>(), static_cast<std::uint64_t>(kSamples));
  EXPECT_EQ(link_->counters().delivered.load(), static_cast<std::uint64_t>(kSamples));

  const std::vector<Event> log = events();
  ASSERT_EQ(log.size(), r["recorded"].get<std::size_t>());
  ASSERT_GT(log.size(), 0u);
  double last = -1;
  for (const Event& e : log) {
    EXPECT_EQ(e.channel, kConnection);
    EXPECT_GE(e.timestamp_us, wall_before_us - 1000);  // the monotonic stamp moved onto the epoch
    EXPECT_LE(e.timestamp_us, wall_after_us + 1000);
    const Reference value = decode(e.data);
    EXPECT_GT(value.direction_deg, last);  // in order, no repeats
    EXPECT_EQ(value.speed_mps, value.direction_deg * 0.5);
    last = value.direction_deg;
  }
  EXPECT_EQ(last, kSamples - 1);  // the last sample is never the one dropped
}

TEST_F(Recording, AWriterThatCannotKeepUpDropsAndCountsWhileForwardingGoesOn) {
  // Depth 4 and the writer not running: a writer that never keeps up.
  ASSERT_TRUE(recorder_.open(*engine_, log_.string(), {kConnection}, 4));
  std::uint64_t last_dropped = 0;
  for (int round = 1; round <= 5; ++round) {
    for (int i = 0; i < 100; ++i) write((round - 1) * 100 + i);
    const nlohmann::json s = stats();
    // The connection delivers every sample; the recording drops all but the tap's depth.
    EXPECT_EQ(link_->counters().delivered.load(), static_cast<std::uint64_t>(round * 100));
    EXPECT_EQ(link_->counters().dropped(), 0u);
    const std::uint64_t dropped = s["recording"]["record_dropped"].get<std::uint64_t>();
    EXPECT_EQ(dropped, static_cast<std::uint64_t>(round * 100 - 4));
    EXPECT_GT(dropped, last_dropped);
    last_dropped = dropped;
    for (const auto& c : s["connections"]) {
      if (c["name"] == "Joystick.reference -> Control.reference") {
        EXPECT_EQ(c["record_dropped"], dropped) << c.dump();
      }
    }
  }
  recorder_.stop();  // writes what the tap holds: the newest four
  const std::vector<Event> log = events();
  ASSERT_EQ(log.size(), 4u);
  for (std::size_t k = 0; k < 4; ++k) EXPECT_EQ(decode(log[k].data).direction_deg, 496.0 + static_cast<double>(k));
  EXPECT_EQ(stats()["recording"]["connections"][0]["recorded"], 4);
}

TEST_F(Recording, EveryDataConnectionWhenNoneIsChosen) {
  ASSERT_TRUE(recorder_.open(*engine_, log_.string(), {}, 16));
  const nlohmann::json s = stats();
  std::size_t data_connections = 0;
  for (const auto& c : engine_->connections()) data_connections += c->source().kind() == PortKind::data ? 1 : 0;
  ASSERT_GT(data_connections, 0u);
  ASSERT_EQ(s["recording"]["connections"].size(), data_connections);
  for (const auto& r : s["recording"]["connections"]) {
    std::string name = r["connection"].get<std::string>();
    name.erase(std::remove(name.begin(), name.end(), ' '), name.end());
    EXPECT_EQ(r["channel"], name);
  }
}

TEST_F(Recording, AnUnknownConnectionIsRefusedWithTheNames) {
  const Result<void> opened = recorder_.open(*engine_, log_.string(), {"Joystick.reference->HW.voltages"}, 16);
  ASSERT_FALSE(opened);
  EXPECT_NE(opened.error().message.find("Joystick.reference->HW.voltages"), std::string::npos) << opened.error().message;
  EXPECT_NE(opened.error().message.find(kConnection), std::string::npos) << opened.error().message;
  EXPECT_FALSE(recorder_.active());
}

// In-process components whose port type is an LCM struct (tests/record/data/count.lcm): the
// samples are recorded LCM-encoded, so LCM tools decode them.
class RecordingLcmTypes : public Recording {
 protected:
  const char* profile_path() const override { return POLYPORT_SOURCE_DIR "/tests/record/data/lcm_count_app.xml"; }
  const char* source_port() const override { return "ticker.count"; }
};

TEST_F(RecordingLcmTypes, AnInProcessSampleOfAnLcmTypeIsRecordedLcmEncoded) {
  ASSERT_TRUE(recorder_.open(*engine_, log_.string(), {}, 1024));
  recorder_.start();
  std::vector<std::string> warnings;
  ASSERT_TRUE(engine_->start(warnings));
  ASSERT_TRUE(eventually([&] { return stats()["recording"]["events"].get<int>() >= 50; }));
  engine_->stop();
  recorder_.stop();
  const nlohmann::json s = stats();
  const auto& r = s["recording"]["connections"][0];
  EXPECT_EQ(r["channel"], "ticker.count->collector.in");
  EXPECT_EQ(r["encoding"], "lcm");
  EXPECT_EQ(r["dropped"], 0);
  EXPECT_EQ(r["recorded"], link_->counters().received.load());

  auto codec = make_lcm_codec(*out_->type());
  ASSERT_TRUE(codec);
  const std::vector<Event> log = events();
  ASSERT_EQ(log.size(), r["recorded"].get<std::size_t>());
  std::int64_t expected = 1;  // the Ticker counts its cycles from 1
  for (const Event& e : log) {
    // int64_t count after the 8-byte fingerprint, big-endian as LCM encodes.
    ASSERT_EQ(e.data.size(), 16u);
    std::int64_t count = 0;
    const CodecResult decoded = codec.value()->decode(e.data.data(), 16, reinterpret_cast<std::byte*>(&count), sizeof count);
    ASSERT_TRUE(decoded.ok()) << to_string(decoded.error);  // the fingerprint is rec.count_t's
    std::uint64_t big_endian = 0;
    for (int k = 8; k < 16; ++k) big_endian = (big_endian << 8) | static_cast<std::uint8_t>(e.data[static_cast<std::size_t>(k)]);
    EXPECT_EQ(static_cast<std::int64_t>(big_endian), count);
    EXPECT_EQ(count, expected++);
  }
}

}  // namespace
}  // namespace polyport
