#include "core/filter/discretize.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <complex>
#include <limits>

#include <Eigen/Dense>

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

// Q = ∫_0^Δ e^{As} G e^{A's} ds for a symmetric G (not necessarily PSD: the derivative of Q is
// one block of such an integral, see DiscretizeDerivative).
Eigen::MatrixXd IntegratedCovariance(const Eigen::MatrixXd& A, const Eigen::MatrixXd& G,
                                     double dt) {
  const Eigen::Index n = A.rows();
  assert(dt > 0 && A.cols() == n && G.rows() == n && G.cols() == n);
  const int s = DoublingSteps(Norm1(A) * dt);
  const double delta = std::ldexp(dt, -s);

  // Van Loan on the short interval, where e^{-Aδ} is harmless:
  //   exp([[-A, G], [0, A']] δ) = [[., F12], [0, F22]],  Φ(δ) = F22',  Q(δ) = Φ(δ) F12.
  Eigen::MatrixXd M = Eigen::MatrixXd::Zero(2 * n, 2 * n);
  M.topLeftCorner(n, n) = -A * delta;
  M.topRightCorner(n, n) = G * delta;
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

// The matrix whose exponential holds Φ, the input matrices and g (see the header).
Eigen::MatrixXd AugmentedMatrix(const Eigen::MatrixXd& A, const Eigen::MatrixXd& B,
                                const Eigen::VectorXd& c, double dt, model::InputHold hold) {
  const Eigen::Index n = A.rows(), m = B.cols();
  // ZOH: z = (x, u, 1): dx = A x + B u + c.
  // FOH: z = (x, w, 1, v) with dw/dt = v/Δ: w runs linearly from u_k (w(0)) to u_{k+1} when
  // v = u_{k+1} - u_k. The block of v is then Γ1 and the block of w is ∫ e^{As} ds B.
  const Eigen::Index size = hold == model::InputHold::kZoh ? n + m + 1 : n + 2 * m + 1;
  Eigen::MatrixXd M = Eigen::MatrixXd::Zero(size, size);
  M.topLeftCorner(n, n) = A * dt;
  M.block(0, n, n, m) = B * dt;
  M.block(0, n + m, n, 1) = c * dt;
  if (hold == model::InputHold::kFoh) M.block(n, n + m + 1, m, m).setIdentity();  // (1/Δ) · Δ
  return M;
}

// Φ, Γ0, Γ1 and g from the first block row of e^M (or of its derivative: the map is linear).
void ReadAugmented(const Eigen::MatrixXd& E, Eigen::Index n, Eigen::Index m, model::InputHold hold,
                   Discrete* d) {
  d->Phi = E.topLeftCorner(n, n);
  d->g = E.block(0, n + m, n, 1);
  if (hold == model::InputHold::kZoh) {
    d->Gamma0 = E.block(0, n, n, m);
    d->Gamma1 = Eigen::MatrixXd::Zero(n, m);
  } else {
    d->Gamma1 = E.block(0, n + m + 1, n, m);
    d->Gamma0 = E.block(0, n, n, m) - d->Gamma1;
  }
}

// d e^M along dM: the top-right block of exp([[M, dM], [0, M]]). dM is scaled to the size of M
// first (the block is linear in dM), so that it adds no squarings and keeps M's accuracy.
Eigen::MatrixXd ExpmDerivative(const Eigen::MatrixXd& M, const Eigen::MatrixXd& dM) {
  const Eigen::Index s = M.rows();
  const double norm_dM = Norm1(dM);
  if (norm_dM == 0.0) return Eigen::MatrixXd::Zero(s, s);
  const double scale = std::max(Norm1(M), kShortNorm) / norm_dM;
  Eigen::MatrixXd big = Eigen::MatrixXd::Zero(2 * s, 2 * s);
  big.topLeftCorner(s, s) = M;
  big.topRightCorner(s, s) = scale * dM;
  big.bottomRightCorner(s, s) = M;
  return Expm(big).topRightCorner(s, s) / scale;
}

}  // namespace

Eigen::MatrixXd IntegratedDiffusion(const Eigen::MatrixXd& A, const Eigen::VectorXd& sigma2,
                                    double dt) {
  return IntegratedCovariance(A, Eigen::MatrixXd(sigma2.asDiagonal()), dt);
}

