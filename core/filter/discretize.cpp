#include "core/filter/discretize.h"

#include <cassert>
#include <cmath>
#include <complex>

#include <Eigen/Dense>
#include <limits>

namespace gb::filter {
namespace {

// Doubling starts from an interval δ = Δ/2^s on which ‖M δ‖₁ <= kShortNorm.
constexpr double kShortNorm = 0.25;
constexpr int kMaxTaylorTerms = 30;

// A norm that is not finite (A·Δ overflowed: an interval of 1e308 s) needs no doubling: no
// number of them helps, the result is not finite, and the filter reports the interval
// (DiscretizeIntervals, kalman.h). A finite norm needs at most 1026 (log2 of the largest double is
// below 1024; norm / kShortNorm itself could overflow).
int DoublingSteps(double norm) {
  if (!(norm > kShortNorm) || !std::isfinite(norm)) return 0;
  return static_cast<int>(std::ceil(std::log2(norm) - std::log2(kShortNorm)));
}

double Norm1(const Eigen::MatrixXd& M) { return M.cwiseAbs().colwise().sum().maxCoeff(); }

// e^M - I for ‖M‖₁ <= kShortNorm by its Taylor series (terms shrink at least 4-fold each).
Eigen::MatrixXd Expm1Short(const Eigen::MatrixXd& M) {
  Eigen::MatrixXd term = M;
  Eigen::MatrixXd sum = M;
  for (int k = 2; k < kMaxTaylorTerms; ++k) {
    term = (term * M / k).eval();
    sum += term;
    if (Norm1(term) <= std::numeric_limits<double>::epsilon() * Norm1(sum) * 0.5) break;
  }
  return sum;
}

// e^M for any M, by scaling and squaring from the Taylor series on a short interval, squaring
// both F = e^{Mδ} (F <- F²) and E = F - I (E <- 2E + E²). A diagonal entry near 1 (a slow mode
// of a stiff model: 1 - tiny) is taken as 1 + E_ii, which keeps the tiny part exact where F_ii
// alone would lose about s·log10(2) digits of it; an entry far from 1 (a mode that has decayed)
// is taken from F, exact relative to its own small size. Off-diagonal entries of F and E agree.
Eigen::MatrixXd Expm(const Eigen::MatrixXd& M) {
  const int s = DoublingSteps(Norm1(M));
  Eigen::MatrixXd E = Expm1Short(std::ldexp(1.0, -s) * M);
  Eigen::MatrixXd F = Eigen::MatrixXd::Identity(M.rows(), M.cols()) + E;
  for (int i = 0; i < s; ++i) {
    E = (2.0 * E + E * E).eval();
    F = (F * F).eval();
  }
  for (Eigen::Index i = 0; i < M.rows(); ++i)
    if (std::abs(E(i, i)) < 0.5) F(i, i) = 1.0 + E(i, i);
  return F;
}

}  // namespace

Eigen::MatrixXd IntegratedDiffusion(const Eigen::MatrixXd& A, const Eigen::VectorXd& sigma2,
                                    double dt) {
  const Eigen::Index n = A.rows();
  assert(dt > 0 && A.cols() == n && sigma2.size() == n);
  const int s = DoublingSteps(Norm1(A) * dt);
  const double delta = std::ldexp(dt, -s);

  // Van Loan on the short interval, where e^{-Aδ} is harmless:
  //   exp([[-A, G], [0, A']] δ) = [[., F12], [0, F22]],  Φ(δ) = F22',  Q(δ) = Φ(δ) F12.
  Eigen::MatrixXd M = Eigen::MatrixXd::Zero(2 * n, 2 * n);
  M.topLeftCorner(n, n) = -A * delta;
  M.topRightCorner(n, n) = Eigen::MatrixXd(sigma2.asDiagonal()) * delta;
  M.bottomRightCorner(n, n) = A.transpose() * delta;
  const Eigen::MatrixXd F = Eigen::MatrixXd::Identity(2 * n, 2 * n) + Expm1Short(M);
  Eigen::MatrixXd E = F.bottomRightCorner(n, n).transpose() - Eigen::MatrixXd::Identity(n, n);
  Eigen::MatrixXd Q = F.bottomRightCorner(n, n).transpose() * F.topRightCorner(n, n);
  Q = (0.5 * (Q + Q.transpose())).eval();
  // Q(2δ) = Φ Q Φ' + Q with Φ = I + E, and E(2δ) = 2E + E².
  for (int i = 0; i < s; ++i) {
    const Eigen::MatrixXd Phi = Eigen::MatrixXd::Identity(n, n) + E;
    Q = (Phi * Q * Phi.transpose() + Q).eval();
    Q = (0.5 * (Q + Q.transpose())).eval();
    E = (2.0 * E + E * E).eval();
  }
  return Q;
}

Discrete Discretize(const Eigen::MatrixXd& A, const Eigen::MatrixXd& B, const Eigen::VectorXd& c,
                    const Eigen::VectorXd& sigma2, double dt, model::InputHold hold) {
  const Eigen::Index n = A.rows(), m = B.cols();
  assert(dt > 0 && A.cols() == n && B.rows() == n && c.size() == n);
  Discrete d;
  // e^{MΔ} of the augmented matrix: its first block row is [Φ, input blocks, g].
  if (hold == model::InputHold::kZoh) {
    // z = (x, u, 1): dx = A x + B u + c.
    Eigen::MatrixXd M = Eigen::MatrixXd::Zero(n + m + 1, n + m + 1);
    M.topLeftCorner(n, n) = A * dt;
    M.block(0, n, n, m) = B * dt;
    M.block(0, n + m, n, 1) = c * dt;
    const Eigen::MatrixXd E = Expm(M);
    d.Phi = E.topLeftCorner(n, n);
    d.Gamma0 = E.block(0, n, n, m);
    d.Gamma1 = Eigen::MatrixXd::Zero(n, m);
    d.g = E.block(0, n + m, n, 1);
  } else {
    // z = (x, w, 1, v) with dw/dt = v/Δ: w runs linearly from u_k (w(0)) to u_{k+1} when
    // v = u_{k+1} - u_k. The block of v is then Γ1 and the block of w is ∫ e^{As} ds B.
    Eigen::MatrixXd M = Eigen::MatrixXd::Zero(n + 2 * m + 1, n + 2 * m + 1);
    M.topLeftCorner(n, n) = A * dt;
    M.block(0, n, n, m) = B * dt;
    M.block(0, n + m, n, 1) = c * dt;
    M.block(n, n + m + 1, m, m).setIdentity();  // (1/Δ) · Δ
    const Eigen::MatrixXd E = Expm(M);
    d.Phi = E.topLeftCorner(n, n);
    d.Gamma1 = E.block(0, n + m + 1, n, m);
    d.Gamma0 = E.block(0, n, n, m) - d.Gamma1;
    d.g = E.block(0, n + m, n, 1);
  }
  d.Q = IntegratedDiffusion(A, sigma2, dt);
  return d;
}

bool StationaryCovariance(const Eigen::MatrixXd& A, const Eigen::VectorXd& sigma2,
                          Eigen::MatrixXd* P, std::complex<double>* bad_eigenvalue) {
  const Eigen::Index n = A.rows();
  Eigen::EigenSolver<Eigen::MatrixXd> es(A, /*computeEigenvectors=*/false);
  for (Eigen::Index i = 0; i < n; ++i) {
    if (!(es.eigenvalues()(i).real() < 0)) {
      if (bad_eigenvalue) *bad_eigenvalue = es.eigenvalues()(i);
      return false;
    }
  }
  // (I ⊗ A + A ⊗ I) vec(P) = -vec(G), with column-major vec.
  const Eigen::MatrixXd I = Eigen::MatrixXd::Identity(n, n);
  Eigen::MatrixXd K = Eigen::MatrixXd::Zero(n * n, n * n);
  for (Eigen::Index i = 0; i < n; ++i) {
    for (Eigen::Index j = 0; j < n; ++j) {
      K.block(i * n, j * n, n, n) += I(i, j) * A;   // I ⊗ A
      K.block(i * n, j * n, n, n) += A(i, j) * I;   // A ⊗ I
    }
  }
  Eigen::VectorXd rhs = Eigen::VectorXd::Zero(n * n);
  for (Eigen::Index i = 0; i < n; ++i) rhs(i * n + i) = -sigma2(i);
  const Eigen::VectorXd x = K.partialPivLu().solve(rhs);
  *P = Eigen::Map<const Eigen::MatrixXd>(x.data(), n, n);
  *P = (0.5 * (*P + P->transpose())).eval();
  return true;
}

}  // namespace gb::filter
