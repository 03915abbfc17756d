#include "core/estimate/estimate.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <fstream>
#include <map>
#include <optional>
#include <set>
#include <sstream>
#include <thread>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "core/design/prbs.h"
#include "core/model/linear_model.h"
#include "core/project/problem.h"
#include "core/sim/simulate.h"
#include "core/util/json.h"
#include "core/util/sanitizers.h"
#include "tests/core/estimate_fixtures.h"

namespace gb::estimate {
namespace {

const std::string kData = GREYBENCH_TEST_DATA_DIR;

using testing::Compile;
using testing::Simulate;

// Every free parameter's estimate within `k` standard errors of the truth.
void ExpectWithinStandardErrors(const EstimateSummary& s,
                                const std::map<std::string, double>& truth, double k) {
  for (const auto& p : s.parameters) {
    if (p.fixed || !truth.count(p.name)) continue;
    ASSERT_TRUE(p.std_error.has_value()) << p.name << " has no standard error";
    EXPECT_LT(std::abs(p.estimate - truth.at(p.name)), k * *p.std_error)
        << p.name << " = " << p.estimate << " ± " << *p.std_error << ", truth " << truth.at(p.name);
  }
}

// ---- the fuel film, paper Table 2 point f1 -----------------------------------------------------

Json FuelFilm(bool truth) {
  Json j = Json::parse(R"json({
    "greybench_model": 1, "states": ["mfv", "mff"], "inputs": ["mfi"], "outputs": ["ilambda"],
    "parameters": {
      "tau_fv": {"value": 0.1, "lower": 0.005, "upper": 1.0},
      "tau_ff": {"value": 0.5, "lower": 0.01, "upper": 5.0},
      "X": {"value": 0.3, "lower": 0.0, "upper": 1.0},
      "Kb": {"value": 0.8, "lower": 0.1, "upper": 5.0},
      "s11": {"value": 1e-3, "lower": 1e-9, "upper": 1.0},
      "s12": {"value": 1e-3, "lower": 1e-9, "upper": 1.0},
      "s2": {"value": 1e-3, "lower": 1e-9, "upper": 1.0},
      "mfi0": {"value": 1.2, "fixed": true}},
    "drift": {"mfv": "(-mfv + (1 - X)*mfi)/tau_fv", "mff": "(-mff + X*mfi)/tau_ff"},
    "diffusion": {"mfv": "sqrt(s11)", "mff": "sqrt(s12)"},
    "observation": {"ilambda": "Kb*(mfv + mff)"},
    "measurement_variance": {"ilambda": "s2"},
    "output_delay": {"ilambda": {"min": 0, "max": 10}},
    "initial_state": {"mfv": "(1 - X)*mfi0", "mff": "X*mfi0"}})json");
  if (truth) {
    const std::map<std::string, double> f1 = {
        {"tau_fv", 0.0750}, {"tau_ff", 0.375},  {"X", 0.175},     {"Kb", 0.8421},
        {"s11", 0.1098e-2}, {"s12", 0.3910e-3}, {"s2", 1.2570e-4}};
    for (const auto& [k, v] : f1) j["parameters"][k]["value"] = v;
    j["output_delay"]["ilambda"] = 5;
  }
  return j;
}

TEST(Estimate, RecoversTheFuelFilmModelAndItsDelayFromSimulatedPrbsData) {
  const auto truth = Compile(FuelFilm(true));
  design::PrbsOptions prbs;  // the paper's experiment: n = 6, 0.5 s bits, ±10 % of the bias, 80 Hz
  prbs.order = 6;
  prbs.bit_period = 0.5;
  prbs.sample_time = 0.0125;
  // 10 000 samples; under the sanitizers 2 500 (the point there is the code path of the fit and
  // the delay profile, not the precision of the estimates, which the release suite checks).
  prbs.duration = kSanitized ? 31.25 : 125.0;
  prbs.low = 1.08;
  prbs.high = 1.32;
  const auto series = Simulate(*truth, {prbs}, 42);
  auto lik = filter::Likelihood::Create(Compile(FuelFilm(false)), {series});
  ASSERT_TRUE(lik.ok());
  auto s = Estimate(*lik, EstimateOptions{});
  ASSERT_TRUE(s.ok()) << s.error().ToString();
  EXPECT_TRUE(s->converged) << s->message;
  EXPECT_EQ(s->delays[0].estimate, 5);
  ASSERT_EQ(s->delays[0].profile.size(), 11u);
  for (const auto& pt : s->delays[0].profile) {
    if (pt.delay != 5) {
      EXPECT_LT(*pt.loglik, s->loglik) << "delay " << pt.delay;
    }
  }
  ExpectWithinStandardErrors(*s,
                             {{"tau_fv", 0.0750},
                              {"tau_ff", 0.375},
                              {"X", 0.175},
                              {"Kb", 0.8421},
                              {"s11", 0.1098e-2},
                              {"s12", 0.3910e-3},
                              {"s2", 1.2570e-4}},
                             3.0);
  // The result file holds what user guide §5 lists.
  const Json j = s->ToJson();
  EXPECT_EQ(j["greybench_result"], 1);
  EXPECT_TRUE(j["parameters"]["mfi0"]["std_error"].is_null());
  EXPECT_TRUE(j["parameters"]["mfi0"]["fixed"].get<bool>());
  EXPECT_EQ(j["output_delay"]["ilambda"]["estimate"], 5);
  EXPECT_NEAR(j["aic"].get<double>(), -2 * s->loglik + 2 * s->n_free, 1e-9);
}

// The paper's f1 experiment for `duration` s, simulated from the truth; the fuel-film model at
// the truth with every parameter fixed.
std::shared_ptr<const data::Series> FuelFilmRecord(double duration) {
  design::PrbsOptions prbs;
  prbs.order = 6;
  prbs.bit_period = 0.5;
  prbs.sample_time = 0.0125;
  prbs.duration = duration;
  prbs.low = 1.08;
  prbs.high = 1.32;
  return Simulate(*Compile(FuelFilm(true)), {prbs}, 7);
}
Json FuelFilmAllFixed() {
  Json j = FuelFilm(true);
  for (auto& [name, p] : j["parameters"].items()) p["fixed"] = true;
  return j;
}

// With every parameter fixed the only unknown is the scanned delay: the estimate is the delay
// of the largest log-likelihood, each evaluated directly (a brute-force profile), and nothing
// else is reported as estimated. Found by issue 32: the score split its parameters into
// clamp(…, 1, 0) chunks and read past the end (SIGSEGV).
TEST(Estimate, WithEveryParameterFixedOnlyTheDelayIsEstimatedByItsProfile) {
  Json j = FuelFilmAllFixed();
  j["output_delay"]["ilambda"] = Json{{"min", 2}, {"max", 8}};
  auto lik = filter::Likelihood::Create(Compile(j), {FuelFilmRecord(20.0)});
  ASSERT_TRUE(lik.ok()) << lik.error().ToString();
  auto s = Estimate(*lik, EstimateOptions{});
  ASSERT_TRUE(s.ok()) << s.error().ToString();
  int best = -1;
  double best_loglik = -HUGE_VAL;
  for (int d = 2; d <= 8; ++d) {
    const std::vector<int> delay{d};
    auto l = lik->Evaluate(lik->spec().Values(), delay);
    ASSERT_TRUE(l.ok());
    if (l->loglik > best_loglik) best = d, best_loglik = l->loglik;
  }
  EXPECT_EQ(s->delays[0].estimate, best);
  EXPECT_DOUBLE_EQ(s->loglik, best_loglik);
  EXPECT_EQ(s->n_free, 1);  // the delay
  for (const auto& p : s->parameters) EXPECT_FALSE(p.std_error.has_value()) << p.name;
}

TEST(Estimate, AModelWithNothingToEstimateIsRefusedNamingTheModel) {
  auto lik = filter::Likelihood::Create(Compile(FuelFilmAllFixed()), {FuelFilmRecord(5.0)});
  ASSERT_TRUE(lik.ok());
  auto s = Estimate(*lik, EstimateOptions{});
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().kind, ErrorKind::kInput);
  EXPECT_NE(s.error().message.find("nothing to estimate"), std::string::npos) << s.error().message;
  EXPECT_NE(s.error().message.find("test.json"), std::string::npos) << s.error().message;
}

