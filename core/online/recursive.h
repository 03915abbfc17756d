// On-line identification of a linear model (core/model/linear_model.h): the recursive
// maximum-likelihood estimator (a recursive prediction-error method with the Gaussian
// likelihood as criterion; Ljung & Söderström, Theory and Practice of Recursive Identification,
// 1983, ch. 3), one row at a time, at a cost per row that does not depend on how many rows came
// before.
//
// The filter is the exact Kalman filter of kalman.h (exact discretisation, sequential scalar
// updates, output delays in whole samples, zoh/foh, Huber) run at the current estimate θ_j, and
// beside it the forward sensitivities of its state and covariance, ∂x̂/∂θ_i and ∂P/∂θ_i, as
// score.h carries them. At every state index j they give the exact score of that index's
// log-likelihood term, s_j = ∂ℓ_j/∂θ, and its expected information (Fisher's, per scalar
// observation with innovation ε, variance R: dε dε'/R + ½ dR dR'/R²). Then
//
//   F_j = λ_j F_{j-1} + I_j          information, discounted by the forgetting factor λ
//   G_j = λ_j² G_{j-1} + I_j         (for the covariance of a discounted estimate, below)
//   θ_j = θ_{j-1} + F_j⁻¹ s_j        the Gauss-Newton step of the discounted log-likelihood
//
// projected into the parameters' bounds (a step that would leave them is shortened to stop a
// small margin inside; one the model refuses, e.g. a negative variance, is halved until it is
// accepted). With λ = 1 this is the recursive form of the batch maximum-likelihood estimate: on a
// stationary record it ends within the batch standard errors of the batch estimate
// (tests/core/recursive_test.cpp). With λ < 1 the estimate weighs row j-k by λ^k: its memory is
// 1/(1-λ) rows, and it follows a parameter that changes.
//
// Uncertainty, at every row: the covariance of the discounted estimate is the sandwich
// F⁻¹ G F⁻¹. For λ = 1 it is F⁻¹, the inverse of the information as in the batch fit. For λ < 1,
// in steady state with information I per row, F = I/(1-λ) and G = I/(1-λ²), so the covariance
// is F⁻¹/(1+λ), about half of F⁻¹: an exponentially weighted mean with memory 1/(1-λ) rows has
// the variance of an ordinary mean of (1+λ)/(1-λ) rows.
//
// Which parameters are tracked: the free parameters that any of A, B, c, C, D, d, σ, S depends on.
// A parameter that only sets the initial state (the fuel film's mfi0) has no information after
// the first rows and stays at its reference value.
//
// The start: θ from the reference (a batch result) and its information scaled to `prior_rows`
// rows of data (by default the memory 1/(1-λ), or the reference's own rows when λ = 1: the
// estimator starts as if it had already seen that much data agree with the reference). The state
// starts at the model's equilibrium for the first input with the stationary covariance when A is
// stable (a live stream starts wherever the system is, not where the reference record started),
// otherwise at the model's own initial state and covariance. For the first `warmup` rows the
// filter runs but θ is not updated, so the state and its sensitivities settle first.
#pragma once

#include <optional>
#include <span>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "core/data/follow.h"
#include "core/estimate/estimate.h"
#include "core/filter/discretize.h"
#include "core/filter/linear_step.h"
#include "core/model/linear_model.h"
#include "core/online/estimator.h"
#include "core/util/result.h"

namespace gb::online {

class RecursiveMl final : public OnlineEstimator {
 public:
  // The model with the reference's values; errors when the model cannot be evaluated at them.
  // Options are checked (λ in (0, 1], ...).
  static Result<RecursiveMl> Create(const model::LinearModel& model, const Reference& reference,
                                    const RecursiveOptions& options, bool adapt = true);

  // OnlineEstimator (estimator.h).
  Result<std::vector<RecursiveUpdate>> Push(const Sample& row) override;
  const std::vector<int>& tracked() const override { return tracked_; }
  const std::vector<std::string>& tracked_names() const override { return tracked_names_; }
  const model::ModelSpec& spec() const override { return model_.spec(); }
  const std::vector<double>& theta() const override { return theta_; }
  // F⁻¹ G F⁻¹.
  Eigen::MatrixXd Covariance() const override;
  std::string Method() const override {
    return "recursive maximum likelihood (exact Kalman filter, Gauss-Newton steps)";
  }

  const model::LinearModel& model() const { return model_; }

 private:
  RecursiveMl(const model::LinearModel& model, const Reference& reference,
              const RecursiveOptions& options);
  Status Evaluate();          // ss_, dss_ at theta_; discretisations dropped
  Status Refresh(double dt);  // ss_, dss_, disc_, ddisc_ for dt at theta_, when stale
  Status Start(const Sample& first, const Sample* second);
  Status TimeUpdate(const Sample& from, const Sample& to);
  Result<RecursiveUpdate> MeasurementUpdate(int j);
  void Step(const Eigen::VectorXd& score);  // score in working coordinates
  Eigen::VectorXd Slopes() const;           // dθ/dw of the tracked parameters at theta_

  model::LinearModel model_;
  RecursiveOptions options_;
  std::string source_;
  std::vector<double> theta_;
  std::vector<double> theta_model_;  // where ss_, dss_ (and disc_) were evaluated
  std::vector<int> tracked_;
  std::vector<std::string> tracked_names_;  // parameter indices
  std::vector<double> lower_, upper_;       // bounds of the tracked parameters (±inf when none)
  std::vector<int> delay_;
  int lag_ = 0;     // max delay
  int warmup_ = 0;  // rows; -1 until the first interval is known
  double warmup_time_ = 0.0;
  double lambda_ = 1.0;
  double ramp_ = 0.999;  // λ_j = ramp λ_{j-1} + (1 - ramp) λ

  model::StateSpace ss_;
  std::vector<model::StateSpace> dss_;
  double disc_dt_ = -1.0;
  filter::Discrete disc_;
  std::vector<filter::Discrete> ddisc_;
  std::vector<double> disc_w_;  // working coordinates the discretisation was computed at
  std::vector<double> sd_w_;    // current SDs in working coordinates (sqrt diag F⁻¹)

  // x̂, P and their sensitivities, stepped by the filter's own step (no allocation per row), and
  // what a row's updates add up.
  filter::internal::LinearStep<Eigen::Dynamic> step_;
  filter::internal::LinearState<Eigen::Dynamic> state_;
  filter::internal::TermScores scores_;
  Eigen::MatrixXd Finv_;      // F⁻¹, kept current with F
  Eigen::MatrixXd F_, G_;     // k x k
  std::vector<Sample> rows_;  // ring of the last lag_ + 2 rows
  long n_rows_ = 0;           // rows pushed
  int next_index_ = 0;        // next state index to complete
};

// The free parameters a linear model's dynamics or observations depend on (not only x0 and P0),
// among `free`.
std::vector<int> TrackableParameters(const model::LinearModel& model, std::span<const int> free);

}  // namespace gb::online
