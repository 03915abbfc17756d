// Sections: 1. settings and P0  2. the filter loop (templated on the state dimension)
//           3. dispatch
#include "core/filter/kalman.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <complex>
#include <cstdint>
#include <numbers>

#include <fmt/format.h>

#include "core/filter/discretize.h"
#include "core/filter/internal.h"

namespace gb::filter {
namespace {

using internal::FixedDiscrete;
using internal::kCancelCheckInterval;
using internal::kLog2Pi;
using internal::NotPositiveInnovationVariance;
using internal::Symmetrize;
using internal::WithStateDimension;

}  // namespace

// ---- 1. settings and P0 ----------------------------------------------------------------------

FilterSettings FilterSettings::FromModel(const model::ModelSpec& spec) {
  FilterSettings s;
  s.hold = spec.input_hold;
  s.initial_covariance = spec.initial_covariance;
  s.huber = spec.robust_huber;
  for (const auto& d : spec.output_delay) s.delay.push_back(d.min);
  return s;
}

Result<std::vector<Discrete>> DiscretizeIntervals(const model::StateSpace& ss,
                                                  const data::Series& series,
                                                  model::InputHold hold) {
  const Eigen::VectorXd sigma2 = ss.sigma.array().square();
  std::vector<Discrete> out;
  out.reserve(series.intervals.distinct.size());
  for (double dt : series.intervals.distinct)
    out.push_back(Discretize(ss.A, ss.B, ss.c, sigma2, dt, hold));
  const auto finite = [](const Discrete& d) {
    return d.Phi.allFinite() && d.Gamma0.allFinite() && d.Gamma1.allFinite() && d.g.allFinite() &&
           d.Q.allFinite();
  };
  if (std::all_of(out.begin(), out.end(), finite)) return out;
  // The rows are walked only to name the first interval that failed.
  const auto& group = series.intervals.group;
  std::size_t k = 0;
  while (k + 1 < group.size() && finite(out[group[k]])) ++k;  // every group has a row
  Error e = NumericalError(fmt::format(
      "the model cannot be discretised over the {:g} s from row {} (t = {:g}) to the next: "
      "e^(A dt) or its integrals overflow at these parameter values (an interval this long, or "
      "a mode this unstable)",
      series.time[k + 1] - series.time[k], k + 1, series.time[k]));
  return data::AtRow(e, series, static_cast<int>(k));
}

namespace {

Result<Eigen::MatrixXd> InitialCovarianceFrom(const model::StateSpace& ss,
                                              const data::Series& series,
                                              const FilterSettings& settings,
                                              const std::vector<Discrete>* disc) {
  switch (settings.initial_covariance) {
    case model::InitialCovariance::kCtsm: {
      if (disc && !disc->empty()) return (*disc)[series.intervals.group[0]].Q;
      const Eigen::VectorXd sigma2 = ss.sigma.array().square();
      return IntegratedDiffusion(ss.A, sigma2, series.time[1] - series.time[0]);
    }
    case model::InitialCovariance::kStationary: {
      Eigen::MatrixXd P;
      std::complex<double> bad;
      const Eigen::VectorXd sigma2 = ss.sigma.array().square();
      if (!StationaryCovariance(ss.A, sigma2, &P, &bad))
        return NumericalError(fmt::format(
            "initial_covariance \"stationary\" needs a stable A, but A has the eigenvalue "
            "{:.6g}{:+.6g}i (real part not negative); use \"ctsm\" or explicit variances",
            bad.real(), bad.imag()));
      return P;
    }
    case model::InitialCovariance::kExplicit:
      return Eigen::MatrixXd(ss.P0_diag.asDiagonal());
  }
  return NumericalError("unknown initial covariance");
}

}  // namespace

Result<Eigen::MatrixXd> InitialCovariance(const model::StateSpace& ss, const data::Series& series,
                                          const FilterSettings& settings) {
  if (settings.P0.size() > 0) return settings.P0;
  return InitialCovarianceFrom(ss, series, settings, nullptr);
}

// ---- 2. the filter loop ----------------------------------------------------------------------

namespace {

struct Context {
  std::vector<double>* terms;  // per-state-index terms, or null
  const model::StateSpace& ss;
  const data::Series& series;
  const FilterSettings& settings;
  const std::vector<Discrete>& disc;
  const Eigen::MatrixXd& P0;
  std::vector<int> delay;
  std::vector<int> first_obs;
  int last_j;  // last state index that some observation sees
};

// Σ log R over many R > 0 with one log at the end: the product is kept as mantissa × 2^exponent,
// renormalised after every factor by moving the exponent bits out (no overflow or underflow for
// any normal R). Rounding: one relative error per factor, as summing the logs would give.
class LogProduct {
 public:
  void Multiply(double r) {
    if (r < kTiny || r > kHuge) {  // far outside the normal range: take the log directly
      direct_ += std::log(r);
      return;
    }
    mantissa_ *= r;
    const auto bits = std::bit_cast<std::uint64_t>(mantissa_);
    exponent_ += static_cast<std::int64_t>((bits >> 52) & 0x7ff) - 1023;
    mantissa_ =
        std::bit_cast<double>((bits & ~(std::uint64_t{0x7ff} << 52)) | (std::uint64_t{1023} << 52));
  }
  double Log() const { return std::log(mantissa_) + exponent_ * kLn2 + direct_; }

