// The loops over a series of the linear filter (kalman.h: LogLikelihood, RunFilter) and of its
// score (score.h: LogLikelihoodScore), templated on the state dimension NX; each state index is
// one LinearStep (linear_step.h): the measurement updates with the outputs observed there, the
// log-likelihood term, the time update, and the steady-state replay. Not part of the public API.
//
// Each dimension is instantiated in a file of its own, core/filter/generated/linear_nx<NX>.cpp
// (1..8, those up to kMaxFixedStates) and linear_dynamic.cpp (Eigen::Dynamic), so that they
// compile in parallel; kalman.cpp and score.cpp choose one with WithStateDimension.
#pragma once

#include <algorithm>
#include <atomic>
#include <bit>
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

  // What the loops read off it: the states, outputs, inputs, parameters and rows, and whether
  // the inputs are held first-order.
  struct Sizes {
    int n, p, m, k, N;
    bool foh;
  };
  Sizes sizes() const {
    return {ss.n_states(),
            ss.n_outputs(),
            ss.n_inputs(),
            static_cast<int>(dss.size()),
            static_cast<int>(series.size()),
            settings.hold == model::InputHold::kFoh};
  }
};

// The measurement updates of state index j: the outputs observed there, one scalar at a time
// (kScores: with the sensitivities, into *scores), recorded or replayed by *replay, added up in
// *sums. False, with *error set, for an R that is not positive. *P_start (when given): P at the
// index's start (the replayed step's record while replaying). Up to 64 outputs, the bits of
// their mask give them (no list to fill and walk: ObservationRule::Mask); *observed is the list
// for more (where SteadyReplay is off, so no mask is needed).
// Inlined, as are the step's updates: in the steady state a step is a few dozen flops, and the
// calls cost as much (bench/loglik_bench, docs/benchmarks.md).
template <int NX, bool kScores>
[[gnu::always_inline]] inline bool MeasurementUpdates(
    int j, const data::Series& series, const ObservationRule& rule, LinearStep<NX>& step,
    LinearState<NX>* s, SteadyReplay<NX>* replay, TermSums* sums, TermScores* scores,
    ObservedOutputs* observed, Error* error, typename LinearState<NX>::Mat* P_start = nullptr) {
  const int m = static_cast<int>(series.U.rows());
  const int N = static_cast<int>(series.size());
  const int group = j == N - 1 ? -1 : series.intervals.group[j];
  sums->Begin();
  if constexpr (kScores) scores->Begin();
  const double* u = series.U.data() + static_cast<std::size_t>(j) * m;
  const bool by_mask = rule.p() <= 64;
  std::uint64_t bits = 0;
  if (by_mask)
    bits = rule.Mask(j);
  else
    ObservedAt(j, rule, observed);
  replay->Begin(bits, group, &s->P, &s->dP);
  if (P_start) *P_start = replay->replaying() ? replay->PStart() : s->P;
  for (int next = 0;; ++next) {
    int o;
    if (by_mask) {
      if (bits == 0) break;
      o = std::countr_zero(bits);
      bits &= bits - 1;
    } else {
      if (next == observed->size()) break;
      o = observed->begin()[next];
    }
    const int k = rule.Row(j, o);
    double R;
    if (!step.template MeasurementUpdate<kScores>(o, rule.Y(k, o), u, s, replay, sums, scores,
                                                  &R)) {
      *error = NotPositiveInnovationVariance(series, o, k, R);
      return false;
    }
  }
  return true;
}

// Whether index j + 1 (at most `last`; the series has N) replays the steady state's next step:
// its outputs (*bits) and interval (*group) those the replay recorded, and no cancel found set
// there. It is then the replay's current step (SteadyReplay::Holds).
template <int NX>
[[gnu::always_inline]] inline bool NextReplays(int j, int last, int N, const data::Series& series,
                                               const ObservationRule& rule,
                                               const std::atomic<bool>* cancel,
                                               SteadyReplay<NX>* replay, std::uint64_t* bits,
                                               int* group) {
  if (!replay->replaying() || j >= last || CancelledAt(cancel, j + 1)) return false;
  *group = j + 1 == N - 1 ? -1 : series.intervals.group[j + 1];
  *bits = rule.Mask(j + 1);
  return replay->Holds(*bits, *group);
}

