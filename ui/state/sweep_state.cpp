// AppState's operating-point sweep: reading the project's sweep, starting, cancelling and
// installing the sweep job (declared in ui/state/app_state.h beside the estimation's counterparts).
#include <algorithm>
#include <chrono>
#include <utility>

#include "ui/format.h"
#include "ui/state/app_state.h"

namespace gb::ui {
namespace {

bool HasParameter(const model::ModelSpec& spec, const std::string& name) {
  return std::any_of(spec.parameters.begin(), spec.parameters.end(),
                     [&](const model::Parameter& p) { return p.name == name; });
}

// The sweep's parameter names must be the model's: a typo would otherwise leave a relation out
// without a word.
std::string CheckNames(const AppState& state, const project::OperatingPointsSpec& spec,
                       const model::ModelSpec& m) {
  const std::string where =
      (state.project ? state.project->path + ": " : std::string()) + project::kOperatingPointsKey;
  if (!HasParameter(m, spec.trend_parameter))
    return where + ".trend.parameter: the model has no parameter '" + spec.trend_parameter + "'";
  for (std::size_t i = 0; i < spec.mean_of.size(); ++i) {
    if (!HasParameter(m, spec.mean_of[i]))
      return where + ".mean_of[" + std::to_string(i) + "]: the model has no parameter '" +
             spec.mean_of[i] + "'";
  }
  if (!spec.delay_parameter.empty() && !HasParameter(m, spec.delay_parameter))
    return where + ".delay_parameter: the model has no parameter '" + spec.delay_parameter + "'";
  return "";
}

void InstallSweep(AppState& state, SweepRun run) {
  SweepState& s = state.sweep;
  const double elapsed =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - s.started).count();
  const int n = static_cast<int>(s.running_datasets.size());
  s.status.reset();
  s.running_datasets.clear();
  if (s.started_generation != state.project_generation) return;  // a project since closed
  if (!run.result) {
    s.last_failure = "The sweep failed: " + run.error;
    s.last_failure_is_error = true;
    AddMessage(state, Severity::kError,
               s.last_failure + (s.result ? " (the previous table is kept)" : ""));
    return;
  }
  if (run.result->cancelled) {
    s.last_failure = "The sweep was cancelled" + ElapsedClause(state, " after ", elapsed) + " (" +
                     std::to_string(run.result->rows.size()) + " of " + std::to_string(n) +
                     " points fitted)";
    s.last_failure_is_error = false;
    AddMessage(state, Severity::kWarning,
               s.last_failure + (s.result ? "; the previous table is kept" : ""));
    return;
  }
  const auto& rows = run.result->rows;
  const auto converged =
      std::count_if(rows.begin(), rows.end(), [](const auto& r) { return r.summary.converged; });
  const bool all = converged == static_cast<long>(rows.size());
  AddMessage(state, all ? Severity::kInfo : Severity::kWarning,
             "Sweep finished: " + std::to_string(rows.size()) + " operating points, " +
                 (all ? "all converged" : std::to_string(converged) + " converged") +
                 ElapsedClause(state, ", ", elapsed));
  s.last_failure.clear();
  project::OperatingPointsSpec points = s.spec ? *s.spec : project::OperatingPointsSpec{};
  // The trend keeps the user's choice when the new sweep has it, else the project's.
  std::string parameter = s.trend.parameter.empty() ? points.trend_parameter : s.trend.parameter;
  std::string tag = s.trend.tag.empty() ? points.trend_tag : s.trend.tag;
  if (!run.linearised_error.empty()) {
    AddMessage(state, Severity::kError,
               "The nonlinear fit could not be linearised at the points: " + run.linearised_error);
  }
  s.result = MakeSweepFigures(std::move(run.result).value(), std::move(points), s.started_revision,
                              std::move(run.linearised), std::move(run.linearised_error));
  const SweepFigures& f = *s.result;
  if (std::find(f.parameters.begin(), f.parameters.end(), parameter) == f.parameters.end())
    parameter = f.points.trend_parameter;
  if (std::find(f.tags.begin(), f.tags.end(), tag) == f.tags.end()) tag = f.points.trend_tag;
  s.trend = MakeTrendPlot(f, parameter, tag);
  s.delay_x.RequestFit();
  s.trend_x.RequestFit();
}

}  // namespace

