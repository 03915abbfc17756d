// The operating-point sweep over the six bundled virtual-dyno fuel datasets (assets/data).
#include "core/project/sweep.h"

#include <atomic>
#include <chrono>
#include <cmath>
#include <map>
#include <mutex>
#include <thread>

#include <gtest/gtest.h>

#include "core/project/problem.h"
#include "core/sim/dyno.h"
#include "core/util/json.h"
#include "tests/shortened_data.h"

namespace gb::project {
namespace {

const std::string kRoot = GREYBENCH_SOURCE_DIR;

TEST(Sweep, RecoversEveryOperatingPointOfTable2FromTheBundledDynoData) {
  auto spec = model::LoadModelFile(kRoot + "/assets/models/fuel_film.json");
  ASSERT_TRUE(spec.ok()) << spec.error().ToString();
  // Not under the sanitizers: three whole points are among the slowest of any test there
  // (docs/benchmarks.md, "Timings behind the code's limits"), and
  // the sweep's code path (fits, the delay search, the relations of Fig. 3-4) runs under them in
  // WorkbenchSweep.ClickingRunInstallsTheSweepCoreComputesAndTheViewShowsTable2 (core's Sweep on
  // three points, beside the GUI's) and Sweep.CancelStops…; the point of this test, the whole of
  // Table 2 recovered, is the release suite's.
  if (kSanitized) GTEST_SKIP() << "the release suite's: see the comment";
  std::vector<std::string> files;
  const auto points = sim::PaperFuelPoints();
  for (std::size_t i = 0; i < points.size(); ++i)
    files.push_back(kRoot + "/assets/data/fuel_" + points[i].name + ".csv");
  SweepOptions options;
  auto result = Sweep(*spec, PlainDatasets(files), options);
  ASSERT_TRUE(result.ok()) << result.error().ToString();
  ASSERT_EQ(result->rows.size(), files.size());
  for (const auto& row : result->rows) {
    const auto truth = *sim::FindFuelPoint(row.point.name);
    EXPECT_EQ(row.point.values.at("n_rpm"), truth.speed_rpm);
    EXPECT_TRUE(row.summary.converged) << row.point.name << ": " << row.summary.message;
    // The delay, exactly.
    EXPECT_NEAR(row.summary.delays[0].estimate * 0.0125, truth.delay_s, 1e-12) << row.point.name;
    // The physical parameters within 3 standard errors. (The noise variances are biased by the
    // anti-alias filters, as docs/case-study.md explains, and are not checked here.)
    const std::map<std::string, double> physical = {
        {"tau_fv", truth.tau_fv}, {"tau_ff", truth.tau_ff}, {"X", truth.X}, {"Kb", truth.Kb}};
    for (const auto& p : row.summary.parameters) {
      if (!physical.count(p.name)) continue;
      ASSERT_TRUE(p.std_error.has_value()) << row.point.name << " " << p.name;
      EXPECT_LT(std::abs(p.estimate - physical.at(p.name)), 3 * *p.std_error)
          << row.point.name << " " << p.name << " = " << p.estimate << " ± " << *p.std_error
          << ", truth " << physical.at(p.name);
    }
  }
  // Fig. 3: the delay falls with speed, Δt = c / n with c near the dyno's own relation.
  ASSERT_TRUE(result->delay_vs_speed.has_value());
  const double c_truth = sim::ExhaustDelay(1.0);
  EXPECT_LT(std::abs(result->delay_vs_speed->b - c_truth), 3 * result->delay_vs_speed->se_b);
  // Fig. 4: X grows with the throttle angle.
  ASSERT_TRUE(result->trend.has_value());
  EXPECT_GT(result->trend->b, 0.0);
  // The tables.
  EXPECT_NE(result->Markdown().find("| f1 |"), std::string::npos);
  EXPECT_NE(result->Csv().find("tau_fv_se"), std::string::npos);
}

TEST(Sweep, ReadsTheOperatingPointTagOfADataFile) {
  auto p = ReadOperatingPoint(kRoot + "/assets/data/fuel_f7.csv");
  ASSERT_TRUE(p.ok());
  EXPECT_EQ(p->name, "f7");
  EXPECT_EQ(p->values.at("alpha_deg"), 36.5);
  auto untagged = ReadOperatingPoint(std::string(GREYBENCH_TEST_DATA_DIR) + "/cli/fuel.csv");
  ASSERT_TRUE(untagged.ok());
  EXPECT_EQ(untagged->name, "fuel");
  EXPECT_TRUE(untagged->values.empty());
}

// Under the sanitizers, the first 2 000 rows of each (the cancelling tests' point is the code
// path of stopping fits under way).
std::vector<std::string> BundledFuelFiles() {
  std::vector<std::string> files;
  for (const auto& p : sim::PaperFuelPoints())
    files.push_back(
        testing::ShortenedUnderSanitizers(kRoot + "/assets/data/fuel_" + p.name + ".csv", 2000));
  return files;
}

TEST(Sweep, ACancelSetBeforehandStartsNoFit) {
  auto spec = model::LoadModelFile(kRoot + "/assets/models/fuel_film.json");
  ASSERT_TRUE(spec.ok());
  std::atomic<bool> cancel{true};
  SweepOptions options;
  options.estimate.cancel = &cancel;
  int reports = 0;
  options.progress = [&](const SweepProgress&) { ++reports; };
  auto result = Sweep(*spec, PlainDatasets(BundledFuelFiles()), options);
  ASSERT_TRUE(result.ok()) << result.error().ToString();
  EXPECT_TRUE(result->cancelled);
  EXPECT_TRUE(result->rows.empty());
  EXPECT_EQ(reports, 0);
  EXPECT_FALSE(result->delay_vs_speed.has_value());
}

TEST(Sweep, CancelStopsTheFitsUnderWayWithin100msAndKeepsTheFinishedPoints) {
  auto spec = model::LoadModelFile(kRoot + "/assets/models/fuel_film.json");
  ASSERT_TRUE(spec.ok());
  const std::vector<std::string> files = BundledFuelFiles();
  std::atomic<bool> cancel{false};
  std::mutex mutex;
  std::vector<int> started, finished;
  SweepOptions options;
  options.parallel = 2;
  options.estimate.cancel = &cancel;
  options.progress = [&](const SweepProgress& p) {
    const std::lock_guard<std::mutex> lock(mutex);
    (p.finished ? finished : started).push_back(p.dataset);
  };
  std::chrono::steady_clock::time_point cancelled_at;
  std::thread canceller([&] {
    // Cancel once the first fit has finished and others are under way.
    for (;;) {
      {
        const std::lock_guard<std::mutex> lock(mutex);
        if (!finished.empty()) break;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    cancelled_at = std::chrono::steady_clock::now();
    cancel = true;
  });
  auto result = Sweep(*spec, PlainDatasets(files), options);
  const auto returned_at = std::chrono::steady_clock::now();
  canceller.join();
  ASSERT_TRUE(result.ok()) << result.error().ToString();
  EXPECT_TRUE(result->cancelled);
  EXPECT_LT(returned_at - cancelled_at, std::chrono::milliseconds(100));
  // Every start was reported with its end; the rows are fits that finished, each converged.
  EXPECT_EQ(started.size(), finished.size());
  EXPECT_LT(started.size(), files.size()) << "the sweep was not stopped";
  ASSERT_GE(result->rows.size(), 1u);
  EXPECT_LT(result->rows.size(), started.size());
  for (const SweepRow& row : result->rows) {
    EXPECT_FALSE(row.summary.cancelled);
    EXPECT_TRUE(row.summary.converged) << row.dataset;
  }
  EXPECT_TRUE(result->means.empty());
  EXPECT_FALSE(result->trend.has_value());
}

TEST(Sweep, FitLineMatchesTheClosedFormOfSimpleRegression) {
  // y = 1 + 2 x + e with residuals (+0.1, -0.2, +0.1) at x = 0, 1, 2: the closed forms
  // b = Sxy / Sxx, a = ȳ - b x̄, s² = RSS / (n - 2), se_b = s / sqrt(Sxx),
  // se_a = s sqrt(1/n + x̄² / Sxx).
  const std::vector<double> x = {0, 1, 2}, y = {1.1, 2.8, 5.1};
  const LinearFit f = FitLine(x, y, true);
  const double xbar = 1, ybar = 9.0 / 3, sxx = 2, sxy = (-1) * (1.1 - ybar) + 1 * (5.1 - ybar);
  const double b = sxy / sxx, a = ybar - b * xbar;
  double rss = 0;
  for (int i = 0; i < 3; ++i) rss += std::pow(y[i] - a - b * x[i], 2);
  const double s = std::sqrt(rss / 1);
  EXPECT_NEAR(f.b, b, 1e-12);
  EXPECT_NEAR(f.a, a, 1e-12);
  EXPECT_NEAR(f.se_b, s / std::sqrt(sxx), 1e-12);
  EXPECT_NEAR(f.se_a, s * std::sqrt(1.0 / 3 + xbar * xbar / sxx), 1e-12);
  EXPECT_EQ(f.n, 3);
  // Through the origin: b = Σxy / Σx², se_b = s / sqrt(Σx²) with s² = RSS / (n - 1).
  const std::vector<double> u = {1, 2, 4}, v = {2.1, 3.9, 8.2};
  const LinearFit g = FitLine(u, v, false);
  const double sxx0 = 1 + 4 + 16, sxy0 = 2.1 + 7.8 + 32.8;
  double rss0 = 0;
  for (int i = 0; i < 3; ++i) rss0 += std::pow(v[i] - sxy0 / sxx0 * u[i], 2);
  EXPECT_NEAR(g.b, sxy0 / sxx0, 1e-12);
  EXPECT_EQ(g.a, 0.0);
  EXPECT_NEAR(g.se_b, std::sqrt(rss0 / 2) / std::sqrt(sxx0), 1e-12);
  // Too few points: nothing fitted.
  EXPECT_EQ(FitLine({1, 2}, {3, 4}, true).b, 0.0);
}

}  // namespace
}  // namespace gb::project
