// Predictions and simulations of models through the EKF (core/filter/ekf_predict.h,
// core/sim/sde.h) against independent references: for a linear model, the exact predictions and
// the exact deterministic response (to the ODE tolerance); for sample paths, the closed-form
// moments of geometric Brownian motion and of the Ornstein-Uhlenbeck process (Monte Carlo).
#include "core/filter/ekf_predict.h"

#include <cmath>

#include <gtest/gtest.h>

#include "core/filter/predict.h"
#include "core/model/linear_model.h"
#include "core/sim/response.h"
#include "core/sim/sde.h"
#include "core/util/json.h"
#include "tests/core/filter_fixtures.h"

namespace gb::filter {
namespace {

struct Both {
  model::ModelSpec spec;
  model::StateSpace ss;
  std::optional<model::NonlinearModel> nm;
};

Both Compile(const char* json_text) {
  Both b;
  b.spec = *model::ParseModel(Json::parse(json_text), "test.json");
  b.ss = *model::LinearModel::Compile(b.spec)->Evaluate(b.spec.Values());
  b.nm = *model::NonlinearModel::Compile(b.spec);
  return b;
}

// max |a - b| / (1 + |b|) over the entries where b is a number (NaN where b is must be NaN in a).
double MaxRelativeDifference(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
  EXPECT_EQ(a.rows(), b.rows());
  EXPECT_EQ(a.cols(), b.cols());
  double worst = 0.0;
  for (Eigen::Index i = 0; i < a.rows(); ++i) {
    for (Eigen::Index k = 0; k < a.cols(); ++k) {
      if (std::isnan(b(i, k))) {
        EXPECT_TRUE(std::isnan(a(i, k))) << i << "," << k;
        continue;
      }
      worst = std::max(worst, std::abs(a(i, k) - b(i, k)) / (1.0 + std::abs(b(i, k))));
    }
  }
  return worst;
}

TEST(EkfPredict, LinearModelEqualsTheExactPredictionsAndSimulation) {
  Both b = Compile(fixtures::kTwoOutputModel);
  const data::Series series = fixtures::RandomSeries(200, 2, 0.1, 11);
  for (const auto hold : {model::InputHold::kZoh, model::InputHold::kFoh}) {
    FilterSettings settings = FilterSettings::FromModel(b.spec);
    settings.hold = hold;
    settings.delay = {2, 0};
    SCOPED_TRACE(hold == model::InputHold::kZoh ? "zoh" : "foh");

    auto exact = PredictOneStep(b.ss, series, settings);
    auto ekf = EkfPredictOneStep(*b.nm, b.spec.Values(), series, settings);
    ASSERT_TRUE(exact && ekf);
    EXPECT_LT(MaxRelativeDifference(ekf->y_pred, exact->y_pred), 1e-7);
    EXPECT_LT(MaxRelativeDifference(ekf->y_sd, exact->y_sd), 1e-7);
    EXPECT_LT(MaxRelativeDifference(ekf->standardized, exact->standardized), 1e-6);

    FilterTrace trace;
    ASSERT_TRUE(EkfRunFilter(*b.nm, b.spec.Values(), series, settings, &trace));
    for (const int h : {0, 1, 4}) {
      auto exact_ahead = PredictAhead(b.ss, series, settings, h);
      auto ekf_ahead = EkfPredictAhead(*b.nm, b.spec.Values(), series, settings, trace, h);
      ASSERT_TRUE(exact_ahead && ekf_ahead);
      EXPECT_LT(MaxRelativeDifference(ekf_ahead->y_pred, exact_ahead->y_pred), 1e-7) << h;
      EXPECT_LT(MaxRelativeDifference(ekf_ahead->y_sd, exact_ahead->y_sd), 1e-7) << h;
      EXPECT_LT(MaxRelativeDifference(ekf_ahead->x_pred, exact_ahead->x_pred), 1e-7) << h;
    }

    auto exact_sim = sim::DeterministicResponse(b.ss, series, settings);
    auto ekf_sim = sim::DeterministicResponse(*b.nm, b.spec.Values(), series, settings);
    ASSERT_TRUE(exact_sim && ekf_sim);
    EXPECT_LT(MaxRelativeDifference(ekf_sim->X, exact_sim->X), 1e-7);
    EXPECT_LT(MaxRelativeDifference(ekf_sim->Y, exact_sim->Y), 1e-7);

    auto exact_smooth = Smooth(b.ss, series, settings);
    auto ekf_smooth = EkfSmooth(*b.nm, b.spec.Values(), series, settings, trace);
    ASSERT_TRUE(exact_smooth && ekf_smooth) << ekf_smooth.error().ToString();
    EXPECT_LT(MaxRelativeDifference(ekf_smooth->x, exact_smooth->x), 1e-7);
    EXPECT_LT(MaxRelativeDifference(ekf_smooth->y, exact_smooth->y), 1e-7);
    EXPECT_LT(MaxRelativeDifference(ekf_smooth->y_sd, exact_smooth->y_sd), 1e-7);
    double worst_P = 0.0;
    for (std::size_t j = 0; j < exact_smooth->P.size(); ++j)
      worst_P = std::max(worst_P, MaxRelativeDifference(ekf_smooth->P[j], exact_smooth->P[j]));
    EXPECT_LT(worst_P, 1e-7);
  }
}

TEST(EkfSmooth, SmoothedStatesOfANonlinearModelAreCalibratedAndBeatTheFilteredOnes) {
  // Two tanks draining through orifices, only the lower level measured: the upper level is
  // seen through the flow it sends down, later. Over sample paths of the model, the smoothed
  // errors x - x̂_{j|N} must have the variance the smoother claims (mean of the squared errors
  // over P_{j|N} near 1) and be smaller than the filtered ones.
  const char* const kTanks = R"json({
    "greybench_model": 1, "states": ["h1", "h2"], "inputs": ["u"], "outputs": ["y"],
    "parameters": {"k1": 0.5, "k2": 0.4, "s": 0.05, "r": 0.0004},
    "drift": {"h1": "u - k1*sqrt(h1)", "h2": "k1*sqrt(h1) - k2*sqrt(h2)"},
    "diffusion": {"h1": "s", "h2": "s"},
    "observation": {"y": "h2"}, "measurement_variance": {"y": "r"},
    "initial_state": {"h1": "4", "h2": "6"}, "initial_covariance": {"h1": "0.01", "h2": "0.01"}
  })json";
  const model::ModelSpec spec = *model::ParseModel(Json::parse(kTanks), "test.json");
  const model::NonlinearModel nm = *model::NonlinearModel::Compile(spec);
  const int rows = 400;
  std::vector<double> t(rows);
  Eigen::MatrixXd U(1, rows);
  for (int k = 0; k < rows; ++k) {
    t[k] = 0.5 * k;
    U(0, k) = ((k / 17) % 3 == 1) ? 1.4 : 0.8;  // a square wave of unequal halves
  }
  const FilterSettings settings = FilterSettings::FromModel(spec);
  double z2[2] = {0, 0}, smoothed_sq[2] = {0, 0}, filtered_sq[2] = {0, 0};
  long count = 0;
  const int paths = 30;
  for (int path = 0; path < paths; ++path) {
    data::Series series = fixtures::MakeSeries(t, U, Eigen::MatrixXd::Zero(1, rows));
    auto truth = sim::SamplePath(nm, spec.Values(), series, settings, 500 + path);
    ASSERT_TRUE(truth) << truth.error().ToString();
    series.Y = truth->Y;
    FilterTrace trace;
    ASSERT_TRUE(EkfRunFilter(nm, spec.Values(), series, settings, &trace));
    auto smoothed = EkfSmooth(nm, spec.Values(), series, settings, trace);
    ASSERT_TRUE(smoothed) << smoothed.error().ToString();
    for (int j = 0; j < rows; ++j) {
      for (int i = 0; i < 2; ++i) {
        const double e = truth->X(i, j) - smoothed->x(i, j);
        z2[i] += e * e / smoothed->P[j](i, i);
        smoothed_sq[i] += e * e;
        const double f = truth->X(i, j) - trace.x_filt(i, j);
        filtered_sq[i] += f * f;
      }
      ++count;
    }
  }
  for (int i = 0; i < 2; ++i) {
    SCOPED_TRACE(i == 0 ? "h1" : "h2");
    // 12 000 correlated terms per state; the EKF's linearisation error is small at these levels.
    // Measured: 1.018 (h1) and 1.001 (h2); smoothed/filtered squared errors 0.87 and 0.84.
    EXPECT_NEAR(z2[i] / count, 1.0, 0.1);
    EXPECT_LT(smoothed_sq[i], 0.93 * filtered_sq[i]);
  }
}

