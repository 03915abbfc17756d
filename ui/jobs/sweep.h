// The operating-point sweep as the workbench runs it (core/project/sweep.h): the sweep the
// project names, the progress record the sweeping threads write and the UI reads every frame,
// the work of the sweep job, and the finished sweep prepared for drawing (the Table 2 cells and
// the plot arrays of Fig. 3 and Fig. 4).
//
//   auto status = std::make_shared<SweepStatus>(n_datasets);
//   job.Start([=](JobControl& c) { return RunSweep(input, *status, c); });
//   every frame: status->latest(); job.TakeIfReady()
//
// Cancelling: the job's JobControl::cancel is the sweep's EstimateOptions::cancel, so
// Job::RequestCancel() stops the fits under way within about one log-likelihood evaluation and
// starts no other.
// No ImGui here: the job runs on its own threads and the tests use these types without a UI.
#pragma once

#include <chrono>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "core/model/model.h"
#include "core/project/linearised.h"
#include "core/project/operating_points.h"
#include "core/project/sweep.h"
#include "ui/jobs/job.h"
#include "ui/widgets/plot.h"

namespace gb::ui {

// Everything the sweep job needs, copied when it starts.
struct SweepInput {
  model::ModelSpec spec;
  project::OperatingPointsSpec points;
  int parallel = 0;  // datasets fitted at once; 0: all cores
  // The nonlinear model linearised at the points (operating_points.linearised) when the key
  // names no model file: the project's model as the workbench holds it.
  std::optional<model::ModelSpec> project_model;
  // SweepState::quick: each point's delay profile evaluated at its estimate, no extra starts.
  bool quick = false;
};

// The options RunSweep hands to core's Sweep: the points' relations, one thread per fit (so
// the fits are the same whatever `parallel` is), the other estimation options at their defaults
// (with `quick`, those SweepState::quick names).
project::SweepOptions MakeSweepOptions(const SweepInput& input);

// Written by the sweeping threads through SweepOptions::progress, read by the UI thread.
class SweepStatus {
 public:
  enum class PointState { kWaiting, kFitting, kDone };
  explicit SweepStatus(int n_datasets) : states_(static_cast<std::size_t>(n_datasets)) {}

  void Record(const project::SweepProgress& p);
  std::vector<PointState> states() const;  // one per dataset
  int done() const;                        // datasets whose fit has ended

 private:
  mutable std::mutex mutex_;
  std::vector<PointState> states_;
};

// What the job returns.
struct SweepRun {
  // Absent when the sweep failed (a dataset cannot be read or fitted); a cancelled sweep has a
  // result with `cancelled` set.
  std::optional<project::SweepResult> result;
  std::string error;  // why `result` is absent
  // With operating_points.linearised, after a sweep that finished: the nonlinear fit linearised
  // at each fitted point (in the order of `result->rows`), or why it could not be.
  std::optional<project::LinearisedSweep> linearised;
  std::string linearised_error;
};

// The job's work. Never throws.
SweepRun RunSweep(const SweepInput& input, SweepStatus& status, JobControl& control);

// One row of the Table 2 layout: a quantity, then one cell per operating point.
struct SweepTableRow {
  std::string label;  // "tau_fv [s]", "α [°]"
  std::vector<std::string> cells;
  std::string mean;  // "mean (SD)" over the points, for the parameters averaged; else ""
  // A row of the linearised nonlinear fit (beneath the parameter of its name): per cell, the
  // difference from the per-point estimate in combined standard errors, (lin − est) /
  // √(SE_lin² + SE_est²); NaN where either is missing.
  bool linearised = false;
  std::vector<double> z;
};

// A finished sweep, installed in AppState and drawn by the Operating points view.
struct SweepFigures {
  project::SweepResult result;
  project::OperatingPointsSpec points;  // what it ran with (labels of the tags)
  int model_revision = 0;               // AppState::model_revision when it started
  std::vector<std::string> columns;     // the points' names
  std::vector<SweepTableRow> table;
  std::vector<std::string> parameters;  // the free parameters, for the trend plot's choice
  std::vector<std::string> tags;        // the numeric tags every point has

