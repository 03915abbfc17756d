// Profile likelihood intervals (estimate.h: ProfileIntervals).
//
// For a parameter θ_p with estimate θ̂_p and the maximum L̂ of the objective, the threshold is
// L̂ - q/2 with q the χ²₁ quantile at the level (1.92 for 95 %). One side (σ = ±1) at a time:
//   1. step from the standard error (or 10 % of |θ̂_p|, or of the range), v = v_prev + σ step,
//      each point fitted over the other free parameters with θ_p held at v, warm-started from the
//      previous point (filter::Likelihood at the estimate's delays);
//   2. while the profile stays above the threshold, the next step aims where a parabola through
//      the estimate and the last point crosses it (at most 4x the last step, at least the last
//      step); a point at the parameter's bound that is still above ends the side there (no end);
//   3. once below, the end is bracketed: the Illinois method on P(v) - threshold until the
//      bracket's value is within 1e-3 of the threshold or its width within 1e-9 relative.
#include <algorithm>
#include <cmath>

#include <boost/math/distributions/chi_squared.hpp>
#include <fmt/format.h>

#include "core/estimate/estimate.h"
#include "core/estimate/fitter.h"
#include "core/util/parallel.h"

namespace gb::estimate {

namespace {

using internal::FitResult;
using internal::Fitter;

constexpr int kMaxStepsOut = 40;     // points fitted walking out before giving up
constexpr int kMaxRefinements = 30;  // Illinois iterations
constexpr double kLoglikTol = 1e-3;  // |P(v) - threshold| accepted at an end
constexpr double kWidthTol = 1e-9;   // relative width of the bracket accepted at an end

// One side of one parameter's profile.
class ProfileSide {
 public:
  ProfileSide(const filter::Likelihood& lik, const EstimateOptions& options,
              const std::vector<double>& theta_hat, const std::vector<int>& delay, int p,
              double loglik_max, double threshold, double first_step, int sign)
      : lik_(lik),
        options_(options),
        delay_(delay),
        p_(p),
        threshold_(threshold),
        first_step_(first_step),
        sign_(sign) {
    const auto& par = lik.spec().parameters[p];
    bound_ = sign > 0 ? par.upper : par.lower;
    prior_ = par.prior;
    points_.push_back({theta_hat[p], loglik_max, true});
    thetas_.push_back(theta_hat);
  }

  std::optional<double> end;
  bool at_bound = false;
  std::vector<std::string> warnings;
  const std::vector<ProfilePoint>& points() const { return points_; }

  void Run() {
    const auto& name = lik_.spec().parameters[p_].name;
    const double v0 = points_[0].value;
    if (bound_ && std::abs(*bound_ - v0) <= 1e-12 * std::max(1.0, std::abs(v0))) {
      at_bound = true;  // the estimate is at this bound
      return;
    }
    double step = first_step_;
    for (int n = 0; n < kMaxStepsOut; ++n) {
      if (Cancelled()) return;
      double v = points_.back().value + sign_ * step;
      bool last = false;
      if (bound_ && sign_ * (v - *bound_) >= 0) v = *bound_, last = true;
      const ProfilePoint& pt = Fit(v, thetas_.size() - 1);
      if (!std::isfinite(pt.loglik)) {
        // The model cannot be fitted here: shorten the step; give up when it is negligible.
        points_.pop_back(), thetas_.pop_back();
        step /= 4;
        if (step < 1e-8 * std::max(1.0, std::abs(v0))) {
          warnings.push_back(
              fmt::format("the profile of {} cannot be computed {} {} (the model "
                          "fails there): that end is missing",
                          name, sign_ > 0 ? "above" : "below", points_.back().value));
          return;
        }
        continue;
      }
      if (pt.loglik < threshold_) {
        Refine();
        return;
      }
      if (last) {
        at_bound = true;
        return;
      }
      // Aim at where a parabola through the estimate and this point meets the threshold.
      const double dv = v - v0;
      const double drop = points_[0].loglik - pt.loglik;
      double next = 4 * step;
      if (drop > 0) {
        const double c = drop / (dv * dv);
        const double target = std::sqrt((points_[0].loglik - threshold_) / c) * 1.05;
        next = std::clamp(target - std::abs(dv), step, 4 * step);
      }
      step = next;
    }
    warnings.push_back(
        fmt::format("the profile of {} stays within the threshold for {} steps {} "
                    "the estimate: that end is missing (the data hardly bound it)",
                    name, kMaxStepsOut, sign_ > 0 ? "above" : "below"));
  }

 private:
  bool Cancelled() const { return options_.cancel && options_.cancel->load(); }

  // The profile at v, from the others of point `from`; appended to points_ and thetas_.
  const ProfilePoint& Fit(double v, std::size_t from) {
    std::vector<double> base = thetas_[from];
    base[p_] = v;
    const int held[] = {p_};
    EstimateOptions inner = options_;
    inner.threads = 1;
    inner.progress = nullptr;
    Fitter fitter(lik_, inner, base, held);
    FitResult r = fitter.Fit(fitter.ZStart(), delay_, "profile");
    double value = r.loglik;
    if (prior_) value += prior_->LogDensity(v);
    points_.push_back({v, value, r.converged});
    thetas_.push_back(std::isfinite(r.loglik) ? fitter.Theta(r.z) : base);
    return points_.back();
  }

