// Numerical faults (issue 8): each one gives a clear message or a flagged result, never a crash,
// a hang or a NaN reported as a number, and the optimiser recovers from non-finite points.
//
// Sections: 1. helpers  2. unstable A  3. time constants from 1e-4 to 1e4 s  4. degenerate
//           innovation variances  5. parameters at bounds  6. non-finite numbers in data, model
//           files, --set and expressions  7. an optimiser that wanders into non-finite log L
//           8. files written atomically
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <random>
#include <sstream>

#include <Eigen/Dense>
#include <gtest/gtest.h>
#include <unistd.h>

#include "core/data/dataset.h"
#include "core/design/prbs.h"
#include "core/estimate/estimate.h"
#include "core/filter/kalman.h"
#include "core/filter/likelihood.h"
#include "core/filter/predict.h"
#include "core/model/linear_model.h"
#include "core/project/project.h"
#include "core/sim/simulate.h"
#include "core/util/file.h"

namespace gb {
namespace {

// ---- 1. helpers --------------------------------------------------------------------------------

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kLog2Pi = 1.8378770664093454835606594728112;

Result<model::LinearModel> TryCompile(const Json& j) {
  auto spec = model::ParseModel(j, "test.json");
  if (!spec) return spec.error();
  return model::LinearModel::Compile(std::move(*spec));
}

std::shared_ptr<const model::LinearModel> Compile(const Json& j) {
  auto lm = TryCompile(j);
  EXPECT_TRUE(lm.ok()) << lm.error().ToString();
  return std::make_shared<const model::LinearModel>(std::move(*lm));
}

data::Series MakeSeries(std::vector<double> t, Eigen::MatrixXd U, Eigen::MatrixXd Y) {
  data::Series s;
  s.source = "test.csv";
  s.intervals = data::GroupIntervals(t);
  s.time = std::move(t);
  s.U = std::move(U);
  s.Y = std::move(Y);
  return s;
}

// Regular times 0, dt, 2 dt, ... and outputs simulated from `truth` at its values, with a PRBS
// on each input (or none).
std::shared_ptr<const data::Series> SimulatePrbs(const model::LinearModel& truth, int N, double dt,
                                                 double bit_period, std::uint64_t seed) {
  std::vector<double> t(N);
  for (int k = 0; k < N; ++k) t[k] = k * dt;
  Eigen::MatrixXd U(truth.n_inputs(), N);
  for (int i = 0; i < truth.n_inputs(); ++i) {
    design::PrbsOptions prbs;
    prbs.order = 7;
    prbs.bit_period = bit_period;
    prbs.sample_time = dt;
    prbs.duration = N * dt;
    prbs.seed = static_cast<std::uint32_t>(seed + i);
    auto u = design::MakePrbs(prbs);
    EXPECT_TRUE(u.ok());
    for (int k = 0; k < N; ++k) U(i, k) = u->u[std::min<std::size_t>(k, u->u.size() - 1)];
  }
  data::Series s = MakeSeries(t, U, Eigen::MatrixXd::Zero(truth.n_outputs(), N));
  const auto ss = truth.Evaluate(truth.spec().Values());
  EXPECT_TRUE(ss.ok());
  sim::SimulateOptions o;
  o.seed = seed;
  auto sim = sim::Simulate(*ss, s, filter::FilterSettings::FromModel(truth.spec()), o);
  EXPECT_TRUE(sim.ok());
  s.Y = sim->Y;
  return std::make_shared<const data::Series>(std::move(s));
}

// A result is either a finite value or an error with a message: never a non-finite number.
void ExpectFiniteOrMessage(const Result<filter::Loglik>& l) {
  if (l.ok()) {
    EXPECT_TRUE(std::isfinite(l->loglik)) << "a non-finite log-likelihood returned as a value";
  } else {
    EXPECT_EQ(l.error().kind, ErrorKind::kNumerical);
    EXPECT_FALSE(l.error().message.empty());
  }
}

// The scalar model dx = a x dt + s dω, y = x + e, e ~ N(0, r), x(0) ~ N(m0, P0).
Json ScalarModel(double a, double s, double r) {
  Json j = Json::parse(R"json({
    "greybench_model": 1, "states": ["x"], "inputs": [], "outputs": ["y"],
    "parameters": {"a": 0, "s": 0, "r": 0, "m0": {"value": 1.0, "fixed": true}},
    "drift": {"x": "a*x"}, "diffusion": {"x": "s"}, "observation": {"y": "x"},
    "measurement_variance": {"y": "r"}, "initial_state": {"x": "m0"}})json");
  j["parameters"]["a"] = a;
  j["parameters"]["s"] = s;
  j["parameters"]["r"] = r;
  return j;
}

// ---- 2. unstable A -----------------------------------------------------------------------------

// The whole-series density of y = (y_0 .. y_{N-1}) for the scalar model at regular dt, from the
// covariance of the exact process: Var x_{k+1} = φ² Var x_k + q, Cov(x_i, x_j) = φ^{j-i} Var x_i.
double BruteForceScalarLoglik(double a, double s, double r, double m0, double dt,
                              const Eigen::VectorXd& y) {
  const int N = static_cast<int>(y.size());
  const double phi = std::exp(a * dt);
  const double q = s * s * std::expm1(2 * a * dt) / (2 * a);
  Eigen::VectorXd var(N), mean(N);
  var(0) = q;  // the "ctsm" P0: Q over the first interval
  mean(0) = m0;
  for (int k = 1; k < N; ++k) {
    var(k) = phi * phi * var(k - 1) + q;
    mean(k) = phi * mean(k - 1);
  }
  Eigen::MatrixXd Sigma(N, N);
  for (int i = 0; i < N; ++i)
    for (int j = i; j < N; ++j) Sigma(i, j) = Sigma(j, i) = std::pow(phi, j - i) * var(i);
  Sigma.diagonal().array() += r;
  const Eigen::LLT<Eigen::MatrixXd> llt(Sigma);
  EXPECT_EQ(llt.info(), Eigen::Success);
  const Eigen::VectorXd e = y - mean;
  const double logdet = 2 * llt.matrixL().toDenseMatrix().diagonal().array().log().sum();
  return -0.5 * (logdet + e.dot(llt.solve(e)) + N * kLog2Pi);
}

TEST(Faults, UnstableAGivesTheExactFiniteLikelihoodWithTheCtsmInitialCovariance) {
  const double a = 0.3, s = 0.5, r = 0.2, dt = 0.5;
  const auto lm = Compile(ScalarModel(a, s, r));
  const int N = 30;
  std::vector<double> t(N);
  Eigen::MatrixXd Y(1, N);
  std::mt19937 rng(5);
  std::normal_distribution<double> normal(0.0, 1.0);
  for (int k = 0; k < N; ++k) {
    t[k] = k * dt;
    Y(0, k) = std::exp(a * t[k]) + 0.7 * normal(rng);  // growing, as the unstable mode does
  }
  const data::Series series = MakeSeries(t, Eigen::MatrixXd(0, N), Y);
  const auto ss = lm->Evaluate(lm->spec().Values());
  ASSERT_TRUE(ss.ok());
  const auto l = filter::LogLikelihood(*ss, series, filter::FilterSettings::FromModel(lm->spec()));
  ASSERT_TRUE(l.ok()) << l.error().ToString();
  const double expected = BruteForceScalarLoglik(a, s, r, 1.0, dt, Y.row(0).transpose());
  EXPECT_NEAR(l->loglik, expected, 1e-9 * std::abs(expected));
}

TEST(Faults, UnstableAOverALongSeriesStaysFiniteAndPredictsFinitely) {
  // e^{aT} = e^{600}: the open-loop mean overflows, the filtered one does not.
  const double a = 1.0, dt = 1.0;
  const auto lm = Compile(ScalarModel(a, 0.5, 0.2));
  const int N = 600;
  std::vector<double> t(N);
  Eigen::MatrixXd Y(1, N);
  for (int k = 0; k < N; ++k) {
    t[k] = k * dt;
    Y(0, k) = std::sin(0.1 * k);
  }
  const data::Series series = MakeSeries(t, Eigen::MatrixXd(0, N), Y);
  const auto ss = lm->Evaluate(lm->spec().Values());
  const auto settings = filter::FilterSettings::FromModel(lm->spec());
  const auto l = filter::LogLikelihood(*ss, series, settings);
  ASSERT_TRUE(l.ok()) << l.error().ToString();
  EXPECT_TRUE(std::isfinite(l->loglik));
  const auto pred = filter::PredictOneStep(*ss, series, settings);
  ASSERT_TRUE(pred.ok());
  EXPECT_TRUE(pred->y_pred.allFinite());
  EXPECT_TRUE(pred->y_sd.allFinite());
  EXPECT_TRUE((pred->y_sd.array() > 0).all());
}

TEST(Faults, StationaryInitialCovarianceRefusesAnUnstableAWithTheEigenvalue) {
  Json j = ScalarModel(0.3, 0.5, 0.2);
  j["initial_covariance"] = "stationary";
  const auto lm = Compile(j);
  const data::Series series =
      MakeSeries({0, 1, 2}, Eigen::MatrixXd(0, 3), Eigen::MatrixXd::Ones(1, 3));
  const auto ss = lm->Evaluate(lm->spec().Values());
  const auto settings = filter::FilterSettings::FromModel(lm->spec());
  const auto l = filter::LogLikelihood(*ss, series, settings);
  ASSERT_FALSE(l.ok());
  EXPECT_EQ(l.error().kind, ErrorKind::kNumerical);
  EXPECT_NE(l.error().message.find("stable A"), std::string::npos) << l.error().message;
  EXPECT_NE(l.error().message.find("0.3"), std::string::npos) << l.error().message;
  // The simulator and the estimator refuse the same way, with the same reason.
  EXPECT_FALSE(sim::Simulate(*ss, series, settings, {}).ok());
  auto lik = filter::Likelihood::Create(lm, {std::make_shared<const data::Series>(series)});
  ASSERT_TRUE(lik.ok());
  const auto est = estimate::Estimate(*lik, {});
  ASSERT_FALSE(est.ok());
  EXPECT_NE(est.error().message.find("stable A"), std::string::npos) << est.error().message;
  // A marginally stable A (an integrator) has no stationary covariance either.
  j["parameters"]["a"] = 0.0;
  const auto integrator = Compile(j);
  const auto l0 =
      filter::LogLikelihood(*integrator->Evaluate(integrator->spec().Values()), series, settings);
  ASSERT_FALSE(l0.ok());
  EXPECT_NE(l0.error().message.find("stable A"), std::string::npos) << l0.error().message;
}

// ---- 3. time constants from 1e-4 to 1e4 s in one model -----------------------------------------

// Three first-order lags in parallel with time constants 1e-4 s, 1 s and 1e4 s, sampled at
// 0.05 s: the fast one is white noise at that rate, the slow one an integrator.
Json StiffModel() {
  return Json::parse(R"json({
    "greybench_model": 1, "states": ["xf", "xm", "xs"], "inputs": ["u"], "outputs": ["y"],
    "parameters": {
      "tau_f": {"value": 1e-4, "fixed": true}, "tau_m": {"value": 1.0, "lower": 0.01, "upper": 100},
      "tau_s": {"value": 1e4, "fixed": true},
      "kf": {"value": 1.0, "lower": -10, "upper": 10}, "km": {"value": 2.0, "lower": -10, "upper": 10},
      "ks": {"value": 300.0, "lower": 0, "upper": 1e4},
      "qf": {"value": 1.0, "fixed": true}, "qs": {"value": 1e-3, "lower": 0, "upper": 1},
      "r": {"value": 1e-3, "lower": 0, "upper": 1}},
    "drift": {"xf": "(-xf + kf*u)/tau_f", "xm": "(-xm + km*u)/tau_m", "xs": "(-xs + ks*u)/tau_s"},
    "diffusion": {"xf": "sqrt(qf)", "xm": "0", "xs": "sqrt(qs)"},
    "observation": {"y": "xf + xm + xs"},
    "measurement_variance": {"y": "r"}})json");
}

