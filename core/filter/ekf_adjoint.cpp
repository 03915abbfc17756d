#include "core/filter/ekf_adjoint.h"

#include <cmath>
#include <vector>

#include "core/filter/ekf.h"
#include "core/filter/ekf_score.h"
#include "core/filter/internal.h"
#include "core/filter/moments.h"

namespace gb::filter {
namespace {

// The packed moments' adjoint (∂L/∂z, z = [x; lower triangle of P]) and the adjoint of (x, P)
// with P symmetric (dL = x̄'dx + Σ_ab P̄_ab dP_ab, P̄ symmetric). Where P comes from z (the
// moments at the end of an interval, Unpack: P_ab = P_ba = z_ab) z̄_ab = 2 P̄_ab off the
// diagonal; where z comes from P (the start of one, Pack: z_ab = (P_ab + P_ba) / 2)
// P̄_ab = P̄_ba = z̄_ab / 2. The diagonal is the same both ways.
void PackAdjoint(const Eigen::VectorXd& x_bar, const Eigen::MatrixXd& P_bar, std::span<double> z) {
  const auto n = x_bar.size();
  std::copy(x_bar.data(), x_bar.data() + n, z.begin());
  std::size_t k = static_cast<std::size_t>(n);
  for (Eigen::Index b = 0; b < n; ++b)
    for (Eigen::Index a = b; a < n; ++a) z[k++] = a == b ? P_bar(a, a) : 2.0 * P_bar(a, b);
}

void UnpackAdjoint(std::span<const double> z, Eigen::VectorXd* x_bar, Eigen::MatrixXd* P_bar) {
  const auto n = x_bar->size();
  std::copy(z.begin(), z.begin() + n, x_bar->data());
  std::size_t k = static_cast<std::size_t>(n);
  for (Eigen::Index b = 0; b < n; ++b) {
    for (Eigen::Index a = b; a < n; ++a) {
      const double v = z[k++];
      if (a == b) {
        (*P_bar)(a, a) = v;
      } else {
        (*P_bar)(a, b) = (*P_bar)(b, a) = 0.5 * v;
      }
    }
  }
}

// One scalar update as ScalarUpdate computed it: the values before it and its gain.
struct UpdateRecord {
  int o = 0;
  Eigen::VectorXd x, k;
  Eigen::MatrixXd P;
  double R = 0.0, eps = 0.0;
};

}  // namespace

Result<Loglik> EkfLogLikelihoodWithAdjoint(
    const model::NonlinearModel& model, const model::NonlinearSensitivity& sensitivity,
    std::span<const double> theta, const data::Series& series, const FilterSettings& settings,
    std::span<const int> free, Eigen::VectorXd* gradient, bool* applicable, OdeCounts* counts) {
  const int n = model.n_states();
  const int p = model.n_outputs();
  const int np = model.n_parameters();
  const int N = static_cast<int>(series.size());
  assert(model.spec().ekf.iterations == 1 && "the iterated EKF has no exact score here");
  assert(gradient != nullptr && applicable != nullptr);
  *applicable = model.spec().ekf.method != model::OdeMethod::kBdf;
  if (!*applicable) return Loglik{};
  auto window = ObservationWindowOf(series, p, settings);
  if (!window) return window.error();
  MomentPropagator propagator(model, theta, series, settings.hold, false, &sensitivity, {});
  const auto nz = static_cast<std::size_t>(propagator.moments_size());
  auto stiff = [&] { return propagator.counts().stiff_intervals > 0; };
  auto not_applicable = [&] {  // the integrator's work is counted all the same
    if (counts) *counts += propagator.counts();
    *applicable = false;
    return Loglik{};
  };

  // ---- forward: the filter, keeping the checkpoints ----
  std::vector<double> steps;  // every logged step, (t, Δt) pairs
  propagator.set_step_log(&steps);
  Eigen::VectorXd x;
  Eigen::MatrixXd P;
  if (auto s = propagator.Initial(settings.initial_covariance, &x, &P); !s) return s.error();
  const std::size_t initial_steps = steps.size();  // "ctsm": the first interval from (x0, 0)
  if (stiff()) return not_applicable();
  const Eigen::VectorXd x0 = x;
  const Eigen::MatrixXd P0 = P;
  std::vector<double> initial_dense = sensitivity.initial().Zeroed();
  if (auto s = propagator.InitialDerivatives(initial_dense); !s) return s.error();

  std::vector<double> meas(model.measurement_size());
  auto H_row = [&](int o) {
    return Eigen::Map<const Eigen::RowVectorXd>(
        meas.data() + p + static_cast<std::ptrdiff_t>(o) * n, n);
  };
  auto S_of = [&](int o) { return meas[p + p * n + o]; };
  const double* Y = series.Y.data();
  const internal::ObservationRule rule(series, *window);
  internal::ObservedOutputs observed(rule.p());

  std::vector<double> priors;         // the packed prior of every observed index
  std::vector<double> starts;         // the packed moments every interval starts from
  std::vector<std::size_t> step_end;  // interval j's steps end at steps[step_end[j]]
  std::vector<int> prior_of(static_cast<std::size_t>(N), -1);
  double loglik = 0.0;
  long n_obs = 0;
  int last = 0;  // the last state index the filter reached
  Eigen::VectorXd x_prior(n), PHt(n);
  for (int j = 0; j <= window->last_j; ++j) {
    if (settings.cancel && settings.cancel->load(std::memory_order_relaxed))
      return NumericalError("cancelled");
    last = j;
    internal::ObservedAt(j, rule, &observed);
    if (!observed.empty()) {
      prior_of[static_cast<std::size_t>(j)] = static_cast<int>(priors.size() / nz);
      priors.resize(priors.size() + nz);
      propagator.Pack(x, P, std::span<double>(priors).last(nz));
      if (auto s = propagator.Measure(j, x, meas); !s) return s.error();
      x_prior = x;
      double r2 = 0.0, logdet = 0.0;
      for (const int o : observed) {
        const int k = j + window->delay[o];
        double eps = 0.0, R = 0.0;
        if (!internal::ScalarUpdate(Y[static_cast<std::size_t>(k) * p + o], meas[o], H_row(o),
                                    S_of(o), x_prior, &x, &P, &PHt, &eps, &R))
          return internal::NotPositiveInnovationVariance(series, o, k, R);
        logdet += std::log(R);
        r2 += eps * eps / R;
      }
      loglik += internal::LoglikTerm(logdet, observed.size(), r2, settings.huber);
      n_obs += observed.size();
    }
    if (j == N - 1) break;
    if (j == window->last_j) break;  // nothing later is observed
    starts.resize(starts.size() + nz);
    propagator.Pack(x, P, std::span<double>(starts).last(nz));
    if (auto s = propagator.Advance(j, &x, &P); !s) return s.error();
    step_end.push_back(steps.size());
    if (stiff()) return not_applicable();
  }
  if (!std::isfinite(loglik)) return internal::NotFiniteLoglik(series);

  // ---- backward: ∂ log L/∂(x̂, P) from the last index to the first, ∂ log L/∂θ gathered ----
  std::vector<double> theta_bar(static_cast<std::size_t>(np), 0.0);
  std::vector<double> z_bar(nz, 0.0);
  Eigen::VectorXd x_bar(n), x_lin_bar(n), k_bar(n), P_k_bar(n);
  Eigen::MatrixXd P_bar(n, n);
  Eigen::RowVectorXd H_bar(n);
  std::vector<double> dmeas = sensitivity.measurement().Zeroed();
  const internal::MeasurementDerivatives d{&sensitivity, dmeas, p, n};
  std::vector<UpdateRecord> records;
  for (int j = last; j >= 0; --j) {
    if (settings.cancel && settings.cancel->load(std::memory_order_relaxed))
      return NumericalError("cancelled");
    const auto J = static_cast<std::size_t>(j);
    if (j < last) {
      const std::size_t begin = j == 0 ? initial_steps : step_end[J - 1];
      const std::span<const double> interval(steps.data() + begin, step_end[J] - begin);
      if (auto s = propagator.ReverseAdvance(j, std::span<const double>(starts).subspan(J * nz, nz),
                                             interval, z_bar, theta_bar);
          !s)
        return s.error();
    }
    UnpackAdjoint(z_bar, &x_bar, &P_bar);  // at the posterior (Pack's convention)
    if (prior_of[J] >= 0) {
      // The index's updates again from its prior, each one's inputs kept.
      propagator.Unpack(
          std::span<const double>(priors).subspan(static_cast<std::size_t>(prior_of[J]) * nz, nz),
          &x, &P);
      x_prior = x;
      if (auto s = propagator.Measure(j, x_prior, meas); !s) return s.error();
      if (auto s = propagator.MeasureSensitivities(j, x_prior, dmeas); !s) return s.error();
      internal::ObservedAt(j, rule, &observed);
      records.clear();
      double r2 = 0.0, logdet = 0.0;
      for (const int o : observed) {
        UpdateRecord& u = records.emplace_back();
        u.o = o;
        u.x = x;
        u.P = P;
        const double y = Y[static_cast<std::size_t>(j + window->delay[o]) * p + o];
        internal::ScalarUpdate(y, meas[o], H_row(o), S_of(o), x_prior, &x, &P, &PHt, &u.eps, &u.R);
        u.k = PHt;
        logdet += std::log(u.R);
        r2 += u.eps * u.eps / u.R;
      }
      double drho = 0.5;
      internal::LoglikTerm(logdet, observed.size(), r2, settings.huber, &drho);
      const double a_bar = -0.5, b_bar = -drho;  // ∂ℓ/∂ log R and ∂ℓ/∂(ε²/R) of each update
      x_lin_bar.setZero();
      for (auto u = records.rbegin(); u != records.rend(); ++u) {
        const auto H = H_row(u->o);
        const double R = u->R, e = u->eps;
        const double xk = x_bar.dot(u->k);
        // x⁺ = x + k ε/R, P⁺ = P - k k'/R, log R and ε²/R into the term.
        k_bar.noalias() = x_bar * (e / R);
        k_bar.noalias() -= (2.0 / R) * (P_bar * u->k);
        const double e_bar = xk / R + 2.0 * b_bar * e / R;
        const double R_bar = -xk * e / (R * R) + u->k.dot(P_bar * u->k) / (R * R) + a_bar / R -
                             b_bar * e * e / (R * R);
        const double yhat_bar = -e_bar;
        // R = H k + S, then k = P H'.
        k_bar.noalias() += R_bar * H.transpose();
        P_k_bar.noalias() = u->P * k_bar;
        H_bar = R_bar * u->k.transpose() + P_k_bar.transpose() +
                yhat_bar * (u->x - x_prior).transpose();
        P_bar.noalias() += 0.5 * (k_bar * H + H.transpose() * k_bar.transpose());
        // ŷ = h + H (x - x̂⁻) with h, H and S at (x̂⁻, θ): through x̂⁻, ŷ's -H and h's ∂h/∂x = H
        // cancel, leaving H's own dependence.
        x_bar.noalias() += yhat_bar * H.transpose();
        for (int m = 0; m < n; ++m) x_lin_bar(m) += H_bar.dot(d.Hx(m).row(u->o));
        for (int l = 0; l < np; ++l) {
          theta_bar[static_cast<std::size_t>(l)] += yhat_bar * d.h_theta(u->o, l) +
                                                    H_bar.dot(d.Htheta(l).row(u->o)) +
                                                    R_bar * d.S_theta(u->o, l);
        }
      }
      x_bar += x_lin_bar;
    }
    PackAdjoint(x_bar, P_bar, z_bar);  // at the prior (Unpack's convention)
  }

  // ---- the initial state: x̄0 and P̄0 in x_bar and P_bar ----
  Eigen::VectorXd x0_bar = x_bar;
  switch (settings.initial_covariance) {
    case model::InitialCovariance::kExplicit:
      for (int l = 0; l < np; ++l) {
        for (int i = 0; i < n; ++i) {
          theta_bar[static_cast<std::size_t>(l)] +=
              P_bar(i, i) *
              initial_dense[sensitivity.InitP0theta() +
                            static_cast<std::size_t>(l) * static_cast<std::size_t>(n) +
                            static_cast<std::size_t>(i)];
        }
      }
      break;
    case model::InitialCovariance::kCtsm: {
      // P0 is the covariance at the end of the first interval from (x0, 0).
      std::vector<double> start(nz, 0.0), end_bar(nz, 0.0);
      propagator.Pack(x0, Eigen::MatrixXd::Zero(n, n), start);
      PackAdjoint(Eigen::VectorXd::Zero(n), P_bar, end_bar);
      if (auto s = propagator.ReverseAdvance(
              0, start, std::span<const double>(steps.data(), initial_steps), end_bar, theta_bar);
          !s)
        return s.error();
      x0_bar += Eigen::Map<const Eigen::VectorXd>(end_bar.data(), n);
      break;
    }
    case model::InitialCovariance::kStationary:
      if (auto s = propagator.StationaryAdjoint(x0, P0, P_bar, &x0_bar, theta_bar); !s)
        return s.error();
      break;
  }
  for (int l = 0; l < np; ++l) {
    const Eigen::Map<const Eigen::VectorXd> x0_theta(
        initial_dense.data() + static_cast<std::size_t>(l) * static_cast<std::size_t>(n), n);
    theta_bar[static_cast<std::size_t>(l)] += x0_bar.dot(x0_theta);
  }
  gradient->resize(static_cast<Eigen::Index>(free.size()));
  for (std::size_t q = 0; q < free.size(); ++q)
    (*gradient)(static_cast<Eigen::Index>(q)) = theta_bar[static_cast<std::size_t>(free[q])];
  if (counts) *counts += propagator.counts();
  if (!gradient->allFinite())
    return NumericalError("the derivatives of the log-likelihood are not finite");
  return Loglik{loglik, n_obs};
}

}  // namespace gb::filter
