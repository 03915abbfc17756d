#include "core/filter/discretize.h"

#include <cmath>
#include <complex>

#include <Eigen/Dense>
#include <gtest/gtest.h>

namespace gb::filter {
namespace {

using model::InputHold;

// Scalar Ornstein-Uhlenbeck with input and constant: dx = (a x + b u + c) dt + σ dω.
struct ScalarOu {
  double a, b, c, sigma;
};

Discrete DiscretizeScalar(const ScalarOu& ou, double dt, InputHold hold) {
  Eigen::MatrixXd A(1, 1), B(1, 1);
  Eigen::VectorXd c(1), s2(1);
  A << ou.a;
  B << ou.b;
  c << ou.c;
  s2 << ou.sigma * ou.sigma;
  return Discretize(A, B, c, s2, dt, hold);
}

TEST(Discretize, MatchesClosedFormForScalarOuWithZeroOrderHold) {
  for (const ScalarOu ou : {ScalarOu{-2.0, 3.0, 0.5, 0.7}, ScalarOu{-0.01, 1.0, -1.0, 2.0},
                            ScalarOu{0.3, -1.5, 0.0, 0.1}}) {
    for (double dt : {1e-3, 0.0125, 0.5, 7.0}) {
      const Discrete d = DiscretizeScalar(ou, dt, InputHold::kZoh);
      const double e = std::exp(ou.a * dt);
      EXPECT_NEAR(d.Phi(0, 0), e, 4e-14 * e);                // a few squarings of rounding
      const double integral = std::expm1(ou.a * dt) / ou.a;  // ∫_0^Δ e^{as} ds
      EXPECT_NEAR(d.Gamma0(0, 0), ou.b * integral, 1e-13 * std::abs(ou.b * integral));
      EXPECT_EQ(d.Gamma1(0, 0), 0.0);
      EXPECT_NEAR(d.g(0), ou.c * integral, 1e-13 * std::abs(ou.c * integral) + 1e-300);
      const double q = ou.sigma * ou.sigma * std::expm1(2 * ou.a * dt) / (2 * ou.a);
      EXPECT_NEAR(d.Q(0, 0), q, 1e-12 * q) << "a=" << ou.a << " dt=" << dt;
    }
  }
}

TEST(Discretize, MatchesClosedFormForScalarOuWithFirstOrderHold) {
  const ScalarOu ou{-1.7, 2.5, 0.3, 0.4};
  for (double dt : {0.01, 0.25, 3.0}) {
    const Discrete d = DiscretizeScalar(ou, dt, InputHold::kFoh);
    const double a = ou.a;
    // Γ1 = b/Δ ∫_0^Δ e^{a(Δ-s)} s ds = b (e^{aΔ} - 1 - aΔ) / (a² Δ)
    const double gamma1 = ou.b * (std::expm1(a * dt) - a * dt) / (a * a * dt);
    const double gamma0 = ou.b * std::expm1(a * dt) / a - gamma1;
    EXPECT_NEAR(d.Gamma1(0, 0), gamma1, 1e-12 * std::abs(gamma1));
    EXPECT_NEAR(d.Gamma0(0, 0), gamma0, 1e-12 * std::abs(gamma0));
    EXPECT_NEAR(d.Phi(0, 0), std::exp(a * dt), 1e-14);
  }
}

// Fine-step RK4 integration of the mean (input ramping linearly) and of dQ/dt = AQ + QA' + G.
struct Integrated {
  Eigen::VectorXd x;
  Eigen::MatrixXd Q;
};

Integrated IntegrateFine(const Eigen::MatrixXd& A, const Eigen::MatrixXd& B,
                         const Eigen::VectorXd& c, const Eigen::VectorXd& s2,
                         const Eigen::VectorXd& x0, const Eigen::VectorXd& u0,
                         const Eigen::VectorXd& u1, double dt, bool linear_input, int steps) {
  const Eigen::MatrixXd G = s2.asDiagonal();
  auto u_at = [&](double t) -> Eigen::VectorXd {
    return linear_input ? Eigen::VectorXd(u0 + (u1 - u0) * (t / dt)) : u0;
  };
  auto fx = [&](double t, const Eigen::VectorXd& x) -> Eigen::VectorXd {
    return A * x + B * u_at(t) + c;
  };
  auto fq = [&](const Eigen::MatrixXd& Q) -> Eigen::MatrixXd {
    return A * Q + Q * A.transpose() + G;
  };
  Eigen::VectorXd x = x0;
  Eigen::MatrixXd Q = Eigen::MatrixXd::Zero(A.rows(), A.rows());
  const double h = dt / steps;
  for (int i = 0; i < steps; ++i) {
    const double t = i * h;
    const Eigen::VectorXd k1 = fx(t, x), k2 = fx(t + h / 2, x + h / 2 * k1),
                          k3 = fx(t + h / 2, x + h / 2 * k2), k4 = fx(t + h, x + h * k3);
    x += h / 6 * (k1 + 2 * k2 + 2 * k3 + k4);
    const Eigen::MatrixXd q1 = fq(Q), q2 = fq(Q + h / 2 * q1), q3 = fq(Q + h / 2 * q2),
                          q4 = fq(Q + h * q3);
    Q += h / 6 * (q1 + 2 * q2 + 2 * q3 + q4);
  }
  return {x, Q};
}

TEST(Discretize, MatchesFineStepIntegrationForCoupledNonSymmetricThreeStateModel) {
  Eigen::MatrixXd A(3, 3), B(3, 2);
  A << -1.2, 0.8, 0.0,  //
      -0.5, -0.3, 1.1,  //
      0.2, -0.9, -2.0;  // non-symmetric, complex eigenvalues
  B << 1.0, 0.0,        //
      0.3, -0.7,        //
      0.0, 2.0;
  Eigen::VectorXd c(3), s2(3), x0(3), u0(2), u1(2);
  c << 0.1, -0.2, 0.05;
  s2 << 0.5, 0.02, 1.3;
  x0 << 1.0, -2.0, 0.5;
  u0 << 0.4, -1.0;
  u1 << 1.5, 0.3;
  for (InputHold hold : {InputHold::kZoh, InputHold::kFoh}) {
    for (double dt : {0.05, 0.7, 2.5}) {
      const Discrete d = Discretize(A, B, c, s2, dt, hold);
      const bool foh = hold == InputHold::kFoh;
      const Integrated ref = IntegrateFine(A, B, c, s2, x0, u0, u1, dt, foh, 4000);
      const Eigen::VectorXd x = d.Phi * x0 + d.Gamma0 * u0 + d.Gamma1 * u1 + d.g;
      EXPECT_LT((x - ref.x).cwiseAbs().maxCoeff(), 1e-10 * (1 + ref.x.norm())) << "dt=" << dt;
      EXPECT_LT((d.Q - ref.Q).cwiseAbs().maxCoeff(), 1e-10 * (1 + ref.Q.norm())) << "dt=" << dt;
      EXPECT_EQ((d.Q - d.Q.transpose()).cwiseAbs().maxCoeff(), 0.0);
    }
  }
}

TEST(Discretize, StaysAccurateForStiffModelsOverLongIntervals) {
  // Time constants from 1e-4 to 1e4 in one model, sampled at Δ = 10: e^{-AΔ} would overflow.
  Eigen::MatrixXd A = Eigen::Vector3d(-1e4, -1.0, -1e-4).asDiagonal();
  Eigen::MatrixXd B = Eigen::MatrixXd::Ones(3, 1);
  Eigen::VectorXd c = Eigen::VectorXd::Zero(3), s2(3);
  s2 << 2.0, 0.5, 1e-3;
  const double dt = 10.0;
  const Discrete d = Discretize(A, B, c, s2, dt, InputHold::kZoh);
  for (int i = 0; i < 3; ++i) {
    const double a = A(i, i);
    const double q = s2(i) * std::expm1(2 * a * dt) / (2 * a);
    EXPECT_NEAR(d.Q(i, i), q, 1e-10 * q) << "state " << i;
    EXPECT_NEAR(d.Gamma0(i, 0), std::expm1(a * dt) / a, 1e-10 * std::abs(std::expm1(a * dt) / a));
    EXPECT_NEAR(d.Phi(i, i), std::exp(a * dt), 1e-14);
  }
  EXPECT_TRUE(d.Q.allFinite());
}

TEST(StationaryCovariance, SolvesTheLyapunovEquationAndEqualsTheLongIntervalLimit) {
  Eigen::MatrixXd A(2, 2);
  A << -1.0, 2.0,  //
      -0.5, -0.8;
  Eigen::VectorXd s2(2);
  s2 << 0.3, 1.1;
  Eigen::MatrixXd P;
  std::complex<double> bad;
  ASSERT_TRUE(StationaryCovariance(A, s2, &P, &bad));
  const Eigen::MatrixXd residual = A * P + P * A.transpose() + Eigen::MatrixXd(s2.asDiagonal());
  EXPECT_LT(residual.cwiseAbs().maxCoeff(), 1e-13);
  const Eigen::MatrixXd Q_long = IntegratedDiffusion(A, s2, 200.0);
  EXPECT_LT((Q_long - P).cwiseAbs().maxCoeff(), 1e-12);
}

TEST(StationaryCovariance, RefusesAnUnstableMatrix) {
  Eigen::MatrixXd A(2, 2);
  A << 0.1, 1.0,  //
      0.0, -1.0;
  Eigen::VectorXd s2 = Eigen::VectorXd::Ones(2);
  Eigen::MatrixXd P;
  std::complex<double> bad;
  EXPECT_FALSE(StationaryCovariance(A, s2, &P, &bad));
  EXPECT_NEAR(bad.real(), 0.1, 1e-12);
}

}  // namespace
}  // namespace gb::filter

