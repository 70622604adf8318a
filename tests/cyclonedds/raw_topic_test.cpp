// Raw Cyclone topics against generated code, in one process on domain kDomain (loopback
// only, config/cyclonedds-loopback.xml):
//  - an idlc-generated writer's sample arrives at a RawReader as exactly the bytes polyport's
//    XCDR1 codec makes of the same values, and polyport decodes them back field by field;
//  - bytes from polyport's codec written with a RawWriter arrive at a generated reader
//    (dds_take) with the same values.
// Every wait polls a condition until a deadline; nothing sleeps a fixed time.
#include <gtest/gtest.h>

#include "generated_peer.hpp"
#include <unistd.h>

#include <chrono>
#include <cstring>
#include <functional>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "dds/dds.h"
#include "polyport/codecs/codec.hpp"
#include "polyport/base/diagnostics.hpp"
#include "polyport/types/types.hpp"
#include "raw_topic.hpp"

namespace {

namespace cyc = polyport::cyclonedds;
using polyport::FlatSpan;
using polyport::Type;

constexpr std::uint32_t kDomain = 143;  // used by no other test
constexpr const char* kTypeName = "raw_peer::Pose";
constexpr auto kDeadline = std::chrono::seconds(10);

bool wait_until(const std::function<bool()>& condition) {
  const auto end = std::chrono::steady_clock::now() + kDeadline;
  while (!condition()) {
    if (std::chrono::steady_clock::now() > end) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  return true;
}

std::string unique_topic(const char* what) {
  return std::string("polyport_raw_") + what + "_" + std::to_string(getpid());
}

struct PoseValues {
  std::int32_t id = 0;
  double x = 0;
  float heading = 0;
  bool valid = false;
  std::string frame;
  std::vector<double> samples;
  std::uint8_t last = 0;
};

PoseValues example() {
  return PoseValues{-42, 1.25, -0.5F, true, "base_link", {0.5, -1.0, 3.75}, 0xab};
}

// ---- polyport's side: the type from the same IDL, flat samples, the XCDR1 codec -----------

class PolyportPose {
 public:
  PolyportPose() {
    polyport::Diagnostics diagnostics;
    if (!registry_.add_idl_file(POLYPORT_RAW_PEER_IDL, diagnostics)) {
      for (const auto& d : diagnostics.all()) ADD_FAILURE() << d.message;
      return;
    }
    type_ = registry_.find(kTypeName);
    if (type_ == nullptr) return;
    auto codec = polyport::make_cdr_codec(*type_, polyport::WireFormat::xcdr1);
    if (!codec) {
      ADD_FAILURE() << codec.error().message;
      return;
    }
    codec_ = std::move(codec).value();
  }

  bool ok() const { return codec_ != nullptr; }

  std::vector<std::byte> encode(const PoseValues& v) const {
    std::vector<std::byte> flat(type_->size);
    put(flat, "id", v.id);
    put(flat, "x", v.x);
    put(flat, "heading", v.heading);
    put(flat, "valid", v.valid);
    put(flat, "last", v.last);
    const auto frame_at = append(flat, v.frame.c_str(), v.frame.size() + 1, 1);
    put(flat, "frame", FlatSpan{frame_at, static_cast<std::uint32_t>(v.frame.size())});
    const auto samples_at =
        append(flat, v.samples.data(), v.samples.size() * sizeof(double), alignof(double));
    put(flat, "samples", FlatSpan{v.samples.empty() ? 0 : samples_at,
                                  static_cast<std::uint32_t>(v.samples.size())});
    std::vector<std::byte> wire(codec_->max_wire_size(static_cast<std::uint32_t>(flat.size())));
    const auto result = codec_->encode(flat.data(), static_cast<std::uint32_t>(flat.size()),
                                       wire.data(), static_cast<std::uint32_t>(wire.size()));
    EXPECT_TRUE(result.ok()) << polyport::to_string(result.error);
    wire.resize(result.size);
    return wire;
  }

  bool decode(const std::byte* wire, std::uint32_t size, PoseValues& v) const {
    std::vector<std::byte> flat(type_->size + 4096);
    const auto result = codec_->decode(wire, size, flat.data(), static_cast<std::uint32_t>(flat.size()));
    EXPECT_TRUE(result.ok()) << polyport::to_string(result.error);
    if (!result.ok()) return false;
    v.id = get<std::int32_t>(flat, "id");
    v.x = get<double>(flat, "x");
    v.heading = get<float>(flat, "heading");
    v.valid = get<bool>(flat, "valid");
    v.last = get<std::uint8_t>(flat, "last");
    const auto frame = get<FlatSpan>(flat, "frame");
    v.frame.assign(reinterpret_cast<const char*>(flat.data() + frame.offset), frame.count);
    const auto samples = get<FlatSpan>(flat, "samples");
    v.samples.resize(samples.count);
    if (samples.count > 0)
      std::memcpy(v.samples.data(), flat.data() + samples.offset, samples.count * sizeof(double));
    return true;
  }

 private:
  std::uint32_t offset(std::string_view name) const {
    const polyport::Field* field = type_->resolved().find_field(name);
    EXPECT_NE(field, nullptr) << name;
    return field == nullptr ? 0 : field->offset;
  }
  template <class T>
  void put(std::vector<std::byte>& flat, std::string_view name, const T& value) const {
    std::memcpy(flat.data() + offset(name), &value, sizeof value);
  }
  template <class T>
  T get(const std::vector<std::byte>& flat, std::string_view name) const {
    T value;
    std::memcpy(&value, flat.data() + offset(name), sizeof value);
    return value;
  }
  static std::uint32_t append(std::vector<std::byte>& flat, const void* data, std::size_t size,
                              std::size_t align) {
    const std::size_t at = (flat.size() + align - 1) / align * align;
    flat.resize(at + size);
    if (size > 0) std::memcpy(flat.data() + at, data, size);
    return static_cast<std::uint32_t>(at);
  }

  polyport::TypeRegistry registry_;
  const Type* type_ = nullptr;
  std::unique_ptr<polyport::Codec> codec_;
};

void expect_equal(const PoseValues& got, const PoseValues& want) {
  EXPECT_EQ(got.id, want.id);
  EXPECT_EQ(got.x, want.x);
  EXPECT_EQ(got.heading, want.heading);
  EXPECT_EQ(got.valid, want.valid);
  EXPECT_EQ(got.frame, want.frame);
  EXPECT_EQ(got.samples, want.samples);
  EXPECT_EQ(got.last, want.last);
}

// ---- the generated application's side ---------------------------------------------------------

// A participant of its own on the same domain (which the polyport Participant configured).
using polyport::test::GeneratedPeer;
using polyport::test::publication_matches;
using polyport::test::subscription_matches;

class CycloneRawTopicTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(pose_.ok());
    auto participant = cyc::Participant::create(kDomain, POLYPORT_CYCLONE_LOOPBACK_CONFIG);
    ASSERT_TRUE(participant.ok()) << participant.error().message;
    participant_ = std::move(participant).value();
  }

