// Estimation of nonlinear models through the EKF: recovery of the true parameters from data
// simulated by the model itself (Milstein paths), from generic starts, with standard errors and
// a profile interval; and a linear model forced through the EKF reaches the exact filter's
// estimate.
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <sstream>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "core/data/dataset.h"
#include "core/design/prbs.h"
#include "core/estimate/estimate.h"
#include "core/filter/ekf.h"
#include "core/filter/likelihood.h"
#include "core/model/nonlinear_model.h"
#include "core/sim/sde.h"
#include "core/util/json.h"
#include "core/util/sanitizers.h"
#include "tests/core/nonlinear_tank.h"

namespace gb::estimate {
namespace {

using testing::CompileTank;
using testing::kTank;
std::shared_ptr<const data::Series> Simulate(std::uint64_t seed, double duration = 300.0) {
  return testing::SimulateTank(seed, duration);
}

TEST(EkfEstimate, RecoversANonlinearTankFromGenericStarts) {
  const auto nm = CompileTank(Json::parse(kTank));
  auto lik = filter::Likelihood::Create(nm, {Simulate(3)});
  ASSERT_TRUE(lik);
  EstimateOptions options;
  options.threads = 1;
  // Under the sanitizers without the profile intervals (a dozen fits per parameter through the
  // same Likelihood; ProfileIntervals.* covers their code).
  options.profile_intervals = !kSanitized;
  auto fit = Estimate(*lik, options);
  ASSERT_TRUE(fit) << fit.error().ToString();
  ASSERT_TRUE(fit->converged) << fit->message;
  EXPECT_TRUE(fit->extended);
  EXPECT_GT(fit->ode.steps, 0);
  const std::map<std::string, double> truth = {
      {"k", 0.8}, {"a", 0.5}, {"s", 0.08}, {"r", 0.004}, {"h0", 2.5}};
  for (const ParameterEstimate& p : fit->parameters) {
    SCOPED_TRACE(p.name);
    ASSERT_TRUE(p.std_error.has_value());
    EXPECT_LT(std::abs(p.estimate - truth.at(p.name)), 3.0 * *p.std_error)
        << p.estimate << " ± " << *p.std_error;
    if (kSanitized) continue;
    // The likelihood-ratio interval brackets the estimate and is near the Wald interval.
    ASSERT_TRUE(p.profile && p.profile->lower && p.profile->upper);
    EXPECT_LT(*p.profile->lower, p.estimate);
    EXPECT_GT(*p.profile->upper, p.estimate);
    EXPECT_NEAR(*p.profile->upper - *p.profile->lower, 2 * 1.96 * *p.std_error,
                0.5 * 2 * 1.96 * *p.std_error);
  }
  const Json j = fit->ToJson();
  EXPECT_EQ(j["filter"]["kind"], "ekf");
  EXPECT_NE(fit->Report().find("Filter: extended Kalman filter"), std::string::npos);
}

// ---- a published nonlinear result: CTSM's fed-batch bioreactor (tests/data/bioreactor) ---------

struct Bioreactor {
  std::shared_ptr<const model::NonlinearModel> model;
  filter::Likelihood likelihood;
};

Bioreactor LoadBioreactor(const std::map<std::string, double>& values = {}) {
  const std::string dir = std::string(GREYBENCH_TEST_DATA_DIR) + "/bioreactor/";
  auto spec = model::LoadModelFile(dir + "fedbatch.json");
  EXPECT_TRUE(spec) << spec.error().ToString();
  for (const auto& [name, value] : values) EXPECT_TRUE(model::SetParameter(&*spec, name, value));
  auto nm = std::make_shared<const model::NonlinearModel>(*model::NonlinearModel::Compile(*spec));
  auto dataset = data::ReadCsvFile(dir + "fedbatch.csv");
  EXPECT_TRUE(dataset) << dataset.error().ToString();
  auto series = data::Bind(**dataset, nm->spec().inputs, nm->spec().outputs);
  EXPECT_TRUE(series) << series.error().ToString();
  return {nm, *filter::Likelihood::Create(nm, {*series})};
}

// CTSM's estimates as printed, the initial states at full precision (its predictions' first row).
const std::map<std::string, double> kCtsmEstimates = {
    {"mumax", 1.0022},           {"K1", 0.031629},          {"S11", 0.0075248},
    {"S22", 0.0010636},          {"S33", 0.011388},         {"X0", 1.0095462824854442},
    {"S0", 0.23834703891425607}, {"V0", 1.0039507255993247}};

TEST(EkfEstimate, NinetyFivePercentIntervalsCoverTheTruthAtTheNominalRate) {
  // The tank above: replicates of 600 samples, fitted from the model file's generic starts (one
  // start each); the Wald intervals estimate ± 1.96 SE of the five parameters (standard errors
  // from second differences of log L through the EKF). Measured: 92.8 % of 500 (k 90, a 89,
  // s 96, r 94, h0 95 of 100); the z-scores (estimate - truth)/SE have means within ±0.16 of 0
  // and standard deviations 1.15 (k), 1.11 (a), 0.98-1.04 (s, r, h0): the flow parameters,
  // strongly correlated, have Wald intervals slightly too narrow at 600 samples.
  // A Monte Carlo property, measured by the release suite. Its code under the sanitizers (the
  // EKF's fit of this tank from generic starts) is what RecoversANonlinearTankFromGenericStarts
  // runs.
  if (kSanitized) GTEST_SKIP() << "a coverage rate over 100 fits; the release suite measures it";
  const int replicates = 100;
  const std::map<std::string, double> truth = {
      {"k", 0.8}, {"a", 0.5}, {"s", 0.08}, {"r", 0.004}, {"h0", 2.5}};
  const auto nm = CompileTank(Json::parse(kTank));
  std::map<std::string, int> covered_by;
  int covered = 0, total = 0;
  for (int rep = 0; rep < replicates; ++rep) {
    auto lik = filter::Likelihood::Create(nm, {Simulate(2000 + rep)});
    ASSERT_TRUE(lik);
    EstimateOptions options;
    options.threads = 1;
    options.starts_on_bound = 0;
    auto fit = Estimate(*lik, options);
    ASSERT_TRUE(fit) << fit.error().ToString();
    EXPECT_TRUE(fit->converged) << rep << ": " << fit->message;
    for (const ParameterEstimate& p : fit->parameters) {
      if (!p.std_error) continue;
      ++total;
      if (std::abs(p.estimate - truth.at(p.name)) <= 1.96 * *p.std_error) {
        ++covered;
        ++covered_by[p.name];
      }
    }
  }
  EXPECT_GE(total, 5 * replicates - 2);
  const double rate = static_cast<double>(covered) / total;
  std::string per_parameter;
  for (const auto& [name, n] : covered_by) per_parameter += fmt::format(" {} {}", name, n);
  RecordProperty("coverage", fmt::format("{:.4f}", rate));
  RecordProperty("covered_per_parameter", per_parameter);
  std::printf("coverage %.4f over %d intervals;%s of %d each\n", rate, total, per_parameter.c_str(),
              replicates);
  EXPECT_GE(rate, 0.90);
  EXPECT_LE(rate, 0.98);
}

TEST(Bioreactor, LogLikelihoodAtCtsmsEstimatesIsItsPublishedValue) {
  Bioreactor b = LoadBioreactor(kCtsmEstimates);
  auto l = b.likelihood.Evaluate(b.model->spec().Values());
  ASSERT_TRUE(l) << l.error().ToString();
  EXPECT_EQ(l->n_obs, 303);
  // CTSM: -log L = -388.4857; PSM's EKF 388.4689. The printed estimates carry 5 digits, and
  // μmax and K1 are 0.9975 correlated: rounding them moves log L by about 0.01.
  EXPECT_NEAR(l->loglik, 388.4857, 0.03);

  // CTSM's one-step state predictions at these values, row by row.
  const std::string path =
      std::string(GREYBENCH_TEST_DATA_DIR) + "/bioreactor/ctsm_predictions.csv";
  std::ifstream in(path);
  ASSERT_TRUE(in) << path;
  filter::FilterTrace trace;
  ASSERT_TRUE(filter::EkfRunFilter(*b.model, b.model->spec().Values(), *b.likelihood.series()[0],
                                   b.likelihood.settings(), &trace));
  std::string line;
  int row = 0;
  double worst = 0.0;
  while (std::getline(in, line)) {
    std::stringstream fields(line);
    std::vector<double> v;
    for (std::string cell; std::getline(fields, cell, ';');) v.push_back(std::stod(cell));
    ASSERT_GE(v.size(), 4u);
    for (int i = 0; i < 3; ++i)
      worst = std::max(worst, std::abs(trace.x_pred(i, row) - v[1 + i]) / std::abs(v[1 + i]));
    ++row;
  }
  EXPECT_EQ(row, 101);
  EXPECT_LT(worst, 2e-3);  // 0.07 %: the 5-digit μmax and K1
}

TEST(Bioreactor, EstimatesFromNeutralStartsAreCtsmsWithinItsStandardErrors) {
  Bioreactor b = LoadBioreactor();
  EstimateOptions options;
  options.threads = 1;
  auto fit = Estimate(b.likelihood, options);
  ASSERT_TRUE(fit) << fit.error().ToString();
  ASSERT_TRUE(fit->converged) << fit->message;
  // log L at the optimum: a little below CTSM's 388.4857, whose approximate prediction step
  // reaches about 0.01 more than any exact EKF (PSM: 388.4689 at CTSM's values).
  EXPECT_NEAR(fit->loglik, 388.4857, 0.03);
  const std::map<std::string, std::pair<double, double>> ctsm = {{"mumax", {1.0022, 0.0033419}},
                                                                 {"K1", {0.031629, 0.0015977}},
                                                                 {"S11", {0.0075248, 0.00097618}},
                                                                 {"S22", {0.0010636, 0.00013763}},
                                                                 {"S33", {0.011388, 0.0014960}}};
  for (const ParameterEstimate& p : fit->parameters) {
    auto it = ctsm.find(p.name);
    if (it == ctsm.end()) continue;
    SCOPED_TRACE(p.name);
    const auto [estimate, sd] = it->second;
    EXPECT_LT(std::abs(p.estimate - estimate), sd) << p.estimate;
    ASSERT_TRUE(p.std_error.has_value());
    EXPECT_NEAR(*p.std_error, sd, 0.35 * sd);  // CTSM's SDs are 7-13 % small (S33: √(2/101) S33)
  }
}

}  // namespace
}  // namespace gb::estimate
