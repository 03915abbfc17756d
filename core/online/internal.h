// What the on-line estimators share (recursive.cpp, augmented.cpp, ekf_stream.cpp, monitor.cpp):
// the working coordinates that keep a parameter inside its bounds, the choice of the tracked
// parameters, and the constants for "none" and "never".
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>
#include <span>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "core/model/model.h"
#include "core/online/estimator.h"
#include "core/util/result.h"

namespace gb::online::internal {

inline constexpr double kInf = std::numeric_limits<double>::infinity();
inline constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
// A parameter on a bound starts this fraction of its range (or of 1 + |bound|) inside it.
inline constexpr double kInside = 1e-6;

// The working coordinate w of a parameter with bounds [lo, hi]: log((θ-lo)/(hi-θ)) with both,
// log(θ-lo) or -log(hi-θ) with one, θ itself with none. The estimators move w, so that the
// bounds hold by construction and a scale parameter moves by factors, not by increments.
inline double ToWorking(double v, double lo, double hi) {
  const bool has_lo = std::isfinite(lo), has_hi = std::isfinite(hi);
  if (has_lo && has_hi) return std::log((v - lo) / (hi - v));
  if (has_lo) return std::log(v - lo);
  if (has_hi) return -std::log(hi - v);
  return v;
}
inline double FromWorking(double w, double lo, double hi) {
  const bool has_lo = std::isfinite(lo), has_hi = std::isfinite(hi);
  if (has_lo && has_hi) return lo + (hi - lo) / (1.0 + std::exp(-w));
  if (has_lo) return lo + std::exp(w);
  if (has_hi) return hi - std::exp(-w);
  return w;
}
// dθ/dw at θ = v.
inline double WorkingSlope(double v, double lo, double hi) {
  const bool has_lo = std::isfinite(lo), has_hi = std::isfinite(hi);
  if (has_lo && has_hi) return (v - lo) * (hi - v) / (hi - lo);
  if (has_lo) return v - lo;
  if (has_hi) return hi - v;
  return 1.0;
}
// v moved kInside of the range inside its bounds.
inline double Inside(double v, double lo, double hi) {
  const double span =
      std::isfinite(hi - lo) ? hi - lo : 1.0 + std::abs(std::isfinite(lo) ? lo : hi);
  if (std::isfinite(lo)) v = std::max(v, lo + kInside * span);
  if (std::isfinite(hi)) v = std::min(v, hi - kInside * span);
  return v;
}

// The parameters to track: all of `trackable` when `names` is empty, else those named (sorted,
// each once). Errors name a parameter that is not trackable and list those that are; `why` says
// what makes a parameter trackable for this estimator.
Result<std::vector<int>> ChooseTracked(const model::ModelSpec& spec,
                                       const std::vector<int>& trackable,
                                       std::span<const std::string> names, const char* why);

// The prior covariance of the tracked parameters in working coordinates (slope: dθ/dw at the
// start): the reference's covariance D⁻¹ Σ D⁻¹ (D = diag slope), scaled to `prior_rows` rows of
// data (<= 0: the memory 1/(1-λ), or the reference's own rows for λ = 1) from the reference's
// rows (n_obs / outputs); without a usable covariance, a weak prior of 2 units of the working
// coordinate for a bounded parameter (a factor e² in a scale parameter), or the parameter's size
// (at least 1) for an unbounded one.
Eigen::MatrixXd PriorCovariance(const Reference& reference, std::span<const int> tracked,
                                const Eigen::VectorXd& slope, std::span<const double> lower,
                                std::span<const double> upper, std::span<const double> theta,
                                const RecursiveOptions& options, int outputs);

}  // namespace gb::online::internal