// ---- the crankshaft, eq. 15-16 with the values of Section 5 ------------------------------------

Json Crankshaft(bool truth, bool load_perturbed) {
  Json j = Json::parse(R"json({
    "greybench_model": 1, "states": ["N"], "inputs": ["theta", "Tl"], "outputs": ["Nm", "Pman"],
    "parameters": {
      "tau_f": {"value": 3.0, "lower": 0.1, "upper": 50},
      "Je": {"value": 1.0, "lower": 0.01, "upper": 10},
      "Gp": {"value": 5.0, "lower": 0.1, "upper": 50},
      "Kn": {"value": 0.01, "lower": 1e-5, "upper": 1},
      "Kth": {"value": 3.0, "lower": 0.1, "upper": 20},
      "s1": {"value": 50, "lower": 1e-6, "upper": 1e4},
      "s21": {"value": 10, "lower": 1e-6, "upper": 1e4},
      "s22": {"value": 1, "lower": 1e-6, "upper": 1e4}},
    "drift": {"N": "(-1/tau_f - Gp*Kn/Je)*N + Gp*Kth/Je*theta - Tl/Je"},
    "diffusion": {"N": "sqrt(s1)"},
    "observation": {"Nm": "N", "Pman": "-Kn*N + Kth*theta"},
    "measurement_variance": {"Nm": "s21", "Pman": "s22"},
    "initial_covariance": "stationary"})json");
  if (truth) {
    const std::map<std::string, double> v = {{"tau_f", 4.1358}, {"Je", 0.6028},  {"Gp", 6.3570},
                                             {"Kn", 0.008746},  {"Kth", 3.6403}, {"s1", 74.70},
                                             {"s21", 14.43},    {"s22", 0.6988}};
    for (const auto& [k, x] : v) j["parameters"][k]["value"] = x;
  }
  (void)load_perturbed;
  return j;
}

