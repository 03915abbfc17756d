// The expected information of a design (core/design/information.h) against the whole record's
// multivariate normal density, differentiated by central differences (brute force).
#include "core/design/information.h"

#include <cmath>
#include <numeric>
#include <vector>

#include <Eigen/Cholesky>
#include <gtest/gtest.h>

#include "core/filter/discretize.h"
#include "filter_fixtures.h"

namespace gb::design {
namespace {

using filter::fixtures::CompileModel;
using filter::fixtures::kTwoOutputModel;
using filter::fixtures::RandomSeries;

// The observations the filter uses, stacked: their mean μ and covariance Σ at θ, by brute force
// (the states' means and cross-covariances over the whole record).
struct Stacked {
  Eigen::VectorXd mu;
  Eigen::MatrixXd Sigma;
};

Stacked StackedObservations(const model::LinearModel& lm, const std::vector<double>& theta,
                            const data::Series& series, const filter::FilterSettings& settings) {
  const model::StateSpace ss = *lm.Evaluate(theta);
  const int n = ss.n_states();
  const int N = static_cast<int>(series.size());
  std::vector<Eigen::VectorXd> m(N);
  std::vector<Eigen::MatrixXd> Phi(N), P(N);
  const Eigen::VectorXd sigma2 = ss.sigma.array().square();
  m[0] = ss.x0;
  P[0] = *filter::InitialCovariance(ss, series, settings);
  for (int j = 0; j + 1 < N; ++j) {
    const auto d = filter::Discretize(ss.A, ss.B, ss.c, sigma2, series.time[j + 1] - series.time[j],
                                      settings.hold);
    Phi[j] = d.Phi;
    m[j + 1] = d.Phi * m[j] + d.Gamma0 * series.U.col(j) + d.Gamma1 * series.U.col(j + 1) + d.g;
    P[j + 1] = d.Phi * P[j] * d.Phi.transpose() + d.Q;
  }
  auto cross = [&](int j, int l) {  // Cov(x_j, x_l), j >= l
    Eigen::MatrixXd c = P[l];
    for (int i = l; i < j; ++i) c = (Phi[i] * c).eval();
    return c;
  };
  struct Obs {
    int o, j;
  };
  std::vector<Obs> obs;
  for (int j = 0; j < N; ++j)
    for (int o = 0; o < ss.n_outputs(); ++o) {
      const int row = j + settings.delay[o];
      if (row < N && std::isfinite(series.Y(o, row))) obs.push_back({o, j});
    }
  Stacked s;
  const auto M = static_cast<Eigen::Index>(obs.size());
  s.mu.resize(M);
  s.Sigma.resize(M, M);
  for (Eigen::Index a = 0; a < M; ++a) {
    const auto [o, j] = obs[a];
    s.mu(a) = ss.C.row(o).dot(m[j]) + ss.D.row(o).dot(series.U.col(j)) + ss.d(o);
    for (Eigen::Index b = 0; b <= a; ++b) {
      const auto [o2, l] = obs[b];
      const Eigen::MatrixXd c = j >= l ? cross(j, l) : Eigen::MatrixXd(cross(l, j).transpose());
      s.Sigma(a, b) = s.Sigma(b, a) = ss.C.row(o).dot(c * ss.C.row(o2).transpose());
    }
    s.Sigma(a, a) += ss.S(o);
  }
  (void)n;
  return s;
}

// I_ab = μ_a' Σ⁻¹ μ_b + ½ tr(Σ⁻¹ Σ_a Σ⁻¹ Σ_b), the derivatives by central differences.
Eigen::MatrixXd BruteForceInformation(const model::LinearModel& lm,
                                      const std::vector<double>& theta,
                                      const std::vector<int>& free, const data::Series& series,
                                      const filter::FilterSettings& settings) {
  const Stacked at = StackedObservations(lm, theta, series, settings);
  const Eigen::LDLT<Eigen::MatrixXd> ldlt(at.Sigma);
  const auto k = static_cast<Eigen::Index>(free.size());
  std::vector<Eigen::VectorXd> dmu(free.size());
  std::vector<Eigen::MatrixXd> dSigma(free.size());
  for (std::size_t i = 0; i < free.size(); ++i) {
    const double h = 1e-5 * std::max(std::abs(theta[free[i]]), 0.1);
    auto plus = theta, minus = theta;
    plus[free[i]] += h;
    minus[free[i]] -= h;
    const Stacked up = StackedObservations(lm, plus, series, settings);
    const Stacked down = StackedObservations(lm, minus, series, settings);
    dmu[i] = (up.mu - down.mu) / (2 * h);
    dSigma[i] = (up.Sigma - down.Sigma) / (2 * h);
  }
  Eigen::MatrixXd I(k, k);
  for (Eigen::Index a = 0; a < k; ++a)
    for (Eigen::Index b = 0; b < k; ++b) {
      const Eigen::MatrixXd Xa = ldlt.solve(dSigma[a]);
      const Eigen::MatrixXd Xb = ldlt.solve(dSigma[b]);
      I(a, b) = dmu[a].dot(ldlt.solve(dmu[b])) + 0.5 * (Xa * Xb).trace();
    }
  return I;
}

void ExpectSameInformation(const Eigen::MatrixXd& I, const Eigen::MatrixXd& expected) {
  ASSERT_EQ(I.rows(), expected.rows());
  for (Eigen::Index a = 0; a < I.rows(); ++a)
    for (Eigen::Index b = 0; b < I.cols(); ++b)
      EXPECT_NEAR(I(a, b), expected(a, b), 2e-6 * std::sqrt(expected(a, a) * expected(b, b)))
          << "I(" << a << ", " << b << ")";
}

struct Case {
  model::InputHold hold;
  model::InitialCovariance p0;
};

class InformationBruteForce : public ::testing::TestWithParam<Case> {};

TEST_P(InformationBruteForce, EqualsTheWholeRecordsGaussianInformation) {
  const model::LinearModel lm = CompileModel(kTwoOutputModel);
  std::vector<double> theta;
  for (const auto& p : lm.spec().parameters) theta.push_back(p.value);
  std::vector<int> free(theta.size());
  std::iota(free.begin(), free.end(), 0);
  // Irregular times, missing observations, a delay on the first output.
  const data::Series series = RandomSeries(24, 2, 0.15, 7);
  filter::FilterSettings settings;
  settings.hold = GetParam().hold;
  settings.initial_covariance = GetParam().p0;
  settings.delay = {1, 0};
  auto info = ExpectedFisherInformation(lm, theta, free, series, settings);
  ASSERT_TRUE(info.ok()) << info.error().ToString();
  ExpectSameInformation(info->information,
                        BruteForceInformation(lm, theta, free, series, settings));
  // The input's part is the mean's: μ_a' Σ⁻¹ μ_b.
  EXPECT_TRUE(info->from_input.allFinite());
  ASSERT_EQ(info->std_error.size(), free.size());
  for (const auto& se : info->std_error) EXPECT_TRUE(se.has_value());
}

INSTANTIATE_TEST_SUITE_P(
    HoldsAndInitialCovariances, InformationBruteForce,
    ::testing::Values(Case{model::InputHold::kZoh, model::InitialCovariance::kCtsm},
                      Case{model::InputHold::kFoh, model::InitialCovariance::kCtsm},
                      Case{model::InputHold::kFoh, model::InitialCovariance::kStationary}));

TEST(ExpectedFisherInformation, InputPartIsTheMeansAndGrowsWithTheAmplitudeSquared) {
  const model::LinearModel lm = CompileModel(kTwoOutputModel);
  std::vector<double> theta;
  for (const auto& p : lm.spec().parameters) theta.push_back(p.value);
  const std::vector<int> free = {0, 1, 2};  // a, b, k: the drift
  data::Series series = RandomSeries(40, 2, 0.0, 3);
  filter::FilterSettings settings;
  auto once = ExpectedFisherInformation(lm, theta, free, series, settings);
  ASSERT_TRUE(once.ok());
  series.U *= 3.0;  // the input's mean response three times as large (the constants stay)
  auto thrice = ExpectedFisherInformation(lm, theta, free, series, settings);
  ASSERT_TRUE(thrice.ok());
  // The noise's part does not depend on the input.
  const Eigen::MatrixXd noise1 = once->information - once->from_input;
  const Eigen::MatrixXd noise3 = thrice->information - thrice->from_input;
  EXPECT_LT((noise1 - noise3).norm(), 1e-10 * noise1.norm());
  EXPECT_GT(thrice->from_input.trace(), once->from_input.trace());
}

TEST(ExpectedFisherInformation, SaysWhichParameterNoObservationDetermines) {
  // r2 is the second output's variance: with every y2 missing nothing determines it.
  const model::LinearModel lm = CompileModel(kTwoOutputModel);
  std::vector<double> theta;
  for (const auto& p : lm.spec().parameters) theta.push_back(p.value);
  data::Series series = RandomSeries(30, 2, 0.0, 5);
  series.Y.row(1).setConstant(std::numeric_limits<double>::quiet_NaN());
  const std::vector<int> free = {0, 5, 6};  // a, r1, r2
  auto info = ExpectedFisherInformation(lm, theta, free, series, filter::FilterSettings{});
  ASSERT_TRUE(info.ok()) << info.error().ToString();
  ASSERT_TRUE(info->undetermined.has_value());
  EXPECT_EQ(*info->undetermined, 2);
  EXPECT_EQ(info->covariance.size(), 0);
  for (const auto& se : info->std_error) EXPECT_FALSE(se.has_value());
}

}  // namespace
}  // namespace gb::design
