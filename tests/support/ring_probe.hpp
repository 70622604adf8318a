// Whether the reactor of the LCM and SocketCAN models (interceptors/common/fd_reactor.hpp) can
// wait with io_uring on this kernel: tests of the ring say why they do not run where it cannot.
#pragma once

#include <unistd.h>

#include <string>

#include "fd_reactor.hpp"

namespace polyport::test {

// Why a reactor cannot wait with io_uring here (a kernel without it, a seccomp filter,
// kernel.io_uring_disabled); empty when it can.
inline std::string ring_refused() {
  struct Nothing final : ReadableHandler {
    void on_readable() noexcept override {}
  } nothing;
  int fds[2];
  if (::pipe(fds) != 0) return "pipe failed";
  auto reactor = FdReactor::create("pp-ring-probe", "the io_uring probe", ReactorIo::io_uring);
  const Result<void> added = reactor->add(fds[0], nothing);
  if (added) reactor->remove(fds[0]);
  reactor.reset();
  ::close(fds[0]);
  ::close(fds[1]);
  return added ? "" : added.error().message;
}

}  // namespace polyport::test