std::vector<design::PrbsOptions> CrankshaftInputs(bool load_perturbed) {
  design::PrbsOptions throttle;
  throttle.order = 7;
  throttle.bit_period = 1.0;
  throttle.sample_time = 0.0625;
  throttle.duration = 600.0;
  throttle.low = -1.0;  // degrees around the bias
  throttle.high = 1.0;
  throttle.seed = 5;
  design::PrbsOptions load = throttle;
  load.order = 6;
  load.bit_period = 2.0;
  load.seed = 19;
  load.low = load_perturbed ? -5.0 : 0.0;  // Nm
  load.high = load_perturbed ? 5.0 : 0.0;
  return {throttle, load};
}

TEST(Estimate, RecoversTheCrankshaftModelWhenThrottleAndLoadArePerturbed) {
  const auto truth = Compile(Crankshaft(true, true));
  const auto series = Simulate(*truth, CrankshaftInputs(true), 7);
  auto lik = filter::Likelihood::Create(Compile(Crankshaft(false, true)), {series});
  ASSERT_TRUE(lik.ok());
  auto s = Estimate(*lik, EstimateOptions{});
  ASSERT_TRUE(s.ok()) << s.error().ToString();
  EXPECT_TRUE(s->converged) << s->message;
  ExpectWithinStandardErrors(*s,
                             {{"tau_f", 4.1358},
                              {"Je", 0.6028},
                              {"Gp", 6.3570},
                              {"Kn", 0.008746},
                              {"Kth", 3.6403},
                              {"s1", 74.70},
                              {"s21", 14.43},
                              {"s22", 0.6988}},
                             3.0);
}

TEST(Estimate, ReportsGpAndJeAsNotIdentifiableWhenTheLoadIsHeldConstant) {
  // With the load torque constant, Gp and Je appear only as Gp/Je (and Gp Kn/Je): the data
  // determine the ratio, not the two.
  const auto truth = Compile(Crankshaft(true, false));
  const auto series = Simulate(*truth, CrankshaftInputs(false), 7);
  auto lik = filter::Likelihood::Create(Compile(Crankshaft(false, false)), {series});
  ASSERT_TRUE(lik.ok());
  EstimateOptions options;
  // Under the sanitizers without the extra starts (73 s there with them): the warning is made
  // from the fit's information matrix whichever start the fit came from.
  if (kSanitized) options.starts_on_bound = 0;
  auto s = Estimate(*lik, options);
  ASSERT_TRUE(s.ok());
  bool named = false;
  for (const auto& w : s->warnings)
    if (w.find("not identifiable") != std::string::npos && w.find("Gp") != std::string::npos &&
        w.find("Je") != std::string::npos)
      named = true;
  EXPECT_TRUE(named) << "warnings: " << fmt::format("{}", fmt::join(s->warnings, " | "));
  for (const auto& p : s->parameters) {
    if (p.name == "Gp" || p.name == "Je") {
      EXPECT_FALSE(p.std_error.has_value()) << p.name << " must not get a (tiny) standard error";
    }
  }
}

