// An error-controlled ODE solver: integrates dz = F(t, z) of any OdeSystem over an interval.
// A folder of its own (below core/filter in scripts/include-order.py's order) because nothing in it
// is about filtering: the extended Kalman filter's moment equations (core/filter/moments.h,
// core/filter/ekf.h) are its user today, and a simulation or a sensitivity system can be another.
// It takes the model's EkfOptions (method and tolerances) as they are set in a model file.
//
// The filter integrates over every sample interval from a new start (each measurement update
// moves the state), so what counts is the cost of one short integration from a cold start, not
// of one long one. Two methods, both with error control on every component
// (|err_i| <= atol + rtol m_i, m_i the component's magnitude: |z_i| unless the system gives its
// own, OdeSystem::Magnitudes):
//   explicit  Dormand-Prince 5(4) (ode.cpp's own loops, taking Boost.Odeint's runge_kutta_dopri5
//             steps bit for bit), a one-step method: no start-up cost, and each interval begins
//             with the step size the last one's first step proposed (each interval starts after
//             an update of the filter, whose transient sets its first steps).
//   bdf       variable-order BDF (SUNDIALS CVODE) with a dense Newton solver, for stiff models.
//             Its Newton matrix comes from OdeSystem::Jacobian (an approximation is enough: it
//             only steers the Newton iteration, never the solution).
// `auto` chooses per interval: BDF when stiffness = ρ(∂F/∂z) (t1 - t0) exceeds kStiffLimit (an
// explicit method would need about stiffness / 3.3 steps for stability alone), else explicit.
// Chosen by measurement on the moment equations of tank models with a restart at every interval
// (docs/benchmarks.md, "Which ODE solver, by measurement"): the explicit method is an order of
// magnitude cheaper on non-stiff intervals, BDF about twice as cheap on a stiff one.
#pragma once

#include <cstddef>
#include <memory>
#include <span>
#include <vector>

#include "core/model/model.h"
#include "core/util/result.h"

namespace gb::ode {

class OdeSystem {
 public:
  virtual ~OdeSystem() = default;
  virtual int size() const = 0;
  // The first components that the explicit method's error test covers (the others, such as
  // sensitivities, follow on the steps those need); BDF tests them all.
  virtual int controlled_size() const { return size(); }
  // The magnitudes m (controlled_size() of them) that the error test scales each controlled
  // component's tolerance by at the point z: |err_i| <= atol + rtol (m_i + h |F_i|) for the
  // explicit method, atol + rtol m_i for BDF. By default |z_i|. A system whose component is
  // small for a structural reason while its error is not (a covariance between two states that
  // happen to be uncorrelated) gives the scale the component's errors are measured on instead.
  virtual void Magnitudes(std::span<const double> z, std::span<double> m) const;
  // dz = F(t, z). Returns false when F is not finite there: the solver then shortens the step.
  virtual bool Rhs(double t, std::span<const double> z, std::span<double> dz) = 0;
  // An approximation of ∂F/∂z, column-major size x size, for the implicit method's Newton matrix.
  virtual void Jacobian(double t, std::span<const double> z, std::span<double> jac) = 0;
};

// An OdeSystem whose right-hand side depends on parameters p and that gives vector-Jacobian
// products, for the discrete adjoint of the explicit method's steps (ReverseExplicitSteps).
class AdjointSystem : public OdeSystem {
 public:
  // A retrace of `stages` points begins: the next `stages` calls of Rhs are at stages 0, 1, ...,
  // and Vjp is then called at each of them with its index (in reverse order), so a system may
  // keep what Rhs computed at a stage for its Vjp there.
  virtual void Retrace(int stages) = 0;
  // Adds λ' ∂F/∂z to z_bar (size()) and λ' ∂F/∂p to p_bar at (t, z), the retrace's stage
  // `stage`. Returns false when F or its derivatives are not finite there.
  virtual bool Vjp(int stage, double t, std::span<const double> z, std::span<const double> lambda,
                   std::span<double> z_bar, std::span<double> p_bar) = 0;
};

struct OdeCounts {
  long intervals = 0;        // Advance calls
  long stiff_intervals = 0;  // of which integrated by BDF
  long steps = 0;            // accepted steps
  long rejected = 0;         // steps rejected by the error test (explicit) or failed (BDF)
  long rhs = 0;              // evaluations of F

  OdeCounts& operator+=(const OdeCounts& c) {
    intervals += c.intervals;
    stiff_intervals += c.stiff_intervals;
    steps += c.steps;
    rejected += c.rejected;
    rhs += c.rhs;
    return *this;
  }
};

class OdeSolver {
 public:
  // Intervals with stiffness above this go to BDF under OdeMethod::kAuto (see above).
  static constexpr double kStiffLimit = 400.0;

  OdeSolver(const model::EkfOptions& options, int size);
  ~OdeSolver();
  OdeSolver(const OdeSolver&) = delete;
  OdeSolver& operator=(const OdeSolver&) = delete;

  // Advances z from z(t0) to z(t1), t1 > t0. `stiffness` is an upper bound of ρ(∂F/∂z) times
  // (t1 - t0) (used by kAuto only). Fails (kNumerical) with the reason: "the step size fell to
  // 1e-14 of the interval", "more than 100000 steps", or the BDF solver's own reason.
  Status Advance(OdeSystem& system, double t0, double t1, std::span<double> z, double stiffness);

  const OdeCounts& counts() const { return counts_; }

  // With a log, the explicit method appends (t, Δt) of each step it accepts, in order: the
  // steps ReverseExplicitSteps retraces. Null: none kept.
  void set_step_log(std::vector<double>* log) { step_log_ = log; }

 private:
  struct Explicit;
  struct Bdf;
  Status AdvanceExplicit(OdeSystem& system, double t0, double t1, std::span<double> z);
  template <std::ptrdiff_t N>  // the size at compile time (0: at run time)
  Status AdvanceExplicitSized(OdeSystem& system, double t0, double t1, std::span<double> z);
  Status AdvanceBdf(OdeSystem& system, double t0, double t1, std::span<double> z);

  model::EkfOptions options_;
  int size_ = 0;
  std::unique_ptr<Explicit> explicit_;  // created on first use
  std::unique_ptr<Bdf> bdf_;            // created on first use
  OdeCounts counts_;
  std::vector<double>* step_log_ = nullptr;
};

// The discrete adjoint of the explicit method's accepted steps (Dormand-Prince 5(4), the steps a
// step log recorded from z0, in order): with z_bar the adjoint of the state after the last step
// (∂L/∂z_end), replaces it with the adjoint of z0 (∂L/∂z0) and adds ∂L/∂p to p_bar, through
// the Runge-Kutta map with the step sizes held fixed:
//
//   Y_i = z + h Σ_{k<i} a_ik K_k,  K_i = F(t + c_i h, Y_i),  z' = z + h Σ b_i K_i
//   K̄_i = h b_i z̄',  Ȳ_i = (∂F/∂z)' (K̄_i + h Σ_{k>i} a_ki Ȳ_k),  z̄ = z̄' + Σ Ȳ_i
//
// the derivative of the numbers the method computed, so equal to forward sensitivities that
// ride along on the same steps (OdeSystem::controlled_size) up to rounding. The stages are
// recomputed from z0 and the logged step sizes. Fails (kNumerical) where F or its derivatives
// are not finite.
Status ReverseExplicitSteps(AdjointSystem& system, std::span<const double> steps,
                            std::span<const double> z0, std::span<double> z_bar,
                            std::span<double> p_bar);

}  // namespace gb::ode
