// The trust-region step (core/estimate/fitter.h, TrustRegionStep) against its closed forms and a
// brute-force search over the ball, and the trust-region algorithm against the plain fit.
#include <cmath>
#include <random>

#include <Eigen/Dense>
#include <gtest/gtest.h>

#include "core/estimate/fitter.h"

namespace gb::estimate::internal {
namespace {

double ModelGain(const Eigen::MatrixXd& B, const Eigen::VectorXd& g, const Eigen::VectorXd& e) {
  return g.dot(e) - 0.5 * e.dot(B * e);
}

// The best model gain over many points in the ball of the radius (on its surface and inside).
double BruteForceBest(const Eigen::MatrixXd& B, const Eigen::VectorXd& g, double radius) {
  std::mt19937_64 rng(7);
  std::normal_distribution<double> normal;
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  double best = 0;
  for (int n = 0; n < 200000; ++n) {
    Eigen::VectorXd e(g.size());
    for (Eigen::Index i = 0; i < e.size(); ++i) e(i) = normal(rng);
    e *= radius * std::pow(unit(rng), 0.25) / e.norm();
    best = std::max(best, ModelGain(B, g, e));
  }
  return best;
}

// The best model gain over a fine grid of the box (2 dimensions).
double GridBest(const Eigen::MatrixXd& B, const Eigen::VectorXd& g, const Eigen::VectorXd& lo,
                const Eigen::VectorXd& hi) {
  double best = -HUGE_VAL;
  for (int i = 0; i <= 400; ++i)
    for (int j = 0; j <= 400; ++j) {
      const Eigen::Vector2d e(lo(0) + (hi(0) - lo(0)) * i / 400.0,
                              lo(1) + (hi(1) - lo(1)) * j / 400.0);
      best = std::max(best, ModelGain(B, g, e));
    }
  return best;
}

TEST(BoxModelStep, HoldsTheEntryTheModelDrivesOntoItsBoundAndResolvesTheOthers) {
  Eigen::MatrixXd B(2, 2);
  B << 2, 1, 1, 2;
  const Eigen::VectorXd g = Eigen::Vector2d(4, -1);
  const Eigen::VectorXd newton = B.llt().solve(g);  // (3, -2): leaves the box in d_0
  const Eigen::VectorXd lo = Eigen::Vector2d(-10, -10), hi = Eigen::Vector2d(1, 10);
  const Eigen::VectorXd d = BoxModelStep(B, g, lo, hi, newton);
  // d_0 on its bound 1, d_1 from 2 d_1 = -1 - 1: -1 (the clamped step would keep -2).
  EXPECT_NEAR(d(0), 1.0, 1e-15);
  EXPECT_NEAR(d(1), -1.0, 1e-15);
  EXPECT_GE(ModelGain(B, g, d), GridBest(B, g, lo, hi) - 1e-12);
  // Inside the box: the Newton step itself.
  EXPECT_EQ(BoxModelStep(B, g, lo, Eigen::Vector2d(10, 10), newton), newton);
}

TEST(BoxModelStep, BeatsEveryPointOfAGridOverTheBoxOnRandomProblems) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  for (int trial = 0; trial < 20; ++trial) {
    Eigen::MatrixXd A(2, 2);
    A << unit(rng), unit(rng), unit(rng), unit(rng);
    const Eigen::MatrixXd B = A * A.transpose() + 0.05 * Eigen::MatrixXd::Identity(2, 2);
    const Eigen::VectorXd g = 3.0 * Eigen::Vector2d(unit(rng), unit(rng));
    const Eigen::VectorXd lo =
        Eigen::Vector2d(-0.1 - std::abs(unit(rng)), -0.1 - std::abs(unit(rng)));
    const Eigen::VectorXd hi =
        Eigen::Vector2d(0.1 + std::abs(unit(rng)), 0.1 + std::abs(unit(rng)));
    const Eigen::VectorXd d = BoxModelStep(B, g, lo, hi, B.llt().solve(g));
    for (int a = 0; a < 2; ++a) {
      EXPECT_GE(d(a), lo(a)) << "trial " << trial;
      EXPECT_LE(d(a), hi(a)) << "trial " << trial;
    }
    EXPECT_GE(ModelGain(B, g, d), GridBest(B, g, lo, hi) - 1e-9) << "trial " << trial;
  }
}

TEST(TrustRegionStep, IsTheNewtonStepWhenThatLiesInsideTheRadius) {
  Eigen::MatrixXd B(2, 2);
  B << 4, 1, 1, 3;
  const Eigen::VectorXd g = Eigen::Vector2d(1, 2);
  const Eigen::VectorXd newton = B.llt().solve(g);
  const Eigen::VectorXd e = TrustRegionStep(B, g, 10.0);
  EXPECT_NEAR((e - newton).norm(), 0.0, 1e-14);
}

TEST(TrustRegionStep, OnTheRadiusSolvesTheShiftedSystemWithANonNegativeMultiplier) {
  Eigen::MatrixXd B(3, 3);
  B << 2, 0.5, 0, 0.5, 1, 0.2, 0, 0.2, 0.1;
  const Eigen::VectorXd g = Eigen::Vector3d(1, -2, 3);
  const double radius = 0.5;
  const Eigen::VectorXd e = TrustRegionStep(B, g, radius);
  EXPECT_NEAR(e.norm(), radius, 1e-10);
  // Moré-Sorensen: (B + λI) e = g with λ ≥ 0, i.e. g - Be is parallel to e with a positive factor.
  const Eigen::VectorXd residual = g - B * e;
  const double lambda = residual.dot(e) / e.squaredNorm();
  EXPECT_GE(lambda, 0.0);
  EXPECT_NEAR((residual - lambda * e).norm(), 0.0, 1e-9 * g.norm());
  EXPECT_GE(ModelGain(B, g, e), BruteForceBest(B, g, radius) - 1e-9);
}

TEST(TrustRegionStep, FollowsNegativeCurvatureToTheRadiusAndBeatsEveryPointOfTheBall) {
  Eigen::MatrixXd B(3, 3);
  B << -1, 0.3, 0, 0.3, 2, 0.1, 0, 0.1, 0.5;
  const Eigen::VectorXd g = Eigen::Vector3d(0.2, 1, -0.5);
  for (const double radius : {0.1, 1.0, 3.0}) {
    SCOPED_TRACE(radius);
    const Eigen::VectorXd e = TrustRegionStep(B, g, radius);
    EXPECT_NEAR(e.norm(), radius, 1e-9 * radius);
    EXPECT_GE(ModelGain(B, g, e), BruteForceBest(B, g, radius) - 1e-9);
  }
}

TEST(TrustRegionStep, TheHardCaseGoesAlongTheNegativeCurvatureTheGradientMisses) {
  // g has no component along the eigenvector of the negative eigenvalue (the first axis): the
  // shifted system alone stays inside the radius, and the rest of the radius goes along that axis.
  const Eigen::MatrixXd B = Eigen::Vector3d(-2, 1, 3).asDiagonal();
  const Eigen::VectorXd g = Eigen::Vector3d(0, 1, 1);
  const double radius = 2.0;
  const Eigen::VectorXd e = TrustRegionStep(B, g, radius);
  EXPECT_NEAR(e.norm(), radius, 1e-12);
  EXPECT_NEAR(e(1), 1.0 / 3.0, 1e-12);  // g_i / (λ_i + 2)
  EXPECT_NEAR(e(2), 1.0 / 5.0, 1e-12);
  EXPECT_NEAR(std::abs(e(0)), std::sqrt(4.0 - 1.0 / 9 - 1.0 / 25), 1e-12);
  EXPECT_GE(ModelGain(B, g, e), BruteForceBest(B, g, radius) - 1e-9);
}

}  // namespace
}  // namespace gb::estimate::internal
