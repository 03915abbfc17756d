// The Kalman filter and the innovations log-likelihood (user guide §1).
//
// For a linear model (core/model/linear_model.h) at one θ and one bound data series:
//
//   state index j = 0 .. N-1 (the data's rows), x_j = x(t_j)
//   observation y_{o,k} of output o at row k sees the state delayed by d_o samples:
//       y_{o,k} = C_o x_{k-d_o} + D_o u_{k-d_o} + d_o + e_{o,k},    e ~ N(0, S_o)
//   so at state index j the filter is updated with every y_{o, j+d_o} that is observed, and
//   observations with k < first_obs_o (by default d_o) are not used.
//
//   Filter order: prior (x0, P0) at t_0; at each j first the measurement update with the
//   observations that see x_j, then the time update to t_{j+1} over Δ_j = t_{j+1} - t_j with the
//   exact discretisation (core/filter/discretize.h), cached once per distinct Δ.
//   P0: "ctsm" = Q(Δ_0); "stationary" = solution of A P + P A' + σσ' = 0; or explicit variances.
//
//   log L = Σ_j -½ [ log det R_j + ε_j' R_j⁻¹ ε_j + p_j log 2π ]
//   (ε_j: innovations of the p_j outputs observed at j, R_j their covariance). With the Huber
//   option the term ½ r_j², r_j = sqrt(ε_j' R_j⁻¹ ε_j), is replaced by ρ_c(r_j) = ½ r² (r ≤ c),
//   c r - ½ c² (r > c); the filter's state update itself is unchanged.
//
// Numerics: the measurement noise is diagonal, so the vector update at j is done as p_j scalar
// updates in sequence. That is exactly the LDL' (Cholesky) factorisation of R_j: the scalar
// innovation variances are the pivots, log det R_j is the sum of their logs, and ε'R⁻¹ε the sum of
// the squared scaled innovations; R_j is never inverted. Each scalar update P -= k k' / r is
// symmetric by construction; the time update is symmetrised.
//
// Speed: the loop is compiled for state dimensions 1..8 with fixed-size matrices and does no
// allocation per sample.
//
// Steady state: with a constant sample interval and no missing entry the Riccati recursion
// converges, and in floating point it reaches a fixed point: a step after which P is, bit for
// bit, what it was before the step (the fuel film: after ~250 rows), or a cycle of a few steps
// after which it is (the last bits alternating: the fuel film with its measurement variance at
// 1e-9). From there every step with the same observed outputs and the same interval repeats the
// recorded step's P c', R and P, so they are replayed from a record and only the mean is
// updated; a step that differs (a missing entry, another interval) ends the replay and the full
// recursion resumes from the P that step starts from. The result is identical, bit for bit, to
// the full recursion (tests/core/score_test.cpp), not an approximation. The score (score.h) does
// the same once P and every dP_i repeat, each in a cycle of its own (linear_step.h). For the
// fixed-size loops (1..8 states); the trace (RunFilter) always runs the full recursion.
#pragma once

#include <atomic>
#include <vector>

#include <Eigen/Core>

#include "core/data/dataset.h"
#include "core/filter/discretize.h"
#include "core/model/linear_model.h"
#include "core/util/result.h"

namespace gb::filter {

// How the linear filter's score (score.h) differentiates where only the gradient is asked for
// (no row's score).
enum class LinearGradient {
  kForward,      // forward sensitivities over every index
  kSteadyState,  // and a replayed steady state that lasts to the end by its adjoint
                 // (linear_loops.h: AdjointOfTheSteadyState)
  kAdjoint,      // the whole recursion by its adjoint (linear_loops.h: AdjointOfTheSeries)
};

struct FilterSettings {
  model::InputHold hold = model::InputHold::kZoh;
  model::InitialCovariance initial_covariance = model::InitialCovariance::kCtsm;
  std::optional<double> huber;  // Huber threshold c, or Gaussian
  std::vector<int> delay;       // per output, samples (empty = all 0)
  std::vector<int> first_obs;   // per output (empty = same as delay)
  // When set to true (from any thread), the filter stops within a few thousand samples and
  // returns an Error with kind kNumerical and message "cancelled".
  const std::atomic<bool>* cancel = nullptr;
  // The initial state's mean and covariance in place of the model's x0 and P0: a validation
  // record's own, from its first samples (initial_state.h). Empty: the model's. Honoured by the
  // filters (this header, ekf.h), their predictions and smoothers, and the simulations
  // (core/sim); not by the scores (score.h, ekf_score.h), which differentiate the model's.
  Eigen::VectorXd x0;
  Eigen::MatrixXd P0;
  // The steady state's replay (above); false: the full recursion at every step, which the tests
  // compare it with.
  bool steady_replay = true;
  // How the score's gradient alone is differentiated (the tests compare each with kForward).
  LinearGradient linear_gradient = LinearGradient::kSteadyState;

