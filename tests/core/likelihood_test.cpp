#include "core/filter/likelihood.h"

#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>

#include <gtest/gtest.h>

#include "core/design/prbs.h"
#include "core/sim/simulate.h"
#include "core/util/json.h"
#include "tests/core/nonlinear_tank.h"

namespace gb::filter {
namespace {

std::shared_ptr<const model::LinearModel> Compile(const char* text) {
  auto spec = model::ParseModel(Json::parse(text), "m.json");
  EXPECT_TRUE(spec.ok()) << spec.error().ToString();
  return std::make_shared<const model::LinearModel>(*model::LinearModel::Compile(*spec));
}

const char* kModel = R"json({
  "greybench_model": 1, "states": ["x"], "inputs": ["u"], "outputs": ["y"],
  "parameters": {"a": 1.5, "b": 2.0, "s": 0.4, "r": 0.05},
  "drift": {"x": "-a*x + b*u"}, "diffusion": {"x": "s"},
  "observation": {"y": "x"}, "measurement_variance": {"y": "r"},
  "output_delay": {"y": {"min": 0, "max": 4}}})json";

std::shared_ptr<const data::Series> SimulatedSeries(const model::LinearModel& m, int delay,
                                                    std::uint32_t seed, double duration) {
  design::PrbsOptions o;
  o.order = 5;
  o.bit_period = 0.5;
  o.sample_time = 0.1;
  o.duration = duration;
  o.seed = seed;
  auto u = *design::MakePrbs(o);
  data::Series s;
  s.source = "sim" + std::to_string(seed);
  s.time = u.t;
  s.U = Eigen::Map<const Eigen::MatrixXd>(u.u.data(), 1, static_cast<Eigen::Index>(u.u.size()));
  s.Y.setZero(1, static_cast<Eigen::Index>(u.t.size()));
  s.intervals = data::GroupIntervals(s.time);
  FilterSettings st = FilterSettings::FromModel(m.spec());
  st.delay = {delay};
  sim::SimulateOptions so;
  so.seed = seed;
  s.Y = sim::Simulate(*m.Evaluate(m.spec().Values()), s, st, so)->Y;
  return std::make_shared<const data::Series>(std::move(s));
}

TEST(Likelihood, SeveralDatasetsAddUp) {
  const auto m = Compile(kModel);
  const auto s1 = SimulatedSeries(*m, 2, 1, 30.0);
  const auto s2 = SimulatedSeries(*m, 2, 2, 20.0);
  const auto joint = *Likelihood::Create(m, {s1, s2});
  const auto one = *Likelihood::Create(m, {s1});
  const auto two = *Likelihood::Create(m, {s2});
  const std::vector<double> theta = m->spec().Values();
  for (int d = 0; d <= 4; ++d) {
    const std::vector<int> delay = {d};
    const auto lj = joint.Evaluate(theta, delay);
    const auto l1 = one.Evaluate(theta, delay);
    const auto l2 = two.Evaluate(theta, delay);
    ASSERT_TRUE(lj.ok() && l1.ok() && l2.ok());
    EXPECT_NEAR(lj->loglik, l1->loglik + l2->loglik, 1e-9 * std::abs(lj->loglik));
    EXPECT_EQ(lj->n_obs, l1->n_obs + l2->n_obs);
  }
}

