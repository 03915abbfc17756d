#include "core/filter/ekf.h"

#include <cmath>
#include <complex>
#include <limits>
#include <optional>

#include <Eigen/Core>
#include <fmt/format.h>

#include "core/filter/discretize.h"
#include "core/filter/internal.h"

namespace gb::filter {
namespace {

using internal::kLog2Pi;
using Program = model::NonlinearModel::Program;

// The moment equations over one sample interval: z = [x̂; lower triangle of P, column by column].
class Moments final : public OdeSystem {
 public:
  Moments(const model::NonlinearModel& model, std::span<const double> theta)
      : model_(model),
        n_(model.n_states()),
        m_(model.n_inputs()),
        slots_(model.n_slots(), 0.0),
        out_(model.dynamics_size()),
        packed_(n_, n_),
        J_(n_, n_),
        P_(n_, n_),
        M_(n_, n_) {
    std::copy(theta.begin(), theta.end(), slots_.begin() + model.parameter_slot());
    int k = n_;
    for (int b = 0; b < n_; ++b)
      for (int a = b; a < n_; ++a) packed_(a, b) = packed_(b, a) = k++;
  }

  int size() const override { return n_ + n_ * (n_ + 1) / 2; }

  // The inputs over [t0, t0 + dt]: u0 (zoh), or from u0 to u1 (foh; u1 may be null for zoh).
  void SetInterval(const double* u0, const double* u1, double t0, double dt) {
    u0_ = u0;
    u1_ = u1;
    t0_ = t0;
    dt_ = dt;
  }

  // Evaluates the dynamics at (x, u(t), t) into out_; false (and failure() set) if not finite.
  bool EvaluateAt(double t, const double* x) {
    std::copy(x, x + n_, slots_.begin());
    for (int i = 0; i < m_; ++i) {
      double u = u0_[i];
      if (u1_) u += (t - t0_) / dt_ * (u1_[i] - u0_[i]);
      slots_[n_ + i] = u;
    }
    slots_[model_.time_slot()] = t;
    model_.Dynamics(slots_, out_);
    for (std::size_t k = 0; k < out_.size(); ++k) {
      if (!std::isfinite(out_[k])) {
        failure_ = model_.NotFinite(Program::kDynamics, k, out_[k], slots_);
        return false;
      }
    }
    for (int i = 0; i < n_; ++i)
      for (int j = 0; j < n_; ++j) J_(i, j) = out_[n_ + i * n_ + j];
    return true;
  }

  bool Rhs(double t, std::span<const double> z, std::span<double> dz) override {
    if (!EvaluateAt(t, z.data())) return false;
    for (int i = 0; i < n_; ++i) dz[i] = out_[i];
    Unpack(z, &P_);
    M_.noalias() = J_ * P_;
    const double* sigma = out_.data() + n_ + n_ * n_;
    for (int b = 0; b < n_; ++b) {
      for (int a = b; a < n_; ++a) {
        double v = M_(a, b) + M_(b, a);
        if (a == b) v += sigma[a] * sigma[a];
        dz[packed_(a, b)] = v;
      }
    }
    return true;
  }

  // ∂F/∂z without the terms of ∂J/∂x̂ and ∂σ/∂x̂ (second derivatives): [J 0; 0 L(J)] with
  // L(J) the Lyapunov operator P -> J P + P J' on the lower triangle.
  void Jacobian(double t, std::span<const double> z, std::span<double> jac) override {
    const int N = size();
    std::fill(jac.begin(), jac.end(), 0.0);
    if (!EvaluateAt(t, z.data())) return;
    auto at = [&](int row, int col) -> double& { return jac[static_cast<std::size_t>(col) * N + row]; };
    for (int i = 0; i < n_; ++i)
      for (int j = 0; j < n_; ++j) at(i, j) = J_(i, j);
    // (J P + P J')_ab = Σ_k J_ak P_kb + Σ_k J_bk P_ak; P_cd (c >= d) stands for P_cd and P_dc.
    for (int b = 0; b < n_; ++b) {
      for (int a = b; a < n_; ++a) {
        const int row = packed_(a, b);
        for (int k = 0; k < n_; ++k) {
          at(row, packed_(k, b)) += J_(a, k);
          at(row, packed_(a, k)) += J_(b, k);
        }
      }
    }
  }

