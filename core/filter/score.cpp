// Sections: 1. derivatives of the discretisation and of P0  2. the sensitivity loop (templated on
//           the state dimension)  3. entry point
#include "core/filter/score.h"

#include <cmath>
#include <complex>
#include <cstdint>
#include <vector>

#include <Eigen/Dense>

#include "core/filter/discretize.h"
#include "core/filter/internal.h"

namespace gb::filter {
namespace {

using internal::FixedDiscrete;
using internal::kLog2Pi;

// ---- 1. derivatives of the discretisation and of P0 ------------------------------------------

Eigen::VectorXd Sigma2Derivative(const model::StateSpace& ss, const model::StateSpace& d) {
  return 2.0 * ss.sigma.cwiseProduct(d.sigma);
}

// dd[g][i]: the derivative of the discretisation of distinct interval g along θ_i.
std::vector<std::vector<Discrete>> DiscretizeDerivatives(const model::StateSpace& ss,
                                                         std::span<const model::StateSpace> dss,
                                                         const data::Series& series,
                                                         model::InputHold hold) {
  const Eigen::VectorXd sigma2 = ss.sigma.array().square();
  std::vector<std::vector<Discrete>> out;
  out.reserve(series.intervals.distinct.size());
  for (double dt : series.intervals.distinct) {
    std::vector<Discrete> per_theta;
    per_theta.reserve(dss.size());
    for (const auto& d : dss)
      per_theta.push_back(DiscretizeDerivative(ss.A, ss.B, ss.c, sigma2, d.A, d.B, d.c,
                                               Sigma2Derivative(ss, d), dt, hold));
    out.push_back(std::move(per_theta));
  }
  return out;
}

}  // namespace

std::vector<Eigen::MatrixXd> InitialCovarianceDerivatives(model::InitialCovariance kind,
                                                          const model::StateSpace& ss,
                                                          std::span<const model::StateSpace> dss,
                                                          const Eigen::MatrixXd& P0,
                                                          std::span<const Discrete> dfirst) {
  const Eigen::Index n = ss.A.rows();
  std::vector<Eigen::MatrixXd> dP0;
  switch (kind) {
    case model::InitialCovariance::kCtsm:
      for (const Discrete& d : dfirst) dP0.push_back(d.Q);
      break;
    case model::InitialCovariance::kStationary: {
      // P0 exists, so A is stable and the operator is invertible.
      const Eigen::PartialPivLU<Eigen::MatrixXd> lu(LyapunovOperator(ss.A));
      for (const auto& d : dss) {
        Eigen::MatrixXd rhs = d.A * P0 + P0 * d.A.transpose();
        rhs.diagonal() += Sigma2Derivative(ss, d);
        const Eigen::VectorXd x = lu.solve(-Eigen::Map<const Eigen::VectorXd>(rhs.data(), n * n));
        Eigen::MatrixXd dP = Eigen::Map<const Eigen::MatrixXd>(x.data(), n, n);
        dP0.push_back(0.5 * (dP + dP.transpose()));
      }
      break;
    }
    case model::InitialCovariance::kExplicit:
      for (const auto& d : dss) dP0.emplace_back(d.P0_diag.asDiagonal());
      break;
  }
  return dP0;
}

namespace {

// ---- 2. the sensitivity loop -----------------------------------------------------------------

struct Context {
  const model::StateSpace& ss;
  std::span<const model::StateSpace> dss;
  const data::Series& series;
  const FilterSettings& settings;
  const std::vector<Discrete>& disc;
  const std::vector<std::vector<Discrete>>& ddisc;  // [group][i]
  const Eigen::MatrixXd& P0;
  const std::vector<Eigen::MatrixXd>& dP0;  // [i]
  const ObservationWindow& window;
};

// Γ0 u_j + Γ1 u_{j+1} (the latter only for FOH), added to x.
template <class Vec, class InMat>
void AddInputs(const InMat& Gamma0, const InMat& Gamma1, const double* u0, int m, bool foh,
               Vec& x) {
  if (m == 1) {  // the common case, without a dynamic-size product
    x.noalias() += Gamma0.col(0) * u0[0];
    if (foh) x.noalias() += Gamma1.col(0) * u0[1];
    return;
  }
  x.noalias() += Gamma0 * Eigen::Map<const Eigen::VectorXd>(u0, m);
  if (foh) x.noalias() += Gamma1 * Eigen::Map<const Eigen::VectorXd>(u0 + m, m);
}

template <int NX>
Result<Loglik> ScoreLoop(const Context& ctx, Eigen::VectorXd* gradient, Eigen::MatrixXd* J) {
  using Mat = Eigen::Matrix<double, NX, NX>;
  using Vec = Eigen::Matrix<double, NX, 1>;
  using Row = Eigen::Matrix<double, 1, NX>;

  const model::StateSpace& ss = ctx.ss;
  const data::Series& series = ctx.series;
  const int n = ss.n_states();
  const int p = ss.n_outputs();
  const int m = ss.n_inputs();
  const int k = static_cast<int>(ctx.dss.size());
  const int N = static_cast<int>(series.size());
  const bool foh = ctx.settings.hold == model::InputHold::kFoh;
  const std::vector<int>& delay = ctx.window.delay;
  const std::vector<int>& first_obs = ctx.window.first_obs;

  std::vector<FixedDiscrete<NX>> disc;
  std::vector<FixedDiscrete<NX>> ddisc;  // [group * k + i]
  for (std::size_t g = 0; g < ctx.disc.size(); ++g) {
    disc.emplace_back(ctx.disc[g]);
    for (const Discrete& d : ctx.ddisc[g]) ddisc.emplace_back(d);
  }
  std::vector<Row> C(p), dC(static_cast<std::size_t>(p) * k);  // dC[o * k + i]
  for (int o = 0; o < p; ++o) {
    C[o] = ss.C.row(o);
    for (int i = 0; i < k; ++i) dC[o * k + i] = ctx.dss[i].C.row(o);
  }

  Vec x = ss.x0;
  Mat P = ctx.P0;
  std::vector<Vec> dx(k);
  std::vector<Mat> dP(k);
  for (int i = 0; i < k; ++i) {
    dx[i] = ctx.dss[i].x0;
    dP[i] = ctx.dP0[i];
  }
  Vec PCt = Vec::Zero(n), dPCt = Vec::Zero(n), x_next = Vec::Zero(n);
  Mat PhiP = Mat::Zero(n, n), PhidP = Mat::Zero(n, n), T = Mat::Zero(n, n);
  Eigen::VectorXd d_term(k), d_logdet(k), d_r2(k);
  gradient->setZero(k);
  if (J) J->setZero(N, k);

  const bool robust = ctx.settings.huber.has_value();
  const double huber = ctx.settings.huber.value_or(0.0);
  const int* group = series.intervals.group.data();
  const double* Y = series.Y.data();
  const double* U = series.U.data();
  const std::atomic<bool>* cancel = ctx.settings.cancel;
  double loglik = 0.0;
  long n_obs = 0;
  // The steady state (kalman.h): once a step returns P and every dP_i to the values it started
  // from, bit for bit, the later steps with the same observations and interval repeat its P c',
  // R, dP_i c' + P dc_i' and dR_i: only the means and their sensitivities are updated.
  const bool can_be_steady = NX != Eigen::Dynamic && p <= 64;
  bool steady = false;
  std::uint64_t rec_mask = 0;
  int rec_group = -1;
  Mat rec_P = Mat::Zero(n, n);
  std::vector<Mat> rec_dP(k);
  std::vector<Vec> rec_PCt(can_be_steady ? p : 0);
  std::vector<double> rec_R(can_be_steady ? p : 0);
  std::vector<Vec> rec_dPCt(can_be_steady ? static_cast<std::size_t>(p) * k : 0);
  std::vector<double> rec_dR(can_be_steady ? static_cast<std::size_t>(p) * k : 0);
  for (int j = 0; j <= ctx.window.last_j; ++j) {
    if (cancel && (j & (internal::kCancelCheckInterval - 1)) == 0 &&
        cancel->load(std::memory_order_relaxed))
      return NumericalError("cancelled");
    const double* u = U + static_cast<std::size_t>(j) * m;
    double r2 = 0.0, logdet = 0.0;
    d_logdet.setZero();
    d_r2.setZero();
    int p_j = 0;
    if (can_be_steady) {
      std::uint64_t mask = 0;
      for (int o = 0; o < p; ++o) {
        const int row = j + delay[o];
        if (row >= N || row < first_obs[o]) continue;
        if (!std::isnan(Y[static_cast<std::size_t>(row) * p + o])) mask |= std::uint64_t{1} << o;
      }
      const int group_j = j == N - 1 ? -1 : group[j];
      steady = steady && mask == rec_mask && group_j == rec_group;
      if (!steady) {
        rec_mask = mask;
        rec_group = group_j;
        rec_P = P;
        for (int i = 0; i < k; ++i) rec_dP[i] = dP[i];
      }
    }
    for (int o = 0; o < p; ++o) {
      const int row = j + delay[o];
      if (row >= N || row < first_obs[o]) continue;
      const double y = Y[static_cast<std::size_t>(row) * p + o];
      if (std::isnan(y)) continue;
      double yhat = C[o].dot(x) + ss.d(o);
      for (int l = 0; l < m; ++l) yhat += ss.D(o, l) * u[l];
      double R;
      if (steady) {
        PCt = rec_PCt[p_j];
        R = rec_R[p_j];
      } else {
        PCt.noalias() = P * C[o].transpose();
        R = C[o].dot(PCt) + ss.S(o);
        if (!(R > 0.0)) return internal::NotPositiveInnovationVariance(series, o, row, R);
        if (can_be_steady) rec_PCt[p_j] = PCt, rec_R[p_j] = R;
      }
      const double eps = y - yhat;
      for (int i = 0; i < k; ++i) {
        const model::StateSpace& d = ctx.dss[i];
        const Row& dc = dC[o * k + i];
        double dyhat = dc.dot(x) + C[o].dot(dx[i]) + d.d(o);
        for (int l = 0; l < m; ++l) dyhat += d.D(o, l) * u[l];
        const std::size_t at = static_cast<std::size_t>(p_j) * k + i;
        double dR;
        if (steady) {
          dPCt = rec_dPCt[at];
          dR = rec_dR[at];
        } else {
          dPCt.noalias() = dP[i] * C[o].transpose();
          dPCt.noalias() += P * dc.transpose();
          dR = dc.dot(PCt) + C[o].dot(dPCt) + d.S(o);
          if (can_be_steady) rec_dPCt[at] = dPCt, rec_dR[at] = dR;
          dP[i].noalias() -= (dPCt * PCt.transpose() + PCt * dPCt.transpose()) / R;
          dP[i].noalias() += PCt * PCt.transpose() * (dR / (R * R));
        }
        const double deps = -dyhat;
        d_logdet(i) += dR / R;
        d_r2(i) += (2.0 * eps * deps - eps * eps * dR / R) / R;
        dx[i].noalias() += dPCt * (eps / R) + PCt * ((deps - eps * dR / R) / R);
      }
      logdet += std::log(R);
      r2 += eps * eps / R;
      ++p_j;
      x.noalias() += PCt * (eps / R);
      if (!steady) P.noalias() -= (1.0 / R) * PCt * PCt.transpose();
    }
    if (p_j > 0) {
      double d_rho = 0.5;
      const double rho = internal::HuberRho(r2, robust, huber, &d_rho);
      loglik -= 0.5 * (logdet + p_j * kLog2Pi) + rho;
      n_obs += p_j;
      d_term = -(0.5 * d_logdet + d_rho * d_r2);
      *gradient += d_term;
      if (J) J->row(j) = d_term.transpose();
    }
    if (j == N - 1) break;
    // Time update to t_{j+1}: the sensitivities first, as they read the old x and P.
    const FixedDiscrete<NX>& dd = disc[group[j]];
    if (!steady) PhiP.noalias() = dd.Phi * P;
    for (int i = 0; i < k; ++i) {
      const FixedDiscrete<NX>& ddi = ddisc[static_cast<std::size_t>(group[j]) * k + i];
      x_next.noalias() = ddi.Phi * x;
      x_next.noalias() += dd.Phi * dx[i];
      x_next += ddi.g;
      if (m > 0) AddInputs(ddi.Gamma0, ddi.Gamma1, u, m, foh, x_next);
      dx[i] = x_next;
      if (steady) continue;                      // dP_i is rec_dP[i] again
      T.noalias() = ddi.Phi * PhiP.transpose();  // dΦ P Φ' (P symmetric)
      PhidP.noalias() = dd.Phi * dP[i];
      dP[i].noalias() = PhidP * dd.Phi.transpose();
      dP[i] += T + T.transpose() + ddi.Q;
      internal::Symmetrize(dP[i]);
    }
    x_next.noalias() = dd.Phi * x;
    x_next += dd.g;
    if (m > 0) AddInputs(dd.Gamma0, dd.Gamma1, u, m, foh, x_next);
    x = x_next;
    if (steady) continue;  // P is rec_P again
    P.noalias() = PhiP * dd.Phi.transpose();
    P += dd.Q;
    internal::Symmetrize(P);
    if (can_be_steady) {
      steady = P == rec_P;
      for (int i = 0; i < k && steady; ++i) steady = dP[i] == rec_dP[i];
    }
  }
  if (!std::isfinite(loglik) || !gradient->allFinite()) return internal::NotFiniteLoglik(series);
  return Loglik{loglik, n_obs};
}

}  // namespace

// ---- 3. entry point --------------------------------------------------------------------------

Result<Loglik> LogLikelihoodScore(const model::StateSpace& ss,
                                  std::span<const model::StateSpace> dss,
                                  const data::Series& series, const FilterSettings& settings,
                                  Eigen::VectorXd* gradient, Eigen::MatrixXd* J_terms_theta) {
  assert(gradient != nullptr);
  assert(series.U.rows() == ss.n_inputs() && series.Y.rows() == ss.n_outputs() &&
         "series bound to the model");
  auto window = ObservationWindowOf(series, ss.n_outputs(), settings);
  if (!window) return window.error();
  const auto disc = DiscretizeIntervals(ss, series, settings.hold);
  if (!disc) return disc.error();
  auto P0 = settings.initial_covariance == model::InitialCovariance::kCtsm
                ? Result<Eigen::MatrixXd>((*disc)[series.intervals.group[0]].Q)
                : InitialCovariance(ss, series, settings);
  if (!P0) return P0.error();
  const auto ddisc = DiscretizeDerivatives(ss, dss, series, settings.hold);
  const auto dP0 = InitialCovarianceDerivatives(settings.initial_covariance, ss, dss, *P0,
                                                ddisc[series.intervals.group[0]]);
  const Context ctx{ss, dss, series, settings, *disc, ddisc, *P0, dP0, *window};
  return internal::WithStateDimension(ctx.ss.n_states(), [&](auto nx) {
    return ScoreLoop<decltype(nx)::value>(ctx, gradient, J_terms_theta);
  });
}

}  // namespace gb::filter
