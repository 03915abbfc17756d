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

#include <Eigen/Core>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "core/estimate/estimate.h"
#include "core/filter/discretize.h"
#include "core/model/linear_model.h"
#include "core/online/follow.h"
#include "core/util/result.h"

namespace gb::online {

// Where the estimator starts: every parameter's value (ModelSpec order) and, for the free ones,
// the covariance of their batch estimate.
struct Reference {
  std::string source;          // the result file, for messages ("" when from memory)
  std::vector<double> theta;   // all parameters, natural scale
  std::vector<int> delay;      // per output, whole samples
  std::vector<int> free;       // indices of the parameters the covariance covers
  Eigen::MatrixXd covariance;  // free x free
  long n_obs = 0;              // scalar observations behind the reference

  // The covariance of the parameters `params` (indices as in `free`), NaN in the rows and
  // columns of a parameter the reference has no covariance for.
  Eigen::MatrixXd CovarianceOf(std::span<const int> params) const;
};

// The reference of a batch fit: its estimates, delays and the covariance of its free parameters.
Reference ReferenceFromSummary(const estimate::EstimateSummary& summary,
                               const model::ModelSpec& spec, std::string source = "");

struct RecursiveOptions {
  double forgetting = 1.0;  // λ in (0, 1]
  // λ_j rises from this towards `forgetting` (λ_j = 0.999 λ_{j-1} + 0.001 λ), to forget a poor
  // start fast; <= 0: λ_j = λ from the start.
  double forgetting_start = 0.0;
  // Rows of data the reference's information counts as (<= 0: the memory 1/(1-λ), or the
  // reference's rows for λ = 1).
  double prior_rows = 0.0;
  int warmup = -1;           // rows before θ moves; < 0: five of the slowest time constants
  double max_step_sd = 3.0;  // a step is at most this many current SDs in any parameter
  // The model and its exact discretisation (with their derivatives) are recomputed once a
  // parameter has moved by more than this many of its current SDs since they were last computed
  // (0: at every row). Between, the filter runs at that point: an error in θ of at most this
  // fraction of its uncertainty.
  double rediscretise_sd = 0.1;
  // The parameters to track, by name (each must be trackable: free, and in the dynamics or the
  // observations); empty: all that are. The others stay at the reference's values.
  std::vector<std::string> track;
  // Compute the scores and information of the tracked parameters, but never step: the filter
  // stays at the reference (the monitor's score tests, monitor.h).
  bool hold = false;
  // kLive: the equilibrium and stationary covariance (above). kModel: the model's own x0 and P0
  // as the batch filter starts (kalman.h), with their sensitivities; the first update then waits
  // for the second row (P0 "ctsm" needs the first interval).
  enum class Start { kLive, kModel };
  Start start = Start::kLive;
};

// What one row did.
struct RecursiveUpdate {
  int index = 0;  // state index (0 = the first row)
  double t = 0.0;
  int line = 0;  // source line of the row
  bool warming_up = false;
  std::vector<double> theta;  // tracked parameters (RecursiveMl::tracked() order)
  std::vector<double> sd;     // their standard deviations (empty when held)
  // Per output: innovation ε = y - ŷ and its standard deviation √R at the estimate before the
  // update (NaN where the output was not observed at this index).
  std::vector<double> innovation, innovation_sd;
  std::vector<double> information;  // diagonal of the row's Fisher information (tracked)
  double loglik_term = 0.0;         // ℓ_j at θ_{j-1}
  std::vector<double> score;        // ∂ℓ_j/∂θ at θ_{j-1} (tracked parameters)
};

class RecursiveMl {
 public:
  // The model with the reference's values; errors when the model cannot be evaluated at them.
  // Options are checked (λ in (0, 1], ...).
  static Result<RecursiveMl> Create(const model::LinearModel& model, const Reference& reference,
                                    const RecursiveOptions& options, bool adapt = true);

  // Feeds the next row (times strictly increasing). Returns the updates of the state indices that
  // row completes: with output delays d_o the observations of index j arrive with row
  // j + max d_o, so the updates lag the rows by that many (nothing is returned until then).
  Result<std::vector<RecursiveUpdate>> Push(const Sample& row);

  const std::vector<int>& tracked() const { return tracked_; }
  const std::vector<std::string>& tracked_names() const { return tracked_names_; }
  const model::LinearModel& model() const { return model_; }
  // All parameters at the current estimate.
  const std::vector<double>& theta() const { return theta_; }
  // Covariance of the tracked parameters (F⁻¹ G F⁻¹).
  Eigen::MatrixXd Covariance() const;

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

  Eigen::VectorXd x_;
  Eigen::MatrixXd P_;
  Eigen::MatrixXd dx_;               // n x k
  std::vector<Eigen::MatrixXd> dP_;  // k of n x n
  Eigen::MatrixXd Finv_;             // F⁻¹, kept current with F
  Eigen::MatrixXd F_, G_;            // k x k

  struct Scratch {  // per-row temporaries, sized once (no allocation per row)
    Eigen::MatrixXd PhiP, T, PhidP, info;
    Eigen::VectorXd next, PCt, dPCt;
  };
  Scratch scratch_;
  std::vector<Sample> rows_;  // ring of the last lag_ + 2 rows
  long n_rows_ = 0;           // rows pushed
  int next_index_ = 0;        // next state index to complete
};

// The free parameters a linear model's dynamics or observations depend on (not only x0 and P0),
// among `free`.
std::vector<int> TrackableParameters(const model::LinearModel& model, std::span<const int> free);

}  // namespace gb::online
