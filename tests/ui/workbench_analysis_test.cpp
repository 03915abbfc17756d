// The predictions and residual diagnostics the workbench computes in the background (ui/
// jobs/analysis.h) and the Predictions and Residuals views that draw them.
//
// The numbers the job installs are checked against core's functions called directly on the
// same files (PredictOneStep, PredictAhead, DeterministicResponse, Diagnose), and the residuals
// and RMS against y − ŷ computed here from the data file's own column: the wiring must add
// nothing and lose nothing. Then the job's life: it follows a fit, keeps its results when a
// run is cancelled or fails, and nothing crashes with missing outputs, an unusable dataset or
// no fit.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <unistd.h>

#include "core/diagnose/residuals.h"
#include "core/filter/predict.h"
#include "core/model/model.h"
#include "core/project/problem.h"
#include "core/sim/response.h"
#include "core/util/json.h"
#include "tests/ui/workbench_driver.h"
#include "ui/format.h"

#ifndef GREYBENCH_SOURCE_DIR
#error "GREYBENCH_SOURCE_DIR must name the source tree (tests/ui/CMakeLists.txt sets it)"
#endif

namespace gb::ui {
namespace {

using testing::kCaseStudy;
using testing::kSource;
using testing::kTestProject;
using testing::WorkbenchDriver;

const std::string kTestModel = kSource + "/tests/data/ui/fuel_film.json";
const std::string kTestData = kSource + "/tests/data/ui/f1.csv";

// Equal, or both missing.
bool Same(double a, double b) { return (std::isnan(a) && std::isnan(b)) || a == b; }

// What core computes for the test project at θ with the given delays (empty: the best delay of
// the model's range at θ, by its own profile likelihood).
struct Direct {
  std::vector<int> delay;
  filter::FilterSettings settings;
  std::shared_ptr<const data::Series> series;
  model::StateSpace ss;
  filter::OneStepPredictions pred;
};

Direct ComputeDirectly(const std::vector<double>& theta, std::vector<int> delay) {
  Direct d;
  auto spec = model::LoadModelFile(kTestModel);
  EXPECT_TRUE(spec.ok());
  auto problem = project::LoadProblem(*spec, {kTestData});
  EXPECT_TRUE(problem.ok());
  auto likelihood = project::MakeLikelihood(*problem);
  EXPECT_TRUE(likelihood.ok());
  if (delay.empty()) {
    auto profile = likelihood->Profile(theta);
    EXPECT_TRUE(profile.ok() && profile->best >= 0);
    delay = profile->candidates[static_cast<std::size_t>(profile->best)].delay;
  }
  d.delay = delay;
  d.settings = likelihood->settings();
  d.settings.delay = delay;
  d.series = problem->series.front();
  auto ss = problem->model->Evaluate(theta);
  EXPECT_TRUE(ss.ok());
  d.ss = *ss;
  auto pred = filter::PredictOneStep(d.ss, *d.series, d.settings);
  EXPECT_TRUE(pred.ok());
  d.pred = *pred;
  return d;
}

// The measured column of the data file, read here on its own.
std::vector<double> MeasuredColumn(const std::string& name) {
  auto data = data::ReadCsvFile(kTestData);
  EXPECT_TRUE(data.ok());
  const int c = (*data)->Find(name);
  EXPECT_GE(c, 0);
  return (*data)->columns[static_cast<std::size_t>(c)].values;
}

void ExpectMatchesCore(const Analysis& a, const Direct& direct, int first_obs) {
  ASSERT_EQ(a.datasets.size(), 1u);
  const DatasetAnalysis& d = a.datasets[0];
  ASSERT_TRUE(d.error.empty()) << d.error;
  ASSERT_EQ(d.outputs.size(), 1u);
  const OutputAnalysis& o = d.outputs[0];
  EXPECT_EQ(a.delay, direct.delay);
  EXPECT_EQ(o.delay, direct.delay[0]);
  const std::vector<double> y = MeasuredColumn("ilambda");
  ASSERT_EQ(o.predicted.size(), y.size());
  double sum_sq = 0.0;
  int n = 0;
  for (std::size_t k = 0; k < y.size(); ++k) {
    const auto j = static_cast<Eigen::Index>(k);
    ASSERT_TRUE(Same(o.predicted[k], direct.pred.y_pred(0, j))) << "k = " << k;
    EXPECT_TRUE(Same(o.measured[k], y[k])) << "k = " << k;
    const double sd = direct.pred.y_sd(0, j);
    EXPECT_TRUE(Same(o.lower[k], direct.pred.y_pred(0, j) - 2.0 * sd)) << "k = " << k;
    EXPECT_TRUE(Same(o.upper[k], direct.pred.y_pred(0, j) + 2.0 * sd)) << "k = " << k;
    if (static_cast<int>(k) < o.delay) {
      EXPECT_TRUE(std::isnan(o.predicted[k])) << "no prediction before the delay, k = " << k;
    } else if (std::isfinite(y[k])) {
      // residual = y − ŷ, with y from the file.
      EXPECT_NEAR(o.residual[k], y[k] - o.predicted[k], 1e-15) << "k = " << k;
    }
    if (static_cast<int>(k) >= first_obs && std::isfinite(y[k])) {
      sum_sq += (y[k] - o.predicted[k]) * (y[k] - o.predicted[k]);
      ++n;
      EXPECT_NEAR(o.standardized[k], (y[k] - o.predicted[k]) / sd, 1e-12) << "k = " << k;
    } else {
      EXPECT_TRUE(std::isnan(o.standardized[k])) << "not used by the likelihood, k = " << k;
    }
  }
  EXPECT_EQ(o.n_observed, n);
  EXPECT_NEAR(o.rms, std::sqrt(sum_sq / n), 1e-14);
  EXPECT_DOUBLE_EQ(d.loglik, direct.pred.loglik.loglik);

  // The overlays.
  // The h-step predictions are computed only while the view shows them (horizon 0 otherwise).
  const bool with_ahead = a.request.horizon >= 1;
  auto ahead = filter::PredictAhead(direct.ss, *direct.series, direct.settings,
                                    std::max(a.request.horizon, 1));
  ASSERT_TRUE(ahead.ok());
  auto sim = sim::DeterministicResponse(direct.ss, *direct.series, direct.settings);
  ASSERT_TRUE(sim.ok());
  auto smoothed = filter::Smooth(direct.ss, *direct.series, direct.settings);
  ASSERT_TRUE(smoothed.ok());
  ASSERT_EQ(o.ahead.size(), with_ahead ? y.size() : 0U);
  EXPECT_TRUE(o.ahead_error.empty()) << o.ahead_error;
  ASSERT_EQ(o.simulated.size(), y.size());
  ASSERT_EQ(o.smoothed.size(), y.size()) << o.smoothed_error;
  for (std::size_t k = 0; k < y.size(); ++k) {
    const auto j = static_cast<Eigen::Index>(k);
    if (with_ahead) {
      EXPECT_TRUE(Same(o.ahead[k], ahead->y_pred(0, j))) << "k = " << k;
    }
    EXPECT_TRUE(Same(o.simulated[k], sim->Y(0, j))) << "k = " << k;
    EXPECT_TRUE(Same(o.smoothed[k], smoothed->y(0, j))) << "k = " << k;
    EXPECT_TRUE(Same(o.smoothed_upper[k], smoothed->y(0, j) + 2.0 * smoothed->y_sd(0, j)))
        << "k = " << k;
  }

  // The diagnostics: core's Diagnose on core's standardised residuals, with the input.
  const std::vector<double> z(direct.pred.standardized.row(0).begin(),
                              direct.pred.standardized.row(0).end());
  const std::vector<double> u(direct.series->U.row(0).begin(), direct.series->U.row(0).end());
  const std::vector<diagnose::InputSeries> inputs = {{"mfi", u}};
  auto diag = diagnose::Diagnose(z, inputs);
  ASSERT_TRUE(diag.ok());
  ASSERT_TRUE(o.diagnostics) << o.diagnose_error;
  const diagnose::ResidualDiagnostics& st = o.diagnostics->stats;
  EXPECT_EQ(st.verdict, diag->verdict);
  EXPECT_EQ(st.n, diag->n);
  EXPECT_DOUBLE_EQ(st.ljung_box.statistic, diag->ljung_box.statistic);
  EXPECT_DOUBLE_EQ(st.ljung_box.p_value, diag->ljung_box.p_value);
  EXPECT_DOUBLE_EQ(st.normality.jarque_bera, diag->normality.jarque_bera);
  EXPECT_EQ(st.acf.value, diag->acf.value);
  EXPECT_EQ(o.diagnostics->acf.value, diag->acf.value);
  ASSERT_EQ(o.diagnostics->acf.lag.size(), diag->acf.lag.size());
  for (std::size_t i = 0; i < diag->acf.lag.size(); ++i)
    EXPECT_EQ(o.diagnostics->acf.lag[i], diag->acf.lag[i]);
  ASSERT_EQ(o.diagnostics->ccf_prewhitened.size(), 1u);
  EXPECT_EQ(o.diagnostics->ccf_prewhitened[0].value, diag->ccf[0].ccf_prewhitened.value);
  EXPECT_EQ(st.periodogram.value, diag->periodogram.value);

  // The histogram is a density: its area is 1.
  const DiagnosticsPlot& p = *o.diagnostics;
  double area = 0.0;
  for (std::size_t i = 1; i + 1 < p.hist_x.size(); i += 2)
    area += p.hist_density[i] * (p.hist_x[i + 1] - p.hist_x[i]);
  EXPECT_NEAR(area, 1.0, 1e-12);
}

int LargestDelay(const model::ModelSpec& m) { return m.output_delay[0].max; }

TEST(WorkbenchAnalysis, WithoutAFitThePredictionsAreCoresAtTheModelsValues) {
  WorkbenchDriver d;
  d.Open(kTestProject);
  ASSERT_TRUE(d.state.model) << d.state.model_error;
  d.state.analysis.horizon = 7;
  d.state.analysis.show_ahead = true;
  WaitForJobs(d.state);
  ASSERT_TRUE(d.state.analysis.result) << d.state.analysis.last_failure;
  const Analysis& a = *d.state.analysis.result;
  EXPECT_EQ(a.request.source, AnalysisSource::kCurrentValues);
  EXPECT_EQ(a.request.theta, d.state.model->Values());
  EXPECT_EQ(a.request.horizon, 7);
  EXPECT_EQ(a.delay_source, "profile likelihood at these values");
  const Direct direct = ComputeDirectly(d.state.model->Values(), {});
  ExpectMatchesCore(a, direct, LargestDelay(*d.state.model));
  EXPECT_EQ(a.datasets[0].outputs[0].preview.size(), a.datasets[0].outputs[0].simulated.size());

  // The views draw it, and say plainly that there is no fit.
  d.state.view = View::kPredictions;
  d.Frame();
  std::string log = d.Text();
  EXPECT_NE(log.find("no fit yet"), std::string::npos) << log;
  const OutputAnalysis& o = a.datasets[0].outputs[0];
  EXPECT_EQ(log.find("nan"), std::string::npos) << log;
  d.state.view = View::kResiduals;
  d.Frame();
  log = d.Text();
  EXPECT_NE(log.find(o.diagnostics->stats.verdict), std::string::npos) << log;
  EXPECT_NE(log.find("Ljung-Box Q = " + FormatSig(o.diagnostics->stats.ljung_box.statistic, 4)),
            std::string::npos)
      << log;
}

TEST(WorkbenchAnalysis, AFitRestartsItAtTheEstimatesAndTheDataViewPreviewStaysAtTheValues) {
  WorkbenchDriver d;
  d.Open(kTestProject);
  WaitForJobs(d.state);
  ASSERT_TRUE(d.state.analysis.result);
  EXPECT_EQ(d.state.analysis.result->request.source, AnalysisSource::kCurrentValues);

  d.state.estimation.settings.threads = 1;
  ASSERT_TRUE(StartEstimation(d.state));
  WaitForJobs(d.state);  // the fit, then the analysis it starts
  ASSERT_TRUE(d.state.estimation.result);
  ASSERT_TRUE(d.state.analysis.result) << d.state.analysis.last_failure;
  const estimate::EstimateSummary& fit = d.state.estimation.result->summary;
  const Analysis& a = *d.state.analysis.result;
  EXPECT_EQ(a.request.source, AnalysisSource::kFit);
  EXPECT_EQ(a.request.theta, fit.theta);
  EXPECT_EQ(a.delay_source, "fit");
  ASSERT_EQ(fit.delays.size(), 1u);
  const Direct direct = ComputeDirectly(fit.theta, {fit.delays[0].estimate});
  ExpectMatchesCore(a, direct, LargestDelay(*d.state.model));
  d.state.view = View::kPredictions;
  d.Frame();
  EXPECT_NE(d.Text().find("At the estimates of the last fit"), std::string::npos);

  // The Data view's preview stays at the model's current values (the start values), not at
  // the estimates.
  ASSERT_NE(d.state.model->Values(), fit.theta);
  const Direct current = ComputeDirectly(d.state.model->Values(), {fit.delays[0].estimate});
  auto preview = sim::DeterministicResponse(current.ss, *current.series, current.settings);
  ASSERT_TRUE(preview.ok());
  const OutputAnalysis& o = a.datasets[0].outputs[0];
  ASSERT_EQ(o.preview.size(), o.measured.size());
  for (std::size_t k = 0; k < o.preview.size(); ++k)
    EXPECT_TRUE(Same(o.preview[k], preview->Y(0, static_cast<Eigen::Index>(k)))) << "k = " << k;
  d.state.view = View::kData;
  d.Frame();
  EXPECT_NE(d.Text().find("at the model's current values"), std::string::npos);

  // The model's current values instead of the fit's estimates.
  d.state.analysis.use_current_values = true;
  PollJobs(d.state);
  WaitForJobs(d.state);
  EXPECT_EQ(d.state.analysis.result->request.source, AnalysisSource::kCurrentValues);
  EXPECT_EQ(d.state.analysis.result->request.theta, d.state.model->Values());
}

TEST(WorkbenchAnalysis, ACancelledRunKeepsThePreviousResultsAndIsNotRetriedByItself) {
  // The case study (10 000 samples): a run takes tens of milliseconds, so the cancel below,
  // requested right after the start, always arrives while it is under way.
  WorkbenchDriver d;
  d.state.analysis.show_ahead = true;
  d.Open(kCaseStudy);
  WaitForJobs(d.state);
  ASSERT_TRUE(d.state.analysis.result) << d.state.analysis.last_failure;
  const AnalysisRequest previous = d.state.analysis.result->request;

  d.state.analysis.horizon = previous.horizon + 5;
  PollJobs(d.state);
  ASSERT_TRUE(AnalysisRunning(d.state));
  CancelAnalysis(d.state);
  WaitForJobs(d.state);
  ASSERT_TRUE(d.state.analysis.result);
  EXPECT_EQ(d.state.analysis.result->request, previous);
  EXPECT_NE(d.state.analysis.last_failure.find("cancelled"), std::string::npos);
  ASSERT_FALSE(d.state.messages.empty());
  EXPECT_EQ(d.state.messages.back().severity, Severity::kWarning);
  EXPECT_NE(d.state.messages.back().text.find("previous results are kept"), std::string::npos);
  d.state.view = View::kPredictions;
  d.Frame();
  EXPECT_FALSE(AnalysisRunning(d.state));
  EXPECT_NE(d.Text().find("The plots show the previous results"), std::string::npos);

  // "Compute again" runs it.
  RecomputeAnalysis(d.state);
  PollJobs(d.state);
  WaitForJobs(d.state);
  EXPECT_EQ(d.state.analysis.result->request.horizon, previous.horizon + 5);
  EXPECT_TRUE(d.state.analysis.last_failure.empty());
}

TEST(WorkbenchAnalysis, AFailedRunKeepsThePreviousResultsAndSaysWhy) {
  WorkbenchDriver d;
  d.Open(kTestProject);
  WaitForJobs(d.state);
  ASSERT_TRUE(d.state.analysis.result);
  const std::vector<double> theta = d.state.analysis.result->request.theta;

  // A negative measurement variance: the model cannot be evaluated.
  const int s2 = d.state.model->ParameterIndex("s2");
  ASSERT_GE(s2, 0);
  d.state.model->parameters[static_cast<std::size_t>(s2)].value = -1.0;
  ++d.state.model_revision;
  PollJobs(d.state);
  WaitForJobs(d.state);
  ASSERT_TRUE(d.state.analysis.result);
  EXPECT_EQ(d.state.analysis.result->request.theta, theta);
  EXPECT_NE(d.state.analysis.last_failure.find("negative"), std::string::npos)
      << d.state.analysis.last_failure;
  ASSERT_FALSE(d.state.messages.empty());
  EXPECT_EQ(d.state.messages.back().severity, Severity::kError);
  d.state.view = View::kResiduals;
  d.Frame();
  EXPECT_NE(d.Text().find("The plots show the previous results"), std::string::npos);
}

// A project in a temporary directory: the test model, a dataset with missing outputs (a gap,
// the first rows, scattered cells) and one without the output column.
class MissingOutputs : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() /
           ("greybench_analysis_test_" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir_);
    std::ifstream in(kTestData);
    std::ofstream gaps(dir_ / "gaps.csv");
    std::ofstream no_output(dir_ / "no_output.csv");
    std::string line;
    int row = -1;
    while (std::getline(in, line)) {
      if (line.empty() || line[0] == '#') continue;
      const std::size_t last = line.rfind(',');
      no_output << line.substr(0, last) << "\n";
      const bool missing = (row >= 0 && row < 5) || (row >= 100 && row < 180) || row % 7 == 3;
      gaps << (missing ? line.substr(0, last + 1) + "NA" : line) << "\n";
      ++row;
    }
    std::filesystem::copy_file(kTestModel, dir_ / "model.json",
                               std::filesystem::copy_options::overwrite_existing);
    std::ofstream(dir_ / "project.json")
        << R"({"greybench_project": 1, "name": "gaps", "model": "model.json",
              "datasets": ["gaps.csv", "no_output.csv"]})";
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }
  std::filesystem::path dir_;
};

