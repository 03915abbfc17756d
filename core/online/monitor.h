// Condition monitoring (the paper's section 6): a model watched on-line from a reference (a batch
// result), one row at a time.
//
// Two filters run side by side over the same rows:
//   - the on-line estimator, from the reference, tracking the parameters with its forgetting
//     factor: what the parameters are now, with their standard deviations. For a linear model
//     the recursive maximum-likelihood estimator (recursive.h); for a nonlinear one the augmented
//     extended Kalman filter (augmented.h), whose random walks have the same memory;
//   - the reference filter, held at the reference's estimates (the exact Kalman filter, or the
//     extended Kalman filter of ekf_stream.h for a nonlinear model): its innovations,
//     standardised, z = ε/√R, are i.i.d. N(0, 1) while the system is the reference's. The CUSUM
//     tests of cusum.h watch them, per output, for a shift of their mean (up, down) or a rise of
//     their variance, with thresholds designed for the false-alarm rate the user sets.
// Alarms:
//   - "innovations": a CUSUM test crossed its threshold (then it restarts; see cusum.h);
//   - "parameter": a tracked parameter has moved from its reference by the change the user names
//     (parameter_change, relative), up or down. The test is the statistical local approach
//     (Basseville & Nikiforov, Detection of Abrupt Changes, 1993, ch. 4; Basseville 1998): the
//     reference filter also carries the sensitivities of the tracked parameters, so at every row
//     it gives their exact score s_j = ∂ℓ_j/∂θ at θ_ref. While the system is the reference's,
//     the scores are martingale differences with variance Ī (the information per row of the
//     tracked parameters with the others held, as the held filter holds them: Ī⁻¹ = n Σ_T, Σ_T
//     the reference's covariance of the tracked block conditional on the other free parameters,
//     Reference::ConditionalCovarianceOf, over its n rows); after θ moves by Δ their mean is Ī Δ.
//     So over a block of B rows the efficient estimate of the move, Δ̂ = Ī⁻¹ Σ s / B, is
//     N(Δ, Ī⁻¹/B): for parameter a, z = Δ̂_a / √(n Σ_T,aa / B) is N(0, 1) before a change and
//     N(δ, 1) after a change Δ_a, δ = Δ_a / √(n Σ_T,aa / B), whatever the other tracked
//     parameters do (to first order: the efficient score projects them out, which isolates the
//     parameter that moved; parameters that are nearly interchangeable in the data, or a change
//     large enough to be nonlinear, can also move a neighbour's test). Two
//     mean-shift CUSUMs of cusum.h per parameter (up, down) watch z, one step per block. B makes
//     δ about ½; the thresholds come from the share of the false-alarm rate as for the
//     innovations. This is far more sensitive than waiting for the recursive estimate to leave an
//     interval: it accumulates evidence at the reference instead of comparing two noisy
//     estimates.
//     Calibration. The thresholds assume normal z, but the scores of one row are far from normal
//     (a variance parameter's is a (χ²₁ - 1) kind, skewness √8). What decides the false alarms is
//     the per-row shift δ₁ = Δ_a / √(n Σ_T,aa) the test is designed for, not B: the likeliest
//     way to a false alarm is a run of about 2h/δ₁² rows whose standardised score sum reaches
//     √(2h) SDs (Wald's tilt; h the threshold, 5-15), and with a per-row skewness κ the rate is
//     off by about exp(κ δ₁ h / 3). A change that shows within a few rows (δ₁ of order 1) is
//     decided by a few rows' scores: at δ₁ = 3 the tests alarmed 90-630 times as often as
//     designed. So δ₁ is at most 0.1 (an alarm weighs >= 1000 rows; blocks have >= 25 rows): a
//     larger --change is tested as the change of δ₁ = 0.1, more sensitive than asked (a larger
//     change is found sooner), and parameter_change() says what is tested. That is still
//     0.1 √n reference SEs (5 for n = 2500 rows), well beyond the reference's own error.
//   The parameter tests need the reference's correlations (its covariance given the others held
//   is their information); a tracked block that is singular there (a combination of tracked
//   parameters known exactly, according to the reference) is refused, naming the parameters:
//   no calibrated test exists for it. Tracking parameters outside the combination works.
// Half of the false-alarm rate goes to the innovation tests, half to the parameter tests.
// Nothing alarms during the estimator's warm-up. Both filters start as recursive.h says (kLive).
// The alarm state is sticky: `alarm` stays true from the first alarm until Acknowledge().
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/model/linear_model.h"
#include "core/model/nonlinear_model.h"
#include "core/online/cusum.h"
#include "core/online/estimator.h"
#include "core/online/recursive.h"
#include "core/util/json_fwd.h"
#include "core/util/result.h"

