#include "core/filter/likelihood.h"

#include <atomic>
#include <cmath>
#include <optional>

#include <fmt/format.h>

#include "core/filter/ekf_adjoint.h"
#include "core/filter/ekf_score.h"
#include "core/filter/internal.h"
#include "core/filter/score.h"
#include "core/util/parallel.h"

namespace gb::filter {

namespace {

// Calls run(i) for the series i in [0, n) on up to `threads` threads; run returns false when
// series i failed. A series after a failed one is skipped: the caller reports the first failure
// in the series' order, which always runs.
template <class Run>
void OverSeries(int n, int threads, Run&& run) {
  std::atomic<int> first_failed{n};
  ParallelFor(n, threads, [&](int i) {
    if (i > first_failed.load()) return;
    if (!run(i)) {
      int seen = first_failed.load();
      while (i < seen && !first_failed.compare_exchange_weak(seen, i)) {
      }
    }
  });
}

}  // namespace

struct Likelihood::Counts {
  std::atomic<long> intervals{0}, stiff_intervals{0}, steps{0}, rejected{0}, rhs{0};
  void Add(const ode::OdeCounts& c) {
    intervals += c.intervals;
    stiff_intervals += c.stiff_intervals;
    steps += c.steps;
    rejected += c.rejected;
    rhs += c.rhs;
  }
};

ode::OdeCounts Likelihood::ode_counts() const {
  ode::OdeCounts c;
  c.intervals = counts_->intervals;
  c.stiff_intervals = counts_->stiff_intervals;
  c.steps = counts_->steps;
  c.rejected = counts_->rejected;
  c.rhs = counts_->rhs;
  return c;
}

Result<Likelihood> Likelihood::Create(std::shared_ptr<const model::LinearModel> model,
                                      std::vector<std::shared_ptr<const data::Series>> series) {
  auto l = CreateFor(model->spec(), std::move(series));
  if (l) l->linear_ = std::move(model);
  return l;
}

Result<Likelihood> Likelihood::Create(std::shared_ptr<const model::NonlinearModel> model,
                                      std::vector<std::shared_ptr<const data::Series>> series) {
  auto l = CreateFor(model->spec(), std::move(series));
  if (!l) return l;
  // The derivatives for exact scores; a model whose derivatives do not compile (too deeply
  // nested) keeps the differences.
  if (auto sens = model::NonlinearSensitivity::Compile(*model))
    l->sensitivity_ = std::make_shared<const model::NonlinearSensitivity>(std::move(*sens));
  l->nonlinear_ = std::move(model);
  return l;
}

Result<Likelihood> Likelihood::WithNativeCode() const {
  Likelihood copy = *this;
  if (!nonlinear_ || nonlinear_->native()) return copy;
  std::vector<expr::NativeCode::Program> programs = nonlinear_->NativePrograms();
  const std::size_t first_derivative = programs.size();  // the derivative programs follow
  if (sensitivity_) {
    for (expr::NativeCode::Program& p : sensitivity_->NativePrograms())
      programs.push_back(std::move(p));
  }
  const model::NonlinearModel& m = *nonlinear_;
  auto code =
      expr::NativeCode::Compile(programs, [&m](const std::string& name) { return m.SlotOf(name); });
  if (!code) return code.error();
  auto model = std::make_shared<model::NonlinearModel>(*nonlinear_);
  model->UseNative(*code, 0);
  copy.nonlinear_ = std::move(model);
  if (sensitivity_) {
    auto sensitivity = std::make_shared<model::NonlinearSensitivity>(*sensitivity_);
    sensitivity->UseNative(*code, first_derivative);
    copy.sensitivity_ = std::move(sensitivity);
  }
  return copy;
}

Result<Likelihood> Likelihood::CreateFor(const model::ModelSpec& spec,
                                         std::vector<std::shared_ptr<const data::Series>> series) {
  for (const auto& s : series) {
    for (std::size_t o = 0; o < spec.outputs.size(); ++o) {
      const int max_delay = spec.output_delay[o].max;
      if (max_delay >= static_cast<int>(s->size()) - 1) {
        Error e = InputError(fmt::format(
            "the delay {}reaches {} samples but {} has only {} rows: no observation would be left",
            spec.output_delay[o].IsScan() ? "range " : "", max_delay, s->source, s->size()));
        e.file = spec.source;
        e.path = "output_delay." + spec.outputs[o];
        return e;
      }
    }
    // A record without a single observation in the rows the filter scores contributes nothing:
    // a fit to it would "converge" anywhere, with log L 0 and a BIC of -inf.
    long observed = 0;
    for (std::size_t o = 0; o < spec.outputs.size(); ++o)
      for (Eigen::Index j = spec.output_delay[o].max; j < s->Y.cols(); ++j)
        observed += std::isfinite(s->Y(static_cast<Eigen::Index>(o), j)) ? 1 : 0;
    if (observed == 0 && !spec.outputs.empty()) {
      std::string names;
      for (const auto& o : spec.outputs) names += (names.empty() ? "'" : ", '") + o + "'";
      Error e = InputError(fmt::format(
          "no observation: every value of the output{} {} is missing in the {} rows the filter "
          "uses, so there is nothing to fit or evaluate",
          spec.outputs.size() == 1 ? "" : "s", names, s->size()));
      e.file = s->source;
      return e;
    }
  }
  Likelihood l;
  l.settings_ = FilterSettings::FromModel(spec);
  for (const auto& d : spec.output_delay) l.settings_.first_obs.push_back(d.max);
  l.series_ = std::move(series);
  l.counts_ = std::make_shared<Counts>();
  return l;
}

std::vector<std::vector<int>> Likelihood::DelayGrid() const {
  std::vector<std::vector<int>> grid{{}};
  for (const auto& d : spec().output_delay) {
    std::vector<std::vector<int>> next;
    for (const auto& prefix : grid) {
      for (int v = d.min; v <= d.max; ++v) {
        next.push_back(prefix);
        next.back().push_back(v);
      }
    }
    grid = std::move(next);
  }
  return grid;
}

// Σ over the series of one(series, settings, terms of that series), with the per-series terms
// concatenated into *terms; the series on up to `threads` threads, summed in their order.
template <class One>
Result<Loglik> Likelihood::SumOverSeries(std::span<const int> delay, std::vector<double>* terms,
                                         int threads, One&& one) const {
  FilterSettings settings = settings_;
  if (!delay.empty()) settings.delay.assign(delay.begin(), delay.end());
  const int n = static_cast<int>(series_.size());
  std::vector<std::optional<Result<Loglik>>> each(series_.size());
  std::vector<std::vector<double>> series_terms(terms ? series_.size() : 0);
  OverSeries(n, threads, [&](int i) {
    each[i] = one(i, *series_[i], settings, terms ? &series_terms[i] : nullptr);
    return each[i]->ok();
  });
  Loglik total;
  if (terms) terms->clear();
  for (int i = 0; i < n; ++i) {
    if (!*each[i]) return each[i]->error();
    if (terms) terms->insert(terms->end(), series_terms[i].begin(), series_terms[i].end());
    total.loglik += (*each[i])->loglik;
    total.n_obs += (*each[i])->n_obs;
  }
  return total;
}

void Likelihood::set_series_parameters(std::vector<std::vector<int>> index) {
  assert(index.empty() || index.size() == series_.size());
  for ([[maybe_unused]] const auto& row : index)
    assert(row.empty() || row.size() == spec().parameters.size());
  series_parameters_ = std::move(index);
}

std::vector<double> SeriesTheta(std::span<const double> theta, std::span<const int> row) {
  std::vector<double> own(theta.begin(), theta.end());
  for (std::size_t i = 0; i < row.size(); ++i)
    if (row[i] >= 0) own[i] = theta[static_cast<std::size_t>(row[i])];
  return own;
}

std::vector<double> Likelihood::SeriesTheta(std::span<const double> theta, std::size_t s) const {
  if (s >= series_parameters_.size()) return {theta.begin(), theta.end()};
  return filter::SeriesTheta(theta, series_parameters_[s]);
}

Likelihood::SeriesFree Likelihood::FreeOf(std::span<const int> free, std::size_t s) const {
  SeriesFree out;
  const std::vector<int>* index = s < series_parameters_.size() && !series_parameters_[s].empty()
                                      ? &series_parameters_[s]
                                      : nullptr;
  for (std::size_t f = 0; f < free.size(); ++f) {
    if (!index) {
      out.params.push_back(free[f]);
      out.columns.push_back(static_cast<Eigen::Index>(f));
      continue;
    }
    for (std::size_t i = 0; i < index->size(); ++i) {
      if ((*index)[i] == free[f]) {
        out.params.push_back(static_cast<int>(i));
        out.columns.push_back(static_cast<Eigen::Index>(f));
      }
    }
  }
  return out;
}

Result<std::vector<model::StateSpace>> Likelihood::LinearAt(std::span<const double> theta) const {
  std::vector<model::StateSpace> out;
  const std::size_t n = series_parameters_.empty() ? 1 : series_.size();
  for (std::size_t s = 0; s < n; ++s) {
    auto ss = series_parameters_.empty() ? linear_->Evaluate(theta)
                                         : linear_->Evaluate(SeriesTheta(theta, s));
    if (!ss) return ss.error();
    out.push_back(std::move(*ss));
  }
  return out;
}

Result<Loglik> Likelihood::EvaluateAt(const std::vector<model::StateSpace>& ss,
                                      std::span<const int> delay, std::vector<double>* terms,
                                      int threads) const {
  return SumOverSeries(delay, terms, threads,
                       [&](std::size_t i, const data::Series& s, const FilterSettings& settings,
                           std::vector<double>* t) {
                         return LogLikelihood(ss[ss.size() == 1 ? 0 : i], s, settings, t);
                       });
}

Result<Loglik> Likelihood::EvaluateEkf(std::span<const double> theta, std::span<const int> delay,
                                       std::vector<double>* terms, int threads) const {
  std::vector<ode::OdeCounts> counts(series_.size());
  auto total = SumOverSeries(delay, terms, threads,
                             [&](std::size_t i, const data::Series& s,
                                 const FilterSettings& settings, std::vector<double>* t) {
                               return EkfLogLikelihood(*nonlinear_, SeriesTheta(theta, i), s,
                                                       settings, t, &counts[i]);
                             });
  for (const ode::OdeCounts& c : counts) counts_->Add(c);
  return total;
}

// Central differences of the per-state-index terms (one-sided at a bound), for callers of
// EvaluateWithScore such as `loglik --gradient`; the estimator differences the terms itself
// (estimate::Fitter::ScoresByDifferences), in its scaled units and in parallel.
Result<Loglik> Likelihood::EkfScore(std::span<const double> theta, std::span<const int> delay,
                                    std::span<const int> free, Eigen::VectorXd* gradient,
                                    Eigen::MatrixXd* J_terms_theta) const {
  std::vector<double> terms;
  auto centre = EvaluateEkf(theta, delay, &terms);
  if (!centre) return centre.error();
  const Eigen::Index rows = static_cast<Eigen::Index>(terms.size());
  const Eigen::Index k = static_cast<Eigen::Index>(free.size());
  Eigen::MatrixXd J(rows, k);
  std::vector<double> shifted(theta.begin(), theta.end());
  std::vector<double> up, down;
  const auto& parameters = spec().parameters;
  for (Eigen::Index f = 0; f < k; ++f) {
    if (settings_.cancel && settings_.cancel->load(std::memory_order_relaxed))
      return NumericalError("cancelled");
    const int i = free[f];
    const model::Parameter& par = parameters[i];
    const double width = par.lower && par.upper ? *par.upper - *par.lower : 1.0;
    const double h = kDifferenceStep * std::max(std::abs(theta[i]), 1e-3 * width);
    const bool can_up = !par.upper || theta[i] + h <= *par.upper;
    const bool can_down = !par.lower || theta[i] - h >= *par.lower;
    // A side whose filter fails (the model leaves its domain there) falls back to one-sided.
    double lo = theta[i], hi = theta[i];
    up = terms;
    down = terms;
    if (can_up) {
      shifted[i] = theta[i] + h;
      if (EvaluateEkf(shifted, delay, &up))
        hi = shifted[i];
      else
        up = terms;
    }
    if (can_down) {
      shifted[i] = theta[i] - h;
      if (EvaluateEkf(shifted, delay, &down))
        lo = shifted[i];
      else
        down = terms;
    }
    shifted[i] = theta[i];
    if (hi == lo)
      return NumericalError(fmt::format(
          "the log-likelihood cannot be differentiated in {} at {:g}: the filter fails on both "
          "sides (or there is no room between the bounds)",
          par.name, theta[i]));
    for (Eigen::Index r = 0; r < rows; ++r) J(r, f) = (up[r] - down[r]) / (hi - lo);
  }
  *gradient = J.colwise().sum().transpose();
  if (J_terms_theta) *J_terms_theta = std::move(J);
  return centre;
}

Result<Loglik> Likelihood::Evaluate(std::span<const double> theta, std::span<const int> delay,
                                    std::vector<double>* terms, int threads) const {
  if (nonlinear_) return EvaluateEkf(theta, delay, terms, threads);
  auto ss = LinearAt(theta);
  if (!ss) return ss.error();
  return EvaluateAt(*ss, delay, terms, threads);
}

// The scores of every series summed, and their per-term rows stacked series after series.
// one(s, series, settings, params, g, J) differentiates series s in θ_s's `params`; the columns
// are gathered onto `free` (FreeOf).
template <class One>
Result<Loglik> Likelihood::ScoreOverSeries(std::span<const int> delay, std::span<const int> free,
                                           Eigen::VectorXd* gradient,
                                           Eigen::MatrixXd* J_terms_theta, int threads, One&& one,
                                           LinearGradient linear_gradient) const {
  FilterSettings settings = settings_;
  settings.linear_gradient = linear_gradient;
  if (!delay.empty()) settings.delay.assign(delay.begin(), delay.end());
  const Eigen::Index k = static_cast<Eigen::Index>(free.size());
  const int n = static_cast<int>(series_.size());
  std::vector<std::optional<Result<Loglik>>> each(series_.size());
  std::vector<SeriesFree> free_per_series(series_.size());
  std::vector<Eigen::VectorXd> gradient_per_series(series_.size());
  std::vector<Eigen::MatrixXd> J_per_series(series_.size());
  OverSeries(n, threads, [&](int s) {
    free_per_series[s] = FreeOf(free, s);
    each[s] = one(s, *series_[s], settings, std::span<const int>(free_per_series[s].params),
                  &gradient_per_series[s], J_terms_theta ? &J_per_series[s] : nullptr);
    return each[s]->ok();
  });
  Loglik total;
  gradient->setZero(k);
  for (int s = 0; s < n; ++s) {
    if (!*each[s]) return each[s]->error();
    total.loglik += (*each[s])->loglik;
    total.n_obs += (*each[s])->n_obs;
    total.replayed += (*each[s])->replayed;
    total.adjoint += (*each[s])->adjoint;
    const std::vector<Eigen::Index>& columns = free_per_series[s].columns;
    for (std::size_t c = 0; c < columns.size(); ++c)
      (*gradient)(columns[c]) += gradient_per_series[s](static_cast<Eigen::Index>(c));
  }
  if (J_terms_theta) {
    Eigen::Index rows = 0;
    for (const auto& J : J_per_series) rows += J.rows();
    J_terms_theta->setZero(rows, k);
    Eigen::Index at = 0;
    for (int s = 0; s < n; ++s) {
      const Eigen::MatrixXd& J = J_per_series[s];
      const std::vector<Eigen::Index>& columns = free_per_series[s].columns;
      for (std::size_t c = 0; c < columns.size(); ++c)
        J_terms_theta->block(at, columns[c], J.rows(), 1) += J.col(static_cast<Eigen::Index>(c));
      at += J.rows();
    }
  }
  return total;
}

Result<Loglik> Likelihood::EvaluateWithScore(std::span<const double> theta,
                                             std::span<const int> delay, std::span<const int> free,
                                             Eigen::VectorXd* gradient,
                                             Eigen::MatrixXd* J_terms_theta, int threads,
                                             LinearGradient linear_gradient) const {
  assert(gradient != nullptr);
  if (nonlinear_ && !exact_scores()) return EkfScore(theta, delay, free, gradient, J_terms_theta);
  if (nonlinear_) {
    std::vector<ode::OdeCounts> counts(series_.size());
    const bool adjoint = J_terms_theta == nullptr && UsesAdjoint(free.size());
    auto total = ScoreOverSeries(
        delay, free, gradient, J_terms_theta, threads,
        [&](std::size_t i, const data::Series& s, const FilterSettings& settings,
            std::span<const int> params, Eigen::VectorXd* g, Eigen::MatrixXd* J) -> Result<Loglik> {
          const std::vector<double> own = SeriesTheta(theta, i);
          if (adjoint) {
            bool applicable = false;
            auto l = EkfLogLikelihoodWithAdjoint(*nonlinear_, *sensitivity_, own, s, settings,
                                                 params, g, &applicable, &counts[i]);
            if (!l || applicable) return l;
          }
          return EkfLogLikelihoodWithScore(*nonlinear_, *sensitivity_, own, s, settings, params, g,
                                           J, &counts[i]);
        });
    for (const ode::OdeCounts& c : counts) counts_->Add(c);
    return total;
  }
  if (series_parameters_.empty()) {
    auto ss = linear_->Evaluate(theta);
    if (!ss) return ss.error();
    auto dss = linear_->EvaluateJacobian(theta, free);
    if (!dss) return dss.error();
    return ScoreOverSeries(
        delay, free, gradient, J_terms_theta, threads,
        [&](std::size_t, const data::Series& s, const FilterSettings& settings,
            std::span<const int>, Eigen::VectorXd* g,
            Eigen::MatrixXd* J) { return LogLikelihoodScore(*ss, *dss, s, settings, g, J); },
        linear_gradient);
  }
  return ScoreOverSeries(
      delay, free, gradient, J_terms_theta, threads,
      [&](std::size_t i, const data::Series& s, const FilterSettings& settings,
          std::span<const int> params, Eigen::VectorXd* g, Eigen::MatrixXd* J) -> Result<Loglik> {
        const std::vector<double> own = SeriesTheta(theta, i);
        auto ss = linear_->Evaluate(own);
        if (!ss) return ss.error();
        auto dss = linear_->EvaluateJacobian(own, params);
        if (!dss) return dss.error();
        return LogLikelihoodScore(*ss, *dss, s, settings, g, J);
      },
      linear_gradient);
}

bool Likelihood::GradientInOnePiece() const {
  // The steady-state replay runs at fixed sizes with up to 64 outputs (SteadyReplay).
  return linear_ && static_cast<int>(spec().states.size()) <= internal::kMaxFixedStates &&
         spec().outputs.size() <= 64;
}

bool Likelihood::UsesAdjoint(std::size_t free_count) const {
  if (!nonlinear_ || !exact_scores()) return false;
  // The adjoint retraces the explicit method's steps only: with BDF on every interval its
  // forward pass would be thrown away for the forward sensitivities.
  const model::OdeMethod method = nonlinear_->spec().ekf.method;
  if (method == model::OdeMethod::kBdf) return false;
  switch (gradient_method_) {
    case GradientMethod::kForward:
      return false;
    case GradientMethod::kAdjoint:
      return true;
    case GradientMethod::kAuto:
      break;
  }
  // Measured (docs/benchmarks.md, "The adjoint gradient"): on the Cascaded Tanks SDE model and
  // the engine model the forward sensitivities cost about 1 + 1.3 K evaluations of log L and the
  // adjoint about 3.5 whatever K is, so the adjoint is the cheaper from three free parameters.
  return AutoUsesAdjoint(free_count, method);
}

Result<DelayProfile> Likelihood::Profile(std::span<const double> theta) const {
  std::optional<std::vector<model::StateSpace>> ss;
  if (linear_) {
    auto evaluated = LinearAt(theta);
    if (!evaluated) return evaluated.error();
    ss = std::move(*evaluated);
  }
  DelayProfile profile;
  for (const auto& delay : DelayGrid()) {
    DelayCandidate c;
    c.delay = delay;
    auto l = ss ? EvaluateAt(*ss, delay) : EvaluateEkf(theta, delay);
    if (l) {
      c.ok = true;
      c.loglik = l->loglik;
      c.n_obs = l->n_obs;
      if (profile.best < 0 || c.loglik > profile.candidates[profile.best].loglik)
        profile.best = static_cast<int>(profile.candidates.size());
    } else {
      c.message = l.error().ToString();
    }
    profile.candidates.push_back(std::move(c));
  }
  return profile;
}

}  // namespace gb::filter