TEST(Estimate, ReportsProgressAndStopsWithin100msOfCancellation) {
  const auto truth = Compile(FuelFilm(true));
  design::PrbsOptions prbs;
  prbs.order = 6;
  prbs.bit_period = 0.5;
  prbs.sample_time = 0.0125;
  prbs.duration = 500.0;  // 40 000 samples: a fit of several seconds
  prbs.low = 1.08;
  prbs.high = 1.32;
  auto lik = filter::Likelihood::Create(Compile(FuelFilm(false)), {Simulate(*truth, {prbs}, 3)});
  ASSERT_TRUE(lik.ok());
  std::atomic<bool> cancel{false};
  std::atomic<int> reports{0};
  EstimateOptions o;
  o.cancel = &cancel;
  o.progress = [&](const Progress& p) {
    EXPECT_TRUE(std::isfinite(p.loglik));
    EXPECT_EQ(p.theta.size(), 8u);
    reports.fetch_add(1);
  };
  Result<EstimateSummary> result = InputError("not run");
  std::atomic<bool> done{false};
  std::thread worker([&] {
    result = Estimate(*lik, o);
    done = true;
  });
  while (reports.load() < 2 && !done) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  ASSERT_FALSE(done.load()) << "the fit ended before it could be cancelled";
  const auto asked = std::chrono::steady_clock::now();
  cancel = true;
  worker.join();
  const double waited =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - asked).count();
  EXPECT_LT(waited, 0.1);
  ASSERT_TRUE(result.ok());
  EXPECT_TRUE(result->cancelled);
  EXPECT_FALSE(result->converged);
}

// ---- calibration -------------------------------------------------------------------------------

TEST(Estimate, NinetyFivePercentIntervalsCoverTheTruthAtTheNominalRate) {
  // A scalar model with input; 200 replicates; 4 free parameters: 800 intervals.
  const Json truth_json = Json::parse(R"json({
    "greybench_model": 1, "states": ["x"], "inputs": ["u"], "outputs": ["y"],
    "parameters": {"tau": {"value": 2.0, "lower": 0.05, "upper": 50},
                   "K": {"value": 1.5, "lower": -10, "upper": 10},
                   "s": {"value": 0.3, "lower": 1e-4, "upper": 10},
                   "r": {"value": 0.05, "lower": 1e-6, "upper": 10}},
    "drift": {"x": "(-x + K*u)/tau"}, "diffusion": {"x": "s"},
    "observation": {"y": "x"}, "measurement_variance": {"y": "r"},
    "initial_covariance": "stationary"})json");
  const std::map<std::string, double> truth = {{"tau", 2.0}, {"K", 1.5}, {"s", 0.3}, {"r", 0.05}};
  Json start = truth_json;
  start["parameters"]["tau"]["value"] = 1.0;
  start["parameters"]["K"]["value"] = 1.0;
  start["parameters"]["s"]["value"] = 0.5;
  start["parameters"]["r"]["value"] = 0.1;
  const auto truth_model = Compile(truth_json);
  const auto fit_model = Compile(start);
  design::PrbsOptions prbs;
  prbs.order = 5;
  prbs.bit_period = 1.0;
  prbs.sample_time = 0.25;
  prbs.duration = 150.0;  // 600 samples
  // Under the sanitizers 20 replicates run the same code; the coverage rate (a Monte Carlo
  // property) is checked on 200 in the release suite.
  const int replicates = kSanitized ? 20 : 200;
  int covered = 0, total = 0;
  for (int rep = 0; rep < replicates; ++rep) {
    prbs.seed = static_cast<std::uint32_t>(rep + 1);
    const auto series = Simulate(*truth_model, {prbs}, 1000 + rep);
    auto lik = filter::Likelihood::Create(fit_model, {series});
    EstimateOptions o;
    o.threads = 1;
    auto s = Estimate(*lik, o);
    ASSERT_TRUE(s.ok());
    for (const auto& p : s->parameters) {
      if (!p.std_error) continue;
      ++total;
      if (std::abs(p.estimate - truth.at(p.name)) <= 1.96 * *p.std_error) ++covered;
    }
  }
  EXPECT_GE(total, 4 * replicates - 10);
  const double rate = static_cast<double>(covered) / total;
  if (!kSanitized) {
    EXPECT_GE(rate, 0.90);
    EXPECT_LE(rate, 0.98);
  }
  RecordProperty("coverage", fmt::format("{:.4f}", rate));
}