namespace gb::online {

struct MonitorOptions {
  RecursiveOptions recursive = DefaultRecursive();
  static RecursiveOptions DefaultRecursive() {
    RecursiveOptions o;
    o.forgetting = 0.999;  // a memory of 1000 rows (12.5 s at 80 Hz)
    return o;
  }
  double false_alarms_per_hour = 0.125;  // r: all tests together (one false alarm per 8 hours)
  double mean_shift = 1.0;               // δ of the innovation tests (SD units)
  double variance_ratio = 2.0;           // ρ of the innovation variance test
  // The relative change of a parameter worth an alarm, > 0 and finite (a change that a single
  // row shows at more than 0.1 SD is tested as a 0.1-SD change, see Calibration above: a
  // well-determined parameter's test is then more sensitive than asked).
  double parameter_change = 0.25;
  bool IsValid(std::string* why) const;
};

struct MonitorAlarm {
  enum class Kind { kInnovations, kParameter };
  Kind kind = Kind::kInnovations;
  std::string what;     // "ilambda: mean up" or "tau_ff"
  std::string message;  // a sentence for the user
};

struct MonitorUpdate {
  RecursiveUpdate estimate;             // the tracked parameters, their SDs, the innovations
  std::vector<double> z;                // per output: the reference filter's ε/√R (NaN: none)
  std::vector<double> cusum;            // per output, 3 each (mean up, down, variance): S/h
  std::vector<double> parameter_z;      // per tracked parameter: distance from the reference
  std::vector<double> parameter_cusum;  // per tracked parameter, 2 each (up, down): S/h
  std::vector<MonitorAlarm> alarms;     // raised at this row
  bool alarm = false;                   // any alarm since the start or Acknowledge()
};

class Monitor {
 public:
  static Result<Monitor> Create(const model::LinearModel& model, const Reference& reference,
                                const MonitorOptions& options);
  static Result<Monitor> Create(std::shared_ptr<const model::NonlinearModel> model,
                                const Reference& reference, const MonitorOptions& options);
  // The linear monitor when the model compiles as linear (LinearModel::Compile), else the
  // nonlinear one.
  static Result<Monitor> Create(const model::ModelSpec& spec, const Reference& reference,
                                const MonitorOptions& options);

  // Feeds one row; the updates of the state indices it completes (recursive.h). The CUSUM tests
  // are designed when the second row gives the sample time.
  Result<std::vector<MonitorUpdate>> Push(const Sample& row);
  void Acknowledge() { alarm_ = false; }

  // One line of the monitor's log (JSON Lines): t, line, index, warming_up, parameters (estimate,
  // sd, reference, z), innovations per output (value, sd, z of the reference filter), cusum per
  // output, alarms raised at this row, alarm.
  Json ToJson(const MonitorUpdate& u) const;

  const OnlineEstimator& estimator() const { return *estimator_; }
  const MonitorOptions& options() const { return options_; }
  const std::optional<CusumDesign>& design() const { return design_; }
  // Per tracked parameter: the block of its score test (rows; 0: no test) and its threshold.
  const std::vector<int>& parameter_block() const { return block_; }
  const std::vector<double>& parameter_h() const { return h_par_; }
  // Per tracked parameter: the change its test is designed for (natural units; see
  // MonitorOptions::parameter_change).
  const std::vector<double>& parameter_change() const { return delta_; }
  const std::vector<double>& reference_values() const { return ref_theta_; }  // tracked
  const std::vector<double>& reference_sd() const { return ref_sd_; }  // tracked (NaN: unknown)
  long long alarm_count() const { return alarm_count_; }

 private:
  Monitor(std::unique_ptr<OnlineEstimator> estimator, std::unique_ptr<OnlineEstimator> reference,
          const MonitorOptions& options)
      : estimator_(std::move(estimator)), reference_(std::move(reference)), options_(options) {}
  // The tests' set-up, once both filters are made.
  static Result<Monitor> Build(std::unique_ptr<OnlineEstimator> estimator,
                               std::unique_ptr<OnlineEstimator> held, const Reference& reference,
                               const MonitorOptions& options);
  Status Design(double sample_time);

  std::unique_ptr<OnlineEstimator> estimator_;
  std::unique_ptr<OnlineEstimator> reference_;
  MonitorOptions options_;
  std::vector<double> ref_theta_, ref_sd_;  // tracked
  std::optional<CusumDesign> design_;
  std::optional<CusumDetector> detector_;
  // The parameter score tests, per tracked parameter a.
  std::vector<double> delta_;  // Δ_a, natural units
  std::vector<int> block_;     // B_a rows (0: no test: no reference SE)
  std::vector<double> h_par_;  // threshold (log-likelihood-ratio units)
  std::vector<double> sum_s_;  // per parameter a: Σ s (k) over its block so far
  // The reference covariance of the tracked parameters with the others held at the reference
  // (Reference::ConditionalCovarianceOf, as the held filter holds them; zero where unknown), and
  // its SDs: what the score tests are standardised by.
  Eigen::MatrixXd ref_cov_;
  std::vector<double> test_sd_;
  std::vector<int> in_block_;
  std::vector<double> up_, down_;  // the CUSUM statistics
  double ref_rows_ = 0.0;
  double first_t_ = 0.0;
  long rows_ = 0;
  bool alarm_ = false;
  long long alarm_count_ = 0;
};

// "a, b and c": the parameters of `names` whose components of the unit vector `v` are at least
// 0.1 in size (an eigenvector's combination, for messages about singular covariances).
std::string CombinationOf(const Eigen::VectorXd& v, const std::vector<std::string>& names);

}  // namespace gb::online