TEST(Faults, TimeConstantsFromTenMicroToTenKiloSecondsEstimateAndPredictFinitely) {
  const auto truth = Compile(StiffModel());
  const auto series = SimulatePrbs(*truth, 3000, 0.05, 2.0, 11);
  Json start = StiffModel();
  const std::map<std::string, double> values = {{"tau_m", 1.0}, {"kf", 1.0},  {"km", 2.0},
                                                {"ks", 300.0},  {"qs", 1e-3}, {"r", 1e-3}};
  for (const auto& [name, v] : values) start["parameters"][name]["value"] = v * 1.5;
  auto lik = filter::Likelihood::Create(Compile(start), {series});
  ASSERT_TRUE(lik.ok());
  estimate::EstimateOptions options;
  options.threads = 2;
  const auto s = estimate::Estimate(*lik, options);
  ASSERT_TRUE(s.ok()) << s.error().ToString();
  EXPECT_TRUE(s->converged) << s->message;
  EXPECT_TRUE(std::isfinite(s->loglik));
  for (const auto& p : s->parameters) {
    EXPECT_TRUE(std::isfinite(p.estimate)) << p.name;
    if (p.fixed) continue;
    ASSERT_TRUE(p.std_error.has_value()) << p.name;
    EXPECT_TRUE(std::isfinite(*p.std_error) && *p.std_error > 0) << p.name;
    // Within 4 standard errors of the truth (a Monte Carlo property of the ML estimate).
    EXPECT_LT(std::abs(p.estimate - values.at(p.name)), 4 * *p.std_error)
        << p.name << " = " << p.estimate << " ± " << *p.std_error;
  }
  // Predictions at the estimate: one step and 20 steps ahead, finite everywhere.
  const auto ss = lik->linear()->Evaluate(s->theta);
  ASSERT_TRUE(ss.ok());
  const auto one = filter::PredictOneStep(*ss, *series, lik->settings());
  ASSERT_TRUE(one.ok());
  EXPECT_TRUE(one->y_pred.allFinite() && one->y_sd.allFinite() && one->residual.allFinite());
  const auto ahead = filter::PredictAhead(*ss, *series, lik->settings(), 20);
  ASSERT_TRUE(ahead.ok());
  EXPECT_TRUE(ahead->y_pred.rightCols(series->size() - 20).allFinite());
  EXPECT_TRUE(ahead->y_sd.rightCols(series->size() - 20).allFinite());
  // The one-step residuals are white with unit variance when standardised (a property of the
  // innovations of the true model): their sample variance is 1 within a few standard errors.
  const double var = one->standardized.array().square().mean();
  EXPECT_NEAR(var, 1.0, 4 * std::sqrt(2.0 / series->size()));
}