// ---- generic starts: the best optimum, not the nearest (issue 33) ----------------------------

// Two coupled Ornstein-Uhlenbeck states with every parameter on an unbounded log scale
// (tests/data/ornstein2d/README.md), from generic starts: from many of them a single fit ends at
// a poor optimum with log-scale parameters running off towards ±inf. The default estimate
// (runaways put back to their starts, then extra starts) ends at the best optimum from each.
struct GenericStart {
  double logtheta, mu, logalpha, logsigma_x2, logsigma_y2;
};
const std::vector<GenericStart> kGenericStarts = {
    // Starts from which the plain fit runs off (on the machine these were chosen on) ...
    {-1, 1, -1, 1, -1},
    {-1, 1, -1, 1, 1},
    {-1, 1, 1, 1, 1},
    {-1, 0, -1, 1, 1},
    {-1, 0, 1, 1, 1},
    {-1, 1, -1, -1, 1},
    {-1, 0, -1, -1, 1},
    {-1, 0, 1, 1, -1},
    // ... and starts from which it does not.
    {1, 1, 1, -1, -1},
    {1, 0, -1, 1, 1},
    {1, 1, 1, 1, 1},
    {-1, 1, 1, -1, -1}};

Result<EstimateSummary> FitOrnsteinPair(const GenericStart& g, EstimateOptions options) {
  auto spec = model::LoadModelFile(kData + "/ornstein2d/model.json");
  if (!spec) return spec.error();
  const std::map<std::string, double> values = {{"logtheta", g.logtheta},
                                                {"mu", g.mu},
                                                {"logalpha", g.logalpha},
                                                {"logsigma_x2", g.logsigma_x2},
                                                {"logsigma_y2", g.logsigma_y2}};
  for (auto& p : spec->parameters)
    if (values.count(p.name)) p.value = values.at(p.name);
  auto problem = project::LoadProblem(std::move(*spec), {kData + "/ornstein2d/data.csv"});
  if (!problem) return problem.error();
  auto lik = project::MakeLikelihood(*problem);
  if (!lik) return lik.error();
  options.threads = 1;
  return Estimate(*lik, options);
}

TEST(Estimate, FromEveryGenericStartTheOrnsteinPairReachesTheBestOptimumThatManyStartsFind) {
  // Under the sanitizers, where the whole test took 223 s (the longest there), one default fit
  // from a start whose plain fit runs off: the code (runaways released, extra starts) runs under
  // them; the point of the test, the best optimum from every generic start, is the release
  // suite's.
  if (kSanitized) {
    auto s = FitOrnsteinPair(kGenericStarts.front(), EstimateOptions{});
    ASSERT_TRUE(s.ok()) << s.error().ToString();
    EXPECT_TRUE(std::isfinite(s->loglik));
    return;
  }
  // The reference: the best of 24 extra starts over the model's start ranges (brute force; 8 of
  // the 25 reach it, and 64 find nothing better).
  EstimateOptions brute;
  brute.multistart = 24;
  auto reference = FitOrnsteinPair(kGenericStarts.front(), brute);
  ASSERT_TRUE(reference.ok()) << reference.error().ToString();
  double best = reference->loglik;
  int plain_short = 0;
  for (const GenericStart& g : kGenericStarts) {
    auto s = FitOrnsteinPair(g, EstimateOptions{});
    ASSERT_TRUE(s.ok()) << s.error().ToString();
    best = std::max(best, s->loglik);
    EXPECT_NEAR(s->loglik, reference->loglik, 1e-6 * std::abs(reference->loglik))
        << "from logtheta " << g.logtheta << ", mu " << g.mu << ", logalpha " << g.logalpha
        << ", logsigma_x2 " << g.logsigma_x2 << ", logsigma_y2 " << g.logsigma_y2 << ":\n"
        << s->Report();
    EstimateOptions plain;
    plain.starts_on_bound = 0;  // the plain start's fit alone, for the test's own sake
    auto p = FitOrnsteinPair(g, plain);
    ASSERT_TRUE(p.ok());
    if (p->loglik < reference->loglik - 1) ++plain_short;
  }
  // No start finds more than the brute force, and the data do set the trap: the plain fit stops
  // short from some of these starts.
  EXPECT_LE(best, reference->loglik + 1e-6 * std::abs(reference->loglik));
  EXPECT_GE(plain_short, 3);
}

