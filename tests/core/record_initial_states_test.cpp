// Several records fitted jointly, each from its own initial state (core/project/problem.h's
// PerRecordInitialStates, filter::Likelihood::set_series_parameters): the copies' names and
// index rows, the joint log-likelihood against each record's own at its substituted θ (brute
// force), the gathered gradient against central differences (linear and EKF), the copies'
// starts from the records' first samples, and a fit that recovers two records' different
// initial states within their standard errors.
#include <cmath>
#include <memory>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "core/estimate/estimate.h"
#include "core/filter/likelihood.h"
#include "core/project/problem.h"
#include "core/util/json.h"

namespace gb::project {
namespace {

// dx = (-a x + b u) dt + s dω, y = x + e: x(t0) = x0, a parameter only the initial state uses;
// `a` also sets the initial variance, which does not make it the initial state's own.
constexpr const char* kRecordModel = R"json({
  "greybench_model": 1, "name": "records", "states": ["x"], "inputs": ["u"], "outputs": ["y"],
  "parameters": {"a": {"value": 1.2, "lower": 0.01, "upper": 10},
                 "b": {"value": 2.0, "lower": -10, "upper": 10},
                 "s": {"value": 0.3, "lower": 1e-4, "upper": 10},
                 "r": {"value": 0.01, "lower": 1e-6, "upper": 10},
                 "x0": {"value": 0.0, "lower": -50, "upper": 50}},
  "drift": {"x": "-a*x + b*u"}, "diffusion": {"x": "s"},
  "observation": {"y": "x"}, "measurement_variance": {"y": "r"},
  "initial_state": {"x": "x0"}, "initial_covariance": {"x": "0.01/a"}})json";

// The same dynamics with a nonlinear drift: the extended Kalman filter runs it.
constexpr const char* kNonlinearRecordModel = R"json({
  "greybench_model": 1, "name": "records-ekf", "states": ["x"], "inputs": ["u"],
  "outputs": ["y"],
  "parameters": {"a": {"value": 1.2, "lower": 0.01, "upper": 10}, "b": 2.0, "s": 0.3, "r": 0.01,
                 "x0": 0.5},
  "drift": {"x": "-a*x - 0.1*x^3 + b*u"}, "diffusion": {"x": "s"},
  "observation": {"y": "x"}, "measurement_variance": {"y": "r"},
  "initial_state": {"x": "x0"}})json";

model::ModelSpec Spec(const char* text) {
  auto spec = model::ParseModel(Json::parse(text), "records.json");
  EXPECT_TRUE(spec.ok()) << spec.error().ToString();
  return *spec;
}

// A record of the linear model from x(0) = start: a square-wave input, Euler-Maruyama with
// small steps, y = x + e at 0.1 s.
std::shared_ptr<const data::Dataset> Record(double start, unsigned seed, int rows) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  const double a = 1.2, b = 2.0, s = 0.3, r = 0.01, dt = 0.1;
  auto d = std::make_shared<data::Dataset>();
  d->source = "record" + std::to_string(seed) + ".csv";
  d->time_name = "t";
  data::Column u, y;
  u.name = "u";
  u.field = 1;
  y.name = "y";
  y.field = 2;
  double x = start;
  for (int k = 0; k < rows; ++k) {
    const double uk = (k / 17) % 2 ? 1.0 : -1.0;
    d->time.push_back(k * dt);
    d->row_line.push_back(k + 2);
    u.values.push_back(uk);
    y.values.push_back(x + std::sqrt(r) * normal(rng));
    for (int i = 0; i < 20; ++i)
      x += (-a * x + b * uk) * dt / 20 + s * std::sqrt(dt / 20) * normal(rng);
  }
  d->columns = {u, y};
  return d;
}