// ---- 4. degenerate innovation variances ---------------------------------------------------------

TEST(Faults, ZeroMeasurementVarianceWithAKnownStateIsRefusedNamingTheRow) {
  Json j = ScalarModel(-1.0, 0.0, 0.0);
  j["initial_covariance"] = Json::object({{"x", "0"}});
  const auto lm = Compile(j);
  data::Series series = MakeSeries({0, 1, 2}, Eigen::MatrixXd(0, 3), Eigen::MatrixXd::Ones(1, 3));
  series.outputs = {"y"};          // as Bind sets them
  series.row_line = {12, 13, 14};  // the file lines of the rows
  const auto ss = lm->Evaluate(lm->spec().Values());
  ASSERT_TRUE(ss.ok());
  const auto l = filter::LogLikelihood(*ss, series, filter::FilterSettings::FromModel(lm->spec()));
  ASSERT_FALSE(l.ok());
  EXPECT_EQ(l.error().file, "test.csv");
  EXPECT_EQ(l.error().line, 12);
  EXPECT_EQ(l.error().kind, ErrorKind::kNumerical);
  EXPECT_NE(l.error().message.find("row 1"), std::string::npos) << l.error().message;
  EXPECT_NE(l.error().message.find("not positive"), std::string::npos) << l.error().message;
  EXPECT_NE(l.error().message.find("'y'"), std::string::npos) << l.error().message;
}

TEST(Faults, TinyMeasurementVariancesGiveAFiniteLikelihoodOrAMessage) {
  for (double r : {1e-12, 1e-300, 1e-320, 4.9e-324}) {
    Json j = ScalarModel(-1.0, 0.0, r);
    j["initial_covariance"] = Json::object({{"x", "0"}});
    const auto lm = Compile(j);
    const data::Series series =
        MakeSeries({0, 1, 2, 3}, Eigen::MatrixXd(0, 4), Eigen::MatrixXd::Constant(1, 4, 2.0));
    const auto ss = lm->Evaluate(lm->spec().Values());
    ASSERT_TRUE(ss.ok());
    const auto l =
        filter::LogLikelihood(*ss, series, filter::FilterSettings::FromModel(lm->spec()));
    SCOPED_TRACE(r);
    ExpectFiniteOrMessage(l);
    // The predictions report the same failure rather than non-finite numbers.
    const auto pred =
        filter::PredictOneStep(*ss, series, filter::FilterSettings::FromModel(lm->spec()));
    if (pred.ok()) {
      EXPECT_TRUE(std::isfinite(pred->loglik.loglik));
    }
  }
}