TEST_F(MissingOutputs, NothingCrashesAndTheUnusableDatasetSaysWhy) {
  WorkbenchDriver d;
  d.Open((dir_ / "project.json").string());
  ASSERT_TRUE(d.state.project) << d.state.open_error;
  WaitForJobs(d.state);
  ASSERT_TRUE(d.state.analysis.result) << d.state.analysis.last_failure;
  const Analysis& a = *d.state.analysis.result;
  ASSERT_EQ(a.datasets.size(), 2u);
  const DatasetAnalysis& gaps = a.datasets[0];
  ASSERT_TRUE(gaps.error.empty()) << gaps.error;
  const OutputAnalysis& o = gaps.outputs[0];
  int used = 0;
  for (std::size_t k = 0; k < o.measured.size(); ++k) {
    if (std::isnan(o.measured[k])) {
      EXPECT_TRUE(std::isnan(o.residual[k])) << "k = " << k;
      EXPECT_TRUE(std::isnan(o.standardized[k])) << "k = " << k;
    }
    used += std::isfinite(o.standardized[k]) ? 1 : 0;
  }
  EXPECT_EQ(o.n_observed, used);
  EXPECT_GT(used, 0);
  EXPECT_TRUE(o.diagnostics) << o.diagnose_error;
  EXPECT_NE(a.datasets[1].error.find("ilambda"), std::string::npos) << a.datasets[1].error;

  for (View view : {View::kPredictions, View::kResiduals}) {
    d.state.view = view;
    for (int dataset : {0, 1}) {
      d.state.analysis.dataset = dataset;
      d.Frame();
      const std::string log = d.Text();
      EXPECT_EQ(log.find("nan"), std::string::npos) << log;
      if (dataset == 1) {
        EXPECT_NE(log.find("cannot be used"), std::string::npos) << log;
      }
    }
  }
}

