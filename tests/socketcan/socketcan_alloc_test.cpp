// Heap allocations on the SocketCAN forwarding paths after start-up, counted (label vm, a
// guest with vcan0 and vcan1). This binary interposes malloc (tests/support/malloc_counter.hpp)
// and counts every allocation of the process inside a window in which the test thread only
// makes system calls on its own raw CAN sockets (the peers) and reads pull probes; the only
// other thread is the model's CAN thread (receive path, sinks, broadcast manager updates,
// error frames to events, and its supervision ticks). The windows:
//  - CAN -> CAN, each sample a frame (cyclic_app.xml, EngineData <cycle_ms>0</cycle_ms>);
//  - the same both ways between vcan0 and vcan1 (loop_app.xml), each frame's echo dropped;
//  - CAN -> CAN through the broadcast manager (cyclic_app.xml, BrakeStatus every 50 ms):
//    each sample replaces the task's data;
//  - CAN -> decoded signals on a probe, and error frames -> polyport::CanBusEvent samples
//    (events_app.xml); the window opens after the tick has logged the bus-state change of
//    the warm-up (the tick allocates for a log line; it is not the forwarding path);
//  - CAN -> decoded, mapped onto another message, encoded -> CAN, beside a passthrough of
//    the same frame (convert_alloc_app.xml, the wheelchair's joystick and motor frames).
// The CAN -> CAN windows run once with each way the CAN thread waits (epoll: the sink write()s
// each frame; io_uring: it hands the frame to the thread's next wait). Every wait is poll() or
// a probe read with a deadline.
#include <gtest/gtest.h>
#include <linux/can.h>
#include <linux/can/error.h>
#include <linux/can/raw.h>
#include <net/if.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <cstring>
#include <string>

#include <nlohmann/json.hpp>
#include <spdlog/sinks/ringbuffer_sink.h>
#include <spdlog/spdlog.h>

#include "../support/eventually.hpp"
#include "../support/malloc_counter.hpp"
#include "socketcan_adaptor.hpp"
#include "socketcan_fixture.hpp"

namespace polyport {
namespace {

using test::Clock;
using test::g_all_allocations;
using test::ms_until;

// A raw CAN socket of the test's own, bound to one interface; opened before the window.
class RawPeer {
 public:
  explicit RawPeer(const char* interface) {
    fd_ = ::socket(PF_CAN, SOCK_RAW, CAN_RAW);
    sockaddr_can address{};
    address.can_family = AF_CAN;
    address.can_ifindex = static_cast<int>(::if_nametoindex(interface));
    if (fd_ < 0 || address.can_ifindex == 0 ||
        ::bind(fd_, reinterpret_cast<const sockaddr*>(&address), sizeof address) != 0) {
      error_ = std::string("raw socket on ") + interface + ": " + std::strerror(errno);
    }
  }
  ~RawPeer() {
    if (fd_ >= 0) ::close(fd_);
  }
  const std::string& error() const { return error_; }

  bool send(canid_t id, const std::uint8_t (&data)[8]) const {
    can_frame frame{};
    frame.can_id = id;
    frame.len = 8;
    std::memcpy(frame.data, data, 8);
    return ::write(fd_, &frame, sizeof frame) == static_cast<ssize_t>(sizeof frame);
  }
  bool send(const can_frame& frame) const {
    return ::write(fd_, &frame, sizeof frame) == static_cast<ssize_t>(sizeof frame);
  }
  // The next frame of any id, waited for until the deadline.
  bool receive(can_frame& frame, Clock::time_point deadline) const {
    pollfd p{fd_, POLLIN, 0};
    return ::poll(&p, 1, ms_until(deadline)) > 0 &&
           ::read(fd_, &frame, sizeof frame) == static_cast<ssize_t>(sizeof frame);
  }
  // The next frame with this id and data, waited for until the deadline.
  bool receive(canid_t id, const std::uint8_t (&data)[8], Clock::time_point deadline) const {
    for (;;) {
      pollfd p{fd_, POLLIN, 0};
      if (::poll(&p, 1, ms_until(deadline)) <= 0) return false;
      can_frame frame{};
      if (::read(fd_, &frame, sizeof frame) != static_cast<ssize_t>(sizeof frame)) return false;
      if (frame.can_id == id && std::memcmp(frame.data, data, 8) == 0) return true;
    }
  }

