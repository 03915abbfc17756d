#include "ui/state/app_state.h"

#include <cstdio>
#include <ctime>
#include <exception>
#include <filesystem>
#include <utility>

#include <fmt/format.h>

#include "core/util/json.h"
#include "ui/format.h"

namespace gb::ui {
namespace {

struct ViewInfo {
  View view;
  std::string_view name;
  std::string_view title;
};
constexpr std::array<ViewInfo, 10> kViewInfo = {{
    {View::kData, "data", "Data"},
    {View::kDiagram, "diagram", "Diagram"},
    {View::kEquations, "equations", "Equations"},
    {View::kEstimate, "estimate", "Estimate"},
    {View::kPredictions, "predictions", "Predictions"},
    {View::kResiduals, "residuals", "Residuals"},
    {View::kParameters, "parameters", "Parameters"},
    {View::kOperatingPoints, "operating-points", "Operating points"},
    {View::kLive, "live", "Live"},
    {View::kDesign, "design", "Experiment design"},
}};

const ViewInfo& Info(View view) {
  for (const ViewInfo& info : kViewInfo) {
    if (info.view == view) return info;
  }
  return kViewInfo[0];
}

// Runs on the loading job's thread: reads the project file, then each dataset.
ProjectLoad LoadProjectAndData(const std::string& path, bool deterministic, JobControl& control) {
  ProjectLoad out;
  out.path = path;
  try {
    Result<project::Project> project = project::LoadProject(path);
    if (!project.ok()) {
      out.error = project.error().ToString();
      return out;
    }
    const std::vector<data::DatasetSpec>& specs = project->datasets;
    for (std::size_t i = 0; i < specs.size() && !control.cancel; ++i) {
      control.progress = static_cast<float>(i) / static_cast<float>(specs.size());
      LoadedDataset d;
      d.path = specs[i].file;
      d.spec = specs[i];
      Result<std::shared_ptr<const data::Dataset>> read = data::ReadDataset(specs[i]);
      if (read.ok()) {
        d.data = std::move(read).value();
        d.summary = Summarize(*d.data);
      } else {
        d.error = read.error().ToString();
      }
      out.datasets.push_back(std::move(d));
    }
    const project::Project& p = *project;
    Result<model::ModelSpec> spec =
        model::ParseModel(p.model_json, p.model_path.empty() ? p.path : p.model_path);
    if (spec.ok()) {
      out.model = std::move(spec).value();
    } else {
      out.model_error = spec.error().ToString();
    }
    ReadFits(path, deterministic, &out);
    out.project = std::move(project).value();
  } catch (const std::exception& e) {  // e.g. out of memory on a huge file
    out.project.reset();
    out.error = path + ": " + e.what();
  }
  control.progress = 1.0f;
  return out;
}

std::string FileName(const std::string& path) {
  return std::filesystem::path(path).filename().string();
}

}  // namespace

std::string ElapsedClause(const AppState& state, const char* prefix, double seconds) {
  if (state.deterministic) return "";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.1f s", seconds);
  return prefix + std::string(buf);
}

namespace {

void InstallProject(AppState& state, ProjectLoad load) {
  state.project = std::move(load.project);
  state.datasets = std::move(load.datasets);
  state.open_error.clear();
  state.data_view.x_ranges.assign(state.datasets.size(), plot::LinkedRange{});
  state.model = std::move(load.model);
  state.model_error = std::move(load.model_error);
  ++state.model_revision;
  ++state.project_generation;
  // The fit belonged to the previous project; a run still under way is stopped and ignored.
  if (state.estimation.job.active()) state.estimation.job.RequestCancel();
  state.estimation.result.reset();
  state.estimation.last_failure.clear();
  state.estimation.live_trace.Clear();
  state.estimation.trace_x.RequestFit();
  state.parameters_view = ParametersViewState{};
  InstallFits(state, std::move(load.fits), load.fit_problems);
  // The project's own estimation options (LoadProject checked them); the others are the view's.
  if (state.project) {
    const project::EstimationDefaults d = project::ReadEstimationDefaults(*state.project);
    state.estimation.settings.steady_start = d.steady_start.value_or(false);
    state.estimation.settings.steady_window = d.steady_window.value_or(5.0);
    state.estimation.settings.per_record_initial_states =
        d.per_record_initial_states.value_or(false);
  }
  ResetSweep(state);
  InstallDiagram(state);  // a project's diagram that compiles supplies the model
  InstallSliders(state);
  // So was the analysis; PollAnalysis starts the new project's (a run under way is superseded).
  state.analysis.result.reset();
  state.analysis.last_failure.clear();
  state.analysis.dataset = state.analysis.output = state.analysis.input = 0;
  ResetLive(state);  // the live run watched the previous project's model
  if (!state.model)
    AddMessage(state, Severity::kError, "The model is not valid: " + state.model_error,
               MessageTopic::kModel);
}

bool SameParameters(const model::ModelSpec& a, const model::ModelSpec& b) {
  if (a.parameters.size() != b.parameters.size()) return false;
  for (std::size_t i = 0; i < a.parameters.size(); ++i) {
    const model::Parameter& p = a.parameters[i];
    const model::Parameter& q = b.parameters[i];
    if (p.value != q.value || p.lower != q.lower || p.upper != q.upper || p.fixed != q.fixed)
      return false;
  }
  return true;
}

void InstallEstimation(AppState& state, EstimationRun run) {
  EstimationState& e = state.estimation;
  e.progress->AppendTrace(&e.live_trace);
  e.progress.reset();
  e.trace_x.RequestFit();  // to the new result's trace, or back to the kept one
  if (e.started_generation != state.project_generation) {
    e.live_trace.Clear();
    return;  // a run on a project that is no longer open
  }
  if (!run.summary) {
    e.last_failure = "The estimation failed: " + run.error;
    e.last_failure_severity = Severity::kError;
    AddMessage(state, Severity::kError,
               e.last_failure + (e.result ? " (the previous results are kept)" : ""),
               MessageTopic::kEstimation);
    e.live_trace.Clear();
    return;
  }
  if (run.summary->cancelled && run.summary->parameters.empty()) {
    e.last_failure =
        "The estimation was cancelled" + ElapsedClause(state, " after ", run.summary->elapsed_s);
    e.last_failure_severity = Severity::kWarning;
    AddMessage(state, Severity::kWarning,
               e.last_failure + (e.result ? "; the previous results are kept" : ""));
    e.live_trace.Clear();
    return;
  }
  const estimate::EstimateSummary& s = *run.summary;
  std::string text = std::string(s.cancelled   ? "Estimation stopped; the best point so far is kept"
                                 : s.converged ? "Estimation converged"
                                               : "Estimation did NOT converge") +
                     ": log L = " + FormatSig(s.loglik, 6) + ", " + std::to_string(s.iterations) +
                     " iterations" + ElapsedClause(state, ", ", s.elapsed_s);
  if (!s.warnings.empty()) {
    text += " (" + std::to_string(s.warnings.size()) +
            (s.warnings.size() == 1 ? " warning)" : " warnings)");
  }
  AddMessage(state, s.converged && s.warnings.empty() ? Severity::kInfo : Severity::kWarning, text);
  e.last_failure.clear();
  ResolveMessages(state, MessageTopic::kEstimation);
  Trace trace = std::move(e.live_trace);
  e.live_trace = Trace{};
  FitResult fit = MakeFitResult(std::move(*run.summary), std::move(trace), e.settings,
                                e.started_revision, state.deterministic);
  fit.series_parameters = std::move(run.series_parameters);
  KeepFit(state, std::move(fit), run);
  e.profile_x.assign(e.result->profiles.size(), plot::LinkedRange{});
}

}  // namespace

std::string_view ViewName(View view) { return Info(view).name; }
std::string_view ViewTitle(View view) { return Info(view).title; }

std::optional<View> ParseView(std::string_view name) {
  for (const ViewInfo& info : kViewInfo) {
    if (info.name == name) return info.view;
  }
  return std::nullopt;
}

void AddMessage(AppState& state, Severity severity, std::string text, MessageTopic topic) {
  Message m;
  m.severity = severity;
  m.text = std::move(text);
  m.topic = topic;
  if (!state.deterministic) {
    const std::time_t now = std::time(nullptr);
    std::tm local{};
    localtime_r(&now, &local);
    char buf[16];
    std::strftime(buf, sizeof buf, "%H:%M:%S", &local);
    m.time = buf;
  }
  state.messages.push_back(std::move(m));
}

void ResolveMessages(AppState& state, MessageTopic topic) {
  for (Message& m : state.messages)
    if (m.topic == topic && m.severity != Severity::kInfo) m.resolved = true;
}

const Message* StatusMessage(const AppState& state) {
  if (state.load_job.active() || EstimationRunning(state) || SweepRunning(state)) return nullptr;
  if (state.messages.empty() || state.messages.back().resolved) return nullptr;
  return &state.messages.back();
}

std::string StatusText(const AppState& state) {
  if (state.load_job.active()) return "Opening " + state.loading_path + "\xE2\x80\xA6";
  if (EstimationRunning(state)) {
    const EstimationProgress::Latest p = state.estimation.progress
                                             ? state.estimation.progress->latest()
                                             : EstimationProgress::Latest{};
    std::string text = "Estimating \xE2\x80\x94 " + std::string(StageText(p.stage));
    if (p.any) text += ", iteration " + std::to_string(p.iteration);
    return text + "\xE2\x80\xA6";
  }
  if (SweepRunning(state)) return "Sweeping the operating points\xE2\x80\xA6";
  if (const Message* m = StatusMessage(state)) return m->text;
  return "Ready";
}

void OpenProject(AppState& state, std::string path) {
  if (state.load_job.active()) return;
  state.loading_path = path;
  state.load_job.Start(
      [path = std::move(path), deterministic = state.deterministic](JobControl& control) {
        return LoadProjectAndData(path, deterministic, control);
      });
}

void PollJobs(AppState& state) {
  EstimationState& e = state.estimation;
  if (e.progress) {
    const int known = e.live_trace.size();
    e.progress->AppendTrace(&e.live_trace);
    if (e.live_trace.size() != known) e.trace_x.RequestFit();
  }
  if (std::optional<EstimationRun> run = e.job.TakeIfReady()) {
    InstallEstimation(state, std::move(*run));
  }
  PollSweep(state);
  PollLive(state);
  PollDesign(state);

  std::optional<ProjectLoad> load = state.load_job.TakeIfReady();
  if (!load) {
    PollAnalysis(state);
    return;
  }
  state.loading_path.clear();
  if (!load->project) {
    state.open_error = load->error;
    AddMessage(state, Severity::kError, "Could not open the project: " + load->error);
    return;
  }
  const std::string path = load->path;
  InstallProject(state, std::move(*load));
  load.reset();
  int failed = 0;
  for (const LoadedDataset& d : state.datasets) {
    if (d.data) continue;
    ++failed;
    AddMessage(state, Severity::kError, "Could not read data: " + d.error);
  }
  const std::string name = state.project->name.empty() ? FileName(path) : state.project->name;
  std::string text = "Opened " + name + " (" + std::to_string(state.datasets.size()) +
                     (state.datasets.size() == 1 ? " dataset" : " datasets");
  if (failed > 0) text += ", " + std::to_string(failed) + " could not be read";
  AddMessage(state, failed > 0 ? Severity::kWarning : Severity::kInfo, text + ")");
  PollAnalysis(state);
}

namespace {

// The jobs that end by themselves (not the live run).
bool FiniteJobActive(const AppState& state) {
  return state.load_job.active() || state.estimation.job.active() || state.sweep.job.active() ||
         state.analysis.job.active() || state.design.job.active() || state.design.fit_job.active();
}

}  // namespace

void WaitForJobs(AppState& state) {
  // Installing one job's result may start another (a fit restarts the analysis).
  do {
    state.load_job.Wait();
    PollJobs(state);
    state.estimation.job.Wait();
    PollJobs(state);
    state.sweep.job.Wait();
    PollJobs(state);
    state.analysis.job.Wait();
    PollJobs(state);
    state.design.job.Wait();
    state.design.fit_job.Wait();
    PollJobs(state);
  } while (FiniteJobActive(state));
}

bool AnyJobActive(const AppState& state) {
  // A paused live run changes nothing on screen until the user acts.
  return FiniteJobActive(state) || state.shell.fmu_job.active() ||
         (state.live.job.active() && !state.live.paused);
}

bool EstimationRunning(const AppState& state) { return state.estimation.job.active(); }

bool StartEstimation(AppState& state, std::string* why) {
  auto refuse = [why](std::string reason) {
    if (why) *why = std::move(reason);
    return false;
  };
  if (state.estimation.job.active()) return refuse("an estimation is under way");
  if (state.load_job.active()) return refuse("a project is being opened");
  if (!state.project) return refuse("no project is open");
  if (!state.model) return refuse("the model is not valid: " + state.model_error);
  if (state.datasets.empty()) return refuse("the project lists no datasets");
  EstimationInput input;
  input.spec = *state.model;
  input.settings = state.estimation.settings;
  for (const LoadedDataset& d : state.datasets) {
    if (d.spec.role != data::Role::kEstimation) continue;  // validation records are not fitted
    if (!d.data) return refuse(FileName(d.path) + " could not be read: " + d.error);
    input.datasets.push_back(d.data);
    input.dataset_specs.push_back(d.spec);
  }
  if (input.datasets.empty())
    return refuse("every dataset is a validation record: give one the role estimation");
  std::string invalid;
  estimate::EstimateOptions check;
  check.multistart = input.settings.multistart;
  check.threads = input.settings.threads;
  if (!check.IsValid(&invalid)) return refuse(invalid);

  EstimationState& e = state.estimation;
  e.progress = std::make_shared<EstimationProgress>();
  e.live_trace.Clear();
  e.trace_x.RequestFit();
  e.started = std::chrono::steady_clock::now();
  e.started_revision = state.model_revision;
  e.started_generation = state.project_generation;
  e.job.Start([input = std::move(input), progress = e.progress](JobControl& control) {
    return RunEstimation(input, *progress, control);
  });
  return true;
}

void CancelEstimation(AppState& state) { state.estimation.job.RequestCancel(); }

namespace {

// Why the datasets cannot be changed now ("" when they can).
std::string DatasetsLocked(const AppState& state, std::size_t index) {
  if (!state.project) return "no project is open";
  if (index >= state.datasets.size()) return "there is no such dataset";
  if (EstimationRunning(state)) return "an estimation is under way";
  if (SweepRunning(state)) return "a sweep is under way";
  return "";
}

void DatasetsChanged(AppState& state) {
  ++state.datasets_revision;
  ++state.layout_revision;  // what Save writes changed
}

}  // namespace

bool SetDatasetRole(AppState& state, std::size_t index, data::Role role, std::string* why) {
  if (std::string locked = DatasetsLocked(state, index); !locked.empty()) {
    if (why) *why = std::move(locked);
    return false;
  }
  LoadedDataset& d = state.datasets[index];
  if (d.spec.role == role) return true;
  d.spec.role = role;
  d.spec.plain = false;  // a role is a key: the entry becomes an object
  // The project's entries and the loaded datasets are kept in one order (opened, added and
  // removed together).
  if (index < state.project->datasets.size()) state.project->datasets[index] = d.spec;
  DatasetsChanged(state);
  AddMessage(state, Severity::kInfo,
             d.spec.DisplayName() +
                 (role == data::Role::kValidation
                      ? " is a validation record: it is not fitted, and is shown at the estimates."
                      : " is fitted again (estimation record)."));
  return true;
}

bool SetDatasetRange(AppState& state, std::size_t index, std::optional<std::array<double, 2>> range,
                     std::string* why) {
  if (std::string locked = DatasetsLocked(state, index); !locked.empty()) {
    if (why) *why = std::move(locked);
    return false;
  }
  LoadedDataset& d = state.datasets[index];
  data::DatasetSpec spec = d.spec;
  spec.range = range;
  spec.plain = false;  // a range is a key
  // A local file read once already: read again here rather than in a job, so that the view
  // never shows a range the data do not have.
  Result<std::shared_ptr<const data::Dataset>> read = data::ReadDataset(spec);
  if (!read) {
    if (why) *why = read.error().ToString();
    return false;
  }
  d.spec = std::move(spec);
  d.data = std::move(read).value();
  d.error.clear();
  d.summary = Summarize(*d.data);
  if (index < state.project->datasets.size()) state.project->datasets[index] = d.spec;
  if (index < state.data_view.x_ranges.size()) state.data_view.x_ranges[index].RequestFit();
  DatasetsChanged(state);
  AddMessage(state, Severity::kInfo,
             range ? fmt::format("{} is used from t = {:g} to {:g} ({} rows).",
                                 d.spec.DisplayName(), (*range)[0], (*range)[1], d.data->rows())
                   : d.spec.DisplayName() + " is used whole.");
  return true;
}

bool RemoveDataset(AppState& state, std::size_t index, std::string* why) {
  if (std::string locked = DatasetsLocked(state, index); !locked.empty()) {
    if (why) *why = std::move(locked);
    return false;
  }
  const std::string name = state.datasets[index].spec.DisplayName();
  const auto at = static_cast<std::ptrdiff_t>(index);
  state.datasets.erase(state.datasets.begin() + at);
  if (index < state.project->datasets.size())
    state.project->datasets.erase(state.project->datasets.begin() + at);
  if (index < state.data_view.x_ranges.size())
    state.data_view.x_ranges.erase(state.data_view.x_ranges.begin() + at);
  AnalysisState& a = state.analysis;
  if (a.dataset >= static_cast<int>(index) && a.dataset > 0) --a.dataset;
  DatasetsChanged(state);
  AddMessage(state, Severity::kInfo,
             "Removed " + name + " from the project (the file itself is untouched).");
  return true;
}

void ApplyParameterEdits(AppState& state) {
  ParametersViewState& v = state.parameters_view;
  std::vector<ParameterEdit> edits = std::move(v.pending);
  v.pending.clear();
  const bool use_estimates = v.use_estimates_requested;
  const std::size_t optimum = v.use_optimum;
  v.use_estimates_requested = false;
  v.use_optimum = 0;
  if (!state.model) return;
  bool changed = false;
  for (const ParameterEdit& edit : edits) {
    Result<model::ModelSpec> edited = ApplyParameterEdit(*state.model, edit);
    if (!edited) {
      ParameterRefusal r;
      r.parameter = edit.parameter;
      r.field = edit.field;
      r.text = edit.text;
      r.reason = edited.error().message;
      v.refusal = std::move(r);
      continue;
    }
    if (v.refusal && v.refusal->parameter == edit.parameter && v.refusal->field == edit.field)
      v.refusal.reset();
    if (SameParameters(*edited, *state.model)) continue;  // e.g. the same number retyped
    state.model = std::move(edited).value();
    changed = true;
  }
  if (use_estimates && state.estimation.result) {
    Result<model::ModelSpec> edited =
        UseEstimatesAsStart(*state.model, state.estimation.result->summary, optimum);
    if (edited) {
      changed = changed || !SameParameters(*edited, *state.model);
      state.model = std::move(edited).value();
      v.refusal.reset();
      AddMessage(
          state, Severity::kInfo,
          optimum == 0
              ? std::string("The estimates are now the start values.")
              : fmt::format("The parameters of optimum {} (log L {:.3f}) are now "
                            "the start values.",
                            optimum + 1, state.estimation.result->summary.optima[optimum].loglik));
    } else {
      AddMessage(state, Severity::kError,
                 "The estimates cannot be used as start values: " + edited.error().message);
    }
  }
  if (!changed) return;
  ++state.model_revision;
  // Keep the project's copy of the model in step, so the other views show the edited values.
  if (state.project && state.project->model_json.is_object())
    state.project->model_json["parameters"] = model::ToJson(*state.model)["parameters"];
  SyncDiagramParameters(state);
}

void ApplyFormulaEdits(AppState& state) {
  EquationsViewState& v = state.equations_view;
  std::vector<FormulaEdit> edits = std::move(v.pending);
  v.pending.clear();
  if (!state.model) return;
  for (const FormulaEdit& edit : edits) {
    Result<model::ModelSpec> edited = ApplyFormulaEdit(*state.model, edit);
    if (!edited) {
      v.drafts[edit.path] = FormulaDraft{edit.text, edited.error()};
      continue;
    }
    v.drafts.erase(edit.path);
    state.model = std::move(edited).value();
    ++state.model_revision;
    // Keep the project's copy of the model in step (the view shows it; a save writes it).
    if (state.project && state.project->model_json.is_object()) {
      const std::size_t dot = edit.path.find('.');
      state.project->model_json[edit.path.substr(0, dot)][edit.path.substr(dot + 1)] =
          FormulaEditValue(edit).value();  // ApplyFormulaEdit accepted it
    }
  }
}

}  // namespace gb::ui
