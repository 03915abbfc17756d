// The expected (Fisher) information of a linear model's parameters for a given input: the
// standard errors an experiment would give before it is run (experiment design, issue 39).
//
// The model (core/model/linear_model.h) at θ is taken as the truth, the record's inputs and
// sample times as designed, and every output observed at every row (as the filter would use
// them: each output's delay and first row, kalman.h). The innovations log-likelihood
//   log L = Σ_terms -½ [log R + ε²/R + log 2π]       (the filter's scalar updates, kalman.h)
// has the expected information, exactly (no simulation, no asymptotics),
//   I_ab = Σ_terms  E[∂_a ε ∂_b ε] / R  +  ½ ∂_a R ∂_b R / R²
// because each innovation is independent of the past, and R and ∂R do not depend on the data
// (score.h gives ∂ε and ∂R). ∂ε is a linear function of the true state x, the filter's mean x̂,
// its sensitivities ∂_i x̂ and the noises, so its moments come from propagating, beside the filter,
// the mean and the covariance of the joint vector
//   z = [x; x̂; ∂_1 x̂; ...; ∂_k x̂]                                    (n (k + 2) entries)
// through the filter's own steps (the time update  x' = Φ x + Γ0 u + Γ1 u⁺ + g + v, v ~ N(0, Q),
// x̂' and ∂x̂' as in score.h; each scalar measurement update, y = c x + D_o u + d_o + e,
// e ~ N(0, S_o), linear in z and e). E[∂_a ε ∂_b ε] = m_a m_b + Cov(∂_a ε, ∂_b ε): the mean part
// m (the input's response) and the noise's part, so
//   I = I_input + I_noise,
// where I_noise, the information the process and measurement noise carry, does not depend on the
// input (a linear model's filter gains do not), and I_input grows with the input's amplitude
// squared. x_0 ~ N(x0, P0) with P0 the filter's (ctsm / stationary / explicit).
//
// The standard errors are sqrt(diag(I⁻¹)). Cost: O(N (n (k + 2))² (k + n)) for N rows, k
// parameters, n states (the fuel film's 10 000 rows, 8 parameters: about 0.1 s).
#pragma once

#include <optional>
#include <span>
#include <vector>

#include <Eigen/Core>

#include "core/data/dataset.h"
#include "core/filter/kalman.h"
#include "core/model/linear_model.h"
#include "core/util/result.h"

namespace gb::design {

struct ExpectedInformation {
  std::vector<int> parameters;  // indices into the model's parameters, in the order of `I`
  Eigen::MatrixXd information;  // k x k, I = E[s s'] (s the score)
  Eigen::MatrixXd from_input;   // I_input (the mean response's part); I - I_input = I_noise
  long n_obs = 0;               // scalar observations the filter uses
  // I⁻¹ and the standard errors where I is positive definite (relative to its diagonal: the
  // smallest eigenvalue of the correlation form above kSingular); otherwise empty, and
  // `undetermined` names the parameter most involved in the null direction.
  Eigen::MatrixXd covariance;
  std::vector<std::optional<double>> std_error;  // k
  std::optional<int> undetermined;               // index into `parameters`
};

inline constexpr double kSingular = 1e-12;

// Preconditions: theta has the model's parameters; every index in `parameters` is a parameter;
// series is bound to the model's inputs and outputs (its Y's finite entries are the observations
// the design has; their values are not used). Errors (kNumerical): P0 or an interval's
// discretisation that fails as the filter's would, an innovation variance that is not positive,
// a derivative of the model's entries that is not finite; (kInput): a delay that leaves no
// observation. settings.huber is ignored (the information is the Gaussian likelihood's).
Result<ExpectedInformation> ExpectedFisherInformation(const model::LinearModel& model,
                                                      std::span<const double> theta,
                                                      std::span<const int> parameters,
                                                      const data::Series& series,
                                                      const filter::FilterSettings& settings);

}  // namespace gb::design