TEST(PerRecordInitialStates, CopiesOnlyTheFreeParametersTheInitialStateAloneUses) {
  auto records = PerRecordInitialStates(Spec(kRecordModel), 3);
  ASSERT_TRUE(records.ok()) << records.error().ToString();
  ASSERT_EQ(records->own, std::vector<std::string>{"x0"});
  const model::ModelSpec& m = records->spec;
  ASSERT_EQ(m.parameters.size(), 7u);
  EXPECT_EQ(m.parameters[5].name, "x0_r2");
  EXPECT_EQ(m.parameters[6].name, "x0_r3");
  EXPECT_EQ(*m.parameters[6].lower, -50);  // the original's bounds
  EXPECT_EQ(records->index[0], (std::vector<int>{0, 1, 2, 3, 4, -1, -1}));
  EXPECT_EQ(records->index[1], (std::vector<int>{0, 1, 2, 3, 5, -1, -1}));
  EXPECT_EQ(records->index[2], (std::vector<int>{0, 1, 2, 3, 6, -1, -1}));
  // One record: the model as it is.
  auto one = PerRecordInitialStates(Spec(kRecordModel), 1);
  ASSERT_TRUE(one.ok());
  EXPECT_TRUE(one->index.empty());
  EXPECT_EQ(one->spec.parameters.size(), 5u);
}

TEST(PerRecordInitialStates, ACopyTheModelDeclaresKeepsItsOwnStartAndBounds) {
  Json j = Json::parse(kRecordModel);
  j["parameters"]["x0_r2"] = {{"value", 4.0}, {"lower", 0}, {"upper", 9}};
  auto spec = model::ParseModel(j, "records.json");
  ASSERT_TRUE(spec.ok());
  auto records = PerRecordInitialStates(*spec, 2);
  ASSERT_TRUE(records.ok()) << records.error().ToString();
  ASSERT_EQ(records->spec.parameters.size(), 6u);
  EXPECT_EQ(records->index[1][4], 5);
  EXPECT_EQ(records->spec.parameters[5].value, 4.0);
  EXPECT_EQ(*records->spec.parameters[5].upper, 9.0);
}

TEST(PerRecordInitialStates, AModelWhoseInitialStateHasNoParameterOfItsOwnIsRefusedNamingIt) {
  Json j = Json::parse(kRecordModel);
  j["initial_state"] = {{"x", "b"}};  // b is the drift's too
  auto spec = model::ParseModel(j, "records.json");
  ASSERT_TRUE(spec.ok());
  auto refused = PerRecordInitialStates(*spec, 2);
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.error().file, "records.json");
  EXPECT_EQ(refused.error().path, "initial_state");
  EXPECT_NE(refused.error().message.find("no"), std::string::npos);
}

// log L of the joint likelihood = Σ_s log L of record s alone at θ_s (its copies in the
// originals' places), and its gradient gathered onto θ = central differences of the joint.
void ExpectSeriesParametersAreExact(const Problem& problem) {
  auto joint = MakeLikelihood(problem);
  ASSERT_TRUE(joint.ok()) << joint.error().ToString();
  std::vector<double> theta = problem.spec().Values();
  theta[4] = 0.7;   // x0 of record 1
  theta[5] = -1.9;  // x0 of record 2
  auto total = joint->Evaluate(theta);
  ASSERT_TRUE(total.ok()) << total.error().ToString();
  double sum = 0;
  for (std::size_t s = 0; s < problem.series.size(); ++s) {
    auto alone = problem.model ? filter::Likelihood::Create(problem.model, {problem.series[s]})
                               : filter::Likelihood::Create(problem.nonlinear, {problem.series[s]});
    ASSERT_TRUE(alone.ok());
    auto l = alone->Evaluate(joint->SeriesTheta(theta, s));
    ASSERT_TRUE(l.ok());
    sum += l->loglik;
  }
  EXPECT_NEAR(total->loglik, sum, 1e-10 * std::abs(sum));

  const std::vector<int> free = {0, 1, 4, 5};
  Eigen::VectorXd gradient;
  Eigen::MatrixXd J;
  auto scored = joint->EvaluateWithScore(theta, {}, free, &gradient, &J);
  ASSERT_TRUE(scored.ok()) << scored.error().ToString();
  EXPECT_NEAR(scored->loglik, total->loglik, 1e-9 * std::abs(sum));
  for (std::size_t f = 0; f < free.size(); ++f) {
    const double h = 1e-5;
    std::vector<double> up = theta, down = theta;
    up[static_cast<std::size_t>(free[f])] += h;
    down[static_cast<std::size_t>(free[f])] -= h;
    const double difference =
        (joint->Evaluate(up)->loglik - joint->Evaluate(down)->loglik) / (2 * h);
    EXPECT_NEAR(gradient(static_cast<Eigen::Index>(f)), difference,
                1e-5 * std::max(1.0, std::abs(difference)))
        << problem.spec().parameters[static_cast<std::size_t>(free[f])].name;
    // The per-term rows add up to the gradient.
    EXPECT_NEAR(J.col(static_cast<Eigen::Index>(f)).sum(), gradient(static_cast<Eigen::Index>(f)),
                1e-9 * std::max(1.0, std::abs(difference)));
  }
}

