// Datasets of the user's own in the workbench (issue 34): the import dialog reads a recording
// without header or time as the project's keys do; a dataset with the role "validation" is not
// fitted, is predicted from its own initial state with its fit figures beside the estimation
// record's; and the sidebar changes a dataset's role or removes it (the project file then says
// so when saved).
#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "core/estimate/estimate.h"
#include "core/filter/initial_state.h"
#include "core/model/model.h"
#include "core/project/problem.h"
#include "core/project/project.h"
#include "tests/ui/workbench_driver.h"
#include "ui/shell/import_dialog.h"
#include "ui/shell/shell.h"

namespace gb::ui {
namespace {

using testing::kSource;
using testing::WorkbenchDriver;

class ValidationRecords : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() /
           ("greybench-validation-" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir_);
    std::filesystem::copy_file(kSource + "/tests/data/ui/fuel_film.json", dir_ / "model.json",
                               std::filesystem::copy_options::overwrite_existing);
    std::filesystem::copy_file(kSource + "/tests/data/ui/f1.csv", dir_ / "f1.csv",
                               std::filesystem::copy_options::overwrite_existing);
    // One record cut in two: the first half fitted, the second (which starts where the model's
    // x0 says nothing about) validated on.
    std::ofstream(dir_ / "project.json") << R"({"greybench_project": 1, "name": "halves",
        "model": "model.json",
        "datasets": [{"file": "f1.csv", "range": [0, 4.99]},
                     {"file": "f1.csv", "range": [5, 10], "role": "validation",
                      "name": "second half"}]})";
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }
  std::string Path(const char* name) const { return (dir_ / name).string(); }
  std::filesystem::path dir_;
};

// The sidebar row of dataset `index` (PushID(index) then "##dataset" in the sidebar).
std::optional<ImVec2> FindDatasetRow(WorkbenchDriver& d, int index) {
  ImGuiWindow* sidebar = WorkbenchDriver::FindWindow("##workbench/##sidebar");
  if (!sidebar) return std::nullopt;
  const ImGuiID id = ImHashStr("##dataset", 0, ImHashData(&index, sizeof index, sidebar->ID));
  return d.Find(sidebar, id);
}

// The fit core makes of a project's datasets of role estimation, on one thread (as the
// workbench's tests run it).
Result<estimate::EstimateSummary> DirectFit(const project::Project& p) {
  auto spec = model::ParseModel(p.model_json, p.model_path);
  if (!spec) return spec.error();
  auto problem = project::LoadProblem(*spec, data::WithRole(p.datasets, data::Role::kEstimation));
  if (!problem) return problem.error();
  auto likelihood = project::MakeLikelihood(*problem);
  if (!likelihood) return likelihood.error();
  estimate::EstimateOptions options;
  options.threads = 1;
  return estimate::Estimate(*likelihood, options);
}

void RightClick(WorkbenchDriver& d, ImVec2 p) {
  d.MouseTo(p);
  ImGui::GetIO().MouseDown[1] = true;
  d.Frame();
  ImGui::GetIO().MouseDown[1] = false;
  d.Frame();  // the release opens the menu
  d.Frame();  // which is drawn from this frame on
}

// Clicks the menu item `label` of the open popup.
bool ClickMenuItem(WorkbenchDriver& d, const char* label) {
  ImGuiWindow* popup = nullptr;
  for (ImGuiWindow* w : GImGui->Windows)
    if (w->Active && std::strncmp(w->Name, "##Popup", 7) == 0) popup = w;
  if (!popup) {
    ADD_FAILURE() << "no menu is open";
    return false;
  }
  const std::optional<ImVec2> at = d.Find(popup, popup->GetID(label));
  if (!at) return false;
  d.Click(*at);
  return true;
}