  // An upper bound of ρ(∂F/∂z) times dt at (x, t0): the covariance part has the eigenvalues
  // λ_i + λ_j of J, so 2 max_i Σ_j |J_ij| (Gershgorin) bounds it. Infinite if not finite.
  double Stiffness(const double* x) {
    if (!EvaluateAt(t0_, x)) return std::numeric_limits<double>::infinity();
    return 2.0 * J_.cwiseAbs().rowwise().sum().maxCoeff() * dt_;
  }

  void Unpack(std::span<const double> z, Eigen::MatrixXd* P) const {
    for (int b = 0; b < n_; ++b)
      for (int a = b; a < n_; ++a) (*P)(a, b) = (*P)(b, a) = z[packed_(a, b)];
  }
  void Pack(const Eigen::MatrixXd& P, std::span<double> z) const {
    for (int b = 0; b < n_; ++b)
      for (int a = b; a < n_; ++a) z[packed_(a, b)] = 0.5 * (P(a, b) + P(b, a));
  }

  const Eigen::MatrixXd& J() const { return J_; }
  const double* sigma() const { return out_.data() + n_ + n_ * n_; }
  const std::optional<Error>& failure() const { return failure_; }
  void clear_failure() { failure_.reset(); }

 private:
  const model::NonlinearModel& model_;
  const int n_, m_;
  std::vector<double> slots_;
  std::vector<double> out_;
  Eigen::MatrixXi packed_;
  Eigen::MatrixXd J_, P_, M_;
  const double* u0_ = nullptr;
  const double* u1_ = nullptr;
  double t0_ = 0.0, dt_ = 1.0;
  std::optional<Error> failure_;
};

// Where a series' row is, for messages.
Error AtRow(Error e, const data::Series& series, int j) {
  if (e.file.empty()) e.file = series.source;
  if (j < static_cast<int>(series.row_line.size())) e.line = series.row_line[j];
  return e;
}

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
  const int m = model.n_inputs();
  const int p = model.n_outputs();
  const int N = static_cast<int>(series.size());
  assert(series.U.rows() == m && series.Y.rows() == p && "series bound to the model");
  assert(static_cast<int>(theta.size()) == model.n_parameters());
  auto window = ObservationWindowOf(series, p, settings);
  if (!window) return window.error();
  const model::EkfOptions& options = model.spec().ekf;
  const bool foh = settings.hold == model::InputHold::kFoh;

  std::vector<double> slots(model.n_slots(), 0.0);
  std::copy(theta.begin(), theta.end(), slots.begin() + model.parameter_slot());
  std::vector<double> initial(model.initial_size());
  model.Initial(slots, initial);
  for (std::size_t k = 0; k < initial.size(); ++k) {
    if (!std::isfinite(initial[k]))
      return model.NotFinite(Program::kInitial, k, initial[k], slots);
  }

  Moments moments(model, theta);
  OdeSolver solver(options, moments.size());
  std::vector<double> z(moments.size());
  Eigen::VectorXd x = Eigen::Map<const Eigen::VectorXd>(initial.data(), n);
  Eigen::MatrixXd P(n, n);
  const double* U = series.U.data();
  auto input = [&](int j) { return U + static_cast<std::size_t>(j) * m; };
  auto set_interval = [&](int j) {
    moments.SetInterval(input(j), foh ? input(j + 1) : nullptr, series.time[j],
                        series.time[j + 1] - series.time[j]);
  };
  auto advance = [&](int j) -> Status {
    const double stiffness = options.method == model::OdeMethod::kAuto
                                 ? moments.Stiffness(z.data())
                                 : 0.0;
    moments.clear_failure();
    auto s = solver.Advance(moments, series.time[j], series.time[j + 1], z, stiffness);
    if (s) return s;
    // The model's own reason (an entry not finite where the solver tried it) says more than
    // the solver's.
    const std::string why = moments.failure() ? moments.failure()->message : s.error().message;
    return AtRow(NumericalError(fmt::format(
                     "the moment equations could not be integrated from row {} (t = {:g}) to "
                     "the next: {}",
                     j + 1, series.time[j], why)),
                 series, j);
  };