// Sample means and variances at the last row against closed forms, within 4.5 standard errors
// of the Monte Carlo estimates (a test that fails by chance once in ~150 000 runs per moment).
void ExpectMoments(const char* json_text, double T, int rows, int paths, double mean,
                   double variance) {
  const model::ModelSpec spec = *model::ParseModel(Json::parse(json_text), "test.json");
  const model::NonlinearModel nm = *model::NonlinearModel::Compile(spec);
  std::vector<double> t(rows);
  for (int k = 0; k < rows; ++k) t[k] = T * k / (rows - 1);
  const data::Series series =
      fixtures::MakeSeries(t, Eigen::MatrixXd(0, rows), Eigen::MatrixXd::Zero(1, rows));
  FilterSettings settings = FilterSettings::FromModel(spec);
  double sum = 0.0, sum_sq = 0.0, sum_4 = 0.0;
  for (int path = 0; path < paths; ++path) {
    auto s = sim::SamplePath(nm, spec.Values(), series, settings, 1000 + path, 40);
    ASSERT_TRUE(s) << s.error().ToString();
    const double x = s->X(0, rows - 1);
    sum += x;
    sum_sq += x * x;
    const double d = x - mean;
    sum_4 += d * d * d * d;
  }
  const double m = sum / paths;
  const double v = sum_sq / paths - m * m;
  const double se_mean = std::sqrt(variance / paths);
  const double se_var = std::sqrt(std::max(sum_4 / paths - variance * variance, 0.0) / paths);
  EXPECT_NEAR(m, mean, 4.5 * se_mean);
  EXPECT_NEAR(v, variance, 4.5 * se_var + 0.02 * variance);  // and the scheme's weak error
}