Discrete Discretize(const Eigen::MatrixXd& A, const Eigen::MatrixXd& B, const Eigen::VectorXd& c,
                    const Eigen::VectorXd& sigma2, double dt, model::InputHold hold) {
  assert(dt > 0 && A.cols() == A.rows() && B.rows() == A.rows() && c.size() == A.rows());
  Discrete d;
  ReadAugmented(Expm(AugmentedMatrix(A, B, c, dt, hold)), A.rows(), B.cols(), hold, &d);
  d.Q = IntegratedDiffusion(A, sigma2, dt);
  return d;
}

Discrete DiscretizeDerivative(const Eigen::MatrixXd& A, const Eigen::MatrixXd& B,
                              const Eigen::VectorXd& c, const Eigen::VectorXd& sigma2,
                              const Eigen::MatrixXd& dA, const Eigen::MatrixXd& dB,
                              const Eigen::VectorXd& dc, const Eigen::VectorXd& dsigma2, double dt,
                              model::InputHold hold) {
  const Eigen::Index n = A.rows(), m = B.cols();
  assert(dt > 0 && dA.rows() == n && dB.cols() == m && dc.size() == n && dsigma2.size() == n);
  Discrete d;
  Eigen::MatrixXd dM = AugmentedMatrix(dA, dB, dc, dt, hold);
  if (hold == model::InputHold::kFoh) dM.block(n, n + m + 1, m, m).setZero();  // constant block
  ReadAugmented(ExpmDerivative(AugmentedMatrix(A, B, c, dt, hold), dM), n, m, hold, &d);
  if (dA.isZero(0.0) && dsigma2.isZero(0.0)) {
    d.Q = Eigen::MatrixXd::Zero(n, n);
    return d;
  }
  // dQ = X21 + X21' (see the header). dA is scaled to the size of A first (X21 is linear in dA
  // and dG), as for e^M: a large dA would only add doubling steps.
  const double norm_dA = Norm1(dA);
  const double scale = norm_dA > 0 ? std::max(Norm1(A), kShortNorm / dt) / norm_dA : 1.0;
  Eigen::MatrixXd A_aug = Eigen::MatrixXd::Zero(2 * n, 2 * n);
  A_aug.topLeftCorner(n, n) = A;
  A_aug.bottomLeftCorner(n, n) = scale * dA;
  A_aug.bottomRightCorner(n, n) = A;
  const Eigen::MatrixXd dG_half = (0.5 * scale * dsigma2).asDiagonal();
  Eigen::MatrixXd G_aug = Eigen::MatrixXd::Zero(2 * n, 2 * n);
  G_aug.topLeftCorner(n, n) = sigma2.asDiagonal();
  G_aug.topRightCorner(n, n) = dG_half;
  G_aug.bottomLeftCorner(n, n) = dG_half;
  const Eigen::MatrixXd X21 = IntegratedCovariance(A_aug, G_aug, dt).bottomLeftCorner(n, n);
  d.Q = (X21 + X21.transpose()) / scale;
  return d;
}

Eigen::MatrixXd LyapunovOperator(const Eigen::MatrixXd& A) {
  const Eigen::Index n = A.rows();
  // (I ⊗ A + A ⊗ I) vec(P), with column-major vec.
  const Eigen::MatrixXd I = Eigen::MatrixXd::Identity(n, n);
  Eigen::MatrixXd K = Eigen::MatrixXd::Zero(n * n, n * n);
  for (Eigen::Index i = 0; i < n; ++i) {
    for (Eigen::Index j = 0; j < n; ++j) {
      K.block(i * n, j * n, n, n) += I(i, j) * A;  // I ⊗ A
      K.block(i * n, j * n, n, n) += A(i, j) * I;  // A ⊗ I
    }
  }
  return K;
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
  const Eigen::MatrixXd K = LyapunovOperator(A);  // K vec(P) = vec(A P + P A')
  Eigen::VectorXd rhs = Eigen::VectorXd::Zero(n * n);
  for (Eigen::Index i = 0; i < n; ++i) rhs(i * n + i) = -sigma2(i);
  const Eigen::VectorXd x = K.partialPivLu().solve(rhs);
  *P = Eigen::Map<const Eigen::MatrixXd>(x.data(), n, n);
  *P = (0.5 * (*P + P->transpose())).eval();
  return true;
}

}  // namespace gb::filter
