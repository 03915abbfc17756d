// Exact derivatives of the extended Kalman filter's log-likelihood (ekf.h) with respect to the
// parameters: forward sensitivities. Between samples the derivatives of (x̂, P) follow the
// sensitivity equations of the moment equations (moments.h), integrated with them under the same
// error control; each scalar measurement update is differentiated as written:
//
//   ŷ = h + H (x - x̂⁻),  k = P H',  R = H k + S,  ε = y - ŷ
//   dŷ = dh + dH (x - x̂⁻) + H (dx - dx̂⁻),  dk = dP H' + P dH',  dR = dH k + H dk + dS
//   dx += dk ε/R - k dŷ/R - k ε dR/R²,  dP -= (dk k' + k dk')/R - k k' dR/R²
//
// with h, H, S at the prior mean and dh = H dx̂⁻ + ∂h/∂θ, dH = Σ_m ∂H/∂x_m dx̂⁻_m + ∂H/∂θ,
// dS = ∂S/∂θ. The initial state and covariance are differentiated for each kind ("ctsm" by the
// same integration, "stationary" by the Lyapunov equation's derivative, explicit variances
// directly). The result is the derivative of the filter the ODE solver approximates, so it
// agrees with differences of EkfLogLikelihood to the ODE tolerance.
//
// The iterated EKF (EkfOptions::iterations > 1) is not covered: its passes re-linearise at a
// mean that depends on θ through the update itself (core/filter/likelihood.h then differences).
#pragma once

#include <span>

#include <Eigen/Core>

#include "core/data/dataset.h"
#include "core/filter/kalman.h"
#include "core/filter/ode.h"
#include "core/model/nonlinear_model.h"
#include "core/model/nonlinear_sensitivity.h"
#include "core/util/result.h"

namespace gb::filter {

// log L of one series at θ (all parameters) as EkfLogLikelihood, and its derivatives with
// respect to θ_l, l in `free`: *gradient (free.size()); with J_terms, row j (N rows) is the
// derivative of the term of state index j (EkfLogLikelihood's `terms`). Fails as
// EkfLogLikelihood does, and where a derivative of the model's entries is not finite (named).
// Asserts that the model's EkfOptions::iterations is 1.
Result<Loglik> EkfLogLikelihoodWithScore(const model::NonlinearModel& model,
                                         const model::NonlinearSensitivity& sensitivity,
                                         std::span<const double> theta,
                                         const data::Series& series,
                                         const FilterSettings& settings, std::span<const int> free,
                                         Eigen::VectorXd* gradient,
                                         Eigen::MatrixXd* J_terms = nullptr,
                                         OdeCounts* counts = nullptr);

}  // namespace gb::filter
