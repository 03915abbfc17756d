// Sections: 1. the augmented model  2. set-up  3. one row at a time
#include "core/online/augmented.h"

#include <algorithm>
#include <cmath>
#include <set>

#include <Eigen/Dense>
#include <fmt/format.h>

#include "core/online/internal.h"

namespace gb::online {
namespace {

using internal::FromWorking;
using internal::Inside;
using internal::kInf;
using internal::ToWorking;
using internal::WorkingSlope;

// Rows of warm-up when the start is not a stable equilibrium (no time constant to go by).
constexpr int kDefaultWarmup = 100;

std::string StateName(const std::string& parameter) { return "w(" + parameter + ")"; }
std::string WalkName(const std::string& parameter) { return "q(" + parameter + ")"; }

// θ as an expression of its working coordinate, the variable `w` (internal.h's FromWorking).
expr::ExprPtr NaturalOf(const std::string& w, double lo, double hi) {
  const bool has_lo = std::isfinite(lo), has_hi = std::isfinite(hi);
  std::string text = "W";
  if (has_lo && has_hi)
    text = fmt::format("({:.17g}) + ({:.17g}) / (1 + exp(-W))", lo, hi - lo);
  else if (has_lo)
    text = fmt::format("({:.17g}) + exp(W)", lo);
  else if (has_hi)
    text = fmt::format("({:.17g}) - exp(-W)", hi);
  auto parsed = expr::Parse(text);
  assert(parsed && "a well-formed working-coordinate expression");
  return expr::Substitute(*parsed, "W", expr::Variable(w));
}

// ---- 1. the augmented model ------------------------------------------------------------------

// The model with the tracked parameters as states w (their drift 0, their diffusion q), every
// formula of the dynamics and observations rewritten in w; the initial state and variances keep
// the reference values (they are read before any filtering).
model::ModelSpec Augment(const model::ModelSpec& spec, const std::vector<int>& tracked,
                         const std::vector<double>& lower, const std::vector<double>& upper,
                         const std::vector<double>& theta) {
  model::ModelSpec a = spec;
  a.name = spec.name + " (augmented)";
  auto rewrite = [&](std::vector<model::Formula>& formulas, bool by_value) {
    for (model::Formula& f : formulas) {
      for (std::size_t k = 0; k < tracked.size(); ++k) {
        const std::string& name = spec.parameters[tracked[k]].name;
        const expr::ExprPtr by = by_value ? expr::Constant(theta[tracked[k]])
                                          : NaturalOf(StateName(name), lower[k], upper[k]);
        f.expr = expr::Substitute(f.expr, name, by);
      }
      f.text = expr::ToString(f.expr);
    }
  };
  rewrite(a.drift, false);
  rewrite(a.diffusion, false);
  rewrite(a.observation, false);
  rewrite(a.measurement_variance, false);
  rewrite(a.initial_state, true);
  rewrite(a.initial_variance, true);
  for (std::size_t k = 0; k < tracked.size(); ++k) {
    const model::Parameter& par = spec.parameters[tracked[k]];
    const std::string w = StateName(par.name);
    a.states.push_back(w);
    a.drift.push_back({"0", expr::Constant(0.0), "drift." + w});
    a.diffusion.push_back(
        {WalkName(par.name), expr::Variable(WalkName(par.name)), "diffusion." + w});
    const double w0 = ToWorking(theta[tracked[k]], lower[k], upper[k]);
    a.initial_state.push_back(
        {fmt::format("{:.17g}", w0), expr::Constant(w0), "initial_state." + w});
    if (a.initial_covariance == model::InitialCovariance::kExplicit)
      a.initial_variance.push_back({"0", expr::Constant(0.0), "initial_variance." + w});
    model::Parameter q;
    q.name = WalkName(par.name);
    q.fixed = true;
    q.value = 0.0;
    q.description = "random-walk intensity of " + w;
    a.parameters.push_back(std::move(q));
  }
  return a;
}

}  // namespace

std::vector<int> TrackableParameters(const model::NonlinearModel& model,
                                     std::span<const int> free) {
  std::set<std::string> names;
  for (const model::Formula& f : model.spec().drift) expr::CollectNames(f.expr, &names);
  for (const model::Formula& f : model.spec().observation) expr::CollectNames(f.expr, &names);
  std::vector<int> out;
  for (int i : free)
    if (names.count(model.spec().parameters[i].name)) out.push_back(i);
  std::sort(out.begin(), out.end());
  return out;
}

// ---- 2. set-up -------------------------------------------------------------------------------

Result<AugmentedEkf> AugmentedEkf::Create(std::shared_ptr<const model::NonlinearModel> model,
                                          const Reference& reference,
                                          const RecursiveOptions& options) {
  if (!(options.forgetting > 0.0 && options.forgetting <= 1.0))
    return InputError(
        fmt::format("the forgetting factor must be in (0, 1], not {:g}", options.forgetting));
  const model::ModelSpec& spec = model->spec();
  if (reference.theta.size() != spec.parameters.size())
    return InputError(fmt::format("the reference has {} parameter values, the model {}",
                                  reference.theta.size(), spec.parameters.size()));
  const int p = model->n_outputs();
  std::vector<int> delay = reference.delay;
  if (delay.empty())
    for (const model::DelaySpec& d : spec.output_delay) delay.push_back(d.min);
  if (static_cast<int>(delay.size()) != p)
    return InputError(fmt::format("the reference gives {} output delays, the model has {} outputs",
                                  delay.size(), p));
  auto tracked = internal::ChooseTracked(
      spec, TrackableParameters(*model, reference.free), options.track,
      "it is fixed, has no reference estimate, or is not in the drift or the observation (the "
      "extended Kalman filter cannot learn a variance parameter on-line)");
  if (!tracked) return tracked.error();
  const int k = static_cast<int>(tracked->size());
  std::vector<double> lower, upper, theta = reference.theta;
  for (int i : *tracked) {
    lower.push_back(spec.parameters[i].lower.value_or(-kInf));
    upper.push_back(spec.parameters[i].upper.value_or(kInf));
    theta[i] = Inside(theta[i], lower.back(), upper.back());
  }
  auto augmented = model::NonlinearModel::Compile(Augment(spec, *tracked, lower, upper, theta));
  if (!augmented) return augmented.error();
  std::vector<double> theta_aug = theta;
  theta_aug.resize(theta.size() + static_cast<std::size_t>(k), 0.0);  // q = 0 until opened
  EkfStreamOptions so;
  so.delay = delay;
  so.start = options.start;
  so.equilibrium_states = model->n_states();
  auto stream =
      EkfStream::Create(std::make_shared<const model::NonlinearModel>(std::move(*augmented)),
                        theta_aug, so, reference.source);
  if (!stream) return stream.error();

  AugmentedEkf a(std::move(model), std::move(*stream));
  a.options_ = options;
  a.tracked_ = std::move(*tracked);
  for (int i : a.tracked_) a.names_.push_back(spec.parameters[i].name);
  a.lower_ = std::move(lower);
  a.upper_ = std::move(upper);
  a.theta_ = std::move(theta);
  a.n_ = a.model_->n_states();
  a.warmup_ = options.warmup;

  // Σ₀ in working coordinates, scaled to prior_rows rows of data.
  Eigen::VectorXd slope(k);
  for (int b = 0; b < k; ++b)
    slope(b) = WorkingSlope(a.theta_[a.tracked_[b]], a.lower_[b], a.upper_[b]);
  a.prior_ = internal::PriorCovariance(reference, a.tracked_, slope, a.lower_, a.upper_, a.theta_,
                                       options, p);
  return a;
}

void AugmentedEkf::Open(double dt) {
  const auto k = static_cast<Eigen::Index>(tracked_.size());
  Eigen::MatrixXd& P = stream_.P();
  P.block(n_, 0, k, n_).setZero();
  P.block(0, n_, n_, k).setZero();
  P.block(n_, n_, k, k) = prior_;
  std::vector<double> theta = stream_.theta();
  const double lambda = options_.forgetting;
  for (Eigen::Index a = 0; a < k; ++a)
    theta[theta.size() - static_cast<std::size_t>(k) + static_cast<std::size_t>(a)] =
        std::sqrt((1.0 - lambda) * prior_(a, a) / dt);
  stream_.SetParameters(theta);
  open_ = true;
}

// ---- 3. one row at a time --------------------------------------------------------------------

Eigen::MatrixXd AugmentedEkf::Covariance() const {
  const auto k = static_cast<Eigen::Index>(tracked_.size());
  if (k == 0) return {};
  Eigen::VectorXd slope(k);
  for (Eigen::Index a = 0; a < k; ++a)
    slope(a) = WorkingSlope(theta_[tracked_[a]], lower_[a], upper_[a]);
  // Before the parameters are opened (and before the first row), the prior's.
  const Eigen::MatrixXd& P = stream_.P();
  const Eigen::MatrixXd w = open_ ? Eigen::MatrixXd(P.block(n_, n_, k, k)) : prior_;
  Eigen::MatrixXd cov = slope.asDiagonal() * w * slope.asDiagonal();
  return 0.5 * (cov + cov.transpose());
}

Result<std::vector<RecursiveUpdate>> AugmentedEkf::Push(const Sample& row) {
  if (rows_ == 0) first_t_ = row.t;
  ++rows_;
  auto steps = stream_.Push(row);
  if (!steps) return steps.error();
  const std::size_t k = tracked_.size();
  std::vector<RecursiveUpdate> out;
  out.reserve(steps->size());
  for (const EkfStep& s : *steps) {
    // The mean sample interval so far (the stream completes no index before the second row).
    const double dt = (row.t - first_t_) / static_cast<double>(rows_ - 1);
    if (warmup_ < 0) {
      // The rows of five slowest time constants.
      const double slow = stream_.slowest_time_constant();
      warmup_ = std::isfinite(slow) ? static_cast<int>(std::ceil(5.0 * slow / dt)) : kDefaultWarmup;
    }
    RecursiveUpdate u = ToUpdate(s);
    u.score.clear();
    u.information.clear();
    u.warming_up = s.index < warmup_;
    if (!u.warming_up && !open_ && k > 0) {
      // Open after this index's update: the next interval carries the random walk.
      Open(dt);
    }
    const Eigen::VectorXd& x = stream_.x();
    for (std::size_t a = 0; a < k; ++a) {
      const int i = tracked_[a];
      theta_[i] = Inside(FromWorking(x(n_ + static_cast<Eigen::Index>(a)), lower_[a], upper_[a]),
                         lower_[a], upper_[a]);
      u.theta.push_back(theta_[i]);
    }
    const Eigen::MatrixXd cov = Covariance();
    for (std::size_t a = 0; a < k; ++a) {
      const auto b = static_cast<Eigen::Index>(a);
      u.sd.push_back(std::sqrt(std::max(cov(b, b), 0.0)));
    }
    out.push_back(std::move(u));
  }
  return out;
}

}  // namespace gb::online