// A replayed index j's scalar updates (outputs `bits`, inputs u): x̂ corrected with the recorded
// gains, its term's sums in *sums.
template <int NX>
[[gnu::always_inline]] inline void ReplayedUpdates(int j, std::uint64_t bits,
                                                   const ObservationRule& rule, const double* u,
                                                   const LinearStep<NX>& step,
                                                   const SteadyReplay<NX>& replay,
                                                   typename LinearState<NX>::Vec* x,
                                                   TermSums* sums) {
  sums->Begin();
  for (int q = 0; bits != 0; ++q, bits &= bits - 1) {
    const int o = std::countr_zero(bits);
    const double eps = step.Innovation(o, rule.Y(rule.Row(j, o), o), u, *x);
    LinearStep<NX>::Correct(eps, replay.Gain(q), replay.R(q), x, sums);
  }
}

// State index j's term from its sums, added to *loglik and *n_obs (and stored in (*terms)[j]).
[[gnu::always_inline]] inline void AddTerm(int j, const TermSums& sums, bool robust, double huber,
                                           double* loglik, long* n_obs,
                                           std::vector<double>* terms) {
  if (sums.p_j == 0) return;
  const double term = LoglikTerm(sums.logdet, sums.p_j, sums.r2, robust, huber);
  *loglik += term;
  *n_obs += sums.p_j;
  if (terms) (*terms)[j] = term;
}

// log L (and the per-index terms when ctx.terms is set); with kTrace, fills *trace over every row
// (no steady-state replay). Flattened (every call in it inlined, Eigen's included): where GCC
// leaves one of Eigen's small operations a call, x̂ goes through memory on the loop's critical
// chain, and which ones it leaves changes with the code around them (docs/benchmarks.md).
template <int NX, bool kTrace>
[[gnu::flatten]] Result<Loglik> FilterLoop(const FilterContext& ctx, FilterTrace* trace) {
  const model::StateSpace& ss = ctx.ss;
  const data::Series& series = ctx.series;
  const int n = ss.n_states();
  const int p = ss.n_outputs();
  const int m = ss.n_inputs();
  const int N = static_cast<int>(series.size());
  const bool foh = ctx.settings.hold == model::InputHold::kFoh;
  const std::vector<FixedDiscrete<NX>> disc(ctx.disc.begin(), ctx.disc.end());

  LinearStep<NX> step(ss, {});
  // x̂ and P, and what an index's updates add up, are the loop's own (kept in registers).
  LinearState<NX> state;
  state.x = ctx.settings.x0.size() > 0 ? ctx.settings.x0 : ss.x0;
  state.P = ctx.P0;
  SteadyReplay<NX> replay(!kTrace && ctx.settings.steady_replay, n, p, 0);
  // Without per-step terms, Σ log R is accumulated as a product (one log per series).
  const bool per_step_log = kTrace || ctx.terms != nullptr;
  TermSums sums;
  sums.use_product = !per_step_log;
  const ObservationRule rule(series, ctx.window);
  ObservedOutputs observed(rule.p());
  const bool robust = ctx.settings.huber.has_value();  // read once, not every row
  const double huber = ctx.settings.huber.value_or(0.0);
  Error error;
  if constexpr (kTrace) ResetTrace(n, p, N, trace);
  const bool has_D = m > 0 && ss.D.cwiseAbs().maxCoeff() != 0.0;

  double loglik = 0.0;
  long n_obs = 0, replayed = 0;
  const int j_end = kTrace ? N - 1 : ctx.window.last_j;
  for (int j = 0; j <= j_end; ++j) {
    if (CancelledAt(ctx.settings.cancel, j)) return NumericalError("cancelled");
    if constexpr (kTrace) {
      trace->x_pred.col(j) = state.x;
      trace->P_pred[j] = Eigen::Map<const Eigen::MatrixXd>(state.P.data(), n, n);
      for (int o = 0; o < p; ++o) {
        const int k = j + ctx.window.delay[o];
        if (k >= N) continue;
        double yhat = step.c(o).dot(state.x) + ss.d(o);
        if (has_D) yhat += ss.D.row(o).dot(series.U.col(j));
        trace->y_pred(o, k) = yhat;
        trace->y_var(o, k) = (step.c(o) * state.P * step.c(o).transpose()).value() + ss.S(o);
      }
    }
    // Measurement update: the observations that see x_j.
    if (!MeasurementUpdates<NX, false>(j, series, rule, step, &state, &replay, &sums, nullptr,
                                       &observed, &error))
      return error;
    replayed += replay.replaying() ? 1 : 0;
    AddTerm(j, sums, robust, huber, &loglik, &n_obs, ctx.terms);
    if constexpr (kTrace) {
      trace->x_filt.col(j) = state.x;
      trace->P_filt[j] = Eigen::Map<const Eigen::MatrixXd>(state.P.data(), n, n);
    }
    if (j == N - 1) break;
    // Time update to t_{j+1}.
    const double* u = series.U.data() + static_cast<std::size_t>(j) * m;
    step.template TimeUpdate<false>(disc[series.intervals.group[j]],
                                    static_cast<const FixedDiscrete<NX>*>(nullptr), u, u + m, foh,
                                    replay.replaying(), &state);
    replay.End(state.P, state.dP);
    // The steady state: while the next indices observe the recorded outputs over the recorded
    // interval, only x̂ moves, with the recorded gains, in a loop with nothing else to look at
    // (the same updates as the general step's replay). The index that breaks it, the last one,
    // and one where the cancel flag is found set go back to the general loop.
    if constexpr (!kTrace) {
      std::uint64_t bits = 0;
      int group = -1;
      while (NextReplays(j, j_end, N, series, rule, ctx.settings.cancel, &replay, &bits, &group)) {
        ++j;
        ++replayed;
        const double* u_j = series.U.data() + static_cast<std::size_t>(j) * m;
        ReplayedUpdates(j, bits, rule, u_j, step, replay, &state.x, &sums);
        AddTerm(j, sums, robust, huber, &loglik, &n_obs, ctx.terms);
        step.AdvanceMean(disc[group], u_j, u_j + m, foh, &state.x);
      }
    }
  }
  if (!per_step_log) loglik -= 0.5 * sums.product.Log();
  if (!std::isfinite(loglik)) return NotFiniteLoglik(series);
  return Loglik{loglik, n_obs, replayed};
}

