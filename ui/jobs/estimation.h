// The estimation as the workbench runs it: the options the Estimate view edits, the progress
// record the estimating thread writes and the UI reads every frame, the work of the estimation
// job, and the finished fit prepared for drawing (plot arrays, report text).
//
//   auto progress = std::make_shared<EstimationProgress>();
//   job.Start([=](JobControl& c) { return RunEstimation(input, *progress, c); });
//   every frame: progress->Latest(), progress->AppendTrace(&trace); job.TakeIfReady()
//
// Cancelling: the job's JobControl::cancel is the estimator's EstimateOptions::cancel, so
// Job::RequestCancel() stops the fit within about one log-likelihood evaluation.
// No ImGui here: the job runs on its own thread and the tests use these types without a UI.
#pragma once

#include <array>
#include <limits>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/data/dataset.h"
#include "core/estimate/estimate.h"
#include "core/model/model.h"
#include "ui/jobs/job.h"

namespace gb::ui {

// What the Estimate view lets the user choose (the rest of EstimateOptions keeps its defaults).
struct EstimationSettings {
  estimate::Algorithm algorithm = estimate::Algorithm::kAuto;
  int multistart = 0;              // extra starts spread over the bounds
  int threads = 0;                 // 0: all cores
  bool profile_intervals = false;  // likelihood-ratio intervals of every free parameter (95 %)
  bool steady_start = false;       // EstimateOptions::steady_start
  double steady_window = 5.0;      // ... its windows' length (the project's "estimation" key)
  // Several records each from its own initial state (project::PerRecordInitialStates; the
  // project's "estimation": {"initial_states": "per_record"}).
  bool per_record_initial_states = false;
};
inline constexpr int kMaxMultistart = 1000;
inline constexpr int kMaxThreads = 256;

struct AlgorithmInfo {
  estimate::Algorithm algorithm;
  const char* name;     // as on the command line: "auto", "bhhh", ...
  const char* summary;  // one line for a tooltip
};
inline constexpr std::array<AlgorithmInfo, 6> kAlgorithms = {{
    {estimate::Algorithm::kAuto, "auto",
     "BHHH's information corrected by BFGS updates (exact gradients)"},
    {estimate::Algorithm::kBhhh, "bhhh", "Newton steps with the outer-product information"},
    {estimate::Algorithm::kSlsqp, "slsqp", "NLopt SLSQP: sequential quadratic programming"},
    {estimate::Algorithm::kLbfgs, "lbfgs", "NLopt L-BFGS: limited-memory quasi-Newton"},
    {estimate::Algorithm::kBobyqa, "bobyqa", "NLopt BOBYQA: derivative-free"},
    {estimate::Algorithm::kTrustRegion, "trust-region",
     "auto, then trust-region Newton steps on the exact Hessian where its steps crawl"},
}};
const AlgorithmInfo& Info(estimate::Algorithm algorithm);

// What the estimator is doing, from estimate::Progress::stage.
enum class FitStage { kStarting, kFitting, kDelayProfile, kStandardErrors };
std::string_view StageText(FitStage stage);  // "fitting", "delay profile", ...

// One report of the estimator (after an iteration).
struct TracePoint {
  int iteration = 0;
  int evaluations = 0;
  double loglik = 0.0;  // best log L of the fit under way
  FitStage stage = FitStage::kFitting;
};

// The log-likelihood trace as the plot widget takes it: one x per point, and the log L in the
// series of its stage (NaN in the other, so each series' line breaks where the other's runs).
struct Trace {
  std::vector<double> iteration;
  std::vector<double> loglik_fit;      // fits at the delay being estimated, and the end point
  std::vector<double> loglik_profile;  // fits at the other delays of a scanned range
  bool has_profile = false;            // loglik_profile holds a finite value
  void Append(const TracePoint& p);
  void Clear();
  int size() const { return static_cast<int>(iteration.size()); }
};

// Written by the estimating thread through EstimateOptions::progress, read by the UI thread.
// Every member function is thread-safe; the UI's calls are short and allocate nothing unless
// there are new trace points.
class EstimationProgress {
 public:
  struct Latest {
    bool any = false;  // false until the first report
    int iteration = 0;
    int evaluations = 0;
    // Best log L of the fits at the estimated delay so far (NaN before the first report).
    double best_loglik = std::numeric_limits<double>::quiet_NaN();
    FitStage stage = FitStage::kStarting;
  };

