// polyportd as an operator runs it, on real kernel vcan interfaces (label vm: a guest of its
// own with vcan0 and vcan1): tests/data/socketcan/cyclic_app.xml passes EngineData from vcan0
// to vcan1 frame by frame; vcan0 is deleted and re-added while the daemon runs, and frames
// flow again afterwards. The loss and the return are in the daemon's log and its final
// statistics. cansend, candump and ip are the peers; every wait has a deadline.
#include <gtest/gtest.h>

#include <unistd.h>

#include <chrono>
#include <iostream>
#include <string>

#include "../support/daemon_harness.hpp"
#include "../support/ring_probe.hpp"
#include "can_peer.hpp"

namespace polyport {
namespace {

using test::CanPeer;
using test::cansend;
using test::Clock;
using test::run_command;
using namespace std::chrono_literals;

class SocketCanDaemon : public test::DaemonTest {
 protected:
  SocketCanDaemon() : DaemonTest("polyport-can-daemon") {}
};

// Sends `frame` on vcan0 every 50 ms until candump has printed one EngineData frame of
// vcan1 (candump binds some time after it starts); that line, or what went wrong.
std::string forwarded(const std::string& frame) {
  CanPeer candump({"candump", "-L", "-n", "1", "vcan1,100:7FF"});
  if (!candump.error().empty()) return candump.error();
  const auto deadline = Clock::now() + std::chrono::seconds(10);
  for (int sent = 0; !candump.output_ready(sent == 0 ? 0 : 50); ++sent) {
    if (Clock::now() > deadline) return "candump printed nothing within 10 s of " + std::to_string(sent) + " frames";
    if (std::string failed = cansend("vcan0", frame); !failed.empty()) return failed;
  }
  if (!candump.finish(deadline)) return "candump did not exit after one frame: " + candump.output();
  return candump.output().substr(0, candump.output().find('\n'));
}

std::string add_vcan(const std::string& name) {
  if (std::string failed = run_command({"ip", "link", "add", "dev", name, "type", "vcan"}); !failed.empty()) return failed;
  return run_command({"ip", "link", "set", name, "up"});
}

TEST_F(SocketCanDaemon, SurvivesDeletingAndReAddingItsInterface) {
  auto daemon_process = daemon(POLYPORT_TEST_DATA "/socketcan/cyclic_app.xml");
  EXPECT_NE(forwarded("100#A00F78C8307D0100").find(" vcan1 100#A00F78C8307D0100"), std::string::npos)
      << daemon_process->errors();

  ASSERT_EQ(run_command({"ip", "link", "del", "vcan0"}), "");
  EXPECT_TRUE(test::eventually(
      [&] { return daemon_process->errors().find("bus0: CAN interface 'vcan0' went away") != std::string::npos; }, 10s))
      << daemon_process->errors();
  ASSERT_EQ(add_vcan("vcan0"), "");
  EXPECT_TRUE(test::eventually(
      [&] { return daemon_process->errors().find("bus0: CAN interface 'vcan0' is back") != std::string::npos; }, 10s))
      << daemon_process->errors();
  EXPECT_NE(forwarded("100#A00F78C8307D0200").find(" vcan1 100#A00F78C8307D0200"), std::string::npos)
      << daemon_process->errors();

  const test::Json stats = stop(*daemon_process);
  bool found = false;
  for (const auto& component : stats["components"]) {
    if (component.value("name", "") != "bus0") continue;
    found = true;
    const auto& can = component["socketcan"];
    EXPECT_EQ(can["losses"], 1) << can.dump(2);
    EXPECT_EQ(can["recoveries"], 1) << can.dump(2);
    EXPECT_EQ(can["link"], "up") << can.dump(2);
  }
  EXPECT_TRUE(found) << stats.dump(2);
}

// --can-io picks how the CAN thread waits; by default io_uring, which the guest's kernel gives.
// Both forward, and the final statistics say which one ran.
TEST_F(SocketCanDaemon, TheCommandLineSaysHowTheCanThreadWaits) {
  const std::string refused = test::ring_refused();
  for (const std::string io : {"", "epoll", "io_uring"}) {
    SCOPED_TRACE("--can-io " + (io.empty() ? std::string("(default)") : io));
    if (io == "io_uring" && !refused.empty()) {
      std::cout << "not run with --can-io io_uring: this kernel gives no io_uring: " << refused << "\n";
      continue;
    }
    auto daemon_process = daemon(POLYPORT_TEST_DATA "/socketcan/cyclic_app.xml",
                                 io.empty() ? std::vector<std::string>{} : std::vector<std::string>{"--can-io", io});
    EXPECT_NE(forwarded("100#A00F78C8307D0100").find(" vcan1 100#A00F78C8307D0100"), std::string::npos)
        << daemon_process->errors();
    const test::Json stats = stop(*daemon_process);
    ASSERT_FALSE(stats["components"].empty()) << stats.dump(2);
    for (const auto& component : stats["components"]) {
      EXPECT_EQ(component["socketcan"]["io"], io == "epoll" || !refused.empty() ? "epoll" : "io_uring")
          << component.dump(2);
    }
  }
}

// The CAN receive thread runs with the scheduling <socketcan><receive_thread> asks for:
// SCHED_FIFO 30 on CPU 0, seen in /proc; where the process may not (not root), one warning says so.
TEST_F(SocketCanDaemon, TheReceiveThreadRunsWithTheProfilesScheduling) {
  const test::fs::path app = one_component_app(
      "socketcan", R"(<socketcan><interface>vcan0</interface><receive_thread policy="SCHED_FIFO" priority="30" cpu="0"/></socketcan>)",
      POLYPORT_TEST_DATA "/dbc/vehicle.dbc", "vehicle::EngineData");
  auto daemon_process = daemon(app);
  const auto receive_thread = [&] { return test::thread_scheduling(daemon_process->pid(), "pp-can-recv"); };
  ASSERT_TRUE(test::eventually([&] { return receive_thread().has_value(); })) << daemon_process->errors();
  const bool allowed = geteuid() == 0;
  if (allowed) {
    EXPECT_EQ(receive_thread()->second, 1) << "SCHED_FIFO";
    EXPECT_EQ(receive_thread()->first, 30);
  } else {
    EXPECT_NE(daemon_process->errors().find("real-time priority 30 refused"), std::string::npos)
        << daemon_process->errors();
  }
  const test::Json stats = stop(*daemon_process);
  const test::Json thread = stats["components"][0]["socketcan"]["receive_thread"];
  EXPECT_EQ(thread.value("asked", ""), "SCHED_FIFO 30 on CPU 0") << stats.dump(2);
  EXPECT_EQ(thread.value("realtime", !allowed), allowed) << stats.dump(2);
}

}  // namespace
}  // namespace polyport
