// What every on-line estimator of greybench shares (recursive.h for linear models, augmented.h
// for nonlinear ones, ekf_stream.h's held filter): where it starts (a batch result), its options,
// what one row did, and the interface the monitor (monitor.h) drives.
#pragma once

#include <span>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "core/data/follow.h"
#include "core/estimate/estimate.h"
#include "core/model/model.h"
#include "core/util/result.h"

namespace gb::online {

// The estimators take the rows of a live source (core/data/follow.h) one Sample at a time.
using data::Sample;
using data::SamplesOf;

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
  // The covariance of `params` with the reference's other free parameters held at their
  // estimates: Σ_TT - Σ_TU Σ_UU⁻¹ Σ_UT (U: the free parameters not in `params`), the inverse of
  // the `params` block of the information Σ⁻¹. It is what the data say about `params` when the
  // others are known, and smaller than CovarianceOf's marginal one where they are correlated.
  // NaN where CovarianceOf has NaN.
  Eigen::MatrixXd ConditionalCovarianceOf(std::span<const int> params) const;
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

// An estimator fed one row at a time (recursive.h, augmented.h, ekf_stream.h).
class OnlineEstimator {
 public:
  virtual ~OnlineEstimator() = default;
  // Feeds the next row (times strictly increasing). Returns the updates of the state indices
  // that row completes: with output delays d_o the observations of index j arrive with row
  // j + max d_o, so the updates lag the rows by that many.
  virtual Result<std::vector<RecursiveUpdate>> Push(const Sample& row) = 0;
  // The tracked parameters (indices into the model's parameters, and their names).
  virtual const std::vector<int>& tracked() const = 0;
  virtual const std::vector<std::string>& tracked_names() const = 0;
  virtual const model::ModelSpec& spec() const = 0;
  // All parameters at the current estimate.
  virtual const std::vector<double>& theta() const = 0;
  // Covariance of the tracked parameters at the current estimate.
  virtual Eigen::MatrixXd Covariance() const = 0;
  // What estimates, for reports: "recursive maximum likelihood (exact Kalman filter)".
  virtual std::string Method() const = 0;
};

}  // namespace gb::online