TEST(Faults, ANegativeVarianceExpressionIsNamedNotFiltered) {
  Json j = ScalarModel(-1.0, 0.5, 0.2);
  j["measurement_variance"]["y"] = "r - 1";
  const auto lm = Compile(j);
  const auto ss = lm->Evaluate(lm->spec().Values());
  ASSERT_FALSE(ss.ok());
  EXPECT_EQ(ss.error().kind, ErrorKind::kNumerical);
  EXPECT_NE(ss.error().message.find("measurement_variance.y"), std::string::npos);
  EXPECT_NE(ss.error().message.find("negative"), std::string::npos);
}

// ---- 5. parameters at bounds --------------------------------------------------------------------

TEST(Faults, AnEstimateOnItsBoundIsFlaggedAndHasNoStandardError) {
  // The data have r = 0.5; the box allows at most 0.05.
  const auto truth = Compile(ScalarModel(-0.5, 0.7, 0.5));
  std::vector<double> t(800);
  for (int k = 0; k < 800; ++k) t[k] = 0.2 * k;
  data::Series s0 = MakeSeries(t, Eigen::MatrixXd(0, 800), Eigen::MatrixXd::Zero(1, 800));
  sim::SimulateOptions o;
  o.seed = 3;
  s0.Y = sim::Simulate(*truth->Evaluate(truth->spec().Values()), s0,
                       filter::FilterSettings::FromModel(truth->spec()), o)
             ->Y;
  Json j = ScalarModel(-0.3, 0.5, 0.01);
  j["parameters"]["r"] = Json::object({{"value", 0.01}, {"lower", 1e-4}, {"upper", 0.05}});
  j["parameters"]["a"] = Json::object({{"value", -0.3}, {"lower", -10}, {"upper", -1e-3}});
  auto lik = filter::Likelihood::Create(Compile(j), {std::make_shared<const data::Series>(s0)});
  ASSERT_TRUE(lik.ok());
  estimate::EstimateOptions options;
  options.threads = 2;
  const auto s = estimate::Estimate(*lik, options);
  ASSERT_TRUE(s.ok()) << s.error().ToString();
  const auto& r = s->parameters[2];
  ASSERT_EQ(r.name, "r");
  EXPECT_DOUBLE_EQ(r.estimate, 0.05);
  EXPECT_TRUE(r.at_bound);
  EXPECT_FALSE(r.std_error.has_value());
  EXPECT_FALSE(r.t_value.has_value());
  EXPECT_FALSE(r.p_value.has_value());
  // The others are inside their box and have finite standard errors.
  for (int i : {0, 1}) {
    EXPECT_FALSE(s->parameters[i].at_bound) << s->parameters[i].name;
    ASSERT_TRUE(s->parameters[i].std_error.has_value()) << s->parameters[i].name;
    EXPECT_TRUE(std::isfinite(*s->parameters[i].std_error));
  }
  bool warned = false;
  for (const auto& w : s->warnings)
    warned |= w.find("r is at its upper bound") != std::string::npos;
  EXPECT_TRUE(warned);
  const Json out = s->ToJson();
  EXPECT_TRUE(out["parameters"]["r"]["at_bound"].get<bool>());
  EXPECT_TRUE(out["parameters"]["r"]["std_error"].is_null());
  EXPECT_TRUE(out["parameters"]["r"]["t_value"].is_null());
  // The correlation matrix covers the parameters with a standard error only.
  EXPECT_EQ(s->correlation_names, (std::vector<std::string>{"a", "s"}));
  EXPECT_TRUE(s->correlation.allFinite());
  EXPECT_EQ(s->Report().find("nan"), std::string::npos) << s->Report();
}

// An estimate next to where the model fails: the scalar model whose observation adds
// min(sqrt(d - |a - a0|), 0), which is 0 while |a - a0| <= d and NaN beyond. With a0 just above
// â (or d small) the Hessian's difference points for a fall where log L cannot be evaluated.
// Reference: the same data fitted with the trap far away (a0 = â, d = 1e6): H₀ = Cov₀⁻¹.
class HessianNearAFailure : public ::testing::Test {
 protected:
  static Json Model(double a0, double d) {
    Json j = ScalarModel(-0.5, 0.5, 0.01);
    j["parameters"]["a"] = Json::object({{"value", -0.5}, {"lower", -5}, {"upper", -0.01}});
    j["parameters"]["s"] = Json::object({{"value", 0.5}, {"lower", 1e-3}, {"upper", 10}});
    j["parameters"]["r"] = Json::object({{"value", 0.01}, {"lower", 1e-6}, {"upper", 1}});
    j["parameters"]["a0"] = Json::object({{"value", a0}, {"fixed", true}});
    j["parameters"]["d"] = Json::object({{"value", d}, {"fixed", true}});
    j["observation"]["y"] = "x + min(sqrt(d - abs(a - a0)), 0)";
    return j;
  }
  static void SetUpTestSuite() {
    series_ = SimulatePrbs(*Compile(ScalarModel(-0.5, 0.5, 0.01)), 1000, 0.1, 1.0, 17);
    reference_ = Fit(Model(0, 1e6), nullptr);
  }
  static void TearDownTestSuite() { series_.reset(); }
  // Fits `j`, starting at the reference estimate when there is one.
  static estimate::EstimateSummary Fit(Json j, const estimate::EstimateSummary* start) {
    if (start)
      for (int i : {0, 1, 2}) j["parameters"][start->parameters[i].name]["value"] = start->theta[i];
    auto lik = filter::Likelihood::Create(Compile(j), {series_});
    EXPECT_TRUE(lik.ok());
    estimate::EstimateOptions options;
    options.threads = 2;
    auto s = estimate::Estimate(*lik, options);
    EXPECT_TRUE(s.ok()) << s.error().ToString();
    EXPECT_TRUE(s->converged) << s->message;
    return std::move(*s);
  }
  static bool Warned(const estimate::EstimateSummary& s, const std::string& text) {
    for (const auto& w : s.warnings)
      if (w.find(text) != std::string::npos) return true;
    return false;
  }
  // The Hessian's step of a in natural units (estimate.cpp: differences of the exact gradient,
  // kGradientHessianStep = 1e-5 of |z| in scaled units; scale = |start|, z = θ / scale).
  static double StepOfA() { return 1e-5 * std::abs(reference_.theta[0]); }

