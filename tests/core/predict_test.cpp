// Predictions, the smoother and the simulations against independent sources: the conditional
// moments of the dense joint Gaussian of all states and observations (brute force, no filter),
// the closed form of the Ornstein-Uhlenbeck process, and the closed-form response of a
// first-order system to a square wave (the paper's Fig. 2 experiment).
// Sections: brute force (the joint Gaussian), smoother, predictions, simulation.
#include "core/filter/predict.h"

#include <cmath>
#include <limits>
#include <random>

#include <Eigen/Dense>
#include <gtest/gtest.h>

#include "core/design/prbs.h"
#include "core/filter/discretize.h"
#include "core/model/linear_model.h"
#include "core/sim/response.h"
#include "core/util/json.h"
#include "tests/core/filter_fixtures.h"

namespace gb::filter {
namespace {

using fixtures::CompileModel;
using fixtures::kTwoOutputModel;
using fixtures::MakeSeries;
using fixtures::RandomSeries;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kTight = 1e-9;  // relative agreement of two exact computations

// ---- brute force: the joint Gaussian of (x_0 .. x_{N-1}, used observations) -----------------

struct Joint {
  int n = 0;
  Eigen::VectorXd mx;  // stacked state means, nN
  Eigen::MatrixXd Sx;  // their covariance
  struct Obs {
    int o, k, j;  // output, row, state index it sees
  };
  std::vector<Obs> obs;  // every observation the filter uses
  Eigen::MatrixXd H;     // obs x nN: y = H x + offset + e
  Eigen::VectorXd offset, y, S;
};

Joint BuildJoint(const model::StateSpace& ss, const data::Series& s, const FilterSettings& st) {
  const int n = ss.n_states(), p = ss.n_outputs();
  const int N = static_cast<int>(s.size());
  const Eigen::VectorXd sigma2 = ss.sigma.array().square();
  Joint J;
  J.n = n;
  J.mx.resize(n * N);
  J.Sx = Eigen::MatrixXd::Zero(n * N, n * N);
  J.mx.head(n) = ss.x0;
  J.Sx.block(0, 0, n, n) = IntegratedDiffusion(ss.A, sigma2, s.time[1] - s.time[0]);  // "ctsm"
  for (int j = 0; j + 1 < N; ++j) {
    const Discrete d = Discretize(ss.A, ss.B, ss.c, sigma2, s.time[j + 1] - s.time[j], st.hold);
    J.mx.segment((j + 1) * n, n) =
        d.Phi * J.mx.segment(j * n, n) + d.Gamma0 * s.U.col(j) + d.Gamma1 * s.U.col(j + 1) + d.g;
    for (int i = 0; i <= j; ++i) {
      J.Sx.block((j + 1) * n, i * n, n, n) = d.Phi * J.Sx.block(j * n, i * n, n, n);
      J.Sx.block(i * n, (j + 1) * n, n, n) = J.Sx.block((j + 1) * n, i * n, n, n).transpose();
    }
    J.Sx.block((j + 1) * n, (j + 1) * n, n, n) =
        d.Phi * J.Sx.block(j * n, j * n, n, n) * d.Phi.transpose() + d.Q;
  }
  for (int k = 0; k < N; ++k) {
    for (int o = 0; o < p; ++o) {
      const int j = k - st.delay[o];
      if (j < 0 || k < st.first_obs[o] || std::isnan(s.Y(o, k))) continue;
      J.obs.push_back({o, k, j});
    }
  }
  const int M = static_cast<int>(J.obs.size());
  J.H = Eigen::MatrixXd::Zero(M, n * N);
  J.offset.resize(M);
  J.y.resize(M);
  J.S.resize(M);
  for (int a = 0; a < M; ++a) {
    const auto& ob = J.obs[a];
    J.H.block(a, ob.j * n, 1, n) = ss.C.row(ob.o);
    J.offset(a) = ss.D.row(ob.o).dot(s.U.col(ob.j)) + ss.d(ob.o);
    J.y(a) = s.Y(ob.o, ob.k);
    J.S(a) = ss.S(ob.o);
  }
  return J;
}

struct Conditional {
  Eigen::VectorXd mean;  // of the stacked states
  Eigen::MatrixXd cov;
};

// E[x | y_a, a ∈ subset] = μ_x + Σ_xy Σ_yy⁻¹ (y - μ_y), Cov = Σ_xx - Σ_xy Σ_yy⁻¹ Σ_yx.
Conditional Condition(const Joint& J, const std::vector<int>& subset) {
  const int M = static_cast<int>(subset.size());
  if (M == 0) return {J.mx, J.Sx};
  Eigen::MatrixXd H(M, J.H.cols());
  Eigen::VectorXd r(M), S(M);
  for (int a = 0; a < M; ++a) {
    H.row(a) = J.H.row(subset[a]);
    r(a) = J.y(subset[a]) - J.offset(subset[a]) - J.H.row(subset[a]).dot(J.mx);
    S(a) = J.S(subset[a]);
  }
  const Eigen::MatrixXd Sxy = J.Sx * H.transpose();
  Eigen::MatrixXd Syy = H * Sxy;
  Syy.diagonal() += S;
  const Eigen::LLT<Eigen::MatrixXd> llt(Syy);
  EXPECT_EQ(llt.info(), Eigen::Success);
  return {J.mx + Sxy * llt.solve(r), J.Sx - Sxy * llt.solve(Sxy.transpose())};
}

FilterSettings Settings(model::InputHold hold, std::vector<int> delay, std::vector<int> first) {
  FilterSettings st;
  st.hold = hold;
  st.delay = std::move(delay);
  st.first_obs = std::move(first);
  return st;
}

// ---- smoother --------------------------------------------------------------------------------

TEST(Smooth, EqualsTheConditionalMeanAndCovarianceOfTheStackedGaussian) {
  const model::LinearModel lm = CompileModel(kTwoOutputModel);
  const auto ss = lm.Evaluate(lm.spec().Values());
  ASSERT_TRUE(ss.ok());
  const data::Series series = RandomSeries(14, 2, 0.2, 5);
  for (const FilterSettings& st : {Settings(model::InputHold::kZoh, {0, 0}, {0, 0}),
                                   Settings(model::InputHold::kFoh, {1, 3}, {3, 3})}) {
    const auto smoothed = Smooth(*ss, series, st);
    ASSERT_TRUE(smoothed.ok()) << smoothed.error().ToString();
    const Joint J = BuildJoint(*ss, series, st);
    std::vector<int> all(J.obs.size());
    for (std::size_t a = 0; a < all.size(); ++a) all[a] = static_cast<int>(a);
    const Conditional c = Condition(J, all);
    const int n = ss->n_states();
    for (int j = 0; j < static_cast<int>(series.size()); ++j) {
      for (int i = 0; i < n; ++i) {
        EXPECT_NEAR(smoothed->x(i, j), c.mean(j * n + i),
                    kTight * (1 + std::abs(c.mean(j * n + i))))
            << "state " << i << " at " << j;
        for (int l = 0; l < n; ++l)
          EXPECT_NEAR(smoothed->P[j](i, l), c.cov(j * n + i, j * n + l), kTight) << "at " << j;
      }
    }
    // The smoothed output is the noise-free output map at the smoothed state.
    for (int o = 0; o < 2; ++o) {
      for (int k = st.delay[o]; k < static_cast<int>(series.size()); ++k) {
        const int j = k - st.delay[o];
        const Eigen::RowVectorXd Co = ss->C.row(o);
        const double mean =
            Co.dot(c.mean.segment(j * n, n)) + ss->D.row(o).dot(series.U.col(j)) + ss->d(o);
        const double var = (Co * c.cov.block(j * n, j * n, n, n) * Co.transpose()).value();
        EXPECT_NEAR(smoothed->y(o, k), mean, kTight * (1 + std::abs(mean)));
        EXPECT_NEAR(smoothed->y_sd(o, k), std::sqrt(var), kTight);
      }
      for (int k = 0; k < st.delay[o]; ++k) EXPECT_TRUE(std::isnan(smoothed->y(o, k)));
    }
  }
}

TEST(Smooth, HandlesAStateWithoutNoise) {
  // x2 has no diffusion and is only driven by x1: its predicted variance stays positive, but a
  // deterministic integrator of a known input (x3) has P = 0 forever.
  const model::LinearModel lm = CompileModel(R"json({
    "greybench_model": 1, "states": ["x1", "x2", "x3"], "inputs": ["u"], "outputs": ["y"],
    "parameters": {},
    "drift": {"x1": "-x1 + u", "x2": "x1 - 2*x2", "x3": "u - x3"},
    "diffusion": {"x1": "0.5"}, "observation": {"y": "x2 + x3"},
    "measurement_variance": {"y": "0.01"}, "initial_covariance": {"x1": "1", "x2": "1", "x3": "0"}
  })json");
  const auto ss = lm.Evaluate({});
  ASSERT_TRUE(ss.ok());
  data::Series series = RandomSeries(12, 1, 0.0, 9);
  series.U = series.U.topRows(1).eval();
  FilterSettings st = Settings(model::InputHold::kZoh, {0}, {0});
  st.initial_covariance = model::InitialCovariance::kExplicit;
  const auto smoothed = Smooth(*ss, series, st);
  ASSERT_TRUE(smoothed.ok());
  for (int j = 0; j < 12; ++j) {
    EXPECT_TRUE(smoothed->x.col(j).allFinite()) << "at " << j;
    EXPECT_NEAR(smoothed->P[j](2, 2), 0.0, 1e-12);
  }
}

// ---- predictions -----------------------------------------------------------------------------

TEST(PredictOneStep, ResidualsAreObservationMinusPredictionAndStandardisedWhereUsed) {
  const model::LinearModel lm = CompileModel(kTwoOutputModel);
  const auto ss = lm.Evaluate(lm.spec().Values());
  const data::Series series = RandomSeries(25, 2, 0.2, 3);
  const FilterSettings st = Settings(model::InputHold::kZoh, {2, 0}, {3, 3});
  const auto pred = PredictOneStep(*ss, series, st);
  ASSERT_TRUE(pred.ok());
  const Joint J = BuildJoint(*ss, series, st);
  const int n = ss->n_states();
  for (int o = 0; o < 2; ++o) {
    for (int k = 0; k < 25; ++k) {
      if (k < st.delay[o]) {
        EXPECT_TRUE(std::isnan(pred->y_pred(o, k)));
        continue;
      }
      // ŷ_{o,k} is conditioned on the observations at state indices below j = k - d_o.
      const int j = k - st.delay[o];
      std::vector<int> before;
      for (std::size_t a = 0; a < J.obs.size(); ++a)
        if (J.obs[a].j < j) before.push_back(static_cast<int>(a));
      const Conditional c = Condition(J, before);
      const Eigen::RowVectorXd Co = ss->C.row(o);
      const double mean =
          Co.dot(c.mean.segment(j * n, n)) + ss->D.row(o).dot(series.U.col(j)) + ss->d(o);
      const double var = (Co * c.cov.block(j * n, j * n, n, n) * Co.transpose()).value() + ss->S(o);
      EXPECT_NEAR(pred->y_pred(o, k), mean, kTight * (1 + std::abs(mean))) << o << "," << k;
      EXPECT_NEAR(pred->y_sd(o, k), std::sqrt(var), kTight);
      const double y = series.Y(o, k);
      if (std::isnan(y)) {
        EXPECT_TRUE(std::isnan(pred->residual(o, k)));
      } else {
        EXPECT_DOUBLE_EQ(pred->residual(o, k), y - pred->y_pred(o, k));
      }
      if (k < st.first_obs[o] || std::isnan(y)) {
        EXPECT_TRUE(std::isnan(pred->standardized(o, k)));
      } else {
        EXPECT_NEAR(pred->standardized(o, k), (y - mean) / std::sqrt(var), 1e-8);
      }
    }
  }
}

TEST(PredictAhead, EqualsTheConditionalMomentsGivenObservationsUpToHStepsBefore) {
  const model::LinearModel lm = CompileModel(kTwoOutputModel);
  const auto ss = lm.Evaluate(lm.spec().Values());
  const data::Series series = RandomSeries(16, 2, 0.15, 21);
  const FilterSettings st = Settings(model::InputHold::kFoh, {0, 2}, {2, 2});
  const Joint J = BuildJoint(*ss, series, st);
  const int n = ss->n_states();
  for (int h : {0, 1, 3, 7}) {
    const auto pred = PredictAhead(*ss, series, st, h);
    ASSERT_TRUE(pred.ok());
    EXPECT_EQ(pred->horizon, h);
    for (int o = 0; o < 2; ++o) {
      for (int k = st.delay[o]; k < 16; ++k) {
        const int j = k - st.delay[o];
        std::vector<int> known;
        for (std::size_t a = 0; a < J.obs.size(); ++a)
          if (J.obs[a].j <= j - h) known.push_back(static_cast<int>(a));
        const Conditional c = Condition(J, known);
        const Eigen::RowVectorXd Co = ss->C.row(o);
        const double mean =
            Co.dot(c.mean.segment(j * n, n)) + ss->D.row(o).dot(series.U.col(j)) + ss->d(o);
        const double var =
            (Co * c.cov.block(j * n, j * n, n, n) * Co.transpose()).value() + ss->S(o);
        EXPECT_NEAR(pred->y_pred(o, k), mean, kTight * (1 + std::abs(mean)))
            << "h " << h << " o " << o << " k " << k;
        EXPECT_NEAR(pred->y_sd(o, k), std::sqrt(var), kTight) << "h " << h;
      }
    }
  }
}

TEST(PredictAhead, OneStepIsTheFiltersPrediction) {
  const model::LinearModel lm = CompileModel(kTwoOutputModel);
  const auto ss = lm.Evaluate(lm.spec().Values());
  const data::Series series = RandomSeries(40, 2, 0.1, 8);
  const FilterSettings st = Settings(model::InputHold::kZoh, {1, 0}, {1, 1});
  const auto one = PredictOneStep(*ss, series, st);
  const auto ahead = PredictAhead(*ss, series, st, 1);
  ASSERT_TRUE(one.ok() && ahead.ok());
  for (int o = 0; o < 2; ++o) {
    for (int k = st.delay[o]; k < 40; ++k) {
      EXPECT_NEAR(ahead->y_pred(o, k), one->y_pred(o, k),
                  1e-12 * (1 + std::abs(one->y_pred(o, k))));
      EXPECT_NEAR(ahead->y_sd(o, k), one->y_sd(o, k), 1e-12);
    }
  }
}

TEST(PredictAhead, VarianceMatchesTheClosedFormForScalarOrnsteinUhlenbeck) {
  constexpr double a = 0.8, sigma = 0.5, S = 0.04, dt = 0.1;
  const model::LinearModel lm = CompileModel(R"json({
    "greybench_model": 1, "states": ["x"], "inputs": [], "outputs": ["y"],
    "parameters": {"a": 0.8, "sigma": 0.5, "S": 0.04},
    "drift": {"x": "-a*x"}, "diffusion": {"x": "sigma"}, "observation": {"y": "x"},
    "measurement_variance": {"y": "S"}, "initial_state": {"x": "1.5"}})json");
  const auto ss = lm.Evaluate(lm.spec().Values());
  const int N = 60;
  std::vector<double> t(N);
  Eigen::MatrixXd Y(1, N);
  std::mt19937 rng(4);
  std::normal_distribution<double> normal;
  for (int k = 0; k < N; ++k) {
    t[k] = k * dt;
    Y(0, k) = k % 7 == 3 ? kNaN : normal(rng);
  }
  const data::Series series = MakeSeries(t, Eigen::MatrixXd(0, N), Y);
  for (int delay : {0, 2}) {
    const FilterSettings st = Settings(model::InputHold::kZoh, {delay}, {delay});
    FilterTrace trace;
    ASSERT_TRUE(RunFilter(*ss, series, st, &trace).ok());
    for (int h : {1, 2, 5, 20}) {
      const auto pred = PredictAheadFromTrace(*ss, series, st, trace, h);
      ASSERT_TRUE(pred.ok());
      for (int j = h; j < N; ++j) {
        const int k = j + delay;  // the row whose output sees x_j
        if (k >= N) continue;
        const double decay = std::exp(-a * h * dt);
        const double P = trace.P_filt[j - h](0, 0);
        const double var = decay * decay * P + sigma * sigma * (1 - decay * decay) / (2 * a) + S;
        EXPECT_NEAR(pred->y_sd(0, k) * pred->y_sd(0, k), var, 1e-12) << "h " << h << " j " << j;
        EXPECT_NEAR(pred->y_pred(0, k), decay * trace.x_filt(0, j - h), 1e-12);
      }
    }
  }
}

