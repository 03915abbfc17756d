// The log-likelihood of a model over several independent data series, with output delays
// (user guide §1): log L(θ) = Σ_series log L_series(θ). A linear model (LinearModel) runs
// the exact Kalman filter (kalman.h) with exact scores (score.h); any other model
// (NonlinearModel) runs the extended Kalman filter (ekf.h), whose scores are its forward
// sensitivities (ekf_score.h; differences for the iterated EKF, see EvaluateWithScore).
//
// Delays: each output o has a delay range [min_o, max_o] from the model (a fixed delay has
// min_o = max_o). Every delay candidate is scored on the same observations, y_{o,k} with
// k >= max_o, so the log-likelihoods of different candidates compare. `Evaluate` takes one
// candidate (a delay per output); `Profile` scores every candidate of the grid (the Cartesian
// product of the outputs' ranges) at fixed θ.
#pragma once

#include <memory>
#include <optional>
#include <span>
#include <vector>

#include "core/data/dataset.h"
#include "core/filter/ekf.h"
#include "core/filter/kalman.h"
#include "core/model/linear_model.h"
#include "core/model/nonlinear_model.h"
#include "core/model/nonlinear_sensitivity.h"

namespace gb::filter {

struct DelayCandidate {
  std::vector<int> delay;  // per output
  double loglik = 0.0;
  long n_obs = 0;
  bool ok = false;
  std::string message;  // why it failed, when !ok
};

struct DelayProfile {
  std::vector<DelayCandidate> candidates;  // in grid order
  int best = -1;                           // index of the highest log-likelihood, -1 if none ok
};

// θ_s of a series whose row of Likelihood::set_series_parameters is `row`: θ_s[i] = θ[row[i]],
// or θ[i] where row[i] is -1 (an empty row: θ itself).
std::vector<double> SeriesTheta(std::span<const double> theta, std::span<const int> row);

class Likelihood {
 public:
  // Binds nothing itself: `series` must be bound to the model's inputs and outputs. Fails (kInput)
  // when a delay range does not fit in a series ("output_delay.ilambda: the delay range reaches
  // 12 samples but f1.csv has 10 rows").
  static Result<Likelihood> Create(std::shared_ptr<const model::LinearModel> model,
                                   std::vector<std::shared_ptr<const data::Series>> series);
  // The same for a model the extended Kalman filter runs.
  static Result<Likelihood> Create(std::shared_ptr<const model::NonlinearModel> model,
                                   std::vector<std::shared_ptr<const data::Series>> series);

  // This likelihood with the nonlinear model's programs and their derivatives as native code
  // (core/expr/native.h), compiled now or loaded from the cache: the same values bit for bit,
  // faster. A linear model's (its matrices are built once per evaluation) is copied as it is.
  // Fails (kNumerical) where the code cannot be built; the caller then keeps this one.
  Result<Likelihood> WithNativeCode() const;
  bool native() const { return nonlinear_ && nonlinear_->native(); }

  // log L at θ (all parameters, natural scale) with the given delay per output (empty: each
  // output's min).
  // With `terms`: the per-state-index terms of every series, concatenated (see LogLikelihood).
  // With `threads` > 1 the series are filtered side by side on up to that many threads (records
  // of a joint fit); the sums are taken in the series' order, so the result is the same bit for
  // bit whatever the count.
  Result<Loglik> Evaluate(std::span<const double> theta, std::span<const int> delay = {},
                          std::vector<double>* terms = nullptr, int threads = 1) const;