  PolyportPose pose_;
  std::unique_ptr<cyc::Participant> participant_;
};

// Received bytes, filled on Cyclone's thread.
struct Inbox {
  std::mutex mutex;
  std::vector<std::vector<std::byte>> samples;
  std::vector<polyport::MonoTime> stamps;
  std::size_t count() {
    std::lock_guard lock(mutex);
    return samples.size();
  }
};

TEST_F(CycloneRawTopicTest, GeneratedWriterToRawReaderGivesPolyportsBytes) {
  const std::string topic = unique_topic("to_raw");
  Inbox inbox;
  auto reader = cyc::RawReader::create(
      *participant_, topic, kTypeName,
      [&inbox](const std::byte* cdr, std::uint32_t size, polyport::MonoTime stamp) {
        std::lock_guard lock(inbox.mutex);
        inbox.samples.emplace_back(cdr, cdr + size);
        inbox.stamps.push_back(stamp);
      });
  ASSERT_TRUE(reader.ok()) << reader.error().message;

  GeneratedPeer peer(kDomain, topic.c_str());
  ASSERT_TRUE(peer.ok());
  const dds_entity_t writer = peer.make_writer();
  ASSERT_GT(writer, 0) << dds_strretcode(writer);
  ASSERT_TRUE(wait_until([&] { return publication_matches(writer) >= 1; }))
      << "the generated writer never matched the raw reader";
  ASSERT_TRUE(wait_until([&] { return reader.value()->matched_writers() >= 1; }));

  const PoseValues values = example();
  std::vector<double> samples = values.samples;
  raw_peer_Pose c{};
  c.id = values.id;
  c.x = values.x;
  c.heading = values.heading;
  c.valid = values.valid;
  c.frame = const_cast<char*>(values.frame.c_str());
  c.samples._buffer = samples.data();
  c.samples._length = c.samples._maximum = static_cast<std::uint32_t>(samples.size());
  c.samples._release = false;
  c.last = values.last;
  const polyport::MonoTime before = polyport::mono_now();
  ASSERT_EQ(dds_write(writer, &c), DDS_RETCODE_OK);
  ASSERT_TRUE(wait_until([&] { return inbox.count() >= 1; })) << "nothing arrived";
  const polyport::MonoTime after = polyport::mono_now();

  std::lock_guard lock(inbox.mutex);
  ASSERT_EQ(inbox.samples.size(), 1u);
  const std::vector<std::byte>& got = inbox.samples[0];
  EXPECT_EQ(got, pose_.encode(values)) << "Cyclone's bytes differ from polyport's XCDR1";
  PoseValues decoded;
  ASSERT_TRUE(pose_.decode(got.data(), static_cast<std::uint32_t>(got.size()), decoded));
  expect_equal(decoded, values);
  // The source timestamp, moved onto CLOCK_MONOTONIC, falls inside the write (give or take
  // the clock conversion's read-out skew).
  EXPECT_GE(inbox.stamps[0].ns, before.ns - 1'000'000);
  EXPECT_LE(inbox.stamps[0].ns, after.ns + 1'000'000);
  EXPECT_EQ(reader.value()->received(), 1u);
}

