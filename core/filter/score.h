// The exact score of the innovations log-likelihood (kalman.h): ∂ log L/∂θ_i for chosen
// parameters θ_i on their natural scale, and the score of every per-state-index term,
// ∂ℓ_j/∂θ_i (BHHH's information is Σ_j s_j s_j' with s_j = ∂ℓ_j/∂θ).
//
// Forward-mode sensitivities carried beside the filter, one set per θ_i (d = ∂/∂θ_i):
//
//   entries         dA dB dc dC dD dd dσ dS dx0 dP0_diag   (model::LinearModel::EvaluateJacobian)
//                   dG = d(σσ') = diag(2 σ dσ)
//   discretisation  dΦ dΓ0 dΓ1 dg dQ for every distinct Δ  (DiscretizeDerivative, discretize.h)
//   P0              ctsm:        dP0 = dQ(Δ_0)
//                   stationary:  A dP0 + dP0 A' = -(dA P0 + P0 dA' + dG)   (LyapunovOperator)
//                   explicit:    dP0 = diag(dP0_diag)
//   measurement update, one scalar observation y of output o at state index j (c = C_o):
//       ŷ = c x + D_o u_j + d_o                 dŷ = dc x + c dx + dD_o u_j + dd_o
//       k = P c'                                dk = dP c' + P dc'
//       R = c k + S_o                           dR = dc k + c dk + dS_o
//       ε = y - ŷ                               dε = -dŷ
//       x <- x + k ε/R                          dx <- dx + dk ε/R + k (dε/R - ε dR/R²)
//       P <- P - k k'/R                         dP <- dP - (dk k' + k dk')/R + k k' dR/R²
//   term of state index j (p_j observations; r² = Σ ε²/R over them):
//       ℓ_j = -½ [Σ log R + p_j log 2π] - ρ(r²)
//       dℓ_j = -½ Σ dR/R - ρ'(r²) Σ (2 ε dε/R - ε² dR/R²)
//       Gaussian: ρ = ½ r², ρ' = ½.   Huber (c): ρ' = ½ for r ≤ c, c/(2r) for r > c
//       (ρ_c(r) = c r - ½c² as a function of r² = r·r); the filter's update itself is unchanged.
//   time update over Δ_j:
//       x' = Φ x + Γ0 u_j + Γ1 u_{j+1} + g      dx' = dΦ x + Φ dx + dΓ0 u_j + dΓ1 u_{j+1} + dg
//       P' = Φ P Φ' + Q                         dP' = Φ dP Φ' + T + T' + dQ,   T = dΦ P Φ'
//
// Cost: about (k + 1) times a value-only evaluation for k parameters (the same loop, compiled
// for state dimensions 1..8 with fixed-size matrices), plus 2k block exponentials per distinct Δ.
// The log-likelihood it returns is the filter's (kalman.h) to rounding.
#pragma once

#include <span>
#include <vector>

#include <Eigen/Core>

#include "core/data/dataset.h"
#include "core/filter/discretize.h"
#include "core/filter/kalman.h"
#include "core/model/linear_model.h"
#include "core/util/result.h"

namespace gb::filter {

// The log-likelihood of one series (as LogLikelihood) and its derivatives along k directions:
// dss[i] holds the derivatives of every entry of `ss` with respect to θ_i (the shapes of ss).
// Writes *gradient (k: ∂ log L/∂θ_i) and, when given, *J_terms_theta (N x k: row j is
// ∂ℓ_j/∂θ, zero where nothing is observed; its rows sum to the gradient). Errors as LogLikelihood.
Result<Loglik> LogLikelihoodScore(const model::StateSpace& ss,
                                  std::span<const model::StateSpace> dss,
                                  const data::Series& series, const FilterSettings& settings,
                                  Eigen::VectorXd* gradient,
                                  Eigen::MatrixXd* J_terms_theta = nullptr);

// dP0 along every θ_i (dss[i]) for the initial covariance P0 of `kind` (see above): "ctsm" the
// derivatives of Q over the first interval (`dfirst`, DiscretizeDerivative's, one per θ_i),
// "stationary" the solution of the differentiated Lyapunov equation, explicit diag(dP0_diag).
std::vector<Eigen::MatrixXd> InitialCovarianceDerivatives(model::InitialCovariance kind,
                                                          const model::StateSpace& ss,
                                                          std::span<const model::StateSpace> dss,
                                                          const Eigen::MatrixXd& P0,
                                                          std::span<const Discrete> dfirst);

}  // namespace gb::filter