TEST_F(ValidationRecords, AreNotFittedAndArePredictedFromTheirOwnStart) {
  WorkbenchDriver d;
  d.Open(Path("project.json"));
  ASSERT_TRUE(d.state.project) << d.state.open_error;
  ASSERT_EQ(d.state.datasets.size(), 2u);
  EXPECT_EQ(d.state.datasets[1].spec.role, data::Role::kValidation);
  WaitForJobs(d.state);
  // Before a fit, the scanned delay is the one the estimation record's profile prefers.
  {
    ASSERT_TRUE(d.state.analysis.result) << d.state.analysis.last_failure;
    project::Project p = *project::LoadProject(Path("project.json"));
    auto spec = model::ParseModel(p.model_json, p.model_path);
    ASSERT_TRUE(spec.ok() && spec->HasDelayScan());
    auto problem = project::LoadProblem(*spec, data::WithRole(p.datasets, data::Role::kEstimation));
    ASSERT_TRUE(problem.ok());
    auto likelihood = project::MakeLikelihood(*problem);
    ASSERT_TRUE(likelihood.ok());
    auto profile = likelihood->Profile(spec->Values());
    ASSERT_TRUE(profile.ok() && profile->best >= 0);
    EXPECT_EQ(d.state.analysis.result->delay,
              profile->candidates[static_cast<std::size_t>(profile->best)].delay);
    EXPECT_EQ(d.state.analysis.result->delay_source, "profile likelihood at these values");
  }
  d.state.estimation.settings.threads = 1;
  std::string why;
  ASSERT_TRUE(StartEstimation(d.state, &why)) << why;
  WaitForJobs(d.state);
  ASSERT_TRUE(d.state.estimation.result) << d.state.estimation.last_failure;

  // The fit is the first half's alone, as core fits it.
  auto direct = DirectFit(*project::LoadProject(Path("project.json")));
  ASSERT_TRUE(direct.ok()) << direct.error().ToString();
  EXPECT_EQ(d.state.estimation.result->summary.n_obs, direct->n_obs);
  EXPECT_NEAR(d.state.estimation.result->summary.loglik, direct->loglik,
              1e-9 * std::abs(direct->loglik));

  // Both records are predicted; the validation record from its own first samples.
  ASSERT_TRUE(d.state.analysis.result) << d.state.analysis.last_failure;
  const Analysis& a = *d.state.analysis.result;
  ASSERT_EQ(a.datasets.size(), 2u);
  EXPECT_FALSE(a.datasets[0].validation);
  const DatasetAnalysis& v = a.datasets[1];
  EXPECT_TRUE(v.validation);
  EXPECT_TRUE(v.initial_error.empty()) << v.initial_error;
  EXPECT_EQ(v.initial_samples, filter::InitialStateSamples(static_cast<int>(v.time.size())));
  const OutputAnalysis& fitted = a.datasets[0].outputs[0];
  const OutputAnalysis& validated = v.outputs[0];
  ASSERT_TRUE(std::isfinite(fitted.fit_percent) && std::isfinite(validated.fit_percent));
  // One process, two halves: the model validates about as well as it fits.
  EXPECT_GT(validated.fit_percent, fitted.fit_percent - 15) << validated.fit_percent;
  // Its figures leave out the rows its start was taken from.
  int judged = 0;
  for (std::size_t k = static_cast<std::size_t>(v.initial_samples);
       k < validated.standardized.size(); ++k)
    judged += std::isfinite(validated.standardized[k]) ? 1 : 0;
  EXPECT_EQ(validated.n_simulated, judged);
  // Its first residual is an ordinary one (from the model's x0 it would be far out).
  const auto first = static_cast<std::size_t>(
      std::find_if(validated.standardized.begin(), validated.standardized.end(),
                   [](double z) { return std::isfinite(z); }) -
      validated.standardized.begin());
  ASSERT_LT(first, validated.standardized.size());
  EXPECT_LT(std::abs(validated.standardized[first]), 4) << "row " << first;

  d.state.view = View::kPredictions;
  d.state.analysis.dataset = 1;
  d.Frame();
  const std::string log = d.Text();
  EXPECT_NE(log.find("Validation record: not fitted"), std::string::npos) << log;
  EXPECT_NE(log.find("second half (validation)"), std::string::npos) << log;
  EXPECT_NE(log.find("Fit figures"), std::string::npos) << log;
  EXPECT_EQ(log.find("nan"), std::string::npos) << log;

  // Compare: every record at once, each titled with its role and fit %.
  d.state.analysis.show_compare = true;
  d.Frame();
  const std::string compare = d.Text();
  const auto titled = [&](const std::string& name, double fit) {
    char figure[32];
    std::snprintf(figure, sizeof figure, "fit %.1f %%", fit);
    return compare.find(name + "    ilambda    " + figure) != std::string::npos;
  };
  EXPECT_TRUE(titled(a.datasets[0].name + " (estimation)", fitted.fit_percent)) << compare;
  EXPECT_TRUE(titled("second half (validation)", validated.fit_percent)) << compare;
  EXPECT_EQ(compare.find("Showing t ="), std::string::npos) << compare;
}