  static std::shared_ptr<const data::Series> series_;
  static estimate::EstimateSummary reference_;
};
std::shared_ptr<const data::Series> HessianNearAFailure::series_;
estimate::EstimateSummary HessianNearAFailure::reference_;

TEST_F(HessianNearAFailure, FailingOnOneSideGivesEveryStandardErrorFromOneSidedDifferences) {
  ASSERT_EQ(reference_.correlation_names.size(), 3u) << reference_.Report();
  // log L fails for a < â - step/2: the Hessian's point â - step (and only that side).
  const double a_hat = reference_.theta[0];
  const auto s = Fit(Model(a_hat + 1e6, 1e6 + StepOfA() / 2), &reference_);
  EXPECT_NEAR(s.theta[0], a_hat, 0.05 * StepOfA());
  EXPECT_TRUE(Warned(s, "just below the estimate of a")) << s.Report();
  for (int i : {0, 1, 2}) {
    SCOPED_TRACE(s.parameters[i].name);
    ASSERT_TRUE(s.parameters[i].std_error.has_value()) << s.Report();
    // Second-order one-sided differences: within 0.1% of the central ones of the reference
    // (measured: 9e-6 relative).
    EXPECT_NEAR(*s.parameters[i].std_error, *reference_.parameters[i].std_error,
                1e-3 * *reference_.parameters[i].std_error);
  }
  EXPECT_NEAR(s.correlation(0, 1), reference_.correlation(0, 1), 0.01);
}

TEST_F(HessianNearAFailure, FailingOnBothSidesDropsOnlyThatParameter) {
  // log L fails for |a - â| > step/5: every Hessian point that moves a.
  const double a_hat = reference_.theta[0];
  const auto s = Fit(Model(a_hat, StepOfA() / 5), &reference_);
  EXPECT_TRUE(Warned(s, "on either side of a")) << s.Report();
  EXPECT_FALSE(s.parameters[0].std_error.has_value());
  // s and r: the standard errors with a held at â, from the reference's Hessian H₀ = Cov₀⁻¹:
  // Cov(s, r | a) = (H₀ restricted to s and r)⁻¹.
  const Eigen::MatrixXd H0 = reference_.covariance.inverse();
  const Eigen::MatrixXd conditional = H0.bottomRightCorner(2, 2).inverse();
  for (int i : {1, 2}) {
    SCOPED_TRACE(s.parameters[i].name);
    ASSERT_TRUE(s.parameters[i].std_error.has_value()) << s.Report();
    EXPECT_NEAR(*s.parameters[i].std_error, std::sqrt(conditional(i - 1, i - 1)),
                1e-3 * std::sqrt(conditional(i - 1, i - 1)));
  }
  EXPECT_EQ(s.correlation_names, (std::vector<std::string>{"s", "r"}));
}

// ---- 6. non-finite numbers ----------------------------------------------------------------------

Result<std::shared_ptr<const data::Series>> BindText(const std::string& text) {
  auto d = data::ParseCsv(text, "cells.csv");
  if (!d) return d.error();
  const std::vector<std::string> inputs = {"u"}, outputs = {"y"};
  return data::Bind(**d, inputs, outputs);
}

TEST(Faults, NonFiniteDataCellsAreRefusedNamingLineAndColumnOrMissing) {
  for (const char* cell : {"inf", "-inf", "Infinity", "1e999", "-1e400"}) {
    const auto s = BindText(std::string("t,u,y\n0,1,1\n1,") + cell + ",2\n2,1,3\n");
    ASSERT_FALSE(s.ok()) << cell;
    EXPECT_EQ(s.error().line, 3) << cell;
    EXPECT_EQ(s.error().col, 2) << cell;
    EXPECT_NE(s.error().message.find("not finite"), std::string::npos) << s.error().message;
  }
  for (const char* cell : {"inf", "1e999"}) {  // in an output, too: not a missing value
    const auto s = BindText(std::string("t,u,y\n0,1,1\n1,1,") + cell + "\n2,1,3\n");
    ASSERT_FALSE(s.ok()) << cell;
    EXPECT_EQ(s.error().col, 3) << cell;
  }
  const auto time = BindText("t,u,y\n0,1,1\ninf,1,2\n");
  ASSERT_FALSE(time.ok());
  EXPECT_EQ(time.error().line, 3);
  // NaN in an output is a missing observation; in an input it is an error.
  const auto missing = BindText("t,u,y\n0,1,1\n1,1,NaN\n2,1,3\n");
  ASSERT_TRUE(missing.ok()) << missing.error().ToString();
  EXPECT_TRUE(std::isnan((*missing)->Y(0, 1)));
  const auto input = BindText("t,u,y\n0,1,1\n1,NaN,2\n2,1,3\n");
  ASSERT_FALSE(input.ok());
  EXPECT_EQ(input.error().line, 3);
}