// ---- simulation ------------------------------------------------------------------------------

// The paper's Fig. 2: the fuel-film model with an instantaneous vapour path (one film state and
// a direct term) under a ±10 % square wave in the injected fuel.
TEST(DeterministicResponse, FuelFilmSquareWaveEqualsThePiecewiseExponential) {
  constexpr double tau_ff = 0.25, X = 0.22, Kb = 0.8421;
  constexpr double low = 0.9, high = 1.1, period = 2.0, ts = 0.0125, duration = 6.0;
  const model::LinearModel lm = CompileModel(R"json({
    "greybench_model": 1, "states": ["mff"], "inputs": ["mfi"], "outputs": ["ilambda"],
    "parameters": {"tau_ff": 0.25, "X": 0.22, "Kb": 0.8421, "s12": 3.91e-4, "s2": 1e-4},
    "drift": {"mff": "(-mff + X*mfi)/tau_ff"}, "diffusion": {"mff": "sqrt(s12)"},
    "observation": {"ilambda": "Kb*((1 - X)*mfi + mff)"},
    "measurement_variance": {"ilambda": "s2"}, "initial_state": {"mff": "X*0.9"}})json");
  const auto ss = lm.Evaluate(lm.spec().Values());
  ASSERT_TRUE(ss.ok());
  const auto wave = design::MakeSquareWave(period, ts, duration, low, high);
  ASSERT_TRUE(wave.ok());
  const int N = static_cast<int>(wave->t.size());
  Eigen::MatrixXd U(1, N);
  for (int k = 0; k < N; ++k) U(0, k) = wave->u[k];
  const data::Series series = MakeSeries(wave->t, U, Eigen::MatrixXd::Constant(1, N, kNaN));
  const auto sim = sim::DeterministicResponse(*ss, series, FilterSettings::FromModel(lm.spec()));
  ASSERT_TRUE(sim.ok());

  // Closed form: on each half period [t_s, t_s + period/2) the input is a constant u_s and
  // mff(t) = X u_s + (mff(t_s) - X u_s) e^{-(t - t_s)/τ_ff}, starting from the steady state X·low.
  double max_error = 0.0;
  double t_s = 0.0, mff_s = X * low;
  int segment = 0;
  for (int k = 0; k < N; ++k) {
    const double t = wave->t[k];
    while (t >= t_s + period / 2 - 1e-9) {  // the state at the next switch
      const double u_s = segment % 2 == 0 ? low : high;
      mff_s = X * u_s + (mff_s - X * u_s) * std::exp(-(period / 2) / tau_ff);
      t_s += period / 2;
      ++segment;
    }
    const double u_s = segment % 2 == 0 ? low : high;
    const double mff = X * u_s + (mff_s - X * u_s) * std::exp(-(t - t_s) / tau_ff);
    const double y = Kb * ((1 - X) * u_s + mff);
    max_error = std::max(max_error, std::abs(sim->Y(0, k) - y));
    max_error = std::max(max_error, std::abs(sim->X(0, k) - mff));
  }
  EXPECT_LT(max_error, 1e-12);
  EXPECT_GE(segment, 5) << "the experiment covers several switches";
}