TEST_F(ValidationRecords, TheSidebarChangesARoleAndRemovesADatasetAndSaveKeepsIt) {
  WorkbenchDriver d;
  d.Open(Path("project.json"));
  ASSERT_TRUE(d.state.project) << d.state.open_error;
  WaitForJobs(d.state);
  const int revision = d.state.datasets_revision;

  // Right-click the second record: it becomes an estimation record.
  const std::optional<ImVec2> row = FindDatasetRow(d, 1);
  ASSERT_TRUE(row);
  RightClick(d, *row);
  ASSERT_TRUE(ClickMenuItem(d, "Fit it (estimation record)"));
  EXPECT_EQ(d.state.datasets[1].spec.role, data::Role::kEstimation);
  EXPECT_EQ(d.state.project->datasets[1].role, data::Role::kEstimation);
  EXPECT_GT(d.state.datasets_revision, revision);
  EXPECT_TRUE(HasUnsavedChanges(d.state));
  // The predictions are computed again for the new roles.
  WaitForJobs(d.state);
  ASSERT_TRUE(d.state.analysis.result);
  EXPECT_EQ(d.state.analysis.result->request.datasets_revision, d.state.datasets_revision);
  EXPECT_FALSE(d.state.analysis.result->datasets[1].validation);

  // And back, then the first record removed.
  RightClick(d, *FindDatasetRow(d, 1));
  ASSERT_TRUE(ClickMenuItem(d, "Validate on it (not fitted)"));
  EXPECT_EQ(d.state.datasets[1].spec.role, data::Role::kValidation);
  RightClick(d, *FindDatasetRow(d, 0));
  ASSERT_TRUE(ClickMenuItem(d, "Remove from the project"));
  ASSERT_EQ(d.state.datasets.size(), 1u);
  ASSERT_EQ(d.state.project->datasets.size(), 1u);
  EXPECT_EQ(d.state.datasets[0].spec.DisplayName(), "second half");
  WaitForJobs(d.state);
  ASSERT_TRUE(d.state.analysis.result);
  EXPECT_EQ(d.state.analysis.result->datasets.size(), 1u);
  // Nothing is left to fit: the estimation says why.
  std::string why;
  EXPECT_FALSE(StartEstimation(d.state, &why));
  EXPECT_NE(why.find("every dataset is a validation record"), std::string::npos) << why;

  // Saved, the project keeps the keys and the role; the data file is untouched.
  const std::string saved = Path("saved.json");
  ASSERT_TRUE(project::SaveProject(*d.state.project, saved).ok());
  project::Project back = *project::LoadProject(saved);
  ASSERT_EQ(back.datasets.size(), 1u);
  EXPECT_EQ(back.datasets[0].role, data::Role::kValidation);
  EXPECT_EQ(back.datasets[0].name, "second half");
  ASSERT_TRUE(back.datasets[0].range);
  EXPECT_EQ((*back.datasets[0].range)[0], 5);
}

