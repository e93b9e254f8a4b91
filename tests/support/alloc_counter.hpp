#pragma once
// Counts heap allocations (malloc, calloc, realloc: operator new and Eigen included). Link
// tests/support/alloc_counter.cpp into the test executable.
#include <cstddef>

namespace exoid::test {
/// Number of heap allocations so far in this process.
std::size_t allocationCount();
}  // namespace exoid::test
