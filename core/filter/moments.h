// The moment equations of a model (ekf.h) interval by interval over one series: what the
// extended Kalman filter, its predictions and the deterministic simulation share.
//
//   dx̂/dt = f(x̂, u(t), θ, t),   dP/dt = J P + P J' + diag(σ(x̂, u(t), θ, t)²)
//
// with u(t) held (zoh) or interpolated (foh) as ekf.h says, integrated by OdeSolver (ode.h)
// with the model's EkfOptions.
#pragma once

#include <memory>
#include <span>
#include <vector>

#include <Eigen/Core>

#include "core/data/dataset.h"
#include "core/filter/kalman.h"
#include "core/filter/ode.h"
#include "core/model/nonlinear_model.h"
#include "core/util/result.h"

namespace gb::filter {

class MomentPropagator {
 public:
  // θ: all parameters; `series` bound to the model. Holds references to all three. With
  // `transition`, Advance also integrates the transition matrix of the linearisation (below).
  MomentPropagator(const model::NonlinearModel& model, std::span<const double> theta,
                   const data::Series& series, model::InputHold hold, bool transition = false);
  ~MomentPropagator();
  MomentPropagator(const MomentPropagator&) = delete;
  MomentPropagator& operator=(const MomentPropagator&) = delete;

  // The prior at t_0: x0 and P0 ("ctsm", "stationary" or explicit, as ekf.h says). Errors: an
  // initial entry that is not finite or a negative variance, an unstable linearisation for
  // "stationary", a failed integration for "ctsm".
  Status Initial(model::InitialCovariance kind, Eigen::VectorXd* x, Eigen::MatrixXd* P);

  // (x̂, P) at t_j -> at t_{j+1}. Errors name row j + 1 and the model entry that was not finite
  // where the solver tried it, or the solver's reason. With `transition` and Phi: also
  // Φ = ∂x̂(t_{j+1})/∂x̂(t_j), the solution of dΦ/dt = J(x̂(t)) Φ, Φ(t_j) = I, integrated with the
  // moments under the same error control (the smoother's cross-covariance P_{j|j} Φ').
  Status Advance(int j, Eigen::VectorXd* x, Eigen::MatrixXd* P, Eigen::MatrixXd* Phi = nullptr);

  // h, H = ∂h/∂x (row-major) and S at (x, u_j, θ, t_j): the model's measurement program
  // (NonlinearModel::Measurement). Errors name the entry and row.
  Status Measure(int j, const Eigen::VectorXd& x, std::span<double> out);

  const OdeCounts& counts() const;

 private:
  class Moments;
  const model::NonlinearModel& model_;
  const data::Series& series_;
  std::vector<double> theta_;
  bool foh_ = false;
  std::unique_ptr<Moments> moments_;
  std::unique_ptr<OdeSolver> solver_;
  std::vector<double> z_, slots_;
};

}  // namespace gb::filter
