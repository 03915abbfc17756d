// The two simulations a model offers at any θ, before or after estimation, on the times and
// measured inputs of a data series (its outputs are not used):
//
//   deterministic response (the "simulation" of the model, no filtering, no noise):
//     x_0 = x0,   x_{j+1} = Φ_j x_j + Γ0_j u_j + Γ1_j u_{j+1} + g_j          (exact discretisation)
//     y_{o,k} = C_o x_{k-d_o} + D_o u_{k-d_o} + d_o                          (NaN for k < d_o)
//   sample path: the same with x_0 ~ N(x0, P0), process noise v_j ~ N(0, Q_j) and measurement
//     noise e_{o,k} ~ N(0, S_o), reproducible from `seed` (core/sim/random.h).
// Both are Simulate (core/sim/simulate.h) with the corresponding options; delays and the input
// hold come from `settings`, as in the filter.
#pragma once

#include <cstdint>

#include "core/sim/simulate.h"

namespace gb::sim {

// Never fails (P0 is not used); a Result for symmetry with SamplePath.
Result<Simulation> DeterministicResponse(const model::StateSpace& ss, const data::Series& series,
                                         const filter::FilterSettings& settings);

// Fails where P0 fails ("stationary" with an unstable A).
Result<Simulation> SamplePath(const model::StateSpace& ss, const data::Series& series,
                              const filter::FilterSettings& settings, std::uint64_t seed);

}  // namespace gb::sim
