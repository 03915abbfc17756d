#include "core/filter/ekf.h"

#include <cmath>
#include <optional>

#include <Eigen/Core>
#include <fmt/format.h>

#include "core/filter/ekf_score.h"
#include "core/filter/internal.h"
#include "core/filter/moments.h"

namespace gb::filter {
namespace {

struct Run {
  const model::NonlinearModel& model;
  std::span<const double> theta;
  const data::Series& series;
  const FilterSettings& settings;
  std::vector<double>* terms;
  FilterTrace* trace;
  OdeCounts* counts;

  Result<Loglik> operator()() const;
};

Result<Loglik> Run::operator()() const {
  const int n = model.n_states();
  const int p = model.n_outputs();
  const int N = static_cast<int>(series.size());
  assert(series.U.rows() == model.n_inputs() && series.Y.rows() == p &&
         "series bound to the model");
  assert(static_cast<int>(theta.size()) == model.n_parameters());
  auto window = ObservationWindowOf(series, p, settings);
  if (!window) return window.error();
  const model::EkfOptions& options = model.spec().ekf;
  MomentPropagator propagator(model, theta, series, settings.hold);
  Eigen::VectorXd x;
  Eigen::MatrixXd P;
  if (auto s = propagator.Initial(settings.initial_covariance, &x, &P); !s) return s.error();
  settings.OverrideInitial(&x, &P);

  if (trace) internal::ResetTrace(n, p, N, trace);
  if (terms) terms->assign(N, 0.0);

  std::vector<double> meas(model.measurement_size());
  auto measure = [&](int j, const Eigen::VectorXd& at) { return propagator.Measure(j, at, meas); };
  auto H_row = [&](int o) {
    return Eigen::Map<const Eigen::RowVectorXd>(
        meas.data() + p + static_cast<std::ptrdiff_t>(o) * n, n);
  };
  auto S_of = [&](int o) { return meas[p + p * n + o]; };

  const int j_end = trace ? N - 1 : window->last_j;
  const double* Y = series.Y.data();
  double loglik = 0.0;
  long n_obs = 0;
  const internal::ObservationRule rule(series, *window);
  internal::ObservedOutputs observed(rule.p());  // outputs observed at j
  Eigen::VectorXd x_prior(n), x_lin(n), PHt(n);
  Eigen::MatrixXd P_prior(n, n);
  std::vector<double> h_lin(p);
  Eigen::MatrixXd H_lin(p, n);
  for (int j = 0; j <= j_end; ++j) {
    if (settings.cancel && settings.cancel->load(std::memory_order_relaxed))
      return NumericalError("cancelled");
    internal::ObservedAt(j, rule, &observed);
    if (trace) {
      trace->x_pred.col(j) = x;
      trace->P_pred[j] = P;
    }
    if (!observed.empty() || trace) {
      if (auto s = measure(j, x); !s) return s.error();
    }
    if (trace) {
      for (int o = 0; o < p; ++o) {
        const int k = j + window->delay[o];
        if (k >= N) continue;
        trace->y_pred(o, k) = meas[o];
        trace->y_var(o, k) = (H_row(o) * P * H_row(o).transpose()).value() + S_of(o);
      }
    }
    if (!observed.empty()) {
      x_prior = x;
      P_prior = P;
      double r2 = 0.0, logdet = 0.0;
      // Pass 1: the EKF, linearised at the prior; it gives the likelihood term.
      for (const int o : observed) {
        const int k = j + window->delay[o];
        double eps, R;
        if (!internal::ScalarUpdate(Y[static_cast<std::size_t>(k) * p + o], meas[o], H_row(o),
                                    S_of(o), x_prior, &x, &P, &PHt, &eps, &R))
          return internal::NotPositiveInnovationVariance(series, o, k, R);
        logdet += std::log(R);
        r2 += eps * eps / R;
      }
      // Passes 2..K: the iterated EKF, re-linearised at the latest mean.
      for (int pass = 2; pass <= options.iterations; ++pass) {
        x_lin = x;
        if (auto s = measure(j, x_lin); !s) return s.error();
        for (int o = 0; o < p; ++o) h_lin[o] = meas[o];
        for (int o = 0; o < p; ++o) H_lin.row(o) = H_row(o);
        x = x_prior;
        P = P_prior;
        for (const int o : observed) {
          const int k = j + window->delay[o];
          double eps, R;
          if (!internal::ScalarUpdate(Y[static_cast<std::size_t>(k) * p + o], h_lin[o],
                                      H_lin.row(o), S_of(o), x_lin, &x, &P, &PHt, &eps, &R))
            return internal::NotPositiveInnovationVariance(series, o, k, R);
        }
        if ((x - x_lin).norm() <= 1e-10 * (1.0 + x.norm())) break;
      }
      const double term = internal::LoglikTerm(logdet, observed.size(), r2, settings.huber);
      loglik += term;
      n_obs += observed.size();
      if (terms) (*terms)[j] = term;
    }
    if (trace) {
      trace->x_filt.col(j) = x;
      trace->P_filt[j] = P;
    }
    if (j == N - 1) break;
    // Time update: the moment equations over [t_j, t_{j+1}].
    if (auto s = propagator.Advance(j, &x, &P); !s) return s.error();
  }
  if (counts) *counts += propagator.counts();
  if (!std::isfinite(loglik)) return internal::NotFiniteLoglik(series);
  return Loglik{loglik, n_obs};
}

}  // namespace

Result<Loglik> EkfLogLikelihood(const model::NonlinearModel& model, std::span<const double> theta,
                                const data::Series& series, const FilterSettings& settings,
                                std::vector<double>* terms, OdeCounts* counts) {
  return Run{model, theta, series, settings, terms, nullptr, counts}();
}

Result<Loglik> EkfRunFilter(const model::NonlinearModel& model, std::span<const double> theta,
                            const data::Series& series, const FilterSettings& settings,
                            FilterTrace* trace, OdeCounts* counts) {
  assert(trace != nullptr);
  return Run{model, theta, series, settings, nullptr, trace, counts}();
}

}  // namespace gb::filter
