// Predictions and smoothed states of a linear model at one θ (any θ: a model can be previewed
// before it is estimated). The deterministic simulation and sample paths are in
// core/sim/response.h.
//
// Notation as in core/filter/kalman.h: state index j = 0 .. N-1 (the data's rows), output o has
// the delay d_o (samples), and
//   y_{o,k} = C_o x_{k-d_o} + D_o u_{k-d_o} + d_o + e_{o,k},    e_{o,k} ~ N(0, S_o),
// so the output at row k is predicted from the state at index j = k - d_o, and no output exists
// for k < d_o (NaN everywhere below). "Observations up to state index j" means every y_{o,i+d_o}
// with i <= j that the filter uses (the filter's information set after its update at j).
// Every time step j -> j+1 uses the exact discretisation over Δ_j = t_{j+1} - t_j
// (core/filter/discretize.h) with the measured inputs and the model's input hold:
//   x_{j+1} = Φ_j x_j + Γ0_j u_j + Γ1_j u_{j+1} + g_j + v_j,     v_j ~ N(0, Q_j).
//
// One-step prediction (from the filter's trace):
//   ŷ_{o,k}  = E[y_{o,k} | observations up to state index k-d_o-1] = C_o x̂_{j|j-1} + D_o u_j + d_o
//   sd_{o,k} = sqrt(C_o P_{j|j-1} C_o' + S_o)                            (j = k - d_o)
//   ε_{o,k}  = y_{o,k} - ŷ_{o,k}    (the innovation; NaN where y is missing)
//   standardised residual z_{o,k} = ε_{o,k} / sd_{o,k}, only where the filter uses y_{o,k}
//   (k >= first_obs_o, see FilterSettings); these are the residuals core/diagnose tests.
//
// h-step prediction (h >= 0): from the filtered state at s = j - h,
//   x̂_{j|s} = Φ_{j-1} x̂_{j-1|s} + Γ0_{j-1} u_{j-1} + Γ1_{j-1} u_j + g_{j-1}
//   P_{j|s}  = Φ_{j-1} P_{j-1|s} Φ_{j-1}' + Q_{j-1}          (starting at x̂_{s|s}, P_{s|s})
//   ŷ_{o,k}  = C_o x̂_{j|s} + D_o u_j + d_o                   (j = k - d_o)
//   sd_{o,k} = sqrt(C_o P_{j|s} C_o' + S_o)
// The inputs between s and j are the measured ones (known future inputs, as in a simulation).
// For j < h there is no observation to condition on and the prediction starts from the prior
// (x0, P0) at index 0. h = 1 is the one-step prediction; h = 0 gives the filtered output.
// For the scalar Ornstein-Uhlenbeck process dx = -a x dt + σ dω, y = x + e, Δ constant:
//   Var(y_{j+h} | up to j) = e^{-2ahΔ} P_{j|j} + σ²(1 - e^{-2ahΔ})/(2a) + S.
//
// Smoothed states (Rauch-Tung-Striebel), conditioned on every observation of the series:
//   x̂_{N-1|N} = x̂_{N-1|N-1},  P_{N-1|N} = P_{N-1|N-1}
//   G_j = P_{j|j} Φ_j' P_{j+1|j}⁻¹       (solved by a rank-revealing complete orthogonal
//                                        decomposition, never inverted: a P_{j+1|j} that is
//                                        singular to rounding, as for a state without noise,
//                                        uses the pseudo-inverse)
//   x̂_{j|N} = x̂_{j|j} + G_j (x̂_{j+1|N} - x̂_{j+1|j})
//   P_{j|N} = P_{j|j} + G_j (P_{j+1|N} - P_{j+1|j}) G_j'
// Φ_j is recomputed once per distinct interval, as the filter does. The smoothed output is the
// noise-free C_o x̂_{j|N} + D_o u_j + d_o with sd sqrt(C_o P_{j|N} C_o') (no S_o).
//
// Failures: those of RunFilter (an innovation variance that is not positive, an unstable A with
// "stationary" P0, a delay longer than the data). Preconditions (asserted): the series is bound
// to the model; a trace passed in was made by RunFilter for the same model, series and settings.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "core/data/dataset.h"
#include "core/filter/kalman.h"
#include "core/model/linear_model.h"
#include "core/util/result.h"

