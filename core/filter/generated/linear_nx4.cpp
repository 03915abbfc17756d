// The linear filter and score loops (linear_loops.h) for 4 states, when the build compiles this
// size with fixed-size matrices (GREYBENCH_FIXED_STATES, internal.h). One of nine files alike:
// linear_nx1..8.cpp, linear_dynamic.cpp.
#include "core/filter/linear_loops.h"

namespace gb::filter::internal {

#if 4 <= GREYBENCH_MAX_FIXED_STATES
GREYBENCH_LINEAR_LOOPS(, 4)
#endif

}  // namespace gb::filter::internal
