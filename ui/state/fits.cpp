// The Fits list's life in AppState (declared in ui/state/app_state.h): the project's kept fits
// (core/project/kept_fits.h) read when it opens, each finished fit kept and written beside the
// project, shown in the views, deleted, and compared by the likelihood-ratio test.
#include <filesystem>
#include <utility>

#include <fmt/format.h>

#include "core/project/kept_fits.h"
#include "core/project/problem.h"
#include "core/project/result_file.h"
#include "ui/format.h"
#include "ui/state/app_state.h"

namespace gb::ui {
namespace {

namespace fs = std::filesystem;

std::string FitName(const KeptFit& k) { return fmt::format("fit {}", k.number); }

// The fit's own project file (its "project_file", beside its result file), absolute; "" when it
// is not written or names none.
std::string ProjectFileOf(const KeptFit& k) {
  const auto project_file = k.result.find("project_file");
  if (k.file.empty() || project_file == k.result.end() || !project_file->is_string()) return "";
  std::error_code ec;
  return project::ResolvePath(fs::absolute(fs::path(k.file), ec).parent_path().string(),
                              project_file->get<std::string>());
}

// Writes the fit beside the project; a fit that cannot be written stays in the list and says why.
void WriteFit(AppState& state, KeptFit& k) {
  if (!state.estimation.keep_on_disk || !state.project || state.project->path.empty()) return;
  const std::string folder = project::FitsFolder(state.project->path);
  // The project that fits it again: the model and the datasets as they were fitted.
  project::Project p;
  p.name = state.project->name;
  p.datasets = k.datasets;
  p.extra = Json::object();
  if (k.result.value("initial_states", "") == "per_record")
    p.extra[project::kEstimationKey]["initial_states"] = "per_record";
  const auto settings = k.result.find("settings");
  if (settings != k.result.end() && settings->is_object() &&
      settings->value("steady_start", false)) {
    p.extra[project::kEstimationKey]["steady_start"] = true;
    p.extra[project::kEstimationKey]["steady_window"] = settings->value("steady_window", 5.0);
  }
  Result<project::KeptFitFile> written = project::WriteKeptFit(folder, k.result, k.model, p);
  if (!written) {
    AddMessage(state, Severity::kWarning,
               "The fit could not be kept on disk: " + written.error().ToString());
    return;
  }
  k.file = written->path;
  k.number = written->number;
  k.result = std::move(written->result);
  if (!state.deterministic) k.finished = k.result.value("finished", "");
}

}  // namespace

void KeepFit(AppState& state, FitResult fit, const EstimationRun& run) {
  EstimationState& e = state.estimation;
  KeptFit k;
  k.result = fit.summary.ToJson();
  k.result["data_fingerprints"] = run.fingerprints;
  if (!fit.series_parameters.empty()) k.result["initial_states"] = "per_record";
  const EstimationSettings& s = fit.settings;
  k.result["settings"] = {{"algorithm", Info(s.algorithm).name},
                          {"multistart", s.multistart},
                          {"profile_intervals", s.profile_intervals},
                          {"steady_start", s.steady_start},
                          {"steady_window", s.steady_window}};
  k.model = model::ToJson(run.spec);
  k.datasets = run.dataset_specs;
  k.number = e.next_number;
  k.fit = std::move(fit);
  WriteFit(state, k);
  e.next_number = std::max(e.next_number, k.number) + 1;
  e.fits.push_back(std::move(k));
  e.shown = e.selected = static_cast<int>(e.fits.size()) - 1;
  e.result = e.fits.back().fit;
}

void ReadFits(const std::string& path, bool deterministic, ProjectLoad* out) {
  std::vector<Error> problems;
  std::vector<project::KeptFitFile> files =
      project::ReadKeptFits(project::FitsFolder(path), &problems);
  for (project::KeptFitFile& f : files) {
    Result<estimate::EstimateSummary> summary =
        estimate::EstimateSummary::FromJson(f.result, f.path);
    if (!summary) {
      problems.push_back(summary.error());
      continue;
    }
    KeptFit k;
    k.file = f.path;
    k.number = f.number;
    k.finished = deterministic ? "" : f.result.value("finished", "");
    k.fit =
        MakeFitResult(std::move(summary).value(), Trace{}, EstimationSettings{}, -1, deterministic);
    if (f.result.value("initial_states", "") == "per_record") {
      Result<model::ModelSpec> spec = model::ParseModel(f.model, f.path);
      const auto datasets = f.result.find("datasets");
      const int records = datasets != f.result.end() && datasets->is_array()
                              ? static_cast<int>(datasets->size())
                              : 0;
      if (spec) {
        auto copies = project::PerRecordInitialStates(std::move(spec).value(), records);
        if (copies) k.fit.series_parameters = std::move(copies->index);
      }
    }
    k.result = std::move(f.result);
    k.model = std::move(f.model);
    out->fits.push_back(std::move(k));
  }
  for (const Error& p : problems) out->fit_problems.push_back(p.ToString());
}

// The newest fit of the project's model is shown.
void InstallFits(AppState& state, std::vector<KeptFit> fits,
                 const std::vector<std::string>& problems) {
  EstimationState& e = state.estimation;
  e.fits = std::move(fits);
  e.shown = -1;
  e.compare_a = e.compare_b = e.selected = -1;
  e.next_number = 1;
  for (KeptFit& k : e.fits) {
    e.next_number = std::max(e.next_number, k.number + 1);
    if (state.model && FitMatchesModel(k.fit, *state.model))
      k.fit.model_revision = state.model_revision;
  }
  for (int i = static_cast<int>(e.fits.size()) - 1; i >= 0 && e.shown < 0; --i)
    if (e.fits[static_cast<std::size_t>(i)].fit.model_revision == state.model_revision) e.shown = i;
  if (e.shown >= 0) {
    e.result = e.fits[static_cast<std::size_t>(e.shown)].fit;
    e.profile_x.assign(e.result->profiles.size(), plot::LinkedRange{});
  }
  for (const std::string& p : problems)
    AddMessage(state, Severity::kWarning, "A kept fit could not be read: " + p);
}

bool ShowFit(AppState& state, std::size_t index, std::string* why) {
  auto refuse = [why](std::string reason) {
    if (why) *why = std::move(reason);
    return false;
  };
  EstimationState& e = state.estimation;
  if (index >= e.fits.size()) return refuse("there is no such fit");
  if (e.job.active()) return refuse("an estimation is under way");
  KeptFit& k = e.fits[index];
  if (!state.model || !FitMatchesModel(k.fit, *state.model)) {
    if (state.diagram_view.model_from_diagram)
      return refuse(FitName(k) +
                    " was fitted with another model, and this project's model is "
                    "drawn as a block diagram: open the fit's model file (" +
                    (k.file.empty() ? std::string("not written") : k.file) + ") instead");
    Result<model::ModelSpec> spec =
        model::ParseModel(k.model, k.file.empty() ? FitName(k) : k.file);
    if (!spec) return refuse(FitName(k) + "'s model is not valid: " + spec.error().ToString());
    state.model = std::move(spec).value();
    state.model_error.clear();
    if (state.project) state.project->model_json = k.model;
    ++state.model_revision;
    state.parameters_view = ParametersViewState{};
    state.equations_view.drafts.clear();
    ResolveMessages(state, MessageTopic::kModel);
    AddMessage(state, Severity::kInfo,
               fmt::format("The model is now {}'s ({}); save the project to keep it.", FitName(k),
                           state.model->name));
  }
  k.fit.model_revision = state.model_revision;
  e.result = k.fit;
  e.shown = static_cast<int>(index);
  e.profile_x.assign(e.result->profiles.size(), plot::LinkedRange{});
  e.trace_x.RequestFit();
  state.analysis.RequestFit();
  return true;
}

bool DeleteFit(AppState& state, std::size_t index, std::string* why) {
  EstimationState& e = state.estimation;
  if (index >= e.fits.size()) {
    if (why) *why = "there is no such fit";
    return false;
  }
  const KeptFit& k = e.fits[index];
  if (!k.file.empty()) {
    if (Status st = project::DeleteKeptFit(k.file); !st) {
      if (why) *why = st.error().ToString();
      return false;
    }
  }
  AddMessage(state, Severity::kInfo,
             "Deleted " + FitName(k) + (k.file.empty() ? "" : " (" + k.file + ")") + ".");
  const int i = static_cast<int>(index);
  e.fits.erase(e.fits.begin() + i);
  auto follow = [i](int& at) { at = at == i ? -1 : at > i ? at - 1 : at; };
  follow(e.compare_a);
  follow(e.compare_b);
  follow(e.selected);
  if (e.shown == i) e.result.reset();
  follow(e.shown);
  return true;
}

Result<estimate::LikelihoodRatioTest> CompareFits(const AppState& state, std::size_t a,
                                                  std::size_t b, std::string* notes) {
  const std::vector<KeptFit>& fits = state.estimation.fits;
  if (a >= fits.size() || b >= fits.size() || a == b) return InputError("choose two fits");
  Result<project::NestedFit> fa = project::ReadNestedFit(fits[a].result, FitName(fits[a]));
  if (!fa) return fa.error();
  Result<project::NestedFit> fb = project::ReadNestedFit(fits[b].result, FitName(fits[b]));
  if (!fb) return fb.error();
  if (fa->n_free == fb->n_free)
    return InputError(
        fmt::format("{} and {} have the same number of free parameters ({}): a "
                    "likelihood-ratio test needs nested models",
                    fa->path, fb->path, fa->n_free));
  const project::NestedFit& r = fa->n_free < fb->n_free ? *fa : *fb;
  const project::NestedFit& f = fa->n_free < fb->n_free ? *fb : *fa;
  bool by_name_only = false;
  if (std::string why = project::WhyNotNested(r, f, &by_name_only); !why.empty())
    return InputError("no likelihood-ratio test: " + why);
  if (notes) {
    notes->clear();
    if (by_name_only) *notes += "The data were matched by file name only. ";
    if (f.loglik < r.loglik)
      *notes +=
          "The full model's log L is below the restricted one's: its fit did not reach the "
          "optimum, or the models are not nested.";
  }
  return estimate::CompareNested(r.loglik, r.n_free, f.loglik, f.n_free);
}

namespace {

// `text` as one word of a POSIX shell.
std::string ShellWord(const std::string& text) {
  std::string out = "'";
  for (char c : text) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

}  // namespace

std::string FitCommand(const AppState& state, std::size_t index, std::string* why) {
  const std::vector<KeptFit>& fits = state.estimation.fits;
  if (index >= fits.size()) {
    if (why) *why = "there is no such fit";
    return "";
  }
  const KeptFit& k = fits[index];
  if (k.file.empty()) {
    if (why) *why = "the fit is not written yet: save the project first";
    return "";
  }
  const std::string project_file = ProjectFileOf(k);
  if (project_file.empty()) {
    if (why)
      *why = k.file +
             " names no project file (written by greybench-cli estimate MODEL DATA): "
             "that command fits it again";
    return "";
  }
  std::error_code ec;
  const fs::path folder = fs::absolute(fs::path(k.file), ec).parent_path();
  std::string cmd = "greybench-cli estimate " + ShellWord(project_file);
  const auto settings = k.result.find("settings");
  if (settings != k.result.end() && settings->is_object()) {
    cmd += " --algorithm " + settings->value("algorithm", std::string("auto"));
    if (const int m = settings->value("multistart", 0); m > 0)
      cmd += fmt::format(" --multistart {}", m);
    if (settings->value("profile_intervals", false)) cmd += " --profile-intervals";
    if (settings->value("steady_start", false))
      cmd +=
          fmt::format(" --steady-start --steady-window {}", settings->value("steady_window", 5.0));
  }
  const std::string again = fs::path(k.file).stem().string() + ".again.json";
  return cmd + " --out " + ShellWord((folder / again).string());
}

void WriteUnwrittenFits(AppState& state) {
  if (!state.project || state.project->path.empty()) return;
  std::error_code ec;
  const fs::path folder = fs::absolute(project::FitsFolder(state.project->path), ec);
  for (KeptFit& k : state.estimation.fits) {
    // Not written yet, or written beside the project's old file (Save as).
    if (!k.file.empty() && fs::absolute(fs::path(k.file).parent_path(), ec) == folder) continue;
    // A fit read back: its datasets as they were fitted, from its own project.
    if (k.datasets.empty())
      if (const std::string own = ProjectFileOf(k); !own.empty())
        if (Result<project::Project> p = project::LoadProject(own)) k.datasets = p->datasets;
    k.file.clear();
    WriteFit(state, k);
  }
}

}  // namespace gb::ui
