// The operating points view driven through synthetic ImGui input: click Run, watch the sweep
// job finish, read Table 2; cancel a long sweep and keep the previous table; a wrong
// "operating_points" key and a project without one.
//
// The table the GUI installs is checked against core's Sweep run directly on the same files
// with options written out here (the GUI must add nothing and lose nothing on the way).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "core/model/model.h"
#include "core/online/estimator.h"
#include "core/online/monitor.h"
#include "core/project/linearised.h"
#include "core/project/problem.h"
#include "core/project/result_file.h"
#include "core/project/sweep.h"
#include "core/util/json.h"
#include "tests/shortened_data.h"
#include "tests/ui/workbench_driver.h"
#include "ui/format.h"

#ifndef GREYBENCH_SOURCE_DIR
#error "GREYBENCH_SOURCE_DIR must name the source tree (tests/ui/CMakeLists.txt sets it)"
#endif

namespace gb::ui {
namespace {

using std::chrono::milliseconds;
using testing::FindButton;
using testing::kCancelDeadline;
using testing::kSource;
using testing::WorkbenchDriver;

const std::string kData = kSource + "/tests/data/ui/sweep/";
const std::string kSweepProject = kData + "project.json";
const std::string kBadProject = kData + "bad_project.json";
const std::string kNoSweepProject = kSource + "/tests/data/ui/project.json";
constexpr milliseconds kSweepTimeout{120000};

// The first cell `name` and the `n` cells after it of a table row, from ImGui's log of a table
// ("| tau_fv [s] | 0.07555 (0.0051) | ... |"; a row ending in an empty cell runs on into the
// next on the same log line); empty when there is no such row.
std::vector<std::string> Row(const std::string& log, const std::string& name, std::size_t n) {
  const std::size_t start = log.find("| " + name + " |");
  if (start == std::string::npos) return {};
  std::vector<std::string> cells;
  std::size_t at = start + 2;
  for (std::size_t end; cells.size() <= n && (end = log.find(" |", at)) != std::string::npos;
       at = end + 3)
    cells.push_back(log.substr(at, end - at));
  return cells;
}

// core's sweep of the test project: the case study's model on its three files, the project's
// relations, one thread per fit (as the GUI runs it).
project::SweepResult SweepDirectly() {
  auto spec = model::LoadModelFile(kSource + "/assets/models/fuel_film.json");
  EXPECT_TRUE(spec.ok());
  project::SweepOptions options;
  options.estimate.threads = 1;
  options.speed_tag = "n_rpm";
  options.trend_parameter = "X";
  options.trend_tag = "alpha_deg";
  options.mean_of = {"tau_fv", "tau_ff"};
  // Under the sanitizers the driver's sweep runs the quick way (SweepState::quick: each point's
  // delay profile evaluated at its estimate, no extra starts); so does this one there, so that
  // the two compare like with like at a third of the cost (the estimates are the same either way).
  options.estimate.full_delay_profile = !kSanitized;
  if (kSanitized) options.estimate.starts_on_bound = 0;
  auto result = project::Sweep(
      *spec, project::PlainDatasets({kData + "p1.csv", kData + "p2.csv", kData + "p3.csv"}),
      options);
  EXPECT_TRUE(result.ok()) << result.error().ToString();
  return *result;
}

TEST(WorkbenchSweep, ClickingRunInstallsTheSweepCoreComputesAndTheViewShowsTable2) {
  WorkbenchDriver d;
  d.Open(kSweepProject);
  ASSERT_TRUE(d.state.model) << d.state.model_error;
  ASSERT_TRUE(d.state.sweep.spec) << d.state.sweep.spec_error;
  d.state.view = View::kOperatingPoints;
  d.Frame();
  EXPECT_NE(d.Text().find("No sweep yet"), std::string::npos);

  const std::optional<ImVec2> run = FindButton(d, "Run");
  ASSERT_TRUE(run) << "the Run button was not found in the operating points view";
  d.Click(*run);
  EXPECT_TRUE(SweepRunning(d.state) || d.state.sweep.result);
  ASSERT_TRUE(d.FramesUntil([&] { return !SweepRunning(d.state); }, kSweepTimeout));
  d.Frame();
  ASSERT_TRUE(d.state.sweep.result) << d.state.sweep.last_failure;

  const project::SweepResult& gui = d.state.sweep.result->result;
  const project::SweepResult direct = SweepDirectly();
  ASSERT_EQ(gui.rows.size(), 3u);
  ASSERT_EQ(gui.rows.size(), direct.rows.size());
  for (std::size_t i = 0; i < direct.rows.size(); ++i) {
    const project::SweepRow& g = gui.rows[i];
    const project::SweepRow& c = direct.rows[i];
    EXPECT_EQ(g.point.name, c.point.name);
    EXPECT_EQ(g.point.values, c.point.values);
    EXPECT_DOUBLE_EQ(g.summary.loglik, c.summary.loglik) << c.point.name;
    EXPECT_EQ(g.summary.delays[0].estimate, c.summary.delays[0].estimate) << c.point.name;
    ASSERT_EQ(g.summary.parameters.size(), c.summary.parameters.size());
    for (std::size_t k = 0; k < c.summary.parameters.size(); ++k) {
      EXPECT_DOUBLE_EQ(g.summary.parameters[k].estimate, c.summary.parameters[k].estimate)
          << c.point.name << " " << c.summary.parameters[k].name;
    }
  }
  ASSERT_TRUE(gui.delay_vs_speed && direct.delay_vs_speed);
  EXPECT_DOUBLE_EQ(gui.delay_vs_speed->b, direct.delay_vs_speed->b);
  ASSERT_TRUE(gui.trend && direct.trend);
  EXPECT_DOUBLE_EQ(gui.trend->b, direct.trend->b);
  EXPECT_DOUBLE_EQ(gui.means.at("tau_fv").first, direct.means.at("tau_fv").first);

  // The view's table: a column per point, the tags with the project's labels, estimates with
  // standard errors, the mean over the points.
  const std::string log = d.Text();
  const std::vector<std::string> header = Row(log, "Point", 4);
  ASSERT_EQ(header.size(), 5u) << log;
  for (std::size_t i = 0; i < direct.rows.size(); ++i)
    EXPECT_EQ(header[i + 1], direct.rows[i].point.name);
  const std::vector<std::string> speed = Row(log, "n [rpm]", 4);
  ASSERT_EQ(speed.size(), 5u) << log;
  EXPECT_EQ(speed[1], FormatSig(direct.rows[0].point.values.at("n_rpm"), 4));
  const std::vector<std::string> tau = Row(log, "tau_fv [s]", 4);
  ASSERT_EQ(tau.size(), 5u) << log;
  for (std::size_t i = 0; i < direct.rows.size(); ++i) {
    const estimate::ParameterEstimate& p = direct.rows[i].summary.parameters[0];
    ASSERT_EQ(p.name, "tau_fv");
    ASSERT_TRUE(p.std_error);
    EXPECT_EQ(tau[i + 1], FormatSig(p.estimate, 4) + " (" + FormatSig(*p.std_error, 2) + ")");
  }
  const auto [mean, sd] = direct.means.at("tau_fv");
  EXPECT_EQ(tau[4], FormatSig(mean, 4) + " (" + FormatSig(sd, 2) + ")");
  const std::vector<std::string> delay = Row(log, "\xCE\x94t [s]", 4);
  ASSERT_EQ(delay.size(), 5u) << log;
  EXPECT_EQ(delay[1], FormatSig(direct.rows[0].summary.delays[0].estimate * 0.0125, 4));
  EXPECT_EQ(log.find("nan"), std::string::npos) << log;

  // Fig. 3's arrays: the points by ascending speed (f3, f1, f7), the curve c / n.
  const SweepFigures& f = *d.state.sweep.result;
  ASSERT_EQ(f.speed.size(), 3u);
  for (std::size_t k : {0u, 1u, 2u}) {
    const project::SweepRow& r = direct.rows[k == 0 ? 1 : k == 1 ? 0 : 2];
    EXPECT_EQ(f.speed[k], r.point.values.at("n_rpm"));
    EXPECT_DOUBLE_EQ(f.delay[k], r.summary.delays[0].estimate * r.sample_interval);
    EXPECT_DOUBLE_EQ(f.delay_bar[k], 0.5 * r.sample_interval);
  }
  ASSERT_FALSE(f.curve_speed.empty());
  EXPECT_EQ(f.curve_speed.front(), f.speed.front());
  EXPECT_EQ(f.curve_speed.back(), f.speed.back());
  for (std::size_t k = 0; k < f.curve_speed.size(); ++k)
    EXPECT_DOUBLE_EQ(f.curve_delay[k], direct.delay_vs_speed->b / f.curve_speed[k]);

  // The trend plot follows the choice of parameter.
  SelectTrend(d.state, "tau_ff", "alpha_deg");
  EXPECT_EQ(d.state.sweep.trend.parameter, "tau_ff");
  ASSERT_EQ(d.state.sweep.trend.y.size(), 3u);
  ASSERT_TRUE(d.state.sweep.trend.fit);
  std::vector<double> x, y;
  for (const project::SweepRow& r : direct.rows) {
    x.push_back(r.point.values.at("alpha_deg"));
    y.push_back(r.summary.parameters[1].estimate);  // tau_ff
  }
  EXPECT_DOUBLE_EQ(d.state.sweep.trend.fit->b, project::FitLine(x, y, true).b);
}

TEST(WorkbenchSweep, CancelStopsTheSweepWithin100msAndKeepsThePreviousTable) {
  WorkbenchDriver d;
  d.Open(kSweepProject);
  ASSERT_TRUE(d.state.sweep.spec) << d.state.sweep.spec_error;
  d.state.view = View::kOperatingPoints;
  ASSERT_TRUE(StartSweep(d.state));
  WaitForJobs(d.state);
  ASSERT_TRUE(d.state.sweep.result) << d.state.sweep.last_failure;
  const project::SweepResult first = d.state.sweep.result->result;
  d.Frame();

  // A long sweep (the six full-length case-study datasets), cancelled while it fits.
  d.state.sweep.spec->datasets.clear();
  for (const char* point : {"f1", "f2", "f3", "f4", "f7", "f8"})
    d.state.sweep.spec->datasets.push_back(
        data::PlainDataset(kSource + "/assets/data/fuel_" + point + ".csv"));
  const std::optional<ImVec2> run = FindButton(d, "Run");
  ASSERT_TRUE(run);
  d.Click(*run);
  ASSERT_TRUE(SweepRunning(d.state));
  ASSERT_TRUE(d.FramesUntil(
      [&] {
        if (!d.state.sweep.status) return false;
        for (SweepStatus::PointState s : d.state.sweep.status->states())
          if (s == SweepStatus::PointState::kFitting) return true;
        return false;
      },
      kSweepTimeout));
  EXPECT_NE(d.Text().find("Sweeping"), std::string::npos);
  const std::optional<ImVec2> cancel =
      d.Find(WorkbenchDriver::ViewWindow(), d.ViewItemId("Cancel"), run->y);
  ASSERT_TRUE(cancel) << "the Cancel button was not found next to Run";
  ASSERT_TRUE(SweepRunning(d.state)) << "the sweep ended before it could be cancelled";
  d.MouseTo(*cancel);
  d.Press();
  const auto clicked = std::chrono::steady_clock::now();
  d.Release();  // the button acts here: CancelSweep
  d.state.sweep.job.Wait();
  const auto stopped = std::chrono::steady_clock::now();
  EXPECT_LT(stopped - clicked, kCancelDeadline);
  RecordProperty(
      "cancel_ms",
      static_cast<int>(std::chrono::duration_cast<milliseconds>(stopped - clicked).count()));

  d.Frame();  // installs the outcome
  EXPECT_FALSE(SweepRunning(d.state));
  ASSERT_TRUE(d.state.sweep.result);
  const project::SweepResult& kept = d.state.sweep.result->result;
  ASSERT_EQ(kept.rows.size(), first.rows.size());
  for (std::size_t i = 0; i < first.rows.size(); ++i) {
    EXPECT_EQ(kept.rows[i].dataset, first.rows[i].dataset);
    EXPECT_EQ(kept.rows[i].summary.theta, first.rows[i].summary.theta);
  }
  EXPECT_NE(d.state.sweep.last_failure.find("cancelled"), std::string::npos);
  ASSERT_FALSE(d.state.messages.empty());
  EXPECT_EQ(d.state.messages.back().severity, Severity::kWarning);
  EXPECT_NE(d.state.messages.back().text.find("previous table is kept"), std::string::npos);
  EXPECT_NE(d.Text().find("from the previous sweep"), std::string::npos);
}

TEST(WorkbenchSweep, AFailedSweepNamesTheFileAndKeepsThePreviousTable) {
  WorkbenchDriver d;
  d.Open(kSweepProject);
  ASSERT_TRUE(d.state.sweep.spec) << d.state.sweep.spec_error;
  // Under the sanitizers the first 400 rows of each record (the point is the failure's path).
  for (data::DatasetSpec& dataset : d.state.sweep.spec->datasets)
    dataset.file = gb::testing::ShortenedUnderSanitizers(dataset.file, 400);
  ASSERT_TRUE(StartSweep(d.state));
  WaitForJobs(d.state);
  ASSERT_TRUE(d.state.sweep.result) << d.state.sweep.last_failure;
  const double loglik = d.state.sweep.result->result.rows[0].summary.loglik;

  d.state.sweep.spec->datasets.push_back(data::PlainDataset(kData + "no_such_point.csv"));
  std::string why;
  ASSERT_TRUE(StartSweep(d.state, &why)) << why;
  WaitForJobs(d.state);
  ASSERT_TRUE(d.state.sweep.result);
  EXPECT_EQ(d.state.sweep.result->result.rows[0].summary.loglik, loglik);
  EXPECT_TRUE(d.state.sweep.last_failure_is_error);
  EXPECT_NE(d.state.sweep.last_failure.find("no_such_point.csv"), std::string::npos)
      << d.state.sweep.last_failure;
  ASSERT_FALSE(d.state.messages.empty());
  EXPECT_EQ(d.state.messages.back().severity, Severity::kError);
  EXPECT_NE(d.state.messages.back().text.find("previous table is kept"), std::string::npos);
}

TEST(WorkbenchSweep, AProjectWithoutTheKeyCanSweepItsOwnDatasets) {
  WorkbenchDriver d;
  d.Open(kNoSweepProject);
  ASSERT_TRUE(d.state.project);
  // Two tagged datasets in the project (as if it listed them).
  d.state.project->datasets = project::PlainDatasets({kData + "p1.csv", kData + "p3.csv"});
  d.state.view = View::kOperatingPoints;
  d.Frame();
  EXPECT_NE(d.Text().find("Sweep the project's 2 datasets"), std::string::npos);
  SweepProjectDatasets(d.state);  // what the button does
  ASSERT_TRUE(d.state.sweep.spec);
  EXPECT_TRUE(d.state.sweep.spec->datasets_from_project);
  EXPECT_EQ(data::Files(d.state.sweep.spec->datasets), data::Files(d.state.project->datasets));
  std::string why;
  ASSERT_TRUE(StartSweep(d.state, &why)) << why;
  WaitForJobs(d.state);
  ASSERT_TRUE(d.state.sweep.result) << d.state.sweep.last_failure;
  ASSERT_EQ(d.state.sweep.result->columns.size(), 2u);
  EXPECT_EQ(d.state.sweep.result->columns[0], "f1");
  EXPECT_EQ(d.state.sweep.result->columns[1], "f7");
}

TEST(WorkbenchSweep, AWrongOperatingPointsKeyIsShownWithTheFileAndJsonPath) {
  WorkbenchDriver d;
  d.Open(kBadProject);
  ASSERT_TRUE(d.state.project) << d.state.open_error;  // the rest of the project is fine
  EXPECT_FALSE(d.state.sweep.spec);
  const std::string& error = d.state.sweep.spec_error;
  EXPECT_NE(error.find("bad_project.json"), std::string::npos) << error;
  EXPECT_NE(error.find("operating_points.trend.tag"), std::string::npos) << error;
  std::string why;
  EXPECT_FALSE(StartSweep(d.state, &why));
  EXPECT_EQ(why, error);
  d.state.view = View::kOperatingPoints;
  d.Frame();
  const std::string log = d.Text();
  EXPECT_NE(log.find("operating_points.trend.tag"), std::string::npos) << log;
  ASSERT_FALSE(d.state.messages.empty());
  bool reported = false;
  for (const Message& m : d.state.messages)
    reported = reported || (m.severity == Severity::kError &&
                            m.text.find("operating_points.trend.tag") != std::string::npos);
  EXPECT_TRUE(reported);
}

TEST(WorkbenchSweep, AProjectWithoutTheKeyIsToldHowToAddOne) {
  WorkbenchDriver d;
  d.Open(kNoSweepProject);
  ASSERT_TRUE(d.state.project);
  EXPECT_FALSE(d.state.sweep.spec);
  EXPECT_TRUE(d.state.sweep.spec_error.empty());
  std::string why;
  EXPECT_FALSE(StartSweep(d.state, &why));
  EXPECT_NE(why.find("operating_points"), std::string::npos) << why;
  d.state.view = View::kOperatingPoints;
  d.Frame();
  const std::string log = d.Text();
  EXPECT_NE(log.find("names no operating points"), std::string::npos) << log;
  EXPECT_NE(log.find("\"operating_points\""), std::string::npos) << log;
  // One dataset: nothing to sweep, so no offer to.
  EXPECT_EQ(log.find("Sweep the project's"), std::string::npos) << log;
}

TEST(WorkbenchSweep, ANameTheModelLacksIsRefusedWithTheJsonPath) {
  WorkbenchDriver d;
  d.Open(kSweepProject);
  ASSERT_TRUE(d.state.sweep.spec);
  d.state.sweep.spec->trend_parameter = "Y";
  std::string why;
  EXPECT_FALSE(StartSweep(d.state, &why));
  EXPECT_NE(why.find("project.json: operating_points.trend.parameter: the model has no "
                     "parameter 'Y'"),
            std::string::npos)
      << why;
}

// ---- a nonlinear fit linearised beside the per-point fits (operating_points.linearised) ---------

const std::string kEngineData = kSource + "/tests/data/ui/engine_sweep/";

TEST(WorkbenchSweep, ALinearisedNonlinearFitIsShownBesideThePerPointFits) {
  WorkbenchDriver d;
  d.Open(kEngineData + "project.json");
  ASSERT_TRUE(d.state.model) << d.state.model_error;
  ASSERT_TRUE(d.state.sweep.spec && d.state.sweep.spec->linearised) << d.state.sweep.spec_error;
  // Under the sanitizers the first 800 rows of each record (the point there is the code path).
  for (data::DatasetSpec& dataset : d.state.sweep.spec->datasets)
    dataset.file = gb::testing::ShortenedUnderSanitizers(dataset.file, 800);
  d.state.view = View::kOperatingPoints;
  d.Frame();
  // Before the sweep the view says what Run will do, naming both models' files.
  EXPECT_NE(d.Text().find("fuel_film_pade.json"), std::string::npos) << d.Text();
  EXPECT_NE(d.Text().find("engine_mvem.json"), std::string::npos) << d.Text();
  const std::optional<ImVec2> run = FindButton(d, "Run");
  ASSERT_TRUE(run);
  d.Click(*run);
  ASSERT_TRUE(d.FramesUntil([&] { return !SweepRunning(d.state); }, kSweepTimeout));
  d.Frame();
  ASSERT_TRUE(d.state.sweep.result) << d.state.sweep.last_failure;
  const SweepFigures& f = *d.state.sweep.result;
  ASSERT_TRUE(f.linearised) << f.linearised_error;
  ASSERT_EQ(f.result.rows.size(), 3u);

  // The same linearisation from the files, by core alone.
  const std::vector<std::string> files = data::Files(d.state.sweep.spec->datasets);
  auto direct = project::LineariseAtPoints(*d.state.sweep.spec->linearised,
                                           kSource + "/assets/models/engine_mvem.json", files);
  ASSERT_TRUE(direct.ok()) << direct.error().ToString();
  ASSERT_EQ(direct->quantities, f.linearised->quantities);

  // Beneath each per-point parameter of a quantity's name, a row of the linearised values with
  // their standard errors, and per cell the difference in combined standard errors.
  int rows_seen = 0;
  for (std::size_t r = 1; r < f.table.size(); ++r) {
    if (!f.table[r].linearised) continue;
    ++rows_seen;
    const std::string parameter = f.table[r - 1].label.substr(0, f.table[r - 1].label.find(' '));
    ASSERT_FALSE(f.table[r - 1].linearised);
    for (std::size_t i = 0; i < 3; ++i) {
      const auto [value, se] = direct->At(i, parameter);
      ASSERT_TRUE(std::isfinite(value) && std::isfinite(se)) << parameter;
      EXPECT_EQ(f.table[r].cells[i], FormatSig(value, 4) + " (" + FormatSig(se, 2) + ")")
          << parameter << " at " << f.columns[i];
      const estimate::ParameterEstimate* p = nullptr;
      for (const auto& q : f.result.rows[i].summary.parameters)
        if (q.name == parameter) p = &q;
      ASSERT_TRUE(p);
      if (!p->std_error) {
        EXPECT_TRUE(std::isnan(f.table[r].z[i]));
        continue;
      }
      EXPECT_NEAR(f.table[r].z[i], (value - p->estimate) / std::hypot(se, *p->std_error), 1e-12)
          << parameter << " at " << f.columns[i];
    }
  }
  EXPECT_EQ(rows_seen, 5);  // tau_fv, tau_ff, X, Kb, delay
  const std::string log = d.Text();
  EXPECT_NE(log.find("linearised"), std::string::npos) << log;
  EXPECT_EQ(log.find("nan"), std::string::npos) << log;

  // Fig. 3: the delay parameter ± 1 SE per point, and the linearised delay c_d / n, which at a
  // steady state of the given speed is the fit's c_d over the point's speed, exactly.
  auto spec = model::LoadModelFile(kSource + "/assets/models/engine_mvem.json");
  ASSERT_TRUE(spec.ok());
  auto fit = project::LoadReference(kSource + "/assets/results/engine_mvem.json", *spec);
  ASSERT_TRUE(fit.ok()) << fit.error().ToString();
  double cd = 0;
  for (std::size_t k = 0; k < spec->parameters.size(); ++k)
    if (spec->parameters[k].name == "cd") cd = fit->theta[k];
  ASSERT_GT(cd, 0);
  EXPECT_TRUE(f.delay_bar_is_se);
  ASSERT_EQ(f.speed.size(), 3u);
  ASSERT_EQ(f.lin_speed.size(), 3u);
  EXPECT_TRUE(std::is_sorted(f.lin_speed.begin(), f.lin_speed.end()));
  for (std::size_t k = 0; k < 3; ++k) {
    EXPECT_EQ(f.lin_speed[k], f.speed[k]);
    EXPECT_NEAR(f.lin_delay[k], cd / f.lin_speed[k], 1e-12 * f.lin_delay[k]);
    EXPECT_GT(f.lin_delay_se[k], 0);
    EXPECT_GT(f.delay_bar[k], 0);  // the per-point delay's SE
    EXPECT_NEAR(f.lin_speed_drawn[k] - f.lin_speed[k], 0.012 * (f.speed[2] - f.speed[0]), 1e-9);
  }

  // The trend plot: X's linearised values at the same throttle angles.
  const TrendPlot& t = d.state.sweep.trend;
  ASSERT_EQ(t.parameter, "X");
  ASSERT_EQ(t.lin_x.size(), 3u);
  EXPECT_EQ(t.lin_x, t.x);
  for (std::size_t k = 0; k < 3; ++k) {
    std::size_t i = 0;
    while (f.result.rows[i].point.values.at("alpha_deg") != t.lin_x[k]) ++i;
    EXPECT_EQ(t.lin_y[k], direct->At(i, "X").first);
  }
}

TEST(WorkbenchSweep, ALinearisationThatFailsIsNamedAndTheSweepIsKept) {
  WorkbenchDriver d;
  d.Open(kSweepProject);
  ASSERT_TRUE(d.state.sweep.spec) << d.state.sweep.spec_error;
  project::LinearisedSpec lin;
  lin.result = kData + "no_such_result.json";
  lin.model = kSource + "/assets/models/engine_mvem.json";
  lin.quantities = {{"X", "-B_mff_mfi/A_mff_mff"}};
  d.state.sweep.spec->linearised = lin;
  ASSERT_TRUE(StartSweep(d.state));
  WaitForJobs(d.state);
  d.state.view = View::kOperatingPoints;
  d.Frame();
  ASSERT_TRUE(d.state.sweep.result) << d.state.sweep.last_failure;
  const SweepFigures& f = *d.state.sweep.result;
  EXPECT_EQ(f.result.rows.size(), 3u);
  EXPECT_FALSE(f.linearised);
  EXPECT_NE(f.linearised_error.find("no_such_result.json"), std::string::npos)
      << f.linearised_error;
  for (const SweepTableRow& row : f.table) EXPECT_FALSE(row.linearised) << row.label;
  EXPECT_NE(d.Text().find("could not be linearised"), std::string::npos) << d.Text();
  const bool told =
      std::any_of(d.state.messages.begin(), d.state.messages.end(), [](const auto& m) {
        return m.severity == Severity::kError &&
               m.text.find("no_such_result.json") != std::string::npos;
      });
  EXPECT_TRUE(told);
}

}  // namespace
}  // namespace gb::ui
