// Simulations of a model that is not linear (model::NonlinearModel) on the times and measured
// inputs of a data series (its outputs are not used), as response.h offers for linear models:
//
//   deterministic response  dx/dt = f(x, u(t), θ, t) from x0 without noise (the mean of the
//     open-loop moment equations, core/filter/ekf_predict.h, integrated with error control),
//     y_{o,k} = h_o(x_{k-d_o}, u_{k-d_o}, θ, t_{k-d_o})                    (NaN for k < d_o)
//   sample path  x_0 ~ N(x0, P0) (P0 as the filter starts); between samples the Milstein scheme
//     on `substeps` equal sub-steps of each interval, more where the model is stiff (at least
//     ρ Δ with ρ = max_i Σ_j |∂f_i/∂x_j| at the interval's start, so that the explicit scheme
//     stays stable), u held or interpolated as the filter does:
//       x_i <- x_i + f_i h + σ_i ΔW_i + ½ σ_i ∂σ_i/∂x_i (ΔW_i² - h),   ΔW_i ~ N(0, h)
//     which has strong order 1 when each σ_i depends on the states through x_i only (diagonal
//     noise; always so for additive noise) and order ½ otherwise (the Lévy areas are not drawn);
//     y_{o,k} = h_o(...) + e_{o,k},  e_{o,k} ~ N(0, S_o); reproducible from `seed` (random.h).
#pragma once

#include <cstdint>
#include <span>

#include "core/filter/kalman.h"
#include "core/model/nonlinear_model.h"
#include "core/sim/simulate.h"

namespace gb::sim {

Result<Simulation> DeterministicResponse(const model::NonlinearModel& model,
                                         std::span<const double> theta, const data::Series& series,
                                         const filter::FilterSettings& settings);

// Fails where the initial covariance fails, where the size passes kMaxSimulatedValues
// (simulate.h), or where the path leaves the model's domain (an entry that is not finite:
// "drift.h1 is not a number at these values (h1 = -0.01, ...)").
Result<Simulation> SamplePath(const model::NonlinearModel& model, std::span<const double> theta,
                              const data::Series& series, const filter::FilterSettings& settings,
                              std::uint64_t seed, int substeps = 20);

}  // namespace gb::sim
