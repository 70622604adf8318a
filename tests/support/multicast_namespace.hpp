// A network namespace of the test process's own, with loopback up and a route for LCM's
// default multicast group on it: LCM tests never hear each other, and the route goes with the
// namespace. ctest runs each case as a process of its own, so each case gets one. Needs root
// (CAP_SYS_ADMIN) and iproute2's `ip`; without them the case fails and says why.
// add_multicast_route alone is for a network of the test's own already (the vcan guest).
#pragma once

#include <gtest/gtest.h>
#include <sched.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>

namespace polyport::test {

inline void add_multicast_route() {
  ASSERT_EQ(std::system("ip link set lo up && ip link set lo multicast on && "
                        "ip route add 239.255.76.67/32 dev lo"),
            0)
      << "cannot give loopback a multicast route (iproute2's `ip`)";
}

inline void isolate_with_multicast_route() {
  ASSERT_EQ(unshare(CLONE_NEWNET), 0) << "a network namespace of the test's own needs root (CAP_SYS_ADMIN): "
                                      << std::strerror(errno);
  add_multicast_route();
}

}  // namespace polyport::test
