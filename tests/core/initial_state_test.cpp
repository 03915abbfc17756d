// Tests of core/filter/initial_state.cpp: a record's own initial state from its first samples,
// against the truth of simulated records (a Monte Carlo property: the error in units of the
// reported SD is standard normal), the EKF's against the Kalman filter's on a linear model, and
// the override it feeds (FilterSettings::x0, P0) as the filter, the simulation and the EKF take it.
#include "core/filter/initial_state.h"

#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "core/filter/ekf.h"
#include "core/model/model.h"
#include "core/sim/response.h"
#include "core/sim/sde.h"
#include "core/sim/simulate.h"
#include "core/util/json.h"
#include "tests/core/filter_fixtures.h"

namespace gb::filter {
namespace {

// Ornstein-Uhlenbeck observed with noise; the model's x0 is 0, records start anywhere.
constexpr const char* kOu = R"json({
  "greybench_model": 1, "states": ["x"], "inputs": ["u"], "outputs": ["y"],
  "parameters": {"a": 1.0, "b": 2.0, "s": 0.5, "r": 0.01, "x0": 0},
  "drift": {"x": "-a*x + b*u"}, "diffusion": {"x": "s"},
  "observation": {"y": "x"}, "measurement_variance": {"y": "r"},
  "initial_state": {"x": "x0"}
})json";

data::Series Inputs(int n, double dt) {
  std::vector<double> t(static_cast<std::size_t>(n));
  Eigen::MatrixXd U(1, n), Y(1, n);
  for (int k = 0; k < n; ++k) {
    t[static_cast<std::size_t>(k)] = k * dt;
    U(0, k) = (k / 7) % 2 ? 1.0 : -0.5;
    Y(0, k) = 0;
  }
  return fixtures::MakeSeries(t, U, Y);
}

TEST(InitialState, ItsErrorInUnitsOfItsSdIsStandardNormalOverSimulatedRecords) {
  const model::LinearModel lm = fixtures::CompileModel(kOu);
  const model::StateSpace ss = *lm.Evaluate(lm.spec().Values());
  const FilterSettings settings = FilterSettings::FromModel(lm.spec());
  const data::Series inputs = Inputs(200, 0.1);
  constexpr int kTrials = 400;
  double sum = 0, sum_sq = 0;
  for (int trial = 0; trial < kTrials; ++trial) {
    // The record starts at x_true, far from the model's x0 = 0.
    const double x_true = 12 * std::sin(1.7 * trial);
    FilterSettings at_truth = settings;
    at_truth.x0 = Eigen::VectorXd::Constant(1, x_true);
    sim::SimulateOptions options;
    options.seed = 1000 + static_cast<std::uint64_t>(trial);
    options.random_initial_state = false;
    Result<sim::Simulation> path = sim::Simulate(ss, inputs, at_truth, options);
    ASSERT_TRUE(path.ok()) << path.error().ToString();
    const data::Series record = fixtures::MakeSeries(inputs.time, inputs.U, path->Y);
    Result<InitialStateEstimate> e = EstimateInitialState(ss, record, settings, 20);
    ASSERT_TRUE(e.ok()) << e.error().ToString();
    EXPECT_EQ(e->samples, 20);
    const double z = (e->x0(0) - x_true) / std::sqrt(e->P0(0, 0));
    sum += z;
    sum_sq += z * z;
  }
  const double mean = sum / kTrials, variance = sum_sq / kTrials - mean * mean;
  // 400 draws: the mean's SD is 0.05, the variance's about 0.07.
  EXPECT_NEAR(mean, 0, 0.2) << "variance " << variance;
  EXPECT_NEAR(variance, 1, 0.25) << "mean " << mean;
}

TEST(InitialState, TheEkfsEqualsTheKalmanFiltersOnALinearModel) {
  const model::LinearModel lm = fixtures::CompileModel(kOu);
  const std::vector<double> theta = lm.spec().Values();
  const model::StateSpace ss = *lm.Evaluate(theta);
  Result<model::NonlinearModel> nm = model::NonlinearModel::Compile(lm.spec());
  ASSERT_TRUE(nm.ok()) << nm.error().ToString();
  const FilterSettings settings = FilterSettings::FromModel(lm.spec());
  FilterSettings at_truth = settings;
  at_truth.x0 = Eigen::VectorXd::Constant(1, 4.5);
  sim::SimulateOptions options;
  options.random_initial_state = false;
  const data::Series inputs = Inputs(120, 0.05);
  Result<sim::Simulation> path = sim::Simulate(ss, inputs, at_truth, options);
  ASSERT_TRUE(path.ok());
  const data::Series record = fixtures::MakeSeries(inputs.time, inputs.U, path->Y);
  Result<InitialStateEstimate> kalman = EstimateInitialState(ss, record, settings, 30);
  Result<InitialStateEstimate> ekf = EkfEstimateInitialState(*nm, theta, record, settings, 30);
  ASSERT_TRUE(kalman.ok() && ekf.ok());
  // The EKF integrates the moments numerically: equal to its tolerance.
  EXPECT_NEAR(ekf->x0(0), kalman->x0(0), 1e-5 * std::abs(kalman->x0(0)));
  EXPECT_NEAR(ekf->P0(0, 0), kalman->P0(0, 0), 1e-4 * kalman->P0(0, 0));
  EXPECT_NEAR(kalman->x0(0), 4.5, 5 * std::sqrt(kalman->P0(0, 0)));

  // The override: the filters and the simulations start there.
  FilterSettings own = settings;
  own.x0 = kalman->x0;
  own.P0 = kalman->P0;
  FilterTrace linear_trace, ekf_trace;
  ASSERT_TRUE(RunFilter(ss, record, own, &linear_trace).ok());
  ASSERT_TRUE(EkfRunFilter(*nm, theta, record, own, &ekf_trace).ok());
  EXPECT_EQ(linear_trace.x_pred(0, 0), kalman->x0(0));
  EXPECT_EQ(linear_trace.P_pred[0](0, 0), kalman->P0(0, 0));
  EXPECT_EQ(ekf_trace.x_pred(0, 0), kalman->x0(0));
  Result<sim::Simulation> linear_sim = sim::DeterministicResponse(ss, record, own);
  Result<sim::Simulation> ekf_sim = sim::DeterministicResponse(*nm, theta, record, own);
  ASSERT_TRUE(linear_sim.ok() && ekf_sim.ok());
  EXPECT_EQ(linear_sim->X(0, 0), kalman->x0(0));
  EXPECT_EQ(ekf_sim->X(0, 0), kalman->x0(0));
}

TEST(InitialState, UsesAHundredRowsOrAFifthOfAShorterRecord) {
  EXPECT_EQ(InitialStateSamples(10000), 100);
  EXPECT_EQ(InitialStateSamples(250), 50);
  EXPECT_EQ(InitialStateSamples(5), 2);
  const data::Series s = Inputs(30, 0.1);
  const data::Series head = Head(s, 12);
  EXPECT_EQ(head.size(), 12u);
  EXPECT_EQ(head.time.back(), s.time[11]);
  EXPECT_EQ(head.intervals.group.size(), 11u);
}

}  // namespace
}  // namespace gb::filter