// The records of a joint fit filtered side by side (Likelihood::Evaluate's `threads`) give what
// one thread gives, bit for bit: log L, the terms, the gradient (the EKF's adjoint and forward
// sensitivities) and the per-term scores; and a failure names the first failing record in the
// records' order, whichever thread finished first.
TEST(Likelihood, RecordsOnThreadsGiveWhatOneThreadGivesBitForBit) {
  auto same = [](const Result<Loglik>& a, const Result<Loglik>& b) {
    ASSERT_TRUE(a.ok() && b.ok());
    EXPECT_EQ(std::bit_cast<std::uint64_t>(a->loglik), std::bit_cast<std::uint64_t>(b->loglik));
    EXPECT_EQ(a->n_obs, b->n_obs);
  };
  {
    const auto m = Compile(kModel);
    const auto lik =
        *Likelihood::Create(m, {SimulatedSeries(*m, 2, 1, 30.0), SimulatedSeries(*m, 2, 2, 20.0),
                                SimulatedSeries(*m, 2, 3, 25.0)});
    const std::vector<double> theta = m->spec().Values();
    const std::vector<int> delay = {2}, free = {0, 1, 2, 3};
    std::vector<double> terms1, terms3;
    same(lik.Evaluate(theta, delay, &terms1, 1), lik.Evaluate(theta, delay, &terms3, 3));
    EXPECT_EQ(terms1, terms3);
    Eigen::VectorXd g1, g3;
    Eigen::MatrixXd J1, J3;
    same(lik.EvaluateWithScore(theta, delay, free, &g1, &J1, 1),
         lik.EvaluateWithScore(theta, delay, free, &g3, &J3, 3));
    EXPECT_EQ(g1, g3);
    EXPECT_EQ(J1, J3);
  }
  const auto nm = testing::CompileTank(testing::TankTruth());
  std::vector<std::shared_ptr<const data::Series>> records;
  for (std::uint64_t seed : {1, 2, 3}) records.push_back(testing::SimulateTank(seed, 100.0));
  const auto lik = *Likelihood::Create(nm, records);
  const std::vector<double> theta = nm->spec().Values();
  const std::vector<int> free = {0, 1, 2, 3, 4};
  ASSERT_TRUE(lik.UsesAdjoint(free.size()));
  same(lik.Evaluate(theta, {}, nullptr, 1), lik.Evaluate(theta, {}, nullptr, 2));
  Eigen::VectorXd g1, g2;
  same(lik.EvaluateWithScore(theta, {}, free, &g1, nullptr, 1),
       lik.EvaluateWithScore(theta, {}, free, &g2, nullptr, 2));
  EXPECT_EQ(g1, g2);
  Eigen::MatrixXd J1, J2;
  same(lik.EvaluateWithScore(theta, {}, free, &g1, &J1, 1),
       lik.EvaluateWithScore(theta, {}, free, &g2, &J2, 2));
  EXPECT_EQ(g1, g2);
  EXPECT_EQ(J1, J2);

  // Records 2 and 3 fail (an input that is not a number); record 2's failure is the one named.
  const char* names[] = {"first.csv", "second.csv", "third.csv"};
  std::vector<std::shared_ptr<const data::Series>> failing;
  for (int r = 0; r < 3; ++r) {
    auto s = std::make_shared<data::Series>(*records[static_cast<std::size_t>(r)]);
    s->source = names[r];
    if (r > 0) s->U(0, 10 * r) = std::numeric_limits<double>::quiet_NaN();
    failing.push_back(std::move(s));
  }
  const auto bad = *Likelihood::Create(nm, failing);
  for (int threads : {1, 3}) {
    const auto l = bad.Evaluate(theta, {}, nullptr, threads);
    ASSERT_FALSE(l.ok());
    EXPECT_EQ(l.error().file, "second.csv") << l.error().ToString();
    const auto ls = bad.EvaluateWithScore(theta, {}, free, &g1, nullptr, threads);
    ASSERT_FALSE(ls.ok());
    EXPECT_EQ(ls.error().file, "second.csv") << ls.error().ToString();
  }
}

// A record without one observation in the rows the filter scores (k >= the largest delay) would
// give log L = 0 and a fit that "converges" anywhere: refused, naming the record.
TEST(Likelihood, ARecordWithoutAnObservationInTheScoredRowsIsRefusedNamingIt) {
  const auto m = Compile(kModel);
  const auto good = SimulatedSeries(*m, 2, 1, 10.0);
  auto none = std::make_shared<data::Series>(*good);
  none->source = "no_obs.csv";
  // Observations only before row 4, which no delay candidate (up to 4) scores.
  none->Y.rightCols(none->Y.cols() - 4).setConstant(std::numeric_limits<double>::quiet_NaN());
  const auto refused = Likelihood::Create(m, {good, none});
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.error().file, "no_obs.csv");
  EXPECT_NE(refused.error().message.find("no observation"), std::string::npos)
      << refused.error().message;
  // One observation left at row 4 is enough.
  auto one = std::make_shared<data::Series>(*none);
  one->Y(0, 4) = good->Y(0, 4);
  EXPECT_TRUE(Likelihood::Create(m, {good, one}).ok());
}

TEST(Likelihood, ScoresEveryDelayCandidateOnTheSameObservations) {
  const auto m = Compile(kModel);
  const auto s = SimulatedSeries(*m, 3, 5, 40.0);
  const auto lik = *Likelihood::Create(m, {s});
  const auto profile = lik.Profile(m->spec().Values());
  ASSERT_TRUE(profile.ok());
  ASSERT_EQ(profile->candidates.size(), 5u);
  for (const auto& c : profile->candidates) {
    ASSERT_TRUE(c.ok) << c.message;
    EXPECT_EQ(c.n_obs, static_cast<long>(s->size()) - 4) << "observations k >= max delay (4)";
  }
  EXPECT_EQ(profile->candidates[profile->best].delay[0], 3) << "the simulated delay wins";
}

TEST(Likelihood, RefusesADelayRangeLongerThanTheData) {
  const auto m = Compile(R"json({
    "greybench_model": 1, "states": ["x"], "outputs": ["y"], "parameters": {"a": 1},
    "drift": {"x": "-a*x"}, "diffusion": {"x": "1"}, "observation": {"y": "x"},
    "measurement_variance": {"y": "1"}, "output_delay": {"y": {"min": 0, "max": 50}}})json");
  data::Series s;
  s.source = "short.csv";
  s.time = {0, 1, 2, 3, 4};
  s.U.resize(0, 5);
  s.Y.setZero(1, 5);
  s.intervals = data::GroupIntervals(s.time);
  auto lik = Likelihood::Create(m, {std::make_shared<const data::Series>(s)});
  ASSERT_FALSE(lik.ok());
  EXPECT_EQ(lik.error().path, "output_delay.y");
  EXPECT_NE(lik.error().message.find("short.csv has only 5 rows"), std::string::npos)
      << lik.error().message;
}

}  // namespace
}  // namespace gb::filter