TEST_F(CycloneRawTopicTest, RawWriterToGeneratedReaderGivesTheValues) {
  const std::string topic = unique_topic("from_raw");
  auto writer = cyc::RawWriter::create(*participant_, topic, kTypeName);
  ASSERT_TRUE(writer.ok()) << writer.error().message;

  GeneratedPeer peer(kDomain, topic.c_str());
  ASSERT_TRUE(peer.ok());
  const dds_entity_t reader = peer.make_reader();
  ASSERT_GT(reader, 0) << dds_strretcode(reader);
  ASSERT_TRUE(wait_until([&] { return writer.value()->matched_readers() >= 1; }))
      << "the raw writer never matched the generated reader";
  ASSERT_TRUE(wait_until([&] { return subscription_matches(reader) >= 1; }));

  const PoseValues values = example();
  const std::vector<std::byte> wire = pose_.encode(values);
  ASSERT_EQ(writer.value()->write(wire.data(), static_cast<std::uint32_t>(wire.size())),
            polyport::Status::ok);

  raw_peer_Pose c{};
  void* samples[1] = {&c};
  dds_sample_info_t info{};
  ASSERT_TRUE(wait_until([&] { return dds_take(reader, samples, &info, 1, 1) == 1; }))
      << "nothing arrived at the generated reader";
  ASSERT_TRUE(info.valid_data);
  PoseValues got;
  got.id = c.id;
  got.x = c.x;
  got.heading = c.heading;
  got.valid = c.valid;
  got.frame = c.frame == nullptr ? "<null>" : c.frame;
  got.samples.assign(c.samples._buffer, c.samples._buffer + c.samples._length);
  got.last = c.last;
  dds_sample_free(&c, &raw_peer_Pose_desc, DDS_FREE_CONTENTS);
  expect_equal(got, values);
}

TEST_F(CycloneRawTopicTest, RawWriterToRawReader) {
  const std::string topic = unique_topic("raw_raw");
  Inbox inbox;
  auto reader = cyc::RawReader::create(
      *participant_, topic, kTypeName,
      [&inbox](const std::byte* cdr, std::uint32_t size, polyport::MonoTime stamp) {
        std::lock_guard lock(inbox.mutex);
        inbox.samples.emplace_back(cdr, cdr + size);
        inbox.stamps.push_back(stamp);
      });
  ASSERT_TRUE(reader.ok()) << reader.error().message;
  auto writer = cyc::RawWriter::create(*participant_, topic, kTypeName);
  ASSERT_TRUE(writer.ok()) << writer.error().message;
  ASSERT_TRUE(wait_until([&] { return writer.value()->matched_readers() >= 1; }));

  const std::vector<std::byte> wire = pose_.encode(example());
  for (int i = 0; i < 3; ++i)
    ASSERT_EQ(writer.value()->write(wire.data(), static_cast<std::uint32_t>(wire.size())),
              polyport::Status::ok);
  ASSERT_TRUE(wait_until([&] { return inbox.count() >= 3; }));
  std::lock_guard lock(inbox.mutex);
  for (const auto& sample : inbox.samples) EXPECT_EQ(sample, wire);
}

