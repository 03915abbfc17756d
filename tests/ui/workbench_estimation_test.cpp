// The estimate and parameters views driven through synthetic ImGui input, as a user would use
// them: click Run, watch the job finish, read the estimates in the Parameters view; start a
// long fit and cancel it; type a start value the model refuses, then one it accepts.
//
// The estimates the GUI installs are checked against core's Estimate run directly on the same
// files with the same options (the GUI must add nothing and lose nothing on the way).
#include <chrono>
#include <cmath>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "core/estimate/estimate.h"
#include "core/model/model.h"
#include "core/project/problem.h"
#include "core/project/project.h"
#include "core/util/sanitizers.h"
#include "tests/ui/workbench_driver.h"
#include "ui/format.h"
#include "ui/shell/shell.h"

#ifndef GREYBENCH_SOURCE_DIR
#error "GREYBENCH_SOURCE_DIR must name the source tree (tests/ui/CMakeLists.txt sets it)"
#endif

namespace gb::ui {
namespace {

using std::chrono::milliseconds;
using testing::EndedAsCancelled;
using testing::FindButton;
using testing::kCancelDeadline;
using testing::kCaseStudy;
using testing::kSource;
using testing::kTestProject;
using testing::WorkbenchDriver;

// Under the sanitizers a fit of the case study takes a minute or more; the deadline only
// catches a fit that never ends.
constexpr milliseconds kFitTimeout{kSanitized ? 600000 : 60000};

// The cells of the table row whose first cell is `name`, from ImGui's log of a table
// ("| tau_fv | s | { 0.08 } | ... |"); empty when there is no such row.
std::vector<std::string> Row(const std::string& log, const std::string& name) {
  std::istringstream lines(log);
  std::string line;
  while (std::getline(lines, line)) {
    if (line.rfind("| " + name + " |", 0) != 0) continue;
    std::vector<std::string> cells;
    std::size_t at = 2;
    for (std::size_t end; (end = line.find(" |", at)) != std::string::npos; at = end + 3)
      cells.push_back(line.substr(at, end - at));
    return cells;
  }
  return {};
}

// Columns of the parameters table after a fit.
constexpr std::size_t kEstimateColumn = 6;
constexpr std::size_t kStdErrorColumn = 7;

// core's estimate of the test project, with the GUI's options.
estimate::EstimateSummary EstimateDirectly(const EstimationSettings& settings) {
  auto spec = model::LoadModelFile(kSource + "/tests/data/ui/fuel_film.json");
  EXPECT_TRUE(spec.ok());
  auto problem = project::LoadProblem(*spec, {kSource + "/tests/data/ui/f1.csv"});
  EXPECT_TRUE(problem.ok());
  auto likelihood = project::MakeLikelihood(*problem);
  EXPECT_TRUE(likelihood.ok());
  estimate::EstimateOptions options;
  options.algorithm = settings.algorithm;
  options.multistart = settings.multistart;
  options.threads = settings.threads;
  auto summary = estimate::Estimate(*likelihood, options);
  EXPECT_TRUE(summary.ok());
  return *summary;
}

// Frames until the estimation job has ended, then one more (its result installed).
::testing::AssertionResult FinishFit(WorkbenchDriver& d) {
  if (!d.FramesUntil([&] { return !EstimationRunning(d.state); }, kFitTimeout))
    return ::testing::AssertionFailure() << "the fit did not end in time";
  d.Frame();
  if (!d.state.estimation.result)
    return ::testing::AssertionFailure() << "no result: " << d.state.estimation.last_failure;
  return ::testing::AssertionSuccess();
}

TEST(WorkbenchEstimation, ClickingRunInstallsTheEstimatesAndTheParametersViewShowsThem) {
  WorkbenchDriver d;
  d.Open(kTestProject);
  ASSERT_TRUE(d.state.model) << d.state.model_error;
  d.state.view = View::kEstimate;
  d.state.estimation.settings.threads = 1;
  d.Frame();

  const std::optional<ImVec2> run = d.Find(WorkbenchDriver::ViewWindow(), d.ViewItemId("Run"));
  ASSERT_TRUE(run) << "the Run button was not found in the estimate view";
  d.Click(*run);
  EXPECT_TRUE(EstimationRunning(d.state) || d.state.estimation.result);
  ASSERT_TRUE(FinishFit(d));
  const FitResult& fit = *d.state.estimation.result;
  EXPECT_TRUE(fit.summary.converged) << fit.summary.message;
  EXPECT_GT(fit.trace.size(), 0) << "the progress record fed no trace";
  EXPECT_FALSE(fit.report.empty());

  const estimate::EstimateSummary direct = EstimateDirectly(d.state.estimation.settings);
  EXPECT_DOUBLE_EQ(fit.summary.loglik, direct.loglik);
  ASSERT_EQ(fit.summary.parameters.size(), direct.parameters.size());
  for (std::size_t i = 0; i < direct.parameters.size(); ++i) {
    EXPECT_EQ(fit.summary.parameters[i].name, direct.parameters[i].name);
    EXPECT_DOUBLE_EQ(fit.summary.parameters[i].estimate, direct.parameters[i].estimate)
        << direct.parameters[i].name;
  }

  // The parameters view lists them, row by row.
  d.state.view = View::kParameters;
  d.Frame();
  const std::string log = d.Text();
  for (const estimate::ParameterEstimate& p : direct.parameters) {
    const std::vector<std::string> row = Row(log, p.name);
    ASSERT_GT(row.size(), kStdErrorColumn) << "no row for " << p.name << " in:\n" << log;
    EXPECT_EQ(row[kEstimateColumn], FormatSig(p.estimate, 5)) << p.name;
    if (p.std_error) {
      EXPECT_EQ(row[kStdErrorColumn], FormatSig(*p.std_error, 3)) << p.name;
    }
  }
  EXPECT_EQ(Row(log, "s12").at(kStdErrorColumn), "at lower bound");
  EXPECT_EQ(Row(log, "Kb").at(kStdErrorColumn), "fixed");
  EXPECT_NE(log.find("s12 is at its lower bound"), std::string::npos) << "the warning is missing";
  EXPECT_EQ(log.find("nan"), std::string::npos) << log;
}

TEST(WorkbenchEstimation, ProfileIntervalsShowBesideTheWaldOnesAndAParametersProfileIsPlotted) {
  WorkbenchDriver d;
  d.Open(kTestProject);
  ASSERT_TRUE(d.state.model) << d.state.model_error;
  d.state.view = View::kEstimate;
  d.state.estimation.settings.threads = 1;
  d.state.estimation.settings.profile_intervals = true;  // the Estimate view's check box
  d.Frame();
  const std::optional<ImVec2> run = d.Find(WorkbenchDriver::ViewWindow(), d.ViewItemId("Run"));
  ASSERT_TRUE(run);
  d.Click(*run);
  ASSERT_TRUE(FinishFit(d));
  const estimate::EstimateSummary& s = d.state.estimation.result->summary;

  d.state.view = View::kParameters;
  d.Frame();
  const std::string log = d.Text();
  EXPECT_NE(log.find("95 % profile"), std::string::npos) << log;
  int shown = 0;
  for (const estimate::ParameterEstimate& p : s.parameters) {
    if (p.fixed) continue;
    ASSERT_TRUE(p.profile.has_value()) << p.name;
    const std::vector<std::string> row = Row(log, p.name);
    ASSERT_FALSE(row.empty()) << p.name << " in:\n" << log;
    // The last cell: "lower … upper" ("bound" for an end at the parameter's bound).
    const std::string lower = p.profile->lower            ? FormatSig(*p.profile->lower, 3)
                              : p.profile->lower_at_bound ? "bound"
                                                          : "none";
    const std::string upper = p.profile->upper            ? FormatSig(*p.profile->upper, 3)
                              : p.profile->upper_at_bound ? "bound"
                                                          : "none";
    EXPECT_EQ(row.back(), lower + " \xE2\x80\xA6 " + upper) << p.name;
    ++shown;
  }
  EXPECT_GE(shown, 5);
  // A parameter's profile, as a click on its interval asks: drawn under the table.
  d.state.parameters_view.profile_plot = "tau_fv";
  d.Frame();
  EXPECT_EQ(d.Text().find("nan"), std::string::npos);
}

// The interval columns beside the profile intervals are as wide as their longest text at
// 1024 x 768 and at 1600 x 1000 (the table scrolls sideways where the window is narrower); they
// were squeezed to a character or two at every width.
TEST(WorkbenchEstimation, TheProfileIntervalColumnsKeepTheirWidthAtEveryWindowSize) {
  WorkbenchDriver d;
  d.Open(kTestProject);
  d.state.estimation.settings.threads = 1;
  d.state.estimation.settings.profile_intervals = true;
  std::string why;
  ASSERT_TRUE(StartEstimation(d.state, &why)) << why;
  ASSERT_TRUE(FinishFit(d));
  d.state.view = View::kParameters;
  for (const ImVec2 size : {ImVec2(1024, 768), ImVec2(1600, 1000)}) {
    ImGui::GetIO().DisplaySize = size;
    d.Frame();
    d.Frame();
    const ImGuiTable* table = nullptr;
    for (int i = 0; i < GImGui->Tables.GetMapSize(); ++i) {
      const ImGuiTable* t = GImGui->Tables.TryGetMapData(i);
      if (t && t->ColumnsCount == 11 && t->LastFrameActive == ImGui::GetFrameCount()) table = t;
    }
    ASSERT_TRUE(table) << "no parameters table with profile intervals at " << size.x;
    float longest = 0;
    for (const estimate::ParameterEstimate& p : d.state.estimation.result->summary.parameters) {
      if (!p.profile || !p.profile->lower || !p.profile->upper) continue;
      const std::string text =
          FormatSig(*p.profile->lower, 3) + " \xE2\x80\xA6 " + FormatSig(*p.profile->upper, 3);
      longest = std::max(longest, ImGui::CalcTextSize(text.c_str()).x);
    }
    ASSERT_GT(longest, 0);
    EXPECT_GE(table->Columns[10].WidthGiven, longest) << "at " << size.x;
    EXPECT_GE(table->Columns[9].WidthGiven, 0.8f * longest) << "at " << size.x;
  }
}

// At 1024 x 768 (the smallest window the guide supports) every option of the Estimate view's
// toolbar is on screen: what does not fit on the first line goes to the second.
TEST(WorkbenchEstimation, AtTheSmallestWindowEveryOptionOfTheToolbarCanBeReached) {
  WorkbenchDriver d;
  d.Open(kTestProject);
  ImGui::GetIO().DisplaySize = ImVec2(1024, 768);
  d.state.view = View::kEstimate;
  d.Frame();
  d.Frame();
  const std::optional<ImVec2> run = FindButton(d, "Run");
  ASSERT_TRUE(run);
  const float row = ImGui::GetFrameHeightWithSpacing();
  for (const char* label : {"Profile intervals", "Steady-state start"}) {
    std::optional<ImVec2> at = d.Find(WorkbenchDriver::ViewWindow(), d.ViewItemId(label), run->y);
    if (!at) at = d.Find(WorkbenchDriver::ViewWindow(), d.ViewItemId(label), run->y + row);
    EXPECT_TRUE(at) << label << " is off the toolbar at 1024 x 768";
    if (at) {
      EXPECT_LT(at->x, 1024.0f) << label;
    }
  }
}

TEST(WorkbenchEstimation, CancelStopsTheFitWithin100msAndKeepsItsBestPointAsAStoppedFit) {
  WorkbenchDriver d;
  // Under the sanitizers the test project (500 rows): the case study's first fit took a minute
  // there, and the point is the Cancel button's path, which a fit of 50 starts exercises alike.
  const std::string project = kSanitized ? kTestProject : kCaseStudy;
  d.Open(project);
  ASSERT_TRUE(d.state.model) << d.state.model_error;
  d.state.view = View::kEstimate;
  d.Frame();
  const std::optional<ImVec2> run = d.Find(WorkbenchDriver::ViewWindow(), d.ViewItemId("Run"));
  ASSERT_TRUE(run);

  // A first fit: it stays in the Fits list.
  d.Click(*run);
  ASSERT_TRUE(FinishFit(d));
  const estimate::EstimateSummary first = d.state.estimation.result->summary;

  // A long second fit (many starts), cancelled once it is under way.
  d.state.estimation.settings.multistart = 50;
  d.Click(*run);
  ASSERT_TRUE(EstimationRunning(d.state));
  ASSERT_TRUE(d.FramesUntil(
      [&] {
        return d.state.estimation.progress && d.state.estimation.progress->latest().iteration >= 3;
      },
      kFitTimeout));
  const std::optional<ImVec2> cancel =
      d.Find(WorkbenchDriver::ViewWindow(), d.ViewItemId("Cancel"), run->y);
  ASSERT_TRUE(cancel) << "the Cancel button was not found next to Run";
  ASSERT_TRUE(EstimationRunning(d.state)) << "the fit ended before it could be cancelled";
  d.MouseTo(*cancel);
  d.Press();
  const auto clicked = std::chrono::steady_clock::now();
  d.Release();  // the button acts here: CancelEstimation
  d.state.estimation.job.Wait();
  const auto stopped = std::chrono::steady_clock::now();
  EXPECT_LT(stopped - clicked, kCancelDeadline);
  RecordProperty(
      "cancel_ms",
      static_cast<int>(std::chrono::duration_cast<milliseconds>(stopped - clicked).count()));

  d.Frame();  // installs the outcome
  EXPECT_FALSE(EstimationRunning(d.state));
  // Both fits are in the list; the first is untouched.
  ASSERT_EQ(d.state.estimation.fits.size(), 2u);
  EXPECT_EQ(d.state.estimation.fits[0].fit.summary.theta, first.theta);
  EXPECT_EQ(d.state.estimation.fits[0].fit.summary.loglik, first.loglik);
  // The stopped one is shown: the best point the run had reached, marked so, its log L that of
  // the model at those values (computed here by the likelihood itself).
  ASSERT_TRUE(d.state.estimation.result);
  EXPECT_EQ(d.state.estimation.shown, 1);
  const estimate::EstimateSummary& kept = d.state.estimation.result->summary;
  EXPECT_TRUE(kept.cancelled);
  EXPECT_FALSE(kept.converged);
  ASSERT_EQ(kept.theta.size(), d.state.model->parameters.size());
  auto lik = project::LoadProblem(*d.state.model, {d.state.datasets[0].spec});
  ASSERT_TRUE(lik.ok()) << lik.error().ToString();
  auto likelihood = project::MakeLikelihood(*lik);
  ASSERT_TRUE(likelihood.ok());
  std::vector<int> delay;
  for (const estimate::DelayEstimate& de : kept.delays) delay.push_back(de.estimate);
  auto at = likelihood->Evaluate(kept.theta, delay);
  ASSERT_TRUE(at.ok());
  EXPECT_DOUBLE_EQ(kept.loglik, at->loglik);
  EXPECT_EQ(kept.n_obs, at->n_obs);
  for (const estimate::ParameterEstimate& p : kept.parameters)
    EXPECT_FALSE(p.std_error) << p.name << ": a stopped fit is not an optimum";
  ASSERT_FALSE(d.state.messages.empty());
  EXPECT_NE(d.state.messages.back().text.find("stopped"), std::string::npos)
      << d.state.messages.back().text;
  const std::string log = d.Text();
  EXPECT_NE(log.find("Stopped"), std::string::npos) << log;
  EXPECT_NE(log.find("not an optimum"), std::string::npos) << log;
}

// The Steady-state start box: kept with the project (an unsaved change until saved), read back
// from a project that has it, and an estimation it cannot serve fails with core's reason (the
// test model's steady level is set by K_b, which it fixes).
TEST(WorkbenchEstimation, TheSteadyStateStartBoxIsKeptWithTheProjectAndItsRefusalIsShown) {
  WorkbenchDriver d;
  d.Open(kTestProject);
  ASSERT_TRUE(d.state.model) << d.state.model_error;
  EXPECT_FALSE(d.state.estimation.settings.steady_start);
  d.state.view = View::kEstimate;
  d.Frame();
  EXPECT_FALSE(HasUnsavedChanges(d.state));
  const std::optional<ImVec2> run = FindButton(d, "Run");
  ASSERT_TRUE(run);
  const std::optional<ImVec2> box = FindButton(d, "Steady-state start");
  ASSERT_TRUE(box) << "the Steady-state start box was not found in the toolbar";
  d.Click(*box);
  EXPECT_TRUE(d.state.estimation.settings.steady_start);
  ASSERT_TRUE(d.state.project);
  EXPECT_EQ(d.state.project->extra["estimation"]["steady_start"], true);
  EXPECT_TRUE(HasUnsavedChanges(d.state));

  d.Click(*run);
  if (EstimationRunning(d.state)) d.state.estimation.job.Wait();
  d.Frame();
  EXPECT_FALSE(d.state.estimation.result);
  EXPECT_NE(d.state.estimation.last_failure.find("no free parameter moves the model's steady"),
            std::string::npos)
      << d.state.estimation.last_failure;

  // Saved and opened again: the box is ticked.
  const std::string saved = ::testing::TempDir() + "steady_start_project.json";
  project::Project p = *d.state.project;
  ASSERT_TRUE(project::SaveProject(p, saved).ok());
  WorkbenchDriver again;
  again.Open(saved);
  ASSERT_TRUE(again.state.project) << again.state.open_error;
  EXPECT_TRUE(again.state.estimation.settings.steady_start);
}

TEST(WorkbenchEstimation, ATypedStartValueOutsideTheBoundsIsRefusedWithTheReason) {
  WorkbenchDriver d;
  d.Open(kTestProject);
  ASSERT_TRUE(d.state.model);
  d.state.view = View::kParameters;
  d.Frame();
  // The start value cell of the first parameter (tau_fv, bounds [0.005, 1]).
  ImGuiWindow* view = WorkbenchDriver::FindWindow("##workbench/##view_", "/##parameters_view_");
  ASSERT_TRUE(view);
  const int row = 0;
  const ImGuiID table = ImHashStr("##parameters", 0, view->ID);
  const ImGuiID cell = ImHashStr("##value", 0, ImHashData(&row, sizeof row, table));
  const std::optional<ImVec2> at = d.Find(view, cell);
  ASSERT_TRUE(at) << "the start value cell was not found";
  const int revision = d.state.model_revision;

  d.Click(*at);  // activates the field, its text selected
  d.Type("2");
  d.PressEnter();
  ASSERT_TRUE(d.state.parameters_view.refusal);
  EXPECT_EQ(d.state.parameters_view.refusal->parameter, "tau_fv");
  EXPECT_NE(d.state.parameters_view.refusal->reason.find("outside the bounds"), std::string::npos)
      << d.state.parameters_view.refusal->reason;
  EXPECT_EQ(d.state.model->parameters[0].value, 0.08);  // unchanged
  EXPECT_EQ(d.state.model_revision, revision);
  EXPECT_NE(d.Text().find("refused"), std::string::npos);

  d.Click(*at);
  d.Type("0.09");
  d.PressEnter();
  EXPECT_FALSE(d.state.parameters_view.refusal);
  EXPECT_EQ(d.state.model->parameters[0].value, 0.09);
  EXPECT_GT(d.state.model_revision, revision);
  // The project's model (read by the equations view) follows.
  EXPECT_EQ(d.state.project->model_json["parameters"]["tau_fv"]["value"].get<double>(), 0.09);
}

TEST(WorkbenchEstimation, AFailedRunKeepsThePreviousResultAndSaysWhy) {
  WorkbenchDriver d;
  d.Open(kTestProject);
  ASSERT_TRUE(d.state.model);
  d.state.estimation.settings.threads = 1;
  ASSERT_TRUE(StartEstimation(d.state));
  WaitForJobs(d.state);
  ASSERT_TRUE(d.state.estimation.result);
  const double loglik = d.state.estimation.result->summary.loglik;

  // A delay range longer than the data: the likelihood cannot be built.
  d.state.model->output_delay[0].max = 100000;
  std::string why;
  ASSERT_TRUE(StartEstimation(d.state, &why)) << why;
  WaitForJobs(d.state);
  ASSERT_TRUE(d.state.estimation.result);
  EXPECT_EQ(d.state.estimation.result->summary.loglik, loglik);
  EXPECT_NE(d.state.estimation.last_failure.find("output_delay"), std::string::npos)
      << d.state.estimation.last_failure;
  ASSERT_FALSE(d.state.messages.empty());
  EXPECT_EQ(d.state.messages.back().severity, Severity::kError);
  EXPECT_NE(d.state.messages.back().text.find("previous results are kept"), std::string::npos);
}

TEST(WorkbenchEstimation, RunIsRefusedWithAReasonWhileARunIsUnderWay) {
  WorkbenchDriver d;
  d.Open(kCaseStudy);
  ASSERT_TRUE(StartEstimation(d.state));
  std::string why;
  EXPECT_FALSE(StartEstimation(d.state, &why));
  EXPECT_EQ(why, "an estimation is under way");
  CancelEstimation(d.state);
  WaitForJobs(d.state);
  EXPECT_TRUE(EndedAsCancelled(d.state));
}

}  // namespace
}  // namespace gb::ui
