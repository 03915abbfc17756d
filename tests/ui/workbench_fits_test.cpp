// The Fits list: every fit of a project kept beside it as result files the command line reads,
// there again when the project is reopened, two nested fits compared by the likelihood-ratio
// test, and a fit deleted with its files. Driven as a user would: Run, fix a parameter, Run
// again, tick two fits, reopen.
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include <boost/math/distributions/chi_squared.hpp>
#include <gtest/gtest.h>
#include <unistd.h>

#include "core/estimate/estimate.h"
#include "core/project/kept_fits.h"
#include "core/project/project.h"
#include "core/project/result_file.h"
#include "core/util/file.h"
#include "core/util/sanitizers.h"
#include "tests/ui/workbench_driver.h"
#include "ui/shell/shell.h"

namespace gb::ui {
namespace {

namespace fs = std::filesystem;
using std::chrono::milliseconds;
using testing::kSource;
using testing::WorkbenchDriver;

constexpr milliseconds kKeptFitTimeout{kSanitized ? 600000 : 60000};

// The UI test project (fuel film, f1) copied into a folder of its own, removed afterwards.
class FitsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("greybench-fits-test-" + std::to_string(::getpid()) + "-" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    for (const char* f : {"project.json", "fuel_film.json", "f1.csv"})
      fs::copy_file(kSource + "/tests/data/ui/" + f, dir_ / f);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string Project() const { return (dir_ / "project.json").string(); }
  // Opens the project as the window does (its fits kept on disk), fitting on one thread.
  ::testing::AssertionResult OpenKeeping(WorkbenchDriver& d) const {
    d.state.estimation.keep_on_disk = true;
    d.Open(Project());
    d.state.estimation.settings.threads = 1;
    if (!d.state.model) return ::testing::AssertionFailure() << d.state.model_error;
    return ::testing::AssertionSuccess();
  }
  fs::path Folder() const { return dir_ / "project.fits"; }

  fs::path dir_;
};

::testing::AssertionResult FitAndKeep(WorkbenchDriver& d) {
  std::string why;
  if (!StartEstimation(d.state, &why)) return ::testing::AssertionFailure() << why;
  if (!d.FramesUntil([&] { return !EstimationRunning(d.state); }, kKeptFitTimeout))
    return ::testing::AssertionFailure() << "the fit did not end in time";
  d.Frame();
  if (!d.state.estimation.result)
    return ::testing::AssertionFailure() << "no result: " << d.state.estimation.last_failure;
  return ::testing::AssertionSuccess();
}

TEST_F(FitsTest, TwoFitsAreKeptBesideTheProjectReopenAndAreComparedByTheLikelihoodRatioTest) {
  WorkbenchDriver d;
  ASSERT_TRUE(OpenKeeping(d));
  d.state.view = View::kEstimate;

  // Fit 1: the model as it is. Fit 2: s11 fixed at its start value (a nested model).
  ASSERT_TRUE(FitAndKeep(d));
  const estimate::EstimateSummary full = d.state.estimation.result->summary;
  d.state.parameters_view.pending.push_back(
      {"s11", ParameterField::kFixed, std::nullopt, true, ""});
  ApplyParameterEdits(d.state);
  ASSERT_TRUE(FitAndKeep(d));
  const estimate::EstimateSummary restricted = d.state.estimation.result->summary;
  ASSERT_EQ(restricted.n_free + 1, full.n_free);
  ASSERT_EQ(d.state.estimation.fits.size(), 2u);
  EXPECT_EQ(d.state.estimation.shown, 1);

  // On disk: two result files with their models, which the command line's reader takes.
  for (int n : {1, 2}) {
    const fs::path result = Folder() / ("fit-00" + std::to_string(n) + ".json");
    ASSERT_TRUE(fs::exists(result)) << result;
    EXPECT_TRUE(fs::exists(Folder() / ("fit-00" + std::to_string(n) + ".model.json")));
    auto model =
        model::LoadModelFile((Folder() / ("fit-00" + std::to_string(n) + ".model.json")).string());
    ASSERT_TRUE(model.ok()) << model.error().ToString();
    // As `predict --result` and `--start` read it: the estimates onto the fit's own model.
    auto delays = project::ApplyResultFile(result.string(), {}, &*model);
    ASSERT_TRUE(delays.ok()) << delays.error().ToString();
    const estimate::EstimateSummary& s = n == 1 ? full : restricted;
    for (std::size_t i = 0; i < s.parameters.size(); ++i)
      EXPECT_EQ(model->parameters[i].value, s.theta[i]) << s.parameters[i].name;
  }

  // The likelihood-ratio test of the two, against the closed form: 2 (log L_full - log
  // L_restricted) is χ²-distributed with 1 degree of freedom.
  auto test = CompareFits(d.state, 0, 1);
  ASSERT_TRUE(test.ok()) << test.error().ToString();
  const double statistic = 2 * (full.loglik - restricted.loglik);
  EXPECT_DOUBLE_EQ(test->statistic, statistic);
  EXPECT_EQ(test->df, 1);
  const boost::math::chi_squared chi2(1);
  EXPECT_NEAR(test->p_value, boost::math::cdf(boost::math::complement(chi2, statistic)), 1e-12);
  d.state.estimation.compare_a = 0;
  d.state.estimation.compare_b = 1;
  std::string log = d.Text();
  EXPECT_NE(log.find("Likelihood-ratio test of fit 2 (" + std::to_string(restricted.n_free) +
                     " free) against fit 1"),
            std::string::npos)
      << log;

  // Reopened: both fits are there with their numbers, estimates and log L to the last bit, and
  // the newest fit of the model is shown.
  WorkbenchDriver again;
  again.Open(Project());
  ASSERT_TRUE(again.state.model);
  const std::vector<KeptFit>& fits = again.state.estimation.fits;
  ASSERT_EQ(fits.size(), 2u);
  EXPECT_EQ(fits[0].number, 1);
  EXPECT_EQ(fits[1].number, 2);
  EXPECT_EQ(fits[0].fit.summary.loglik, full.loglik);
  EXPECT_EQ(fits[0].fit.summary.theta, full.theta);
  EXPECT_EQ(fits[1].fit.summary.loglik, restricted.loglik);
  EXPECT_EQ(fits[1].fit.summary.Report(), restricted.Report());
  ASSERT_TRUE(again.state.estimation.result);
  EXPECT_EQ(again.state.estimation.shown, 1);
  auto test_again = CompareFits(again.state, 1, 0);
  ASSERT_TRUE(test_again.ok());
  EXPECT_EQ(test_again->statistic, test->statistic);

  // Shown again: fit 1's estimates in the views.
  std::string why;
  ASSERT_TRUE(ShowFit(again.state, 0, &why)) << why;
  EXPECT_EQ(again.state.estimation.result->summary.theta, full.theta);

  // Deleted: its two files go, the other fit stays.
  ASSERT_TRUE(DeleteFit(again.state, 0, &why)) << why;
  EXPECT_FALSE(fs::exists(Folder() / "fit-001.json"));
  EXPECT_FALSE(fs::exists(Folder() / "fit-001.model.json"));
  EXPECT_TRUE(fs::exists(Folder() / "fit-002.json"));
  EXPECT_EQ(again.state.estimation.fits.size(), 1u);
  EXPECT_FALSE(again.state.estimation.result) << "the deleted fit was the one shown";
}

TEST_F(FitsTest, AFitOfAnotherModelBringsItsModelBackWhenShown) {
  WorkbenchDriver d;
  ASSERT_TRUE(OpenKeeping(d));
  ASSERT_TRUE(FitAndKeep(d));
  const estimate::EstimateSummary first = d.state.estimation.result->summary;

  // Another model: a parameter more (an unused gain), written as a new model file.
  Json other = model::ToJson(*d.state.model);
  other["name"] = "Fuel film with a spare gain";
  other["parameters"]["g"] = {{"value", 1.0}, {"fixed", true}};
  {
    std::ofstream out(dir_ / "other.json");
    out << other.dump(1);
  }
  ASSERT_TRUE(ReplaceModel(d.state, (dir_ / "other.json").string()).ok());
  EXPECT_FALSE(d.state.estimation.result) << "a fit of the previous model is not shown";
  ASSERT_EQ(d.state.estimation.fits.size(), 1u) << "the list keeps it";

  std::string why;
  ASSERT_TRUE(ShowFit(d.state, 0, &why)) << why;
  EXPECT_EQ(d.state.model->name, first.model_name);
  EXPECT_EQ(d.state.model->parameters.size(), first.parameters.size());
  EXPECT_EQ(d.state.estimation.result->summary.theta, first.theta);
  EXPECT_EQ(d.state.estimation.result->model_revision, d.state.model_revision);
}

TEST_F(FitsTest, SavedAsAnotherFileTheProjectTakesItsFitsAlong) {
  WorkbenchDriver d;
  ASSERT_TRUE(OpenKeeping(d));
  ASSERT_TRUE(FitAndKeep(d));
  ASSERT_FALSE(d.state.estimation.fits[0].file.empty());
  // Saved as another file: its fits folder is another, and the fit is written there too.
  const std::string copy = (dir_ / "copy.json").string();
  ASSERT_TRUE(SaveProjectAs(d.state, copy).ok());
  EXPECT_TRUE(fs::exists(dir_ / "copy.fits" / "fit-001.json"));
  EXPECT_TRUE(fs::exists(Folder() / "fit-001.json")) << "the first project's fit stays";
  // A fit read back, saved as a third file: its own project still names the data it was fitted to.
  WorkbenchDriver again;
  again.state.estimation.keep_on_disk = true;
  again.Open(copy);
  ASSERT_EQ(again.state.estimation.fits.size(), 1u);
  ASSERT_TRUE(SaveProjectAs(again.state, (dir_ / "third.json").string()).ok());
  auto own = project::LoadProject((dir_ / "third.fits" / "fit-001.project.json").string());
  ASSERT_TRUE(own.ok()) << own.error().ToString();
  ASSERT_EQ(own->datasets.size(), 1u);
  EXPECT_EQ(fs::path(own->datasets[0].file).filename(), "f1.csv");
}

// The command Copy as command puts on the clipboard, run in a shell, fits the same model to the
// same data again (from the files kept beside the project) and reaches the same log L.
TEST_F(FitsTest, CopyAsCommandRunInAShellFitsAgainToTheSameLogL) {
  WorkbenchDriver d;
  ASSERT_TRUE(OpenKeeping(d));
  // Edited in the workbench and not saved: the command must fit the model as it was fitted.
  d.state.parameters_view.pending.push_back(
      {"s11", ParameterField::kFixed, std::nullopt, true, ""});
  ApplyParameterEdits(d.state);
  ASSERT_TRUE(FitAndKeep(d));
  const double loglik = d.state.estimation.result->summary.loglik;
  std::string why;
  std::string command = FitCommand(d.state, 0, &why);
  ASSERT_FALSE(command.empty()) << why;
  const std::string program = "greybench-cli ";
  ASSERT_EQ(command.rfind(program, 0), 0u) << command;
  command = std::string(GREYBENCH_CLI) + " " + command.substr(program.size()) + " > /dev/null";
  ASSERT_EQ(std::system(command.c_str()), 0) << command;
  auto again = ReadJsonFile((Folder() / "fit-001.again.json").string());
  ASSERT_TRUE(again.ok()) << again.error().ToString();
  EXPECT_NEAR((*again)["loglik"].get<double>(), loglik, 1e-9 * std::abs(loglik));
  EXPECT_EQ((*again)["n_free"], d.state.estimation.result->summary.n_free);
}

TEST_F(FitsTest, AKeptFitThatCannotBeReadIsNamedAndTheOthersOpen) {
  {
    WorkbenchDriver d;
    ASSERT_TRUE(OpenKeeping(d));
    ASSERT_TRUE(FitAndKeep(d));
  }
  fs::copy_file(Folder() / "fit-001.json", Folder() / "fit-002.json");
  fs::copy_file(Folder() / "fit-001.model.json", Folder() / "fit-002.model.json");
  {
    std::ofstream out(Folder() / "fit-003.json");
    out << "{\"greybench_result\": 1, \"model_file\": \"fit-003.model.json\"";  // cut short
  }
  WorkbenchDriver d;
  d.Open(Project());
  EXPECT_EQ(d.state.estimation.fits.size(), 2u);
  bool named = false;
  for (const Message& m : d.state.messages)
    named = named || (m.text.find("fit-003.json") != std::string::npos &&
                      m.text.find("kept fit could not be read") != std::string::npos);
  EXPECT_TRUE(named) << "no message names the broken fit";
}

}  // namespace
}  // namespace gb::ui