// The time span the Data view shows becomes the dataset's estimation range (its "range" key),
// and "Whole record" takes it back; Save keeps it.
TEST_F(ValidationRecords, TheDataViewsShownSpanBecomesTheEstimationRange) {
  WorkbenchDriver d;
  d.Open(Path("project.json"));
  ASSERT_TRUE(d.state.project) << d.state.open_error;
  WaitForJobs(d.state);
  d.state.view = View::kData;
  d.Frame();
  ASSERT_EQ(d.state.data_view.x_ranges.size(), 2u);
  plot::LinkedRange& x = d.state.data_view.x_ranges[0];
  x.range = {1.0, 3.0};
  x.fit_request_frame = plot::LinkedRange::kNoFit;
  d.Frame();
  EXPECT_NE(d.Text().find("Use t = 1 \xE2\x80\xA6 3 only"), std::string::npos) << d.Text();
  const std::size_t rows = d.state.datasets[0].data->rows();
  std::string why;
  ASSERT_TRUE(SetDatasetRange(d.state, 0, std::array<double, 2>{1.0, 3.0}, &why)) << why;
  const data::Dataset& ranged = *d.state.datasets[0].data;
  EXPECT_LT(ranged.rows(), rows);
  EXPECT_GE(ranged.time.front(), 1.0);
  EXPECT_LE(ranged.time.back(), 3.0);
  ASSERT_TRUE(d.state.project->datasets[0].range);
  EXPECT_TRUE(HasUnsavedChanges(d.state));
  d.Frame();
  EXPECT_NE(d.Text().find("Whole record"), std::string::npos);
  // The predictions follow the range.
  WaitForJobs(d.state);
  ASSERT_TRUE(d.state.analysis.result);
  EXPECT_EQ(d.state.analysis.result->datasets[0].time.size(), ranged.rows());
  const std::string saved = Path("ranged.json");
  ASSERT_TRUE(project::SaveProject(*d.state.project, saved).ok());
  ASSERT_TRUE(project::LoadProject(saved)->datasets[0].range);
  EXPECT_EQ((*project::LoadProject(saved)->datasets[0].range)[1], 3.0);
  // And back: the whole file (the project's first range, [0, 4.99], was replaced).
  ASSERT_TRUE(SetDatasetRange(d.state, 0, std::nullopt, &why)) << why;
  EXPECT_FALSE(d.state.project->datasets[0].range);
  EXPECT_GT(d.state.datasets[0].data->rows(), rows);
}

// The recording of tests/data/ui/import: 13 fields, no header, no time, 10 Hz.
const std::string kImportDir = kSource + "/tests/data/ui/import";

// Two records fitted jointly, each from its own initial state: the project's
// "initial_states": "per_record" ticks the Estimate view's box, the fit holds the copies (as core
// fits them), the Parameters view lists them, and record 2 is predicted from its own copy.
TEST_F(ValidationRecords, JointFitsGiveEachRecordItsOwnInitialState) {
  Json model = Json::parse(std::ifstream(dir_ / "model.json"));
  model["initial_state"] = {{"mfv", "v0"}, {"mff", "f0"}};
  model["parameters"]["v0"] = {{"value", 0.0}, {"lower", -1}, {"upper", 1}};
  model["parameters"]["f0"] = {{"value", 0.0}, {"lower", -1}, {"upper", 1}};
  std::ofstream(dir_ / "model.json") << model.dump(1);
  std::ofstream(dir_ / "project.json") << R"({"greybench_project": 1, "name": "halves",
      "model": "model.json", "estimation": {"initial_states": "per_record"},
      "datasets": [{"file": "f1.csv", "range": [0, 4.99]},
                   {"file": "f1.csv", "range": [5, 10], "name": "second half"}]})";
  WorkbenchDriver d;
  d.Open(Path("project.json"));
  ASSERT_TRUE(d.state.project) << d.state.open_error;
  EXPECT_TRUE(d.state.estimation.settings.per_record_initial_states);
  d.state.view = View::kEstimate;
  d.Frame();
  EXPECT_NE(d.Text().find("Initial state per record"), std::string::npos);
  d.state.estimation.settings.threads = 1;
  std::string why;
  ASSERT_TRUE(StartEstimation(d.state, &why)) << why;
  WaitForJobs(d.state);
  ASSERT_TRUE(d.state.estimation.result) << d.state.estimation.last_failure;
  const FitResult& fit = *d.state.estimation.result;
  ASSERT_EQ(fit.series_parameters.size(), 2u);
  std::vector<std::string> names;
  for (const auto& p : fit.summary.parameters) names.push_back(p.name);
  EXPECT_NE(std::find(names.begin(), names.end(), "f0_r2"), names.end());

  // As core fits it.
  project::Project p = *project::LoadProject(Path("project.json"));
  auto spec = model::ParseModel(p.model_json, p.model_path);
  ASSERT_TRUE(spec.ok());
  auto problem = project::LoadProblem(*spec, p.datasets, project::InitialStates::kPerRecord);
  ASSERT_TRUE(problem.ok()) << problem.error().ToString();
  auto likelihood = project::MakeLikelihood(*problem);
  ASSERT_TRUE(likelihood.ok());
  estimate::EstimateOptions options;
  options.threads = 1;
  auto direct = estimate::Estimate(*likelihood, options);
  ASSERT_TRUE(direct.ok());
  EXPECT_NEAR(fit.summary.loglik, direct->loglik, 1e-9 * std::abs(direct->loglik));

  // Record 2 is predicted from its own copies: its first residual is an ordinary one.
  WaitForJobs(d.state);
  ASSERT_TRUE(d.state.analysis.result) << d.state.analysis.last_failure;
  const Analysis& a = *d.state.analysis.result;
  EXPECT_EQ(a.request.source, AnalysisSource::kFit);
  ASSERT_EQ(a.request.record_theta.size(), 2u);
  const std::vector<double>& z = a.datasets[1].outputs[0].standardized;
  const auto first = std::find_if(z.begin(), z.end(), [](double v) { return std::isfinite(v); });
  ASSERT_NE(first, z.end());
  EXPECT_LT(std::abs(*first), 4);

  d.state.view = View::kParameters;
  d.Frame();
  EXPECT_NE(d.Text().find("f0_r2"), std::string::npos);
}

