// The predictions and residual diagnostics the Predictions and Residuals views draw, computed
// by a background job at one parameter vector θ (the last fit's estimates, or the model's
// current values when there is no fit) for every dataset of the project, and laid out as the
// plot widget takes them (it never copies: the arrays live in AppState).
//
//   AnalysisInput input = ...;                  // copied when the job starts
//   job.Start([=](JobControl& c) { return RunAnalysis(input, c); });
//   every frame: job.TakeIfReady() -> AnalysisRun
//
// Per dataset and output o, with the delay d_o used (core/filter/predict.h):
//   measured     y_{o,k}                           (NaN where missing)
//   predicted    ŷ_{o,k|k-1}, band ŷ ± 2 sd         (sd includes the measurement noise S_o)
//   residual     ε_{o,k} = y_{o,k} - ŷ_{o,k|k-1}, band 0 ± 2 sd
//   ahead        ŷ_{o,k|k-h}: the h-step prediction (PredictAhead), h chosen in the view (only
//                while the view shows them: request.horizon 0 otherwise)
//   smoothed     the noise-free output at the smoothed state x̂_{j|N} (conditioned on every
//                observation: Rauch-Tung-Striebel, or its extended form for the EKF), band ± 2 sd
//                of that output (without the measurement noise)
//   simulated    the deterministic response from x0 (core/sim/response.h): no data assimilated
//   fit figures  the simulation's RMS error and fit % = 100 (1 - ||y - ŷ_sim|| / ||y - ȳ||)
//                over the rows the likelihood uses (y observed, k >= the largest delay)
//
// A validation record (not fitted) starts at its own initial state, from its first samples
// (core/filter/initial_state.h), and its fit figures leave those samples out; an estimation
// record starts at the model's x0, which the fit estimated.
//   preview      the same at the model's current values (the Data view's overlay), whatever θ is
//   rms          sqrt(mean ε²) over the n_observed observations the likelihood uses (k >= the
//                output's largest delay, y observed)
//   diagnostics  core/diagnose on the standardised residuals z = ε / sd of those observations,
//                with every input of the model (Diagnose's default lags and bins)
//
// Delays: the fit's estimates; without a fit the model's fixed delay, or for a scanned range the
// delay that maximises the log-likelihood at θ over the estimation records (all datasets when
// every one is a validation record; as greybench-cli predict).
// Observations before each output's largest delay are scored by no candidate, so they carry
// no residual (user guide §1).
//
// Cancelling: JobControl::cancel stops the filter within a few thousand samples; the run then
// returns with `cancelled` set and no result. No ImGui here: the tests use it without a UI.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "core/data/dataset.h"
#include "core/diagnose/residuals.h"
#include "core/model/model.h"
#include "ui/jobs/job.h"