  void Record(const estimate::Progress& p);  // the estimating thread
  Latest latest() const;
  // Appends the points recorded since the trace last got them (trace->size() are known).
  void AppendTrace(Trace* trace) const;

 private:
  mutable std::mutex mutex_;
  Latest latest_;
  std::vector<TracePoint> trace_;
};

// Everything the estimation job needs, copied when it starts: the UI may edit the model while
// the job runs.
struct EstimationInput {
  model::ModelSpec spec;
  std::vector<std::shared_ptr<const data::Dataset>> datasets;
  // The project's entries of those datasets: the kept fit's project, and its files' fingerprints.
  std::vector<data::DatasetSpec> dataset_specs;
  EstimationSettings settings;
};

// What the job returns.
struct EstimationRun {
  // Absent when the estimation could not run (the model does not compile, the data do not fit
  // it, the start values cannot be evaluated); a cancelled run has a summary with cancelled set.
  std::optional<estimate::EstimateSummary> summary;
  std::string error;  // why `summary` is absent
  // With initial states per record: each record's parameters (Problem::series_parameters).
  std::vector<std::vector<int>> series_parameters;
  // The data files' fingerprints (FileFingerprint), as `greybench-cli estimate` records them.
  std::vector<std::string> fingerprints;
  model::ModelSpec spec;                         // the model fitted (EstimationInput::spec)
  std::vector<data::DatasetSpec> dataset_specs;  // EstimationInput::dataset_specs
};

// The job's work: binds the data, builds the likelihood and estimates, reporting to `progress`
// and stopping when control.cancel is set. A run the user stopped returns the best point it
// had reported as a summary of its own (estimate::StoppedSummary: log L there, no standard
// errors, `cancelled` set), or a cancelled summary without parameters when it had reported
// none. Never throws.
EstimationRun RunEstimation(const EstimationInput& input, EstimationProgress& progress,
                            JobControl& control);

// The delay profile of one scanned output, as plot arrays.
struct DelayProfilePlot {
  std::string output;
  std::vector<double> delay;                            // ascending
  std::vector<double> loglik;                           // NaN where the fit at that delay failed
  std::vector<double> estimate_delay, estimate_loglik;  // one point: the estimate
  bool any_lower_bound = false;  // some fits were stopped early (their log L is a lower bound)
};

// A finished fit, installed in AppState and drawn by the Estimate and Parameters views.
struct FitResult {
  estimate::EstimateSummary summary;
  EstimationSettings settings;  // the options it ran with
  int model_revision = 0;       // AppState::model_revision when it started
  std::string report;           // summary.Report() (see MakeFitResult for snapshots)
  Trace trace;
  std::vector<DelayProfilePlot> profiles;
  std::vector<double> correlation;  // summary.correlation, row-major
  // A fit with initial states per record: its parameters are the model's followed by the
  // records' copies, and row k maps fitted record k's parameters onto them
  // (filter::Likelihood::set_series_parameters). Empty for a shared initial state.
  std::vector<std::vector<int>> series_parameters;
};

// The fit is of this model: its parameters are the model's, in order (followed by the records'
// copies in a fit with initial states per record), and so are its outputs (an edit in the
// Parameters view changes values and bounds, never the names), so its θ and delays can be shown
// with it.
bool FitMatchesModel(const FitResult& fit, const model::ModelSpec& m);

// Prepares a summary for drawing. With `deterministic` (greybench-snapshot) the elapsed time
// in the report is replaced by a fixed placeholder, so the same inputs give the same picture.
FitResult MakeFitResult(estimate::EstimateSummary summary, Trace trace, EstimationSettings settings,
                        int model_revision, bool deterministic);

// Shown instead of a duration in snapshots.
inline constexpr const char* kElapsedPlaceholder = "\xE2\x80\x93 s";  // "– s"

}  // namespace gb::ui