TEST(ImportDialog, AHeaderlessTimelessRecordingFitsAsTheProjectsKeysFitIt) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("greybench-import-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  std::filesystem::copy_file(kImportDir + "/model.json", dir / "model.json",
                             std::filesystem::copy_options::overwrite_existing);
  std::filesystem::copy_file(kImportDir + "/headerless.csv", dir / "headerless.csv",
                             std::filesystem::copy_options::overwrite_existing);
  std::ofstream(dir / "empty.json")
      << R"({"greybench_project": 1, "name": "empty", "model": "model.json", "datasets": []})";
  WorkbenchDriver d;
  d.Open((dir / "empty.json").string());
  ASSERT_TRUE(d.state.project) << d.state.open_error;

  // File > Add dataset… chose the file: the dialog tells what it can.
  OpenImportDialog(d.state, (dir / "headerless.csv").string());
  ImportForm& f = d.state.shell.import;
  EXPECT_FALSE(f.header);
  EXPECT_EQ(f.separator, 0);
  EXPECT_EQ(f.decimal, 0);
  EXPECT_EQ(f.time, 0);  // no time column: rows a sample time apart
  ASSERT_EQ(f.names.size(), 13u);
  EXPECT_EQ(f.names[0], "c1");
  EXPECT_FALSE(f.check_ok);  // the model's n is not a column yet
  EXPECT_NE(f.check.find("column 'n' (an input of the model) is not in the file"),
            std::string::npos)
      << f.check;
  // The user maps the model's inputs and output to fields 1, 2 and 12.
  ASSERT_EQ(f.map.size(), 3u);
  f.map = {"c1", "c2", "c12"};
  f.sample_time = 0.1;
  CheckImport(&f, &*d.state.model);
  ASSERT_TRUE(f.check_ok) << f.check;
  // The first 64 KB are previewed and checked; the whole file is read when it is added.
  EXPECT_NE(f.check.find("rows previewed, t = 0 \xE2\x80\xA6"), std::string::npos) << f.check;
  EXPECT_NE(f.check.find("they bind to the model's inputs and outputs"), std::string::npos)
      << f.check;

  // Its Add button: read in the background, installed with its keys.
  d.Frame();  // opens the popup
  d.Frame();  // draws it
  ImGuiWindow* popup = WorkbenchDriver::FindWindow("Import a dataset");
  ASSERT_TRUE(popup);
  const std::optional<ImVec2> add = d.Find(popup, popup->GetID("Add to the project"));
  ASSERT_TRUE(add);
  d.Click(*add);
  ASSERT_TRUE(d.FramesUntil([&] { return !d.state.datasets.empty(); }, std::chrono::seconds(20)));
  ASSERT_EQ(d.state.datasets.size(), 1u);
  EXPECT_EQ(d.state.datasets[0].summary.rows, 400u);
  ASSERT_TRUE(d.state.datasets[0].data) << d.state.datasets[0].error;
  const data::DatasetSpec& spec = d.state.datasets[0].spec;
  EXPECT_EQ(spec.header, false);
  EXPECT_EQ(spec.sample_time, 0.1);
  EXPECT_EQ(spec.map.size(), 3u);
  EXPECT_TRUE(HasUnsavedChanges(d.state));

  d.state.estimation.settings.threads = 1;
  std::string why;
  ASSERT_TRUE(StartEstimation(d.state, &why)) << why;
  WaitForJobs(d.state);
  ASSERT_TRUE(d.state.estimation.result) << d.state.estimation.last_failure;

  // The bundled project names the fields by `columns` instead: the same fit.
  auto direct = DirectFit(*project::LoadProject(kImportDir + "/project.json"));
  ASSERT_TRUE(direct.ok()) << direct.error().ToString();
  const estimate::EstimateSummary& gui = d.state.estimation.result->summary;
  EXPECT_EQ(gui.n_obs, direct->n_obs);
  EXPECT_EQ(gui.loglik, direct->loglik);
  ASSERT_EQ(gui.theta.size(), direct->theta.size());
  for (std::size_t i = 0; i < gui.theta.size(); ++i) EXPECT_EQ(gui.theta[i], direct->theta[i]) << i;

  // Saved, the project keeps the dialog's keys.
  ASSERT_TRUE(SaveCurrentProject(d.state).ok());
  project::Project back = *project::LoadProject((dir / "empty.json").string());
  ASSERT_EQ(back.datasets.size(), 1u);
  EXPECT_EQ(back.datasets[0].map, spec.map);
  EXPECT_EQ(back.datasets[0].sample_time, 0.1);
  std::filesystem::remove_all(dir);
}

