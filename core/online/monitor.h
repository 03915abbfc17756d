// Condition monitoring (the paper's section 6): a linear model watched on-line from a reference
// (a batch result), one row at a time.
//
// Two filters run side by side over the same rows:
//   - the recursive estimator (recursive.h), from the reference, tracking the parameters with its
//     forgetting factor: what the parameters are now, with their standard deviations;
//   - the reference filter, the Kalman filter held at the reference's estimates: its innovations,
//     standardised, z = ε/√R, are i.i.d. N(0, 1) while the system is the reference's. The CUSUM
//     tests of cusum.h watch them, per output, for a shift of their mean (up, down) or a rise of
//     their variance, with thresholds designed for the false-alarm rate the user sets.
// Alarms:
//   - "innovations": a CUSUM test crossed its threshold (then it restarts; see cusum.h);
//   - "parameter": a tracked parameter left its reference interval, i.e. the standardised
//     distance |θ_j - θ_ref| / √(sd_j² + se_ref²) passed z_par. The estimate is correlated from
//     row to row over its memory m = 1/(1-λ) rows, so the test is taken as one look per memory:
//     z_par is the two-sided normal quantile of a false-alarm probability of
//     r T_s m / (3600 k) per look (k tracked parameters, Bonferroni), at least 3. It fires when
//     the distance first passes z_par, and again only after it has stayed below 0.8 z_par for a
//     whole memory.
// Nothing alarms during the estimator's warm-up. Both filters start as recursive.h says (kLive).
// The alarm state is sticky: `alarm` stays true from the first alarm until Acknowledge().
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "core/model/linear_model.h"
#include "core/online/cusum.h"
#include "core/online/recursive.h"
#include "core/util/json.h"
#include "core/util/result.h"

namespace gb::online {

struct MonitorOptions {
  RecursiveOptions recursive{.forgetting = 0.999};
  double false_alarms_per_hour = 0.125;  // r: all tests together (one false alarm per 8 hours)
  double mean_shift = 1.0;               // δ of the innovation tests (SD units)
  double variance_ratio = 2.0;           // ρ of the innovation variance test
  bool IsValid(std::string* why) const;
};

struct MonitorAlarm {
  enum class Kind { kInnovations, kParameter };
  Kind kind = Kind::kInnovations;
  std::string what;     // "ilambda: mean up" or "tau_ff"
  std::string message;  // a sentence for the user
};

struct MonitorUpdate {
  RecursiveUpdate estimate;          // the tracked parameters, their SDs, the innovations
  std::vector<double> z;             // per output: the reference filter's ε/√R (NaN: none)
  std::vector<double> cusum;         // per output, 3 each (mean up, down, variance): S/h
  std::vector<double> parameter_z;   // per tracked parameter: distance from the reference
  std::vector<MonitorAlarm> alarms;  // raised at this row
  bool alarm = false;                // any alarm since the start or Acknowledge()
};

class Monitor {
 public:
  static Result<Monitor> Create(const model::LinearModel& model, const Reference& reference,
                                const MonitorOptions& options);

  // Feeds one row; the updates of the state indices it completes (recursive.h). The CUSUM tests
  // are designed when the second row gives the sample time.
  Result<std::vector<MonitorUpdate>> Push(const Sample& row);
  void Acknowledge() { alarm_ = false; }

  // One line of the monitor's log (JSON Lines): t, line, index, warming_up, parameters (estimate,
  // sd, reference, z), innovations per output (value, sd, z of the reference filter), cusum per
  // output, alarms raised at this row, alarm.
  Json ToJson(const MonitorUpdate& u) const;

  const RecursiveMl& estimator() const { return estimator_; }
  const std::optional<CusumDesign>& design() const { return design_; }
  double parameter_threshold() const { return z_parameter_; }
  std::vector<double> reference_values() const;  // tracked parameters
  std::vector<double> reference_sd() const;      // tracked parameters (NaN: unknown)
  long long alarm_count() const { return alarm_count_; }

 private:
  Monitor(RecursiveMl estimator, RecursiveMl reference, const MonitorOptions& options)
      : estimator_(std::move(estimator)), reference_(std::move(reference)), options_(options) {}
  Status Design(double sample_time);

  RecursiveMl estimator_;
  RecursiveMl reference_;
  MonitorOptions options_;
  std::vector<double> ref_theta_, ref_sd_;  // tracked
  std::optional<CusumDesign> design_;
  std::optional<CusumDetector> detector_;
  double z_parameter_ = 0.0;
  std::vector<bool> out_;   // per tracked parameter: past z_par, not yet back
  std::vector<long> back_;  // rows since it came back below 0.8 z_par
  long rearm_rows_ = 1;
  double first_t_ = 0.0;
  long rows_ = 0;
  bool alarm_ = false;
  long long alarm_count_ = 0;
};

// The reference of a result file for `spec` (the model the monitor runs): every parameter's
// estimate (fixed ones as the model has them), the delays, the covariance of the free parameters
// from their standard errors and correlations, and n_obs. Errors name the file and JSON path.
Result<Reference> LoadReference(const std::string& path, const model::ModelSpec& spec);

}  // namespace gb::online
