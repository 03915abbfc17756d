// On-line identification of a nonlinear model (core/model/nonlinear_model.h): joint state and
// parameter estimation with the augmented extended Kalman filter (Ljung, "Asymptotic behavior of
// the extended Kalman filter as a parameter estimator for linear systems", IEEE TAC 24, 1979;
// Jazwinski 1970, ch. 8), one row at a time at a cost per row that does not depend on how many
// rows came before.
//
// Each tracked parameter θ_a becomes a state of the filter, in its working coordinate w_a
// (log, logit or itself, as the bounds allow: internal.h), so that every value the filter can
// reach is inside the bounds; the parameter is a random walk in it:
//
//   dx   = f(x, u, θ(w), t) dt + σ(x, u, θ(w), t) dω
//   dw_a = q_a dω_a
//   y    = h(x, u, θ(w), t) + e,   e ~ N(0, S(u, θ(w), t))
//
// The augmented model is built symbolically (θ_a replaced by its expression in w_a in every
// formula) and compiled like any model, so the filter is ekf_stream.h's: the moment equations
// with error control, the Jacobians by symbolic differentiation, the parameters' uncertainty
// carried in the augmented covariance and reported at every row (the delta method through
// dθ/dw).
//
// Which parameters can be tracked: the free parameters with a reference estimate that the drift
// or the observation depends on. A parameter met only in the diffusion or the measurement
// variance cannot be: the EKF's update is linear in the innovation, so a variance parameter has
// no cross-covariance with the innovations and would never move (those stay at the reference;
// the linear estimator, recursive.h, tracks them through its exact scores).
//
// The random walk and the forgetting factor λ: a parameter with information I per row (in w)
// and a random walk of variance v per row settles, in the Kalman filter, at the variance
// √(v/I) with gain √(v I). With v = (1-λ) Σ₀ and Σ₀ = (1-λ)/I (the prior below), the gain is
// 1-λ, the memory 1/(1-λ) rows, and the steady variance Σ₀: the same memory and about the same
// uncertainty as recursive.h's λ. So q_a² = (1-λ) Σ₀,aa / Δ, with Δ the first interval. λ = 1
// gives q = 0: the parameters are constant and the filter is the recursive Bayesian estimate
// from the reference.
//
// The prior Σ₀ (the w-block of the covariance when the parameters are opened): the reference's
// covariance in w (D⁻¹ Σ_ref D⁻¹, D = diag dθ/dw), scaled to `prior_rows` rows as recursive.h
// does (by default the memory 1/(1-λ), or the reference's rows for λ = 1); without a covariance,
// 2 units of w (a factor e² in a scale parameter). The start: x as ekf_stream.h (kLive: the
// equilibrium with the stationary covariance), the parameters at the reference with zero
// variance, so that for the first `warmup` rows (default: five of the slowest time constants at
// the start, or 100 rows when the start is not a stable equilibrium) the filter is the EKF at
// the reference and the state settles; then their variance opens to Σ₀ and the random walk
// starts. Options of recursive.h that belong to its Gauss-Newton step (max_step_sd,
// rediscretise_sd, forgetting_start, hold) do not apply.
#pragma once

#include <memory>
#include <span>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "core/model/nonlinear_model.h"
#include "core/online/ekf_stream.h"
#include "core/online/estimator.h"

namespace gb::online {

class AugmentedEkf final : public OnlineEstimator {
 public:
  // Errors: options (λ in (0, 1]), a parameter named in `track` that cannot be tracked (the list
  // of those that can), the augmented model failing to compile.
  static Result<AugmentedEkf> Create(std::shared_ptr<const model::NonlinearModel> model,
                                     const Reference& reference, const RecursiveOptions& options);

  Result<std::vector<RecursiveUpdate>> Push(const Sample& row) override;
  const std::vector<int>& tracked() const override { return tracked_; }
  const std::vector<std::string>& tracked_names() const override { return names_; }
  const model::ModelSpec& spec() const override { return model_->spec(); }
  const std::vector<double>& theta() const override { return theta_; }
  Eigen::MatrixXd Covariance() const override;
  std::string Method() const override {
    return "augmented extended Kalman filter (parameters as random walks)";
  }

  // The augmented model the filter runs (states x, then w(θ_a); for tests and messages).
  const model::NonlinearModel& augmented() const { return stream_.model(); }
  int warmup() const { return warmup_; }  // rows (-1 until known)
  const ode::OdeCounts& counts() const { return stream_.counts(); }

 private:
  AugmentedEkf(std::shared_ptr<const model::NonlinearModel> model, EkfStream stream)
      : model_(std::move(model)), stream_(std::move(stream)) {}
  void Open(double dt);  // the parameters' variance and random walk, after the warm-up

  std::shared_ptr<const model::NonlinearModel> model_;
  EkfStream stream_;
  RecursiveOptions options_;
  std::vector<int> tracked_;
  std::vector<std::string> names_;
  std::vector<double> lower_, upper_;  // bounds of the tracked parameters (±inf when none)
  std::vector<double> theta_;          // all parameters at the current estimate
  Eigen::MatrixXd prior_;              // Σ₀, working coordinates
  int n_ = 0;                          // states of the model (w follows)
  int warmup_ = -1;
  bool open_ = false;
  double first_t_ = 0.0;
  long rows_ = 0;
};

// The free parameters a nonlinear model's drift or observation depends on, among `free`.
std::vector<int> TrackableParameters(const model::NonlinearModel& model, std::span<const int> free);

}  // namespace gb::online