  switch (settings.initial_covariance) {
    case model::InitialCovariance::kCtsm: {
      z.assign(z.size(), 0.0);
      std::copy(x.data(), x.data() + n, z.begin());
      set_interval(0);
      if (auto s = advance(0); !s) return s.error();
      moments.Unpack(z, &P);
      break;
    }
    case model::InitialCovariance::kStationary: {
      set_interval(0);
      if (!std::isfinite(moments.Stiffness(x.data()))) return AtRow(*moments.failure(), series, 0);
      Eigen::VectorXd sigma2(n);
      for (int i = 0; i < n; ++i) sigma2(i) = moments.sigma()[i] * moments.sigma()[i];
      std::complex<double> bad;
      if (!StationaryCovariance(moments.J(), sigma2, &P, &bad))
        return NumericalError(fmt::format(
            "initial_covariance \"stationary\" needs a stable linearisation at the initial state, "
            "but ∂f/∂x has the eigenvalue {:.6g}{:+.6g}i there (real part not negative); use "
            "\"ctsm\" or explicit variances",
            bad.real(), bad.imag()));
      break;
    }
    case model::InitialCovariance::kExplicit:
      P.setZero();
      for (int i = 0; i < n; ++i) {
        if (initial[n + i] < 0)
          return NumericalError(fmt::format("{} = {:g} is negative at these parameter values (a "
                                            "variance)", model.spec().initial_variance[i].path,
                                            initial[n + i]));
        P(i, i) = initial[n + i];
      }
      break;
  }

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
  auto measure = [&](int j, const Eigen::VectorXd& at) -> Status {
    std::copy(at.data(), at.data() + n, slots.begin());
    for (int i = 0; i < m; ++i) slots[n + i] = input(j)[i];
    slots[model.time_slot()] = series.time[j];
    model.Measurement(slots, meas);
    for (std::size_t k = 0; k < meas.size(); ++k) {
      if (!std::isfinite(meas[k]))
        return AtRow(model.NotFinite(Program::kMeasurement, k, meas[k], slots), series, j);
    }
    return Ok{};
  };
  auto H_row = [&](int o) { return Eigen::Map<const Eigen::RowVectorXd>(meas.data() + p + o * n, n); };
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
    if (settings.cancel && (j & (internal::kCancelCheckInterval - 1)) == 0 &&
        settings.cancel->load(std::memory_order_relaxed))
      return NumericalError("cancelled");
    observed.clear();
    for (int o = 0; o < p; ++o) {
      const int k = j + window->delay[o];
      if (k >= N || k < window->first_obs[o]) continue;
      if (!std::isnan(Y[static_cast<std::size_t>(k) * p + o])) observed.push_back(o);
    }
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
        if (!(R > 0.0)) return internal::NotPositiveInnovationVariance(series, o, j + window->delay[o], R);
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
          if (!(R > 0.0)) return internal::NotPositiveInnovationVariance(series, o, j + window->delay[o], R);
          x.noalias() += PHt * ((y - yhat) / R);
          P.noalias() -= (1.0 / R) * PHt * PHt.transpose();
        }
        if ((x - x_lin).norm() <= 1e-10 * (1.0 + x.norm())) break;
      }
      double rho = 0.5 * r2;
      if (robust) {
        const double r = std::sqrt(r2);
        if (r > huber) rho = huber * r - 0.5 * huber * huber;
      }
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
    std::copy(x.data(), x.data() + n, z.begin());
    moments.Pack(P, z);
    set_interval(j);
    if (auto s = advance(j); !s) return s.error();
    x = Eigen::Map<const Eigen::VectorXd>(z.data(), n);
    moments.Unpack(z, &P);
  }
  if (counts) {
    const OdeCounts& c = solver.counts();
    counts->intervals += c.intervals;
    counts->stiff_intervals += c.stiff_intervals;
    counts->steps += c.steps;
    counts->rejected += c.rejected;
    counts->rhs += c.rhs;
  }
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