void ResetSweep(AppState& state) {
  SweepState& s = state.sweep;
  // A run still under way belonged to the previous project: stopped, and ignored when it ends.
  if (s.job.active()) s.job.RequestCancel();
  s.spec.reset();
  s.spec_error.clear();
  s.result.reset();
  s.last_failure.clear();
  s.trend = TrendPlot{};
  if (!state.project) return;
  Result<std::optional<project::OperatingPointsSpec>> spec =
      project::ReadOperatingPoints(*state.project);
  if (!spec) {
    s.spec_error = spec.error().ToString();
    AddMessage(state, Severity::kError, "The operating points are not valid: " + s.spec_error);
    return;
  }
  s.spec = std::move(spec).value();
}

void SweepProjectDatasets(AppState& state) {
  if (!state.project || state.sweep.spec || !state.sweep.spec_error.empty()) return;
  project::OperatingPointsSpec spec;
  spec.datasets = state.project->datasets;
  spec.datasets_from_project = true;
  state.sweep.spec = std::move(spec);
}

bool SweepRunning(const AppState& state) { return state.sweep.job.active(); }

bool StartSweep(AppState& state, std::string* why) {
  auto refuse = [why](std::string reason) {
    if (why) *why = std::move(reason);
    return false;
  };
  SweepState& s = state.sweep;
  if (s.job.active()) return refuse("a sweep is under way");
  if (state.load_job.active()) return refuse("a project is being opened");
  if (!state.project) return refuse("no project is open");
  if (!s.spec_error.empty()) return refuse(s.spec_error);
  if (!s.spec)
    return refuse("the project names no operating points (the key \"operating_points\")");
  if (s.spec->datasets.empty()) return refuse("the sweep has no datasets");
  // The per-point model: the sweep's own (operating_points.model), else the project's.
  model::ModelSpec per_point;
  if (!s.spec->model.empty()) {
    auto loaded = model::LoadModelFile(s.spec->model);
    if (!loaded) return refuse(loaded.error().ToString());
    per_point = std::move(*loaded);
  } else {
    if (!state.model) return refuse("the model is not valid: " + state.model_error);
    per_point = *state.model;
  }
  if (std::string bad = CheckNames(state, *s.spec, per_point); !bad.empty()) return refuse(bad);

  SweepInput input;
  input.spec = std::move(per_point);
  input.points = *s.spec;
  if (input.points.linearised && state.model) input.project_model = *state.model;
  input.quick = s.quick;
  s.status = std::make_shared<SweepStatus>(static_cast<int>(input.points.datasets.size()));
  s.running_datasets.clear();
  for (const data::DatasetSpec& d : input.points.datasets) s.running_datasets.push_back(d.file);
  s.started = std::chrono::steady_clock::now();
  s.started_revision = state.model_revision;
  s.started_generation = state.project_generation;
  s.job.Start([input = std::move(input), status = s.status](JobControl& control) {
    return RunSweep(input, *status, control);
  });
  return true;
}

void CancelSweep(AppState& state) { state.sweep.job.RequestCancel(); }

void PollSweep(AppState& state) {
  if (std::optional<SweepRun> run = state.sweep.job.TakeIfReady())
    InstallSweep(state, std::move(*run));
}

void SelectTrend(AppState& state, const std::string& parameter, const std::string& tag) {
  SweepState& s = state.sweep;
  if (!s.result || (parameter == s.trend.parameter && tag == s.trend.tag)) return;
  s.trend = MakeTrendPlot(*s.result, parameter, tag);
  s.trend_x.RequestFit();
}

}  // namespace gb::ui