// Found by tests/fuzz/csv_fuzz (2026-11-23): a time column jumping to 1e308 made A·Δ overflow, and
// the number of doublings of the matrix exponential was log2(inf) converted to int (undefined).
TEST(Faults, AnIntervalTooLongToDiscretiseIsNamedByItsRowAndLine) {
  auto model = Compile(ScalarModel(-10, 1, 0.1));  // A·Δ = -1e309 over the second interval
  const auto d = data::ParseCsv("t,y\n# a comment\n0,1\n0.2,2\n1e308,3\n", "long.csv");
  ASSERT_TRUE(d.ok()) << d.error().ToString();
  const std::vector<std::string> no_inputs, outputs = {"y"};
  const auto series = data::Bind(**d, no_inputs, outputs);
  ASSERT_TRUE(series.ok()) << series.error().ToString();
  const auto ss = *model->Evaluate(model->spec().Values());
  const auto settings = filter::FilterSettings::FromModel(model->spec());
  const auto l = filter::LogLikelihood(ss, **series, settings);
  ASSERT_FALSE(l.ok());
  EXPECT_EQ(l.error().kind, ErrorKind::kNumerical);
  EXPECT_EQ(l.error().file, "long.csv");
  EXPECT_EQ(l.error().line, 4);  // the row the interval starts at
  EXPECT_NE(l.error().message.find("from row 2 (t = 0.2)"), std::string::npos) << l.error().message;
  const auto sim = sim::Simulate(ss, **series, settings, {});
  ASSERT_FALSE(sim.ok());
  EXPECT_EQ(sim.error().line, 4);
  // A long interval is no fault while A·Δ is finite: 1e300 s discretises to Φ = 0 and Q = the
  // stationary variance σ²/2|a| (after 1000 doublings).
  const filter::Discrete fine =
      filter::Discretize(ss.A, ss.B, ss.c, Eigen::VectorXd::Ones(1), 1e300, model::InputHold::kZoh);
  EXPECT_EQ(fine.Phi(0, 0), 0.0);
  EXPECT_NEAR(fine.Q(0, 0), 0.05, 1e-12);
  // ‖A·Δ‖ = 1.7e308, finite, though ‖A·Δ‖/0.25 is not (found by csv_fuzz as well).
  const filter::Discrete edge = filter::Discretize(ss.A, ss.B, ss.c, Eigen::VectorXd::Ones(1),
                                                   1.7e307, model::InputHold::kZoh);
  EXPECT_EQ(edge.Phi(0, 0), 0.0);
  EXPECT_NEAR(edge.Q(0, 0), 0.05, 1e-12);
}

TEST(Faults, NonFiniteParameterValuesAndBoundsInAModelFileAreRefusedWithTheirPath) {
  // JSON text cannot spell NaN, but 1e999 reads as infinity; a model built in memory (the
  // diagram editor, a project) can hold NaN.
  const auto path = std::filesystem::temp_directory_path() /
                    ("greybench-faults-" + std::to_string(::getpid()) + "-big.json");
  std::ofstream(path) << R"({"greybench_model": 1, "states": ["x"], "inputs": [], "outputs": ["y"],
  "parameters": {"a": {"value": 1e999}}, "drift": {"x": "-a*x"},
  "diffusion": {"x": "1"}, "observation": {"y": "x"}, "measurement_variance": {"y": "1"}})";
  const auto text = model::LoadModelFile(path.string());
  std::filesystem::remove(path);
  ASSERT_FALSE(text.ok());
  EXPECT_EQ(text.error().file, path.string());
  EXPECT_EQ(text.error().line, 2);
  EXPECT_EQ(text.error().col, 33);
  EXPECT_NE(text.error().message.find("1e999 is out of range for a double"), std::string::npos)
      << text.error().message;
  for (const char* field : {"value", "lower", "upper"}) {
    for (double bad : {kNaN, HUGE_VAL, -HUGE_VAL}) {
      Json j = ScalarModel(-1, 1, 1);
      j["parameters"]["a"] = Json::object({{"value", -1.0}, {"lower", -2.0}, {"upper", 0.0}});
      j["parameters"]["a"][field] = bad;
      const auto spec = model::ParseModel(j, "m.json");
      ASSERT_FALSE(spec.ok()) << field << " = " << bad;
      EXPECT_EQ(spec.error().path, std::string("parameters.a.") + field);
      EXPECT_EQ(spec.error().file, "m.json");
    }
  }
}

TEST(Faults, NonFiniteSetValuesAreRefused) {
  auto spec = model::ParseModel(ScalarModel(-1, 1, 1), "m.json");
  ASSERT_TRUE(spec.ok());
  for (double bad : {kNaN, HUGE_VAL, -HUGE_VAL}) {
    const auto st = model::SetParameter(&*spec, "a", bad);
    ASSERT_FALSE(st.ok());
    EXPECT_NE(st.error().message.find("finite"), std::string::npos) << st.error().message;
  }
  EXPECT_EQ(spec->parameters[0].value, -1.0);  // left as it was
}

TEST(Faults, ExpressionsThatAreNotFiniteAtTheseValuesNameTheEntryAndTheCause) {
  struct Case {
    const char* diffusion;
    double p;
    const char* says;
  };
  for (const Case& c :
       {Case{"log(p)", -1.0, "not a number"}, Case{"sqrt(p)", -1.0, "not a number"},
        Case{"1/p", 0.0, "infinite"}, Case{"0/p", 0.0, "not a number"},
        Case{"exp(p)", 1000.0, "infinite"}, Case{"pow(p, 0.5)", -4.0, "not a number"},
        Case{"log(p)", 0.0, "infinite"}}) {
    Json j = ScalarModel(-1, 1, 1);
    j["parameters"]["p"] = c.p;
    j["diffusion"]["x"] = c.diffusion;
    const auto lm = Compile(j);
    const auto ss = lm->Evaluate(lm->spec().Values());
    ASSERT_FALSE(ss.ok()) << c.diffusion;
    EXPECT_EQ(ss.error().kind, ErrorKind::kNumerical);
    EXPECT_NE(ss.error().message.find("diffusion.x"), std::string::npos) << ss.error().message;
    EXPECT_NE(ss.error().message.find(c.says), std::string::npos) << ss.error().message;
    EXPECT_NE(ss.error().message.find("p = "), std::string::npos)
        << "names the parameter values: " << ss.error().message;
  }
  // A derivative entry (A, from the drift) names the equation it comes from.
  Json j = ScalarModel(-1, 1, 1);
  j["parameters"]["p"] = -1.0;
  j["drift"]["x"] = "-x*log(p)";
  const auto lm = Compile(j);
  const auto ss = lm->Evaluate(lm->spec().Values());
  ASSERT_FALSE(ss.ok());
  EXPECT_NE(ss.error().message.find("drift.x"), std::string::npos) << ss.error().message;
}