// The model file's starts fitted to the records with the default options on `threads` threads,
// as a user runs `greybench-cli estimate MODEL DATA...`.
Result<EstimateSummary> FitWithDefaults(const std::string& model_file,
                                        const std::vector<std::string>& data_files, int threads) {
  auto spec = model::LoadModelFile(model_file);
  if (!spec) return spec.error();
  auto problem = project::LoadProblem(std::move(*spec), data_files);
  if (!problem) return problem.error();
  auto lik = project::MakeLikelihood(*problem);
  if (!lik) return lik.error();
  EstimateOptions options;
  options.threads = threads;
  return Estimate(*lik, options);
}

TEST(Estimate, TwoRecordsGivenInEitherOrderReachTheSameOptimum) {
  // Issue 33: the outcome may not turn on the order the datasets are given in (the sum of their
  // log-likelihoods rounds differently). The fuel film from generic starts on f1 and f7, where
  // a variance ends on its bound and is released: the whole default job, delay profile included.
  // Not under the sanitizers (its time there: docs/benchmarks.md, "Timings behind the code's
  // limits"): the stages it runs run there in the Ornstein pair's generic starts and the fuel
  // film's estimates.
  if (kSanitized) GTEST_SKIP() << "the release suite's: see the comment";
  const std::string assets = std::string(GREYBENCH_SOURCE_DIR) + "/";
  const std::vector<std::string> files = {assets + "assets/data/fuel_f1.csv",
                                          assets + "assets/data/fuel_f7.csv"};
  std::vector<EstimateSummary> fits;
  for (const bool reversed : {false, true}) {
    auto s = FitWithDefaults(assets + "bench/models/fuel_film_generic.json",
                             reversed ? std::vector<std::string>{files[1], files[0]} : files, 1);
    ASSERT_TRUE(s.ok()) << s.error().ToString();
    fits.push_back(std::move(*s));
  }
  EXPECT_NEAR(fits[1].loglik, fits[0].loglik, 1e-6 * std::abs(fits[0].loglik));
  ASSERT_EQ(fits[0].delays.size(), fits[1].delays.size());
  for (std::size_t o = 0; o < fits[0].delays.size(); ++o)
    EXPECT_EQ(fits[1].delays[o].estimate, fits[0].delays[o].estimate);
  for (std::size_t i = 0; i < fits[0].parameters.size(); ++i) {
    const auto& a = fits[0].parameters[i];
    const auto& b = fits[1].parameters[i];
    // Within a hundredth of a standard error (or 1e-6 relative where there is none).
    const double tol =
        a.std_error ? 0.01 * *a.std_error : 1e-6 * std::max(1.0, std::abs(a.estimate));
    EXPECT_NEAR(b.estimate, a.estimate, tol) << a.name;
  }
}

// ---- the CTSM-R conformance case ---------------------------------------------------------------