// Whether every state index from j0 to the loop's last repeats the cycles `replay` replays: the
// same outputs observed and, but after the last index, the same interval.
template <int NX>
[[gnu::noinline]] bool RepeatsToTheEnd(const ScoreContext& ctx, const ObservationRule& rule,
                                       const SteadyReplay<NX>& replay, int j0) {
  const int last = ctx.window.last_j;
  for (int j = j0; j <= last; ++j)
    if (rule.Mask(j) != replay.mask() ||
        (j < last && ctx.series.intervals.group[j] != replay.group()))
      return false;
  return true;
}

// The gradient of the steady state's terms by its adjoint (the gradient alone, no row's score):
// where the replay began at index j0 and its cycles repeat to the loop's last index
// (RepeatsToTheEnd), those indices move x̂ only, with the recorded gains, and the gradient of
// their terms is
//   λ_j0' dx̂_i(j0)
//   + Σ over each cycle's steps and their updates: ∂/∂k · dk_i + ∂/∂R dR_i
//   + Σ over the outputs: ∂/∂c_o · dc_o,i + ∂/∂d_o dd_o,i + ∂/∂D_o · dD_o,i
//   + <∂/∂Φ, dΦ_i> + ∂/∂g · dg_i + <∂/∂Γ0, dΓ0_i> (+ <∂/∂Γ1, dΓ1_i>),
// each ∂ summed over the indices in one backward pass of the adjoint λ of x̂ (n numbers per index)
// instead of k sensitivities of x̂ carried forward (k n per index). Adds the indices' log L (the
// forward recursion's to the bit: the same updates in the same order), their observations and
// gradient (the forward one's to rounding). s: the state at j0. False when cancelled.
template <int NX>
[[gnu::noinline, gnu::flatten]] bool AdjointOfTheSteadyState(
    const ScoreContext& ctx, const ObservationRule& rule, LinearStep<NX>& step,
    const SteadyReplay<NX>& replay, const std::vector<FixedDiscrete<NX>>& disc,
    const std::vector<FixedDiscrete<NX>>& ddisc, int j0, const LinearState<NX>& s, double* loglik,
    long* n_obs, Eigen::VectorXd* gradient) {
  using Vec = typename LinearState<NX>::Vec;
  using Mat = typename LinearState<NX>::Mat;
  const data::Series& series = ctx.series;
  const int n = ctx.ss.n_states();
  const int m = ctx.ss.n_inputs();
  const int k = static_cast<int>(ctx.dss.size());
  const bool foh = ctx.settings.hold == model::InputHold::kFoh;
  const int last = ctx.window.last_j;
  const int rows = last - j0 + 1;
  std::vector<int> outputs;  // the observed outputs, in the order of their updates
  for (std::uint64_t bits = replay.mask(); bits != 0; bits &= bits - 1)
    outputs.push_back(std::countr_zero(bits));
  const int p = static_cast<int>(outputs.size());
  const FixedDiscrete<NX>& d = disc[replay.group()];
  // The dP_i's periods, each once: the derivatives' sums are kept per step of each cycle.
  std::vector<int> periods, period_of(k);
  for (int i = 0; i < k; ++i) {
    const int L = replay.Period(i + 1);
    auto at = std::find(periods.begin(), periods.end(), L);
    period_of[i] = static_cast<int>(at - periods.begin());
    if (at == periods.end()) periods.push_back(L);
  }

  // P's cycle: the record of each of its steps (the t-th replayed index is at t mod its period,
  // which the loops count instead of dividing).
  const int L0 = replay.Period(0);
  std::vector<const typename SteadyReplay<NX>::Record*> cycle(L0);
  for (int t = 0; t < L0; ++t) cycle[t] = &replay.PartStep(0, t);
  // And log R of each of their updates, the value Correct would take each time.
  std::vector<double> log_R(static_cast<std::size_t>(L0) * p);
  for (int t = 0; t < L0; ++t)
    for (int q = 0; q < p; ++q)
      log_R[static_cast<std::size_t>(t) * p + q] = std::log(cycle[t]->R[q]);

  // Forward: x̂ before each index's updates and after them ([r * (p + 1) + q]), the innovations
  // and ρ'(r²), and the terms.
  std::vector<Vec> x_at(static_cast<std::size_t>(rows) * (p + 1), Vec::Zero(n));
  std::vector<double> eps(static_cast<std::size_t>(rows) * p), d_rho(rows, 0.5);
  Vec x = s.x;
  TermSums sums;
  for (int r = 0, phase = 0; r < rows; ++r, phase = phase + 1 == L0 ? 0 : phase + 1) {
    const int j = j0 + r;
    if (CancelledAt(ctx.settings.cancel, j)) return false;
    const auto& record = *cycle[phase];
    const double* u = series.U.data() + static_cast<std::size_t>(j) * m;
    Vec* x_r = x_at.data() + static_cast<std::size_t>(r) * (p + 1);
    sums.Begin();
    for (int q = 0; q < p; ++q) {
      const int o = outputs[q];
      x_r[q] = x;
      const double e = step.Innovation(o, rule.Y(rule.Row(j, o), o), u, x);
      eps[static_cast<std::size_t>(r) * p + q] = e;
      // Correct's update, with its log R from the cycle's.
      const double R = record.R[q];
      x.noalias() += record.PCt[q] * (e / R);
      sums.logdet += log_R[static_cast<std::size_t>(phase) * p + q];
      sums.r2 += e * e / R;
      ++sums.p_j;
    }
    x_r[p] = x;
    if (sums.p_j > 0) {
      *loglik += LoglikTerm(sums.logdet, sums.p_j, sums.r2, ctx.settings.huber, &d_rho[r]);
      *n_obs += sums.p_j;
    }
    if (j == last) break;  // (no later term reads x̂ past the loop's last index)
    step.AdvanceMean(d, u, u + m, foh, &x);
  }

  // Backward: λ = ∂(the terms from here on)/∂x̂, and the sums the derivatives are contracted with.
  Vec lambda = Vec::Zero(n);
  Mat dPhi_sum = Mat::Zero(n, n);  // Σ λ_{j+1} x̂_j' (x̂ after the updates)
  Vec dg_sum = Vec::Zero(n);
  using Inputs = Eigen::Matrix<double, NX, Eigen::Dynamic>;  // n x m, as Γ0 and Γ1
  Inputs dGamma0_sum = Inputs::Zero(n, m), dGamma1_sum = Inputs::Zero(n, m);
  // Per period v: the sums of the cycle's steps' updates, [phase * p + q].
  std::vector<std::vector<Vec>> dk_sum;
  std::vector<std::vector<double>> dR_sum;
  for (const int L : periods) {
    const std::size_t updates = static_cast<std::size_t>(std::min(L, rows)) * p;
    dk_sum.emplace_back(updates, Vec::Zero(n));
    dR_sum.emplace_back(updates, 0.0);
  }
  std::vector<Vec> dc_sum(p, Vec::Zero(n));
  std::vector<double> dd_sum(p, 0.0);
  Eigen::MatrixXd dD_sum = Eigen::MatrixXd::Zero(p, m);
  // Φ' as a matrix of its own: Φ' λ by columns, without the sums across a vector's lanes that
  // put λ through memory on its chain.
  const Mat PhiT = d.Phi.transpose();
  // P's and each period's phase at the index r (r mod the period), counted down.
  int phase0 = (rows - 1) % L0;
  std::vector<int> phase(periods.size());
  for (std::size_t v = 0; v < periods.size(); ++v) phase[v] = (rows - 1) % periods[v];
  for (int r = rows - 1; r >= 0; --r) {
    const int j = j0 + r;
    const auto& record = *cycle[phase0];
    const double* u = series.U.data() + static_cast<std::size_t>(j) * m;
    const Vec* x_q = x_at.data() + static_cast<std::size_t>(r) * (p + 1);
    if (j < last) {  // x̂_{j+1} = Φ x̂_j + g + Γ0 u_j (+ Γ1 u_{j+1})
      dPhi_sum.noalias() += lambda * x_q[p].transpose();
      dg_sum += lambda;
      for (int l = 0; l < m; ++l) {
        dGamma0_sum.col(l) += lambda * u[l];
        if (foh) dGamma1_sum.col(l) += lambda * u[m + l];
      }
      lambda = PhiT * lambda;
    }
    for (int q = p - 1; q >= 0; --q) {  // x̂ += k ε/R, ε = y - c_o x̂ - d_o - D_o u
      const double e = eps[static_cast<std::size_t>(r) * p + q];
      const double R = record.R[q];
      const Vec& gain = record.PCt[q];
      const double lk = lambda.dot(gain);
      const double inv_R = 1.0 / R;                        // (off λ's chain)
      const double w = (lk - 2.0 * d_rho[r] * e) * inv_R;  // ∂/∂ε
      const double dR_adjoint = ((d_rho[r] * e * e - lk * e) * inv_R - 0.5) * inv_R;  // ∂/∂R
      for (std::size_t v = 0; v < periods.size(); ++v) {
        const std::size_t at = static_cast<std::size_t>(phase[v]) * p + q;
        dk_sum[v][at].noalias() += lambda * (e * inv_R);
        dR_sum[v][at] += dR_adjoint;
      }
      dc_sum[q].noalias() -= w * x_q[q];
      dd_sum[q] -= w;
      for (int l = 0; l < m; ++l) dD_sum(q, l) -= w * u[l];
      lambda.noalias() -= w * step.c(outputs[q]).transpose();
    }
    phase0 = (phase0 == 0 ? L0 : phase0) - 1;
    for (std::size_t v = 0; v < periods.size(); ++v)
      phase[v] = (phase[v] == 0 ? periods[v] : phase[v]) - 1;
  }

  const int group = replay.group();
  for (int i = 0; i < k; ++i) {
    double g = lambda.dot(s.dx[i]);
    const int v = period_of[i];
    for (std::size_t a = 0; a < dR_sum[v].size(); ++a) {
      const auto& record = replay.PartStep(i + 1, static_cast<long>(a) / p);
      const std::size_t at = replay.At(static_cast<int>(a % p), i);
      g += dk_sum[v][a].dot(record.dPCt[at]) + dR_sum[v][a] * record.dR[at];
    }
    for (int q = 0; q < p; ++q) {
      const int o = outputs[q];
      g += dc_sum[q].dot(step.dc(o, i).transpose()) + dd_sum[q] * step.dd(o, i);
      if (m > 0) g += dD_sum.row(q).dot(step.dD(i).row(o));
    }
    const FixedDiscrete<NX>& di = ddisc[static_cast<std::size_t>(group) * k + i];
    g += di.Phi.cwiseProduct(dPhi_sum).sum() + di.g.dot(dg_sum);
    if (m > 0) {
      g += (di.Gamma0.cwiseProduct(dGamma0_sum)).sum();
      if (foh) g += (di.Gamma1.cwiseProduct(dGamma1_sum)).sum();
    }
    (*gradient)(i) += g;
  }
  return true;
}

