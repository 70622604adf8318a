// Counts every heap allocation in the process (this test binary replaces operator new).
#pragma once

#include <cstdint>

namespace polyport::test {
std::uint64_t allocations() noexcept;
}