// Checks a building-3 fit against CTSM-R's published estimates and standard errors
// (tests/data/building3/published.txt): the optimum at least CTSM-R's, and every well-determined
// parameter within half of CTSM-R's standard error.
void ExpectCtsmRsBuilding3Estimates(const EstimateSummary& s) {
  EXPECT_TRUE(s.converged) << s.message;
  // CTSM-R's 5930.09335342 includes a small penalty that keeps Aw and Cs off their bounds, so
  // the unpenalised optimum is at least as high.
  EXPECT_GE(s.loglik, 5930.09335342 - 1e-6);
  std::ifstream in(kData + "/building3/published.txt");
  std::map<std::string, std::pair<double, double>> published;
  for (std::string line; std::getline(in, line);) {
    std::istringstream ss(line);
    std::string name;
    double est, se;
    if (ss >> name >> est >> se) published[name] = {est, se};
  }
  ASSERT_EQ(published.size(), 19u);
  // Well determined: a standard error here and in CTSM-R, not on a bound, not in a group the
  // data barely separate (|r| > 0.99 with another parameter, where both tools' errors are
  // unreliable), and not one whose standard error here is over 10 times CTSM-R's (p44, the log
  // of a variance that heads for zero along an almost flat ridge: 2.5e8 from CTSM-R's own
  // estimates, where log L is 0.03 above CTSM-R's penalised optimum).
  std::set<std::string> collinear;
  for (Eigen::Index a = 0; a < s.correlation.rows(); ++a)
    for (Eigen::Index b = 0; b < s.correlation.cols(); ++b)
      if (a != b && std::abs(s.correlation(a, b)) > 0.99) collinear.insert(s.correlation_names[a]);
  int compared = 0;
  for (const auto& p : s.parameters) {
    if (!p.std_error || p.at_bound || collinear.count(p.name)) continue;
    const auto [est, se] = published.at(p.name);
    if (*p.std_error > 10 * se) continue;
    EXPECT_LT(std::abs(p.estimate - est), 0.5 * se) << p.name;
    ++compared;
  }
  EXPECT_GE(compared, 10);
}

TEST(Conformance, Building3ReachesOneOptimumFromStartsNoOneCanTellApartOnOneOrTwoThreads) {
  // Issue 33: the outcome may not turn on the last bits of the start or on the thread count.
  // The model file's neutral start with the default options on two threads, as a user runs it,
  // must reach CTSM-R's optimum and published estimates; then two starts no one can tell apart,
  // each free parameter's start value times 1 + 1e-9 and times 1 - 1e-9, on one thread each:
  // every fit at the same optimum, within 1e-6 relative (before the polish of the estimate
  // along its curved valley, EstimateRun::Polish, such starts ended 0.0067 apart, and before
  // runaways were released at 5669.8-5930.1). Three fits in two rounds, the release suite's
  // longest test (docs/quality.md: five fits and a separate neutral-start test took 386 s of
  // CI's 40 min; the neutral start on one thread and an alternating sign pattern were dropped
  // then).
  if (kSanitized)
    GTEST_SKIP() << "the release suite's: the linear estimator, its exact filter "
                    "and scores run under the sanitizers in the fuel film's fits";
  auto spec = model::LoadModelFile(kData + "/building3/model_start.json");
  ASSERT_TRUE(spec.ok());
  struct Run {
    double factor;  // every free parameter's start value times this
    int threads;
  };
  const std::vector<Run> runs = {{1.0, 2}, {1 + 1e-9, 1}, {1 - 1e-9, 1}};
  std::vector<std::optional<EstimateSummary>> fits(runs.size());
  std::vector<std::string> failures(runs.size());
  auto fit = [&](std::size_t r) {
    model::ModelSpec perturbed = *spec;
    for (auto& p : perturbed.parameters)
      if (!p.fixed) p.value *= runs[r].factor;
    auto problem = project::LoadProblem(std::move(perturbed), {kData + "/building3/data.csv"});
    if (!problem.ok()) return failures[r] = problem.error().ToString(), void();
    auto lik = project::MakeLikelihood(*problem);
    EstimateOptions options;  // the defaults, as a user runs them
    options.threads = runs[r].threads;
    auto s = Estimate(*lik, options);
    if (!s.ok()) return failures[r] = s.error().ToString(), void();
    fits[r] = std::move(*s);
  };
  // The fit on two threads alone, then the two on one thread side by side: the machine's two
  // cores.
  fit(0);
  std::thread other(fit, 2);
  fit(1);
  other.join();
  for (std::size_t r = 0; r < runs.size(); ++r) {
    ASSERT_TRUE(failures[r].empty()) << r << ": " << failures[r];
    ASSERT_TRUE(fits[r]);
  }
  ExpectCtsmRsBuilding3Estimates(*fits[0]);
  for (std::size_t r = 1; r < runs.size(); ++r) {
    EXPECT_GE(fits[r]->loglik, 5930.09335342 - 1e-6) << "run " << r;
    EXPECT_NEAR(fits[r]->loglik, fits[0]->loglik, 1e-6 * std::abs(fits[0]->loglik))
        << fmt::format("run {} (starts times {}, {} threads)", r, runs[r].factor, runs[r].threads);
  }
}