TEST(WorkbenchAnalysis, PredictionsOpenWhereSamplesCanBeToldApartAndADoubleClickShowsAll) {
  // A 10 000-sample PRBS record drawn whole is a solid band: the time axis of the Predictions
  // and Residuals views opens on its first kInitialTimeWindow samples (3 s of the case study,
  // some 4 pixels a sample), says so, and a double-click on a time plot shows the whole record.
  WorkbenchDriver d;
  d.Open(kCaseStudy);
  WaitForJobs(d.state);
  ASSERT_TRUE(d.state.analysis.result) << d.state.analysis.last_failure;
  d.state.view = View::kPredictions;
  for (int i = 0; i < 3; ++i) d.Frame();
  const DatasetAnalysis& ds = d.state.analysis.result->datasets[0];
  ASSERT_GT(ds.time.size(), 5u * static_cast<std::size_t>(kInitialTimeWindow));
  const plot::Range& x = d.state.analysis.time_x.range;
  EXPECT_EQ(x.min, ds.time.front());
  EXPECT_EQ(x.max, ds.time[static_cast<std::size_t>(kInitialTimeWindow) - 1]);
  const std::string hint = "double-click a time plot for the whole record";
  EXPECT_NE(d.Text().find(hint), std::string::npos) << d.Text();

  // Double-click in the plot: press, release, press, release in place.
  ImGuiWindow* view = WorkbenchDriver::ViewWindow();
  ASSERT_NE(view, nullptr);
  const ImRect r = view->Rect();
  d.MouseTo(ImVec2(0.5f * (r.Min.x + r.Max.x), r.Min.y + 0.6f * r.GetHeight()));
  d.Press();
  d.Release();
  d.Press();
  d.Release();
  d.Frame();
  EXPECT_LE(x.min, ds.time.front());
  EXPECT_GE(x.max, ds.time.back());
  EXPECT_EQ(d.Text().find(hint), std::string::npos);

  // The Residuals view shares the axis; choosing a dataset (the selector calls OpenTimeWindow)
  // opens on its first samples again.
  d.state.view = View::kResiduals;
  d.Frame();
  EXPECT_GE(x.max, ds.time.back());
  OpenTimeWindow(d.state.analysis);
  d.Frame();
  EXPECT_EQ(x.max, ds.time[static_cast<std::size_t>(kInitialTimeWindow) - 1]);
  EXPECT_NE(d.Text().find(hint), std::string::npos);
}

}  // namespace
}  // namespace gb::ui
