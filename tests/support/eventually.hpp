// Waiting for a condition in a test: polls until it holds or a deadline passes (then the
// test fails). A condition, not a fixed sleep, decides when the test goes on.
#pragma once

#include <chrono>
#include <thread>

namespace polyport::test {

template <class F>
bool eventually(F&& condition, std::chrono::milliseconds limit = std::chrono::seconds(20)) {
  const auto deadline = std::chrono::steady_clock::now() + limit;
  while (!condition()) {
    if (std::chrono::steady_clock::now() > deadline) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  return true;
}

}  // namespace polyport::test