  // log L at θ as Evaluate, and its exact derivatives (core/filter/score.h) with respect to the
  // parameters θ_i, i in `free` (indices into the model's parameters), on their natural scale:
  // *gradient (free.size()) is Σ_series ∂ log L_series/∂θ; with J_terms_theta, row r is the score
  // ∂ℓ_r/∂θ of the r-th term that Evaluate's `terms` returns (series after series), so the rows
  // sum to the gradient and BHHH's information is J' J. Fails as Evaluate does, and when a
  // derivative of the model's entries is not finite (LinearModel::EvaluateJacobian).
  // For the extended Kalman filter the derivatives are exact to the ODE tolerance (forward
  // sensitivities, core/filter/ekf_score.h) unless exact_scores() is false (the iterated EKF):
  // then central differences of the terms with the step h_i = kDifferenceStep max(|θ_i|,
  // 1e-3 s_i), s_i the width of θ_i's bounds or 1 when unbounded (one-sided where a step would
  // leave the bounds), as accurate as the ODE tolerance allows (about rtol / kDifferenceStep).
  // `threads` as Evaluate's. A linear model's gradient alone is differentiated as
  // `linear_gradient` says (GradientInOnePiece).
  Result<Loglik> EvaluateWithScore(
      std::span<const double> theta, std::span<const int> delay, std::span<const int> free,
      Eigen::VectorXd* gradient, Eigen::MatrixXd* J_terms_theta = nullptr, int threads = 1,
      LinearGradient linear_gradient = LinearGradient::kSteadyState) const;

  // Every delay candidate at θ. The model is evaluated once.
  Result<DelayProfile> Profile(std::span<const double> theta) const;

  // The delay grid: the Cartesian product of the outputs' ranges (a single entry without scans).
  std::vector<std::vector<int>> DelayGrid() const;

  static constexpr double kDifferenceStep = 1e-5;

  // How EvaluateWithScore differentiates the extended Kalman filter when only the gradient is
  // asked for (no J_terms_theta): forward sensitivities (ekf_score.h), or the discrete adjoint
  // (ekf_adjoint.h), whose cost does not grow with the parameters. kAuto chooses by the model's
  // size and the number of free parameters (UsesAdjoint). Both give the same gradient to
  // rounding; the per-term scores are always the forward sensitivities'. A series on which an
  // interval needs BDF falls back to the forward sensitivities.
  enum class GradientMethod { kAuto, kForward, kAdjoint };
  void set_gradient_method(GradientMethod method) { gradient_method_ = method; }
  GradientMethod gradient_method() const { return gradient_method_; }
  // Whether a gradient of `free_count` free parameters (no per-term scores) is the adjoint's:
  // under kAuto from kAdjointFrom free parameters on; never for a model whose "ode" is "bdf".
  bool UsesAdjoint(std::size_t free_count) const;
  static constexpr std::size_t kAdjointFrom = 3;
  // kAuto's rule for an EKF with exact scores (UsesAdjoint's, and the report's, which formats a
  // fit without its likelihood): the adjoint from kAdjointFrom free parameters on, unless the
  // model's "ode" is "bdf".
  static bool AutoUsesAdjoint(std::size_t free_count, model::OdeMethod method) {
    return method != model::OdeMethod::kBdf && free_count >= kAdjointFrom;
  }

  // Whether a gradient alone (no per-term scores) may come from the linear filter's adjoints
  // (LinearGradient::kSteadyState, kAdjoint). Where the steady state begins turns on which
  // parameters are differentiated together, and the adjoint of the whole recursion is one
  // pass, so such a gradient is asked for all the free parameters at once: in chunks (on
  // threads) its last bits would turn on the chunks. With kForward the gradient is the same in
  // any chunks.
  bool GradientInOnePiece() const;

  // Whether EvaluateWithScore's derivatives are exact (to the ODE tolerance for the EKF): every
  // linear model, and every other whose EKF is not iterated.
  bool exact_scores() const {
    return linear_ || (sensitivity_ && nonlinear_->spec().ekf.iterations == 1);
  }

