#include "core/filter/likelihood.h"

#include <fmt/format.h>

#include "core/filter/score.h"

namespace gb::filter {

Result<Likelihood> Likelihood::Create(std::shared_ptr<const model::LinearModel> model,
                                      std::vector<std::shared_ptr<const data::Series>> series) {
  const model::ModelSpec& spec = model->spec();
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
  }
  Likelihood l;
  l.settings_ = FilterSettings::FromModel(spec);
  for (const auto& d : spec.output_delay) l.settings_.first_obs.push_back(d.max);
  l.model_ = std::move(model);
  l.series_ = std::move(series);
  return l;
}

std::vector<std::vector<int>> Likelihood::DelayGrid() const {
  std::vector<std::vector<int>> grid{{}};
  for (const auto& d : model_->spec().output_delay) {
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

Result<Loglik> Likelihood::EvaluateAt(const model::StateSpace& ss, std::span<const int> delay,
                                      std::vector<double>* terms) const {
  FilterSettings settings = settings_;
  if (!delay.empty()) settings.delay.assign(delay.begin(), delay.end());
  Loglik total;
  std::vector<double> one;
  if (terms) terms->clear();
  for (const auto& s : series_) {
    auto l = LogLikelihood(ss, *s, settings, terms ? &one : nullptr);
    if (!l) return l.error();
    if (terms) terms->insert(terms->end(), one.begin(), one.end());
    total.loglik += l->loglik;
    total.n_obs += l->n_obs;
  }
  return total;
}

Result<Loglik> Likelihood::Evaluate(std::span<const double> theta, std::span<const int> delay,
                                    std::vector<double>* terms) const {
  auto ss = model_->Evaluate(theta);
  if (!ss) return ss.error();
  return EvaluateAt(*ss, delay, terms);
}

Result<Loglik> Likelihood::EvaluateWithScore(std::span<const double> theta,
                                             std::span<const int> delay, std::span<const int> free,
                                             Eigen::VectorXd* gradient,
                                             Eigen::MatrixXd* J_terms_theta) const {
  assert(gradient != nullptr);
  auto ss = model_->Evaluate(theta);
  if (!ss) return ss.error();
  auto dss = model_->EvaluateJacobian(theta, free);
  if (!dss) return dss.error();
  FilterSettings settings = settings_;
  if (!delay.empty()) settings.delay.assign(delay.begin(), delay.end());
  const Eigen::Index k = static_cast<Eigen::Index>(free.size());
  Loglik total;
  gradient->setZero(k);
  Eigen::VectorXd one_gradient;
  std::vector<Eigen::MatrixXd> J_per_series;
  for (const auto& s : series_) {
    Eigen::MatrixXd one_J;
    auto l = LogLikelihoodScore(*ss, *dss, *s, settings, &one_gradient,
                                J_terms_theta ? &one_J : nullptr);
    if (!l) return l.error();
    total.loglik += l->loglik;
    total.n_obs += l->n_obs;
    *gradient += one_gradient;
    if (J_terms_theta) J_per_series.push_back(std::move(one_J));
  }
  if (J_terms_theta) {
    Eigen::Index rows = 0;
    for (const auto& J : J_per_series) rows += J.rows();
    J_terms_theta->resize(rows, k);
    Eigen::Index at = 0;
    for (const auto& J : J_per_series) {
      J_terms_theta->middleRows(at, J.rows()) = J;
      at += J.rows();
    }
  }
  return total;
}

Result<DelayProfile> Likelihood::Profile(std::span<const double> theta) const {
  auto ss = model_->Evaluate(theta);
  if (!ss) return ss.error();
  DelayProfile profile;
  for (const auto& delay : DelayGrid()) {
    DelayCandidate c;
    c.delay = delay;
    auto l = EvaluateAt(*ss, delay);
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