  // The last point is below the threshold, the one before above: the Illinois method.
  void Refine() {
    std::size_t a = points_.size() - 2, b = points_.size() - 1;  // above, below
    double fa = points_[a].loglik - threshold_, fb = points_[b].loglik - threshold_;
    int side = 0;
    for (int it = 0; it < kMaxRefinements && !Cancelled(); ++it) {
      const double va = points_[a].value, vb = points_[b].value;
      if (std::abs(vb - va) <= kWidthTol * std::max(std::abs(va), std::abs(vb))) break;
      double v = vb - fb * (vb - va) / (fb - fa);
      if (!(std::isfinite(v)) || sign_ * (v - va) <= 0 || sign_ * (v - vb) >= 0)
        v = 0.5 * (va + vb);
      const std::size_t from = std::abs(v - va) < std::abs(v - vb) ? a : b;
      const ProfilePoint& pt = Fit(v, from);
      if (!std::isfinite(pt.loglik)) break;
      const double f = pt.loglik - threshold_;
      const std::size_t c = points_.size() - 1;
      if (std::abs(f) < kLoglikTol) {
        end = v;
        return;
      }
      if (f > 0) {
        a = c, fa = f;
        if (side == +1) fb /= 2;
        side = +1;
      } else {
        b = c, fb = f;
        if (side == -1) fa /= 2;
        side = -1;
      }
    }
    // The bracket's interpolated crossing.
    const double va = points_[a].value, vb = points_[b].value;
    end = fb != fa ? vb - fb * (vb - va) / (fb - fa) : 0.5 * (va + vb);
  }

  const filter::Likelihood& lik_;
  const EstimateOptions& options_;
  const std::vector<int>& delay_;
  int p_;
  double threshold_;
  double first_step_;
  int sign_;
  std::optional<double> bound_;
  std::optional<model::Parameter::Prior> prior_;
  std::vector<ProfilePoint> points_;         // the estimate first, then in the order fitted
  std::vector<std::vector<double>> thetas_;  // all parameters at each point
};

}  // namespace

Result<std::vector<ProfileInterval>> ProfileIntervals(const filter::Likelihood& lik,
                                                      const EstimateSummary& at,
                                                      const std::vector<std::string>& names,
                                                      double level,
                                                      const EstimateOptions& fit_options) {
  const model::ModelSpec& spec = lik.spec();
  if (!(level > 0 && level < 1))
    return InputError(
        fmt::format("the profile interval's level must be in (0, 1), found {}", level));
  if (at.theta.size() != spec.parameters.size() || at.parameters.size() != spec.parameters.size())
    return InputError("the estimate is not of this model (its parameters differ)");
  std::vector<int> which;
  if (names.empty()) {
    for (std::size_t i = 0; i < spec.parameters.size(); ++i)
      if (!spec.parameters[i].fixed) which.push_back(static_cast<int>(i));
  } else {
    for (const auto& n : names) {
      const int i = spec.ParameterIndex(n);
      if (i < 0) return InputError(fmt::format("no parameter named '{}' in the model", n));
      if (spec.parameters[i].fixed)
        return InputError(fmt::format("'{}' is fixed: it has no profile", n));
      which.push_back(i);
    }
  }
  std::vector<int> delay;
  for (const auto& d : at.delays) delay.push_back(d.estimate);
  const double loglik_max = at.log_posterior.value_or(at.loglik);
  const double q = boost::math::quantile(boost::math::chi_squared(1.0), level);
  const double threshold = loglik_max - q / 2;

  struct Task {
    int p;
    int sign;
  };
  std::vector<Task> tasks;
  for (int p : which)
    for (int sign : {-1, 1}) tasks.push_back({p, sign});
  std::vector<std::optional<ProfileSide>> sides(tasks.size());
  for (std::size_t t = 0; t < tasks.size(); ++t) {
    const int p = tasks[t].p;
    const auto& par = spec.parameters[p];
    const ParameterEstimate& e = at.parameters[p];
    double step = e.std_error && *e.std_error > 0 ? *e.std_error : 0.1 * std::abs(e.estimate);
    if (!(step > 0)) step = par.lower && par.upper ? 0.1 * (*par.upper - *par.lower) : 0.1;
    sides[t].emplace(lik, fit_options, at.theta, delay, p, loglik_max, threshold, step,
                     tasks[t].sign);
  }
  ParallelFor(static_cast<int>(tasks.size()), fit_options.threads, [&](int t) { sides[t]->Run(); });
  if (fit_options.cancel && fit_options.cancel->load()) return NumericalError("cancelled");

  std::vector<ProfileInterval> out;
  for (std::size_t w = 0; w < which.size(); ++w) {
    const ProfileSide& lo = *sides[2 * w];
    const ProfileSide& hi = *sides[2 * w + 1];
    ProfileInterval r;
    r.level = level;
    r.lower = lo.end;
    r.upper = hi.end;
    r.lower_at_bound = lo.at_bound;
    r.upper_at_bound = hi.at_bound;
    r.warnings = lo.warnings;
    r.warnings.insert(r.warnings.end(), hi.warnings.begin(), hi.warnings.end());
    r.curve = lo.points();
    r.curve.insert(r.curve.end(), hi.points().begin() + 1, hi.points().end());
    std::sort(r.curve.begin(), r.curve.end(),
              [](const ProfilePoint& a, const ProfilePoint& b) { return a.value < b.value; });
    const auto& name = spec.parameters[which[w]].name;
    for (const auto& pt : r.curve) {
      if (pt.loglik > loglik_max + kLoglikTol) {
        r.warnings.push_back(fmt::format(
            "the profile of {} reaches {:.4f} at {} = {:.6g}, above the estimate's {:.4f}: the "
            "fit had not found the maximum; estimate again from there",
            name, pt.loglik, name, pt.value, loglik_max));
        break;
      }
    }
    out.push_back(std::move(r));
  }
  return out;
}

}  // namespace gb::estimate