TEST(DeterministicResponse, AnOutputDelayShiftsTheOutputBySamples) {
  const model::LinearModel lm = CompileModel(kTwoOutputModel);
  const auto ss = lm.Evaluate(lm.spec().Values());
  const data::Series series = RandomSeries(20, 2, 0.0, 2);
  const auto plain =
      sim::DeterministicResponse(*ss, series, Settings(model::InputHold::kZoh, {0, 0}, {}));
  const auto delayed =
      sim::DeterministicResponse(*ss, series, Settings(model::InputHold::kZoh, {3, 1}, {}));
  ASSERT_TRUE(plain.ok() && delayed.ok());
  for (int k = 0; k < 20; ++k) {
    if (k < 3)
      EXPECT_TRUE(std::isnan(delayed->Y(0, k)));
    else
      EXPECT_DOUBLE_EQ(delayed->Y(0, k), plain->Y(0, k - 3));
    if (k < 1)
      EXPECT_TRUE(std::isnan(delayed->Y(1, k)));
    else
      EXPECT_DOUBLE_EQ(delayed->Y(1, k), plain->Y(1, k - 1));
  }
}

TEST(SamplePath, MomentsAcrossSeedsMatchTheOrnsteinUhlenbeckTransitionLaw) {
  // x_0 ~ N(x0, P0) with P0 = Q(Δ) ("ctsm"), so Var(x_j) = e^{-2ajΔ} Q(Δ) + Q(jΔ), closed form.
  constexpr double a = 1.2, sigma = 0.7, x0 = 2.0, dt = 0.05;
  const model::LinearModel lm = CompileModel(R"json({
    "greybench_model": 1, "states": ["x"], "inputs": [], "outputs": ["y"],
    "parameters": {"a": 1.2, "sigma": 0.7},
    "drift": {"x": "-a*x"}, "diffusion": {"x": "sigma"}, "observation": {"y": "x"},
    "measurement_variance": {"y": "0.01"}, "initial_state": {"x": "2"}})json");
  const auto ss = lm.Evaluate(lm.spec().Values());
  constexpr int N = 30, kPaths = 4000;
  std::vector<double> t(N);
  for (int k = 0; k < N; ++k) t[k] = k * dt;
  const data::Series series = MakeSeries(t, Eigen::MatrixXd(0, N), Eigen::MatrixXd::Zero(1, N));
  const FilterSettings st = FilterSettings::FromModel(lm.spec());
  double sum = 0, sum2 = 0;
  for (int s = 0; s < kPaths; ++s) {
    const auto path = sim::SamplePath(*ss, series, st, 1000 + s);
    ASSERT_TRUE(path.ok());
    const double x = path->X(0, N - 1);
    sum += x;
    sum2 += x * x;
  }
  const auto Q = [&](double T) { return sigma * sigma * (1 - std::exp(-2 * a * T)) / (2 * a); };
  const double T = (N - 1) * dt;
  const double mean = x0 * std::exp(-a * T);
  const double var = std::exp(-2 * a * T) * Q(dt) + Q(T);
  const double m = sum / kPaths, v = sum2 / kPaths - m * m;
  EXPECT_NEAR(m, mean, 4 * std::sqrt(var / kPaths));
  EXPECT_NEAR(v, var, 4 * var * std::sqrt(2.0 / kPaths));
  // The same seed gives the same path.
  const auto p1 = sim::SamplePath(*ss, series, st, 7), p2 = sim::SamplePath(*ss, series, st, 7);
  EXPECT_EQ(p1->Y, p2->Y);
}

}  // namespace
}  // namespace gb::filter
