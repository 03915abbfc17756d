// On-line estimation of a nonlinear model: the streaming EKF (core/online/ekf_stream.h) against
// the batch EKF and its exact score, the augmented EKF (core/online/augmented.h) on stationary
// data and after a parameter step, and the monitor (core/online/monitor.h) on a nonlinear model.
#include "core/online/augmented.h"

#include <cmath>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "core/estimate/estimate.h"
#include "core/filter/ekf.h"
#include "core/filter/ekf_score.h"
#include "core/filter/likelihood.h"
#include "core/model/nonlinear_sensitivity.h"
#include "core/online/ekf_stream.h"
#include "core/online/monitor.h"
#include "core/util/json.h"
#include "core/util/sanitizers.h"
#include "tests/core/nonlinear_tank.h"

namespace gb::online {
namespace {

using testing::CompileTank;
using testing::kTank;
using testing::SimulateTank;
using testing::TankTruth;

// The batch fit of the tank on `series` as a monitor's reference.
Reference FitReference(const std::shared_ptr<const model::NonlinearModel>& model,
                       std::vector<std::shared_ptr<const data::Series>> series,
                       estimate::EstimateSummary* out = nullptr) {
  auto lik = filter::Likelihood::Create(model, std::move(series));
  EXPECT_TRUE(lik) << lik.error().ToString();
  estimate::EstimateOptions o;
  o.threads = 1;
  auto fit = estimate::Estimate(*lik, o);
  EXPECT_TRUE(fit && fit->converged) << (fit ? fit->message : fit.error().ToString());
  Reference r = ReferenceFromSummary(*fit, model->spec(), "fit");
  if (out) *out = std::move(*fit);
  return r;
}

// Held at θ from the model's own start, the stream is the batch EKF: its terms sum to the batch
// log L and its scores to the exact gradient (ekf_score.h), with and without an output delay.
TEST(EkfStream, HeldAtThetaItsTermsAndScoresSumToTheBatchLikelihoodAndGradient) {
  const auto model = CompileTank(TankTruth());
  const auto series = SimulateTank(11, kSanitized ? 60.0 : 200.0);
  const std::vector<double> theta = model->spec().Values();
  const std::vector<int> free = {0, 1, 2, 3, 4};
  auto sensitivity = model::NonlinearSensitivity::Compile(*model);
  ASSERT_TRUE(sensitivity);
  for (int delay : {0, 3}) {
    SCOPED_TRACE(delay);
    EkfStreamOptions o;
    o.delay = {delay};
    o.sensitivities = free;
    o.start = RecursiveOptions::Start::kModel;
    auto stream = EkfStream::Create(model, theta, o, "tank.csv");
    ASSERT_TRUE(stream) << stream.error().ToString();
    double loglik = 0.0;
    Eigen::VectorXd score = Eigen::VectorXd::Zero(5);
    int steps = 0;
    for (const Sample& r : SamplesOf(*series)) {
      auto s = stream->Push(r);
      ASSERT_TRUE(s) << s.error().ToString();
      for (const EkfStep& step : *s) {
        EXPECT_EQ(step.index, steps++);
        loglik += step.loglik_term;
        score += step.score;
        EXPECT_TRUE(step.information.allFinite());
      }
    }
    EXPECT_EQ(steps, static_cast<int>(series->size()) - delay);
    filter::FilterSettings settings = filter::FilterSettings::FromModel(model->spec());
    settings.delay = {delay};
    Eigen::VectorXd gradient;
    auto batch = filter::EkfLogLikelihoodWithScore(*model, *sensitivity, theta, *series, settings,
                                                   free, &gradient);
    ASSERT_TRUE(batch) << batch.error().ToString();
    EXPECT_NEAR(loglik, batch->loglik, 1e-9 * std::abs(batch->loglik));
    for (int l = 0; l < 5; ++l)
      EXPECT_NEAR(score(l), gradient(l), 1e-7 * (1.0 + std::abs(gradient(l)))) << l;
  }
}

// The live start: the equilibrium of the first input with the stationary covariance.
TEST(EkfStream, ALiveStreamStartsAtTheEquilibriumOfTheFirstInput) {
  const auto model = CompileTank(TankTruth());
  EkfStreamOptions o;
  auto stream = EkfStream::Create(model, model->spec().Values(), o, "live");
  ASSERT_TRUE(stream);
  Sample a{0.0, {1.2}, {std::nan("")}, 2}, b{0.5, {1.2}, {std::nan("")}, 3};
  ASSERT_TRUE(stream->Push(a));
  auto steps = stream->Push(b);
  ASSERT_TRUE(steps && steps->size() == 2);
  // k u = a sqrt(h): h = (0.8 * 1.2 / 0.5)², and the level stays there.
  const double h = std::pow(0.8 * 1.2 / 0.5, 2);
  EXPECT_NEAR(stream->x()(0), h, 1e-8 * h);
  // dh = (k u - a √h) dt + s √h dω: J = -a / (2 √h), P = s² h / (2 |J|).
  const double J = -0.5 / (2.0 * std::sqrt(h));
  EXPECT_NEAR(stream->P()(0, 0), 0.08 * 0.08 * h / (2.0 * -J), 1e-6);
  EXPECT_NEAR(stream->slowest_time_constant(), -1.0 / J, 1e-9);
}

// Stationary data, λ = 1: from the batch fit of one record, over a second record the augmented
// EKF ends within 2 SE of the joint batch fit of both (the data it has seen), for each tracked
// parameter; and its SD is the joint fit's size.
TEST(AugmentedEkf, OnStationaryDataItEndsWithinTwoStandardErrorsOfTheJointBatchFit) {
  const auto model = CompileTank(Json::parse(kTank));
  const double duration = kSanitized ? 150.0 : 400.0;
  const auto first = SimulateTank(21, duration), second = SimulateTank(22, duration);
  const Reference ref = FitReference(model, {first});
  estimate::EstimateSummary joint;
  FitReference(model, {first, second}, &joint);
  RecursiveOptions o;
  o.forgetting = 1.0;
  auto ekf = AugmentedEkf::Create(model, ref, o);
  ASSERT_TRUE(ekf) << ekf.error().ToString();
  ASSERT_EQ(ekf->tracked_names(), (std::vector<std::string>{"k", "a"}))
      << "s and r are variances: not tracked; h0 only sets the start";
  RecursiveUpdate last;
  for (const Sample& r : SamplesOf(*second)) {
    auto ups = ekf->Push(r);
    ASSERT_TRUE(ups) << ups.error().ToString();
    if (!ups->empty()) last = ups->back();
  }
  EXPECT_FALSE(last.warming_up);
  for (std::size_t a = 0; a < 2; ++a) {
    const std::string& name = ekf->tracked_names()[a];
    SCOPED_TRACE(name);
    const estimate::ParameterEstimate* p = nullptr;
    for (const auto& e : joint.parameters)
      if (e.name == name) p = &e;
    ASSERT_TRUE(p && p->std_error);
    EXPECT_LT(std::abs(last.theta[a] - p->estimate), 2.0 * *p->std_error)
        << last.theta[a] << " ± " << last.sd[a] << " against " << p->estimate << " ± "
        << *p->std_error;
    EXPECT_GT(last.sd[a], 0.5 * *p->std_error);
    EXPECT_LT(last.sd[a], 2.0 * *p->std_error);
  }
}

// The tank whose inflow gain k rises by 30 % around t = 300 s (a smooth step, 2 s wide).
Json SteppedTank(double at) {
  Json truth = TankTruth();
  truth["drift"]["h"] = fmt::format("k*(1 + 0.15*(1 + tanh((t - {})/2)))*u - a*sqrt(h)", at);
  return truth;
}

// A step of +30 % in k: the augmented EKF (λ = 0.99, a memory of 50 s) follows it to the new value
// within 3 SD, every value inside the bounds; the innovation tests alarm within 30 s of the step,
// the score test names "k: up" within 100 s, and nothing alarms before the step.
TEST(AugmentedEkf, AfterAStepTheEstimateFollowsAndTheMonitorNamesTheParameter) {
  const auto model = CompileTank(Json::parse(kTank));
  const Reference ref = FitReference(model, {SimulateTank(31, 400.0)});
  const double step_at = kSanitized ? 150.0 : 300.0;
  const auto record = SimulateTank(32, 2.0 * step_at, SteppedTank(step_at));
  MonitorOptions o;
  o.recursive.forgetting = 0.99;
  o.false_alarms_per_hour = 1.0;
  o.parameter_change = 0.25;
  // k alone: k and a are close to interchangeable here (the level is (k u / a)²), and the score
  // test's isolation is first-order (monitor.h), so watching both would also name a.
  o.recursive.track = {"k"};
  auto monitor = Monitor::Create(model->spec(), ref, o);
  ASSERT_TRUE(monitor) << monitor.error().ToString();
  EXPECT_NE(monitor->estimator().Method().find("augmented"), std::string::npos);
  double first_alarm = -1.0, parameter_alarm = -1.0;
  std::string what;  // the first parameter alarm
  RecursiveUpdate last;
  for (const Sample& r : SamplesOf(*record)) {
    auto ups = monitor->Push(r);
    ASSERT_TRUE(ups) << ups.error().ToString();
    for (const MonitorUpdate& u : *ups) {
      last = u.estimate;
      EXPECT_GT(u.estimate.theta[0], 0.01);
      EXPECT_LT(u.estimate.theta[0], 5.0);
      if (!u.alarms.empty() && first_alarm < 0) first_alarm = u.estimate.t;
      for (const MonitorAlarm& a : u.alarms) {
        if (a.kind != MonitorAlarm::Kind::kParameter || !what.empty()) continue;
        what = a.what;
        parameter_alarm = u.estimate.t;
      }
    }
  }
  RecordProperty("first_alarm_s", fmt::format("{:.1f}", first_alarm));
  RecordProperty("parameter_alarm_s", fmt::format("{:.1f}", parameter_alarm));
  EXPECT_GT(first_alarm, step_at);
  EXPECT_LT(first_alarm, step_at + 30.0);
  EXPECT_EQ(what, "k: up");
  EXPECT_GT(parameter_alarm, step_at);
  EXPECT_LT(parameter_alarm, step_at + 100.0);
  const double k_after = ref.theta[0] * 1.3;
  EXPECT_LT(std::abs(last.theta[0] - k_after), 3.0 * last.sd[0] + 0.02 * k_after)
      << last.theta[0] << " ± " << last.sd[0] << " against " << k_after;
}

// On stationary data the nonlinear monitor's alarms (innovation and score tests together) come at
// no more than the rate set: hours of the tank at 5 per hour.
TEST(AugmentedEkf, OnStationaryDataTheMonitorsFalseAlarmRateIsAtMostTheRateSet) {
  const auto model = CompileTank(Json::parse(kTank));
  const Reference ref = FitReference(model, {SimulateTank(41, 400.0)});
  const double hours = kSanitized ? 1.0 : 4.0;
  const auto record = SimulateTank(42, 3600.0 * hours);
  MonitorOptions o;
  o.false_alarms_per_hour = 5.0;
  auto monitor = Monitor::Create(model->spec(), ref, o);
  ASSERT_TRUE(monitor) << monitor.error().ToString();
  long alarms = 0;
  for (const Sample& r : SamplesOf(*record)) {
    auto ups = monitor->Push(r);
    ASSERT_TRUE(ups) << ups.error().ToString();
    for (const MonitorUpdate& u : *ups) alarms += static_cast<long>(u.alarms.size());
  }
  RecordProperty("alarms", static_cast<int>(alarms));
  // The rate is a bound (Bonferroni over the tests); allow its Poisson error, 3 SD.
  const double expected = 5.0 * hours;
  EXPECT_LE(static_cast<double>(alarms), expected + 3.0 * std::sqrt(expected)) << alarms;
}

TEST(AugmentedEkf, RefusesToTrackAVarianceParameterAndSaysWhichCanBe) {
  const auto model = CompileTank(Json::parse(kTank));
  Reference ref;
  ref.theta = model->spec().Values();
  ref.free = {0, 1, 2, 3, 4};
  RecursiveOptions o;
  o.track = {"r"};
  auto ekf = AugmentedEkf::Create(model, ref, o);
  ASSERT_FALSE(ekf);
  EXPECT_NE(ekf.error().message.find("cannot track 'r'"), std::string::npos);
  EXPECT_NE(ekf.error().message.find("are k, a"), std::string::npos) << ekf.error().message;
}

TEST(Monitor, ChoosesTheRecursiveEstimatorForALinearModelAndTheAugmentedEkfOtherwise) {
  auto linear =
      model::LoadModelFile(std::string(GREYBENCH_SOURCE_DIR) + "/assets/models/crankshaft.json");
  ASSERT_TRUE(linear);
  Reference ref;
  ref.theta = linear->Values();
  auto m = Monitor::Create(*linear, ref, MonitorOptions{});
  ASSERT_TRUE(m) << m.error().ToString();
  EXPECT_NE(m->estimator().Method().find("recursive maximum likelihood"), std::string::npos);
  const auto tank = CompileTank(Json::parse(kTank));
  Reference tref;
  tref.theta = tank->spec().Values();
  auto n = Monitor::Create(tank->spec(), tref, MonitorOptions{});
  ASSERT_TRUE(n) << n.error().ToString();
  EXPECT_NE(n->estimator().Method().find("augmented extended Kalman filter"), std::string::npos);
}

}  // namespace
}  // namespace gb::online
