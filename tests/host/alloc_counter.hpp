// Counts heap allocations of the test program (global operator new replaced in
// alloc_counter.cpp, a separate file so the compiler cannot inline new into a test's delete).
#pragma once

namespace alloc_counter {
void start();
long stop();  // allocations since start()
}  // namespace alloc_counter
