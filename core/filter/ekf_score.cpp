#include "core/filter/ekf_score.h"

#include <cmath>
#include <vector>

#include "core/filter/ekf.h"
#include "core/filter/internal.h"
#include "core/filter/moments.h"

namespace gb::filter {

Result<Loglik> EkfLogLikelihoodWithScore(const model::NonlinearModel& model,
                                         const model::NonlinearSensitivity& sensitivity,
                                         std::span<const double> theta, const data::Series& series,
                                         const FilterSettings& settings, std::span<const int> free,
                                         Eigen::VectorXd* gradient, Eigen::MatrixXd* J_terms,
                                         OdeCounts* counts) {
  const int n = model.n_states();
  const int p = model.n_outputs();
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
    return Eigen::Map<const Eigen::RowVectorXd>(
        meas.data() + p + static_cast<std::ptrdiff_t>(o) * n, n);
  };
  auto S_of = [&](int o) { return meas[p + p * n + o]; };
  const internal::MeasurementDerivatives derivatives{&sensitivity, dmeas, p, n};

  const double* Y = series.Y.data();
  double loglik = 0.0;
  long n_obs = 0;
  const internal::ObservationRule rule(series, *window);
  internal::ObservedOutputs observed(rule.p());
  internal::ScoreUpdate update;
  for (int j = 0; j <= window->last_j; ++j) {
    if (settings.cancel && settings.cancel->load(std::memory_order_relaxed))
      return NumericalError("cancelled");
    internal::ObservedAt(j, rule, &observed);
    if (!observed.empty()) {
      if (auto s = propagator.Measure(j, x, meas); !s) return s.error();
      if (auto s = propagator.MeasureSensitivities(j, x, dmeas); !s) return s.error();
      update.Begin(x, ds, K);
      double r2 = 0.0, logdet = 0.0;
      for (const int o : observed) {
        const double y = Y[static_cast<std::size_t>(j + window->delay[o]) * p + o];
        double eps = 0.0, R = 0.0;
        if (!internal::ScalarUpdateWithScores(o, y, meas[o], H_row(o), S_of(o), derivatives, free,
                                              false, &x, &P, &ds, &update, &eps, &R))
          return internal::NotPositiveInnovationVariance(series, o, j + window->delay[o], R);
        logdet += std::log(R);
        r2 += eps * eps / R;
      }
      const int p_j = observed.size();
      double drho_dr2 = 0.5;
      loglik += internal::LoglikTerm(logdet, p_j, r2, settings.huber, &drho_dr2);
      n_obs += p_j;
      for (int q = 0; q < K; ++q) {
        const double dterm = internal::TermDerivative(update.dlogdet(q), update.dr2(q), drho_dr2);
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

namespace internal {

void ScoreUpdate::Begin(const Eigen::VectorXd& x, const MomentSensitivities& ds, int K) {
  const auto n = x.size();
  x_prior = x;
  dx_prior = ds.x;
  dlogdet.setZero(K);
  dr2.setZero(K);
  information.setZero(K, K);
  PHt.resize(n);
  dk.resize(n);
  dyhat.resize(K);
  dR.resize(K);
  dks.resize(n, K);
  dH.resize(n);
}

bool ScalarUpdateWithScores(int o, double y, double h_o,
                            const Eigen::Ref<const Eigen::RowVectorXd>& H, double S_o,
                            const MeasurementDerivatives& d, std::span<const int> free,
                            bool information, Eigen::VectorXd* x, Eigen::MatrixXd* P,
                            MomentSensitivities* ds, ScoreUpdate* u, double* eps, double* R) {
  const int n = d.n;
  const int K = static_cast<int>(free.size());
  const double e = ScalarInnovation(y, h_o, H, S_o, u->x_prior, *x, *P, &u->PHt, R);
  if (!(*R > 0.0)) return false;
  const double r = *R;
  *eps = e;
  // The derivatives of this scalar update, from the values before it.
  for (int q = 0; q < K; ++q) {
    const int l = free[q];
    u->dH = d.Htheta(l).row(o);
    for (int m = 0; m < n; ++m) u->dH.noalias() += u->dx_prior(m, q) * d.Hx(m).row(o);
    const double dh = H.dot(u->dx_prior.col(q)) + d.h_theta(o, l);
    u->dyhat(q) = dh + u->dH.dot(*x - u->x_prior) + H.dot(ds->x.col(q) - u->dx_prior.col(q));
    u->dk.noalias() = ds->P[q] * H.transpose();
    u->dk.noalias() += *P * u->dH.transpose();
    u->dks.col(q) = u->dk;
    u->dR(q) = u->dH.dot(u->PHt) + H.dot(u->dk) + d.S_theta(o, l);
  }
  for (int q = 0; q < K; ++q) {
    const double deps = -u->dyhat(q);
    ds->x.col(q) +=
        u->dks.col(q) * (e / r) + u->PHt * (deps / r) - u->PHt * (e * u->dR(q) / (r * r));
    ds->P[q].noalias() -=
        (u->dks.col(q) * u->PHt.transpose() + u->PHt * u->dks.col(q).transpose()) / r;
    ds->P[q].noalias() += (u->dR(q) / (r * r)) * u->PHt * u->PHt.transpose();
    u->dlogdet(q) += u->dR(q) / r;
    u->dr2(q) += 2.0 * e * deps / r - e * e * u->dR(q) / (r * r);
  }
  if (information && K > 0) {
    u->information.noalias() += u->dyhat * u->dyhat.transpose() / r;
    u->information.noalias() += 0.5 * u->dR * u->dR.transpose() / (r * r);
  }
  ScalarCorrection(u->PHt, e, r, x, P);
  return true;
}

}  // namespace internal

}  // namespace gb::filter