  const model::ModelSpec& spec() const { return linear_ ? linear_->spec() : nonlinear_->spec(); }
  // The linear model, or null when the extended Kalman filter runs.
  const model::LinearModel* linear() const { return linear_.get(); }
  // The model the extended Kalman filter runs, or null for a linear model.
  const model::NonlinearModel* nonlinear() const { return nonlinear_.get(); }
  // The same model, shared (WithNativeCode's copy runs native code).
  const std::shared_ptr<const model::NonlinearModel>& nonlinear_shared() const {
    return nonlinear_;
  }
  // The ODE solver's work summed over every EKF evaluation since creation (zero for a linear
  // model). Not synchronised: read it when no evaluation runs.
  ode::OdeCounts ode_counts() const;
  const std::vector<std::shared_ptr<const data::Series>>& series() const { return series_; }
  const FilterSettings& settings() const { return settings_; }
  // Evaluations stop early (with an Error) once *cancel is true; nullptr: never.
  void set_cancel(const std::atomic<bool>* cancel) { settings_.cancel = cancel; }

  // Parameters of a series' own (several records fitted jointly, each from its own initial
  // state: core/project/problem.h's PerRecordInitialStates). Series s is evaluated at θ_s:
  // θ_s[i] = θ[index[s][i]], or θ[i] where index[s][i] is -1 (a parameter series s does not
  // use: another record's copy); an empty row (or no rows) is θ itself. The derivatives are
  // gathered back onto θ: ∂ log L/∂θ_j = Σ_s Σ_{i: index[s][i] = j} ∂ log L_s/∂θ_s,i.
  // Precondition: one row per series, each empty or of the model's parameter count.
  void set_series_parameters(std::vector<std::vector<int>> index);
  // θ_s of series s (θ itself without series parameters).
  std::vector<double> SeriesTheta(std::span<const double> theta, std::size_t s) const;
  const std::vector<std::vector<int>>& series_parameters() const { return series_parameters_; }

 private:
  static Result<Likelihood> CreateFor(const model::ModelSpec& spec,
                                      std::vector<std::shared_ptr<const data::Series>> series);
  // The parameters to differentiate series s in (indices into θ_s) and the column of `free` each
  // one's derivative belongs to.
  struct SeriesFree {
    std::vector<int> params;
    std::vector<Eigen::Index> columns;
  };
  SeriesFree FreeOf(std::span<const int> free, std::size_t s) const;
  // The linear model at each series' parameters: one entry when every series uses θ itself.
  Result<std::vector<model::StateSpace>> LinearAt(std::span<const double> theta) const;
  template <class One>
  Result<Loglik> ScoreOverSeries(
      std::span<const int> delay, std::span<const int> free, Eigen::VectorXd* gradient,
      Eigen::MatrixXd* J_terms_theta, int threads, One&& one,
      LinearGradient linear_gradient = LinearGradient::kSteadyState) const;
  template <class One>
  Result<Loglik> SumOverSeries(std::span<const int> delay, std::vector<double>* terms, int threads,
                               One&& one) const;
  Result<Loglik> EvaluateAt(const std::vector<model::StateSpace>& ss, std::span<const int> delay,
                            std::vector<double>* terms = nullptr, int threads = 1) const;
  Result<Loglik> EvaluateEkf(std::span<const double> theta, std::span<const int> delay,
                             std::vector<double>* terms = nullptr, int threads = 1) const;
  Result<Loglik> EkfScore(std::span<const double> theta, std::span<const int> delay,
                          std::span<const int> free, Eigen::VectorXd* gradient,
                          Eigen::MatrixXd* J_terms_theta) const;

  std::shared_ptr<const model::LinearModel> linear_;
  std::shared_ptr<const model::NonlinearModel> nonlinear_;
  std::shared_ptr<const model::NonlinearSensitivity> sensitivity_;  // for exact EKF scores
  struct Counts;
  std::shared_ptr<Counts> counts_;  // the ODE work, shared by copies
  std::vector<std::shared_ptr<const data::Series>> series_;
  FilterSettings settings_;                          // first_obs = each output's max delay
  std::vector<std::vector<int>> series_parameters_;  // see set_series_parameters
  GradientMethod gradient_method_ = GradientMethod::kAuto;
};

}  // namespace gb::filter