TEST(RecordInitialStates, EachRecordIsFilteredFromItsOwnCopyAndTheScoreIsExactLinear) {
  auto problem = MakeProblem(Spec(kRecordModel), {Record(0.0, 1, 200), Record(4.0, 2, 150)},
                             InitialStates::kPerRecord);
  ASSERT_TRUE(problem.ok()) << problem.error().ToString();
  ASSERT_TRUE(problem->model);
  ExpectSeriesParametersAreExact(*problem);
}

TEST(RecordInitialStates, EachRecordIsFilteredFromItsOwnCopyAndTheScoreIsExactEkf) {
  auto problem = MakeProblem(Spec(kNonlinearRecordModel),
                             {Record(0.0, 3, 120), Record(4.0, 4, 100)}, InitialStates::kPerRecord);
  ASSERT_TRUE(problem.ok()) << problem.error().ToString();
  ASSERT_TRUE(problem->nonlinear);
  ExpectSeriesParametersAreExact(*problem);
}

// The copies start where their records' first samples place the state (a record starting at 4
// is not fitted from the model's x0 = 0); record 1 keeps the model's start.
TEST(RecordInitialStates, TheCopiesStartFromTheirRecordsFirstSamples) {
  auto problem = MakeProblem(Spec(kRecordModel), {Record(0.0, 5, 200), Record(4.0, 6, 200)},
                             InitialStates::kPerRecord);
  ASSERT_TRUE(problem.ok()) << problem.error().ToString();
  const auto& p = problem->spec().parameters;
  EXPECT_EQ(p[4].value, 0.0);
  EXPECT_NEAR(p[5].value, 4.0, 0.4);
}

TEST(RecordInitialStates, AJointFitRecoversEachRecordsInitialState) {
  auto problem = MakeProblem(Spec(kRecordModel), {Record(-3.0, 7, 300), Record(5.0, 8, 300)},
                             InitialStates::kPerRecord);
  ASSERT_TRUE(problem.ok()) << problem.error().ToString();
  auto lik = MakeLikelihood(*problem);
  ASSERT_TRUE(lik.ok());
  auto fit = estimate::Estimate(*lik, estimate::EstimateOptions{});
  ASSERT_TRUE(fit.ok()) << fit.error().ToString();
  ASSERT_EQ(fit->parameters.size(), 6u);
  const auto within = [](const estimate::ParameterEstimate& e, double truth) {
    ASSERT_TRUE(e.std_error) << e.name;
    EXPECT_LT(std::abs(e.estimate - truth), 4 * *e.std_error) << e.name << " " << e.estimate;
  };
  within(fit->parameters[4], -3.0);
  within(fit->parameters[5], 5.0);
  within(fit->parameters[0], 1.2);
  within(fit->parameters[1], 2.0);
  // Shared, the one initial state cannot suit both records: a lower optimum.
  auto shared = MakeProblem(Spec(kRecordModel), {Record(-3.0, 7, 300), Record(5.0, 8, 300)});
  ASSERT_TRUE(shared.ok());
  auto shared_lik = MakeLikelihood(*shared);
  ASSERT_TRUE(shared_lik.ok());
  auto shared_fit = estimate::Estimate(*shared_lik, estimate::EstimateOptions{});
  ASSERT_TRUE(shared_fit.ok());
  EXPECT_GT(fit->loglik, shared_fit->loglik + 10);
}

}  // namespace
}  // namespace gb::project
