// The moment equations of a model (ekf.h) interval by interval over one series: what the
// extended Kalman filter, its predictions and the deterministic simulation share.
//
//   dx̂/dt = f(x̂, u(t), θ, t),   dP/dt = J P + P J' + diag(σ(x̂, u(t), θ, t)²)
//
// with u(t) held (zoh) or interpolated (foh) as ekf.h says, integrated by ode::OdeSolver
// (core/ode/ode.h) with the model's EkfOptions.
#pragma once

#include <memory>
#include <span>
#include <vector>

#include <Eigen/Core>

#include "core/data/dataset.h"
#include "core/filter/kalman.h"
#include "core/model/nonlinear_model.h"
#include "core/model/nonlinear_sensitivity.h"
#include "core/ode/ode.h"
#include "core/util/result.h"

namespace gb::filter {

// The filters report their integrator's work (core/ode/ode.h) as OdeCounts.
using ode::OdeCounts;

// The derivatives of (x̂, P) with respect to the free parameters θ_l (MomentPropagator's `free`):
// column q of x is ∂x̂/∂θ_{free[q]}, P[q] is ∂P/∂θ_{free[q]}.
struct MomentSensitivities {
  Eigen::MatrixXd x;               // n x K
  std::vector<Eigen::MatrixXd> P;  // K of n x n
};

// An upper bound of ρ(A), A square and finite: the smaller of the largest row and column sums of
// |D⁻¹ A D|, with the diagonal D from four sweeps of Osborne's balancing (as LAPACK's dgebal) in
// powers of two, so that the scaled entries are A's own to the bit; *scaled (A on entry) ends as
// D⁻¹ A D. O(n²) a sweep. Where A's entries span the states' units it stays near ρ when a plain
// norm does not: on the engine's Padé chain at 5 000 rpm (∂ż3/∂z1 = 3·10⁶ s⁻³, fastest mode
// 148/s) it is 4.1 ρ, the row-sum norm 2·10⁴ ρ. The filter's stiffness test (`ode: auto`) computes
// J's eigenvalues only where this bound does not settle that an interval is not stiff.
double SpectralRadiusBound(Eigen::MatrixXd* scaled);

class MomentPropagator {
 public:
  // θ: all parameters; `series` bound to the model. Holds references to all three. With
  // `transition`, Advance also integrates the transition matrix of the linearisation (below).
  // With `sensitivity` and `free`: also the derivatives of the moments with respect to the
  // parameters θ_l, l in `free`, integrated with them (the forward sensitivity equations, under
  // the same error control):
  //   dS/dt  = J S + ∂f/∂θ_l,   S = ∂x̂/∂θ_l
  //   dSP/dt = dJ P + P dJ' + J SP + SP J' + diag(2 σ_i dσ_i),   SP = ∂P/∂θ_l
  // with dJ = Σ_m ∂J/∂x_m S_m + ∂J/∂θ_l, dσ = ∂σ/∂x S + ∂σ/∂θ_l. Initial and Advance then take
  // and return them (MomentSensitivities).
  MomentPropagator(const model::NonlinearModel& model, std::span<const double> theta,
                   const data::Series& series, model::InputHold hold, bool transition = false,
                   const model::NonlinearSensitivity* sensitivity = nullptr,
                   std::span<const int> free = {});
  ~MomentPropagator();
  MomentPropagator(const MomentPropagator&) = delete;
  MomentPropagator& operator=(const MomentPropagator&) = delete;

  // The prior at t_0: x0 and P0 ("ctsm", "stationary" or explicit, as ekf.h says). Errors: an
  // initial entry that is not finite or a negative variance, an unstable linearisation for
  // "stationary", a failed integration for "ctsm".
  Status Initial(model::InitialCovariance kind, Eigen::VectorXd* x, Eigen::MatrixXd* P,
                 MomentSensitivities* ds = nullptr);

  // (x̂, P) at t_j -> at t_{j+1}. Errors name row j + 1 and the model entry that was not finite
  // where the solver tried it, or the solver's reason. With `transition` and Phi: also
  // Φ = ∂x̂(t_{j+1})/∂x̂(t_j), the solution of dΦ/dt = J(x̂(t)) Φ, Φ(t_j) = I, integrated with the
  // moments under the same error control (the smoother's cross-covariance P_{j|j} Φ').
  Status Advance(int j, Eigen::VectorXd* x, Eigen::MatrixXd* P, Eigen::MatrixXd* Phi = nullptr,
                 MomentSensitivities* ds = nullptr);

  // h, H = ∂h/∂x (row-major) and S at (x, u_j, θ, t_j): the model's measurement program
  // (NonlinearModel::Measurement). Errors name the entry and row.
  Status Measure(int j, const Eigen::VectorXd& x, std::span<double> out);

  // The measurement program's derivatives (NonlinearSensitivity::measurement()) at
  // (x, u_j, θ, t_j) into `dense` (from its Zeroed()). Errors name the entry and row.
  Status MeasureSensitivities(int j, const Eigen::VectorXd& x, std::span<double> dense);

  const ode::OdeCounts& counts() const;

  // ---- the discrete adjoint (core/filter/ekf_adjoint.h): needs `sensitivity`, no `free` ----
  // Advance and Initial append the explicit method's accepted steps ((t, Δt) pairs) to *log.
  void set_step_log(std::vector<double>* log);
  // The packed moments [x̂; lower triangle of P, column by column] that Advance integrates.
  int moments_size() const;
  void Pack(const Eigen::VectorXd& x, const Eigen::MatrixXd& P, std::span<double> z) const;
  // Pack's inverse: x (resized to n) and the symmetric P (n x n) from z.
  void Unpack(std::span<const double> z, Eigen::VectorXd* x, Eigen::MatrixXd* P) const;
  // Interval j's adjoint (ode::ReverseExplicitSteps): z0 the packed moments Advance started from
  // at t_j, `steps` the steps it logged; z_bar, ∂L/∂z at t_{j+1}, becomes ∂L/∂z at t_j, and
  // ∂L/∂θ (every parameter) is added to theta_bar. Errors name row j + 1.
  Status ReverseAdvance(int j, std::span<const double> z0, std::span<const double> steps,
                        std::span<double> z_bar, std::span<double> theta_bar);
  // "stationary" P0's adjoint. P0 solves J P0 + P0 J' + diag σ² = 0 at (x0, u_0, t_0); with
  // P0_bar = ∂L/∂P0 (symmetric), adds ∂L/∂x0 through P0 to *x0_bar and ∂L/∂θ to theta_bar:
  // with Y the solution of J' Y + Y J = P0_bar, they are -<Y, dJ P0 + P0 dJ' + diag(2 σ dσ)>.
  Status StationaryAdjoint(const Eigen::VectorXd& x0, const Eigen::MatrixXd& P0,
                           const Eigen::MatrixXd& P0_bar, Eigen::VectorXd* x0_bar,
                           std::span<double> theta_bar);
  // The initial program's derivatives (NonlinearSensitivity::initial()) at θ into `dense` (from
  // its Zeroed()).
  Status InitialDerivatives(std::span<double> dense);

 private:
  class Moments;
  const model::NonlinearModel& model_;
  const data::Series& series_;
  std::vector<double> theta_;
  bool foh_ = false;
  bool transition_ = false;
  const model::NonlinearSensitivity* sensitivity_ = nullptr;
  std::vector<int> free_;
  std::unique_ptr<Moments> moments_;
  std::unique_ptr<ode::OdeSolver> solver_;
  std::vector<double> z_, slots_, measure_scratch_;
};

}  // namespace gb::filter