namespace gb::filter {
namespace {

// d/da of the scalar OU's Φ = e^{aΔ}, Γ0 = b (e^{aΔ} - 1)/a and Q = σ² (e^{2aΔ} - 1)/(2a), and
// dQ/dσ² = (e^{2aΔ} - 1)/(2a): closed forms.
TEST(DiscretizeDerivative, MatchesClosedFormForScalarOu) {
  const double a = -1.7, b = 0.8, s2 = 0.3;
  const Eigen::MatrixXd A = Eigen::MatrixXd::Constant(1, 1, a),
                        B = Eigen::MatrixXd::Constant(1, 1, b);
  const Eigen::VectorXd c = Eigen::VectorXd::Zero(1), sigma2 = Eigen::VectorXd::Constant(1, s2);
  const Eigen::MatrixXd one = Eigen::MatrixXd::Ones(1, 1), zero = Eigen::MatrixXd::Zero(1, 1);
  const Eigen::VectorXd v_one = Eigen::VectorXd::Ones(1), v_zero = Eigen::VectorXd::Zero(1);
  for (double dt : {0.01, 0.5, 6.0}) {
    const double e = std::exp(a * dt), e2 = std::exp(2 * a * dt);
    const Discrete da =
        DiscretizeDerivative(A, B, c, sigma2, one, zero, v_zero, v_zero, dt, InputHold::kZoh);
    EXPECT_NEAR(da.Phi(0, 0), dt * e, 1e-13);
    EXPECT_NEAR(da.Gamma0(0, 0), b * (dt * e / a - (e - 1) / (a * a)), 1e-13);
    EXPECT_NEAR(da.Q(0, 0), s2 * (dt * e2 / a - (e2 - 1) / (2 * a * a)), 1e-13);
    const Discrete ds =
        DiscretizeDerivative(A, B, c, sigma2, zero, zero, v_zero, v_one, dt, InputHold::kZoh);
    EXPECT_NEAR(ds.Q(0, 0), (e2 - 1) / (2 * a), 1e-13);
    EXPECT_EQ(ds.Phi(0, 0), 0.0);
  }
}

// A stiff coupled pair with FOH (modes at -1000 and -0.01) over a long interval: the derivative
// along a random direction equals central differences of Discretize.
TEST(DiscretizeDerivative, MatchesCentralDifferencesForAStiffModelWithFirstOrderHold) {
  Eigen::MatrixXd A(2, 2), B(2, 1), dA(2, 2), dB(2, 1);
  A << -1000.0, 5.0, 0.2, -0.01;
  B << 3.0, -1.0;
  dA << 40.0, -1.0, 0.5, 0.003;
  dB << 0.7, 0.2;
  Eigen::VectorXd c(2), sigma2(2), dc(2), ds2(2);
  c << 0.5, -0.2;
  sigma2 << 4.0, 0.01;
  dc << 0.1, 0.3;
  ds2 << 0.5, 0.002;
  for (double dt : {0.0125, 3.0}) {
    const Discrete d = DiscretizeDerivative(A, B, c, sigma2, dA, dB, dc, ds2, dt, InputHold::kFoh);
    const double h = 1e-6;
    const Discrete up =
        Discretize(A + h * dA, B + h * dB, c + h * dc, sigma2 + h * ds2, dt, InputHold::kFoh);
    const Discrete down =
        Discretize(A - h * dA, B - h * dB, c - h * dc, sigma2 - h * ds2, dt, InputHold::kFoh);
    const auto expect_near = [&](const Eigen::MatrixXd& analytic, const Eigen::MatrixXd& plus,
                                 const Eigen::MatrixXd& minus, const char* what) {
      const Eigen::MatrixXd difference = (plus - minus) / (2 * h);
      EXPECT_LE((analytic - difference).cwiseAbs().maxCoeff(),
                1e-6 * std::max(1.0, difference.cwiseAbs().maxCoeff()))
          << what << " at dt = " << dt << "\n"
          << analytic << "\n"
          << difference;
    };
    expect_near(d.Phi, up.Phi, down.Phi, "Phi");
    expect_near(d.Gamma0, up.Gamma0, down.Gamma0, "Gamma0");
    expect_near(d.Gamma1, up.Gamma1, down.Gamma1, "Gamma1");
    expect_near(d.g, up.g, down.g, "g");
    expect_near(d.Q, up.Q, down.Q, "Q");
  }
}

}  // namespace
}  // namespace gb::filter