// Loop prevention (cyclonedds_domain.cpp): with ignore_own, a reader does not match the
// writers of its own participant, so what they write never reaches it (RawWriterToRawReader
// shows that it would), while another participant's writer on the topic still does.
TEST_F(CycloneRawTopicTest, IgnoreOwnKeepsTheParticipantsOwnWritesFromItsReaders) {
  const std::string topic = unique_topic("ignore_own");
  Inbox inbox;
  auto reader = cyc::RawReader::create(
      *participant_, topic, kTypeName,
      [&inbox](const std::byte* cdr, std::uint32_t size, polyport::MonoTime) {
        std::lock_guard lock(inbox.mutex);
        inbox.samples.emplace_back(cdr, cdr + size);
      },
      {}, true);
  ASSERT_TRUE(reader.ok()) << reader.error().message;
  auto own = cyc::RawWriter::create(*participant_, topic, kTypeName, {}, true);
  ASSERT_TRUE(own.ok()) << own.error().message;
  auto other_participant = cyc::Participant::create(kDomain, POLYPORT_CYCLONE_LOOPBACK_CONFIG);
  ASSERT_TRUE(other_participant.ok()) << other_participant.error().message;
  auto other = cyc::RawWriter::create(*other_participant.value(), topic, kTypeName);
  ASSERT_TRUE(other.ok()) << other.error().message;
  ASSERT_TRUE(wait_until([&] { return reader.value()->matched_writers() == 1 && other.value()->matched_readers() == 1; }))
      << "matched writers " << reader.value()->matched_writers();
  EXPECT_EQ(own.value()->matched_readers(), 0);

  const std::vector<std::byte> wire = pose_.encode(example());
  for (int i = 0; i < 3; ++i)
    ASSERT_EQ(own.value()->write(wire.data(), static_cast<std::uint32_t>(wire.size())), polyport::Status::ok);
  ASSERT_EQ(other.value()->write(wire.data(), static_cast<std::uint32_t>(wire.size())), polyport::Status::ok);
  ASSERT_TRUE(wait_until([&] { return inbox.count() >= 1; }));
  // The other participant's one sample came after the own writer's three: had they come,
  // they would be here first (one process, delivered in write order on each writer).
  EXPECT_EQ(inbox.count(), 1u);
  EXPECT_EQ(reader.value()->received(), 1u);
}

TEST_F(CycloneRawTopicTest, RefusesBadArguments) {
  auto writer = cyc::RawWriter::create(*participant_, unique_topic("bad"), kTypeName);
  ASSERT_TRUE(writer.ok()) << writer.error().message;
  const std::byte three[3] = {};
  EXPECT_EQ(writer.value()->write(three, 3), polyport::Status::bad_size);
  EXPECT_EQ(writer.value()->write(nullptr, 8), polyport::Status::bad_size);

  cyc::Qos qos;
  qos.depth = 0;
  EXPECT_FALSE(cyc::RawWriter::create(*participant_, unique_topic("bad2"), kTypeName, qos).ok());
  EXPECT_FALSE(cyc::RawWriter::create(*participant_, "", kTypeName).ok());
  EXPECT_FALSE(cyc::RawReader::create(*participant_, unique_topic("bad3"), kTypeName, {}).ok());
  const auto bad_domain = cyc::Participant::create(231);
  ASSERT_FALSE(bad_domain.ok());
  EXPECT_NE(bad_domain.error().message.find("231"), std::string::npos);
}

}  // namespace

