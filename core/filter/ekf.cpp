#include "core/filter/ekf.h"

#include <cmath>
#include <limits>
#include <optional>

#include <Eigen/Core>
#include <fmt/format.h>

#include "core/filter/internal.h"
#include "core/filter/moments.h"

namespace gb::filter {
namespace {

using internal::kLog2Pi;

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

  if (trace) {
    constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
    trace->y_pred.setConstant(p, N, kNaN);
    trace->y_var.setConstant(p, N, kNaN);
    trace->x_pred.setConstant(n, N, kNaN);
    trace->x_filt.setConstant(n, N, kNaN);
    trace->P_pred.assign(N, Eigen::MatrixXd());
    trace->P_filt.assign(N, Eigen::MatrixXd());
  }
  if (terms) terms->assign(N, 0.0);

  std::vector<double> meas(model.measurement_size());
  auto measure = [&](int j, const Eigen::VectorXd& at) { return propagator.Measure(j, at, meas); };
  auto H_row = [&](int o) {
    return Eigen::Map<const Eigen::RowVectorXd>(
        meas.data() + p + static_cast<std::ptrdiff_t>(o) * n, n);
  };
  auto S_of = [&](int o) { return meas[p + p * n + o]; };

  const double huber = settings.huber.value_or(0.0);
  const bool robust = settings.huber.has_value();
  const int j_end = trace ? N - 1 : window->last_j;
  const double* Y = series.Y.data();
  double loglik = 0.0;
  long n_obs = 0;
  std::vector<int> observed;  // outputs observed at j
  Eigen::VectorXd x_prior(n), x_lin(n), PHt(n);
  Eigen::MatrixXd P_prior(n, n);
  std::vector<double> h_lin(p);
  Eigen::MatrixXd H_lin(p, n);
  for (int j = 0; j <= j_end; ++j) {
    if (settings.cancel && settings.cancel->load(std::memory_order_relaxed))
      return NumericalError("cancelled");
    internal::ObservedAt(j, series, *window, &observed);
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
        const double y = Y[static_cast<std::size_t>(j + window->delay[o]) * p + o];
        const auto H = H_row(o);
        const double yhat = meas[o] + H.dot(x - x_prior);
        PHt.noalias() = P * H.transpose();
        const double R = H.dot(PHt) + S_of(o);
        if (!(R > 0.0))
          return internal::NotPositiveInnovationVariance(series, o, j + window->delay[o], R);
        const double eps = y - yhat;
        logdet += std::log(R);
        r2 += eps * eps / R;
        x.noalias() += PHt * (eps / R);
        P.noalias() -= (1.0 / R) * PHt * PHt.transpose();
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
          const double y = Y[static_cast<std::size_t>(j + window->delay[o]) * p + o];
          const auto H = H_lin.row(o);
          const double yhat = h_lin[o] + H.dot(x - x_lin);
          PHt.noalias() = P * H.transpose();
          const double R = H.dot(PHt) + S_of(o);
          if (!(R > 0.0))
            return internal::NotPositiveInnovationVariance(series, o, j + window->delay[o], R);
          x.noalias() += PHt * ((y - yhat) / R);
          P.noalias() -= (1.0 / R) * PHt * PHt.transpose();
        }
        if ((x - x_lin).norm() <= 1e-10 * (1.0 + x.norm())) break;
      }
      const double rho = internal::HuberRho(r2, robust, huber);
      const double term = -(0.5 * (logdet + static_cast<double>(observed.size()) * kLog2Pi) + rho);
      loglik += term;
      n_obs += static_cast<long>(observed.size());
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