// ---- model comparison ------------------------------------------------------------------------

TEST(CompareNested, GivesTheChiSquaredTailProbability) {
  // df = 1: P(χ² > x) = erfc(sqrt(x / 2)); df = 2: exp(-x / 2).
  auto t1 = CompareNested(100.0, 3, 101.5, 4);
  ASSERT_TRUE(t1.ok());
  EXPECT_DOUBLE_EQ(t1->statistic, 3.0);
  EXPECT_NEAR(t1->p_value, std::erfc(std::sqrt(1.5)), 1e-12);
  auto t2 = CompareNested(100.0, 3, 102.0, 5);
  EXPECT_NEAR(t2->p_value, std::exp(-2.0), 1e-12);
  EXPECT_FALSE(CompareNested(100.0, 5, 102.0, 5).ok());
}

TEST(Estimate, AVariancePinnedOnItsBoundLeadsToAFitWithTheDiffusionRelaxed) {
  // Issue 33: bench/robustness.py's house model thermal_s7 (tests/data/thermal/README.md). From
  // the generic start the plain fit pins a diffusion variance on its bound below the optimum
  // that the start at the true parameters reaches (3851.262, the best known). The fit again
  // with the diffusion relaxed finds it, on one thread and on two.
  if (kSanitized) GTEST_SKIP() << "the release suite's: two fits of a few seconds each";
  const std::string dir = std::string(GREYBENCH_SOURCE_DIR) + "/tests/data/thermal/";
  for (const int threads : {1, 2}) {
    auto s = FitWithDefaults(dir + "model_generic.json", {dir + "data.csv"}, threads);
    ASSERT_TRUE(s.ok()) << s.error().ToString();
    EXPECT_GE(s->loglik, 3851.262 - 0.01) << threads << " thread(s)";
    EXPECT_EQ(s->relaxed_starts, 1);
    EXPECT_TRUE(s->relaxed_better);
  }
}

TEST(Estimate, APositiveParameterCreepingDownAValleyToItsBoundGoesOnOnALogScale) {
  // Issue 33: the Cascaded Tanks SDE (the published benchmark's estimation record) from its
  // model file's generic starts. Its optimum has the upper tank's outflow coefficient k1 on its
  // lower bound, traded along a narrow valley against the exponent a1 and the overflow level
  // h1max over two decades; on the fitter's linear scale the fit crawled down it for about a
  // thousand iterations (966 with the extra starts off, 1478 with the defaults). Once BHHH
  // crawls with k1 falling at every step, k1 goes on a log scale, where the valley is straight
  // (docs/benchmarks.md). The same optimum as the bundled result's, in a few hundred
  // iterations; k1 crept onto its bound, so it is not released back to its start (a start
  // from which the exploring fit strays where the ODE is stiff): only the measurement
  // variance r, which did run off, is.
  if (kSanitized) GTEST_SKIP() << "the release suite's: a fit of a few seconds";
  const std::string root = std::string(GREYBENCH_SOURCE_DIR);
  auto s = FitWithDefaults(root + "/assets/models/cascaded_tanks_sde.json",
                           {root + "/assets/data/tanks_estimation.csv"}, 1);
  ASSERT_TRUE(s.ok()) << s.error().ToString();
  EXPECT_TRUE(s->converged) << s->message;
  EXPECT_NEAR(s->loglik, 2193.043379, 2e-6);
  EXPECT_LT(s->iterations, 600);
  EXPECT_EQ(s->released_starts, 1);
  EXPECT_NE(std::find(s->log_scale.begin(), s->log_scale.end(), "k1"), s->log_scale.end());
  EXPECT_NE(s->Report().find("k1 (ended on it)"), std::string::npos) << s->Report();
  for (const auto& p : s->parameters) {
    if (p.name == "k1") {
      EXPECT_TRUE(p.at_bound);
    }
  }
}

}  // namespace
}  // namespace gb::estimate