// log L and its gradient (k) by the adjoint of the whole recursion (the gradient alone, no row's
// score). One pass forward, the filter's own (the steady state replayed), keeps x̂ and P at each
// index's start; one pass backward recomputes each index's scalar updates from them and carries
// λ = ∂(the terms from here on)/∂x̂ and Λ = ∂/∂P (symmetric) back through them:
//   update (k = P c', R = c k + S_o, ε = y - c x̂ - d_o - D_o u, x̂ += k ε/R, P -= k k'/R):
//     w = ∂/∂ε = (λ'k - 2 ρ' ε)/R,   R̄ = (ρ' ε² - λ'k ε + k'Λk)/R² - ½/R,
//     k̄ = λ ε/R - 2 Λ k/R + R̄ c',   c̄_o += R̄ k + P k̄ - w x̂,   S̄_o += R̄,   d̄_o -= w,
//     D̄_o -= w u',   Λ += ½ (k̄ c + c' k̄'),   λ -= w c'
//   time update (x̂' = Φ x̂ + g + Γ0 u_j (+ Γ1 u_{j+1}), P' = Φ P Φ' + Q):
//     Φ̄ += λ x̂' + 2 Λ Φ P,   Q̄ += Λ,   ḡ += λ,   Γ̄0 += λ u_j',   λ <- Φ'λ,   Λ <- Φ'ΛΦ
// and at the first index λ'dx̂0_i + <Λ, dP0_i>; the sums (per interval for Φ, Q, g, Γ; per
// output for c, S, d, D) are contracted with the model's derivatives once. Its cost does not grow
// with the parameters: about n³ per index, against the forward sensitivities' k n³ where the
// covariances have not settled. log L is the forward recursion's to the bit (the same updates in
// the same order as ScoreLoop's); the gradient is the forward one's to rounding. Fixed sizes and
// at most 64 outputs (the caller checks).
template <int NX>
[[gnu::noinline, gnu::flatten]] Result<Loglik> AdjointOfTheSeries(const ScoreContext& ctx,
                                                                  Eigen::VectorXd* gradient) {
  using Vec = typename LinearState<NX>::Vec;
  using Mat = typename LinearState<NX>::Mat;
  using Row = typename LinearStep<NX>::Row;
  using Inputs = Eigen::Matrix<double, NX, Eigen::Dynamic>;  // n x m, as Γ0 and Γ1
  const model::StateSpace& ss = ctx.ss;
  const data::Series& series = ctx.series;
  const auto [n, p, m, k, N, foh] = ctx.sizes();
  const int last = ctx.window.last_j;
  const int groups = static_cast<int>(ctx.disc.size());
  std::vector<FixedDiscrete<NX>> disc(ctx.disc.begin(), ctx.disc.end());

  // Forward: the filter, keeping x̂ and P at each index's start and ρ'(r²) of its term.
  LinearStep<NX> step(ss, ctx.dss);
  LinearState<NX> state;
  state.x = ss.x0;
  state.P = ctx.P0;
  SteadyReplay<NX> replay(ctx.settings.steady_replay, n, p, 0);
  const ObservationRule rule(series, ctx.window);
  ObservedOutputs observed(rule.p());
  TermSums sums;
  Error error;
  const int rows = last + 1;
  std::vector<Vec> x_start(rows, Vec::Zero(n));
  std::vector<Mat> P_start(rows, Mat::Zero(n, n));
  std::vector<double> d_rho(rows, 0.5);
  double loglik = 0.0;
  long n_obs = 0, replayed = 0;
  for (int j = 0; j <= last; ++j) {
    if (CancelledAt(ctx.settings.cancel, j)) return NumericalError("cancelled");
    x_start[j] = state.x;
    if (!MeasurementUpdates<NX, false>(j, series, rule, step, &state, &replay, &sums, nullptr,
                                       &observed, &error, &P_start[j]))
      return error;
    replayed += replay.replaying() ? 1 : 0;
    if (sums.p_j > 0) {
      loglik += LoglikTerm(sums.logdet, sums.p_j, sums.r2, ctx.settings.huber, &d_rho[j]);
      n_obs += sums.p_j;
    }
    if (j == N - 1) break;
    const double* u = series.U.data() + static_cast<std::size_t>(j) * m;
    step.template TimeUpdate<false>(disc[series.intervals.group[j]],
                                    static_cast<const FixedDiscrete<NX>*>(nullptr), u, u + m, foh,
                                    replay.replaying(), &state);
    replay.End(state.P, state.dP);
    // The steady state as FilterLoop steps it (only x̂ moves, with the recorded gains); the index
    // that breaks it, the last one and one where the cancel flag is set go back to the loop.
    std::uint64_t bits = 0;
    int group = -1;
    while (NextReplays(j, last, N, series, rule, ctx.settings.cancel, &replay, &bits, &group)) {
      ++j;
      ++replayed;
      x_start[j] = state.x;
      P_start[j] = replay.PStart();
      const double* u_j = series.U.data() + static_cast<std::size_t>(j) * m;
      ReplayedUpdates(j, bits, rule, u_j, step, replay, &state.x, &sums);
      if (sums.p_j > 0) {
        loglik += LoglikTerm(sums.logdet, sums.p_j, sums.r2, ctx.settings.huber, &d_rho[j]);
        n_obs += sums.p_j;
      }
      step.AdvanceMean(disc[group], u_j, u_j + m, foh, &state.x);
    }
  }

  // Backward.
  Vec lambda = Vec::Zero(n);
  Mat Lambda = Mat::Zero(n, n);
  std::vector<Mat> Phi_bar(groups, Mat::Zero(n, n)), Q_bar(groups, Mat::Zero(n, n));
  std::vector<Vec> g_bar(groups, Vec::Zero(n));
  std::vector<Inputs> Gamma0_bar(groups, Inputs::Zero(n, m)),
      Gamma1_bar(groups, Inputs::Zero(n, m));
  std::vector<Vec> c_bar(p, Vec::Zero(n));
  Eigen::VectorXd S_bar = Eigen::VectorXd::Zero(p), d_bar = Eigen::VectorXd::Zero(p);
  Eigen::MatrixXd D_bar = Eigen::MatrixXd::Zero(p, m);
  // One index's updates recomputed: x̂ and P before each, its output, k, R and ε.
  std::vector<Vec> x_q(p + 1, Vec::Zero(n)), PCt(p, Vec::Zero(n));
  std::vector<Mat> P_q(p + 1, Mat::Zero(n, n));
  std::vector<int> o_q(p);
  std::vector<double> R_q(p), inv_R_q(p), e_q(p);
  std::vector<Mat> PhiT(disc.size());  // Φ' per interval, as AdjointOfTheSteadyState keeps it
  for (std::size_t g = 0; g < disc.size(); ++g) PhiT[g] = disc[g].Phi.transpose();
  for (int j = last; j >= 0; --j) {
    if (CancelledAt(ctx.settings.cancel, j)) return NumericalError("cancelled");
    const double* u = series.U.data() + static_cast<std::size_t>(j) * m;
    x_q[0] = x_start[j];
    P_q[0] = P_start[j];
    int updates = 0;
    for (std::uint64_t bits = rule.Mask(j); bits != 0; bits &= bits - 1, ++updates) {
      const int o = std::countr_zero(bits);
      const int q = updates;
      const Row& c = step.c(o);
      o_q[q] = o;
      PCt[q].noalias() = P_q[q] * c.transpose();
      R_q[q] = c.dot(PCt[q]) + step.S(o);
      inv_R_q[q] = 1.0 / R_q[q];  // (for the update of P and the adjoint's, once)
      e_q[q] = step.Innovation(o, rule.Y(rule.Row(j, o), o), u, x_q[q]);
      x_q[q + 1] = x_q[q];
      x_q[q + 1].noalias() += PCt[q] * (e_q[q] / R_q[q]);
      P_q[q + 1] = P_q[q];
      P_q[q + 1].noalias() -= inv_R_q[q] * PCt[q] * PCt[q].transpose();
    }
    if (j < last && j < N - 1) {  // the time update to j + 1
      const int g = series.intervals.group[j];
      const Mat LPhi = Lambda * disc[g].Phi;
      Phi_bar[g].noalias() += lambda * x_q[updates].transpose();
      Phi_bar[g].noalias() += 2.0 * LPhi * P_q[updates];
      Q_bar[g] += Lambda;
      g_bar[g] += lambda;
      for (int l = 0; l < m; ++l) {
        Gamma0_bar[g].col(l) += lambda * u[l];
        if (foh) Gamma1_bar[g].col(l) += lambda * u[m + l];
      }
      lambda = PhiT[g] * lambda;
      Lambda.noalias() = PhiT[g] * LPhi;
    }
    for (int q = updates - 1; q >= 0; --q) {
      const int o = o_q[q];
      const Row& c = step.c(o);
      const Vec& gain = PCt[q];
      const double e = e_q[q], rho = d_rho[j];
      const Vec Lk = Lambda * gain;
      const double lk = lambda.dot(gain);
      const double inv_R = inv_R_q[q];
      const double w = (lk - 2.0 * rho * e) * inv_R;
      const double R_bar = ((rho * e * e - lk * e + gain.dot(Lk)) * inv_R - 0.5) * inv_R;
      Vec k_bar = lambda * (e * inv_R) - Lk * (2.0 * inv_R);
      k_bar += R_bar * c.transpose();
      c_bar[o] += R_bar * gain + P_q[q] * k_bar - w * x_q[q];
      S_bar(o) += R_bar;
      d_bar(o) -= w;
      for (int l = 0; l < m; ++l) D_bar(o, l) -= w * u[l];
      const Mat kc = k_bar * c;
      Lambda += 0.5 * (kc + kc.transpose());
      lambda.noalias() -= w * c.transpose();
    }
  }

  gradient->setZero(k);
  for (int i = 0; i < k; ++i) {
    double gi = lambda.dot(ctx.dss[i].x0) + (Lambda.cwiseProduct(ctx.dP0[i])).sum();
    for (int g = 0; g < groups; ++g) {
      const Discrete& di = ctx.ddisc[g][i];
      gi += (di.Phi.cwiseProduct(Phi_bar[g])).sum() + (di.Q.cwiseProduct(Q_bar[g])).sum() +
            di.g.dot(g_bar[g]);
      if (m > 0) {
        gi += (di.Gamma0.cwiseProduct(Gamma0_bar[g])).sum();
        if (foh) gi += (di.Gamma1.cwiseProduct(Gamma1_bar[g])).sum();
      }
    }
    for (int o = 0; o < p; ++o) {
      gi += step.dc(o, i).dot(c_bar[o].transpose()) + step.dS(o, i) * S_bar(o) +
            step.dd(o, i) * d_bar(o);
      if (m > 0) gi += D_bar.row(o).dot(step.dD(i).row(o));
    }
    (*gradient)(i) = gi;
  }
  if (!std::isfinite(loglik) || !gradient->allFinite()) return NotFiniteLoglik(series);
  return Loglik{loglik, n_obs, replayed, rows};
}