// The dialog's preparation: a range, means removed and a new sample time become the entry's keys
// and read as the project's keys read them (core's Prepare on the whole file); a range beyond the
// previewed rows is left to the whole file, and an empty one is refused as typed.
TEST(ImportDialog, ARangeADetrendAndAResampleBecomeTheEntrysKeys) {
  WorkbenchDriver d;
  d.Open(kImportDir + "/project.json");
  ASSERT_TRUE(d.state.project) << d.state.open_error;
  OpenImportDialog(d.state, kImportDir + "/headerless.csv");
  ImportForm& f = d.state.shell.import;
  f.map = {"c1", "c2", "c12"};
  f.sample_time = 0.1;
  f.use_range = true;
  f.range_from = 5;
  f.range_to = 30;
  f.detrend = 1;
  f.resample = 0.5;
  CheckImport(&f, &*d.state.model);
  ASSERT_TRUE(f.check_ok) << f.check;
  const data::DatasetSpec spec = ImportSpecOf(f, &*d.state.model);
  ASSERT_TRUE(spec.range);
  EXPECT_EQ((*spec.range)[0], 5);
  ASSERT_EQ(spec.detrend.size(), 1u);
  EXPECT_EQ(spec.detrend[0].second, data::Detrend::kMean);
  EXPECT_EQ(spec.resample, 0.5);
  auto read = data::ReadDataset(spec);
  ASSERT_TRUE(read.ok()) << read.error().ToString();
  EXPECT_NEAR((*read)->time.front(), 5.0, 1e-9);
  EXPECT_EQ((*read)->rows(), 51u);  // 5, 5.5, ..., 30
  // The means are removed before the decimation: zero at the record's own sample time.
  data::DatasetSpec kept = spec;
  kept.resample = 0;
  auto detrended = data::ReadDataset(kept);
  ASSERT_TRUE(detrended.ok());
  double mean = 0;
  for (double v : (*detrended)->columns[0].values) mean += v;
  EXPECT_LT(std::abs(mean / static_cast<double>((*detrended)->rows())), 1e-9);
  // The same keys through the project file's reader.
  auto parsed = data::ParseDatasetSpec(data::DatasetSpecToJson(spec, "headerless.csv"), "p.json",
                                       "datasets[0]");
  ASSERT_TRUE(parsed.ok()) << parsed.error().ToString();
  EXPECT_EQ(parsed->resample, 0.5);
  // An empty range is refused as typed (the whole file is previewed when it is short).
  if (!f.truncated) {
    f.range_from = 30;
    f.range_to = 5;
    CheckImport(&f, &*d.state.model);
    EXPECT_FALSE(f.check_ok);
  } else {
    EXPECT_NE(f.check.find("is applied to the whole file"), std::string::npos) << f.check;
  }
}