TEST(SamplePath, GeometricBrownianMotionHasItsClosedFormMoments) {
  // dx = μ x dt + σ x dω, x(0) = 1 exactly: E x_T = e^{μT}, Var x_T = e^{2μT} (e^{σ²T} - 1).
  const char* const kGbm = R"json({
    "greybench_model": 1, "states": ["x"], "inputs": [], "outputs": ["y"],
    "parameters": {"mu": 0.3, "sigma": 0.4},
    "drift": {"x": "mu*x"}, "diffusion": {"x": "sigma*x"},
    "observation": {"y": "x"}, "measurement_variance": {"y": "0.01"},
    "initial_state": {"x": "1"}, "initial_covariance": {"x": "0"}
  })json";
  const double T = 1.0;
  ExpectMoments(kGbm, T, 5, 4000, std::exp(0.3 * T),
                std::exp(0.6 * T) * (std::exp(0.16 * T) - 1.0));
}

TEST(SamplePath, OrnsteinUhlenbeckStartsFromP0AndHasItsClosedFormMoments) {
  // dx = -a x dt + s dω from the stationary P0 = s²/(2a): stays stationary.
  const char* const kOu = R"json({
    "greybench_model": 1, "states": ["x"], "inputs": [], "outputs": ["y"],
    "parameters": {"a": 2.0, "s": 0.5},
    "drift": {"x": "-a*x + 1"}, "diffusion": {"x": "s"},
    "observation": {"y": "x"}, "measurement_variance": {"y": "0.01"},
    "initial_state": {"x": "0.5"}, "initial_covariance": "stationary"
  })json";
  ExpectMoments(kOu, 3.0, 7, 4000, 0.5, 0.25 / 4.0);
}

}  // namespace
}  // namespace gb::filter
