// The filter's log-likelihood against the dense multivariate normal density of the whole stacked
// series (brute force), built from the model's transition law without any filtering.
#include "core/filter/kalman.h"

#include <cmath>
#include <limits>
#include <random>

#include <Eigen/Dense>
#include <gtest/gtest.h>

#include "core/filter/discretize.h"
#include "core/model/linear_model.h"
#include "core/util/json.h"
#include "tests/core/filter_fixtures.h"

namespace gb::filter {
namespace {

using fixtures::CompileModel;
using fixtures::kTwoOutputModel;
using fixtures::MakeSeries;
using fixtures::RandomSeries;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kLog2Pi = 1.8378770664093454835606594728112;

// The joint density of every observed y_{o,k}, with the observations ordered by the state index
// they see (j = k - d_o) and then by output, so that the Cholesky factor of the joint covariance
// yields exactly the filter's sequence of innovations.
struct Dense {
  double gaussian_loglik;
  double huber_loglik;  // with threshold `huber`, grouped by state index
  long n_obs;
};

Dense BruteForce(const model::StateSpace& ss, const data::Series& s, const FilterSettings& st,
                 double huber) {
  const int n = ss.n_states(), p = ss.n_outputs();
  const int N = static_cast<int>(s.size());
  const Eigen::VectorXd sigma2 = ss.sigma.array().square();
  // State means and the full state covariance.
  std::vector<Eigen::VectorXd> mean(N);
  Eigen::MatrixXd Sx = Eigen::MatrixXd::Zero(n * N, n * N);
  Eigen::MatrixXd P0;
  if (st.initial_covariance == model::InitialCovariance::kCtsm) {
    P0 = IntegratedDiffusion(ss.A, sigma2, s.time[1] - s.time[0]);
  } else if (st.initial_covariance == model::InitialCovariance::kExplicit) {
    P0 = ss.P0_diag.asDiagonal();
  } else {
    std::complex<double> bad;
    EXPECT_TRUE(StationaryCovariance(ss.A, sigma2, &P0, &bad));
  }
  mean[0] = ss.x0;
  Sx.block(0, 0, n, n) = P0;
  for (int j = 0; j + 1 < N; ++j) {
    const Discrete d = Discretize(ss.A, ss.B, ss.c, sigma2, s.time[j + 1] - s.time[j], st.hold);
    mean[j + 1] = d.Phi * mean[j] + d.Gamma0 * s.U.col(j) + d.Gamma1 * s.U.col(j + 1) + d.g;
    // Cov(x_{j+1}, x_i) = Φ Cov(x_j, x_i) for i <= j; Var(x_{j+1}) = Φ Var(x_j) Φ' + Q.
    for (int i = 0; i <= j; ++i) {
      Sx.block((j + 1) * n, i * n, n, n) = d.Phi * Sx.block(j * n, i * n, n, n);
      Sx.block(i * n, (j + 1) * n, n, n) = Sx.block((j + 1) * n, i * n, n, n).transpose();
    }
    Sx.block((j + 1) * n, (j + 1) * n, n, n) =
        d.Phi * Sx.block(j * n, j * n, n, n) * d.Phi.transpose() + d.Q;
  }
  // Observations in filter order.
  struct Obs {
    int o, k, j;
  };
  std::vector<Obs> obs;
  for (int j = 0; j < N; ++j) {
    for (int o = 0; o < p; ++o) {
      const int k = j + st.delay[o];
      if (k >= N || k < st.first_obs[o] || std::isnan(s.Y(o, k))) continue;
      obs.push_back({o, k, j});
    }
  }
  const int M = static_cast<int>(obs.size());
  Eigen::VectorXd r(M);
  Eigen::MatrixXd Sy(M, M);
  for (int a = 0; a < M; ++a) {
    const Obs& A = obs[a];
    const double mu = ss.C.row(A.o).dot(mean[A.j]) + ss.D.row(A.o).dot(s.U.col(A.j)) + ss.d(A.o);
    r(a) = s.Y(A.o, A.k) - mu;
    for (int b = 0; b < M; ++b) {
      const Obs& B = obs[b];
      Sy(a, b) =
          (ss.C.row(A.o) * Sx.block(A.j * n, B.j * n, n, n) * ss.C.row(B.o).transpose()).value() +
          (a == b ? ss.S(A.o) : 0.0);
    }
  }
  const Eigen::LLT<Eigen::MatrixXd> llt(Sy);
  EXPECT_EQ(llt.info(), Eigen::Success);
  const Eigen::MatrixXd L = llt.matrixL();
  const Eigen::VectorXd z = L.triangularView<Eigen::Lower>().solve(r);
  Dense out;
  out.n_obs = M;
  out.gaussian_loglik =
      -0.5 * (2 * L.diagonal().array().log().sum() + z.squaredNorm() + M * kLog2Pi);
  // Huber: group the standardised innovations by state index.
  out.huber_loglik = 0;
  for (int a = 0; a < M;) {
    double r2 = 0, logdet = 0;
    int count = 0;
    const int j = obs[a].j;
    for (; a < M && obs[a].j == j; ++a, ++count) {
      r2 += z(a) * z(a);
      logdet += 2 * std::log(L(a, a));
    }
    const double rr = std::sqrt(r2);
    const double rho = rr <= huber ? 0.5 * r2 : huber * rr - 0.5 * huber * huber;
    out.huber_loglik -= 0.5 * (logdet + count * kLog2Pi) + rho;
  }
  return out;
}

struct Case {
  model::InputHold hold;
  model::InitialCovariance p0;
  std::vector<int> delay;
  std::vector<int> first_obs;
};

TEST(LogLikelihood, EqualsDenseMultivariateNormalDensityOfTheStackedSeries) {
  const model::LinearModel lm = CompileModel(kTwoOutputModel);
  const auto ss = lm.Evaluate(lm.spec().Values());
  ASSERT_TRUE(ss.ok());
  const data::Series series = RandomSeries(30, 2, 0.2, 7);
  const std::vector<Case> cases = {
      {model::InputHold::kZoh, model::InitialCovariance::kCtsm, {0, 0}, {0, 0}},
      {model::InputHold::kFoh, model::InitialCovariance::kCtsm, {0, 0}, {0, 0}},
      {model::InputHold::kFoh, model::InitialCovariance::kStationary, {0, 0}, {0, 0}},
      {model::InputHold::kZoh, model::InitialCovariance::kCtsm, {2, 0}, {2, 0}},
      {model::InputHold::kFoh, model::InitialCovariance::kCtsm, {1, 3}, {4, 3}},
  };
  for (const Case& c : cases) {
    FilterSettings st;
    st.hold = c.hold;
    st.initial_covariance = c.p0;
    st.delay = c.delay;
    st.first_obs = c.first_obs;
    const auto filter = LogLikelihood(*ss, series, st);
    ASSERT_TRUE(filter.ok()) << filter.error().ToString();
    const Dense dense = BruteForce(*ss, series, st, 1e300);
    EXPECT_EQ(filter->n_obs, dense.n_obs);
    EXPECT_NEAR(filter->loglik, dense.gaussian_loglik, 1e-9 * std::abs(dense.gaussian_loglik))
        << "delay " << c.delay[0] << "," << c.delay[1];
  }
}

TEST(LogLikelihood, HuberEqualsTheCholeskyInnovationsOfTheJointDensity) {
  const model::LinearModel lm = CompileModel(kTwoOutputModel);
  const auto ss = lm.Evaluate(lm.spec().Values());
  ASSERT_TRUE(ss.ok());
  const data::Series series = RandomSeries(30, 2, 0.15, 11);
  for (double c : {0.5, 1.5, 3.0}) {
    FilterSettings st;
    st.hold = model::InputHold::kFoh;
    st.huber = c;
    st.delay = {0, 1};
    st.first_obs = {0, 1};
    const auto filter = LogLikelihood(*ss, series, st);
    ASSERT_TRUE(filter.ok());
    const Dense dense = BruteForce(*ss, series, st, c);
    EXPECT_NEAR(filter->loglik, dense.huber_loglik, 1e-9 * std::abs(dense.huber_loglik));
    EXPECT_GT(filter->loglik, dense.gaussian_loglik) << "Huber down-weights large residuals";
  }
}

TEST(LogLikelihood, AddsNothingForMissingEntriesAndCountsObservedOnes) {
  const model::LinearModel lm = CompileModel(kTwoOutputModel);
  const auto ss = lm.Evaluate(lm.spec().Values());
  data::Series series = RandomSeries(20, 2, 0.0, 3);
  series.Y.row(1).setConstant(kNaN);  // y2 never observed
  FilterSettings st;
  const auto filter = LogLikelihood(*ss, series, st);
  ASSERT_TRUE(filter.ok());
  EXPECT_EQ(filter->n_obs, 20);
  FilterSettings explicit_delays;
  explicit_delays.delay = {0, 0};
  explicit_delays.first_obs = {0, 0};
  const Dense dense = BruteForce(*ss, series, explicit_delays, 1e300);
  EXPECT_NEAR(filter->loglik, dense.gaussian_loglik, 1e-9 * std::abs(dense.gaussian_loglik));
}

TEST(LogLikelihood, ExplicitInitialVariancesAreUsed) {
  const model::LinearModel lm = CompileModel(R"json({
    "greybench_model": 1, "states": ["x"], "inputs": [], "outputs": ["y"],
    "parameters": {"a": 0.7, "s": 0.4, "r": 0.1, "v0": 2.5},
    "drift": {"x": "-a*x"}, "diffusion": {"x": "s"}, "observation": {"y": "x"},
    "measurement_variance": {"y": "r"}, "initial_covariance": {"x": "v0"},
    "initial_state": {"x": "1"}})json");
  const auto ss = lm.Evaluate(lm.spec().Values());
  ASSERT_TRUE(ss.ok());
  // One observation only: y_0 ~ N(x0, v0 + r) exactly.
  std::vector<double> t = {0.0, 1.0};
  Eigen::MatrixXd U(0, 2), Y(1, 2);
  Y << 0.2, kNaN;
  const data::Series series = MakeSeries(t, U, Y);
  FilterSettings st;
  st.initial_covariance = model::InitialCovariance::kExplicit;
  const auto l = LogLikelihood(*ss, series, st);
  ASSERT_TRUE(l.ok());
  const double var = 2.5 + 0.1;
  EXPECT_NEAR(l->loglik, -0.5 * (std::log(2 * M_PI * var) + 0.8 * 0.8 / var), 1e-14);
}

TEST(LogLikelihood, RefusesADelayThatLeavesNoObservation) {
  const model::LinearModel lm = CompileModel(kTwoOutputModel);
  const auto ss = lm.Evaluate(lm.spec().Values());
  const data::Series series = RandomSeries(5, 2, 0.0, 1);
  FilterSettings st;
  st.delay = {5, 7};
  const auto l = LogLikelihood(*ss, series, st);
  ASSERT_FALSE(l.ok());
  EXPECT_NE(l.error().message.find("longer than the data"), std::string::npos);
}

TEST(LogLikelihood, ReportsANonPositiveInnovationVariance) {
  // No process noise, no measurement noise, x0 known: the first innovation variance is zero.
  const model::LinearModel lm = CompileModel(R"json({
    "greybench_model": 1, "states": ["x"], "outputs": ["y"], "parameters": {"a": 1},
    "drift": {"x": "-a*x"}, "observation": {"y": "x"}, "measurement_variance": {"y": "0"}})json");
  const auto ss = lm.Evaluate(lm.spec().Values());
  std::vector<double> t = {0.0, 1.0, 2.0};
  Eigen::MatrixXd U(0, 3), Y(1, 3);
  Y << 0.0, 0.1, 0.2;
  const auto l = LogLikelihood(*ss, MakeSeries(t, U, Y), FilterSettings{});
  ASSERT_FALSE(l.ok());
  EXPECT_EQ(l.error().kind, ErrorKind::kNumerical);
  EXPECT_NE(l.error().message.find("row 1"), std::string::npos) << l.error().message;
}

}  // namespace
}  // namespace gb::filter
