// Zero heap allocations per forwarded CAN frame after start-up, on the passthrough path (the
// joystick frame from vcan0 to vcan1 as it came) and on a converting one (decoded, mapped
// onto the motor voltages, encoded as another frame): tests/data/socketcan_alloc, in the
// engine in this process (label vm: a guest of its own with vcan0 and vcan1).
//
// The SocketCAN model has no SDK: everything between the kernel's socket and the kernel's
// socket is polyport's, so this binary counts every allocation of the whole process
// (tests/support/malloc_counter.hpp) while frames flow. The test thread's own part (raw
// socket write, poll, read) allocates nothing.
#include <gtest/gtest.h>
#include <linux/can.h>
#include <linux/can/raw.h>
#include <net/if.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "../support/engine_fixture.hpp"
#include "../support/malloc_counter.hpp"
#include "socketcan_model.hpp"

namespace polyport::test {
namespace {

// A raw CAN socket of the test's own on one interface: receives only `ids`.
class RawCan {
 public:
  RawCan(const char* interface, std::vector<canid_t> ids) {
    fd_ = ::socket(PF_CAN, SOCK_RAW | SOCK_CLOEXEC, CAN_RAW);
    if (fd_ < 0) {
      error_ = std::string("socket(PF_CAN): ") + std::strerror(errno);
      return;
    }
    std::vector<can_filter> filters;
    for (canid_t id : ids) filters.push_back({id, CAN_SFF_MASK | CAN_EFF_FLAG | CAN_RTR_FLAG});
    ::setsockopt(fd_, SOL_CAN_RAW, CAN_RAW_FILTER, filters.empty() ? nullptr : filters.data(),
                 static_cast<socklen_t>(filters.size() * sizeof(can_filter)));
    sockaddr_can address{};
    address.can_family = AF_CAN;
    address.can_ifindex = static_cast<int>(::if_nametoindex(interface));
    if (address.can_ifindex == 0 || ::bind(fd_, reinterpret_cast<sockaddr*>(&address), sizeof address) != 0) {
      error_ = std::string("bind to ") + interface + ": " + std::strerror(errno);
    }
  }
  ~RawCan() {
    if (fd_ >= 0) ::close(fd_);
  }
  RawCan(const RawCan&) = delete;
  RawCan& operator=(const RawCan&) = delete;

  const std::string& error() const { return error_; }
  bool send(const can_frame& frame) const { return ::write(fd_, &frame, sizeof frame) == sizeof frame; }
  // The next frame within `timeout_ms`; false at the deadline.
  bool receive(can_frame& frame, int timeout_ms) const {
    pollfd p{fd_, POLLIN, 0};
    return ::poll(&p, 1, timeout_ms) > 0 && ::read(fd_, &frame, sizeof frame) == sizeof frame;
  }

 private:
  int fd_ = -1;
  std::string error_;
};

class SocketCanAlloc : public EngineFixture {
 protected:
  SocketCanAlloc() : EngineFixture(POLYPORT_TEST_DATA "/socketcan_alloc", LoadOptions{}) {
    models.add(std::make_unique<socketcan::SocketCanModel>());
  }
};

TEST_F(SocketCanAlloc, ForwardingAFrameAllocatesNothing) {
  ASSERT_TRUE(build("alloc_app.xml")) << problems();
  std::vector<std::string> warnings;
  ASSERT_TRUE(engine.start(warnings)) << problems();
  const RawCan io("vcan0", {});
  const RawCan drive("vcan1", {0x101, 0x201});
  ASSERT_EQ(io.error(), "");
  ASSERT_EQ(drive.error(), "");

  // x = 0.5, y = -0.25 (factor 1e-4, Intel) -> left_v = 12 V, right_v = -6 V (factor 0.01).
  can_frame joystick{};
  joystick.can_id = 0x101;
  joystick.len = 4;
  const std::uint8_t joystick_bytes[] = {0x88, 0x13, 0x3C, 0xF6};
  std::memcpy(joystick.data, joystick_bytes, sizeof joystick_bytes);
  const std::uint8_t voltage_bytes[] = {0xB0, 0x04, 0xA8, 0xFD};

  int bad = 0;
  // One frame at a time, both outputs taken before the next, so no queue ever overflows.
  auto send_and_take = [&](int count) {
    for (int i = 0; i < count; ++i) {
      ASSERT_TRUE(io.send(joystick)) << std::strerror(errno);
      bool same = false;
      bool converted = false;
      can_frame got;
      while (!(same && converted)) {
        ASSERT_TRUE(drive.receive(got, 5000)) << "frame " << i << ": passthrough " << same << ", converted "
                                              << converted << " after 5 s";
        if (got.can_id == 0x101) {
          same = true;
          if (got.len != 4 || std::memcmp(got.data, joystick_bytes, 4) != 0) ++bad;
        } else {
          converted = true;
          if (got.can_id != 0x201 || got.len != 4 || std::memcmp(got.data, voltage_bytes, 4) != 0) ++bad;
        }
      }
    }
  };
  send_and_take(50);  // warm-up: first-use allocations (histogram pages)

  constexpr int kFrames = 500;
  const std::uint64_t before = g_all_allocations.load();
  send_and_take(kFrames);
  const std::uint64_t allocations = g_all_allocations.load() - before;
  EXPECT_EQ(bad, 0) << "frames with other bytes than expected";
  EXPECT_EQ(allocations, 0u) << "the process allocated while forwarding " << kFrames << " frames";
  std::printf("allocations per forwarded frame (two outputs): %.3f\n", static_cast<double>(allocations) / kFrames);

  nlohmann::json stats;
  engine.stats(stats);
  EXPECT_EQ(stats["connections"][0]["conversion"], "passthrough") << stats.dump(2);
  EXPECT_NE(stats["connections"][1]["conversion"], "passthrough") << stats.dump(2);
  EXPECT_EQ(stats["connections"][0]["dropped"], 0) << stats.dump(2);
  EXPECT_EQ(stats["connections"][1]["dropped"], 0) << stats.dump(2);
  engine.stop();
}

}  // namespace
}  // namespace polyport::test
