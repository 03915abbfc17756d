// Pieces every filter loop shares (the linear filter and its score, the EKF and its score, the
// on-line estimators); not part of the public API. The linear filter's step is linear_step.h.
#pragma once

#include <atomic>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <fmt/format.h>

#include "core/data/dataset.h"
#include "core/filter/discretize.h"
#include "core/filter/kalman.h"
#include "core/util/result.h"

namespace gb::filter::internal {

inline constexpr double kLog2Pi = 1.8378770664093454835606594728112;  // log(2π)
inline constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// The linear filters look at the cancel flag every this many samples: well under a millisecond
// of work in a release build, a few under the sanitizers, so a cancel is seen within the
// workbench's 100 ms (4096 was not: docs/benchmarks.md, "Timings behind the code's limits").
// The EKF looks at it every sample, where one sample's moment integration outweighs the look by
// far.
inline constexpr int kCancelCheckInterval = 256;  // a power of two
static_assert((kCancelCheckInterval & (kCancelCheckInterval - 1)) == 0);

// Whether a linear loop stops at state index j: `cancel` set, looked at every
// kCancelCheckInterval indices.
[[gnu::always_inline]] inline bool CancelledAt(const std::atomic<bool>* cancel, int j) {
  return cancel && (j & (kCancelCheckInterval - 1)) == 0 && cancel->load(std::memory_order_relaxed);
}

// The negative log-density's quadratic part at a state index, from r2 = Σ ε²/R over its observed
// outputs: ½ r2 (Gaussian), or with Huber's threshold c (`robust`) c r − ½ c² beyond r = c. With
// d_rho: its derivative with respect to r2 (½, or c / (2r) beyond the threshold).
[[gnu::always_inline]] inline double HuberRho(double r2, bool robust, double c,
                                              double* d_rho = nullptr) {
  if (d_rho) *d_rho = 0.5;
  if (!robust) return 0.5 * r2;
  const double r = std::sqrt(r2);
  if (r <= c) return 0.5 * r2;
  if (d_rho) *d_rho = c / (2.0 * r);
  return c * r - 0.5 * c * c;
}

// The log-likelihood term of a state index (kalman.h) from its p_j scalar updates:
//   ℓ_j = -(½ (log det R_j + p_j log 2π) + ρ(r²)),   log det R_j = Σ log R,  r² = Σ ε²/R
// ρ as HuberRho (Gaussian without `huber`); with d_rho, ρ'(r²) for TermDerivative.
[[gnu::always_inline]] inline double LoglikTerm(double logdet, int p_j, double r2, bool robust,
                                                double c, double* d_rho = nullptr) {
  const double rho = HuberRho(r2, robust, c, d_rho);
  return -(0.5 * (logdet + p_j * kLog2Pi) + rho);
}
// The same with Huber's threshold as FilterSettings::huber holds it.
[[gnu::always_inline]] inline double LoglikTerm(double logdet, int p_j, double r2,
                                                const std::optional<double>& huber,
                                                double* d_rho = nullptr) {
  return LoglikTerm(logdet, p_j, r2, huber.has_value(), huber.value_or(0.0), d_rho);
}

// Its derivative along one θ_i from Σ dR/R (d_logdet) and Σ d(ε²/R) (d_r2):
//   dℓ_j = -(½ Σ dR/R + ρ'(r²) Σ d(ε²/R))
[[gnu::always_inline]] inline double TermDerivative(double d_logdet, double d_r2, double d_rho) {
  return -(0.5 * d_logdet + d_rho * d_r2);
}

// Which observations a loop over the state indices of a series uses (kalman.h's rule: y_{o, j+d_o}
// within the series, at or after the output's first observation, not missing), read from the
// series and its window once, before the loop.
class ObservationRule {
 public:
  ObservationRule(const data::Series& series, const ObservationWindow& window)
      : Y_(series.Y.data()),
        delay_(window.delay.data()),
        first_obs_(window.first_obs.data()),
        p_(static_cast<int>(series.Y.rows())),
        N_(static_cast<int>(series.size())) {}

  int p() const { return p_; }
  // The row y_{o, j+d_o} is at.
  [[gnu::always_inline]] int Row(int j, int o) const { return j + delay_[o]; }
  // y_{o, k} (k = Row(j, o)).
  [[gnu::always_inline]] double Y(int k, int o) const {
    return Y_[static_cast<std::size_t>(k) * p_ + o];
  }
  [[gnu::always_inline]] bool IsObserved(int j, int o) const {
    const int k = Row(j, o);
    return k < N_ && k >= first_obs_[o] && !std::isnan(Y(k, o));
  }
  // The outputs observed at j as a mask, bit o for output o (p <= 64 outputs).
  [[gnu::always_inline]] std::uint64_t Mask(int j) const {
    std::uint64_t mask = 0;
    for (int o = 0; o < p_; ++o)
      if (IsObserved(j, o)) mask |= std::uint64_t{1} << o;
    return mask;
  }

 private:
  const double* Y_;
  const int* delay_;
  const int* first_obs_;
  int p_, N_;
};

// The outputs observed at one state index, in order; room for all p outputs is made once, so
// that filling it in a filter's loop calls nothing.
class ObservedOutputs {
 public:
  explicit ObservedOutputs(int p) : outputs_(static_cast<std::size_t>(p)) {}
  const int* begin() const { return outputs_.data(); }
  const int* end() const { return outputs_.data() + count_; }
  int size() const { return count_; }
  bool empty() const { return count_ == 0; }

 private:
  friend void ObservedAt(int, const ObservationRule&, ObservedOutputs*);
  std::vector<int> outputs_;
  int count_ = 0;
};

// The outputs observed at state index j, into *observed (made for p outputs).
[[gnu::always_inline]] inline void ObservedAt(int j, const ObservationRule& rule,
                                              ObservedOutputs* observed) {
  int* out = observed->outputs_.data();
  int count = 0;
  for (int o = 0; o < rule.p(); ++o) {
    if (!rule.IsObserved(j, o)) continue;
    out[count++] = o;
  }
  observed->count_ = count;
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
[[gnu::always_inline]] inline void Symmetrize(Mat& P) {
  for (Eigen::Index j = 1; j < P.cols(); ++j) {
    for (Eigen::Index i = 0; i < j; ++i) {
      const double v = 0.5 * (P(i, j) + P(j, i));
      P(i, j) = v;
      P(j, i) = v;
    }
  }
}

// *trace sized for n states, p outputs and N rows, every value NaN until the filter writes it.
inline void ResetTrace(int n, int p, int N, FilterTrace* trace) {
  trace->y_pred.setConstant(p, N, kNaN);
  trace->y_var.setConstant(p, N, kNaN);
  trace->x_pred.setConstant(n, N, kNaN);
  trace->x_filt.setConstant(n, N, kNaN);
  trace->P_pred.assign(N, Eigen::MatrixXd());
  trace->P_filt.assign(N, Eigen::MatrixXd());
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
