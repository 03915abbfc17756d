// The continuous-discrete extended Kalman filter and its innovations log-likelihood, for any
// model (core/model/nonlinear_model.h), with the conventions of the linear filter (kalman.h:
// state index j, output delays, first observations, missing entries, Huber, the filter order).
//
// Between samples t_j and t_{j+1}, the mean and covariance follow the moment equations
//
//   dx̂/dt = f(x̂, u(t), θ, t)
//   dP/dt  = J P + P J' + diag(σ(x̂, u(t), θ, t)²),   J = ∂f/∂x at (x̂, u(t), θ, t)
//
// (first-order linearisation about the mean; the diffusion is evaluated at the mean, as CTSM
// does), integrated with error control (core/ode/ode.h) from the filtered (x̂, P) at t_j.
// u(t) is u_j over the interval (zoh) or u_j + (t - t_j)/Δ_j (u_{j+1} - u_j) (foh).
// The state of the ODE is x̂ and the lower triangle of P (n + n(n+1)/2 numbers).
//
// Measurement update at state index j, with every observed y_{o, j+d_o} (as kalman.h), all
// linearised at the prior x̂⁻ = x̂_{j|j-1}: h, H = ∂h/∂x and S at (x̂⁻, u_j, θ, t_j). It is the
// vector EKF update done as scalar updates in sequence (exact for diagonal S):
//   ŷ_o = h_o + H_o (x - x̂⁻),   k = P H_o',   R = H_o k + S_o,   ε = y_o - ŷ_o
//   x <- x + k ε/R,   P <- P - k k'/R
// and the log-likelihood term of j is that of kalman.h with these ε and R (the first-order
// approximation of the predictive density p(y_j | y_{<j})).
// Iterated EKF (EkfOptions::iterations = K > 1): passes 2..K re-linearise h at the latest
// updated mean x_i and redo the update from (x̂⁻, P⁻) with ŷ_o = h_o(x_i) + H_o(x_i) (x - x_i);
// it stops early once a pass moves the mean by less than 1e-10 of its size. Only the update
// changes; the likelihood term stays the one linearised at the prior.
//
// Initial covariance: "ctsm" integrates the covariance equation from P = 0 over the first
// interval with the mean starting at x0 (for a linear model exactly Q(Δ_0), as kalman.h);
// "stationary" solves J P + P J' + diag(σ²) = 0 at (x0, u_0, θ, t_0); explicit variances as given.
//
// For a linear model the moment equations are exact, so this filter equals the exact Kalman
// filter to the ODE tolerance.
#pragma once

#include <cmath>
#include <span>
#include <vector>

#include "core/data/dataset.h"
#include "core/filter/kalman.h"
#include "core/model/nonlinear_model.h"
#include "core/ode/ode.h"
#include "core/util/result.h"

namespace gb::filter {

// The log-likelihood of one series at θ (all parameters), with the model's EkfOptions. Errors
// (kNumerical) as kalman.h's, and: a model entry that is not finite at the filtered mean (named,
// with the values it used: "drift.h1 is not a number at these values (h1 = -0.02, k1 = 0.1)"),
// or moment equations the solver could not integrate (naming the row and file line).
// With `terms`: the per-state-index terms (kalman.h). With `counts`: the solver's work, added.
Result<Loglik> EkfLogLikelihood(const model::NonlinearModel& model, std::span<const double> theta,
                                const data::Series& series, const FilterSettings& settings,
                                std::vector<double>* terms = nullptr,
                                ode::OdeCounts* counts = nullptr);

// As EkfLogLikelihood, and fills *trace (kalman.h's FilterTrace: y_pred = h(x̂⁻), y_var =
// H P⁻ H' + S, the predicted and filtered means and covariances at every row).
Result<Loglik> EkfRunFilter(const model::NonlinearModel& model, std::span<const double> theta,
                            const data::Series& series, const FilterSettings& settings,
                            FilterTrace* trace, ode::OdeCounts* counts = nullptr);

}  // namespace gb::filter
