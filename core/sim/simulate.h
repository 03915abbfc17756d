// Sample paths and deterministic responses of a linear SDE model at given input samples.
//
//   x_0 ~ N(x0, P0)               (P0 as the filter uses it: ctsm / stationary / explicit)
//   x_{j+1} = Φ_j x_j + Γ0_j u_j + Γ1_j u_{j+1} + g_j + v_j,   v_j ~ N(0, Q(Δ_j))   (exact)
//   y_{o,k} = C_o x_{k-d_o} + D_o u_{k-d_o} + d_o + e_{o,k},   e ~ N(0, S_o)
// Outputs with k < d_o see no state and are missing (NaN). With `process_noise` and
// `measurement_noise` off, and `random_initial_state` off, the result is the deterministic
// response from x0 (the "simulation" of the model).
#pragma once

#include <cstdint>

#include <Eigen/Core>

#include "core/data/dataset.h"
#include "core/filter/kalman.h"
#include "core/model/linear_model.h"

namespace gb::sim {

struct SimulateOptions {
  std::uint64_t seed = 1;
  bool process_noise = true;
  bool measurement_noise = true;
  bool random_initial_state = true;  // draw x_0 from N(x0, P0); otherwise x_0 = x0
};

struct Simulation {
  Eigen::MatrixXd X;  // n x N states
  Eigen::MatrixXd Y;  // p x N outputs (NaN where the delay leaves no state)
};

// The most numbers a simulation holds, N · (n + p) (800 MB of doubles): checked before anything
// is allocated.
inline constexpr double kMaxSimulatedValues = 1e8;
// An input Error, saying the limit, when N rows of n states and p outputs would pass it.
Status CheckSimulationSize(std::int64_t rows, int states, int outputs);

// `series` supplies the times and inputs (its Y is not used). Fails where P0 fails ("stationary"
// with an unstable A), where the size passes kMaxSimulatedValues, and (a numerical Error naming
// the row, its time and the state) where the path is not finite (an unstable model over a long
// record).
Result<Simulation> Simulate(const model::StateSpace& ss, const data::Series& series,
                            const filter::FilterSettings& settings, const SimulateOptions& options);

}  // namespace gb::sim