TEST(Faults, EstimationFromAStartWhereTheModelFailsSaysWhy) {
  Json j = ScalarModel(-1, 1, 1);
  j["parameters"]["p"] = Json::object({{"value", -1.0}, {"lower", -2.0}, {"upper", 2.0}});
  j["diffusion"]["x"] = "sqrt(p)";
  auto lik = filter::Likelihood::Create(
      Compile(j), {std::make_shared<const data::Series>(
                      MakeSeries({0, 1, 2}, Eigen::MatrixXd(0, 3), Eigen::MatrixXd::Ones(1, 3)))});
  ASSERT_TRUE(lik.ok());
  const auto s = estimate::Estimate(*lik, {});
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().kind, ErrorKind::kNumerical);
  EXPECT_NE(s.error().message.find("start values"), std::string::npos) << s.error().message;
  EXPECT_NE(s.error().message.find("diffusion.x"), std::string::npos) << s.error().message;
}

// ---- 7. an optimiser that wanders into non-finite log-likelihoods -------------------------------

// An OU process whose diffusion is sqrt(q) with q allowed down to -1: log L is NaN on a third of
// the box. The data have q = 0.04 and the fit starts at q = 5, so a full Newton or quasi-Newton
// step from the start lands below zero.
Json HalfBrokenModel() {
  return Json::parse(R"json({
    "greybench_model": 1, "states": ["x"], "inputs": [], "outputs": ["y"],
    "parameters": {"a": {"value": -0.5, "fixed": true}, "q": {"value": 5, "lower": -1, "upper": 10},
                   "r": {"value": 0.01, "fixed": true}},
    "drift": {"x": "a*x"}, "diffusion": {"x": "sqrt(q)"}, "observation": {"y": "x"},
    "measurement_variance": {"y": "r"}})json");
}

// The maximiser of f over [lo, hi] by golden-section search on a fine grid's best bracket.
double MaximiseOnInterval(const std::function<double(double)>& f, double lo, double hi) {
  const int kGrid = 400;
  int best = 0;
  double best_f = -HUGE_VAL;
  for (int i = 0; i <= kGrid; ++i) {
    const double v = f(lo + (hi - lo) * i / kGrid);
    if (v > best_f) best_f = v, best = i;
  }
  double a = lo + (hi - lo) * std::max(0, best - 1) / kGrid;
  double b = lo + (hi - lo) * std::min(kGrid, best + 1) / kGrid;
  const double g = (std::sqrt(5.0) - 1) / 2;
  for (int it = 0; it < 200 && b - a > 1e-12 * std::abs(b); ++it) {
    const double c = b - g * (b - a), d = a + g * (b - a);
    if (f(c) > f(d))
      b = d;
    else
      a = c;
  }
  return 0.5 * (a + b);
}

TEST(Faults, TheOptimiserBacksOffFromNonFiniteLogLikelihoodsAndFindsTheFiniteOptimum) {
  Json truth_json = HalfBrokenModel();
  truth_json["parameters"]["q"]["value"] = 0.04;
  const auto truth = Compile(truth_json);
  const auto series = SimulatePrbs(*truth, 1000, 0.1, 1.0, 21);
  const auto lm = Compile(HalfBrokenModel());
  auto lik = filter::Likelihood::Create(lm, {series});
  ASSERT_TRUE(lik.ok());
  // The brute-force optimum over the finite part of the box (q > 0).
  auto loglik_at = [&](double q) {
    const auto l = lik->Evaluate(std::vector<double>{-0.5, q, 0.01});
    return l.ok() ? l->loglik : -HUGE_VAL;
  };
  const double q_best = MaximiseOnInterval(loglik_at, 1e-6, 10.0);
  ASSERT_FALSE(lik->Evaluate(std::vector<double>{-0.5, -0.5, 0.01}).ok());
  for (auto algorithm : {estimate::Algorithm::kAuto, estimate::Algorithm::kBhhh,
                         estimate::Algorithm::kLbfgs, estimate::Algorithm::kSlsqp,
                         estimate::Algorithm::kBobyqa, estimate::Algorithm::kTrustRegion}) {
    SCOPED_TRACE(static_cast<int>(algorithm));
    estimate::EstimateOptions options;
    options.algorithm = algorithm;
    options.threads = 2;
    const auto s = estimate::Estimate(*lik, options);
    ASSERT_TRUE(s.ok()) << s.error().ToString();
    EXPECT_TRUE(s->converged) << s->message;
    ASSERT_TRUE(s->parameters[1].std_error.has_value()) << s->Report();
    // Within a hundredth of a standard error of the brute-force maximiser.
    EXPECT_NEAR(s->parameters[1].estimate, q_best, 0.01 * *s->parameters[1].std_error);
    EXPECT_NEAR(s->loglik, loglik_at(q_best), 1e-6);
  }
}

// ---- 8. files written atomically ----------------------------------------------------------------

std::string ReadAll(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

class AtomicWrite : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() /
           ("greybench-faults-" + std::to_string(::getpid()) + "-" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    std::filesystem::remove_all(dir_);
    std::filesystem::create_directories(dir_);
  }
  void TearDown() override {
    std::filesystem::permissions(dir_, std::filesystem::perms::owner_all);
    std::filesystem::remove_all(dir_);
  }
  int FilesIn() const {
    int n = 0;
    for ([[maybe_unused]] const auto& e : std::filesystem::directory_iterator(dir_)) ++n;
    return n;
  }
  std::filesystem::path dir_;
};

