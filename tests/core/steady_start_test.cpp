// The steady-state start (core/estimate/steady_start.h): on records held at known steady states
// it returns the parameters that set those states, and only those; it says why when it cannot
// run; and a fit from it reaches the optimum where the plain start's fit does not.
#include "core/estimate/steady_start.h"

#include <cmath>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "core/estimate/estimate.h"
#include "core/filter/likelihood.h"
#include "core/model/model.h"
#include "core/model/nonlinear_model.h"
#include "core/sim/engine.h"
#include "core/util/json.h"
#include "core/util/sanitizers.h"
#include "tests/core/nonlinear_tank.h"

namespace gb {
namespace {

const std::string kSource = GREYBENCH_SOURCE_DIR;

model::NonlinearModel Compile(const model::ModelSpec& spec) {
  auto m = model::NonlinearModel::Compile(spec);
  EXPECT_TRUE(m.ok()) << m.error().ToString();
  return std::move(*m);
}

std::vector<double> ValuesOf(const model::ModelSpec& spec) { return spec.Values(); }

// A record that holds the engine at each of Table 2's six points for 5 s (10 rows each), with the
// dyno's exact steady-state inputs and outputs (λ = 1): every window's mean is a steady state.
std::shared_ptr<const data::Series> EngineHeldAtTable2(const sim::EngineTruth& truth) {
  data::Series s;
  s.source = "held.csv";
  const auto points = sim::PaperEnginePoints();
  const int rows = 10;
  const auto total = static_cast<Eigen::Index>(points.size()) * rows;
  s.U.resize(3, total);
  s.Y.resize(3, total);
  Eigen::Index k = 0;
  for (const sim::EnginePoint& point : points) {
    auto steady = sim::EngineSteadyState(truth, point.speed_rpm, point.throttle_deg);
    EXPECT_TRUE(steady.ok()) << point.name;
    for (int r = 0; r < rows; ++r, ++k) {
      s.time.push_back(0.5 * static_cast<double>(k));
      s.U.col(k) << steady->u.alpha, steady->u.mfi, steady->u.Tl;  // the model's inputs
      s.Y.col(k) << steady->x.n, steady->x.p, 1.0;                 // N, Pman, 1/λ
    }
  }
  s.intervals = data::GroupIntervals(s.time);
  return std::make_shared<const data::Series>(std::move(s));
}

TEST(SteadyStart, ReturnsTheEnginesLevelParametersFromRecordsHeldAtSteadyStates) {
  const sim::EngineTruth truth;
  auto spec = model::LoadModelFile(kSource + "/assets/models/engine_mvem.json");
  ASSERT_TRUE(spec.ok()) << spec.error().ToString();
  // Generic starts, far from the dyno's for the five that set its steady states.
  for (const auto& [name, value] : std::vector<std::pair<std::string, double>>{
           {"Cth", 60}, {"ev", 0.5}, {"eta", 0.2}, {"f0", 0}, {"f1", 0}}) {
    spec->parameters[static_cast<std::size_t>(spec->ParameterIndex(name))].value = value;
  }
  const model::NonlinearModel m = Compile(*spec);
  const std::vector<double> start = ValuesOf(*spec);
  auto r = estimate::SteadyStart(m, start, {EngineHeldAtTable2(truth)});
  ASSERT_TRUE(r.ok()) << r.error().ToString();

  // Only the parameters that move a steady state: the throttle flow and the volumetric
  // efficiency (p and 1/λ), the efficiency and friction (n). The volume, inertia, the film's
  // time constants and split (the film's sum is mfi at steady state), the delay (z1 = the port's
  // 1/λ) and every noise parameter keep their starts.
  std::set<std::string> names;
  for (const auto& f : r->fitted) names.insert(f.name);
  EXPECT_EQ(names, (std::set<std::string>{"Cth", "ev", "eta", "f0", "f1"}));
  EXPECT_EQ(r->windows, 6);
  EXPECT_EQ(r->windows_left_out, 0);
  const auto named = truth.Named();
  for (const auto& [name, value] : named) {
    const double got = r->theta[static_cast<std::size_t>(spec->ParameterIndex(name))];
    if (names.count(name))
      EXPECT_NEAR(got, value, 1e-6 * std::max(1.0, std::abs(value))) << name;
    else
      EXPECT_EQ(got, start[static_cast<std::size_t>(spec->ParameterIndex(name))]) << name;
  }
  EXPECT_GT(r->misfit_start, 1.0);
  EXPECT_LT(r->misfit, 1e-8);
  for (const auto& f : r->fitted) {
    EXPECT_EQ(f.from, start[static_cast<std::size_t>(spec->ParameterIndex(f.name))]);
    EXPECT_EQ(f.to, r->theta[static_cast<std::size_t>(spec->ParameterIndex(f.name))]);
  }
  const std::string report = r->Report();
  EXPECT_NE(report.find("Steady-state start: 5 parameters from 6 windows of length 5"),
            std::string::npos)
      << report;
  EXPECT_NE(report.find("Cth 60 -> 137.5"), std::string::npos) << report;
  EXPECT_EQ(r->ToJson()["parameters"]["ev"]["from"].get<double>(), 0.5);
}

TEST(SteadyStart, HoldsFixedParametersAndSaysWhenNoneMovesASteadyState) {
  // A first-order lag: its steady state x = u depends on no parameter.
  auto spec = model::ParseModel(Json::parse(R"json({
    "greybench_model": 1, "states": ["x"], "inputs": ["u"], "outputs": ["y"],
    "parameters": {"tau": {"value": 2, "lower": 0.1, "upper": 10},
                   "g": {"value": 1, "fixed": true},
                   "r": {"value": 0.01, "lower": 1e-6, "upper": 1}},
    "drift": {"x": "(g*u - x)/tau"}, "diffusion": {"x": "0.1"},
    "observation": {"y": "x"}, "measurement_variance": {"y": "r"},
    "initial_state": {"x": "0"}})json"),
                                "lag.json");
  ASSERT_TRUE(spec.ok()) << spec.error().ToString();
  const model::NonlinearModel m = Compile(*spec);
  auto series = testing::SimulateTank(3, 60.0);  // any record with one input and one output
  auto r = estimate::SteadyStart(m, spec->Values(), {series});
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("no free parameter moves the model's steady states"),
            std::string::npos)
      << r.error().message;
}