namespace gb::filter {

struct OneStepPredictions {
  Eigen::MatrixXd y_pred;        // p x N, NaN for k < d_o
  Eigen::MatrixXd y_sd;          // p x N, includes the measurement noise S_o
  Eigen::MatrixXd residual;      // p x N, y - y_pred; NaN where y is missing or k < d_o
  Eigen::MatrixXd standardized;  // p x N, residual / y_sd where the filter uses y (else NaN)
  Loglik loglik;                 // the filter's log-likelihood of the series
};

struct HorizonPredictions {
  int horizon = 1;                 // h
  Eigen::MatrixXd y_pred;          // p x N, NaN for k < d_o
  Eigen::MatrixXd y_sd;            // p x N, includes S_o
  Eigen::MatrixXd x_pred;          // n x N: E[x_j | observations up to state index j - h]
  std::vector<Eigen::MatrixXd> P;  // N of n x n: its covariance
};

struct SmoothedStates {
  Eigen::MatrixXd x;               // n x N: E[x_j | every observation]
  std::vector<Eigen::MatrixXd> P;  // N of n x n
  Eigen::MatrixXd y;               // p x N: noise-free output at the smoothed state (NaN k < d_o)
  Eigen::MatrixXd y_sd;            // p x N: sqrt(C_o P_{j|N} C_o'), without S_o
};

// The delay and first used observation of every output, as the filter applies them (settings
// with empty vectors mean 0 and "same as the delay").
std::vector<int> EffectiveDelay(const FilterSettings& settings, int n_outputs);
std::vector<int> EffectiveFirstObservation(const FilterSettings& settings, int n_outputs);

// Runs the filter and returns its one-step predictions.
Result<OneStepPredictions> PredictOneStep(const model::StateSpace& ss, const data::Series& series,
                                          const FilterSettings& settings);
// The same from a trace already computed (`loglik` is left as given).
OneStepPredictions OneStepFromTrace(const model::StateSpace& ss, const data::Series& series,
                                    const FilterSettings& settings, const FilterTrace& trace,
                                    const Loglik& loglik = {});
// The same from any filter's trace (the extended Kalman filter's too, ekf.h).
OneStepPredictions OneStepFromTrace(const data::Series& series, const FilterSettings& settings,
                                    const FilterTrace& trace, const Loglik& loglik = {});

// h-step predictions, h >= 0 (asserted). Runs the filter.
Result<HorizonPredictions> PredictAhead(const model::StateSpace& ss, const data::Series& series,
                                        const FilterSettings& settings, int horizon);
// The same from a trace. Fails only where the initial covariance fails.
Result<HorizonPredictions> PredictAheadFromTrace(const model::StateSpace& ss,
                                                 const data::Series& series,
                                                 const FilterSettings& settings,
                                                 const FilterTrace& trace, int horizon);

// Rauch-Tung-Striebel smoothed states. Runs the filter.
Result<SmoothedStates> Smooth(const model::StateSpace& ss, const data::Series& series,
                              const FilterSettings& settings);
SmoothedStates SmoothFromTrace(const model::StateSpace& ss, const data::Series& series,
                               const FilterSettings& settings, const FilterTrace& trace);

// y_{o,k} = C_o x_{k-d_o} + D_o u_{k-d_o} + d_o for every row k >= d_o (NaN below), from states
// X (n x N). Without noise: the output map the predictions and the simulation share.
Eigen::MatrixXd OutputMean(const model::StateSpace& ss, const data::Series& series,
                           const std::vector<int>& delay, const Eigen::MatrixXd& X);

}  // namespace gb::filter
