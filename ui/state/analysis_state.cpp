// The analysis job's life in AppState (declared in ui/state/app_state.h): which request the
// workbench wants now, starting and superseding runs, installing their results.
#include <algorithm>
#include <utility>

#include "core/filter/likelihood.h"
#include "ui/format.h"
#include "ui/state/app_state.h"

namespace gb::ui {
namespace {

// The two requests differ at most in θ (a slider moved).
bool SameButValues(AnalysisRequest a, const AnalysisRequest& b) {
  a.theta = b.theta;
  a.record_theta = b.record_theta;
  a.preview_theta = b.preview_theta;
  a.moved = b.moved;
  return a == b;
}

void StartAnalysis(AppState& state, AnalysisRequest request) {
  AnalysisInput input;
  input.request = request;
  input.spec = *state.model;
  for (const LoadedDataset& d : state.datasets) {
    input.datasets.push_back(d.data);
    input.names.push_back(DatasetLabel(d.spec));
    input.read_errors.push_back(d.error);
    input.validation.push_back(d.spec.role == data::Role::kValidation);
  }
  AnalysisState& a = state.analysis;
  a.running = request;
  a.attempted = std::move(request);
  a.cancel_requested = false;
  a.job.Start(
      [input = std::move(input)](JobControl& control) { return RunAnalysis(input, control); });
}

void InstallAnalysis(AppState& state, AnalysisRun run) {
  AnalysisState& a = state.analysis;
  const std::optional<AnalysisRequest> request = std::move(a.running);
  a.running.reset();
  const bool by_user = a.cancel_requested;
  a.cancel_requested = false;
  if (!request || request->project_generation != state.project_generation ||
      request->datasets_revision != state.datasets_revision)
    return;
  if (run.analysis) {
    // Same project and datasets: the time axes and lags are those of before, so a zoom is kept;
    // the residuals' distribution moves with θ.
    const bool same_data =
        a.result &&
        a.result->request.project_generation == run.analysis->request.project_generation &&
        a.result->request.datasets_revision == run.analysis->request.datasets_revision;
    a.result = std::move(run.analysis);
    a.last_failure.clear();
    ResolveMessages(state, MessageTopic::kPredictions);
    if (same_data) {
      a.histogram_x.RequestFit();
      a.qq_x.RequestFit();
    } else {
      a.RequestFit();
      OpenTimeWindow(a);
    }
    return;
  }
  if (run.cancelled) {
    if (!by_user) return;  // superseded: the newer request starts right away
    a.last_failure = "The computation of the predictions was cancelled";
    a.last_failure_severity = Severity::kWarning;
    AddMessage(state, Severity::kWarning,
               a.last_failure + (a.result ? "; the previous results are kept" : ""));
    return;
  }
  a.last_failure = "The predictions could not be computed: " + run.error;
  a.last_failure_severity = Severity::kError;
  AddMessage(state, Severity::kError,
             a.last_failure + (a.result ? " (the previous results are kept)" : ""),
             MessageTopic::kPredictions);
}

}  // namespace

void OpenTimeWindow(AnalysisState& a) {
  const Analysis* r = a.result ? &*a.result : nullptr;
  const auto k = static_cast<std::size_t>(a.dataset);
  if (!r || k >= r->datasets.size() ||
      r->datasets[k].time.size() <= static_cast<std::size_t>(kInitialTimeWindow)) {
    a.time_x.RequestFit();
    return;
  }
  const std::vector<double>& t = r->datasets[k].time;
  a.time_x.fit_request_frame = plot::LinkedRange::kNoFit;
  a.time_x.range = {t.front(), t[static_cast<std::size_t>(kInitialTimeWindow) - 1]};
}

std::optional<AnalysisRequest> AnalysisRequestNow(const AppState& state, std::string* why) {
  auto refuse = [why](std::string reason) -> std::optional<AnalysisRequest> {
    if (why) *why = std::move(reason);
    return std::nullopt;
  };
  if (!state.project) return refuse("no project is open");
  if (!state.model) return refuse("the model is not valid: " + state.model_error);
  if (state.datasets.empty()) return refuse("the project lists no datasets");
  const AnalysisState& a = state.analysis;
  const model::ModelSpec& m = *state.model;
  AnalysisRequest r;
  r.project_generation = state.project_generation;
  r.datasets_revision = state.datasets_revision;
  r.model_revision = state.model_revision;
  // The h-step predictions and the filter's steps only while they are shown (for an EKF the
  // h-step predictions cost h integrations a row).
  r.horizon = a.show_ahead ? std::clamp(a.horizon, 1, kMaxHorizon) : 0;
  r.steps = a.show_step;
  r.preview_theta = m.Values();
  const FitResult* fit = state.estimation.result ? &*state.estimation.result : nullptr;
  if (fit && !a.use_current_values && FitMatchesModel(*fit, m)) {
    r.source = AnalysisSource::kFit;
    // The model's parameters come first; a fit per record's copies after them.
    const auto model_part = [&m](std::vector<double> theta) {
      theta.resize(m.parameters.size());
      return theta;
    };
    r.theta = model_part(fit->summary.theta);
    for (const std::vector<int>& row : fit->series_parameters)
      r.record_theta.push_back(model_part(filter::SeriesTheta(fit->summary.theta, row)));
    for (const estimate::DelayEstimate& d : fit->summary.delays) r.delay.push_back(d.estimate);
  } else {
    r.source = AnalysisSource::kCurrentValues;
    r.theta = m.Values();
  }
  // The sliders' what-if values, in every record's θ and in the preview.
  ApplySliders(state, &r.theta);
  for (std::vector<double>& theta : r.record_theta) ApplySliders(state, &theta);
  ApplySliders(state, &r.preview_theta);
  for (const auto& [name, value] : state.sliders.moved) {
    for (const model::Parameter& p : m.parameters)
      if (p.name == name) r.moved.push_back(name);
  }
  return r;
}

void PollAnalysis(AppState& state) {
  AnalysisState& a = state.analysis;
  if (std::optional<AnalysisRun> run = a.job.TakeIfReady()) InstallAnalysis(state, std::move(*run));
  std::optional<AnalysisRequest> want = AnalysisRequestNow(state);
  if (!a.enabled) want.reset();
  if (a.job.active()) {
    // While a slider is dragged, the run under way for other values of θ finishes first: one
    // cancelled on every frame would show nothing until the release.
    const bool only_values =
        want && a.running && state.sliders.dragging && SameButValues(*want, *a.running);
    if (!want || !a.running || (*want != *a.running && !only_values)) a.job.RequestCancel();
    return;
  }
  if (!want || (a.attempted && *a.attempted == *want)) return;
  StartAnalysis(state, *want);
}

void CancelAnalysis(AppState& state) {
  AnalysisState& a = state.analysis;
  if (!a.job.active()) return;
  a.cancel_requested = true;
  a.job.RequestCancel();
}

void RecomputeAnalysis(AppState& state) { state.analysis.attempted.reset(); }

bool AnalysisRunning(const AppState& state) { return state.analysis.job.active(); }

}  // namespace gb::ui
