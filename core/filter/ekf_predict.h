// Predictions of a model through the extended Kalman filter (ekf.h), with the shapes and
// conventions of the linear ones (predict.h): delays, first observations, NaN where no value
// exists.
//
//   one step   from the filter's trace: ŷ_{o,k} = h_o(x̂_{j|j-1}), sd² = H_o P_{j|j-1} H_o' + S_o
//   h steps    the moment equations integrated over h intervals without updates, from the filtered
//              (x̂_{s|s}, P_{s|s}) at s = j - h (from the prior at index 0 for j < h); h = 0 gives
//              the filtered output h(x̂_{j|j})
//   open loop  from the prior at index 0 over the whole series, without any update: the mean is
//              the deterministic response (the "simulation": dx/dt = f(x, u, θ, t) from x0), and
//              P its first-order uncertainty
//   smoothed   the extended Rauch-Tung-Striebel smoother: backwards from the last filtered state,
//                x̂_{j|N} = x̂_{j|j} + G_j (x̂_{j+1|N} - x̂_{j+1|j}),   G_j = P_{j|j} Φ_j' P_{j+1|j}⁻¹
//                P_{j|N} = P_{j|j} + G_j (P_{j+1|N} - P_{j+1|j}) G_j'
//              with Φ_j = ∂x̂(t_{j+1})/∂x̂(t_j) the transition matrix of the linearisation about
//              the predicted mean (MomentPropagator::Advance), so P_{j|j} Φ_j' is the first-order
//              cross-covariance of x_j and x_{j+1}. For a linear model Φ_j = e^{AΔ_j}: the linear
//              smoother (predict.h) to the ODE tolerance.
// Outputs at state index j are y_{o, j+d_o} = h_o(x̂_j, u_j, θ, t_j) with sd² = H_o P H_o' + S_o
// (the smoothed outputs without S_o, as predict.h's).
#pragma once

#include <span>

#include "core/filter/ekf.h"
#include "core/filter/predict.h"

namespace gb::filter {

// Runs the filter: one-step predictions, residuals and standardised residuals.
Result<OneStepPredictions> EkfPredictOneStep(const model::NonlinearModel& model,
                                             std::span<const double> theta,
                                             const data::Series& series,
                                             const FilterSettings& settings);

// h-step predictions (h >= 0) from a trace EkfRunFilter made for the same θ, series, settings.
Result<HorizonPredictions> EkfPredictAhead(const model::NonlinearModel& model,
                                           std::span<const double> theta,
                                           const data::Series& series,
                                           const FilterSettings& settings, const FilterTrace& trace,
                                           int horizon);

// Smoothed states and outputs from a trace EkfRunFilter made for the same θ, series, settings.
// Fails where the moment equations fail (they did not for the filter, but are integrated again
// with Φ).
Result<SmoothedStates> EkfSmooth(const model::NonlinearModel& model, std::span<const double> theta,
                                 const data::Series& series, const FilterSettings& settings,
                                 const FilterTrace& trace);

// The open-loop prediction (horizon = -1 in the result).
Result<HorizonPredictions> EkfOpenLoop(const model::NonlinearModel& model,
                                       std::span<const double> theta, const data::Series& series,
                                       const FilterSettings& settings);

}  // namespace gb::filter
