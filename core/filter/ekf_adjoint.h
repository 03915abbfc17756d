// The gradient of the extended Kalman filter's log-likelihood (ekf.h) by the discrete adjoint:
// one pass forward that keeps, per state index, the prior and the start of the interval after
// it with the explicit method's accepted steps (the checkpoints), then one pass backward that
// carries ∂ log L/∂(x̂, P) from the last index to the first:
//
//   each interval    ode::ReverseExplicitSteps over the moment equations (moments.h), the stages
//                    retraced from the interval's start; it adds ∂/∂θ of every step
//   each scalar      x⁺ = x + k ε/R, P⁺ = P - k k'/R, k = P H', R = H k + S, ε = y - ŷ,
//   update           ŷ = h + H (x - x̂⁻), reversed term by term (ekf_adjoint.cpp), with h, H, S
//                    and their derivatives at the index's prior x̂⁻
//   the initial      x0 and explicit P0 through their derivatives; "ctsm" P0 through the first
//   state            interval's steps from (x0, 0); "stationary" P0 through the adjoint Lyapunov
//                    equation (MomentPropagator::StationaryAdjoint)
//
// Its cost does not grow with the number of parameters the way forward sensitivities do (one
// block of moment equations per parameter, ekf_score.h): a gradient costs the forward pass, the
// retraced stages and one vector-Jacobian product per stage. It is the derivative of the numbers
// the filter computed with the step sizes held fixed, which forward sensitivities riding on the
// same steps also are, so the two agree to rounding. It gives the gradient only (no per-term
// scores), for the explicit method only: an interval that `auto` sends to BDF, or the method
// `bdf`, leaves it not applicable (the caller then uses forward sensitivities).
#pragma once

#include <span>

#include <Eigen/Core>

#include "core/data/dataset.h"
#include "core/filter/kalman.h"
#include "core/model/nonlinear_model.h"
#include "core/model/nonlinear_sensitivity.h"
#include "core/ode/ode.h"
#include "core/util/result.h"

namespace gb::filter {

// log L of one series at θ (all parameters) as EkfLogLikelihoodWithScore gives it (the model's
// own x0 and P0), and *gradient (free.size()) by the adjoint. *applicable is set false, and
// nothing else is meaningful, when an interval needed the BDF method. Fails as
// EkfLogLikelihoodWithScore does. Asserts that the model's EkfOptions::iterations is 1.
Result<Loglik> EkfLogLikelihoodWithAdjoint(const model::NonlinearModel& model,
                                           const model::NonlinearSensitivity& sensitivity,
                                           std::span<const double> theta,
                                           const data::Series& series,
                                           const FilterSettings& settings,
                                           std::span<const int> free, Eigen::VectorXd* gradient,
                                           bool* applicable, ode::OdeCounts* counts = nullptr);

}  // namespace gb::filter
