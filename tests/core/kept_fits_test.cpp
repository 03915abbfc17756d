// A fit's summary written as a result file and read back (EstimateSummary::FromJson), a fit
// stopped by the user summarised at its best point (StoppedSummary), and the kept-fits folder
// beside a project (core/project/kept_fits.h).
#include "core/project/kept_fits.h"

#include <atomic>
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>
#include <unistd.h>

#include "core/data/import.h"
#include "core/estimate/estimate.h"
#include "core/project/problem.h"
#include "core/project/project.h"
#include "core/project/result_file.h"
#include "core/util/file.h"

namespace gb {
namespace {

namespace fs = std::filesystem;
const std::string kData = GREYBENCH_TEST_DATA_DIR;

filter::Likelihood FuelFilm() {
  auto spec = model::LoadModelFile(kData + "/ui/fuel_film.json");
  EXPECT_TRUE(spec.ok());
  auto problem = project::LoadProblem(*spec, {kData + "/ui/f1.csv"});
  EXPECT_TRUE(problem.ok());
  auto likelihood = project::MakeLikelihood(*problem);
  EXPECT_TRUE(likelihood.ok());
  return std::move(likelihood).value();
}

estimate::EstimateSummary FitFuelFilm(bool profile_intervals) {
  estimate::EstimateOptions options;
  options.threads = 1;
  options.profile_intervals = profile_intervals;
  auto summary = estimate::Estimate(FuelFilm(), options);
  EXPECT_TRUE(summary.ok());
  return std::move(summary).value();
}

TEST(ResultFile, ASummaryReadBackWritesTheSameFileAndTheSameReport) {
  for (bool profiles : {false, true}) {
    const estimate::EstimateSummary s = FitFuelFilm(profiles);
    const Json j = s.ToJson();
    // Through text, as the file is: every double must come back to the last bit.
    auto back = estimate::EstimateSummary::FromJson(Json::parse(j.dump(1)), "fit.json");
    ASSERT_TRUE(back.ok()) << back.error().ToString();
    EXPECT_EQ(back->ToJson(), j);
    EXPECT_EQ(back->Report(), s.Report());
    EXPECT_EQ(back->theta, s.theta);
    // The covariance from the correlations and the standard errors.
    ASSERT_EQ(back->covariance.rows(), s.covariance.rows());
    for (Eigen::Index a = 0; a < s.covariance.rows(); ++a)
      for (Eigen::Index b = 0; b < s.covariance.cols(); ++b)
        EXPECT_NEAR(back->covariance(a, b), s.covariance(a, b),
                    1e-12 * std::sqrt(s.covariance(a, a) * s.covariance(b, b)));
  }
}

TEST(ResultFile, AMalformedResultIsRefusedNamingTheFileAndTheJsonPath) {
  const Json good = FitFuelFilm(false).ToJson();
  struct Case {
    const char* what;
    std::function<void(Json&)> spoil;
    const char* path;
  };
  const std::vector<Case> cases = {
      {"not a result", [](Json& j) { j.erase("greybench_result"); }, ""},
      {"a checkpoint", [](Json& j) { j["partial"] = true; }, "partial"},
      {"log L a string", [](Json& j) { j["loglik"] = "high"; }, "loglik"},
      {"an estimate missing", [](Json& j) { j["parameters"]["tau_fv"].erase("estimate"); },
       "parameters.tau_fv.estimate"},
      {"a correlation row short", [](Json& j) { j["correlation"]["matrix"][0].erase(0); },
       "correlation.matrix[0]"},
      {"an optimum without a parameter", [](Json& j) { j["optima"][0]["parameters"].erase("X"); },
       "optima[0].parameters.X"},
      {"an unknown filter", [](Json& j) { j["filter"]["kind"] = "particle"; }, "filter.kind"},
      {"a log-scale name a number", [](Json& j) { j["log_scale"] = Json::array({1}); },
       "log_scale[0]"},
      {"a delay not whole", [](Json& j) { j["output_delay"]["ilambda"]["estimate"] = 1.5; },
       "output_delay.ilambda.estimate"},
  };
  for (const Case& c : cases) {
    Json j = good;
    c.spoil(j);
    auto back = estimate::EstimateSummary::FromJson(j, "fit.json");
    ASSERT_FALSE(back.ok()) << c.what;
    EXPECT_EQ(back.error().file, "fit.json") << c.what;
    EXPECT_EQ(back.error().path, c.path) << c.what << ": " << back.error().ToString();
  }
}

TEST(StoppedSummary, AFitStoppedByTheUserIsSummarisedAtTheBestPointItReported) {
  const filter::Likelihood likelihood = FuelFilm();
  std::atomic<bool> cancel{false};
  estimate::Progress best;
  best.loglik = -HUGE_VAL;
  estimate::EstimateOptions options;
  options.threads = 1;
  options.cancel = &cancel;
  options.progress = [&](const estimate::Progress& p) {
    if (p.loglik > best.loglik) best = p;
    if (p.iteration >= 4) cancel = true;
  };
  auto cancelled = estimate::Estimate(likelihood, options);
  ASSERT_TRUE(cancelled.ok());
  ASSERT_TRUE(cancelled->cancelled);
  EXPECT_TRUE(cancelled->parameters.empty()) << "Estimate's own summary of a cancelled run";

  auto s = estimate::StoppedSummary(likelihood, *cancelled, best);
  ASSERT_TRUE(s.ok()) << s.error().ToString();
  EXPECT_TRUE(s->cancelled);
  EXPECT_FALSE(s->converged);
  EXPECT_EQ(s->theta, best.theta);
  // log L there is the likelihood's at those values, and so the best the run reported.
  auto at = likelihood.Evaluate(best.theta, best.delay);
  ASSERT_TRUE(at.ok());
  EXPECT_EQ(s->loglik, at->loglik);
  EXPECT_NEAR(s->loglik, best.loglik, 1e-9 * std::abs(best.loglik));
  EXPECT_EQ(s->n_obs, at->n_obs);
  int free = 1;  // the scanned delay
  for (const model::Parameter& p : likelihood.spec().parameters) free += p.fixed ? 0 : 1;
  EXPECT_EQ(s->n_free, free);
  EXPECT_DOUBLE_EQ(s->aic, -2 * s->loglik + 2 * free);
  for (const estimate::ParameterEstimate& p : s->parameters) EXPECT_FALSE(p.std_error) << p.name;
  ASSERT_FALSE(s->warnings.empty());
  EXPECT_NE(s->warnings[0].find("not an optimum"), std::string::npos);
  // Its result file says so, reads back, and is refused by the likelihood-ratio test.
  const Json j = s->ToJson();
  EXPECT_EQ(j.value("cancelled", false), true);
  auto back = estimate::EstimateSummary::FromJson(j, "stopped.json");
  ASSERT_TRUE(back.ok()) << back.error().ToString();
  EXPECT_TRUE(back->cancelled);
  auto nested = project::ReadNestedFit(j, "stopped.json");
  ASSERT_FALSE(nested.ok());
  EXPECT_EQ(nested.error().path, "cancelled");
}

class KeptFitsFolder : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("greybench-kept-" + std::to_string(::getpid()) + "-" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

TEST_F(KeptFitsFolder, FitsAreNumberedNeverWrittenOverAndReadBackInOrder) {
  const std::string project = (dir_ / "engine.json").string();
  const std::string folder = project::FitsFolder(project);
  EXPECT_EQ(fs::path(folder).filename(), "engine.fits");
  const Json model = {{"greybench_model", 1}, {"name", "m"}};
  const Json result = {{"greybench_result", 1}, {"loglik", 1.5}};
  project::Project p;
  p.name = "engine";
  p.datasets = {data::PlainDataset((dir_ / "f1.csv").string())};
  auto first = project::WriteKeptFit(folder, result, model, p);
  ASSERT_TRUE(first.ok()) << first.error().ToString();
  EXPECT_EQ(first->number, 1);
  EXPECT_EQ(first->result["model_file"], "fit-001.model.json");
  EXPECT_EQ(first->result["project_file"], "fit-001.project.json");
  // Its project names the model beside it and the data beside the project.
  auto written = ReadJsonFile((fs::path(folder) / "fit-001.project.json").string());
  ASSERT_TRUE(written.ok());
  EXPECT_EQ((*written)["model"], "fit-001.model.json");
  EXPECT_EQ((*written)["datasets"][0], "../f1.csv");
  // A file of the user's with the next name is left alone: the fit takes the number after it.
  { std::ofstream(fs::path(folder) / "fit-002.model.json") << "mine"; }
  auto second = project::WriteKeptFit(folder, result, model, p);
  ASSERT_TRUE(second.ok());
  EXPECT_EQ(second->number, 3);
  std::ifstream mine(fs::path(folder) / "fit-002.model.json");
  std::string text;
  mine >> text;
  EXPECT_EQ(text, "mine");

  std::vector<Error> problems;
  const std::vector<project::KeptFitFile> fits = project::ReadKeptFits(folder, &problems);
  ASSERT_EQ(fits.size(), 2u);
  EXPECT_EQ(fits[0].number, 1);
  EXPECT_EQ(fits[1].number, 3);
  EXPECT_EQ(fits[1].model, model);
  EXPECT_TRUE(problems.empty());

  // Deleting removes the pair, and only a kept fit's.
  ASSERT_TRUE(project::DeleteKeptFit(fits[0].path).ok());
  EXPECT_FALSE(fs::exists(fs::path(folder) / "fit-001.json"));
  EXPECT_FALSE(fs::exists(fs::path(folder) / "fit-001.model.json"));
  EXPECT_FALSE(fs::exists(fs::path(folder) / "fit-001.project.json"));
  EXPECT_FALSE(project::DeleteKeptFit(project).ok()) << "the project file is no kept fit";
  EXPECT_TRUE(fs::exists(fs::path(folder) / "fit-002.model.json"));
}

TEST_F(KeptFitsFolder, AFitWhoseModelIsMissingIsReportedAndTheOthersRead) {
  const std::string folder = (dir_ / "p.fits").string();
  const Json model = {{"greybench_model", 1}};
  ASSERT_TRUE(project::WriteKeptFit(folder, {{"greybench_result", 1}}, model, {}).ok());
  ASSERT_TRUE(project::WriteKeptFit(folder, {{"greybench_result", 1}}, model, {}).ok());
  fs::remove(fs::path(folder) / "fit-001.model.json");
  std::vector<Error> problems;
  const auto fits = project::ReadKeptFits(folder, &problems);
  ASSERT_EQ(fits.size(), 1u);
  EXPECT_EQ(fits[0].number, 2);
  ASSERT_EQ(problems.size(), 1u);
  EXPECT_NE(problems[0].ToString().find("fit-001.model.json"), std::string::npos)
      << problems[0].ToString();
}

TEST_F(KeptFitsFolder, AFileInTheWayOfTheFolderIsRefusedNamingIt) {
  const std::string folder = (dir_ / "p.fits").string();
  { std::ofstream(folder) << "not a folder"; }
  auto kept = project::WriteKeptFit(folder, {{"greybench_result", 1}}, Json::object(), {});
  ASSERT_FALSE(kept.ok());
  EXPECT_EQ(kept.error().file, folder);
}

}  // namespace
}  // namespace gb
