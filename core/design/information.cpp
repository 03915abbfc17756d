#include "core/design/information.h"

#include <cassert>
#include <cmath>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <fmt/format.h>

#include "core/filter/discretize.h"
#include "core/filter/score.h"

namespace gb::design {

namespace {

// The joint vector z = [x; x̂; ∂_1 x̂; ...; ∂_k x̂]: its mean (n x (k + 2), block b a column) and
// the covariance of its fluctuation (n (k + 2) square). Block 0 is the true state, 1 the filter's
// mean, 2 + i the sensitivity along θ_i.
struct Joint {
  Eigen::MatrixXd mean;
  Eigen::MatrixXd cov;
  int n = 0;
};

// The filter's own covariance P and its derivatives dP_i.
struct Riccati {
  Eigen::MatrixXd P;
  std::vector<Eigen::MatrixXd> dP;
};

// One scalar observation of output o: adds its expected information to *I (and the mean part to
// *I_input), then updates the filter (x̂, ∂x̂ and P, dP) and the joint moments, as score.h's
// measurement update does with y = c x + D_o u + d_o + e.
void MeasurementUpdate(const model::StateSpace& ss, std::span<const model::StateSpace> dss, int o,
                       const Eigen::VectorXd& u, Joint* z, Riccati* f, Eigen::MatrixXd* I,
                       Eigen::MatrixXd* I_input, double* R_out) {
  const int n = z->n;
  const int k = static_cast<int>(dss.size());
  const int nz = n * (k + 2);
  const Eigen::RowVectorXd c = ss.C.row(o);
  const Eigen::VectorXd gain = f->P * c.transpose();
  const double R = c.dot(gain) + ss.S(o);
  *R_out = R;
  Eigen::MatrixXd dgain(n, k);
  Eigen::VectorXd dR(k), m_eps(k);
  const double eps_mean = c.dot(z->mean.col(0) - z->mean.col(1));
  for (int i = 0; i < k; ++i) {
    const Eigen::RowVectorXd dc = dss[i].C.row(o);
    dgain.col(i) = f->dP[i] * c.transpose() + f->P * dc.transpose();
    dR(i) = dc.dot(gain) + c.dot(dgain.col(i)) + dss[i].S(o);
    m_eps(i) = -(dc.dot(z->mean.col(1)) + c.dot(z->mean.col(2 + i)) + dss[i].d(o));
    if (u.size() > 0) m_eps(i) -= dss[i].D.row(o).dot(u);
  }
  // The fluctuations: ε = w0' z + e and ∂_i ε = l_i' z (W = [w0, l_1 .. l_k]).
  Eigen::MatrixXd W = Eigen::MatrixXd::Zero(nz, k + 1);
  W.col(0).segment(0, n) = c.transpose();
  W.col(0).segment(n, n) = -c.transpose();
  for (int i = 0; i < k; ++i) {
    W.col(1 + i).segment(n, n) = -dss[i].C.row(o).transpose();
    W.col(1 + i).segment(static_cast<Eigen::Index>(2 + i) * n, n) = -c.transpose();
  }
  const Eigen::MatrixXd ZW = z->cov * W;
  const Eigen::MatrixXd WZW = W.transpose() * ZW;
  const Eigen::MatrixXd cov_deps = WZW.bottomRightCorner(k, k);
  const Eigen::MatrixXd mean_part = m_eps * m_eps.transpose() / R;
  *I_input += mean_part;
  *I += mean_part + cov_deps / R + 0.5 * dR * dR.transpose() / (R * R);

  // z⁺ = (I + A W') z + a0 e: A's column 0 carries ε's gains, column 1 + i the k/R that ∂_i ε
  // adds to ∂_i x̂.
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(nz, k + 1);
  A.col(0).segment(n, n) = gain / R;
  for (int i = 0; i < k; ++i) {
    const auto rows = static_cast<Eigen::Index>(2 + i) * n;
    A.col(0).segment(rows, n) = dgain.col(i) / R - gain * dR(i) / (R * R);
    A.col(1 + i).segment(rows, n) = gain / R;
  }
  const Eigen::MatrixXd AZW = A * ZW.transpose();
  z->cov +=
      AZW + AZW.transpose() + A * WZW * A.transpose() + ss.S(o) * A.col(0) * A.col(0).transpose();
  z->cov = 0.5 * (z->cov + z->cov.transpose()).eval();
  // The means (the measurement's mean is c x + D_o u + d_o, so E[ε] = c (x - x̂)).
  for (int i = 0; i < k; ++i)
    z->mean.col(2 + i) +=
        dgain.col(i) * eps_mean / R + gain * (m_eps(i) / R - eps_mean * dR(i) / (R * R));
  z->mean.col(1) += gain * eps_mean / R;
  // The filter's covariance.
  for (int i = 0; i < k; ++i)
    f->dP[i] += -(dgain.col(i) * gain.transpose() + gain * dgain.col(i).transpose()) / R +
                gain * gain.transpose() * dR(i) / (R * R);
  f->P -= gain * gain.transpose() / R;
}

// The time update over one interval: x' = Φ x + Γ0 u + Γ1 u⁺ + g + v, x̂' likewise without v,
// ∂_i x̂' = ∂Φ x̂ + Φ ∂_i x̂ + ∂Γ0 u + ∂Γ1 u⁺ + ∂g; P' = Φ P Φ' + Q and its derivatives.
void TimeUpdate(const filter::Discrete& d, std::span<const filter::Discrete> dd,
                const Eigen::VectorXd& u, const Eigen::VectorXd& u_next, bool foh, Joint* z,
                Riccati* f) {
  const int n = z->n;
  const int k = static_cast<int>(dd.size());
  const int blocks = k + 2;
  auto drive = [&](const filter::Discrete& m) {
    Eigen::VectorXd v = m.g;
    if (u.size() > 0) {
      v += m.Gamma0 * u;
      if (foh) v += m.Gamma1 * u_next;
    }
    return v;
  };
  Eigen::MatrixXd mean(n, blocks);
  mean.col(0) = d.Phi * z->mean.col(0) + drive(d);
  mean.col(1) = d.Phi * z->mean.col(1) + drive(d);
  for (int i = 0; i < k; ++i)
    mean.col(2 + i) = dd[i].Phi * z->mean.col(1) + d.Phi * z->mean.col(2 + i) + drive(dd[i]);
  z->mean = mean;
  // cov' = T cov T' + [Q 0; 0 0], T = blockdiag(Φ) + (∂Φ_i in block row 2 + i, column 1).
  auto apply_rows = [&](const Eigen::MatrixXd& M) {
    Eigen::MatrixXd out(M.rows(), M.cols());
    for (int b = 0; b < blocks; ++b) {
      const auto rows = static_cast<Eigen::Index>(b) * n;
      out.middleRows(rows, n) = d.Phi * M.middleRows(rows, n);
      if (b >= 2) out.middleRows(rows, n) += dd[b - 2].Phi * M.middleRows(n, n);
    }
    return out;
  };
  const Eigen::MatrixXd half = apply_rows(z->cov);
  z->cov = apply_rows(half.transpose()).transpose();
  z->cov.topLeftCorner(n, n) += d.Q;
  z->cov = 0.5 * (z->cov + z->cov.transpose()).eval();
  for (int i = 0; i < k; ++i) {
    const Eigen::MatrixXd T = dd[i].Phi * f->P * d.Phi.transpose();
    f->dP[i] = d.Phi * f->dP[i] * d.Phi.transpose() + T + T.transpose() + dd[i].Q;
  }
  f->P = d.Phi * f->P * d.Phi.transpose() + d.Q;
  f->P = 0.5 * (f->P + f->P.transpose()).eval();
}

// I⁻¹ and the standard errors where I is positive definite; else the parameter that the
// weakest direction of the correlation form involves most.
void Invert(ExpectedInformation* out) {
  const Eigen::MatrixXd& I = out->information;
  const auto k = I.rows();
  out->std_error.assign(static_cast<std::size_t>(k), std::nullopt);
  if (k == 0) return;
  const Eigen::VectorXd diag = I.diagonal();
  if ((diag.array() <= 0).any() || !diag.allFinite()) {
    Eigen::Index i = 0;
    diag.minCoeff(&i);
    out->undetermined = static_cast<int>(i);
    return;
  }
  const Eigen::VectorXd scale = diag.cwiseSqrt().cwiseInverse();
  const Eigen::MatrixXd corr = scale.asDiagonal() * I * scale.asDiagonal();
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(corr);
  if (eig.info() != Eigen::Success || eig.eigenvalues()(0) <= kSingular) {
    Eigen::Index i = 0;
    if (eig.info() == Eigen::Success) eig.eigenvectors().col(0).cwiseAbs().maxCoeff(&i);
    out->undetermined = static_cast<int>(i);
    return;
  }
  const Eigen::MatrixXd corr_inv = eig.eigenvectors() *
                                   eig.eigenvalues().cwiseInverse().asDiagonal() *
                                   eig.eigenvectors().transpose();
  out->covariance = scale.asDiagonal() * corr_inv * scale.asDiagonal();
  for (Eigen::Index i = 0; i < k; ++i)
    out->std_error[static_cast<std::size_t>(i)] = std::sqrt(out->covariance(i, i));
}

}  // namespace

Result<ExpectedInformation> ExpectedFisherInformation(const model::LinearModel& model,
                                                      std::span<const double> theta,
                                                      std::span<const int> parameters,
                                                      const data::Series& series,
                                                      const filter::FilterSettings& settings) {
  assert(series.U.rows() == model.n_inputs() && series.Y.rows() == model.n_outputs() &&
         "series bound to the model");
  auto ss = model.Evaluate(theta);
  if (!ss) return ss.error();
  auto dss = model.EvaluateJacobian(theta, parameters);
  if (!dss) return dss.error();
  auto window = filter::ObservationWindowOf(series, ss->n_outputs(), settings);
  if (!window) return window.error();
  const auto disc = filter::DiscretizeIntervals(*ss, series, settings.hold);
  if (!disc) return disc.error();
  auto P0 = settings.initial_covariance == model::InitialCovariance::kCtsm
                ? Result<Eigen::MatrixXd>((*disc)[series.intervals.group[0]].Q)
                : filter::InitialCovariance(*ss, series, settings);
  if (!P0) return P0.error();

  const int n = ss->n_states();
  const int p = ss->n_outputs();
  const int k = static_cast<int>(parameters.size());
  const int N = static_cast<int>(series.size());
  const bool foh = settings.hold == model::InputHold::kFoh;
  const Eigen::VectorXd sigma2 = ss->sigma.array().square();
  // ∂(discretisation)/∂θ_i for every distinct interval: ddisc[g][i].
  std::vector<std::vector<filter::Discrete>> ddisc;
  for (double dt : series.intervals.distinct) {
    std::vector<filter::Discrete> per_theta;
    for (const auto& d : *dss)
      per_theta.push_back(filter::DiscretizeDerivative(ss->A, ss->B, ss->c, sigma2, d.A, d.B, d.c,
                                                       2.0 * ss->sigma.cwiseProduct(d.sigma), dt,
                                                       settings.hold));
    ddisc.push_back(std::move(per_theta));
  }
  Riccati f;
  f.P = *P0;
  f.dP = filter::InitialCovarianceDerivatives(settings.initial_covariance, *ss, *dss, *P0,
                                              ddisc[series.intervals.group[0]]);
  Joint z;
  z.n = n;
  z.mean = Eigen::MatrixXd::Zero(n, k + 2);
  z.mean.col(0) = ss->x0;
  z.mean.col(1) = ss->x0;
  for (int i = 0; i < k; ++i) z.mean.col(2 + i) = (*dss)[i].x0;
  const Eigen::Index nz = static_cast<Eigen::Index>(n) * (k + 2);
  z.cov = Eigen::MatrixXd::Zero(nz, nz);
  z.cov.topLeftCorner(n, n) = *P0;

  ExpectedInformation out;
  out.parameters.assign(parameters.begin(), parameters.end());
  out.information = Eigen::MatrixXd::Zero(k, k);
  out.from_input = Eigen::MatrixXd::Zero(k, k);
  for (int j = 0; j <= window->last_j; ++j) {
    if (settings.cancel && settings.cancel->load()) return NumericalError("cancelled");
    const Eigen::VectorXd u = series.U.col(j);
    for (int o = 0; o < p; ++o) {
      const int row = j + window->delay[o];
      if (row >= N || row < window->first_obs[o] || !std::isfinite(series.Y(o, row))) continue;
      double R = 0;
      MeasurementUpdate(*ss, *dss, o, u, &z, &f, &out.information, &out.from_input, &R);
      if (!(R > 0) || !std::isfinite(R))
        return data::AtRow(
            NumericalError(fmt::format("the innovation variance of output {} is not positive "
                                       "({}) in the expected information",
                                       o + 1, R)),
            series, row);
      ++out.n_obs;
    }
    if (j == N - 1 || j == window->last_j) break;
    const int g = series.intervals.group[j];
    TimeUpdate((*disc)[g], ddisc[g], u, series.U.col(j + 1), foh, &z, &f);
  }
  if (!out.information.allFinite())
    return NumericalError("the expected information is not finite at these parameter values");
  out.information = 0.5 * (out.information + out.information.transpose()).eval();
  Invert(&out);
  return out;
}

}  // namespace gb::design
