#include "core/filter/ekf_score.h"

#include <cmath>
#include <vector>

#include "core/filter/ekf.h"
#include "core/filter/internal.h"
#include "core/filter/moments.h"

namespace gb::filter {

using internal::kLog2Pi;

Result<Loglik> EkfLogLikelihoodWithScore(const model::NonlinearModel& model,
                                         const model::NonlinearSensitivity& sensitivity,
                                         std::span<const double> theta,
                                         const data::Series& series,
                                         const FilterSettings& settings, std::span<const int> free,
                                         Eigen::VectorXd* gradient, Eigen::MatrixXd* J_terms,
                                         OdeCounts* counts) {
  const int n = model.n_states();
  const int p = model.n_outputs();
  const int np = model.n_parameters();
  const int N = static_cast<int>(series.size());
  const int K = static_cast<int>(free.size());
  assert(model.spec().ekf.iterations == 1 && "the iterated EKF has no exact score here");
  assert(gradient != nullptr);
  auto window = ObservationWindowOf(series, p, settings);
  if (!window) return window.error();
  MomentPropagator propagator(model, theta, series, settings.hold, false, &sensitivity, free);
  Eigen::VectorXd x;
  Eigen::MatrixXd P;
  MomentSensitivities ds;
  if (auto s = propagator.Initial(settings.initial_covariance, &x, &P, &ds); !s) return s.error();
  if (K == 0) {  // the initial sensitivities were sized by Initial; keep the shapes consistent
    ds.x.resize(n, 0);
    ds.P.clear();
  }

  gradient->setZero(K);
  if (J_terms) J_terms->setZero(N, K);

  std::vector<double> meas(model.measurement_size());
  std::vector<double> dmeas = sensitivity.measurement().Zeroed();
  auto H_row = [&](int o) {
    return Eigen::Map<const Eigen::RowVectorXd>(meas.data() + p + static_cast<std::ptrdiff_t>(o) * n, n);
  };
  auto S_of = [&](int o) { return meas[p + p * n + o]; };
  const Eigen::Map<const Eigen::MatrixXd> h_theta(dmeas.data(), p, np);
  const Eigen::Map<const Eigen::MatrixXd> S_theta(dmeas.data() + sensitivity.MeasStheta(), p, np);
  auto Hx = [&](int m) {
    return Eigen::Map<const Eigen::MatrixXd>(dmeas.data() + sensitivity.MeasHx(m), p, n);
  };
  auto Htheta = [&](int l) {
    return Eigen::Map<const Eigen::MatrixXd>(dmeas.data() + sensitivity.MeasHtheta(l), p, n);
  };

  const double huber = settings.huber.value_or(0.0);
  const bool robust = settings.huber.has_value();
  const double* Y = series.Y.data();
  double loglik = 0.0;
  long n_obs = 0;
  std::vector<int> observed;
  Eigen::VectorXd x_prior(n), PHt(n), dk(n);
  Eigen::MatrixXd dx_prior(n, K);
  Eigen::RowVectorXd dH(n);
  Eigen::VectorXd dlogdet(K), dr2(K), dyhat(K), dR(K);
  Eigen::MatrixXd dks(n, K);
  for (int j = 0; j <= window->last_j; ++j) {
    if (settings.cancel && settings.cancel->load(std::memory_order_relaxed))
      return NumericalError("cancelled");
    internal::ObservedAt(j, series, *window, &observed);
    if (!observed.empty()) {
      if (auto s = propagator.Measure(j, x, meas); !s) return s.error();
      if (auto s = propagator.MeasureSensitivities(j, x, dmeas); !s) return s.error();
      x_prior = x;
      dx_prior = ds.x;
      double r2 = 0.0, logdet = 0.0;
      dlogdet.setZero();
      dr2.setZero();
      for (const int o : observed) {
        const double y = Y[static_cast<std::size_t>(j + window->delay[o]) * p + o];
        const auto H = H_row(o);
        const double yhat = meas[o] + H.dot(x - x_prior);
        PHt.noalias() = P * H.transpose();
        const double R = H.dot(PHt) + S_of(o);
        if (!(R > 0.0))
          return internal::NotPositiveInnovationVariance(series, o, j + window->delay[o], R);
        const double eps = y - yhat;
        // The derivatives of this scalar update, from the values before it.
        for (int q = 0; q < K; ++q) {
          const int l = free[q];
          dH = Htheta(l).row(o);
          for (int m = 0; m < n; ++m) dH.noalias() += dx_prior(m, q) * Hx(m).row(o);
          const double dh = H.dot(dx_prior.col(q)) + h_theta(o, l);
          dyhat(q) = dh + dH.dot(x - x_prior) + H.dot(ds.x.col(q) - dx_prior.col(q));
          dk.noalias() = ds.P[q] * H.transpose();
          dk.noalias() += P * dH.transpose();
          dks.col(q) = dk;
          dR(q) = dH.dot(PHt) + H.dot(dk) + S_theta(o, l);
        }
        for (int q = 0; q < K; ++q) {
          const double deps = -dyhat(q);
          ds.x.col(q) += dks.col(q) * (eps / R) + PHt * (deps / R) - PHt * (eps * dR(q) / (R * R));
          ds.P[q].noalias() -= (dks.col(q) * PHt.transpose() + PHt * dks.col(q).transpose()) / R;
          ds.P[q].noalias() += (dR(q) / (R * R)) * PHt * PHt.transpose();
          dlogdet(q) += dR(q) / R;
          dr2(q) += 2.0 * eps * deps / R - eps * eps * dR(q) / (R * R);
        }
        logdet += std::log(R);
        r2 += eps * eps / R;
        x.noalias() += PHt * (eps / R);
        P.noalias() -= (1.0 / R) * PHt * PHt.transpose();
      }
      double drho_dr2 = 0.5;
      const double rho = internal::HuberRho(r2, robust, huber, &drho_dr2);
      const double term = -(0.5 * (logdet + static_cast<double>(observed.size()) * kLog2Pi) + rho);
      loglik += term;
      n_obs += static_cast<long>(observed.size());
      for (int q = 0; q < K; ++q) {
        const double dterm = -(0.5 * dlogdet(q) + drho_dr2 * dr2(q));
        (*gradient)(q) += dterm;
        if (J_terms) (*J_terms)(j, q) = dterm;
      }
    }
    if (j == N - 1) break;
    if (j == window->last_j) break;  // nothing later is observed
    if (auto s = propagator.Advance(j, &x, &P, nullptr, &ds); !s) return s.error();
  }
  if (counts) *counts += propagator.counts();
  if (!std::isfinite(loglik)) return internal::NotFiniteLoglik(series);
  if (!gradient->allFinite())
    return NumericalError("the derivatives of the log-likelihood are not finite");
  return Loglik{loglik, n_obs};
}

}  // namespace gb::filter
