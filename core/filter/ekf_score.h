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
#include "core/filter/moments.h"
#include "core/model/nonlinear_model.h"
#include "core/model/nonlinear_sensitivity.h"
#include "core/ode/ode.h"
#include "core/util/result.h"

namespace gb::filter {

// log L of one series at θ (all parameters) as EkfLogLikelihood, and its derivatives with
// respect to θ_l, l in `free`: *gradient (free.size()); with J_terms, row j (N rows) is the
// derivative of the term of state index j (EkfLogLikelihood's `terms`). Fails as
// EkfLogLikelihood does, and where a derivative of the model's entries is not finite (named).
// Asserts that the model's EkfOptions::iterations is 1.
Result<Loglik> EkfLogLikelihoodWithScore(const model::NonlinearModel& model,
                                         const model::NonlinearSensitivity& sensitivity,
                                         std::span<const double> theta, const data::Series& series,
                                         const FilterSettings& settings, std::span<const int> free,
                                         Eigen::VectorXd* gradient,
                                         Eigen::MatrixXd* J_terms = nullptr,
                                         ode::OdeCounts* counts = nullptr);

namespace internal {

// The measurement program's derivatives at the prior, as MomentPropagator::MeasureSensitivities
// fills them (the layout of NonlinearSensitivity::measurement()). Read only for the parameters
// of a ScalarUpdateWithScores (none: `sensitivity` may be null).
struct MeasurementDerivatives {
  const model::NonlinearSensitivity* sensitivity = nullptr;
  std::span<const double> dense;
  int p = 0, n = 0;
  double h_theta(int o, int l) const { return dense[At(o, l)]; }
  double S_theta(int o, int l) const { return dense[sensitivity->MeasStheta() + At(o, l)]; }
  // Entry (o, l) of a p x np column-major block.
  std::size_t At(int o, int l) const {
    return static_cast<std::size_t>(l) * static_cast<std::size_t>(p) + static_cast<std::size_t>(o);
  }
  Eigen::Map<const Eigen::MatrixXd> Hx(int m) const {
    return Eigen::Map<const Eigen::MatrixXd>(dense.data() + sensitivity->MeasHx(m), p, n);
  }
  Eigen::Map<const Eigen::MatrixXd> Htheta(int l) const {
    return Eigen::Map<const Eigen::MatrixXd>(dense.data() + sensitivity->MeasHtheta(l), p, n);
  }
};

// The prior of an index's updates and what they add up (per state index: reset, then one
// ScalarUpdateWithScores per observed output).
struct ScoreUpdate {
  Eigen::VectorXd x_prior;       // x̂⁻
  Eigen::MatrixXd dx_prior;      // ∂x̂⁻/∂θ (n x K)
  Eigen::VectorXd dlogdet, dr2;  // Σ dR/R, Σ d(ε²/R) over the index's outputs (K)
  Eigen::MatrixXd information;   // Σ dε dε'/R + ½ dR dR'/R² (K x K), when asked for
  // Workspace.
  Eigen::VectorXd PHt, dk, dyhat, dR;
  Eigen::MatrixXd dks;
  Eigen::RowVectorXd dH;
  void Begin(const Eigen::VectorXd& x, const MomentSensitivities& ds, int K);
};

// The scalar EKF update of output o with observation y (ekf.h), linearised at x_lin where h_o, H
// (row o of ∂h/∂x) and S_o were evaluated (the prior mean, or in the iterated EKF's later passes
// the latest mean):
//
//   ŷ = h_o + H (x - x_lin),  k = P H',  R = H k + S_o,  ε = y - ŷ
//   x <- x + k ε/R,  P <- P - k k'/R
//
// in two halves: ScalarInnovation gives ε, k (*PHt) and R; ScalarCorrection updates x and P.
// ScalarUpdate is both; ScalarUpdateWithScores differentiates between the two.
template <class RowH>
double ScalarInnovation(double y, double h_o, const RowH& H, double S_o,
                        const Eigen::VectorXd& x_lin, const Eigen::VectorXd& x,
                        const Eigen::MatrixXd& P, Eigen::VectorXd* PHt, double* R) {
  const double yhat = h_o + H.dot(x - x_lin);
  PHt->noalias() = P * H.transpose();
  *R = H.dot(*PHt) + S_o;
  return y - yhat;
}

inline void ScalarCorrection(const Eigen::VectorXd& PHt, double eps, double R, Eigen::VectorXd* x,
                             Eigen::MatrixXd* P) {
  x->noalias() += PHt * (eps / R);
  P->noalias() -= (1.0 / R) * PHt * PHt.transpose();
}

// Returns false, changing neither x nor P, when R is not positive (*R says what it is).
template <class RowH>
bool ScalarUpdate(double y, double h_o, const RowH& H, double S_o, const Eigen::VectorXd& x_lin,
                  Eigen::VectorXd* x, Eigen::MatrixXd* P, Eigen::VectorXd* PHt, double* eps,
                  double* R) {
  *eps = ScalarInnovation(y, h_o, H, S_o, x_lin, *x, *P, PHt, R);
  if (!(*R > 0.0)) return false;
  ScalarCorrection(*PHt, *eps, *R, x, P);
  return true;
}

// One scalar update of output o with observation y (ekf.h), with the forward sensitivities of the
// parameters `free` (ekf_score.h's formulas), linearised at u.x_prior: h_o, H (row o of ∂h/∂x)
// and S_o there. Updates x, P and ds, adds to u's sums (and, with `information`, to
// u.information), and gives ε and R. Returns false, changing nothing, when R = H P H' + S is not
// positive (*R is what it was).
bool ScalarUpdateWithScores(int o, double y, double h_o,
                            const Eigen::Ref<const Eigen::RowVectorXd>& H, double S_o,
                            const MeasurementDerivatives& d, std::span<const int> free,
                            bool information, Eigen::VectorXd* x, Eigen::MatrixXd* P,
                            MomentSensitivities* ds, ScoreUpdate* u, double* eps, double* R);

}  // namespace internal

}  // namespace gb::filter
