// Sections: 1. settings and P0  2. dispatch on the state dimension (the loop: linear_loops.h)
//           3. entry points
#include "core/filter/kalman.h"

#include <algorithm>
#include <cmath>
#include <complex>

#include <fmt/format.h>

#include "core/filter/discretize.h"
#include "core/filter/internal.h"
#include "core/filter/linear_loops.h"

namespace gb::filter {
namespace {

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

// ---- 2. dispatch on the state dimension ------------------------------------------------------

namespace {

template <bool kTrace>
Result<Loglik> Dispatch(const internal::FilterContext& ctx, FilterTrace* trace) {
  return WithStateDimension(ctx.ss.n_states(), [&](auto nx) {
    return internal::FilterLoop<decltype(nx)::value, kTrace>(ctx, trace);
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
  const internal::FilterContext ctx{terms, ss, series, settings, *disc, *P0, *window};
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