namespace {

// QoS from polyport's DdsQos reaches Cyclone: partitions keep endpoints apart, a
// transient-local writer gives its history to a late reader, and the writer GUID polyport
// puts in service requests is the one readers see.
dds_entity_t generated_reader_in(dds_entity_t participant, dds_entity_t topic, const char* partition,
                                 bool transient_local) {
  dds_qos_t* group = dds_create_qos();
  dds_qset_partition1(group, partition);
  const dds_entity_t subscriber = dds_create_subscriber(participant, group, nullptr);
  dds_delete_qos(group);
  dds_qos_t* qos = dds_create_qos();
  dds_qset_reliability(qos, DDS_RELIABILITY_RELIABLE, DDS_MSECS(100));
  dds_qset_history(qos, DDS_HISTORY_KEEP_LAST, 10);
  if (transient_local) dds_qset_durability(qos, DDS_DURABILITY_TRANSIENT_LOCAL);
  const dds_entity_t reader = dds_create_reader(subscriber, topic, qos, nullptr);
  dds_delete_qos(qos);
  return reader;
}

TEST_F(CycloneRawTopicTest, PartitionsKeepEndpointsApart) {
  const std::string topic_name = unique_topic("partitions");
  polyport::DdsQos qos;
  qos.partitions = {"robot_a"};
  auto writer = cyc::RawWriter::create(*participant_, topic_name, kTypeName, qos);
  ASSERT_TRUE(writer.ok()) << writer.error().message;
  const dds_entity_t app = dds_create_participant(kDomain, nullptr, nullptr);
  ASSERT_GT(app, 0);
  const dds_entity_t topic = dds_create_topic(app, &raw_peer_Pose_desc, topic_name.c_str(), nullptr, nullptr);
  const dds_entity_t other = generated_reader_in(app, topic, "robot_b", false);
  const dds_entity_t same = generated_reader_in(app, topic, "robot_a", false);
  ASSERT_GT(other, 0);
  ASSERT_GT(same, 0);
  // Discovery is done once the reader in the same partition matched; the other never does.
  ASSERT_TRUE(wait_until([&] { return subscription_matches(same) >= 1; }));
  EXPECT_EQ(writer.value()->matched_readers(), 1);
  EXPECT_EQ(subscription_matches(other), 0);
  dds_delete(app);
}

TEST_F(CycloneRawTopicTest, TransientLocalWriterGivesItsHistoryToALateReader) {
  const std::string topic_name = unique_topic("transient");
  polyport::DdsQos qos;
  qos.durability = polyport::DdsQos::Durability::transient_local;
  qos.depth = 5;
  auto writer = cyc::RawWriter::create(*participant_, topic_name, kTypeName, qos);
  ASSERT_TRUE(writer.ok()) << writer.error().message;
  PoseValues values = example();
  for (int i = 0; i < 3; ++i) {
    values.id = 100 + i;
    const std::vector<std::byte> wire = pose_.encode(values);
    ASSERT_EQ(writer.value()->write(wire.data(), static_cast<std::uint32_t>(wire.size())), polyport::Status::ok);
  }
  // The reader joins after the writes.
  const dds_entity_t app = dds_create_participant(kDomain, nullptr, nullptr);
  const dds_entity_t topic = dds_create_topic(app, &raw_peer_Pose_desc, topic_name.c_str(), nullptr, nullptr);
  const dds_entity_t reader = generated_reader_in(app, topic, "", true);
  ASSERT_GT(reader, 0);
  std::vector<std::int32_t> ids;
  ASSERT_TRUE(wait_until([&] {
    void* samples[1] = {nullptr};
    dds_sample_info_t info{};
    while (dds_take(reader, samples, &info, 1, 1) == 1) {
      if (info.valid_data) ids.push_back(static_cast<const raw_peer_Pose*>(samples[0])->id);
      dds_return_loan(reader, samples, 1);
    }
    return ids.size() >= 3;
  })) << "the late reader got " << ids.size() << " of 3 samples";
  EXPECT_EQ(ids, (std::vector<std::int32_t>{100, 101, 102}));
  dds_delete(app);
}

TEST_F(CycloneRawTopicTest, WriterGuidIsTheOneReadersSee) {
  const std::string topic_name = unique_topic("guid");
  auto writer = cyc::RawWriter::create(*participant_, topic_name, kTypeName);
  ASSERT_TRUE(writer.ok()) << writer.error().message;
  GeneratedPeer peer(kDomain, topic_name.c_str());
  const dds_entity_t reader = peer.make_reader();
  ASSERT_TRUE(wait_until([&] { return subscription_matches(reader) >= 1; }));
  dds_instance_handle_t handles[4];
  const dds_return_t n = dds_get_matched_publications(reader, handles, 4);
  ASSERT_EQ(n, 1);
  dds_builtintopic_endpoint_t* data = dds_get_matched_publication_data(reader, handles[0]);
  ASSERT_NE(data, nullptr);
  const auto guid = writer.value()->guid();
  EXPECT_EQ(std::memcmp(guid.data(), data->key.v, 16), 0);
  EXPECT_NE(guid, (std::array<std::uint8_t, 16>{}));
  dds_builtintopic_free_endpoint(data);
}

}  // namespace
