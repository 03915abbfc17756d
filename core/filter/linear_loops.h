// The loops over a series of the linear filter (kalman.h: LogLikelihood, RunFilter) and of its
// score (score.h: LogLikelihoodScore), templated on the state dimension NX; each state index is
// one LinearStep (linear_step.h): the measurement updates with the outputs observed there, the
// log-likelihood term, the time update, and the steady-state replay. Not part of the public API.
//
// Each dimension is instantiated in a file of its own, core/filter/generated/linear_nx<NX>.cpp
// (1..8, those up to kMaxFixedStates) and linear_dynamic.cpp (Eigen::Dynamic), so that they
// compile in parallel; kalman.cpp and score.cpp choose one with WithStateDimension.
#pragma once

#include <atomic>
#include <cstdint>
#include <limits>
#include <span>
#include <vector>

#include <Eigen/Core>

#include "core/data/dataset.h"
#include "core/filter/discretize.h"
#include "core/filter/internal.h"
#include "core/filter/kalman.h"
#include "core/filter/linear_step.h"
#include "core/model/linear_model.h"
#include "core/util/result.h"

namespace gb::filter::internal {

// What the filter loop needs (kalman.cpp sets it up).
struct FilterContext {
  std::vector<double>* terms;  // per-state-index terms, or null
  const model::StateSpace& ss;
  const data::Series& series;
  const FilterSettings& settings;
  const std::vector<Discrete>& disc;  // per distinct interval
  const Eigen::MatrixXd& P0;
  const ObservationWindow& window;
};

// What the score loop needs (score.cpp sets it up).
struct ScoreContext {
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

// The measurement updates of state index j: the outputs observed there (into *observed), one
// scalar at a time (kScores: with the sensitivities), recorded or replayed by *replay, added up
// in *sums. False, with *error set, for an R that is not positive. Inlined, as are the step's
// updates: in the steady state a step is a few dozen flops, and the calls cost as much
// (bench/loglik_bench, docs/benchmarks.md).
template <int NX, bool kScores>
[[gnu::always_inline]] inline bool MeasurementUpdates(int j, const data::Series& series,
                                                      const ObservationWindow& window,
                                                      LinearStep<NX>* step,
                                                      SteadyReplay<NX>* replay, TermSums* sums,
                                                      std::vector<int>* observed, Error* error) {
  const int p = static_cast<int>(series.Y.rows());
  const int m = static_cast<int>(series.U.rows());
  const int N = static_cast<int>(series.size());
  const std::uint64_t mask = ObservedAt(j, series, window, observed);
  replay->Begin(mask, j == N - 1 ? -1 : series.intervals.group[j], step->P, step->dP);
  sums->Begin();
  const double* u = series.U.data() + static_cast<std::size_t>(j) * m;
  const double* Y = series.Y.data();
  for (const int o : *observed) {
    const int k = j + window.delay[o];
    double R;
    if (!step->template MeasurementUpdate<kScores>(o, Y[static_cast<std::size_t>(k) * p + o], u,
                                                   replay, sums, &R)) {
      *error = NotPositiveInnovationVariance(series, o, k, R);
      return false;
    }
  }
  return true;
}

// log L (and the per-index terms when ctx.terms is set); with kTrace, fills *trace over every row
// (no steady-state replay).
template <int NX, bool kTrace>
Result<Loglik> FilterLoop(const FilterContext& ctx, FilterTrace* trace) {
  const model::StateSpace& ss = ctx.ss;
  const data::Series& series = ctx.series;
  const int n = ss.n_states();
  const int p = ss.n_outputs();
  const int m = ss.n_inputs();
  const int N = static_cast<int>(series.size());
  const bool foh = ctx.settings.hold == model::InputHold::kFoh;
  const std::vector<FixedDiscrete<NX>> disc(ctx.disc.begin(), ctx.disc.end());

  LinearStep<NX> step(ss, {});
  step.x = ctx.settings.x0.size() > 0 ? ctx.settings.x0 : ss.x0;
  step.P = ctx.P0;
  SteadyReplay<NX> replay(!kTrace, n, p, 0);
  // Without per-step terms, Σ log R is accumulated as a product (one log per series).
  const bool per_step_log = kTrace || ctx.terms != nullptr;
  LogProduct log_product;
  TermSums sums(0, false, per_step_log ? nullptr : &log_product);
  std::vector<int> observed;
  observed.reserve(static_cast<std::size_t>(p));
  Error error;
  if constexpr (kTrace) ResetTrace(n, p, N, trace);
  const bool has_D = m > 0 && ss.D.cwiseAbs().maxCoeff() != 0.0;

  double loglik = 0.0;
  long n_obs = 0;
  const int j_end = kTrace ? N - 1 : ctx.window.last_j;
  for (int j = 0; j <= j_end; ++j) {
    if (CancelledAt(ctx.settings.cancel, j)) return NumericalError("cancelled");
    if constexpr (kTrace) {
      trace->x_pred.col(j) = step.x;
      trace->P_pred[j] = Eigen::Map<const Eigen::MatrixXd>(step.P.data(), n, n);
      for (int o = 0; o < p; ++o) {
        const int k = j + ctx.window.delay[o];
        if (k >= N) continue;
        double yhat = step.c(o).dot(step.x) + ss.d(o);
        if (has_D) yhat += ss.D.row(o).dot(series.U.col(j));
        trace->y_pred(o, k) = yhat;
        trace->y_var(o, k) = (step.c(o) * step.P * step.c(o).transpose()).value() + ss.S(o);
      }
    }
    // Measurement update: the observations that see x_j.
    if (!MeasurementUpdates<NX, false>(j, series, ctx.window, &step, &replay, &sums, &observed,
                                       &error))
      return error;
    if (sums.p_j > 0) {
      const double term = LoglikTerm(sums.logdet, sums.p_j, sums.r2, ctx.settings.huber);
      loglik += term;
      n_obs += sums.p_j;
      if (ctx.terms) (*ctx.terms)[j] = term;
    }
    if constexpr (kTrace) {
      trace->x_filt.col(j) = step.x;
      trace->P_filt[j] = Eigen::Map<const Eigen::MatrixXd>(step.P.data(), n, n);
    }
    if (j == N - 1) break;
    // Time update to t_{j+1}.
    const double* u = series.U.data() + static_cast<std::size_t>(j) * m;
    step.template TimeUpdate<false>(disc[series.intervals.group[j]],
                                    static_cast<const FixedDiscrete<NX>*>(nullptr), u, u + m, foh,
                                    replay.replaying());
    replay.End(step.P, step.dP);
  }
  if (!per_step_log) loglik -= 0.5 * log_product.Log();
  if (!std::isfinite(loglik)) return NotFiniteLoglik(series);
  return Loglik{loglik, n_obs};
}

// log L with its gradient (k) and, when J is given, the derivatives of every term (N x k).
template <int NX>
Result<Loglik> ScoreLoop(const ScoreContext& ctx, Eigen::VectorXd* gradient, Eigen::MatrixXd* J) {
  const model::StateSpace& ss = ctx.ss;
  const data::Series& series = ctx.series;
  const int n = ss.n_states();
  const int p = ss.n_outputs();
  const int m = ss.n_inputs();
  const int k = static_cast<int>(ctx.dss.size());
  const int N = static_cast<int>(series.size());
  const bool foh = ctx.settings.hold == model::InputHold::kFoh;

  std::vector<FixedDiscrete<NX>> disc;
  std::vector<FixedDiscrete<NX>> ddisc;  // [group * k + i]
  for (std::size_t g = 0; g < ctx.disc.size(); ++g) {
    disc.emplace_back(ctx.disc[g]);
    for (const Discrete& d : ctx.ddisc[g]) ddisc.emplace_back(d);
  }
  LinearStep<NX> step(ss, ctx.dss);
  step.x = ss.x0;
  step.P = ctx.P0;
  for (int i = 0; i < k; ++i) {
    step.dx[i] = ctx.dss[i].x0;
    step.dP[i] = ctx.dP0[i];
  }
  SteadyReplay<NX> replay(true, n, p, k);
  TermSums sums(k, false);
  Eigen::VectorXd d_term(k);
  std::vector<int> observed;
  observed.reserve(static_cast<std::size_t>(p));
  Error error;
  gradient->setZero(k);
  if (J) J->setZero(N, k);

  double loglik = 0.0;
  long n_obs = 0;
  for (int j = 0; j <= ctx.window.last_j; ++j) {
    if (CancelledAt(ctx.settings.cancel, j)) return NumericalError("cancelled");
    if (!MeasurementUpdates<NX, true>(j, series, ctx.window, &step, &replay, &sums, &observed,
                                      &error))
      return error;
    if (sums.p_j > 0) {
      double d_rho = 0.5;
      loglik += LoglikTerm(sums.logdet, sums.p_j, sums.r2, ctx.settings.huber, &d_rho);
      n_obs += sums.p_j;
      sums.TermScore(d_rho, &d_term);
      *gradient += d_term;
      if (J) J->row(j) = d_term.transpose();
    }
    if (j == N - 1) break;
    // Time update to t_{j+1}: the sensitivities first, as they read the old x and P.
    const int g = series.intervals.group[j];
    const double* u = series.U.data() + static_cast<std::size_t>(j) * m;
    step.template TimeUpdate<true>(disc[g], ddisc.data() + static_cast<std::size_t>(g) * k, u,
                                   u + m, foh, replay.replaying());
    replay.End(step.P, step.dP);
  }
  if (!std::isfinite(loglik) || !gradient->allFinite()) return NotFiniteLoglik(series);
  return Loglik{loglik, n_obs};
}

// The instantiations of one state dimension (`extern` here, defined in generated/). EXTERN is
// `extern` or nothing, which no parentheses can enclose.
// NOLINTBEGIN(bugprone-macro-parentheses)
#define GREYBENCH_LINEAR_LOOPS(EXTERN, NX)                                                  \
  EXTERN template Result<Loglik> FilterLoop<NX, false>(const FilterContext&, FilterTrace*); \
  EXTERN template Result<Loglik> FilterLoop<NX, true>(const FilterContext&, FilterTrace*);  \
  EXTERN template Result<Loglik> ScoreLoop<NX>(const ScoreContext&, Eigen::VectorXd*,       \
                                               Eigen::MatrixXd*);
// NOLINTEND(bugprone-macro-parentheses)

GREYBENCH_LINEAR_LOOPS(extern, 1)
GREYBENCH_LINEAR_LOOPS(extern, 2)
GREYBENCH_LINEAR_LOOPS(extern, 3)
GREYBENCH_LINEAR_LOOPS(extern, 4)
GREYBENCH_LINEAR_LOOPS(extern, 5)
GREYBENCH_LINEAR_LOOPS(extern, 6)
GREYBENCH_LINEAR_LOOPS(extern, 7)
GREYBENCH_LINEAR_LOOPS(extern, 8)
GREYBENCH_LINEAR_LOOPS(extern, Eigen::Dynamic)

}  // namespace gb::filter::internal
