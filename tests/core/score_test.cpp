// The analytic score (core/filter/score.h) against central differences of the log-likelihood.
#include "core/filter/score.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <span>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "core/filter/likelihood.h"
#include "core/filter/linear_step.h"
#include "core/util/json.h"
#include "filter_fixtures.h"

namespace gb::filter {
namespace {

const std::string kRoot = GREYBENCH_SOURCE_DIR;

// The best central difference must agree with the analytic derivative to this, relative to
// max(|∂ log L/∂θ_i|, 1).
constexpr double kAgreement = 1e-6;
// Steps relative to |θ_i|, from coarse to fine: the error of (L(θ+h) - L(θ-h))/2h is O(h²) until
// rounding (about eps |L| / h) takes over.
constexpr double kRelativeSteps[] = {1e-2, 1e-3, 1e-4, 1e-5};

// The first `rows` rows of a bound series.
std::shared_ptr<const data::Series> Head(const data::Series& s, int rows) {
  data::Series h = s;
  h.time.resize(rows);
  h.U = s.U.leftCols(rows);
  h.Y = s.Y.leftCols(rows);
  if (!h.row_line.empty()) h.row_line.resize(rows);
  h.intervals = data::GroupIntervals(h.time);
  return std::make_shared<const data::Series>(std::move(h));
}

std::shared_ptr<const data::Series> AssetSeries(const model::ModelSpec& spec, const char* file,
                                                int rows) {
  auto data = data::ReadCsvFile(kRoot + "/assets/data/" + file);
  EXPECT_TRUE(data.ok()) << data.error().ToString();
  auto series = data::Bind(**data, spec.inputs, spec.outputs);
  EXPECT_TRUE(series.ok()) << series.error().ToString();
  return Head(**series, rows);
}

std::shared_ptr<const model::LinearModel> AssetModel(const char* file) {
  auto spec = model::LoadModelFile(kRoot + "/assets/models/" + file);
  EXPECT_TRUE(spec.ok()) << spec.error().ToString();
  return std::make_shared<const model::LinearModel>(*model::LinearModel::Compile(*spec));
}

std::shared_ptr<const model::LinearModel> JsonModel(const Json& j) {
  auto spec = model::ParseModel(j, "test.json");
  EXPECT_TRUE(spec.ok()) << spec.error().ToString();
  auto lm = model::LinearModel::Compile(*spec);
  EXPECT_TRUE(lm.ok()) << lm.error().ToString();
  return std::make_shared<const model::LinearModel>(std::move(*lm));
}

std::vector<int> AllParameters(const model::LinearModel& m) {
  std::vector<int> all(m.n_parameters());
  for (int i = 0; i < m.n_parameters(); ++i) all[i] = i;
  return all;
}

struct StepStudy {
  std::vector<double> error;     // |central difference - analytic| at each of kRelativeSteps
  std::vector<double> rounding;  // the rounding error of the difference there, eps |log L| / h
  double best_relative = 0;      // the smallest error, relative to max(|analytic|, 1)
};

// Compares the analytic gradient with central differences at every step of kRelativeSteps, for
// every parameter, and returns the study (one entry per parameter). Checks the agreement and that
// the rows of J_terms_theta sum to the gradient.
std::vector<StepStudy> CheckScore(const Likelihood& lik, const std::vector<double>& theta,
                                  std::span<const int> delay = {}) {
  const std::vector<int> free = AllParameters(*lik.linear());
  Eigen::VectorXd gradient;
  Eigen::MatrixXd J;
  const auto l = lik.EvaluateWithScore(theta, delay, free, &gradient, &J);
  EXPECT_TRUE(l.ok()) << l.error().ToString();
  if (!l.ok()) return {};
  const auto value = lik.Evaluate(theta, delay);
  EXPECT_NEAR(l->loglik, value->loglik, 1e-10 * std::abs(value->loglik));
  EXPECT_EQ(l->n_obs, value->n_obs);
  const Eigen::VectorXd sum_of_scores = J.colwise().sum().transpose();
  EXPECT_LE((sum_of_scores - gradient).cwiseAbs().maxCoeff(),
            1e-10 * std::max(1.0, gradient.cwiseAbs().maxCoeff()));

  std::vector<StepStudy> study;
  for (std::size_t i = 0; i < free.size(); ++i) {
    const std::string& name = lik.spec().parameters[free[i]].name;
    StepStudy s;
    s.best_relative = INFINITY;
    for (double rel : kRelativeSteps) {
      const double h = rel * std::max(std::abs(theta[free[i]]), 1e-3);
      std::vector<double> up = theta, down = theta;
      up[free[i]] += h;
      down[free[i]] -= h;
      const auto lu = lik.Evaluate(up, delay);
      const auto ld = lik.Evaluate(down, delay);
      EXPECT_TRUE(lu.ok() && ld.ok()) << name;
      const double difference = (lu->loglik - ld->loglik) / (2 * h);
      s.error.push_back(std::abs(difference - gradient(i)));
      s.rounding.push_back(std::numeric_limits<double>::epsilon() * std::abs(l->loglik) / h);
      s.best_relative =
          std::min(s.best_relative, s.error.back() / std::max(std::abs(gradient(i)), 1.0));
    }
    EXPECT_LE(s.best_relative, kAgreement)
        << name << ": analytic " << gradient(i) << ", errors of the differences at h/|θ| = 1e-2 "
        << s.error[0] << ", 1e-3 " << s.error[1] << ", 1e-4 " << s.error[2] << ", 1e-5 "
        << s.error[3];
    study.push_back(std::move(s));
  }
  return study;
}

double Worst(const std::vector<StepStudy>& study) {
  double worst = 0;
  for (const auto& s : study) worst = std::max(worst, s.best_relative);
  return worst;
}

TEST(Score, FuelFilmWithDelayMatchesCentralDifferencesAndTheirErrorShrinksAsHSquared) {
  const auto m = AssetModel("fuel_film.json");
  const auto lik = *Likelihood::Create(m, {AssetSeries(m->spec(), "fuel_f1.csv", 1500)});
  const std::vector<int> delay = {5};
  const auto study = CheckScore(lik, m->spec().Values(), delay);
  ASSERT_EQ(study.size(), 8u);
  // The step study: from h to h/10 the truncation error falls 100-fold; require 30-fold while
  // the error at h/10 is still well above rounding.
  for (std::size_t i = 0; i < study.size(); ++i) {
    const auto& e = study[i].error;
    for (std::size_t s = 0; s + 1 < e.size() && e[s + 1] > 100 * study[i].rounding[s + 1]; ++s)
      EXPECT_GT(e[s] / e[s + 1], 30.0) << m->spec().parameters[i].name << " step " << s;
  }
  RecordProperty("worst_relative_error", std::to_string(Worst(study)));
}

TEST(Score, TheSteadyStateInterruptedByMissingValuesMatchesCentralDifferences) {
  // The filter's covariance and its sensitivities reach a fixed point after ~300 rows, from
  // where their updates are replayed (kalman.h, "steady state"); missing values at rows 600,
  // 601 and 1000 leave it and the filter returns to it.
  const auto m = AssetModel("fuel_film.json");
  data::Series s = *AssetSeries(m->spec(), "fuel_f1.csv", 1500);
  for (int row : {600, 601, 1000}) s.Y(0, row) = std::numeric_limits<double>::quiet_NaN();
  const auto series = std::make_shared<const data::Series>(std::move(s));
  const auto lik = *Likelihood::Create(m, {series});
  const std::vector<int> delay = {5};
  CheckScore(lik, m->spec().Values(), delay);
  // The value filter's replay is exact: the trace path (which never replays) agrees bit for bit
  // (both summing the per-row terms).
  FilterSettings settings = FilterSettings::FromModel(m->spec());
  settings.delay = delay;
  const auto ss = *m->Evaluate(m->spec().Values());
  FilterTrace trace;
  std::vector<double> terms;
  const auto replayed = LogLikelihood(ss, *series, settings, &terms);
  const auto traced = RunFilter(ss, *series, settings, &trace);
  ASSERT_TRUE(replayed.ok() && traced.ok());
  EXPECT_EQ(replayed->loglik, traced->loglik);
  EXPECT_EQ(replayed->n_obs, 1492);
}

// The score and the value filter with the steady state's replay against the full recursion
// (FilterSettings::steady_replay = false), to the last bit; the replay must cover more than
// `min_replayed` rows (-1: any number).
// The gradient alone (no row's score) by the adjoints (linear_loops.h): of a replayed steady
// state that lasts to the end (AdjointOfTheSteadyState), and of the whole recursion
// (AdjointOfTheSeries). log L to the bit and every component to rounding, relative to the sum
// of the rows' |scores| (J) it adds up, against the forward sensitivities'. Returns the rows the
// steady state's adjoint gave.
long ExpectTheSteadyStatesAdjointIsTheForwardGradient(const model::StateSpace& ss,
                                                      std::span<const model::StateSpace> dss,
                                                      const data::Series& series,
                                                      const FilterSettings& settings,
                                                      const Eigen::MatrixXd& J) {
  FilterSettings forward = settings;
  forward.linear_gradient = LinearGradient::kForward;
  Eigen::VectorXd g_forward;
  const auto sensitivities = LogLikelihoodScore(ss, dss, series, forward, &g_forward);
  // The whole recursion's adjoint runs the value filter forward (its replay needs only P).
  const auto value = LogLikelihood(ss, series, settings);
  EXPECT_TRUE(sensitivities.ok() && value.ok());
  if (!sensitivities.ok() || !value.ok()) return 0;
  EXPECT_EQ(sensitivities->adjoint, 0);
  long steady_rows = 0;
  for (const LinearGradient method : {LinearGradient::kSteadyState, LinearGradient::kAdjoint}) {
    SCOPED_TRACE(method == LinearGradient::kAdjoint ? "the whole recursion's adjoint"
                                                    : "the steady state's adjoint");
    FilterSettings adjoint_settings = settings;
    adjoint_settings.linear_gradient = method;
    Eigen::VectorXd g_adjoint;
    const auto adjoint = LogLikelihoodScore(ss, dss, series, adjoint_settings, &g_adjoint);
    EXPECT_TRUE(adjoint.ok());
    if (!adjoint.ok()) return 0;
    EXPECT_EQ(adjoint->loglik, sensitivities->loglik);
    EXPECT_EQ(adjoint->n_obs, sensitivities->n_obs);
    EXPECT_EQ(adjoint->replayed,
              method == LinearGradient::kAdjoint ? value->replayed : sensitivities->replayed);
    for (Eigen::Index i = 0; i < g_forward.size(); ++i)
      EXPECT_NEAR(g_adjoint(i), g_forward(i), 1e-12 * J.col(i).cwiseAbs().sum()) << "θ_" << i;
    if (method == LinearGradient::kSteadyState) steady_rows = adjoint->adjoint;
  }
  return steady_rows;
}

void ExpectReplayIsTheFullRecursion(const model::StateSpace& ss,
                                    std::span<const model::StateSpace> dss,
                                    const data::Series& series, const FilterSettings& settings,
                                    long min_replayed) {
  FilterSettings full = settings;
  full.steady_replay = false;
  Eigen::VectorXd g_replayed, g_full;
  Eigen::MatrixXd J_replayed, J_full;
  const auto replayed = LogLikelihoodScore(ss, dss, series, settings, &g_replayed, &J_replayed);
  const auto recursed = LogLikelihoodScore(ss, dss, series, full, &g_full, &J_full);
  ASSERT_TRUE(replayed.ok() && recursed.ok());
  EXPECT_GT(replayed->replayed, min_replayed);
  EXPECT_EQ(recursed->replayed, 0);
  EXPECT_EQ(replayed->loglik, recursed->loglik);
  EXPECT_TRUE(g_replayed == g_full) << (g_replayed - g_full).transpose();
  EXPECT_TRUE(J_replayed == J_full) << (J_replayed - J_full).cwiseAbs().maxCoeff();
  ExpectTheSteadyStatesAdjointIsTheForwardGradient(ss, dss, series, settings, J_full);

  // The value filter alone: its P is replayed too, and equal to the full recursion's.
  std::vector<double> terms_replayed, terms_full;
  const auto value = LogLikelihood(ss, series, settings, &terms_replayed);
  const auto value_full = LogLikelihood(ss, series, full, &terms_full);
  ASSERT_TRUE(value.ok() && value_full.ok());
  EXPECT_GT(value->replayed, min_replayed);
  EXPECT_EQ(value->loglik, value_full->loglik);
  EXPECT_EQ(value->loglik, replayed->loglik);
  EXPECT_TRUE(terms_replayed == terms_full);
}

// s with its outputs missing at `rows`: each breaks the replay where it stands in its cycles,
// and the full recursion resumes from the values the replay left behind.
std::shared_ptr<const data::Series> WithMissing(const data::Series& s,
                                                const std::vector<int>& rows) {
  data::Series out = s;
  for (int row : rows) out.Y.col(row).setConstant(std::numeric_limits<double>::quiet_NaN());
  return std::make_shared<const data::Series>(std::move(out));
}

TEST(Score, ACovarianceThatEndsInACycleOfStepsIsReplayedBitForBit) {
  // The fuel film at the generic fit's optimum on f7, its measurement variance on its bound
  // 1e-9: in floating point P and the dP_i do not settle on one step but on a cycle of a few,
  // their last bits alternating (linear_step.h, SteadyReplay). The cycle is replayed, and the
  // replay is the full recursion to the last bit: log L, the gradient and every row's terms,
  // also where missing values break it at either phase of its cycles.
  const auto m = AssetModel("fuel_film.json");
  const auto series = AssetSeries(m->spec(), "fuel_f7.csv", 4000);
  std::vector<double> theta = m->spec().Values();
  const std::pair<const char*, double> optimum[] = {
      {"tau_fv", 0.0879525}, {"tau_ff", 0.35309},  {"X", 0.158823}, {"Kb", 0.650211},
      {"s11", 0.0159101},    {"s12", 0.000160355}, {"s2", 1e-9}};
  std::vector<int> all;
  for (std::size_t i = 0; i < theta.size(); ++i) {
    all.push_back(static_cast<int>(i));
    for (const auto& [name, value] : optimum)
      if (m->spec().parameters[i].name == name) theta[i] = value;
  }
  FilterSettings settings = FilterSettings::FromModel(m->spec());
  settings.delay = {3};
  const auto ss = *m->Evaluate(theta);
  const auto dss = *m->EvaluateJacobian(theta, all);
  // The cycles begin within the first thousand rows (none was replayed before cycles were).
  ExpectReplayIsTheFullRecursion(ss, dss, *series, settings, 3000);
  ExpectReplayIsTheFullRecursion(ss, dss, *WithMissing(*series, {1500, 1501, 2601, 3334}), settings,
                                 1000);
}

TEST(Score, CovariancesWhoseSensitivitiesCycleEachOnItsOwnAreReplayedBitForBit) {
  // Building 3 (4 states, 19 parameters) at CTSM-R's estimates: P ends in a cycle of 2 steps and
  // each dP_i in one of its own (2 to 12 steps, one longer than 16), so that the whole state
  // repeats only after 120 steps; each is replayed from its own cycle (linear_step.h,
  // SteadyReplay), and the result is the full recursion to the last bit, also where missing
  // values break it.
  auto spec = model::LoadModelFile(kRoot + "/tests/data/building3/model.json");
  ASSERT_TRUE(spec.ok()) << spec.error().ToString();
  auto data = data::ReadCsvFile(kRoot + "/tests/data/building3/data.csv");
  ASSERT_TRUE(data.ok()) << data.error().ToString();
  auto series = data::Bind(**data, spec->inputs, spec->outputs);
  ASSERT_TRUE(series.ok()) << series.error().ToString();
  const auto m = std::make_shared<const model::LinearModel>(*model::LinearModel::Compile(*spec));
  const std::vector<double> theta = m->spec().Values();
  std::vector<int> free;
  for (std::size_t i = 0; i < theta.size(); ++i)
    if (!m->spec().parameters[i].fixed) free.push_back(static_cast<int>(i));
  const FilterSettings settings = FilterSettings::FromModel(m->spec());
  const auto ss = *m->Evaluate(theta);
  const auto dss = *m->EvaluateJacobian(theta, free);
  // How many rows replay turns on the last bits: 4 400 of 6 905 in the release build (GCC), none
  // in the sanitizers' (Clang), where a dP_i's cycle is longer than the ring. Either way the
  // replay is the full recursion.
  ExpectReplayIsTheFullRecursion(ss, dss, **series, settings, -1);
  ExpectReplayIsTheFullRecursion(ss, dss, *WithMissing(**series, {5000, 5001, 6003}), settings, -1);
  Eigen::VectorXd gradient;
  const auto l = LogLikelihoodScore(ss, dss, **series, settings, &gradient);
  ASSERT_TRUE(l.ok());
  EXPECT_NEAR(l->loglik, 5930.09335342, 1e-6 * 5930.09335342);  // CTSM-R's
}

TEST(Score, ACovarianceBackWithItsZerosSignFlippedRepeats) {
  // SteadyReplay looks for a repeat of P (and of each dP_i) by a fingerprint of its bits first;
  // == takes -0 for 0, and so must the fingerprint, or a period the comparison finds is missed.
  using Replay = internal::SteadyReplay<2>;
  using Mat = Replay::Mat;
  for (const int k : {0, 1}) {
    Replay replay(/*enabled=*/true, 2, 1, k);
    Mat P{{2.0, 0.0}, {0.0, 3.0}};
    std::vector<Mat> dP(k, Mat{{0.0, 1.0}, {1.0, 0.0}});
    replay.Begin(1, 0, &P, &dP);
    Mat P_end = P;
    P_end(0, 1) = -0.0;  // (one: the sign bits of two would cancel in the fingerprint's sum)
    std::vector<Mat> dP_end = dP;
    for (Mat& d : dP_end) d(0, 0) = -0.0;
    replay.End(P_end, dP_end);
    EXPECT_TRUE(replay.replaying()) << "k = " << k;
    // P one ulp off: no repeat.
    Replay other(/*enabled=*/true, 2, 1, k);
    other.Begin(1, 0, &P, &dP);
    P_end(1, 1) = std::nextafter(3.0, 4.0);
    other.End(P_end, dP_end);
    EXPECT_FALSE(other.replaying()) << "k = " << k;
  }
}

// The two-output model with parameters in A, B, the drift's constant, σ, C, d, D, R and x̂0, and
// the given input hold.
Json WithParametersInEveryMatrix(const char* hold) {
  Json j = Json::parse(fixtures::kTwoOutputModel);
  j["observation"] = {{"y1", "c1*x1 + 0.5*x2 + e*u2 + f"}, {"y2", "2*x2 - c1*x1"}};
  j["parameters"]["c1"] = 0.8;
  j["parameters"]["e"] = 0.3;
  j["parameters"]["f"] = 1.0;
  j["input_hold"] = hold;
  return j;
}

TEST(Score, TheWholeRecursionsAdjointIsTheForwardGradientOnIrregularTimesWithMissingValues) {
  // Irregular intervals (each its own discretisation), a fifth of the outputs missing (a
  // varying set of updates per index), parameters in every matrix and in x̂0, and the initial
  // covariance CTSM's or the stationary one's (P0 a function of θ): no steady state lasts, so
  // the adjoint of the whole recursion (linear_loops.h, AdjointOfTheSeries) covers every index.
  for (const char* p0 : {"ctsm", "stationary"}) {
    for (const char* hold : {"zoh", "foh"}) {
      SCOPED_TRACE(std::string(p0) + ", " + hold);
      Json j = WithParametersInEveryMatrix(hold);
      j["initial_covariance"] = p0;
      const auto m = JsonModel(j);
      const data::Series s = fixtures::RandomSeries(300, 2, 0.2, 29);
      const std::vector<double> theta = m->spec().Values();
      const std::vector<int> all = AllParameters(*m);
      const FilterSettings settings = FilterSettings::FromModel(m->spec());
      const auto ss = *m->Evaluate(theta);
      const auto dss = *m->EvaluateJacobian(theta, all);
      Eigen::VectorXd g, g_adjoint;
      Eigen::MatrixXd J;
      ASSERT_TRUE(LogLikelihoodScore(ss, dss, s, settings, &g, &J).ok());
      ExpectTheSteadyStatesAdjointIsTheForwardGradient(ss, dss, s, settings, J);
      FilterSettings adjoint = settings;
      adjoint.linear_gradient = LinearGradient::kAdjoint;
      const auto l = LogLikelihoodScore(ss, dss, s, adjoint, &g_adjoint);
      ASSERT_TRUE(l.ok());
      EXPECT_EQ(l->adjoint, static_cast<long>(s.size()));
    }
  }
}

TEST(Score, TheSteadyStatesAdjointGradientIsTheForwardOneToRoundingAndMatchesDifferences) {
  // Two outputs, an input in the observation, parameters in A, B, the drift's constant, σ, C, d,
  // D, R and x̂0, regularly sampled and never missing, so that the replay lasts to the end; with
  // zero- and first-order hold, Gaussian and Huber's loss.
  for (const char* hold : {"zoh", "foh"}) {
    for (const bool huber : {false, true}) {
      SCOPED_TRACE(std::string(hold) + (huber ? ", Huber" : ", Gaussian"));
      Json j = WithParametersInEveryMatrix(hold);
      if (huber) j["robust_huber"] = 1.5;
      const auto m = JsonModel(j);
      data::Series s = fixtures::RandomSeries(600, 2, 0.0, 23);
      for (std::size_t r = 0; r < s.time.size(); ++r) s.time[r] = 0.1 * static_cast<double>(r);
      s.intervals = data::GroupIntervals(s.time);
      const std::vector<double> theta = m->spec().Values();
      const std::vector<int> all = AllParameters(*m);
      const FilterSettings settings = FilterSettings::FromModel(m->spec());
      const auto ss = *m->Evaluate(theta);
      const auto dss = *m->EvaluateJacobian(theta, all);
      Eigen::VectorXd g;
      Eigen::MatrixXd J;
      ASSERT_TRUE(LogLikelihoodScore(ss, dss, s, settings, &g, &J).ok());
      EXPECT_GT(ExpectTheSteadyStatesAdjointIsTheForwardGradient(ss, dss, s, settings, J), 400);
      // And against central differences, with the gradient alone.
      const auto lik = *Likelihood::Create(m, {std::make_shared<const data::Series>(std::move(s))});
      Eigen::VectorXd gradient;
      ASSERT_TRUE(lik.EvaluateWithScore(theta, {}, all, &gradient).ok());
      for (std::size_t i = 0; i < all.size(); ++i) {
        double best = INFINITY;
        for (double rel : kRelativeSteps) {
          const double h = rel * std::max(std::abs(theta[i]), 1e-3);
          std::vector<double> up = theta, down = theta;
          up[i] += h;
          down[i] -= h;
          const double difference =
              (lik.Evaluate(up)->loglik - lik.Evaluate(down)->loglik) / (2 * h);
          best = std::min(best, std::abs(difference - gradient(i)));
        }
        EXPECT_LE(best, kAgreement * std::max(std::abs(gradient(i)), 1.0))
            << m->spec().parameters[i].name;
      }
    }
  }
}

TEST(Score, CrankshaftWithTwoOutputsFohAndStationaryP0MatchesCentralDifferences) {
  const auto m = AssetModel("crankshaft.json");
  const auto lik = *Likelihood::Create(m, {AssetSeries(m->spec(), "crankshaft.csv", 800)});
  CheckScore(lik, m->spec().Values());
}

TEST(Score, TenStateChainOfLagsMatchesCentralDifferences) {
  // x1' = (-x1 + k u1)/τ1, x_i' = (-x_i + x_{i-1})/τ_i: ten lags in series, y = x10 + 0.5 u2.
  Json j = {{"greybench_model", 1}, {"inputs", {"u1", "u2"}}, {"outputs", {"y"}}};
  Json states = Json::array(), params = Json::object(), drift = Json::object(),
       diffusion = Json::object();
  for (int i = 1; i <= 10; ++i) {
    const std::string x = "x" + std::to_string(i), tau = "tau" + std::to_string(i);
    states.push_back(x);
    params[tau] = 0.2 + 0.05 * i;
    drift[x] =
        i == 1 ? "(-x1 + k*u1)/tau1 + c" : "(-" + x + " + x" + std::to_string(i - 1) + ")/" + tau;
    diffusion[x] = "s";
  }
  params["k"] = 1.5;
  params["c"] = 0.1;
  params["s"] = 0.3;
  params["r"] = 0.05;
  j["states"] = states;
  j["parameters"] = params;
  j["drift"] = drift;
  j["diffusion"] = diffusion;
  j["observation"] = {{"y", "x10 + 0.5*u2"}};
  j["measurement_variance"] = {{"y", "r"}};
  const auto m = JsonModel(j);
  // Regular sampling (one distinct interval), with RandomSeries' inputs and outputs.
  data::Series s = fixtures::RandomSeries(200, 1, 0.0, 3);
  for (std::size_t r = 0; r < s.time.size(); ++r) s.time[r] = 0.1 * static_cast<double>(r);
  s.intervals = data::GroupIntervals(s.time);
  CheckScore(*Likelihood::Create(m, {std::make_shared<const data::Series>(std::move(s))}),
             m->spec().Values());
}

TEST(Score, MissingEntriesOfTwoOutputsMatchCentralDifferences) {
  const auto m = JsonModel(Json::parse(fixtures::kTwoOutputModel));
  const auto s = std::make_shared<const data::Series>(fixtures::RandomSeries(200, 2, 0.3, 5));
  CheckScore(*Likelihood::Create(m, {s}), m->spec().Values());
}

TEST(Score, TwoDatasetsWithDelaysAddUpAndMatchCentralDifferences) {
  Json j = Json::parse(fixtures::kTwoOutputModel);
  j["output_delay"] = {{"y1", 1}, {"y2", {{"min", 0}, {"max", 2}}}};
  const auto m = JsonModel(j);
  const auto s1 = std::make_shared<const data::Series>(fixtures::RandomSeries(150, 2, 0.1, 7));
  const auto s2 = std::make_shared<const data::Series>(fixtures::RandomSeries(90, 2, 0.1, 8));
  const auto joint = *Likelihood::Create(m, {s1, s2});
  const std::vector<int> delay = {1, 2};
  const std::vector<double> theta = m->spec().Values();
  CheckScore(joint, theta, delay);

  const std::vector<int> free = AllParameters(*m);
  Eigen::VectorXd g, g1, g2;
  Eigen::MatrixXd J;
  ASSERT_TRUE(joint.EvaluateWithScore(theta, delay, free, &g, &J).ok());
  ASSERT_TRUE(Likelihood::Create(m, {s1})->EvaluateWithScore(theta, delay, free, &g1).ok());
  ASSERT_TRUE(Likelihood::Create(m, {s2})->EvaluateWithScore(theta, delay, free, &g2).ok());
  EXPECT_LE((g - g1 - g2).cwiseAbs().maxCoeff(), 1e-10 * g.cwiseAbs().maxCoeff());
  EXPECT_EQ(J.rows(), static_cast<Eigen::Index>(s1->size() + s2->size()));
}

TEST(Score, HuberLikelihoodMatchesCentralDifferences) {
  Json j = Json::parse(fixtures::kTwoOutputModel);
  const auto gaussian = JsonModel(j);
  j["robust_huber"] = 1.0;
  const auto m = JsonModel(j);
  const auto s = std::make_shared<const data::Series>(fixtures::RandomSeries(200, 2, 0.1, 11));
  const auto lik = *Likelihood::Create(m, {s});
  // Some terms are past the threshold (ρ_c < ½r² there), so both branches are differentiated.
  EXPECT_GT(lik.Evaluate(m->spec().Values())->loglik,
            Likelihood::Create(gaussian, {s})->Evaluate(m->spec().Values())->loglik + 1.0);
  CheckScore(lik, m->spec().Values());
}

TEST(Score, ExplicitInitialVariancesAndFohMatchCentralDifferences) {
  Json j = Json::parse(fixtures::kTwoOutputModel);
  j["initial_covariance"] = {{"x1", "p1"}, {"x2", "p1*a"}};
  j["parameters"]["p1"] = 0.7;
  j["input_hold"] = "foh";
  const auto m = JsonModel(j);
  const auto s = std::make_shared<const data::Series>(fixtures::RandomSeries(120, 2, 0.1, 13));
  CheckScore(*Likelihood::Create(m, {s}), m->spec().Values());
}

TEST(Score, GradientOverChosenParametersIsTheMatchingPartOfTheFullGradient) {
  const auto m = JsonModel(Json::parse(fixtures::kTwoOutputModel));
  const auto s = std::make_shared<const data::Series>(fixtures::RandomSeries(80, 2, 0.0, 17));
  const auto lik = *Likelihood::Create(m, {s});
  const std::vector<double> theta = m->spec().Values();
  const std::vector<int> all = AllParameters(*m), some = {6, 1};
  Eigen::VectorXd g_all, g_some;
  ASSERT_TRUE(lik.EvaluateWithScore(theta, {}, all, &g_all).ok());
  ASSERT_TRUE(lik.EvaluateWithScore(theta, {}, some, &g_some).ok());
  EXPECT_EQ(g_some(0), g_all(6));
  EXPECT_EQ(g_some(1), g_all(1));
}

TEST(Score, AnInfiniteDerivativeOfAnEntryIsAnErrorNamingIt) {
  Json j = Json::parse(fixtures::kTwoOutputModel);
  j["diffusion"]["x1"] = "sqrt(s1)";
  j["parameters"]["s1"] = 0.0;
  const auto m = JsonModel(j);
  const auto s = std::make_shared<const data::Series>(fixtures::RandomSeries(20, 2, 0.0, 19));
  Eigen::VectorXd g;
  const auto l =
      Likelihood::Create(m, {s})->EvaluateWithScore(m->spec().Values(), {}, AllParameters(*m), &g);
  ASSERT_FALSE(l.ok());
  EXPECT_EQ(l.error().kind, ErrorKind::kNumerical);
  EXPECT_NE(l.error().message.find("derivative of diffusion.x1 with respect to s1 is infinite"),
            std::string::npos)
      << l.error().message;
}

}  // namespace
}  // namespace gb::filter