  // Hold, P0 and Huber from the model; each output's delay at its `min`.
  static FilterSettings FromModel(const model::ModelSpec& spec);
  // *x and *P, the model's initial state, replaced by x0 and P0 where they are set.
  void OverrideInitial(Eigen::VectorXd* x, Eigen::MatrixXd* P) const {
    if (x0.size() > 0) *x = x0;
    if (P0.size() > 0 && P != nullptr) *P = P0;
  }
};

struct Loglik {
  double loglik = 0.0;
  long n_obs = 0;     // scalar observations used
  long replayed = 0;  // state indices whose covariances the linear filter replayed (steady state)
  long adjoint = 0;   // the indices whose gradient an adjoint gave (score; LinearGradient)
};

// Everything the filter computed, for predictions, residuals and the smoother.
// Matrices over rows: column k is row k of the data. NaN where a value does not exist.
struct FilterTrace {
  Eigen::MatrixXd y_pred;               // p x N: E[y_{o,k} | observations before state index k-d_o]
  Eigen::MatrixXd y_var;                // p x N: its variance (including S_o)
  Eigen::MatrixXd x_pred;               // n x N: E[x_j | observations at state indices < j]
  Eigen::MatrixXd x_filt;               // n x N: E[x_j | observations at state indices <= j]
  std::vector<Eigen::MatrixXd> P_pred;  // N of n x n
  std::vector<Eigen::MatrixXd> P_filt;  // N of n x n
};

// The log-likelihood of one series. Errors (kNumerical): an innovation variance that is not
// positive (names the row and output), a non-finite likelihood, "stationary" P0 with an unstable
// A. Errors (kInput): a delay that leaves no observation in the data.
// With `terms`, also writes the log-likelihood term of every state index j (0 where nothing is
// observed), so that terms->size() == series.size() and the terms sum to the log-likelihood: the
// per-observation contributions whose differences are the scores (for BHHH / Fisher scoring).
Result<Loglik> LogLikelihood(const model::StateSpace& ss, const data::Series& series,
                             const FilterSettings& settings, std::vector<double>* terms = nullptr);

// As LogLikelihood, and fills *trace.
Result<Loglik> RunFilter(const model::StateSpace& ss, const data::Series& series,
                         const FilterSettings& settings, FilterTrace* trace);

// The exact discretisation of every distinct sample interval of `series`
// (series.intervals.distinct), in that order; the filter, the predictions and the simulator use it.
// An interval whose discretisation is not finite (one so long, or a mode so unstable, that
// e^(AΔ) or its integrals overflow) is an error naming the first row and file line it starts at.
Result<std::vector<Discrete>> DiscretizeIntervals(const model::StateSpace& ss,
                                                  const data::Series& series,
                                                  model::InputHold hold);

// Which observations the filter uses on `series` (p outputs): each output's delay and first row
// (settings.first_obs raised to the delay), and the last state index j that an observation sees.
// Errors (kInput) as LogLikelihood: fewer than two rows, or a delay that leaves no observation.
struct ObservationWindow {
  std::vector<int> delay;      // per output
  std::vector<int> first_obs;  // per output
  int last_j = -1;
};
Result<ObservationWindow> ObservationWindowOf(const data::Series& series, int p,
                                              const FilterSettings& settings);

// The initial covariance P0 the filter starts from (for display and tests).
Result<Eigen::MatrixXd> InitialCovariance(const model::StateSpace& ss, const data::Series& series,
                                          const FilterSettings& settings);

}  // namespace gb::filter