namespace gb::ui {

// Where θ comes from.
enum class AnalysisSource { kFit, kCurrentValues };

// What an analysis is computed for. Two equal requests give the same numbers, so the workbench
// restarts the job only when the request it would make changes.
struct AnalysisRequest {
  int project_generation = 0;  // AppState::project_generation
  int datasets_revision = 0;   // AppState::datasets_revision
  int model_revision = 0;      // AppState::model_revision
  AnalysisSource source = AnalysisSource::kCurrentValues;
  std::vector<double> theta;  // every parameter, in model order
  std::vector<int> delay;     // per output (the fit's); empty: chosen as described above
  bool steps = false;         // the filter's steps (FilterSteps: the Predictions view's Step mode)
  int horizon = 1;  // h of the h-step predictions, >= 1; 0: none (the view does not show them)
  std::vector<double> preview_theta;  // the model's current values, for `preview`
  // A fit with initial states per record: fitted record k's own θ (model order), for the k-th
  // estimation dataset in project order; empty: every record at `theta`.
  std::vector<std::vector<double>> record_theta;
  // The parameters the sliders moved away from the source's values (their values are in θ).
  std::vector<std::string> moved;
  bool operator==(const AnalysisRequest&) const = default;
};

inline constexpr int kMaxHorizon = 100000;

// Everything the job needs, copied when it starts.
struct AnalysisInput {
  AnalysisRequest request;
  model::ModelSpec spec;  // the structure; its parameter values are not used (θ is the request's)
  // One per dataset of the project, in project order; null: it could not be read (`read_error`).
  std::vector<std::shared_ptr<const data::Dataset>> datasets;
  std::vector<std::string> names;        // file names for the view
  std::vector<std::string> read_errors;  // per dataset, why it is null
  std::vector<bool> validation;          // per dataset: a validation record (empty: none is)
};

// A correlogram as plot arrays: stems at `lag`, and the band ±`band` over the lag range.
struct CorrelogramPlot {
  std::vector<double> lag, value;
  std::vector<double> band_x, band_lo, band_hi;  // two points: the first and last lag
  double band = 0.0;
};

// The diagnostics of one output as plot arrays (the numbers themselves are in `stats`).
struct DiagnosticsPlot {
  diagnose::ResidualDiagnostics stats;
  CorrelogramPlot acf, pacf;
  std::vector<CorrelogramPlot> ccf, ccf_prewhitened;  // one per input, lags -K..K
  // Cumulated periodogram against frequency (cycles per sample, as core computes it), the
  // white-noise line and its Kolmogorov-Smirnov band.
  std::vector<double> white_lo, white_hi;
  // Histogram of z as a density (a staircase: x repeats at each inner edge) and N(0, 1).
  std::vector<double> hist_x, hist_density, hist_zero;
  std::vector<double> normal_x, normal_density;
  // QQ: stats.normality.qq_theoretical against qq_sample, and the line y = x over their range.
  std::vector<double> qq_line;
};

struct OutputAnalysis {
  std::string name;
  int delay = 0;
  std::vector<double> measured, predicted, lower, upper;
  std::vector<double> residual, residual_lower, residual_upper;
  std::vector<double> standardized;  // NaN where the likelihood does not use y
  std::vector<double> ahead;         // h-step predictions (empty when they failed: ahead_error)
  std::string ahead_error;
  std::vector<double> smoothed, smoothed_lower, smoothed_upper;  // empty when smoothed_error
  std::string smoothed_error;
  std::vector<double> simulated;
  std::vector<double> preview;  // empty when the model's values cannot be evaluated
  int n_observed = 0;
  double rms = 0.0;  // NaN when n_observed = 0
  // The simulation against the measurements (NaN when there is no simulation or fewer than 2
  // rows to judge it on): its RMS error and fit %, over n_simulated rows.
  double simulation_rms = 0.0;
  double fit_percent = 0.0;
  int n_simulated = 0;
  std::optional<DiagnosticsPlot> diagnostics;
  std::string diagnose_error;  // why `diagnostics` is absent (e.g. too few residuals)
};

// The filter sample by sample (the Predictions view's Step mode), at every state index j: the state
// before the update (x̂_{j|j-1}, sd from P_{j|j-1}) and after it (x̂_{j|j}, sd from P_{j|j}), and the
// gain K_j = P_{j|j-1} H' (H P_{j|j-1} H' + S)⁻¹ of the outputs observed there (H = C, or ∂h/∂x at
// x̂_{j|j-1} for the EKF), so that x̂_{j|j} = x̂_{j|j-1} + K_j ε_j. Output o's row is k = j + d_o.
struct FilterSteps {
  std::vector<std::string> states;
  Eigen::MatrixXd x_prior, x_post, sd_prior, sd_post;  // n x N
  Eigen::MatrixXd gain;    // (n p) x N: K(i, o) in row i p + o; NaN where o is not observed at j
  Eigen::MatrixXd y_post;  // p x N at row k: the output at x̂_{j|j} (without noise); NaN unobserved
  std::string error;       // why the gains could not be computed (the rest is there)
};

struct DatasetAnalysis {
  std::string name;  // file name
  bool validation = false;
  int initial_samples = 0;    // a validation record: the rows its initial state is taken from
  std::string initial_error;  // why it starts at the model's x0 after all
  std::string error;          // why there is nothing else (unreadable, does not fit the model, ...)
  std::string time_name;
  std::vector<double> time;
  double sample_interval = 0.0;  // the uniform Δ, or 0 when the intervals vary
  std::vector<OutputAnalysis> outputs;
  FilterSteps steps;    // empty unless request.steps
  double loglik = 0.0;  // of this dataset at θ (the filter's)
  long n_obs = 0;
};

struct Analysis {
  AnalysisRequest request;
  std::vector<std::string> parameter_names;
  std::vector<std::string> inputs, outputs, states;
  std::vector<int> delay;     // used, per output
  std::string delay_source;   // "fit", "model", "profile likelihood at these values"
  std::string preview_error;  // why there is no preview (the model's values do not evaluate)
  std::vector<DatasetAnalysis> datasets;
};

struct AnalysisRun {
  std::optional<Analysis> analysis;  // absent: failed (error) or cancelled
  bool cancelled = false;
  std::string error;
};

// The job's work. Never throws.
AnalysisRun RunAnalysis(const AnalysisInput& input, JobControl& control);

}  // namespace gb::ui