TEST_F(AtomicWrite, ReplacesTheFileAndLeavesNoTemporary) {
  const auto path = dir_ / "result.json";
  ASSERT_TRUE(WriteFileAtomic(path.string(), "old\n").ok());
  ASSERT_TRUE(WriteFileAtomic(path.string(), "new\n").ok());
  EXPECT_EQ(ReadAll(path), "new\n");
  EXPECT_EQ(FilesIn(), 1);
}

TEST_F(AtomicWrite, AFailedWriteKeepsTheOldFileAndLeavesNoTemporary) {
  const auto path = dir_ / "result.json";
  ASSERT_TRUE(WriteFileAtomic(path.string(), "good\n").ok());
  // A read-only directory: the temporary cannot be created (as root, permissions do not stop
  // the write, so the check is skipped there).
  std::filesystem::permissions(
      dir_, std::filesystem::perms::owner_read | std::filesystem::perms::owner_exec);
  if (::access(dir_.c_str(), W_OK) == 0) {
    std::filesystem::permissions(dir_, std::filesystem::perms::owner_all);
    GTEST_SKIP() << "running with permission to write anywhere";
  }
  const auto st = WriteFileAtomic(path.string(), "bad\n");
  ASSERT_FALSE(st.ok());
  EXPECT_EQ(st.error().file, path.string());
  EXPECT_NE(st.error().message.find("cannot"), std::string::npos) << st.error().message;
  std::filesystem::permissions(dir_, std::filesystem::perms::owner_all);
  EXPECT_EQ(ReadAll(path), "good\n");
  EXPECT_EQ(FilesIn(), 1);
}

TEST_F(AtomicWrite, ADirectoryNobodyCanWriteToIsAMessageNamingTheFile) {
  // /proc refuses new files even to root, so this failure path is tested wherever tests run.
  if (!std::filesystem::is_directory("/proc/self")) GTEST_SKIP() << "no /proc";
  const std::string path = "/proc/greybench-faults-test.json";
  const auto st = WriteFileAtomic(path, "text\n");
  ASSERT_FALSE(st.ok());
  EXPECT_EQ(st.error().file, path);
  EXPECT_NE(st.error().message.find("cannot write the file"), std::string::npos)
      << st.error().message;
  EXPECT_FALSE(std::filesystem::exists(path));
}

TEST_F(AtomicWrite, ATargetThatCannotBeReplacedKeepsItsContentAndLeavesNoTemporary) {
  // The target is a non-empty directory: the temporary is written, the rename fails, and the
  // temporary must go (this failure path works as root too).
  const auto path = dir_ / "occupied";
  std::filesystem::create_directories(path / "inside");
  const auto st = WriteFileAtomic(path.string(), "text\n");
  ASSERT_FALSE(st.ok());
  EXPECT_EQ(st.error().file, path.string());
  EXPECT_TRUE(std::filesystem::is_directory(path / "inside"));
  EXPECT_EQ(FilesIn(), 1);
}

TEST_F(AtomicWrite, AMissingDirectoryIsAMessageNamingTheFile) {
  const auto path = dir_ / "no" / "such" / "dir" / "out.csv";
  const auto st = WriteFileAtomic(path.string(), "x\n");
  ASSERT_FALSE(st.ok());
  EXPECT_EQ(st.error().file, path.string());
  EXPECT_EQ(FilesIn(), 0);
}

TEST_F(AtomicWrite, CheckWritableForeseesEachFailureOfTheWriteAndLeavesNothing) {
  // Each case of the tests above, checked before any write: the same verdict, the same message.
  const auto occupied = dir_ / "occupied";
  std::filesystem::create_directories(occupied / "inside");
  const std::string missing = (dir_ / "no" / "dir" / "out.csv").string();
  const std::string proc = "/proc/greybench-faults-test.json";
  for (const std::string& path : {occupied.string(), missing, proc}) {
    if (path == proc && !std::filesystem::is_directory("/proc/self")) continue;
    const auto check = CheckWritable(path);
    const auto write = WriteFileAtomic(path, "x\n");
    ASSERT_FALSE(check.ok()) << path;
    ASSERT_FALSE(write.ok()) << path;
    EXPECT_EQ(check.error().file, path);
    // The temporary's name differs between the two calls; the rest of the message does not.
    const auto reason = [](const std::string& m) { return m.substr(m.rfind(':')); };
    EXPECT_EQ(reason(check.error().message), reason(write.error().message)) << path;
  }
  const auto fine = dir_ / "result.json";
  EXPECT_TRUE(CheckWritable(fine.string()).ok());
  EXPECT_FALSE(std::filesystem::exists(fine));
  EXPECT_EQ(FilesIn(), 1);  // the occupied folder only
}

// Files that cannot be read to their end are refused before reading: a device would be read
// until memory runs out (found reading the code: `greybench-cli loglik /dev/zero` never ended).
TEST(UnreadableFiles, DevicesPipesAndFoldersAreRefusedNamingTheFile) {
  if (std::filesystem::exists("/dev/zero")) {
    const auto json = ReadJsonFile("/dev/zero");
    ASSERT_FALSE(json.ok());
    EXPECT_EQ(json.error().file, "/dev/zero");
    EXPECT_NE(json.error().message.find("a device or a pipe"), std::string::npos)
        << json.error().message;
    const auto csv = data::ReadCsvFile("/dev/zero");
    ASSERT_FALSE(csv.ok());
    EXPECT_NE(csv.error().message.find("a device or a pipe"), std::string::npos)
        << csv.error().message;
  }
  const std::string folder = std::filesystem::temp_directory_path().string();
  const auto project = project::LoadProject(folder);
  ASSERT_FALSE(project.ok());
  EXPECT_EQ(project.error().file, folder);
  EXPECT_NE(project.error().message.find("it is a folder"), std::string::npos)
      << project.error().message;
}

}  // namespace
}  // namespace gb