 private:
  int fd_ = -1;
  std::string error_;
};

using SocketCanAllocTest = test::SocketCanFixture;
using SocketCanAllocBothWaits = test::SocketCanIoFixture;

constexpr int kFrames = 500;
constexpr auto kWindowDeadline = std::chrono::seconds(60);  // bounds a failure only

// EngineData frames (0x100) sent on vcan0 and awaited one by one on vcan1: 10 to warm up,
// then kFrames counted, with the allocations of the whole process meanwhile.
struct Forwarded {
  std::string failed;  // empty when every warm-up frame came through
  int through = 0;
  std::uint64_t allocations = 0;
};

Forwarded forward_engine_data(std::uint8_t (&data)[8]) {
  RawPeer writer("vcan0");
  RawPeer reader("vcan1");
  if (!writer.error().empty()) return {writer.error()};
  if (!reader.error().empty()) return {reader.error()};
  const auto deadline = Clock::now() + kWindowDeadline;
  for (int i = 0; i < 10; ++i) {  // warm-up
    data[7] = static_cast<std::uint8_t>(i);
    if (!writer.send(0x100, data) || !reader.receive(0x100, data, deadline)) {
      return {"warm-up frame " + std::to_string(i) + " did not come through"};
    }
  }
  Forwarded result;
  const std::uint64_t before = g_all_allocations.load();
  for (int i = 0; i < kFrames; ++i) {
    data[7] = static_cast<std::uint8_t>(i);
    if (!writer.send(0x100, data) || !reader.receive(0x100, data, deadline)) break;
    ++result.through;
  }
  result.allocations = g_all_allocations.load() - before;
  return result;
}

TEST_P(SocketCanAllocBothWaits, ForwardingFrameByFrameAllocatesNothing) {
  ASSERT_TRUE(build("cyclic_app.xml")) << problems();
  start();
  expect_io("bus1");
  std::uint8_t data[8] = {0xA0, 0x0F, 0x78, 0xC8, 0x30, 0x7D, 0x01, 0x00};
  const Forwarded forwarded = forward_engine_data(data);
  ASSERT_EQ(forwarded.failed, "");
  EXPECT_EQ(forwarded.through, kFrames);
  EXPECT_EQ(forwarded.allocations, 0u) << "allocations while " << forwarded.through << " frames were forwarded";
}

// Loop prevention on the path (loop_app.xml: EngineData both ways between vcan0 and vcan1):
// each frame from vcan0 is fingerprinted and recorded before polyport sends it on vcan1, and
// its echo, back at polyport's reading socket of vcan1, is fingerprinted, found and dropped.
TEST_P(SocketCanAllocBothWaits, DroppingTheEchoOfItsOwnFrameAllocatesNothing) {
  ASSERT_TRUE(build("loop_app.xml")) << problems();
  start();
  expect_io("r1");
  std::uint8_t data[8] = {0xA0, 0x0F, 0x78, 0xC8, 0x30, 0x7D, 0x02, 0x00};
  const Forwarded forwarded = forward_engine_data(data);
  ASSERT_EQ(forwarded.failed, "");
  EXPECT_EQ(forwarded.through, kFrames);
  EXPECT_EQ(forwarded.allocations, 0u)
      << "allocations while " << forwarded.through << " frames were forwarded and their echoes dropped";
  auto loop_dropped = [&](const char* component) {
    nlohmann::json stats;
    engine.stats(stats);
    for (const auto& c : stats["components"]) {
      if (c["name"] == component) return c["socketcan"]["loop_dropped"].get<int>();
    }
    return -1;
  };
  EXPECT_TRUE(test::eventually([&] { return loop_dropped("r1") == 10 + kFrames; })) << loop_dropped("r1");
  EXPECT_EQ(loop_dropped("r0"), 0);
}

TEST_F(SocketCanAllocTest, UpdatingABroadcastManagerTaskAllocatesNothing) {
  ASSERT_TRUE(build("cyclic_app.xml")) << problems();
  start();
  RawPeer writer("vcan0");
  RawPeer reader("vcan1");
  ASSERT_EQ(writer.error(), "");
  ASSERT_EQ(reader.error(), "");
  std::uint8_t data[8] = {0x04, 0xD2, 0x3E, 0x80, 0x00, 0x85, 0x00, 0xAA};
  const auto deadline = Clock::now() + kWindowDeadline;
  ASSERT_TRUE(writer.send(0x1A0, data));  // starts the task (warm-up)
  ASSERT_TRUE(reader.receive(0x1A0, data, deadline)) << "the periodic frame did not come";
  // In batches of 50 (fewer than polyport's socket buffers), each waited for until its last
  // sample's data goes out with the next cycle.
  constexpr int kBatch = 50;
  const std::uint64_t before = g_all_allocations.load();
  int batches = 0;
  for (int i = 0; i < kFrames;) {
    bool sent = true;
    for (int k = 0; k < kBatch && sent; ++k, ++i) {
      data[6] = static_cast<std::uint8_t>(i);
      data[7] = static_cast<std::uint8_t>(i >> 8);
      sent = writer.send(0x1A0, data);
    }
    if (!sent || !reader.receive(0x1A0, data, deadline)) break;
    ++batches;
  }
  const std::uint64_t allocations = g_all_allocations.load() - before;
  EXPECT_EQ(batches, kFrames / kBatch) << "a batch's last sample never went out";
  EXPECT_EQ(allocations, 0u) << "allocations while " << kFrames << " samples updated the task";
  EXPECT_EQ(port_counters("bus1", "brake")["sent"], kFrames + 1);
}

TEST_F(SocketCanAllocTest, DecodingFramesAndErrorFramesIntoEventsAllocatesNothing) {
  ASSERT_TRUE(build("events_app.xml")) << problems();
  DataInPort* engine_probe = probe("bus0.engine");
  DataInPort* events = probe("bus0.bus");
  ASSERT_TRUE(engine_probe && events);
  start();
  RawPeer writer("vcan0");
  ASSERT_EQ(writer.error(), "");
  const std::uint8_t data[8] = {0xA0, 0x0F, 0x78, 0xC8, 0x30, 0x7D, 0x01, 0x00};
  const std::uint8_t warning[8] = {0x00, 0x08, 0x00, 0x00, 0x00, 0x00, 0x60, 0x00};
  double values[6];
  socketcan::CanBusEventSample event;
  const auto deadline = Clock::now() + kWindowDeadline;
  auto one_round = [&] {
    if (!writer.send(0x100, data) || !writer.send(CAN_ERR_FLAG | CAN_ERR_CRTL, warning)) return false;
    bool have_sample = false;
    bool have_event = false;
    while (!(have_sample && have_event) && Clock::now() < deadline) {
      have_sample = have_sample || engine_probe->read(values, sizeof values) == Status::ok;
      have_event = have_event || events->read(&event, sizeof event) == Status::ok;
    }
    return have_sample && have_event;
  };
  // The first warning changes the bus state, which the next supervision tick logs (not the
  // forwarding path: it allocates). The window opens after that line.
  auto sink = std::make_shared<spdlog::sinks::ringbuffer_sink_mt>(64);
  const auto previous = spdlog::default_logger();
  spdlog::set_default_logger(std::make_shared<spdlog::logger>("test", sink));
  for (int i = 0; i < 10; ++i) ASSERT_TRUE(one_round()) << "warm-up round " << i;
  const bool logged = test::eventually(
      [&] {
        for (const auto& line : sink->last_formatted()) {
          if (line.find("bus state error-warning") != std::string::npos) return true;
        }
        return false;
      },
      test::kDeadline);
  spdlog::set_default_logger(previous);
  ASSERT_TRUE(logged) << "the bus state error-warning was not logged";
  int through = 0;
  const std::uint64_t before = g_all_allocations.load();
  for (int i = 0; i < kFrames && one_round(); ++i) ++through;
  const std::uint64_t allocations = g_all_allocations.load() - before;
  EXPECT_EQ(through, kFrames);
  EXPECT_EQ(allocations, 0u) << "allocations while " << through << " frames and error frames were decoded";
  EXPECT_EQ(event.kind, static_cast<int>(socketcan::CanBusEventKind::error_warning));
  EXPECT_DOUBLE_EQ(values[0], 1000.0);
}

TEST_P(SocketCanAllocBothWaits, ConvertingAFrameIntoAnotherAllocatesNothing) {
  ASSERT_TRUE(build("convert_alloc_app.xml")) << problems();
  start();
  expect_io("drive");
  RawPeer io("vcan0");
  RawPeer drive("vcan1");
  ASSERT_EQ(io.error(), "");
  ASSERT_EQ(drive.error(), "");
  // x = 0.5, y = -0.25 (factor 1e-4, Intel) -> left_v = 12 V, right_v = -6 V (factor 0.01).
  can_frame joystick{};
  joystick.can_id = 0x101;
  joystick.len = 4;
  const std::uint8_t joystick_bytes[] = {0x88, 0x13, 0x3C, 0xF6};
  std::memcpy(joystick.data, joystick_bytes, sizeof joystick_bytes);
  const std::uint8_t voltage_bytes[] = {0xB0, 0x04, 0xA8, 0xFD};
  const auto deadline = Clock::now() + kWindowDeadline;
  int wrong = 0;
  // One frame at a time, both outputs taken before the next.
  auto one_round = [&] {
    if (!io.send(joystick)) return false;
    bool same = false;
    bool converted = false;
    can_frame got{};
    while (!(same && converted)) {
      if (!drive.receive(got, deadline)) return false;
      const bool is_same = got.can_id == 0x101;
      (is_same ? same : converted) = true;
      const std::uint8_t* want = is_same ? joystick_bytes : voltage_bytes;
      if ((!is_same && got.can_id != 0x201) || got.len != 4 || std::memcmp(got.data, want, 4) != 0) ++wrong;
    }
    return true;
  };
  for (int i = 0; i < 10; ++i) ASSERT_TRUE(one_round()) << "warm-up frame " << i << " did not come through both ways";
  int through = 0;
  const std::uint64_t before = g_all_allocations.load();
  for (int i = 0; i < kFrames && one_round(); ++i) ++through;
  const std::uint64_t allocations = g_all_allocations.load() - before;
  EXPECT_EQ(through, kFrames);
  EXPECT_EQ(wrong, 0) << "frames with other bytes than expected";
  EXPECT_EQ(allocations, 0u) << "allocations while " << through << " frames were passed on and converted";
  nlohmann::json stats;
  engine.stats(stats);
  EXPECT_EQ(stats["connections"][0]["conversion"], "passthrough") << stats.dump(2);
  EXPECT_NE(stats["connections"][1]["conversion"], "passthrough") << stats.dump(2);
  EXPECT_EQ(stats["connections"][1]["dropped"], 0) << stats.dump(2);
}

POLYPORT_BOTH_CAN_WAITS(SocketCanAllocBothWaits);

}  // namespace
}  // namespace polyport