// log L with its gradient (k) and, when J is given, the derivatives of every term (N x k).
// Flattened as FilterLoop is: when AdjointOfTheSteadyState's own Φ x̂ products came in, GCC left
// the loop's as calls, and the score of the 4-state chain took 22 % longer.
template <int NX>
[[gnu::flatten]] Result<Loglik> ScoreLoop(const ScoreContext& ctx, Eigen::VectorXd* gradient,
                                          Eigen::MatrixXd* J) {
  const model::StateSpace& ss = ctx.ss;
  const data::Series& series = ctx.series;
  const auto [n, p, m, k, N, foh] = ctx.sizes();

  if constexpr (NX != Eigen::Dynamic)
    if (!J && ctx.settings.linear_gradient == LinearGradient::kAdjoint && p <= 64)
      return AdjointOfTheSeries<NX>(ctx, gradient);
  std::vector<FixedDiscrete<NX>> disc;
  std::vector<FixedDiscrete<NX>> ddisc;  // [group * k + i]
  for (std::size_t g = 0; g < ctx.disc.size(); ++g) {
    disc.emplace_back(ctx.disc[g]);
    for (const Discrete& d : ctx.ddisc[g]) ddisc.emplace_back(d);
  }
  LinearStep<NX> step(ss, ctx.dss);
  LinearState<NX> state;
  state.x = ss.x0;
  state.P = ctx.P0;
  state.dx.resize(k);
  state.dP.resize(k);
  for (int i = 0; i < k; ++i) {
    state.dx[i] = ctx.dss[i].x0;
    state.dP[i] = ctx.dP0[i];
  }
  SteadyReplay<NX> replay(ctx.settings.steady_replay, n, p, k);
  TermSums sums;
  TermScores scores(k, false);
  Eigen::VectorXd d_term(k);
  const ObservationRule rule(series, ctx.window);
  ObservedOutputs observed(rule.p());
  Error error;
  gradient->setZero(k);
  if (J) J->setZero(N, k);

  double loglik = 0.0;
  long n_obs = 0, replayed = 0, adjoint = 0;
  for (int j = 0; j <= ctx.window.last_j; ++j) {
    if (CancelledAt(ctx.settings.cancel, j)) return NumericalError("cancelled");
    if (!MeasurementUpdates<NX, true>(j, series, rule, step, &state, &replay, &sums, &scores,
                                      &observed, &error))
      return error;
    replayed += replay.replaying() ? 1 : 0;
    if (sums.p_j > 0) {
      double d_rho = 0.5;
      loglik += LoglikTerm(sums.logdet, sums.p_j, sums.r2, ctx.settings.huber, &d_rho);
      n_obs += sums.p_j;
      scores.TermScore(d_rho, &d_term);
      *gradient += d_term;
      if (J) J->row(j) = d_term.transpose();
    }
    if (j == N - 1) break;
    // Time update to t_{j+1}: the sensitivities first, as they read the old x and P.
    const int g = series.intervals.group[j];
    const double* u = series.U.data() + static_cast<std::size_t>(j) * m;
    step.template TimeUpdate<true>(disc[g], ddisc.data() + static_cast<std::size_t>(g) * k, u,
                                   u + m, foh, replay.replaying(), &state);
    const bool was_replaying = replay.replaying();
    replay.End(state.P, state.dP);
    // The steady state to the end: by its adjoint where no row's score is asked for.
    if (!J && !was_replaying && replay.replaying() && j < ctx.window.last_j &&
        ctx.settings.linear_gradient == LinearGradient::kSteadyState &&
        RepeatsToTheEnd(ctx, rule, replay, j + 1)) {
      if (!AdjointOfTheSteadyState(ctx, rule, step, replay, disc, ddisc, j + 1, state, &loglik,
                                   &n_obs, gradient))
        return NumericalError("cancelled");
      // (As replayed rows, the forward loop counts the series' last index out: with no interval
      // after it, it ends the replay, with the values the replay would have given.)
      adjoint = ctx.window.last_j - j;
      replayed += adjoint - (ctx.window.last_j == N - 1 ? 1 : 0);
      break;
    }
  }
  if (!std::isfinite(loglik) || !gradient->allFinite()) return NotFiniteLoglik(series);
  return Loglik{loglik, n_obs, replayed, adjoint};
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
