// Issue 14: profile likelihood intervals, priors (MAP), multistart and the delay search from
// generic starts. Every expected number comes from an independent computation: fits with the
// parameter held (brute-force profile), a golden-section maximisation of the log posterior, the
// Monte Carlo coverage of the intervals, the published Table 2 optimum.
#include <algorithm>
#include <cmath>
#include <map>
#include <optional>

#include <boost/math/distributions/chi_squared.hpp>
#include <fmt/format.h>
#include <gtest/gtest.h>

#include "core/design/prbs.h"
#include "core/estimate/estimate.h"
#include "core/model/linear_model.h"
#include "core/project/problem.h"
#include "core/sim/simulate.h"
#include "core/util/json.h"
#include "core/util/sanitizers.h"
#include "tests/core/estimate_fixtures.h"
#include "tests/shortened_data.h"

namespace gb::estimate {
namespace {

const std::string kSource = GREYBENCH_SOURCE_DIR;

using testing::Compile;

// A first-order system with a PRBS input: dx = (-x + K u)/tau dt + s dω, y = x + e, Var e = r.
Json Scalar() {
  return Json::parse(R"json({
    "greybench_model": 1, "states": ["x"], "inputs": ["u"], "outputs": ["y"],
    "parameters": {"tau": {"value": 1.0, "lower": 0.05, "upper": 50},
                   "K": {"value": 1.0, "lower": -10, "upper": 10},
                   "s": {"value": 0.5, "lower": 1e-4, "upper": 10},
                   "r": {"value": 0.1, "lower": 1e-6, "upper": 10}},
    "drift": {"x": "(-x + K*u)/tau"}, "diffusion": {"x": "s"},
    "observation": {"y": "x"}, "measurement_variance": {"y": "r"},
    "initial_covariance": "stationary"})json");
}

const std::map<std::string, double> kScalarTruth = {
    {"tau", 2.0}, {"K", 1.5}, {"s", 0.3}, {"r", 0.05}};

std::shared_ptr<const data::Series> SimulateScalar(double duration, std::uint64_t seed) {
  Json truth = Scalar();
  for (const auto& [k, v] : kScalarTruth) truth["parameters"][k]["value"] = v;
  design::PrbsOptions prbs;
  prbs.order = 5;
  prbs.bit_period = 1.0;
  prbs.sample_time = 0.25;
  prbs.duration = duration;
  prbs.seed = static_cast<std::uint32_t>(seed);
  return testing::Simulate(*Compile(truth), {prbs}, seed + 1000);
}

EstimateSummary Fit(const Json& j, const std::shared_ptr<const data::Series>& series,
                    EstimateOptions o = {}) {
  auto lik = filter::Likelihood::Create(Compile(j), {series});
  EXPECT_TRUE(lik.ok());
  o.threads = o.threads ? o.threads : 1;
  auto s = Estimate(*lik, o);
  EXPECT_TRUE(s.ok()) << s.error().ToString();
  return *s;
}

const ParameterEstimate& Param(const EstimateSummary& s, const std::string& name) {
  for (const auto& p : s.parameters)
    if (p.name == name) return p;
  throw std::runtime_error("no parameter " + name);
}

// ---- profile intervals -------------------------------------------------------------------------

TEST(ProfileIntervals, EndsAreWhereBruteForceFitsCrossTheThresholdAndDifferFromWald) {
  // 30 s of data (120 samples): the log-likelihood of the variances is far from quadratic.
  const auto series = SimulateScalar(30.0, 3);
  EstimateOptions o;
  o.profile_intervals = true;
  const EstimateSummary s = Fit(Scalar(), series, o);
  ASSERT_TRUE(s.converged) << s.message;
  const double threshold =
      s.loglik - boost::math::quantile(boost::math::chi_squared(1.0), 0.95) / 2;
  // The brute-force profile at v: θ_p fixed at v in the model file, the others fitted from the
  // model's (neutral) start values.
  auto profile_at = [&](const std::string& name, double v) {
    Json j = Scalar();
    j["parameters"][name] = Json::object({{"value", v}, {"fixed", true}});
    return Fit(j, series).loglik;
  };
  int marked = 0;
  for (const std::string name : {"tau", "s", "r"}) {
    SCOPED_TRACE(name);
    const ParameterEstimate& p = Param(s, name);
    ASSERT_TRUE(p.profile && p.profile->lower && p.profile->upper) << s.Report();
    ASSERT_TRUE(p.std_error);
    const double lo = *p.profile->lower, hi = *p.profile->upper;
    EXPECT_LT(lo, p.estimate);
    EXPECT_GT(hi, p.estimate);
    // Just inside each end the profile is above the threshold, just outside below it.
    const double d = 0.01 * (hi - lo);
    EXPECT_GT(profile_at(name, lo + d), threshold);
    EXPECT_LT(profile_at(name, lo - d), threshold);
    EXPECT_GT(profile_at(name, hi - d), threshold);
    EXPECT_LT(profile_at(name, hi + d), threshold);
    // The curve holds the estimate's value at the estimate.
    bool at_estimate = false;
    for (const auto& pt : p.profile->curve)
      if (pt.value == p.estimate) at_estimate = std::abs(pt.loglik - s.loglik) < 1e-6;
    EXPECT_TRUE(at_estimate);
    const double half = 1.959964 * *p.std_error;
    if (std::abs(hi - (p.estimate + half)) > 0.1 * half ||
        std::abs(lo - (p.estimate - half)) > 0.1 * half)
      ++marked;
  }
  EXPECT_GE(marked, 1) << "no interval differs markedly from Wald's: pick a harder case\n"
                       << s.Report();
  // In the JSON, as the issue specifies.
  const Json j = s.ToJson();
  const Json& r = j["parameters"]["r"]["profile_interval"];
  EXPECT_DOUBLE_EQ(r["lower"].get<double>(), *Param(s, "r").profile->lower);
  EXPECT_DOUBLE_EQ(r["level"].get<double>(), 0.95);
  EXPECT_NE(s.Report().find("profile lower"), std::string::npos);
}

TEST(ProfileIntervals, AnEndBeyondTheBoundIsNullAndSaidSo) {
  // The measurement variance's lower bound 0.04 sits inside its profile interval.
  const auto series = SimulateScalar(30.0, 3);
  Json j = Scalar();
  j["parameters"]["r"]["lower"] = 0.04;
  EstimateOptions o;
  o.profile_intervals = true;
  const EstimateSummary s = Fit(j, series, o);
  const ParameterEstimate& r = Param(s, "r");
  ASSERT_TRUE(r.profile);
  EXPECT_FALSE(r.profile->lower.has_value()) << s.Report();
  EXPECT_TRUE(r.profile->lower_at_bound);
  EXPECT_TRUE(r.profile->upper.has_value());
  EXPECT_TRUE(s.ToJson()["parameters"]["r"]["profile_interval"]["lower"].is_null());
  bool said = false;
  for (const auto& w : s.warnings)
    said = said || w.find("down to its lower bound") != std::string::npos;
  EXPECT_TRUE(said) << s.Report();
}

TEST(ProfileIntervals, NinetyFivePercentIntervalsCoverTheTruthAtTheNominalRate) {
  // 200 replicates of 150 s (600 samples); the profile intervals of tau and r.
  const int replicates = kSanitized ? 4 : 200;
  int covered = 0, total = 0;
  for (int rep = 0; rep < replicates; ++rep) {
    const auto series = SimulateScalar(150.0, 100 + rep);
    auto lik = filter::Likelihood::Create(Compile(Scalar()), {series});
    ASSERT_TRUE(lik.ok());
    EstimateOptions o;
    o.threads = 1;
    auto s = Estimate(*lik, o);
    ASSERT_TRUE(s.ok());
    auto intervals = ProfileIntervals(*lik, *s, {"tau", "r"}, 0.95, o);
    ASSERT_TRUE(intervals.ok()) << intervals.error().ToString();
    for (std::size_t i = 0; i < 2; ++i) {
      const auto& pi = (*intervals)[i];
      if (!pi.lower || !pi.upper) continue;
      const double truth = kScalarTruth.at(i == 0 ? "tau" : "r");
      ++total;
      if (*pi.lower <= truth && truth <= *pi.upper) ++covered;
    }
  }
  EXPECT_GE(total, 2 * replicates - 2);
  const double rate = static_cast<double>(covered) / total;
  if (!kSanitized) {
    EXPECT_GE(rate, 0.90);
    EXPECT_LE(rate, 0.98);
  }
  RecordProperty("coverage", fmt::format("{:.4f}", rate));
}

// ---- priors (MAP) ------------------------------------------------------------------------------

TEST(Priors, WideGivesTheMlEstimateTightGivesTheMeanAndBetweenTheLogPosteriorMaximum) {
  const auto series = SimulateScalar(60.0, 5);
  // tau alone free, the others at the truth: a one-dimensional posterior.
  Json j = Scalar();
  for (const std::string name : {"K", "s", "r"})
    j["parameters"][name] = Json::object({{"value", kScalarTruth.at(name)}, {"fixed", true}});
  const EstimateSummary ml = Fit(j, series);
  const double tau_ml = Param(ml, "tau").estimate;
  const double se_ml = *Param(ml, "tau").std_error;
  auto with_prior = [&](double mean, double sd) {
    Json jp = j;
    jp["parameters"]["tau"]["prior"] = {{"mean", mean}, {"sd", sd}};
    return Fit(jp, series);
  };
  // Very wide: the ML estimate.
  const EstimateSummary wide = with_prior(1.0, 1e6);
  EXPECT_NEAR(Param(wide, "tau").estimate, tau_ml, 1e-6 * tau_ml);
  ASSERT_TRUE(wide.log_posterior.has_value());
  EXPECT_NE(wide.Report().find("MAP estimate"), std::string::npos);
  EXPECT_TRUE(wide.ToJson().contains("log_posterior"));
  // Very tight: its mean.
  const EstimateSummary tight = with_prior(1.0, 1e-7);
  EXPECT_NEAR(Param(tight, "tau").estimate, 1.0, 1e-5);
  // In between (sd = the ML standard error, mean 2 SE below): the maximum of log L + log prior
  // by golden-section search on the log posterior, evaluated directly.
  const double mean = tau_ml - 2 * se_ml, sd = se_ml;
  const EstimateSummary map = with_prior(mean, sd);
  auto lik = filter::Likelihood::Create(Compile(j), {series});
  const int tau_index = lik->spec().ParameterIndex("tau");
  auto log_posterior = [&](double tau) {
    std::vector<double> theta = lik->spec().Values();
    theta[tau_index] = tau;
    const double t = (tau - mean) / sd;
    return lik->Evaluate(theta)->loglik - 0.5 * t * t;
  };
  double a = mean - 2 * sd, b = tau_ml + sd;
  const double phi = (std::sqrt(5.0) - 1) / 2;
  for (int it = 0; it < 200 && b - a > 1e-12; ++it) {
    const double c = b - phi * (b - a), d = a + phi * (b - a);
    if (log_posterior(c) > log_posterior(d))
      b = d;
    else
      a = c;
  }
  const double brute = (a + b) / 2;
  EXPECT_GT(brute, mean);
  EXPECT_LT(brute, tau_ml);
  EXPECT_NEAR(Param(map, "tau").estimate, brute, 1e-6 * brute);
  // Its standard error is the posterior's: smaller than the likelihood's.
  EXPECT_LT(*Param(map, "tau").std_error, se_ml);
}

TEST(Priors, ABadPriorIsAnErrorNamingItsPath) {
  Json j = Scalar();
  j["parameters"]["tau"]["prior"] = {{"mean", 1.0}, {"sd", 0.0}};
  auto spec = model::ParseModel(j, "m.json");
  ASSERT_FALSE(spec.ok());
  EXPECT_NE(spec.error().ToString().find("parameters.tau.prior.sd"), std::string::npos)
      << spec.error().ToString();
  j["parameters"]["tau"]["prior"] = {{"mean", 1.0}, {"sigma", 0.1}};
  spec = model::ParseModel(j, "m.json");
  ASSERT_FALSE(spec.ok());
  EXPECT_NE(spec.error().ToString().find("parameters.tau.prior.sigma"), std::string::npos);
  // A prior survives a round trip through the file format.
  j["parameters"]["tau"]["prior"] = {{"mean", 1.0}, {"sd", 0.25}};
  spec = model::ParseModel(j, "m.json");
  ASSERT_TRUE(spec.ok());
  auto again = model::ParseModel(model::ToJson(*spec), "again.json");
  ASSERT_TRUE(again.ok());
  const auto& prior = again->parameters[again->ParameterIndex("tau")].prior;
  ASSERT_TRUE(prior.has_value());
  EXPECT_EQ(prior->sd, 0.25);
}

// ---- generic starts: the fuel film with little fuel on the film (issue 14) ----------------------

// The generic fuel-film model on a dyno record; under the sanitizers on its first `rows` rows
// (the same code paths, a fraction of the time).
std::shared_ptr<const filter::Likelihood> GenericFuelFilm(const std::string& point, int delay_min,
                                                          int delay_max, int rows,
                                                          std::optional<double> tau_ff_max = {}) {
  auto spec = model::LoadModelFile(kSource + "/bench/models/fuel_film_generic.json");
  EXPECT_TRUE(spec.ok());
  if (tau_ff_max)
    for (auto& p : spec->parameters)
      if (p.name == "tau_ff") p.upper = *tau_ff_max;
  spec->output_delay[0].min = delay_min;
  spec->output_delay[0].max = delay_max;
  auto problem = project::LoadProblem(
      std::move(*spec),
      {testing::ShortenedUnderSanitizers(kSource + "/assets/data/fuel_" + point + ".csv", rows)});
  EXPECT_TRUE(problem.ok());
  auto lik = project::MakeLikelihood(*problem);
  EXPECT_TRUE(lik.ok());
  return std::make_shared<const filter::Likelihood>(std::move(*lik));
}

TEST(Estimate, GenericStartsReachTheTable2OptimumWithEveryDelayOfTheProfileConverged) {
  // Point f3 (X ≈ 0.07): the start values favour delay 7, the optimum is at 6. Table 2's fit
  // (docs/case-study-table2.csv, from the tuned model) reached log L 30461.065384. Under the
  // sanitizers the scan is 5..7 on the first 3000 rows: the same code paths, where the log-
  // likelihood is not Table 2's (other observations), so it is not compared.
  const auto lik = GenericFuelFilm("f3", kSanitized ? 5 : 0, kSanitized ? 7 : 10, 3000);
  auto s = Estimate(*lik, EstimateOptions{});
  ASSERT_TRUE(s.ok()) << s.error().ToString();
  EXPECT_TRUE(s->converged) << s->Report();
  EXPECT_EQ(s->delays[0].estimate, 6);
  if (!kSanitized) {
    EXPECT_NEAR(s->loglik, 30461.065384, 1e-3);
  }
  for (const auto& pt : s->delays[0].profile) {
    EXPECT_TRUE(pt.converged) << "delay " << pt.delay;
    ASSERT_TRUE(pt.loglik.has_value());
    EXPECT_LE(*pt.loglik, s->loglik + 1e-9);
  }
  EXPECT_EQ(s->delays[0].profile.size(), kSanitized ? 3u : 11u);
}

TEST(Estimate, MultistartIsNeverWorseThanThePlainStartAndCountsTheStartsAtTheBest) {
  const auto lik = GenericFuelFilm("f8", 6, 6, 2500);
  EstimateOptions one;
  one.threads = 1;
  auto plain = Estimate(*lik, one);
  ASSERT_TRUE(plain.ok());
  EstimateOptions many = one;
  many.multistart = kSanitized ? 1 : 4;
  auto multi = Estimate(*lik, many);
  ASSERT_TRUE(multi.ok());
  EXPECT_GE(multi->loglik, plain->loglik - 1e-6);
  EXPECT_EQ(multi->starts, many.multistart + 1);
  EXPECT_GE(multi->starts_at_best, 1);
  EXPECT_LE(multi->starts_at_best, multi->starts);
  EXPECT_NE(
      multi->Report().find(fmt::format("of {} starts reached the best optimum", multi->starts)),
      std::string::npos);
  EXPECT_EQ(multi->ToJson()["starts"]["total"], multi->starts);
}

TEST(Estimate, ListsTheDistinctOptimaBestFirstEachWithItsStartsAndItsLogLikelihood) {
  const auto lik = GenericFuelFilm("f8", 6, 6, 2500);
  EstimateOptions options;
  options.threads = 1;
  options.multistart = kSanitized ? 1 : 4;
  auto s = Estimate(*lik, options);
  ASSERT_TRUE(s.ok());
  ASSERT_FALSE(s->optima.empty());
  // The first is the estimate.
  EXPECT_NEAR(s->optima.front().loglik, s->loglik, 1e-9);
  EXPECT_EQ(s->optima.front().theta, s->theta);
  EXPECT_EQ(s->optima.front().starts, s->starts_at_best);
  int starts = 0;
  const Json j = s->ToJson();
  ASSERT_EQ(j["optima"].size(), s->optima.size());
  for (std::size_t o = 0; o < s->optima.size(); ++o) {
    const Optimum& opt = s->optima[o];
    starts += opt.starts;
    // Distinct: each lies more than 1e-3 below the one before.
    if (o > 0) {
      EXPECT_LT(opt.loglik, s->optima[o - 1].loglik - 1e-3);
    }
    // Its parameters give its log-likelihood, evaluated afresh.
    const std::vector<int> delay = {s->delays[0].estimate};
    const auto l = lik->Evaluate(opt.theta, delay);
    ASSERT_TRUE(l.ok());
    EXPECT_NEAR(l->loglik, opt.loglik, 1e-6 * std::abs(opt.loglik));
    EXPECT_EQ(j["optima"][o]["starts"], opt.starts);
    EXPECT_EQ(j["optima"][o]["parameters"]["tau_ff"], opt.theta[1]);
  }
  EXPECT_LE(starts, s->starts);
  EXPECT_EQ(s->Report().find("Distinct optima") != std::string::npos, s->optima.size() > 1);
}

TEST(EstimateSummary, AnOptimumDiffersMostInTheParametersFarthestInStandardErrors) {
  EstimateSummary s;
  // a: 1 ± 0.1, b: 10 (no standard error: relative to its size), c: fixed, d: 5 ± 1.
  for (const auto& [name, value, se, fixed] :
       {std::tuple{"a", 1.0, 0.1, false}, std::tuple{"b", 10.0, 0.0, false},
        std::tuple{"c", 3.0, 0.0, true}, std::tuple{"d", 5.0, 1.0, false}}) {
    ParameterEstimate e;
    e.name = name;
    e.estimate = value;
    e.fixed = fixed;
    if (se > 0) e.std_error = se;
    s.parameters.push_back(e);
  }
  s.optima = {{0.0, 1, true, {1.0, 10.0, 3.0, 5.0}}, {-5.0, 1, true, {1.25, 30.0, 99.0, 8.0}}};
  // Distances: a 2.5 SE, b 2 (relative), c fixed (left out), d 3 SE.
  EXPECT_EQ(s.DifferMost(1, 3), (std::vector<std::size_t>{3, 0, 1}));
  EXPECT_EQ(s.DifferMost(1, 1), (std::vector<std::size_t>{3}));
  EXPECT_TRUE(s.DifferMost(0, 3).empty());  // the estimate itself
  EXPECT_TRUE(s.DifferMost(2, 3).empty());  // no such optimum
}

TEST(Estimate, OnALogScaleTheOptimumAndItsStandardErrorsAreTheLinearScalesOnes) {
  // The working scale changes the path, not the answer: the same optimum, and the standard
  // errors of θ (from the Hessian in log θ, with its gradient term, mapped back) agree.
  const auto lik = GenericFuelFilm("f1", 5, 5, 3000);
  EstimateOptions linear, log;
  linear.threads = log.threads = 1;
  log.log_scale = true;
  auto a = Estimate(*lik, linear);
  auto b = Estimate(*lik, log);
  ASSERT_TRUE(a.ok() && b.ok());
  ASSERT_TRUE(a->converged && b->converged) << a->message << " / " << b->message;
  EXPECT_NEAR(a->loglik, b->loglik, 1e-6 * std::abs(a->loglik));
  int compared = 0;
  for (std::size_t i = 0; i < a->parameters.size(); ++i) {
    const ParameterEstimate& p = a->parameters[i];
    if (!p.std_error || !b->parameters[i].std_error) continue;
    ++compared;
    EXPECT_NEAR(b->parameters[i].estimate, p.estimate, 0.01 * *p.std_error) << p.name;
    EXPECT_NEAR(*b->parameters[i].std_error, *p.std_error, 1e-3 * *p.std_error) << p.name;
  }
  EXPECT_GE(compared, 6);
}

TEST(Estimate, TheDelayProfileDoesNotDependOnTheNumberOfThreads) {
  // With 2 threads the plain start's two first fits and the two walkers of the delay profile run
  // side by side, each from the same start as on 1 thread: the same numbers, bit for bit.
  const auto lik = GenericFuelFilm("f1", 3, 7, 3000);
  EstimateOptions one, two;
  one.threads = 1;
  two.threads = 2;
  auto a = Estimate(*lik, one);
  auto b = Estimate(*lik, two);
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_EQ(a->loglik, b->loglik);
  EXPECT_EQ(a->iterations, b->iterations);
  ASSERT_EQ(a->delays[0].profile.size(), 5u);
  ASSERT_EQ(b->delays[0].profile.size(), 5u);
  for (std::size_t i = 0; i < 5; ++i) {
    EXPECT_EQ(a->delays[0].profile[i].loglik, b->delays[0].profile[i].loglik) << i;
    EXPECT_TRUE(a->delays[0].profile[i].converged) << i;
  }
  for (std::size_t i = 0; i < a->theta.size(); ++i) EXPECT_EQ(a->theta[i], b->theta[i]) << i;
}

TEST(Estimate, AnEstimateOnABoundGetsExtraStartsThatNeverMakeItWorse) {
  // τ_ff capped at 0.2 (f8's optimum is near 0.28): the estimate ends on that bound.
  const auto lik = GenericFuelFilm("f8", 6, 6, 2500, 0.2);
  EstimateOptions none;
  none.threads = 1;
  none.starts_on_bound = 0;
  auto plain = Estimate(*lik, none);
  ASSERT_TRUE(plain.ok());
  ASSERT_TRUE(std::any_of(plain->parameters.begin(), plain->parameters.end(),
                          [](const ParameterEstimate& e) { return e.at_bound; }));
  EXPECT_EQ(plain->starts, 1);
  EXPECT_FALSE(plain->starts_for_bound);
  EstimateOptions on_bound = none;
  on_bound.starts_on_bound = kSanitized ? 1 : 4;
  auto extra = Estimate(*lik, on_bound);
  ASSERT_TRUE(extra.ok());
  EXPECT_GE(extra->loglik, plain->loglik - 1e-6);
  EXPECT_EQ(extra->starts, on_bound.starts_on_bound + 1);
  EXPECT_TRUE(extra->starts_for_bound);
  EXPECT_NE(extra->Report().find("Extra starts (parameters ran off or ended on a bound)"),
            std::string::npos);
  EXPECT_EQ(extra->ToJson()["starts"]["on_bound"], true);
  // Explicit multistart replaces them.
  EstimateOptions multi = on_bound;
  multi.multistart = 1;
  auto m = Estimate(*lik, multi);
  ASSERT_TRUE(m.ok());
  EXPECT_EQ(m->starts, 2);
  EXPECT_FALSE(m->starts_for_bound);
}

}  // namespace
}  // namespace gb::estimate
