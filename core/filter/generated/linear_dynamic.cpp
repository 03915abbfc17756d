// The linear filter and score loops (linear_loops.h) at dynamic size, for the state dimensions
// above GREYBENCH_FIXED_STATES (internal.h). One of nine files alike: linear_nx1..8.cpp,
// linear_dynamic.cpp.
#include "core/filter/linear_loops.h"

namespace gb::filter::internal {

GREYBENCH_LINEAR_LOOPS(, Eigen::Dynamic)

}  // namespace gb::filter::internal