// An ASAM MDF 4 recording in the dialog: its channels listed with their groups and rates,
// picked, on a chosen time base; the entry reads as the project's keys read it.
TEST(ImportDialog, AnMdfRecordingsChannelsArePickedOntoATimeBase) {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() /
                                    ("greybench-import-mdf-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  std::filesystem::copy_file(kSource + "/tests/data/mdf4/two_rates.mf4", dir / "two_rates.mf4",
                             std::filesystem::copy_options::overwrite_existing);
  std::ofstream(dir / "model.json") << R"({"greybench_model": 1, "name": "p", "states": ["x"],
      "inputs": ["speed"], "outputs": ["pressure"],
      "parameters": {"a": {"value": 1, "lower": 0.01, "upper": 100}, "b": 0.001, "c": 1000,
                     "s": {"value": 1, "lower": 1e-6}, "r": {"value": 1, "lower": 1e-6}},
      "drift": {"x": "-a*x + b*speed"}, "diffusion": {"x": "s"},
      "observation": {"pressure": "c + x"}, "measurement_variance": {"pressure": "r"}})";
  std::ofstream(dir / "empty.json")
      << R"({"greybench_project": 1, "name": "mdf", "model": "model.json", "datasets": []})";
  WorkbenchDriver d;
  d.Open((dir / "empty.json").string());
  ASSERT_TRUE(d.state.project) << d.state.open_error;
  OpenImportDialog(d.state, (dir / "two_rates.mf4").string());
  ImportForm& f = d.state.shell.import;
  ASSERT_TRUE(f.mdf);
  ASSERT_TRUE(f.mdf_file) << f.read_error;
  EXPECT_EQ(f.channels, (std::vector<std::string>{"speed", "temp", "pressure"}));
  EXPECT_EQ(f.time_base, 1);  // "fast", the group with the most samples
  ASSERT_TRUE(f.check_ok) << f.check;
  // temp left out, the 10 Hz group's times.
  f.use[1] = false;
  f.time_base = 2;
  CheckImport(&f, &*d.state.model);
  ASSERT_TRUE(f.check_ok) << f.check;
  EXPECT_NE(f.check.find("5 rows"), std::string::npos) << f.check;
  const data::DatasetSpec spec = ImportSpecOf(f, &*d.state.model);
  EXPECT_EQ(spec.columns, (std::vector<std::string>{"speed", "pressure"}));
  EXPECT_EQ(spec.time, "2");
  EXPECT_FALSE(spec.header.has_value());
  d.Frame();  // opens the popup
  d.Frame();  // draws it
  ImGuiWindow* popup = WorkbenchDriver::FindWindow("Import a dataset");
  ASSERT_TRUE(popup);
  const std::optional<ImVec2> add = d.Find(popup, popup->GetID("Add to the project"));
  ASSERT_TRUE(add);
  d.Click(*add);
  ASSERT_TRUE(d.FramesUntil([&] { return !d.state.datasets.empty(); }, std::chrono::seconds(20)));
  ASSERT_TRUE(d.state.datasets[0].data) << d.state.datasets[0].error;
  auto direct = data::ReadDataset(spec);
  ASSERT_TRUE(direct.ok()) << direct.error().ToString();
  EXPECT_EQ(d.state.datasets[0].data->time, (*direct)->time);
  EXPECT_EQ(d.state.datasets[0].data->columns[0].values, (*direct)->columns[0].values);
  // Nothing picked: said so.
  OpenImportDialog(d.state, (dir / "two_rates.mf4").string());
  d.state.shell.import.use.assign(3, false);
  CheckImport(&d.state.shell.import, &*d.state.model);
  EXPECT_FALSE(d.state.shell.import.check_ok);
  EXPECT_EQ(d.state.shell.import.check, "choose the channels to read");
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace gb::ui
