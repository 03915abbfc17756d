// Exact discretisation of  dx = (A x + B u(t) + c) dt + diag(σ) dω  over one sample interval Δ
// (Δ in the data's time unit, > 0):
//
//   x_{k+1} = Φ x_k + Γ0 u_k + Γ1 u_{k+1} + g + v_k,     v_k ~ N(0, Q)
//
//   Φ  = e^{AΔ}
//   g  = ∫_0^Δ e^{As} ds c
//   ZOH (u held at u_k):          Γ0 = ∫_0^Δ e^{As} ds B,                 Γ1 = 0
//   FOH (u linear from u_k to u_{k+1}):
//                                 Γ1 = ∫_0^Δ e^{A(Δ-s)} (s/Δ) ds B,       Γ0 = ∫_0^Δ e^{As} ds B -
//                                 Γ1
//   Q  = ∫_0^Δ e^{As} σσ' e^{A's} ds                                      (Van Loan)
//
// Φ, Γ0, Γ1 and g come from one matrix exponential of the augmented matrix
//   ZOH: [[A, B, c], [0, 0, 0]] Δ          FOH: [[A, B, c, 0], [0, 0, 0, I/Δ], [0, 0, 0, 0]] Δ
// (for FOH the block of v = u_{k+1} - u_k gives Γ1; see the .cpp), by a Taylor series on a
// short interval δ = Δ/2^s (‖M‖δ ≤ 1/4) and s squarings. The squarings also carry E = e^M - I
// (E <- 2E + E²), so that the slow modes of a stiff model stay exact to rounding (squaring e^M
// alone loses ~s·log10(2) digits of 1 - tiny). Q is computed by Van Loan's method on the short
// interval and then doubled s times,
//   Q(2δ) = Φ(δ) Q(δ) Φ(δ)' + Q(δ),   Φ(2δ) = Φ(δ)²,
// which never forms e^{-AΔ} (it overflows for stiff A over long intervals) and only adds
// positive semi-definite terms, so Q stays symmetric PSD to rounding for any Δ and any A
// (stable or not, symmetric or not).
#pragma once

#include <Eigen/Core>

#include "core/model/model.h"

namespace gb::filter {

struct Discrete {
  Eigen::MatrixXd Phi;     // n x n
  Eigen::MatrixXd Gamma0;  // n x m
  Eigen::MatrixXd Gamma1;  // n x m (zero for ZOH)
  Eigen::VectorXd g;       // n
  Eigen::MatrixXd Q;       // n x n, symmetric
};

// `sigma2` is the diagonal of σσ' (σ_i²). Preconditions: dt > 0; sizes consistent.
Discrete Discretize(const Eigen::MatrixXd& A, const Eigen::MatrixXd& B, const Eigen::VectorXd& c,
                    const Eigen::VectorXd& sigma2, double dt, model::InputHold hold);

// The derivative of Discretize along one direction: every member of the result is the
// derivative of the same member of Discretize(A, B, c, sigma2, dt, hold) when A, B, c, sigma2 move
// along dA, dB, dc, dsigma2 (the derivatives of the model's entries with respect to one θ_i).
//   Φ, Γ0, Γ1, g: they are linear in the first block row of e^M (M the augmented matrix above),
//     and d e^M along dM is the top-right block of exp([[M, dM], [0, M]]) (the block exponential
//     is computed as e^M is, so it is exact for the same stiff models).
//   Q: for the augmented system  Ã = [[A, 0], [dA, A]],  G̃ = [[G, dG/2], [dG/2, 0]]  (G = σσ'),
//     e^{Ãs} = [[e^{As}, 0], [d e^{As}, e^{As}]], and X = ∫_0^Δ e^{Ãs} G̃ e^{Ã's} ds has the block
//       X21 = ∫_0^Δ (d e^{As} G + ½ e^{As} dG) e^{A's} ds,   so   dQ = X21 + X21'
//     (Van Loan and doubling as for Q; the doubling is linear, so it needs no definite G̃).
// Same preconditions as Discretize; dA, dB, dc, dsigma2 have the shapes of A, B, c, sigma2.
Discrete DiscretizeDerivative(const Eigen::MatrixXd& A, const Eigen::MatrixXd& B,
                              const Eigen::VectorXd& c, const Eigen::VectorXd& sigma2,
                              const Eigen::MatrixXd& dA, const Eigen::MatrixXd& dB,
                              const Eigen::VectorXd& dc, const Eigen::VectorXd& dsigma2, double dt,
                              model::InputHold hold);

// Q(Δ) alone (the `ctsm` initial covariance is Q over the first sample interval).
Eigen::MatrixXd IntegratedDiffusion(const Eigen::MatrixXd& A, const Eigen::VectorXd& sigma2,
                                    double dt);

// The stationary covariance: the solution P of A P + P A' + diag(sigma2) = 0.
// Requires every eigenvalue of A to have a negative real part; otherwise returns false and
// writes the offending eigenvalue to *bad_eigenvalue.
bool StationaryCovariance(const Eigen::MatrixXd& A, const Eigen::VectorXd& sigma2,
                          Eigen::MatrixXd* P, std::complex<double>* bad_eigenvalue);

// The n² x n² matrix K of the Lyapunov operator X -> A X + X A', vec(A X + X A') = K vec(X)
// (column-major vec: K = I ⊗ A + A ⊗ I). The stationary covariance and its derivative
// (A dP + dP A' = -(dA P + P dA' + dG)) solve linear systems with it.
Eigen::MatrixXd LyapunovOperator(const Eigen::MatrixXd& A);

}  // namespace gb::filter
