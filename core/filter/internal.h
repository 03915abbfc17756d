// Pieces the filter loops share (kalman.cpp, score.cpp); not part of the public API.
#pragma once

#include <cmath>
#include <string>
#include <type_traits>
#include <utility>

#include <Eigen/Core>
#include <fmt/format.h>

#include "core/data/dataset.h"
#include "core/filter/discretize.h"
#include "core/util/result.h"

namespace gb::filter::internal {

inline constexpr double kLog2Pi = 1.8378770664093454835606594728112;  // log(2π)

// The linear filters look at the cancel flag every this many samples: well under a millisecond
// of work in a release build, a few under the sanitizers, so a cancel is seen within the
// workbench's 100 ms (4096 was not: docs/benchmarks.md, "Timings behind the code's limits").
// The EKF looks at it every sample, where one sample's moment integration outweighs the look by
// far.
inline constexpr int kCancelCheckInterval = 256;  // a power of two
static_assert((kCancelCheckInterval & (kCancelCheckInterval - 1)) == 0);

// The negative log-density's quadratic part at a state index, from r2 = Σ ε²/R over its observed
// outputs: ½ r2 (Gaussian), or with Huber's threshold c (`robust`) c r − ½ c² beyond r = c. With
// d_rho: its derivative with respect to r2 (½, or c / (2r) beyond the threshold).
inline double HuberRho(double r2, bool robust, double c, double* d_rho = nullptr) {
  if (d_rho) *d_rho = 0.5;
  if (!robust) return 0.5 * r2;
  const double r = std::sqrt(r2);
  if (r <= c) return 0.5 * r2;
  if (d_rho) *d_rho = c / (2.0 * r);
  return c * r - 0.5 * c * c;
}

// Largest state dimension with a fixed-size instantiation of the loops: 8, or what the build
// sets (GREYBENCH_FIXED_STATES in CMake; the sanitizer build compiles 1 and 2 only, a third of
// the instantiations, and runs the larger models through the dynamic-size loop, docs/quality.md).
#ifndef GREYBENCH_MAX_FIXED_STATES
#define GREYBENCH_MAX_FIXED_STATES 8
#endif
inline constexpr int kMaxFixedStates = GREYBENCH_MAX_FIXED_STATES;
static_assert(kMaxFixedStates >= 0 && kMaxFixedStates <= 16);

// f(StateDimension<NX>{}) with NX = n for n in 1..kMaxFixedStates (fixed-size matrices), else
// Eigen::Dynamic: the loops are compiled once per state dimension. (A generic lambda taking the
// dimension as a type, rather than a template lambda, which cppcheck 2.10 cannot parse.)
template <int NX>
using StateDimension = std::integral_constant<int, NX>;

template <class F, int NX = 1>
decltype(auto) WithStateDimension(int n, F&& f) {
  if constexpr (NX > kMaxFixedStates) {
    return f(StateDimension<Eigen::Dynamic>{});
  } else {
    if (n == NX) return f(StateDimension<NX>{});
    return WithStateDimension<F, NX + 1>(n, std::forward<F>(f));
  }
}

// One discretisation (discretize.h) with the state dimension fixed at compile time.
template <int NX>
struct FixedDiscrete {
  Eigen::Matrix<double, NX, NX> Phi, Q;
  Eigen::Matrix<double, NX, Eigen::Dynamic> Gamma0, Gamma1;
  Eigen::Matrix<double, NX, 1> g;
  explicit FixedDiscrete(const Discrete& d)
      : Phi(d.Phi), Q(d.Q), Gamma0(d.Gamma0), Gamma1(d.Gamma1), g(d.g) {}
};

// P <- (P + P')/2 in place (no temporary: the dynamic-size loop must not allocate).
template <class Mat>
void Symmetrize(Mat& P) {
  for (Eigen::Index j = 1; j < P.cols(); ++j) {
    for (Eigen::Index i = 0; i < j; ++i) {
      const double v = 0.5 * (P(i, j) + P(j, i));
      P(i, j) = v;
      P(j, i) = v;
    }
  }
}

// R_k is not positive definite: its pivot for output o at row k is R (zero, negative or NaN).
inline Error NotPositiveInnovationVariance(const data::Series& series, int o, int k, double R) {
  const std::string output = o < static_cast<int>(series.outputs.size())
                                 ? fmt::format("'{}'", series.outputs[o])
                                 : fmt::format("{}", o + 1);
  Error e = NumericalError(fmt::format(
      "the innovation variance of output {} at row {} (t = {:g}) is {:g}, not positive: the "
      "model claims to predict this observation exactly (a measurement variance of zero, and "
      "no uncertainty in the state?)",
      output, k + 1, series.time[k], R));
  e.file = series.source;
  if (k < static_cast<int>(series.row_line.size())) e.line = series.row_line[k];
  return e;
}

inline Error NotFiniteLoglik(const data::Series& series) {
  return NumericalError(
      fmt::format("{}: the log-likelihood is not finite at these parameter values", series.source));
}

}  // namespace gb::filter::internal