TEST(SteadyStart, NamesTheFirstWindowWithoutASteadyState) {
  // An integrator has no steady state unless its input is 0.
  auto spec = model::ParseModel(Json::parse(R"json({
    "greybench_model": 1, "states": ["x"], "inputs": ["u"], "outputs": ["y"],
    "parameters": {"k": {"value": 2, "lower": 0.1, "upper": 10},
                   "r": {"value": 0.01, "lower": 1e-6, "upper": 1}},
    "drift": {"x": "k*u"}, "diffusion": {"x": "0.1"},
    "observation": {"y": "x"}, "measurement_variance": {"y": "r"},
    "initial_state": {"x": "0"}})json"),
                                "integrator.json");
  ASSERT_TRUE(spec.ok()) << spec.error().ToString();
  const model::NonlinearModel m = Compile(*spec);
  auto r = estimate::SteadyStart(m, spec->Values(), {testing::SimulateTank(3, 60.0)});
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("no window of the records has a steady state at the start "
                                   "values (the first: tank.csv, t 0-4.5 s:"),
            std::string::npos)
      << r.error().message;
}

// The tank's level is (k u / a)²: with k four times the truth's the start's level is 16 times
// the truth's. The levels fix k / a and not k and a apart, so one combination is moved and the
// other left at the starts; the fit from there reaches the optimum of a fit from the truth.
TEST(SteadyStart, AFitFromItReachesTheTanksOptimumFromAStartFarOff) {
  auto series = testing::SimulateTank(11, 600.0);
  Json far = testing::TankTruth();
  far["parameters"]["k"]["value"] = 3.2;
  far["parameters"]["a"]["value"] = 0.5;
  far["parameters"]["s"]["value"] = 0.05;
  far["parameters"]["r"]["value"] = 0.01;
  far["parameters"]["h0"]["value"] = 1.0;
  auto model = testing::CompileTank(far);
  auto lik = filter::Likelihood::Create(model, {series});
  ASSERT_TRUE(lik.ok()) << lik.error().ToString();
  estimate::EstimateOptions options;
  options.threads = 1;
  options.steady_start = true;
  options.steady_window = 20.0;
  auto steady = estimate::Estimate(*lik, options);
  ASSERT_TRUE(steady.ok()) << steady.error().ToString();
  ASSERT_TRUE(steady->steady_start.has_value());
  std::set<std::string> moved;
  for (const auto& f : steady->steady_start->fitted) moved.insert(f.name);
  EXPECT_EQ(moved, (std::set<std::string>{"k", "a"}));
  EXPECT_LT(steady->steady_start->misfit, 0.5 * steady->steady_start->misfit_start);
  EXPECT_EQ(steady->steady_start->undetermined, 1);
  EXPECT_TRUE(steady->converged) << steady->message;

  EXPECT_NE(steady->Report().find("Steady-state start: 2 parameters"), std::string::npos);
  EXPECT_TRUE(steady->ToJson().contains("steady_start"));

  // The optimum: the fit from the truth. Not under the sanitizers (the two fits are slow there;
  // the steady start's path and the fit from it are the point there, checked above).
  if (kSanitized) return;
  auto truth_lik = filter::Likelihood::Create(testing::CompileTank(testing::TankTruth()), {series});
  ASSERT_TRUE(truth_lik.ok());
  options.steady_start = false;
  auto best = estimate::Estimate(*truth_lik, options);
  ASSERT_TRUE(best.ok()) << best.error().ToString();
  EXPECT_NEAR(steady->loglik, best->loglik, 1e-4 * std::abs(best->loglik));
  for (std::size_t i = 0; i < best->theta.size(); ++i)
    EXPECT_NEAR(steady->theta[i], best->theta[i], 1e-3 * std::abs(best->theta[i]))
        << best->parameters[i].name;
}

}  // namespace
}  // namespace gb