 private:
  static constexpr double kTiny = 1e-290, kHuge = 1e290;
  static constexpr double kLn2 = 0.69314718055994530941723212145818;
  double mantissa_ = 1.0;  // in [1, 2) after every Multiply
  std::int64_t exponent_ = 0;
  double direct_ = 0.0;
};

template <int NX, bool kTrace>
Result<Loglik> FilterLoop(const Context& ctx, FilterTrace* trace) {
  using Mat = Eigen::Matrix<double, NX, NX>;
  using Vec = Eigen::Matrix<double, NX, 1>;
  using Row = Eigen::Matrix<double, 1, NX>;

  const model::StateSpace& ss = ctx.ss;
  const data::Series& series = ctx.series;
  const int n = ss.n_states();
  const int p = ss.n_outputs();
  const int N = static_cast<int>(series.size());
  const bool foh = ctx.settings.hold == model::InputHold::kFoh;
  const bool has_inputs = ss.n_inputs() > 0;

  const std::vector<FixedDiscrete<NX>> disc(ctx.disc.begin(), ctx.disc.end());
  // Rows of C and the output offsets, fixed-size for the inner loop.
  std::vector<Row> C(p);
  for (int o = 0; o < p; ++o) C[o] = ss.C.row(o);
  const Eigen::MatrixXd& D = ss.D;
  const bool has_D = has_inputs && D.cwiseAbs().maxCoeff() != 0.0;

  Vec x = ctx.settings.x0.size() > 0 ? Vec(ctx.settings.x0) : Vec(ss.x0);
  Mat P = ctx.P0;
  Vec PCt, x_next;
  Mat PhiP;
  if constexpr (NX == Eigen::Dynamic) {
    PCt.resize(n);
    x_next.resize(n);
    PhiP.resize(n, n);
  }

  const double huber = ctx.settings.huber.value_or(0.0);
  const bool robust = ctx.settings.huber.has_value();
  double loglik = 0.0;
  long n_obs = 0;
  const int* group = series.intervals.group.data();
  const double* Y = series.Y.data();
  const double* U = series.U.data();
  const int m = ss.n_inputs();

  if constexpr (kTrace) {
    trace->y_pred.setConstant(p, N, std::numeric_limits<double>::quiet_NaN());
    trace->y_var.setConstant(p, N, std::numeric_limits<double>::quiet_NaN());
    trace->x_pred.setConstant(n, N, std::numeric_limits<double>::quiet_NaN());
    trace->x_filt.setConstant(n, N, std::numeric_limits<double>::quiet_NaN());
    trace->P_pred.assign(N, Eigen::MatrixXd());
    trace->P_filt.assign(N, Eigen::MatrixXd());
  }

  const int j_end = kTrace ? N - 1 : ctx.last_j;
  // The steady state (kalman.h): the record of the last full step, replayed while it applies.
  constexpr bool kSteady = !kTrace && NX != Eigen::Dynamic;
  struct StepRecord {
    std::uint64_t mask = 0;   // the outputs updated, in order
    int group = -1;           // the interval of the time update (-1: none)
    Mat P_start;              // P at the start of the step
    std::array<Vec, 64> PCt;  // P c' of each scalar update, in order
    std::array<double, 64> R{};
  };
  StepRecord rec;
  bool steady = false;
  const bool can_be_steady = kSteady && p <= 64;
  // Without per-step terms, Σ log R is accumulated as a product (one log per series).
  const bool per_step_log = kTrace || ctx.terms != nullptr;
  LogProduct log_product;
  const std::atomic<bool>* cancel = ctx.settings.cancel;
  for (int j = 0; j <= j_end; ++j) {
    if (cancel && (j & (kCancelCheckInterval - 1)) == 0 && cancel->load(std::memory_order_relaxed))
      return NumericalError("cancelled");
    if constexpr (kTrace) {
      trace->x_pred.col(j) = x;
      trace->P_pred[j] = Eigen::Map<const Eigen::MatrixXd>(P.data(), n, n);
      for (int o = 0; o < p; ++o) {
        const int k = j + ctx.delay[o];
        if (k >= N) continue;
        double yhat = C[o].dot(x) + ss.d(o);
        if (has_D) yhat += D.row(o).dot(series.U.col(j));
        trace->y_pred(o, k) = yhat;
        trace->y_var(o, k) = (C[o] * P * C[o].transpose()).value() + ss.S(o);
      }
    }
    // Measurement update: the observations that see x_j, one scalar at a time.
    double r2 = 0.0;
    double logdet = 0.0;
    int p_j = 0;
    std::uint64_t mask = 0;
    if (can_be_steady) {
      for (int o = 0; o < p; ++o) {
        const int k = j + ctx.delay[o];
        if (k >= N || k < ctx.first_obs[o]) continue;
        if (!std::isnan(Y[static_cast<std::size_t>(k) * p + o])) mask |= std::uint64_t{1} << o;
      }
      const int group_j = j == N - 1 ? -1 : group[j];
      steady = steady && mask == rec.mask && group_j == rec.group;
      if (!steady) {
        rec.mask = mask;
        rec.group = group_j;
        rec.P_start = P;
      }
    }
    for (int o = 0; o < p; ++o) {
      const int k = j + ctx.delay[o];
      if (k >= N || k < ctx.first_obs[o]) continue;
      const double y = Y[static_cast<std::size_t>(k) * p + o];
      if (std::isnan(y)) continue;
      double yhat = C[o].dot(x) + ss.d(o);
      if (has_D) {
        const double* u = U + static_cast<std::size_t>(j) * m;
        for (int i = 0; i < m; ++i) yhat += D(o, i) * u[i];
      }
      double R;
      if (steady) {  // this step's P c' and R are those recorded
        R = rec.R[p_j];
        PCt = rec.PCt[p_j];
      } else {
        PCt.noalias() = P * C[o].transpose();
        R = C[o].dot(PCt) + ss.S(o);
        if (!(R > 0.0)) return NotPositiveInnovationVariance(series, o, k, R);
        if (can_be_steady) rec.PCt[p_j] = PCt, rec.R[p_j] = R;
        P.noalias() -= (1.0 / R) * PCt * PCt.transpose();
      }
      const double eps = y - yhat;
      if (per_step_log)
        logdet += std::log(R);
      else
        log_product.Multiply(R);
      r2 += eps * eps / R;
      ++p_j;
      x.noalias() += PCt * (eps / R);
    }
    if (p_j > 0) {
      const double rho = internal::HuberRho(r2, robust, huber);
      const double term = -(0.5 * (logdet + p_j * kLog2Pi) + rho);
      loglik += term;
      n_obs += p_j;
      if (ctx.terms) (*ctx.terms)[j] = term;
    }
    if constexpr (kTrace) {
      trace->x_filt.col(j) = x;
      trace->P_filt[j] = Eigen::Map<const Eigen::MatrixXd>(P.data(), n, n);
    }
    if (j == N - 1) break;
    // Time update to t_{j+1}.
    const FixedDiscrete<NX>& dd = disc[group[j]];
    x_next.noalias() = dd.Phi * x;
    x_next += dd.g;
    if (has_inputs) {
      const double* u0 = U + static_cast<std::size_t>(j) * m;
      if (m == 1) {  // the common case, without a dynamic-size product
        x_next.noalias() += dd.Gamma0.col(0) * u0[0];
        if (foh) x_next.noalias() += dd.Gamma1.col(0) * u0[1];
      } else {
        x_next.noalias() += dd.Gamma0 * Eigen::Map<const Eigen::VectorXd>(u0, m);
        if (foh) x_next.noalias() += dd.Gamma1 * Eigen::Map<const Eigen::VectorXd>(u0 + m, m);
      }
    }
    x = x_next;
    if (steady) continue;  // P is P_start again
    PhiP.noalias() = dd.Phi * P;
    P.noalias() = PhiP * dd.Phi.transpose();
    P += dd.Q;
    Symmetrize(P);
    // A step that returns P to the value it started from, bit for bit, is a fixed point of the
    // Riccati recursion: every later step with the same observations and interval repeats it.
    if (can_be_steady) steady = P == rec.P_start;
  }
  if (!per_step_log) loglik -= 0.5 * log_product.Log();
  if (!std::isfinite(loglik)) return internal::NotFiniteLoglik(series);
  return Loglik{loglik, n_obs};
}

template <bool kTrace>
Result<Loglik> Dispatch(const Context& ctx, FilterTrace* trace) {
  return WithStateDimension(ctx.ss.n_states(), [&](auto nx) {
    return FilterLoop<decltype(nx)::value, kTrace>(ctx, trace);
  });
}

// ---- 3. entry points -------------------------------------------------------------------------

}  // namespace

Result<ObservationWindow> ObservationWindowOf(const data::Series& series, int p,
                                              const FilterSettings& settings) {
  const int N = static_cast<int>(series.size());
  if (N < 2) return InputError(fmt::format("{}: at least two rows are needed", series.source));
  ObservationWindow w;
  w.delay = settings.delay.empty() ? std::vector<int>(p, 0) : settings.delay;
  w.first_obs = settings.first_obs.empty() ? w.delay : settings.first_obs;
  assert(static_cast<int>(w.delay.size()) == p && static_cast<int>(w.first_obs.size()) == p);
  for (int o = 0; o < p; ++o) {
    w.first_obs[o] = std::max(w.first_obs[o], w.delay[o]);
    if (w.first_obs[o] < N) w.last_j = std::max(w.last_j, N - 1 - w.delay[o]);
  }
  if (w.last_j < 0)
    return InputError(
        fmt::format("{}: the output delay ({} samples) is longer than the data "
                    "({} rows): no observation is left",
                    series.source, *std::max_element(w.delay.begin(), w.delay.end()), N));
  return w;
}

namespace {

template <bool kTrace>
Result<Loglik> Run(const model::StateSpace& ss, const data::Series& series,
                   const FilterSettings& settings, FilterTrace* trace, std::vector<double>* terms) {
  assert(series.U.rows() == ss.n_inputs() && series.Y.rows() == ss.n_outputs() &&
         "series bound to the model");
  auto window = ObservationWindowOf(series, ss.n_outputs(), settings);
  if (!window) return window.error();
  const auto disc = DiscretizeIntervals(ss, series, settings.hold);
  if (!disc) return disc.error();
  auto P0 = settings.P0.size() > 0 ? Result<Eigen::MatrixXd>(settings.P0)
                                   : InitialCovarianceFrom(ss, series, settings, &*disc);
  if (!P0) return P0.error();
  if (terms) terms->assign(series.size(), 0.0);
  const Context ctx{
      terms, ss, series, settings, *disc, *P0, window->delay, window->first_obs, window->last_j};
  return Dispatch<kTrace>(ctx, trace);
}

}  // namespace

Result<Loglik> LogLikelihood(const model::StateSpace& ss, const data::Series& series,
                             const FilterSettings& settings, std::vector<double>* terms) {
  return Run<false>(ss, series, settings, nullptr, terms);
}

Result<Loglik> RunFilter(const model::StateSpace& ss, const data::Series& series,
                         const FilterSettings& settings, FilterTrace* trace) {
  assert(trace != nullptr);
  return Run<true>(ss, series, settings, trace, nullptr);
}

}  // namespace gb::filter
