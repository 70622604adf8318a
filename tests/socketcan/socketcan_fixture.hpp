// What the SocketCAN engine tests share (socketcan_test.cpp, socketcan_fd_test.cpp): an
// engine with the SocketCAN model over the profiles of tests/data/socketcan, started and read
// back through pull probes and the interceptors' describe() counters. Every wait polls a
// condition until a deadline, which bounds a failure, never a latency.
#pragma once

#include <gtest/gtest.h>

#include <chrono>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "../support/engine_fixture.hpp"
#include "../support/eventually.hpp"
#include "can_peer.hpp"
#include "polyport/runtime/engine.hpp"
#include "../support/ring_probe.hpp"
#include "socketcan_model.hpp"

namespace polyport::test {

inline constexpr auto kDeadline = std::chrono::seconds(5);  // bounds a failure, not a latency

class SocketCanFixture : public EngineFixture {
 protected:
  // `io`: how the model's CAN thread waits (the daemon's default, automatic, is io_uring in
  // the guest; SocketCanIoFixture runs a case both ways).
  // `check`: the interval of the model's own look-up of the interfaces (the kernel's link
  // notifications run it at once besides).
  explicit SocketCanFixture(ReactorIo io = ReactorIo::automatic,
                            std::chrono::milliseconds check = socketcan::CanReactor::kTickInterval)
      : EngineFixture(POLYPORT_TEST_DATA "/socketcan", LoadOptions{}) {
    models.add(std::make_unique<socketcan::SocketCanModel>(io, check));
  }

  void start() {
    std::vector<std::string> warnings;
    auto started = engine.start(warnings);
    ASSERT_TRUE(started) << started.error().message;
  }

  DataInPort* probe(const std::string& port) {
    auto added = engine.add_probe(port, 16);
    EXPECT_TRUE(added) << (added ? "" : added.error().message);
    return added ? added.value() : nullptr;
  }

  // The next decoded sample of a probe, waited for until the deadline.
  static bool next_sample(DataInPort& probe, std::vector<double>& values) {
    return eventually(
        [&] { return probe.read(values.data(), static_cast<std::uint32_t>(values.size() * sizeof(double))) == Status::ok; },
        kDeadline);
  }

  // The describe() entry of a component's port.
  nlohmann::json port_counters(const std::string& component, const std::string& port) {
    nlohmann::json out;
    engine.find_interceptor(component)->describe(out);
    for (const auto& p : out["socketcan"]["ports"]) {
      if (p["port"] == port) return p;
    }
    ADD_FAILURE() << component << " has no port " << port << ": " << out.dump(2);
    return {};
  }
  nlohmann::json socket_counters(const std::string& component) {
    nlohmann::json out;
    engine.find_interceptor(component)->describe(out);
    return out["socketcan"];
  }
};

// A case run once with each way of waiting: epoll (every frame write()n by its sink) and
// io_uring (a frame forwarded on the CAN thread handed over with its next wait). Each checks
// that the thread waits the way asked: the guest's kernel gives a ring.
class SocketCanIoFixture : public SocketCanFixture, public ::testing::WithParamInterface<ReactorIo> {
 protected:
  SocketCanIoFixture() : SocketCanFixture(GetParam()) {}
  void SetUp() override {
    SocketCanFixture::SetUp();
    if (GetParam() != ReactorIo::io_uring) return;
    if (const std::string why = ring_refused(); !why.empty()) {
      GTEST_SKIP() << "this kernel gives no io_uring, so the case runs with epoll only: " << why;
    }
  }
  void expect_io(const std::string& component) {
    EXPECT_EQ(socket_counters(component)["io"], to_string(GetParam())) << socket_counters(component).dump(2);
  }
};

inline std::string io_name(const ::testing::TestParamInfo<ReactorIo>& param) { return to_string(param.param); }
#define POLYPORT_BOTH_CAN_WAITS(suite) \
  INSTANTIATE_TEST_SUITE_P(Waits, suite, ::testing::Values(ReactorIo::epoll, ReactorIo::io_uring), test::io_name)

}  // namespace polyport::test