  // Fig. 3: Δt against the speed tag, sorted by speed; bars ± half a sample interval when the
  // delay is estimated in whole samples, ± 1 SE when it is a parameter (delay_parameter); and
  // the fitted Δt = c / n over the speeds' range.
  std::vector<double> speed, delay, delay_bar;
  bool delay_bar_is_se = false;
  std::vector<double> curve_speed, curve_delay;

  // The linearised nonlinear fit (operating_points.linearised), when the project asks for it:
  // its table rows sit beneath the per-point estimates of the same name, and Fig. 3 shows its
  // delay (the quantity named like delay_parameter, or "delay") ± 1 SE at each point.
  std::optional<project::LinearisedSweep> linearised;
  std::string linearised_error;  // why it is absent although asked for
  std::vector<double> lin_speed, lin_delay, lin_delay_se;
  std::vector<double> lin_speed_drawn;  // lin_speed moved right a little (Dodged)
};

// Prepares a sweep for drawing (`linearised` and its error from the same run).
SweepFigures MakeSweepFigures(project::SweepResult result, project::OperatingPointsSpec points,
                              int model_revision,
                              std::optional<project::LinearisedSweep> linearised = std::nullopt,
                              std::string linearised_error = "");

// A parameter against a tag (Fig. 4: X against α): the estimates ± 1 SE sorted by the tag, and
// the least-squares line θ = a + b · tag over the tag's range (absent with fewer than 3 points).
struct TrendPlot {
  std::string parameter, tag;
  std::vector<double> x, y, se;  // se: 0 where the fit gave no standard error
  int without_se = 0;            // points drawn without a bar
  std::optional<project::LinearFit> fit;
  std::vector<double> line_x, line_y;
  // The linearised nonlinear fit's quantity of the parameter's name at the same points ± 1 SE
  // (empty without one).
  std::vector<double> lin_x, lin_y, lin_se;
  std::vector<double> lin_x_drawn;  // lin_x moved right a little (Dodged)
};

// Where markers drawn beside others at the same x go: `x` moved right by 1.2 % of the range of
// `x` and `others` together, so that neither hides the other.
std::vector<double> Dodged(const std::vector<double>& x, const std::vector<double>& others);
TrendPlot MakeTrendPlot(const SweepFigures& figures, const std::string& parameter,
                        const std::string& tag);

// The sweep: what the project names, the job under way, and the last finished sweep.
struct SweepState {
  // From the project's "operating_points" key when it was installed; absent when the key is
  // absent or wrong (`spec_error` says what is wrong, with file and JSON path).
  std::optional<project::OperatingPointsSpec> spec;
  std::string spec_error;

  Job<SweepRun> job;
  std::shared_ptr<SweepStatus> status;        // of the run under way
  std::vector<std::string> running_datasets;  // the run under way's files
  std::chrono::steady_clock::time_point started;
  int started_revision = 0;
  int started_generation = 0;
  // Runs the sweep's fits the quick way: each point's delay profile is evaluated at its estimate
  // instead of re-optimised at every delay (the estimates, the delays and the table are the
  // same, in a fraction of the fits, as tests/core/sweep_test does), and a point whose estimate
  // ends on a bound gets no extra starts (their code path has its own test,
  // tests/core/profile_test.cpp). Off in the workbench. The sanitizer suite turns it on, to
  // keep its time in check: greybench-snapshot --quick-sweep, and the workbench tests' driver.
  bool quick = false;
  // The last sweep that finished; a failed or cancelled run leaves it alone.
  std::optional<SweepFigures> result;
  std::string last_failure;            // how the last run ended when it left no result
  bool last_failure_is_error = false;  // else a warning (cancelled)

  // The trend plot's choice (edited in the view) and its arrays, remade when either changes.
  TrendPlot trend;
  plot::LinkedRange delay_x, trend_x;  // refitted when a new result is installed
};

}  // namespace gb::ui
