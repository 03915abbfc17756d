// Sections: 1. set-up (tracked parameters, the prior, the start)  2. the filter and its
//           sensitivities, one row at a time  3. the parameter step
#include "core/online/recursive.h"

#include <algorithm>
#include <cmath>
#include <complex>
#include <set>

#include <Eigen/Dense>
#include <Eigen/Eigenvalues>
#include <fmt/format.h>

#include "core/filter/internal.h"
#include "core/filter/score.h"
#include "core/online/internal.h"

namespace gb::online {
namespace {

constexpr int kMaxHalvings = 20;
constexpr double kSameInterval = 1e-10;  // relative: data::Intervals::kIntervalRelTol
// The largest step of one row in the working coordinates (a factor e^1 in a scale parameter).
constexpr double kMaxWorkingStep = 0.1;

using internal::FromWorking;
using internal::Inside;
using internal::kInf;
using internal::kNaN;
using internal::ToWorking;
using internal::WorkingSlope;

}  // namespace

// ---- 1. set-up -------------------------------------------------------------------------------

Result<std::vector<int>> internal::ChooseTracked(const model::ModelSpec& spec,
                                                 const std::vector<int>& trackable,
                                                 std::span<const std::string> names,
                                                 const char* why) {
  if (names.empty()) return trackable;
  std::vector<int> chosen;
  for (const std::string& name : names) {
    const int i = spec.ParameterIndex(name);
    if (std::find(trackable.begin(), trackable.end(), i) == trackable.end()) {
      std::string list;
      for (int t : trackable) list += (list.empty() ? "" : ", ") + spec.parameters[t].name;
      return InputError(fmt::format(
          "cannot track '{}': {}; the parameters that can be tracked are {}", name,
          i < 0 ? "the model has no such parameter" : why, list.empty() ? "none" : list));
    }
    if (std::find(chosen.begin(), chosen.end(), i) == chosen.end()) chosen.push_back(i);
  }
  std::sort(chosen.begin(), chosen.end());
  return chosen;
}

std::vector<int> TrackableParameters(const model::LinearModel& model, std::span<const int> free) {
  const int n = model.n_states(), m = model.n_inputs(), p = model.n_outputs();
  // Entries in LinearModel::entries() order: A, B, c, C, D, d, sigma, S, then x0 and P0.
  const auto z = [](int v) { return static_cast<std::size_t>(v); };
  const std::size_t dynamic =
      z(n) * z(n) + z(n) * z(m) + z(n) + z(p) * z(n) + z(p) * z(m) + z(p) + z(n) + z(p);
  std::set<std::string> names;
  const auto& entries = model.entries();
  for (std::size_t k = 0; k < dynamic && k < entries.size(); ++k)
    expr::CollectNames(entries[k], &names);
  std::vector<int> out;
  for (int i : free)
    if (names.count(model.spec().parameters[i].name)) out.push_back(i);
  return out;
}

Reference ReferenceFromSummary(const estimate::EstimateSummary& summary,
                               const model::ModelSpec& spec, std::string source) {
  Reference r;
  r.source = std::move(source);
  r.theta = summary.theta;
  for (const estimate::DelayEstimate& d : summary.delays) r.delay.push_back(d.estimate);
  for (const std::string& name : summary.correlation_names)
    r.free.push_back(spec.ParameterIndex(name));
  r.covariance = summary.covariance;
  r.n_obs = summary.n_obs;
  return r;
}

RecursiveMl::RecursiveMl(const model::LinearModel& model, const Reference& reference,
                         const RecursiveOptions& options)
    : model_(model), options_(options), source_(reference.source), theta_(reference.theta) {}

Eigen::MatrixXd Reference::CovarianceOf(std::span<const int> params) const {
  const auto k = static_cast<Eigen::Index>(params.size());
  std::vector<Eigen::Index> at(params.size(), -1);
  for (std::size_t a = 0; a < params.size(); ++a)
    for (std::size_t b = 0; b < free.size(); ++b)
      if (free[b] == params[a] && static_cast<Eigen::Index>(b) < covariance.rows())
        at[a] = static_cast<Eigen::Index>(b);
  Eigen::MatrixXd out = Eigen::MatrixXd::Constant(k, k, kNaN);
  for (Eigen::Index a = 0; a < k; ++a)
    for (Eigen::Index b = 0; b < k; ++b)
      if (at[a] >= 0 && at[b] >= 0) out(a, b) = covariance(at[a], at[b]);
  return out;
}

Eigen::MatrixXd internal::PriorCovariance(const Reference& reference, std::span<const int> tracked,
                                          const Eigen::VectorXd& slope,
                                          std::span<const double> lower,
                                          std::span<const double> upper,
                                          std::span<const double> theta,
                                          const RecursiveOptions& options, int outputs) {
  const auto k = static_cast<Eigen::Index>(tracked.size());
  const Eigen::MatrixXd cov = reference.CovarianceOf(tracked);
  if (k > 0 && cov.allFinite() && reference.n_obs > 0) {
    const Eigen::LDLT<Eigen::MatrixXd> ldlt(cov);
    if (ldlt.info() == Eigen::Success && ldlt.isPositive() &&
        (ldlt.vectorD().array() > 0.0).all()) {
      const double ref_rows = static_cast<double>(reference.n_obs) / std::max(outputs, 1);
      double rows = options.prior_rows;
      if (!(rows > 0.0))
        rows = options.forgetting < 1.0 ? 1.0 / (1.0 - options.forgetting) : ref_rows;
      const Eigen::VectorXd inv = slope.cwiseInverse();
      Eigen::MatrixXd prior = inv.asDiagonal() * cov * inv.asDiagonal() * (ref_rows / rows);
      prior = 0.5 * (prior + prior.transpose()).eval();
      if (prior.allFinite()) return prior;
    }
  }
  Eigen::MatrixXd prior = Eigen::MatrixXd::Zero(k, k);
  for (Eigen::Index a = 0; a < k; ++a) {
    const bool bounded = std::isfinite(lower[a]) || std::isfinite(upper[a]);
    const double sd = bounded ? 2.0 : std::max(std::abs(theta[tracked[a]]), 1.0);
    prior(a, a) = sd * sd;
  }
  return prior;
}

Eigen::MatrixXd Reference::ConditionalCovarianceOf(std::span<const int> params) const {
  Eigen::MatrixXd out = CovarianceOf(params);
  std::vector<int> others;
  for (std::size_t b = 0; b < free.size(); ++b)
    if (static_cast<Eigen::Index>(b) < covariance.rows() &&
        std::find(params.begin(), params.end(), free[b]) == params.end())
      others.push_back(free[b]);
  if (others.empty() || !out.allFinite()) return out;
  std::vector<int> all(params.begin(), params.end());
  all.insert(all.end(), others.begin(), others.end());
  const Eigen::MatrixXd joint = CovarianceOf(all);
  const auto k = static_cast<Eigen::Index>(params.size());
  const auto u = static_cast<Eigen::Index>(others.size());
  const Eigen::MatrixXd tu = joint.topRightCorner(k, u);
  const Eigen::CompleteOrthogonalDecomposition<Eigen::MatrixXd> uu(joint.bottomRightCorner(u, u));
  out -= tu * uu.solve(tu.transpose());
  return 0.5 * (out + out.transpose());
}

Result<RecursiveMl> RecursiveMl::Create(const model::LinearModel& model, const Reference& reference,
                                        const RecursiveOptions& options, bool adapt) {
  if (!(options.forgetting > 0.0 && options.forgetting <= 1.0))
    return InputError(
        fmt::format("the forgetting factor must be in (0, 1], not {:g}", options.forgetting));
  if (options.forgetting_start > options.forgetting)
    return InputError(fmt::format("the starting forgetting factor {:g} is above the final one {:g}",
                                  options.forgetting_start, options.forgetting));
  if (!(options.max_step_sd > 0.0))
    return InputError(
        fmt::format("the largest step must be positive, not {:g} SD", options.max_step_sd));
  const model::ModelSpec& spec = model.spec();
  if (reference.theta.size() != spec.parameters.size())
    return InputError(fmt::format("the reference has {} parameter values, the model {}",
                                  reference.theta.size(), spec.parameters.size()));
  RecursiveMl r(model, reference, options);
  const int p = model.n_outputs();
  r.delay_ = reference.delay;
  if (r.delay_.empty())
    for (const model::DelaySpec& d : spec.output_delay) r.delay_.push_back(d.min);
  if (static_cast<int>(r.delay_.size()) != p)
    return InputError(fmt::format("the reference gives {} output delays, the model has {} outputs",
                                  r.delay_.size(), p));
  for (int d : r.delay_) {
    if (d < 0) return InputError(fmt::format("an output delay of {} samples", d));
    r.lag_ = std::max(r.lag_, d);
  }
  if (adapt) r.tracked_ = TrackableParameters(model, reference.free);
  if (adapt && !options.track.empty()) {
    auto chosen = internal::ChooseTracked(
        spec, r.tracked_, options.track,
        "it is fixed, has no reference estimate, or only sets the initial state");
    if (!chosen) return chosen.error();
    r.tracked_ = std::move(*chosen);
  }
  const int k = static_cast<int>(r.tracked_.size());
  for (int i : r.tracked_) {
    const model::Parameter& par = spec.parameters[i];
    r.lower_.push_back(par.lower.value_or(-kInf));
    r.upper_.push_back(par.upper.value_or(kInf));
    r.theta_[i] = Inside(r.theta_[i], r.lower_.back(), r.upper_.back());
  }
  for (int i : r.tracked_) r.tracked_names_.push_back(spec.parameters[i].name);
  if (Status s = r.Evaluate(); !s) return s.error();
  r.theta_model_ = r.theta_;

  // The prior information (working coordinates): the inverse of the prior covariance.
  const Eigen::MatrixXd prior = internal::PriorCovariance(reference, r.tracked_, r.Slopes(),
                                                          r.lower_, r.upper_, r.theta_, options, p);
  r.F_ = Eigen::LDLT<Eigen::MatrixXd>(prior).solve(Eigen::MatrixXd::Identity(k, k));
  r.F_ = 0.5 * (r.F_ + r.F_.transpose()).eval();
  r.G_ = r.F_;
  r.sd_w_.assign(static_cast<std::size_t>(k), 0.0);
  r.Finv_ = Eigen::LDLT<Eigen::MatrixXd>(r.F_).solve(Eigen::MatrixXd::Identity(k, k));
  for (int a = 0; a < k; ++a) r.sd_w_[a] = std::sqrt(std::max(r.Finv_(a, a), 0.0));
  r.lambda_ = options.forgetting_start > 0.0 ? options.forgetting_start : options.forgetting;
  r.rows_.resize(static_cast<std::size_t>(r.lag_) + 2);
  return r;
}

Eigen::VectorXd RecursiveMl::Slopes() const {
  Eigen::VectorXd out(static_cast<Eigen::Index>(tracked_.size()));
  for (std::size_t a = 0; a < tracked_.size(); ++a)
    out(static_cast<Eigen::Index>(a)) = WorkingSlope(theta_[tracked_[a]], lower_[a], upper_[a]);
  return out;
}

Status RecursiveMl::Evaluate() {
  auto ss = model_.Evaluate(theta_);
  if (!ss) return ss.error();
  std::vector<model::StateSpace> dss;
  if (!tracked_.empty()) {
    auto d = model_.EvaluateJacobian(theta_, tracked_);
    if (!d) return d.error();
    dss = std::move(*d);
  }
  ss_ = std::move(*ss);
  dss_ = std::move(dss);
  step_.SetModel(ss_, dss_);
  return Ok{};
}

Status RecursiveMl::Refresh(double dt) {
  // The model and its exact discretisation (with their derivatives) are kept while the interval
  // is the same (to rounding) and no parameter has moved by more than rediscretise_sd of its
  // current SD since they were computed (in working coordinates).
  const std::size_t k = tracked_.size();
  bool fresh = disc_dt_ > 0.0 && std::abs(dt - disc_dt_) <= kSameInterval * disc_dt_;
  for (std::size_t a = 0; a < k && fresh; ++a) {
    const double w = ToWorking(theta_[tracked_[a]], lower_[a], upper_[a]);
    fresh = std::abs(w - disc_w_[a]) <= options_.rediscretise_sd * sd_w_[a];
  }
  if (fresh) return Ok{};
  if (theta_ != theta_model_) {
    // A point the model refuses (a variance it computes negative, say) is approached by halving
    // the move from the last point it accepted, in working coordinates.
    const std::vector<double> target = theta_;
    bool accepted = false;
    for (int halving = 0; halving <= kMaxHalvings && !accepted; ++halving) {
      const double f = std::ldexp(1.0, -halving);
      for (std::size_t a = 0; a < k; ++a) {
        const int i = tracked_[a];
        const double w0 = ToWorking(theta_model_[i], lower_[a], upper_[a]);
        const double w1 = ToWorking(target[i], lower_[a], upper_[a]);
        theta_[i] =
            Inside(FromWorking(w0 + f * (w1 - w0), lower_[a], upper_[a]), lower_[a], upper_[a]);
      }
      accepted = static_cast<bool>(Evaluate());
    }
    if (!accepted) {
      theta_ = theta_model_;
      if (Status s = Evaluate(); !s) return s;
    }
    theta_model_ = theta_;
  }
  const Eigen::VectorXd sigma2 = ss_.sigma.array().square();
  const model::InputHold hold = model_.spec().input_hold;
  filter::Discrete disc = filter::Discretize(ss_.A, ss_.B, ss_.c, sigma2, dt, hold);
  if (!disc.Phi.allFinite() || !disc.Q.allFinite())
    return NumericalError(
        fmt::format("the model cannot be discretised over {:g} at the current estimate", dt));
  std::vector<filter::Discrete> ddisc;
  ddisc.reserve(dss_.size());
  for (const model::StateSpace& d : dss_)
    ddisc.push_back(filter::DiscretizeDerivative(ss_.A, ss_.B, ss_.c, sigma2, d.A, d.B, d.c,
                                                 2.0 * ss_.sigma.cwiseProduct(d.sigma), dt, hold));
  disc_ = std::move(disc);
  ddisc_ = std::move(ddisc);
  disc_dt_ = dt;
  disc_w_.resize(k);
  for (std::size_t a = 0; a < k; ++a)
    disc_w_[a] = ToWorking(theta_[tracked_[a]], lower_[a], upper_[a]);
  return Ok{};
}

Status RecursiveMl::Start(const Sample& first, const Sample* second) {
  const int n = ss_.n_states();
  const int k = static_cast<int>(tracked_.size());
  Eigen::ComplexEigenSolver<Eigen::MatrixXd> es(ss_.A, false);
  double slowest = 0.0;
  bool stable = es.info() == Eigen::Success;
  if (stable) {
    for (Eigen::Index i = 0; i < es.eigenvalues().size(); ++i) {
      const double re = es.eigenvalues()(i).real();
      if (!(re < 0.0))
        stable = false;
      else
        slowest = std::max(slowest, -1.0 / re);
    }
  }
  state_.dx.assign(static_cast<std::size_t>(k), Eigen::VectorXd::Zero(n));
  state_.dP.assign(static_cast<std::size_t>(k), Eigen::MatrixXd::Zero(n, n));
  scores_ = filter::internal::TermScores(k, true);
  const Eigen::VectorXd sigma2 = ss_.sigma.array().square();
  Eigen::MatrixXd P;
  std::complex<double> bad;
  if (options_.start == RecursiveOptions::Start::kModel) {
    // As the batch filter: x0, P0 and their derivatives (score.h).
    state_.x = ss_.x0;
    for (int i = 0; i < k; ++i) state_.dx[i] = dss_[i].x0;
    const model::InitialCovariance kind = model_.spec().initial_covariance;
    switch (kind) {
      case model::InitialCovariance::kCtsm:
        if (Status s = Refresh(second->t - first.t); !s) return s;
        state_.P = disc_.Q;
        break;
      case model::InitialCovariance::kStationary:
        if (!filter::StationaryCovariance(ss_.A, sigma2, &P, &bad))
          return NumericalError("initial_covariance \"stationary\" needs a stable A");
        state_.P = P;
        break;
      case model::InitialCovariance::kExplicit:
        state_.P = ss_.P0_diag.asDiagonal();
        break;
    }
    state_.dP = filter::InitialCovarianceDerivatives(kind, ss_, dss_, state_.P, ddisc_);
  } else if (stable && filter::StationaryCovariance(ss_.A, sigma2, &P, &bad)) {
    // The equilibrium for the first input and the stationary covariance.
    const Eigen::Map<const Eigen::VectorXd> u0(first.u.data(),
                                               static_cast<Eigen::Index>(first.u.size()));
    state_.x = ss_.A.fullPivLu().solve(-(ss_.B * u0 + ss_.c));
    state_.P = P;
  } else {
    state_.x = ss_.x0;
    state_.P = ss_.P0_diag.size() == n ? Eigen::MatrixXd(ss_.P0_diag.asDiagonal())
                                       : Eigen::MatrixXd(sigma2.asDiagonal());
  }
  if (options_.warmup >= 0) {
    warmup_ = options_.warmup;
  } else {
    // Five of the slowest time constants, in rows of the first interval (the rows are not yet
    // known: the second row's time decides).
    warmup_ = -1;
    warmup_time_ = 5.0 * slowest;
  }
  return Ok{};
}

// ---- 2. the filter and its sensitivities -----------------------------------------------------

Status RecursiveMl::TimeUpdate(const Sample& from, const Sample& to) {
  const double dt = to.t - from.t;
  if (!(dt > 0.0))
    return InputError(
        fmt::format("time {:g} does not increase (the row before has {:g})", to.t, from.t));
  if (warmup_ < 0) warmup_ = static_cast<int>(std::ceil(warmup_time_ / dt));
  if (Status s = Refresh(dt); !s) return s;
  const bool foh = model_.spec().input_hold == model::InputHold::kFoh;
  step_.TimeUpdate<true>(disc_, ddisc_.data(), from.u.data(), to.u.data(), foh, false, &state_);
  return Ok{};
}

Result<RecursiveUpdate> RecursiveMl::MeasurementUpdate(int j) {
  const int p = ss_.n_outputs();
  const int k = static_cast<int>(tracked_.size());
  const std::size_t ring = rows_.size();
  const Sample& row_j = rows_[static_cast<std::size_t>(j) % ring];
  RecursiveUpdate up;
  up.index = j;
  up.t = row_j.t;
  up.line = row_j.line;
  up.innovation.assign(static_cast<std::size_t>(p), kNaN);
  up.innovation_sd.assign(static_cast<std::size_t>(p), kNaN);
  Eigen::VectorXd score = Eigen::VectorXd::Zero(k);
  filter::internal::TermSums sums;
  scores_.Begin();
  for (int o = 0; o < p; ++o) {
    const Sample& row = rows_[static_cast<std::size_t>(j + delay_[o]) % ring];
    const double y = row.y[o];
    if (std::isnan(y)) continue;
    double R = 0.0, eps = 0.0;
    if (!step_.MeasurementUpdate<true>(o, y, row_j.u.data(), &state_, nullptr, &sums, &scores_, &R,
                                       &eps)) {
      Error e = NumericalError(fmt::format(
          "the innovation variance of output '{}' is {:g}, not positive, at the current estimate",
          model_.spec().outputs[o], R));
      e.file = source_;
      e.line = row.line;
      return e;
    }
    up.innovation[o] = eps;
    up.innovation_sd[o] = std::sqrt(R);
  }
  const int p_j = sums.p_j;
  if (p_j > 0) {
    double d_rho = 0.5;
    up.loglik_term =
        filter::internal::LoglikTerm(sums.logdet, p_j, sums.r2, model_.spec().robust_huber, &d_rho);
    scores_.TermScore(d_rho, &score);
  }
  up.score.assign(score.data(), score.data() + k);
  up.warming_up = j < warmup_ || warmup_ < 0;
  const Eigen::MatrixXd& info = scores_.information;
  for (int a = 0; a < k; ++a) up.information.push_back(info(a, a));
  if (k > 0 && p_j > 0 && !up.warming_up && !options_.hold) {
    if (options_.forgetting_start > 0.0)
      lambda_ = ramp_ * lambda_ + (1.0 - ramp_) * options_.forgetting;
    const Eigen::VectorXd slope = Slopes();
    const Eigen::MatrixXd info_w = slope.asDiagonal() * info * slope.asDiagonal();
    F_ = lambda_ * F_ + info_w;
    G_ = lambda_ * lambda_ * G_ + info_w;
    Step(slope.cwiseProduct(score));
  }
  for (int i : tracked_) up.theta.push_back(theta_[i]);
  if (options_.hold) return up;  // held at the reference: its scores are what is asked for
  const Eigen::MatrixXd cov = Covariance();
  for (int a = 0; a < k; ++a) up.sd.push_back(std::sqrt(std::max(cov(a, a), 0.0)));
  return up;
}

Result<std::vector<RecursiveUpdate>> RecursiveMl::Push(const Sample& row) {
  if (static_cast<int>(row.u.size()) != ss_.n_inputs() ||
      static_cast<int>(row.y.size()) != ss_.n_outputs())
    return InputError("a row with the wrong number of inputs or outputs");
  const std::size_t ring = rows_.size();
  if (n_rows_ > 0) {
    const Sample& last = rows_[static_cast<std::size_t>(n_rows_ - 1) % ring];
    if (!(row.t > last.t)) {
      Error e =
          InputError(fmt::format("time {:g} does not increase (the row before, line {}, has {:g})",
                                 row.t, last.line, last.t));
      e.file = source_;
      e.line = row.line;
      return e;
    }
  }
  rows_[static_cast<std::size_t>(n_rows_) % ring] = row;
  ++n_rows_;
  // State index j is complete once row j + lag is in (and, for the model's own start, the
  // second row: P0 "ctsm" is Q over the first interval).
  const bool model_start = options_.start == RecursiveOptions::Start::kModel;
  std::vector<RecursiveUpdate> out;
  while (next_index_ + lag_ < n_rows_ && !(model_start && n_rows_ < 2)) {
    const int j = next_index_;
    const Sample& at = rows_[static_cast<std::size_t>(j) % ring];
    Status s = j == 0 ? Start(rows_[0], n_rows_ > 1 ? &rows_[1] : nullptr)
                      : TimeUpdate(rows_[static_cast<std::size_t>(j - 1) % ring], at);
    if (!s) {
      Error e = s.error();
      e.file = source_;
      e.line = at.line;
      return e;
    }
    auto up = MeasurementUpdate(j);
    if (!up) return up.error();
    ++next_index_;
    out.push_back(std::move(*up));
  }
  return out;
}

// ---- 3. the parameter step -------------------------------------------------------------------

Eigen::MatrixXd RecursiveMl::Covariance() const {
  const Eigen::Index k = F_.rows();
  if (k == 0) return {};
  const Eigen::VectorXd slope = Slopes();
  Eigen::MatrixXd cov = slope.asDiagonal() * (Finv_ * G_ * Finv_) * slope.asDiagonal();
  return 0.5 * (cov + cov.transpose());
}

void RecursiveMl::Step(const Eigen::VectorXd& score) {
  const int k = static_cast<int>(tracked_.size());
  const Eigen::LDLT<Eigen::MatrixXd> ldlt(F_);
  Finv_ = ldlt.solve(Eigen::MatrixXd::Identity(k, k));  // F changed: the covariance's too
  const Eigen::MatrixXd& Finv = Finv_;
  for (int a = 0; a < k; ++a) sd_w_[a] = std::sqrt(std::max(Finv(a, a), 0.0));
  if (ldlt.info() != Eigen::Success) return;
  Eigen::VectorXd step = ldlt.solve(score);
  if (!step.allFinite()) return;
  // At most max_step_sd of the current SDs (sqrt of diag F⁻¹), and kMaxWorkingStep, in any
  // working coordinate.
  double scale = 1.0;
  for (int a = 0; a < k; ++a) {
    const double limit =
        std::min(options_.max_step_sd * std::sqrt(std::max(Finv(a, a), 0.0)), kMaxWorkingStep);
    if (std::abs(step(a)) > limit) scale = std::min(scale, limit / std::abs(step(a)));
  }
  for (int a = 0; a < k; ++a) {
    const int i = tracked_[a];
    const double w = ToWorking(theta_[i], lower_[a], upper_[a]) + scale * step(a);
    theta_[i] = Inside(FromWorking(w, lower_[a], upper_[a]), lower_[a], upper_[a]);
  }
}

}  // namespace gb::online
