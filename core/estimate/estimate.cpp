// Sections: 1. options  3. start points  4. Hessian and uncertainties  5. Estimate: the run's
//           stages (EstimateRun) and the entry point  6. likelihood-ratio test
// The fitter (section 2: the free parameters on their working scale, the objective, its parallel
// gradient, the optimisers) is in fitter.h and fitter.cpp; the report and JSON forms of the
// summary are in summary_format.cpp.
#include "core/estimate/estimate.h"

#include <algorithm>
#include <chrono>
#include <climits>
#include <cmath>
#include <limits>
#include <map>
#include <mutex>
#include <optional>
#include <random>
#include <set>
#include <tuple>

#include <Eigen/Dense>
#include <boost/math/distributions/chi_squared.hpp>
#include <boost/math/distributions/normal.hpp>
#include <boost/math/distributions/students_t.hpp>
#include <fmt/format.h>
#include <nlopt.hpp>

#include "core/estimate/fitter.h"
#include "core/expr/expr.h"
#include "core/expr/native.h"
#include "core/util/parallel.h"

namespace gb::estimate {

// ---- 1. options ------------------------------------------------------------------------------

bool EstimateOptions::IsValid(std::string* why) const {
  auto fail = [&](const char* m) {
    if (why) *why = m;
    return false;
  };
  if (!(ftol_rel >= 0 && ftol_rel < 1) || !(xtol_rel >= 0 && xtol_rel < 1))
    return fail("the tolerances must be from 0 up to (not including) 1");
  if (ftol_rel == 0 && xtol_rel == 0 && max_evaluations <= 0)
    return fail("no stopping rule: set a tolerance or max_evaluations");
  if (max_evaluations < 0) return fail("max_evaluations must be >= 0");
  if (multistart < 0 || multistart > kMaxStarts)
    return fail("multistart must be from 0 to 10000 (each extra start is a whole fit)");
  if (starts_on_bound < 0 || starts_on_bound > kMaxStarts)
    return fail("starts_on_bound must be from 0 to 10000");
  if (threads < 0 || threads > kMaxThreads)
    return fail("threads must be from 1 to 1024, or 0 for all cores");
  if (!(profile_level > 0 && profile_level < 1))
    return fail("the profile intervals' level must lie strictly between 0 and 1");
  if (steady_start && !(steady_window > 0 && std::isfinite(steady_window)))
    return fail("the steady-state start's window must be longer than 0");
  return true;
}

namespace {

using namespace internal;
using Clock = std::chrono::steady_clock;

// A parameter's row of the summary at `value`: its name, bounds, unit and whether it is fixed
// (standard errors and tests are the caller's).
ParameterEstimate EstimateOf(const model::Parameter& p, double value) {
  ParameterEstimate e;
  e.name = p.name;
  e.estimate = value;
  e.lower = p.lower;
  e.upper = p.upper;
  e.fixed = p.fixed;
  e.unit = p.unit;
  return e;
}

// ---- 3. start points -------------------------------------------------------------------------

// The model's start and `extra` more, spread by a Latin hypercube over each free parameter's
// range (bounded on both sides: uniform in the bounds; otherwise log-uniform within a factor 10
// of the start, kept inside any single bound).
std::vector<std::vector<double>> StartPoints(const Fitter& f, int extra, std::uint64_t seed) {
  std::vector<std::vector<double>> starts{f.ZStart()};
  if (extra <= 0 || f.k() == 0) return starts;
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::vector<std::vector<double>> columns(f.k());
  for (int i = 0; i < f.k(); ++i) {
    std::vector<int> perm(extra);
    for (int s = 0; s < extra; ++s) perm[s] = s;
    std::shuffle(perm.begin(), perm.end(), rng);
    for (int s = 0; s < extra; ++s) columns[i].push_back((perm[s] + unit(rng)) / extra);
  }
  const std::vector<double> z0 = f.ZStart();
  for (int s = 0; s < extra; ++s) {
    std::vector<double> z(f.k());
    for (int i = 0; i < f.k(); ++i) {
      const double u = columns[i][s];
      const double lo = f.lower(i), hi = f.upper(i);
      if (std::isfinite(lo) && std::isfinite(hi)) {
        z[i] = lo + u * (hi - lo);  // on a log scale: log-uniform in θ
      } else if (f.log_scale(i)) {  // within a factor 10 of the start
        z[i] = std::clamp(z0[i] + std::log(10.0) * (2 * u - 1), lo, hi);
      } else {
        const double base = z0[i] != 0 ? z0[i] : 1.0;
        z[i] = std::clamp(base * std::pow(10.0, 2 * u - 1), lo, hi);
      }
    }
    starts.push_back(std::move(z));
  }
  return starts;
}

// Whether free parameter i at z lies on one of its bounds: within kAtBoundTol of its range (or of
// its size, without two bounds).
bool AtBound(const Fitter& f, const std::vector<double>& z, int i) {
  const double range = std::isfinite(f.upper(i) - f.lower(i)) ? f.upper(i) - f.lower(i)
                                                              : std::max(1.0, std::abs(z[i]));
  const double to_bound = std::min(z[i] - f.lower(i), f.upper(i) - z[i]);
  return to_bound <= kAtBoundTol * std::max(range, std::abs(z[i]));
}

// Whether fit r ended with free parameter i on the lower bound it crept onto (FitResult::crept).
bool CreptOntoBound(const Fitter& f, const FitResult& r, int i) {
  return std::binary_search(r.crept.begin(), r.crept.end(), i) && AtBound(f, r.z, i) &&
         r.z[i] - f.lower(i) <= f.upper(i) - r.z[i];
}

// Whether fit r ended with a parameter on a bound, other than one it crept onto.
bool OnABound(const Fitter& f, const FitResult& r) {
  for (int i = 0; i < f.k(); ++i)
    if (AtBound(f, r.z, i) && !CreptOntoBound(f, r, i)) return true;
  return false;
}

// The free and fixed parameters (indices into the model's) that the diffusion uses and no other
// formula does: its variances, which the relaxed fit holds (EstimateRun::RelaxDiffusion).
std::vector<int> DiffusionOnly(const model::ModelSpec& spec) {
  std::set<std::string> in_diffusion, elsewhere;
  for (const model::Formula& f : spec.diffusion) expr::CollectNames(f.expr, &in_diffusion);
  for (const auto* list : {&spec.drift, &spec.observation, &spec.measurement_variance,
                           &spec.initial_state, &spec.initial_variance})
    for (const model::Formula& f : *list) expr::CollectNames(f.expr, &elsewhere);
  std::vector<int> only;
  for (std::size_t i = 0; i < spec.parameters.size(); ++i) {
    const std::string& name = spec.parameters[i].name;
    if (in_diffusion.contains(name) && !elsewhere.contains(name))
      only.push_back(static_cast<int>(i));
  }
  return only;
}

// The same likelihood with the model's diffusion σ(x, u, θ) multiplied by √factor (σσ' by
// factor), over the same records and series parameters.
Result<filter::Likelihood> RelaxedLikelihood(const filter::Likelihood& lik, double factor) {
  model::ModelSpec spec = lik.spec();
  const auto product = expr::Parse("relax_factor * diffusion");
  if (!product) return product.error();
  const expr::ExprPtr scaled =
      expr::Substitute(*product, "relax_factor", expr::Constant(std::sqrt(factor)));
  for (model::Formula& f : spec.diffusion) {
    f.expr = expr::Substitute(scaled, "diffusion", f.expr);
    f.text = expr::ToString(f.expr);
  }
  // Over the same records and series parameters.
  auto over_records = [&](auto model) {
    Result<filter::Likelihood> relaxed = filter::Likelihood::Create(std::move(model), lik.series());
    if (relaxed && !lik.series_parameters().empty())
      relaxed->set_series_parameters(lik.series_parameters());
    if (relaxed && lik.native()) {
      if (auto native = relaxed->WithNativeCode()) relaxed = std::move(native);
    }
    return relaxed;
  };
  if (lik.linear()) {
    auto m = model::LinearModel::Compile(std::move(spec));
    if (!m) return m.error();
    return over_records(std::make_shared<const model::LinearModel>(std::move(m).value()));
  }
  auto m = model::NonlinearModel::Compile(std::move(spec));
  if (!m) return m.error();
  return over_records(std::make_shared<const model::NonlinearModel>(std::move(m).value()));
}

// ---- 4. Hessian and uncertainties ------------------------------------------------------------

// The Hessian of -log L in scaled units by finite differences over the parameters `active`
// (steps h), from the value f0 = log L(z). Each parameter's differences are central, or, where
// log L cannot be evaluated on one side of the estimate (a model that fails just below it, say),
// one-sided of second order:
//   central:  f'  ≈ (f₁ - f₋₁)/2h                f'' ≈ (f₁ - 2f₀ + f₋₁)/h²
//   one-sided: f' ≈ (-3f₀ + 4f₁ - f₂)/2h         f'' ≈ (2f₀ - 5f₁ + 4f₂ - f₃)/h²
// (fₖ = f(z + k d h e_a), d = ±1 the side that works). A mixed derivative is the product of the
// two parameters' first-derivative stencils; with every parameter central these are the usual
// 4-corner formulas. A parameter whose differences fail on both sides, or whose one-sided
// stencil would leave its bounds, is dropped: its row and column are left zero.
class HessianByDifferences {
 public:
  HessianByDifferences(Fitter& f, const std::vector<double>& z, double f0,
                       const std::vector<int>& delay, const std::vector<int>& active,
                       std::vector<double> h, int threads)
      : f_(f),
        z_(z),
        f0_(f0),
        delay_(delay),
        active_(active),
        h_(std::move(h)),
        threads_(threads),
        dir_(active.size(), 0),
        dropped_(active.size(), false) {}

  int direction(int a) const { return dir_[a]; }  // 0 central, +1 forward, -1 backward
  bool dropped(int a) const { return dropped_[a]; }

  Eigen::MatrixXd Run() {
    const int m = static_cast<int>(active_.size());
    // Each round either ends with a finite Hessian or makes a parameter one-sided or drops it.
    for (int round = 0; round <= 2 * m; ++round) {
      Evaluate(NeededPoints());
      if (f_.Cancelled()) return Eigen::MatrixXd::Zero(m, m);
      Eigen::MatrixXd H = Assemble();
      if (H.allFinite() || !Mend()) return H;
    }
    Evaluate(NeededPoints());  // not reached: Mend changes something at most 2m times
    return Assemble();
  }

 private:
  // A point: up to two parameters displaced, by a whole number of their steps (a < b, or b = -1).
  struct Point {
    int a = -1, oa = 0, b = -1, ob = 0;
    bool operator<(const Point& o) const {
      return std::tie(a, oa, b, ob) < std::tie(o.a, o.oa, o.b, o.ob);
    }
    bool operator==(const Point& o) const {
      return std::tie(a, oa, b, ob) == std::tie(o.a, o.oa, o.b, o.ob);
    }
  };
  using Stencil = std::vector<std::pair<int, double>>;  // (offset in steps, weight)

  Stencil First(int a) const {
    const int d = dir_[a];
    if (d == 0) return {{1, 0.5}, {-1, -0.5}};
    return {{0, -1.5 * d}, {d, 2.0 * d}, {2 * d, -0.5 * d}};
  }
  Stencil Second(int a) const {
    const int d = dir_[a];
    if (d == 0) return {{1, 1.0}, {0, -2.0}, {-1, 1.0}};
    return {{0, 2.0}, {d, -5.0}, {2 * d, 4.0}, {3 * d, -1.0}};
  }
  // A parameter displaced by 0 steps is not displaced: it is left out of the point.
  static Point Make(int a, int oa, int b, int ob) {
    if (oa == 0) a = -1;
    if (ob == 0) b = -1;
    if (a < 0) std::swap(a, b), std::swap(oa, ob);
    if (b >= 0 && b < a) std::swap(a, b), std::swap(oa, ob);
    return {a, oa, b, ob};
  }

  // Calls visit(a, b, point, weight) for every term of every H(a, b), a <= b, of the parameters
  // not dropped.
  template <class Visit>
  void EachTerm(const Visit& visit) const {
    const int m = static_cast<int>(active_.size());
    for (int a = 0; a < m; ++a) {
      if (dropped_[a]) continue;
      for (const auto& [o, w] : Second(a)) visit(a, a, Make(a, o, -1, 0), w);
      for (int b = a + 1; b < m; ++b) {
        if (dropped_[b]) continue;
        for (const auto& [oa, wa] : First(a))
          for (const auto& [ob, wb] : First(b)) visit(a, b, Make(a, oa, b, ob), wa * wb);
      }
    }
  }

  std::vector<Point> NeededPoints() const {
    std::vector<Point> need;
    EachTerm([&](int, int, const Point& p, double) {
      if (p.a >= 0 && !values_.count(p)) need.push_back(p);
    });
    std::sort(need.begin(), need.end());
    need.erase(std::unique(need.begin(), need.end()), need.end());
    return need;
  }

  void Evaluate(const std::vector<Point>& points) {
    std::vector<double> v(points.size());
    ParallelFor(static_cast<int>(points.size()), threads_, [&](int c) {
      const Point& p = points[c];
      std::vector<double> zp = z_;
      zp[active_[p.a]] += p.oa * h_[p.a];
      if (p.b >= 0) zp[active_[p.b]] += p.ob * h_[p.b];
      v[c] = -f_.Objective(zp, delay_, /*threads=*/1);
    });
    for (std::size_t c = 0; c < points.size(); ++c) values_[points[c]] = v[c];
  }

  double Value(const Point& p) const { return p.a < 0 ? -f0_ : values_.at(p); }

  Eigen::MatrixXd Assemble() const {
    const int m = static_cast<int>(active_.size());
    Eigen::MatrixXd H = Eigen::MatrixXd::Zero(m, m);
    EachTerm([&](int a, int b, const Point& p, double w) { H(a, b) += w * Value(p); });
    for (int a = 0; a < m; ++a)
      for (int b = a; b < m; ++b) H(a, b) = H(b, a) = H(a, b) / (h_[a] * h_[b]);
    return H;
  }

  // After a Hessian with non-finite entries: makes central parameters one-sided, away from the
  // side where their points fail; when none can be, drops the parameter that takes part in the
  // most failed points. False when nothing could be changed.
  bool Mend() {
    const int m = static_cast<int>(active_.size());
    std::vector<int> failed_plus(m, 0), failed_minus(m, 0);
    EachTerm([&](int, int, const Point& p, double) {
      if (p.a < 0 || std::isfinite(Value(p))) return;
      for (auto [q, o] : {std::pair{p.a, p.oa}, std::pair{p.b, p.ob}})
        if (q >= 0) ++(o > 0 ? failed_plus : failed_minus)[q];
    });
    bool changed = false;
    for (int a = 0; a < m; ++a) {
      if (dropped_[a] || dir_[a] != 0 || (failed_plus[a] > 0) == (failed_minus[a] > 0)) continue;
      const int d = failed_minus[a] > 0 ? 1 : -1;
      const int i = active_[a];
      const double room = d > 0 ? f_.upper(i) - z_[i] : z_[i] - f_.lower(i);
      if (!(3 * h_[a] < room)) continue;  // the one-sided stencil would leave the bounds
      dir_[a] = d;
      changed = true;
    }
    if (changed) return true;
    int worst = -1;
    for (int a = 0; a < m; ++a) {
      const int n = failed_plus[a] + failed_minus[a];
      if (!dropped_[a] && n > 0 && (worst < 0 || n > failed_plus[worst] + failed_minus[worst]))
        worst = a;
    }
    if (worst < 0) return false;
    dropped_[worst] = true;
    return true;
  }

  Fitter& f_;
  const std::vector<double>& z_;
  double f0_;
  const std::vector<int>& delay_;
  const std::vector<int>& active_;
  std::vector<double> h_;
  int threads_;
  std::vector<int> dir_;
  std::vector<bool> dropped_;
  std::map<Point, double> values_;  // -log L at the points evaluated so far
};

// The Hessian of -objective in scaled units from differences of the exact gradient (Fitter::
// Scores) over the parameters `active` (steps h): column a is -∂g/∂z_a,
//   central:   (g(z + h e_a) - g(z - h e_a)) / 2h
//   one-sided: (-3 g(z) + 4 g(z + d h e_a) - g(z + 2 d h e_a)) / 2dh   (d = ±1, second order)
// the latter where the gradient cannot be computed on one side; a parameter whose gradient fails
// on both sides (or whose one-sided stencil would leave the bounds) is dropped, its row and column
// left zero. The result is symmetrised. 2m gradient evaluations, on `threads` threads; its error
// is O(h²) where second differences of log L are O(h²) + O(eps/h²).
class HessianByGradients {
 public:
  HessianByGradients(Fitter& f, const std::vector<double>& z, const Eigen::VectorXd& g0,
                     const std::vector<int>& delay, const std::vector<int>& active,
                     std::vector<double> h, int threads)
      : f_(f),
        z_(z),
        g0_(g0),
        delay_(delay),
        active_(active),
        h_(std::move(h)),
        threads_(threads),
        dir_(active.size(), 0),
        dropped_(active.size(), false) {}

  int direction(int a) const { return dir_[a]; }  // 0 central, +1 forward, -1 backward
  bool dropped(int a) const { return dropped_[a]; }

  Eigen::MatrixXd Run() {
    const int m = static_cast<int>(active_.size());
    // Central differences first; then, for the parameters that failed on one side, one-sided.
    std::vector<std::pair<int, int>> points;  // (a, offset in steps)
    for (int a = 0; a < m; ++a) points.insert(points.end(), {{a, 1}, {a, -1}});
    Evaluate(points);
    points.clear();
    for (int a = 0; a < m; ++a) {
      const bool plus = Ok(a, 1), minus = Ok(a, -1);
      if (plus && minus) continue;
      const int d = plus ? 1 : minus ? -1 : 0;
      const int i = active_[a];
      const double room = d > 0 ? f_.upper(i) - z_[i] : z_[i] - f_.lower(i);
      if (d == 0 || !(2 * h_[a] < room)) {
        dropped_[a] = true;
        continue;
      }
      dir_[a] = d;
      points.emplace_back(a, 2 * d);
    }
    Evaluate(points);
    Eigen::MatrixXd H = Eigen::MatrixXd::Zero(m, m);
    for (int a = 0; a < m; ++a) {
      if (dropped_[a]) continue;
      const int d = dir_[a];
      if (d != 0 && !Ok(a, 2 * d)) {
        dropped_[a] = true;
        continue;
      }
      Eigen::VectorXd column =
          d == 0 ? Eigen::VectorXd((grad_.at({a, 1}) - grad_.at({a, -1})) / (2 * h_[a]))
                 : Eigen::VectorXd((-3 * g0_ + 4 * grad_.at({a, d}) - grad_.at({a, 2 * d})) /
                                   (2 * d * h_[a]));
      for (int b = 0; b < m; ++b) H(b, a) = -column(active_[b]);
    }
    for (int a = 0; a < m; ++a)
      for (int b = 0; b < m; ++b)
        if (dropped_[a] || dropped_[b]) H(a, b) = 0;
    return (H + H.transpose()) / 2;
  }

 private:
  bool Ok(int a, int offset) const {
    auto it = grad_.find({a, offset});
    return it != grad_.end() && it->second.size() > 0;
  }

  void Evaluate(const std::vector<std::pair<int, int>>& points) {
    std::vector<Eigen::VectorXd> g(points.size());
    ParallelFor(static_cast<int>(points.size()), threads_, [&](int c) {
      const auto [a, offset] = points[c];
      std::vector<double> zp = z_;
      const int i = active_[a];
      zp[i] += offset * h_[a];
      if (zp[i] < f_.lower(i) || zp[i] > f_.upper(i)) return;  // outside the bounds: failed
      double value = 0;
      Eigen::VectorXd gp;
      if (f_.Scores(zp, delay_, &value, &gp, nullptr, /*split=*/false)) g[c] = std::move(gp);
    });
    for (std::size_t c = 0; c < points.size(); ++c) grad_[points[c]] = std::move(g[c]);
  }

  Fitter& f_;
  const std::vector<double>& z_;
  const Eigen::VectorXd& g0_;
  const std::vector<int>& delay_;
  const std::vector<int>& active_;
  std::vector<double> h_;
  int threads_;
  std::vector<int> dir_;
  std::vector<bool> dropped_;
  std::map<std::pair<int, int>, Eigen::VectorXd> grad_;  // empty where the gradient failed
};

struct Uncertainty {
  std::vector<std::optional<double>> std_error;  // per free parameter
  std::vector<bool> at_bound;
  std::vector<int> with_se;    // free-parameter indices that have an SE
  Eigen::MatrixXd covariance;  // over with_se
  std::vector<std::string> warnings;
  // Where the Hessian has a clearly negative eigenvalue: its eigenvector (scaled units, per free
  // parameter, zero for those at a bound), along which the objective increases.
  std::optional<Eigen::VectorXd> uphill;
  // The Hessian of -objective in scaled units over all free parameters (NaN where not computed)
  // and the Newton decrement ½ g' H⁻¹ g over the parameters with a standard error: the increase
  // of the objective a Newton step would bring (0 when unknown).
  Eigen::MatrixXd hessian_scaled;
  double newton_decrement = 0.0;
};

Uncertainty ComputeUncertainty(Fitter& f, const std::vector<double>& z, double f0,
                               const std::vector<int>& delay, const model::ModelSpec& spec,
                               int threads) {
  Uncertainty u;
  const int k = f.k();
  u.std_error.assign(k, std::nullopt);
  u.at_bound.assign(k, false);
  std::vector<int> active;  // free parameters not at a bound
  std::vector<double> h;    // their steps (scaled units)
  for (int i = 0; i < k; ++i) {
    if (AtBound(f, z, i)) {
      u.at_bound[i] = true;
      continue;
    }
    const double to_bound = std::min(z[i] - f.lower(i), f.upper(i) - z[i]);
    double step = kHessianStep * std::max(std::abs(z[i]), 1e-2);
    step = std::min(step, to_bound / 2.5);  // stay inside the bounds with ±2 steps
    active.push_back(i);
    h.push_back(step);
  }
  const int m = static_cast<int>(active.size());
  auto name = [&](int a) { return spec.parameters[f.free()[active[a]]].name; };
  // From differences of the exact gradient where it can be computed at the estimate; else from
  // second differences of the objective.
  std::vector<int> direction(m, 0);
  std::vector<bool> dropped(m, false);
  Eigen::MatrixXd H;
  double f_at = 0;
  Eigen::VectorXd g0;
  bool exact = false;
  if (f.Scores(z, delay, &f_at, &g0, nullptr, true, &exact) && exact) {
    std::vector<double> hg(m);
    for (int a = 0; a < m; ++a) hg[a] = std::min(h[a] * kGradientHessianStep / kHessianStep, h[a]);
    HessianByGradients hd(f, z, g0, delay, active, std::move(hg), threads);
    H = hd.Run();
    for (int a = 0; a < m; ++a) direction[a] = hd.direction(a), dropped[a] = hd.dropped(a);
  } else {
    HessianByDifferences hd(f, z, f0, delay, active, std::move(h), threads);
    H = hd.Run();
    for (int a = 0; a < m; ++a) direction[a] = hd.direction(a), dropped[a] = hd.dropped(a);
  }
  if (f.Cancelled()) return u;
  for (int a = 0; a < m; ++a) {
    if (dropped[a])
      u.warnings.push_back(fmt::format(
          "the log-likelihood cannot be evaluated on either side of {} near the estimate: no "
          "standard error for {}; the others' are computed with it held at its estimate",
          name(a), name(a)));
    else if (direction[a] != 0)
      u.warnings.push_back(fmt::format(
          "the log-likelihood cannot be evaluated just {} the estimate of {} (the model fails "
          "there): its standard error uses one-sided differences",
          direction[a] > 0 ? "below" : "above", name(a)));
  }
  // Negative curvature (in scaled units): the estimate is a saddle, and the direction of the
  // most negative curvature leads uphill.
  {
    std::vector<int> kept;
    for (int a = 0; a < m; ++a)
      if (!dropped[a]) kept.push_back(a);
    const int n = static_cast<int>(kept.size());
    if (n > 0 && H.allFinite()) {
      Eigen::MatrixXd Hk(n, n);
      for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) Hk(i, j) = H(kept[i], kept[j]);
      Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(Hk);
      const double largest = es.eigenvalues().cwiseAbs().maxCoeff();
      if (es.eigenvalues()(0) < -kNegativeCurvature * largest) {
        u.uphill = Eigen::VectorXd::Zero(k);
        for (int i = 0; i < n; ++i) (*u.uphill)(active[kept[i]]) = es.eigenvectors()(i, 0);
      }
    }
  }
  if (!H.allFinite()) {  // every point finite, yet the differences overflow
    u.warnings.push_back(
        "the Hessian could not be computed (the differences of the "
        "log-likelihood near the estimate overflow): no standard errors");
    return u;
  }
  u.hessian_scaled = Eigen::MatrixXd::Constant(k, k, NAN);
  for (int a = 0; a < m; ++a)
    for (int b = 0; b < m; ++b)
      if (!dropped[a] && !dropped[b]) u.hessian_scaled(active[a], active[b]) = H(a, b);
  // Hessian of -log L in working units, then to the natural scale: with θ_i = θ_i(z_i),
  //   ∂²(-f)/∂z_a∂z_b = θ'_a θ'_b ∂²(-f)/∂θ_a∂θ_b - [a = b] θ''_a ∂f/∂θ_a,
  // and θ'' = θ' on a log scale (θ = e^z), 0 on a linear one (θ = s z): a log-scale parameter's
  // diagonal gets its gradient g_a = θ'_a ∂f/∂θ_a back before the division.
  for (int a = 0; a < m; ++a) {
    const int i = active[a];
    if (f.log_scale(i) && g0.size() == k && g0.allFinite() && !dropped[a]) H(a, a) += g0(i);
  }
  for (int a = 0; a < m; ++a)
    for (int b = 0; b < m; ++b)
      H(a, b) /= f.Slope(active[a], z[active[a]]) * f.Slope(active[b], z[active[b]]);

  // Parameters whose own curvature is not positive are not determined by the data at all.
  std::vector<int> keep;
  for (int a = 0; a < m; ++a) {
    if (dropped[a]) continue;
    if (H(a, a) > 0)
      keep.push_back(a);
    else
      u.warnings.push_back(
          fmt::format("the log-likelihood is flat or curves upward in {}: the "
                      "data do not determine it (no standard error)",
                      name(a)));
  }
  // Scale to unit diagonal and look for directions the data do not determine.
  for (int iter = 0; iter < m && !keep.empty(); ++iter) {
    const int n = static_cast<int>(keep.size());
    Eigen::MatrixXd Hs(n, n);
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j)
        Hs(i, j) = H(keep[i], keep[j]) / std::sqrt(H(keep[i], keep[i]) * H(keep[j], keep[j]));
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(Hs);
    if (es.eigenvalues()(0) > kUndeterminedEig * es.eigenvalues()(n - 1)) break;
    // The weakest direction: name the parameters that take part in it.
    const Eigen::VectorXd v = es.eigenvectors().col(0);
    std::vector<int> involved;
    for (int i = 0; i < n; ++i)
      if (std::abs(v(i)) > 0.2) involved.push_back(i);
    std::string names;
    for (std::size_t t = 0; t < involved.size(); ++t)
      names += (t ? (t + 1 == involved.size() ? " and " : ", ") : "") + name(keep[involved[t]]);
    u.warnings.push_back(fmt::format(
        "not identifiable: the data do not determine {} separately (only a combination of "
        "them); no standard errors for {}. Fix one of them or add an experiment that separates "
        "them.",
        names, involved.size() > 1 ? "them" : "it"));
    std::vector<int> next;
    for (int i = 0; i < n; ++i)
      if (std::find(involved.begin(), involved.end(), i) == involved.end()) next.push_back(keep[i]);
    keep = std::move(next);
  }
  if (keep.empty()) return u;
  const int n = static_cast<int>(keep.size());
  Eigen::MatrixXd Hk(n, n);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) Hk(i, j) = H(keep[i], keep[j]);
  const Eigen::LLT<Eigen::MatrixXd> llt(Hk);
  if (llt.info() != Eigen::Success) {
    u.warnings.push_back(
        "the Hessian is not positive definite at the estimate (not a maximum?): "
        "no standard errors");
    return u;
  }
  u.covariance = llt.solve(Eigen::MatrixXd::Identity(n, n));
  if (g0.size() == k) {
    Eigen::VectorXd g_natural(n);
    for (int i = 0; i < n; ++i)
      g_natural(i) = g0(active[keep[i]]) / f.Slope(active[keep[i]], z[active[keep[i]]]);
    u.newton_decrement = 0.5 * g_natural.dot(u.covariance * g_natural);
  }
  for (int i = 0; i < n; ++i) {
    const int fi = active[keep[i]];
    u.with_se.push_back(fi);
    u.std_error[fi] = std::sqrt(u.covariance(i, i));
  }
  return u;
}

// From a saddle point `at` (the objective curves upward along `uphill`, scaled units): the first
// of a few steps along ±uphill, from long to short, that raises the objective, and a full fit from
// there if it ends higher than `at`. nullopt when no step helps.
std::optional<FitResult> EscapeSaddle(Fitter& f, const FitResult& at, const Eigen::VectorXd& uphill,
                                      const std::vector<int>& delay) {
  const Eigen::VectorXd v = uphill.normalized();
  for (double step : {0.5, 0.1, 0.02, 0.004}) {
    for (int sign : {1, -1}) {
      std::vector<double> z = at.z;
      for (int i = 0; i < f.k(); ++i)
        z[i] = std::clamp(z[i] + sign * step * v(i), f.lower(i), f.upper(i));
      if (!(f.Objective(z, delay) > at.loglik)) continue;
      FitResult r = f.Fit(z, delay, "fitting");
      if (r.cancelled || r.loglik > at.loglik + kSameOptimum) return r;
    }
  }
  return std::nullopt;
}

// The warnings of a parameter's profile interval, and where it and the Wald interval θ̂ ± z SE
// disagree by more than a quarter of the Wald half-width at either end: the Hessian's curvature
// is not the profile's, and the profile interval is the one to trust.
void AddProfileWarnings(const ParameterEstimate& e, std::vector<std::string>* warnings) {
  const ProfileInterval& pi = *e.profile;
  for (const auto& w : pi.warnings) warnings->push_back(w);
  for (auto [end, at_bound, side] : {std::tuple{pi.lower, pi.lower_at_bound, "lower"},
                                     std::tuple{pi.upper, pi.upper_at_bound, "upper"}}) {
    if (!end && at_bound)
      warnings->push_back(
          fmt::format("the profile of {} stays within the {:.0f} % threshold down "
                      "to its {} bound: the data do not bound it on that side",
                      e.name, 100 * pi.level, side));
  }
  if (!e.std_error) return;
  const double zq = boost::math::quantile(boost::math::normal(), 0.5 + pi.level / 2);
  const double half = zq * *e.std_error;
  const double lo = e.estimate - half, hi = e.estimate + half;
  const bool differs = (!pi.lower || std::abs(*pi.lower - lo) > 0.25 * half) ||
                       (!pi.upper || std::abs(*pi.upper - hi) > 0.25 * half);
  if (differs)
    warnings->push_back(fmt::format(
        "the Wald interval of {} [{:.4g}, {:.4g}] differs from its profile interval [{}, {}]: "
        "the log-likelihood is far from quadratic there; trust the profile interval",
        e.name, lo, hi, pi.lower ? fmt::format("{:.4g}", *pi.lower) : "bound",
        pi.upper ? fmt::format("{:.4g}", *pi.upper) : "bound"));
}

// Without profile intervals: where the Wald intervals cannot be trusted (a parameter at a bound,
// or without a standard error), recommend them.
void RecommendProfiles(const std::vector<ParameterEstimate>& parameters,
                       std::vector<std::string>* warnings) {
  std::string which;
  for (const auto& e : parameters)
    if (!e.fixed && (e.at_bound || !e.std_error)) which += (which.empty() ? "" : ", ") + e.name;
  if (!which.empty())
    warnings->push_back(
        fmt::format("the standard errors assume a quadratic log-likelihood, which "
                    "does not hold at a bound or where the data hardly determine "
                    "a parameter ({}): use profile intervals "
                    "(--profile-intervals)",
                    which));
}

// ---- 5. Estimate -----------------------------------------------------------------------------

// A fit from one start: its optimum (or where it stopped), at `delay`.
struct Reached {
  double loglik;
  std::vector<double> z;
  bool converged;
  std::vector<int> delay;
};

// The distinct optima among the fits `reached` at the estimate's delay, best first: fits whose
// objectives lie within kSameOptimum of a better one's reached the same optimum. The best's is the
// estimate `best` (its fit may have gone on from there: a saddle left, the exact Hessian's refit).
std::vector<Optimum> DistinctOptima(const Fitter& f, std::vector<Reached> reached,
                                    const FitResult& best, const std::vector<int>& delay) {
  std::erase_if(reached,
                [&](const Reached& r) { return r.delay != delay || !std::isfinite(r.loglik); });
  std::stable_sort(reached.begin(), reached.end(),
                   [](const Reached& a, const Reached& b) { return a.loglik > b.loglik; });
  std::vector<Optimum> optima;
  for (const Reached& r : reached) {
    if (!optima.empty() && r.loglik >= optima.back().loglik - kSameOptimum) {
      ++optima.back().starts;
      continue;
    }
    optima.push_back({r.loglik, 1, r.converged, f.Theta(r.z)});
  }
  if (optima.empty() || best.loglik >= optima.front().loglik - kSameOptimum) {
    if (optima.empty()) optima.push_back({best.loglik, 1, best.converged, {}});
    optima.front().loglik = std::max(optima.front().loglik, best.loglik);
    optima.front().converged = best.converged;
    optima.front().theta = f.Theta(best.z);
  } else {  // the estimate's fit left the basins the starts reached (a saddle's escape)
    optima.insert(optima.begin(), Optimum{best.loglik, 1, best.converged, f.Theta(best.z)});
  }
  return optima;
}

// One run of Estimate over one state: the likelihood (a copy that watches the cancel flag), the
// fitter, the best fit so far and its delay, the plain start's fit at the runner-up delay, the
// fits from the starts and the delay profile. Run() is the list of stages; each stage ends by
// looking at the cancel flag, which can arrive in any of them.
class EstimateRun {
 public:
  EstimateRun(const filter::Likelihood& shared, const EstimateOptions& options)
      : lik_(shared),
        options_(options),
        spec_(lik_.spec()),
        start_time_(Clock::now()),
        threads_(options.threads > 0 ? options.threads : HardwareThreads()) {
    lik_.set_cancel(options.cancel);
  }

  Result<EstimateSummary> Run() {
    if (Status ready = Prepare(); !ready) return ready.error();
    if (Cancelled()) return CancelledSummary();
    FitPlainStart();  // 1.
    Settle();
    reached_ = {{best_.loglik, best_.z, best_.converged, delay_}};
    if (options_.multistart > 0 && !best_.cancelled) ExtraStarts(options_.multistart, 0);  // 2.
    if (scanning_ && !best_.cancelled) DelayProfile();                                     // 3.
    RefitPlainStart();                                                                     // 4.
    RelaxDiffusion();                                                                      // 5.
    ReleaseRunaways();                                                                     // 6.
    StartsOnBound();                                                                       // 7.
    Polish();                                                                              // 8.
    s_.starts = static_cast<int>(reached_.size());
    if (best_.cancelled || Cancelled()) return CancelledSummary();
    if (!std::isfinite(best_.loglik))
      return NumericalError(
          "the log-likelihood could not be evaluated anywhere the optimiser went");
    Uncertainty u = Uncertainties();  // 9.
    if (Cancelled()) return CancelledSummary();
    return Summarise(std::move(u));  // 10.
  }

 private:
  struct ProfileValue {
    std::vector<int> delay;
    double loglik;
    bool converged;
    bool operator<(const ProfileValue& o) const { return delay < o.delay; }
  };

  bool Cancelled() const { return fitter_ && fitter_->Cancelled(); }

  // fit(i, share) for i in [0, n), side by side on the threads: each fit takes its share of them
  // among those still running (ThreadShare), so the last ones go on with all of them.
  template <class Fit>
  void SideBySide(int n, Fit&& fit) {
    ThreadShare share(threads_, n);
    ParallelFor(n, threads_, [&](int i) {
      fit(i, &share);
      share.Done();
    });
  }

  // What there is to estimate, the start (with the steady-state start, if asked), the summary's
  // header and the delay to start from: the best of the grid at the start values, and the
  // runner-up.
  Status Prepare() {
    const bool any_free = std::any_of(spec_.parameters.begin(), spec_.parameters.end(),
                                      [](const model::Parameter& p) { return !p.fixed; });
    if (!any_free && !spec_.HasDelayScan())
      return InputError(fmt::format(
          "nothing to estimate: every parameter of the model {} is fixed and no delay is scanned; "
          "free a parameter (in the Parameters view, or \"fixed\": false in the model file), or "
          "evaluate the likelihood at these values (greybench-cli loglik)",
          spec_.source.empty() ? spec_.name : spec_.source));
    // The start: the model's values, or those with the steady states' parameters moved to the
    // records' levels.
    std::optional<SteadyStartResult> steady;
    if (options_.steady_start) {
      SteadyStartOptions steady_options;
      steady_options.window_seconds = options_.steady_window;
      auto moved = SteadyStart(lik_, spec_.Values(), steady_options);
      if (!moved) return moved.error();
      steady = std::move(moved).value();
    }
    const std::vector<double> theta_start = steady ? steady->theta : spec_.Values();
    fitter_.emplace(lik_, options_, theta_start);
    s_.model_name = spec_.name;
    for (const auto& series : lik_.series()) s_.datasets.push_back(series->source);
    s_.steady_start = std::move(steady);
    s_.extended = lik_.nonlinear() != nullptr;
    s_.ekf = spec_.ekf;
    s_.exact_scores = lik_.exact_scores() && !options_.score_differences;
    ode_at_start_ = lik_.ode_counts();
    scanning_ = spec_.HasDelayScan();
    auto profile = lik_.Profile(theta_start);
    if (Cancelled()) return Ok{};
    if (!profile) {
      Error e = profile.error();  // the model cannot be evaluated at θ0: say that it is the start
      e.message = "the log-likelihood cannot be evaluated at the start values: " + e.message;
      return e;
    }
    if (profile->best < 0)
      return NumericalError("the log-likelihood cannot be evaluated at the start values: " +
                            profile->candidates.front().message);
    delay_ = profile->candidates[profile->best].delay;
    // The runner-up at the start values: the plain start is fitted there too (FitPlainStart).
    double second_loglik = -HUGE_VAL;
    for (std::size_t c = 0; scanning_ && c < profile->candidates.size(); ++c) {
      const auto& cand = profile->candidates[c];
      if (static_cast<int>(c) == profile->best || !cand.ok) continue;
      if (second_delay_.empty() || cand.loglik > second_loglik)
        second_delay_ = cand.delay, second_loglik = cand.loglik;
    }
    return Ok{};
  }

  // 1. The model's start values at the two best delays at the start values, side by side where
  //    there are threads (a misspecified first delay costs a fit from its optimum to the right
  //    one and a plain start's refit there; the runner-up is often the right one); then θ and the
  //    delay in turn until the delay settles (each delay's fit warm-started from the last).
  void FitPlainStart() {
    z_start_ = fitter_->ZStart();
    std::vector<FitResult> first(second_delay_.empty() ? 1 : 2);
    {
      const std::vector<std::vector<int>> first_delays = {delay_, second_delay_};
      const int jobs = static_cast<int>(first.size());
      SideBySide(jobs, [&](int j, const ThreadShare* share) {
        first[j] = fitter_->FitAlongside(z_start_, first_delays[j], "fitting",
                                         std::max(1, threads_ / jobs), 0, nullptr, share);
      });
    }
    plain_evaluations_ =  // what a fit from a start costs here
        fitter_->evaluations() / static_cast<int>(first.size());
    best_ = std::move(first[0]);
    if (first.size() == 2) {
      runner_up_ = std::move(first[1]);
      if (runner_up_.cancelled || runner_up_.loglik > best_.loglik) {
        std::swap(best_, runner_up_);
        std::swap(delay_, second_delay_);
      }
    }
    delay_of_start_ = delay_;
  }

  // r becomes the estimate. At the estimate's own optimum (within SameLevel: a fit on from its
  // point, or a start that came back to it) the parameters that crept onto their bounds on the
  // way there still did (FitResult::crept).
  void Replace(FitResult r) {
    if (std::isfinite(best_.loglik) && r.loglik <= best_.loglik + SameLevel(best_.loglik))
      AddCrept(best_.crept, &r);
    best_ = std::move(r);
  }

  // θ and the delay in turn until the delay settles (each delay's fit warm-started from the last).
  void Settle() {
    for (int round = 0; scanning_ && !best_.cancelled && !fitter_->Cancelled() && round < 10;
         ++round) {
      auto profile = lik_.Profile(fitter_->Theta(best_.z));
      if (!profile || profile->best < 0) break;
      const auto& next = profile->candidates[profile->best].delay;
      if (next == delay_) break;
      delay_ = next;
      FitResult r = fitter_->Fit(best_.z, delay_, "fitting");
      if (r.cancelled || r.loglik >= best_.loglik) Replace(std::move(r));
    }
  }

  // 2. Extra starts at the estimate's delay; the plain start's fit is one of them, so the result
  //    is never worse than it.
  bool ExtraStarts(int n, int explore) {
    auto starts = StartPoints(*fitter_, n, options_.seed);
    starts.erase(starts.begin());
    if (FitStarts(starts, explore, "fitting") < 0) return false;
    Settle();
    return true;
  }

  // Fits from `starts` at the estimate's delay, each recorded in reached_; the best becomes the
  // estimate if it is higher. `explore` > 0: each start is fitted for that many iterations only
  // (side by side where there are threads), or until it crawls at the estimate's level (back in
  // its basin or on its valley: it counts as reaching it, where it stopped); those that have not
  // converged by then but are above the estimate already (they left its basin upwards) are
  // fitted on, within twice the evaluations the plain start's fit took; the others count as not
  // reaching an optimum. (Building 3 from the neutral start: 1218 iterations in all instead of
  // 1747, when the released starts crawled along the estimate's valley for 200 each.) (Fitting
  // on the best two of them instead, as before, cost building 3 two fits of thousands of
  // iterations from starts a thousand log-L units below the estimate, and never found more.)
  // Returns the index of the start that became the estimate (-1: none).
  int FitStarts(const std::vector<std::vector<double>>& starts, int explore,
                const std::string& stage) {
    const int n = static_cast<int>(starts.size());
    std::vector<FitResult> fits(n);
    // Within twice the evaluations the plain start's fit took (side by side where there are
    // threads).
    const int budget = std::max(kMinExtraEvaluations, 2 * plain_evaluations_);
    if (explore > 0) {
      SideBySide(n, [&](int i, const ThreadShare* share) {
        fits[i] = fitter_->ExploreAlongside(starts[i], delay_, explore, std::max(1, threads_ / n),
                                            nullptr, best_.loglik, share);
      });
      std::vector<int> order;
      for (int i = 0; i < n; ++i) {
        if (fits[i].cancelled) {
          best_.cancelled = true;
          return -1;
        }
        if (std::isfinite(fits[i].loglik) && !fits[i].converged) order.push_back(i);
      }
      std::erase_if(order, [&](int i) { return !(fits[i].loglik > best_.loglik + kSameOptimum); });
      // Stopped early: not an optimum, unless crawling at the estimate's level (back in its
      // basin, or on its valley, which Polish finishes).
      for (int i = 0; i < n; ++i)
        if (!fits[i].converged && std::find(order.begin(), order.end(), i) == order.end() &&
            !fits[i].crawling)
          fits[i].loglik = -HUGE_VAL;
      const int lanes = static_cast<int>(order.size());
      SideBySide(lanes, [&](int c, const ThreadShare* share) {
        const int i = order[c];
        const Eigen::MatrixXd model = fits[i].model;
        fits[i] = fitter_->FitAlongside(fits[i].z, delay_, stage, std::max(1, threads_ / lanes),
                                        budget, model.size() > 0 ? &model : nullptr, share);
      });
    } else {
      for (int i = 0; i < n; ++i) fits[i] = fitter_->Fit(starts[i], delay_, stage);
    }
    int better = -1;
    for (int i = 0; i < n; ++i) {
      if (fits[i].cancelled) {
        best_.cancelled = true;
        return -1;
      }
      reached_.push_back({fits[i].loglik, fits[i].z, fits[i].converged, delay_});
      if (fits[i].loglik > (better < 0 ? best_.loglik : fits[better].loglik)) better = i;
    }
    if (better >= 0) Replace(std::move(fits[better]));
    landed_in_best_ = std::all_of(fits.begin(), fits.end(), [&](const FitResult& r) {
      return r.loglik >= best_.loglik - SameLevel(best_.loglik);
    });
    return better;
  }

  // 3. The profile: θ re-optimised at every other delay candidate, to convergence, walking
  //    outward from the estimate so that each fit starts from the optimum of its nearest fitted
  //    neighbour. A better delay found on the way becomes the estimate.
  void DelayProfile() {
    const std::vector<int> delay_best = delay_;
    auto distance = [](const std::vector<int>& a, const std::vector<int>& b) {
      int d = 0;
      for (std::size_t i = 0; i < a.size(); ++i) d += std::abs(a[i] - b[i]);
      return d;
    };
    std::vector<std::vector<int>> grid = lik_.DelayGrid();
    std::stable_sort(grid.begin(), grid.end(), [&](const auto& a, const auto& b) {
      return distance(a, delay_best) < distance(b, delay_best);
    });
    // Each fit starts from the nearest fitted delay: its estimate, its curvature model and the
    // way it took its gradients (the far delays' covariances settle late:
    // FitResult::linear_gradient).
    struct Fitted {
      std::vector<int> delay;
      std::vector<double> z;
      Eigen::MatrixXd model;
      filter::LinearGradient gradient;
    };
    std::vector<Fitted> fitted = {{delay_best, best_.z, best_.model, best_.linear_gradient}};
    profile_points_.push_back({delay_best, best_.loglik, best_.converged});
    // The plain start's fit at the runner-up delay is that delay's profile point.
    const bool have_runner_up = std::isfinite(runner_up_.loglik) && second_delay_ != delay_best &&
                                options_.full_delay_profile;
    if (have_runner_up) {
      fitted.push_back({second_delay_, runner_up_.z, runner_up_.model, runner_up_.linear_gradient});
      profile_points_.push_back({second_delay_, runner_up_.loglik, runner_up_.converged});
    }
    auto model_of = [](const Fitted* f) { return f->model.size() > 0 ? &f->model : nullptr; };
    auto nearest_of = [&](const std::vector<int>& candidate, const std::vector<Fitted>& a,
                          const std::vector<Fitted>& b) {
      const Fitted* start = &a.front();
      int nearest = INT_MAX;
      for (const auto* list : {&a, &b})
        for (const Fitted& f : *list)
          if (distance(f.delay, candidate) < nearest)
            nearest = distance(f.delay, candidate), start = &f;
      return start;
    };
    auto record = [&](const std::vector<int>& candidate, const FitResult& r) {
      if (r.cancelled || fitter_->Cancelled()) {
        best_.cancelled = true;
        best_.message = "cancelled";
        return;
      }
      if (std::isfinite(r.loglik)) fitted.push_back({candidate, r.z, r.model, r.linear_gradient});
      profile_points_.push_back({candidate, r.loglik, r.converged});
      if (r.loglik > best_.loglik) {
        best_ = r;
        delay_ = candidate;
      }
    };
    int scanned_outputs = 0;
    for (const auto& d : spec_.output_delay) scanned_outputs += d.IsScan() ? 1 : 0;
    std::size_t next = 0;
    if (options_.full_delay_profile && scanned_outputs == 1) {
      // One scanned delay: two walkers, down and up from the estimate, side by side where there
      // are threads. Each fit starts from the nearest of the fits made before the walk and the
      // walker's own (its predecessor), so the results do not depend on the number of threads.
      std::vector<std::vector<int>> sides[2];
      for (const auto& candidate : grid) {
        if (candidate == delay_best || (have_runner_up && candidate == second_delay_)) continue;
        sides[candidate < delay_best ? 0 : 1].push_back(candidate);
      }
      std::vector<FitResult> results[2];
      const int lanes = sides[0].empty() || sides[1].empty() ? 1 : 2;
      // The walker of the longer side goes on with every thread once the other is done.
      SideBySide(2, [&](int side, const ThreadShare* share) {
        std::vector<Fitted> own;
        for (const auto& candidate : sides[side]) {
          if (fitter_->Cancelled()) break;
          const Fitted* start = nearest_of(candidate, fitted, own);
          FitResult r = fitter_->FitAlongside(start->z, candidate, "delay profile",
                                              std::max(1, threads_ / lanes), 0, model_of(start),
                                              share, start->gradient);
          if (std::isfinite(r.loglik)) own.push_back({candidate, r.z, r.model, r.linear_gradient});
          results[side].push_back(std::move(r));
        }
      });
      for (int side = 0; side < 2; ++side)
        for (std::size_t c = 0; c < results[side].size() && !best_.cancelled; ++c)
          record(sides[side][c], results[side][c]);
      if (fitter_->Cancelled()) best_.cancelled = true;
      next = grid.size();  // done
    }
    // Otherwise the candidates in waves of equal distance from the estimate; each fit starts
    // from the nearest fit of an earlier wave, so the fits of a wave are independent and run in
    // parallel (each on its share of the threads). The results do not depend on the number of
    // threads.
    while (next < grid.size() && !best_.cancelled) {
      std::size_t end = next;
      while (end < grid.size() &&
             distance(grid[end], delay_best) == distance(grid[next], delay_best))
        ++end;
      std::vector<std::vector<int>> wave;
      for (std::size_t c = next; c < end; ++c)
        if (grid[c] != delay_best && !(have_runner_up && grid[c] == second_delay_))
          wave.push_back(grid[c]);
      next = end;
      if (wave.empty()) continue;
      const int n = static_cast<int>(wave.size());
      if (!options_.full_delay_profile) {
        for (const auto& candidate : wave)
          profile_points_.push_back({candidate, fitter_->Objective(best_.z, candidate), true});
        continue;
      }
      std::vector<const Fitted*> starts(n);
      for (int w = 0; w < n; ++w) starts[w] = nearest_of(wave[w], fitted, {});
      std::vector<FitResult> results(n);
      SideBySide(n, [&](int w, const ThreadShare* share) {
        results[w] =
            fitter_->FitAlongside(starts[w]->z, wave[w], "delay profile", std::max(1, threads_ / n),
                                  0, model_of(starts[w]), share, starts[w]->gradient);
      });
      for (int w = 0; w < n && !best_.cancelled; ++w) record(wave[w], results[w]);
    }
  }

  // 4. A first delay far from the right one can lead the plain start's fit to a poor optimum
  //    (a saddle, a parameter pinned at a bound) from which the warm-started fits do not recover:
  //    fit the plain start again at the chosen delay.
  void RefitPlainStart() {
    if (scanning_ && !best_.cancelled && !fitter_->Cancelled() && delay_ != delay_of_start_) {
      FitResult r = fitter_->Fit(z_start_, delay_, "fitting");
      delay_of_start_ = delay_;
      if (r.cancelled)
        best_.cancelled = true;
      else if (r.loglik > best_.loglik + kSameOptimum)
        best_ = r;
    }
  }

  // 5. Without multistart, where a parameter of the diffusion alone ended on a bound it did not
  //    start on: the grey-box order of work. The model is fitted again from its start with its
  //    diffusion relaxed (σσ' x kRelaxFactor, the diffusion's parameters held at their starts),
  //    where the filter follows the data closely and the drift's parameters are fitted on short
  //    horizons, and from that fit with the diffusion back at its start as a released start is
  //    (FitStarts). A fit whose variances the path pinned at zero often sits in a poorer basin
  //    with its states' roles swapped (bench/robustness.py's house models: walls and floor, 59 to
  //    227 log-L units below; the relaxed path reaches the better basin in each). Kept where
  //    higher.
  void RelaxDiffusion() {
    if (options_.multistart != 0 || options_.starts_on_bound == 0 || best_.cancelled ||
        Cancelled() || !std::isfinite(best_.loglik))
      return;
    const std::vector<int> held = DiffusionOnly(spec_);
    bool pinned = false;
    for (int i = 0; i < fitter_->k(); ++i)
      pinned = pinned || (std::find(held.begin(), held.end(), fitter_->free()[i]) != held.end() &&
                          AtBound(*fitter_, best_.z, i) && !AtBound(*fitter_, z_start_, i));
    if (!pinned) return;
    auto relaxed = RelaxedLikelihood(lik_, kRelaxFactor);
    if (!relaxed) return;  // the model cannot be built so: nothing to try
    relaxed->set_cancel(options_.cancel);
    const EstimateOptions sub =
        fitter_->SubOptions(threads_, std::max(kMinExtraEvaluations, plain_evaluations_));
    Fitter fit(*relaxed, sub, fitter_->Theta(z_start_), held);
    const FitResult r = fit.Fit(fit.ZStart(), delay_, "relaxed diffusion");
    fitter_->AddWork(fit);
    if (r.cancelled) {
      best_.cancelled = true;
      return;
    }
    if (!std::isfinite(r.loglik)) return;
    // The drift's parameters from the relaxed fit, the diffusion's at their starts.
    const std::vector<double> theta = fit.Theta(r.z);
    std::vector<double> z(fitter_->k());
    for (int i = 0; i < fitter_->k(); ++i)
      z[i] = std::clamp(fitter_->ZOf(i, theta[fitter_->free()[i]]), fitter_->lower(i),
                        fitter_->upper(i));
    ++s_.relaxed_starts;
    const int explore = std::clamp(plain_evaluations_, 1, kReleaseIterations);
    if (FitStarts({z}, explore, "relaxed diffusion") >= 0) {
      s_.relaxed_better = true;
      Settle();
    }
  }

  // 6. Without multistart: the parameters that ran off. A parameter the fit took onto a bound it
  //    did not start on, or one the data do not determine at the estimate (no standard error, or
  //    one wider than its range), is often not where the data put it but where the path left it
  //    (a log-variance that ran towards -inf while the others were still far off, a capacity
  //    pinned at its bound). Each is put back to its start value with the others at the
  //    estimate, and all of them together, and fitted from there; a better optimum becomes the
  //    estimate, and its runaways are released in turn (at most kReleaseRounds times).
  void ReleaseRunaways() {
    if (options_.multistart != 0 || options_.starts_on_bound == 0) return;
    for (int round = 0;; ++round) {
      if (best_.cancelled || fitter_->Cancelled() || !std::isfinite(best_.loglik)) return;
      runaways_ = Runaways();  // at the estimate as it now is
      if (runaways_.empty() || round == kReleaseRounds) return;
      std::vector<std::vector<double>> starts;
      for (int i : runaways_) {
        starts.push_back(best_.z);
        starts.back()[i] = z_start_[i];
      }
      if (runaways_.size() > 1) {
        starts.push_back(best_.z);
        for (int i : runaways_) starts.back()[i] = z_start_[i];
      }
      const double before = best_.loglik;
      s_.released_starts += static_cast<int>(starts.size());
      // From near an optimum: not more iterations than the plain start's fit took evaluations.
      const int explore = std::clamp(plain_evaluations_, 1, kReleaseIterations);
      if (FitStarts(starts, explore, "releasing") >= 0) Settle();
      if (best_.loglik <= before + kSameOptimum) {  // the same optimum (a little higher, or not)
        released_into_best_ = landed_in_best_;
        return;
      }
      ++s_.releases;
      // Another round only from another basin: within kNewBasin, the same runaways released from
      // nearly the same point lead where they led.
      if (best_.loglik <= before + kNewBasin) {
        runaways_ = Runaways();
        return;
      }
    }
  }

  // The uncertainty at the best fit, computed once for each point and delay it is asked at
  // (Runaways looks at it, and Uncertainties starts from it: k gradients each time otherwise).
  Uncertainty AtBest() {
    if (!at_best_ || at_best_z_ != best_.z || at_best_delay_ != delay_) {
      Uncertainty u = ComputeUncertainty(*fitter_, best_.z, best_.loglik, delay_, spec_, threads_);
      if (fitter_->Cancelled()) return u;  // cut short: not kept
      at_best_ = std::move(u);
      at_best_z_ = best_.z;
      at_best_delay_ = delay_;
    }
    return *at_best_;
  }

  // The free parameters that ran off at the best fit (see ReleaseRunaways), in index order.
  std::vector<int> Runaways() {
    const Uncertainty u = AtBest();
    std::vector<int> ran;
    for (int i = 0; i < fitter_->k(); ++i) {
      const double z = best_.z[i], z0 = z_start_[i];
      if (std::abs(z - z0) <= kAtBoundTol * std::max({1.0, std::abs(z), std::abs(z0)})) continue;
      const double range = std::isfinite(fitter_->upper(i) - fitter_->lower(i))
                               ? fitter_->upper(i) - fitter_->lower(i)
                               : std::max({1.0, std::abs(z0), std::abs(z - z0)});
      const double se =
          u.std_error[i] ? *u.std_error[i] / fitter_->Slope(i, z) : HUGE_VAL;  // scaled units
      const bool onto_bound =
          u.at_bound[i] && !AtBound(*fitter_, z_start_, i) && !CreptOntoBound(*fitter_, best_, i);
      // Far out on a scale without bounds: towards ±inf.
      const bool far = !std::isfinite(fitter_->lower(i)) && !std::isfinite(fitter_->upper(i)) &&
                       std::abs(z - z0) > kRunaway * std::max(1.0, std::abs(z0));
      if (onto_bound || far || (!u.at_bound[i] && !(se < range))) ran.push_back(i);
    }
    return ran;
  }

  // 7. Without multistart, where the estimate has a parameter on a bound: starts_on_bound extra
  //    starts at the chosen delay (checked only now, so that a bound reached at a misspecified
  //    first delay does not cost them). Where parameters ran off and were released
  //    (ReleaseRunaways), only if one of them has no bound on a side and the released fits did
  //    not all come back to the estimate's optimum: spread over a parameter's start range (a
  //    factor 10 around the start) the starts find what releasing it did not; spread over wide
  //    bounds, 100 iterations from them end far below (building 3: hundreds to thousands of log L
  //    below the estimate, never near it), and a bound parameter's release is its own extra start.
  void StartsOnBound() {
    if (options_.multistart != 0 || options_.starts_on_bound == 0 || best_.cancelled ||
        fitter_->Cancelled() || !std::isfinite(best_.loglik))
      return;
    bool wanted = OnABound(*fitter_, best_);
    if (!runaways_.empty())
      wanted = !released_into_best_ && std::any_of(runaways_.begin(), runaways_.end(), [&](int i) {
        return !std::isfinite(fitter_->lower(i)) || !std::isfinite(fitter_->upper(i));
      });
    if (wanted) {
      s_.starts_for_bound = true;
      // A better optimum from them may have run off in turn.
      if (ExtraStarts(options_.starts_on_bound, kExploreIterations)) ReleaseRunaways();
    }
  }

  // 8. Where the exact Hessian at the estimate still promises more than kPolishDecrement, or is
  //    singular in a direction off the bounds, the fit may have stopped crawling along a curved
  //    valley, where the quadratic model understates what is left (building 3: promised 7.5e-5
  //    where 0.0014 was left, along a ridge of Ci, Cs and Ris that ends on Cs's bound; the
  //    straight line between its two ends dips 27 log-L units; elsewhere on it, Cs and Ris not
  //    separated at all, 0.0077 below the optimum). It is fitted on from there on the log working
  //    scale of the positive parameters (Fitter::FitOnLogScale), where such a valley of
  //    capacities and resistances is straighter: building 3's took 106 iterations there and 249
  //    on the fitter's own scale. Kept where it is higher; within the evaluations a fit from the
  //    start took (a higher point where that ran out is as converged as the estimate was).
  void Polish() {
    if (best_.cancelled || Cancelled() || !std::isfinite(best_.loglik) ||
        !fitter_->AnyOnLogScale() ||
        (options_.algorithm != Algorithm::kAuto && options_.algorithm != Algorithm::kTrustRegion))
      return;
    const Uncertainty u = AtBest();
    // A free parameter off its bounds without a standard error: a flat direction.
    bool flat = false;
    for (int i = 0; i < fitter_->k(); ++i) flat = flat || (!u.at_bound[i] && !u.std_error[i]);
    if (Cancelled() || u.uphill || !(flat || u.newton_decrement > kPolishDecrement)) return;
    FitResult r = fitter_->FitOnLogScale(best_.z, delay_, "fitting",
                                         std::max(kMinExtraEvaluations, plain_evaluations_));
    if (r.cancelled) {
      best_.cancelled = true;
      return;
    }
    if (!(r.loglik > best_.loglik)) return;
    if (!r.converged) {
      r.converged = best_.converged;
      r.message = best_.message;
    }
    // The starts that stopped where the estimate did reached the optimum it went on to.
    const double same = SameLevel(best_.loglik);
    for (Reached& reached : reached_)
      if (reached.delay == delay_ && reached.loglik >= best_.loglik - same)
        reached.loglik = r.loglik, reached.z = r.z, reached.converged = r.converged;
    Replace(std::move(r));
  }

  // 9. Uncertainty at the estimate. Where the Hessian shows negative curvature the fit stopped at
  //    a saddle: step along that direction and fit again (at most kMaxSaddleEscapes times).
  Uncertainty Uncertainties() {
    fitter_->Report("standard errors", best_.z, best_.loglik, delay_);
    Uncertainty u = AtBest();
    // Where the exact Hessian promises more than the curvature model the fit stopped on did (a flat
    // valley, where BHHH's information and its corrections overstate the curvature along it), fit
    // again starting from the exact Hessian.
    for (int again = 0; again < kMaxSaddleEscapes && !fitter_->Cancelled(); ++again) {
      std::optional<FitResult> higher;
      if (u.uphill) {
        higher = EscapeSaddle(*fitter_, best_, *u.uphill, delay_);
      } else if (u.newton_decrement > kNegligibleImprovement &&
                 (options_.algorithm == Algorithm::kAuto ||
                  options_.algorithm == Algorithm::kTrustRegion)) {
        FitResult r =
            fitter_->Fit(best_.z, delay_, "fitting", kMaxBhhhIterations, &u.hessian_scaled);
        if (r.cancelled || r.loglik > best_.loglik) higher = std::move(r);
      }
      if (!higher || higher->cancelled) break;
      Replace(std::move(*higher));
      fitter_->Report("standard errors", best_.z, best_.loglik, delay_);
      u = AtBest();
    }
    // The profile point of the estimate's delay: the final fit's value.
    if (scanning_) {
      std::erase_if(profile_points_, [&](const ProfileValue& p) { return p.delay == delay_; });
      profile_points_.push_back({delay_, best_.loglik, best_.converged});
      std::sort(profile_points_.begin(), profile_points_.end());
    }
    return u;
  }

  // 10. The summary at the estimate.
  Result<EstimateSummary> Summarise(Uncertainty u) {
    s_.converged = best_.converged;
    s_.message = best_.message;
    s_.theta = fitter_->Theta(best_.z);
    for (int i : best_.crept) s_.log_scale.push_back(spec_.parameters[fitter_->free()[i]].name);
    s_.optima = DistinctOptima(*fitter_, reached_, best_, delay_);
    s_.starts_at_best = s_.optima.empty() ? 1 : s_.optima.front().starts;
    long n_obs = 0;
    s_.loglik = fitter_->LogLik(best_.z, delay_, &n_obs);
    s_.n_obs = n_obs;
    if (fitter_->HasPriors()) s_.log_posterior = best_.loglik;
    int scanned = 0;
    for (const auto& d : spec_.output_delay) scanned += d.IsScan() ? 1 : 0;
    s_.n_free = fitter_->k() + scanned;
    s_.aic = -2 * s_.loglik + 2 * s_.n_free;
    s_.bic = -2 * s_.loglik + s_.n_free * std::log(static_cast<double>(s_.n_obs));
    if (!std::isfinite(s_.loglik))
      return NumericalError("the log-likelihood cannot be evaluated at the estimate");
    for (std::size_t i = 0; i < s_.theta.size(); ++i)
      if (!std::isfinite(s_.theta[i]))
        return NumericalError(
            fmt::format("the estimate of {} is not a finite number ({}): the fit "
                        "ran off; give the parameter bounds or another start",
                        spec_.parameters[i].name, s_.theta[i]));
    if (u.uphill) {
      std::string along;
      for (int i = 0; i < fitter_->k(); ++i)
        if (std::abs((*u.uphill)(i)) > 0.2)
          along += (along.empty() ? "" : ", ") + spec_.parameters[fitter_->free()[i]].name;
      s_.converged = false;
      s_.message = "the fit ended at a saddle point of the log-likelihood";
      u.warnings.insert(
          u.warnings.begin(),
          fmt::format("the estimate is a saddle point, not a maximum: the log-likelihood "
                      "curves upward along a combination of {}. Try other start values "
                      "or --multistart 8",
                      along));
    }
    s_.warnings = u.warnings;
    const double dof = static_cast<double>(std::max<long>(1, s_.n_obs - s_.n_free));
    const boost::math::students_t t_dist(dof);
    std::vector<int> free_pos(spec_.parameters.size(), -1);
    for (int i = 0; i < fitter_->k(); ++i) free_pos[fitter_->free()[i]] = i;
    for (std::size_t i = 0; i < spec_.parameters.size(); ++i) {
      const auto& p = spec_.parameters[i];
      ParameterEstimate e = EstimateOf(p, s_.theta[i]);
      const int fi = free_pos[i];
      if (fi >= 0) {
        e.at_bound = u.at_bound[fi];
        if (e.at_bound)
          s_.warnings.push_back(
              fmt::format("{} is at its {} bound ({}): its standard error is not "
                          "reported",
                          p.name,
                          std::abs(e.estimate - p.lower.value_or(NAN)) <
                                  std::abs(e.estimate - p.upper.value_or(NAN))
                              ? "lower"
                              : "upper",
                          e.estimate));
        if (u.std_error[fi]) {
          e.std_error = *u.std_error[fi];
          e.t_value = e.estimate / *e.std_error;
          e.p_value = 2 * boost::math::cdf(boost::math::complement(t_dist, std::abs(*e.t_value)));
        }
      }
      s_.parameters.push_back(std::move(e));
    }
    const int n_se = static_cast<int>(u.with_se.size());
    s_.covariance = u.covariance;
    s_.correlation = Eigen::MatrixXd::Identity(n_se, n_se);
    for (int a = 0; a < n_se; ++a) {
      s_.correlation_names.push_back(spec_.parameters[fitter_->free()[u.with_se[a]]].name);
      for (int b = 0; b < n_se; ++b)
        if (a != b)
          s_.correlation(a, b) =
              u.covariance(a, b) / std::sqrt(u.covariance(a, a) * u.covariance(b, b));
    }
    for (int a = 0; a < n_se; ++a)
      for (int b = a + 1; b < n_se; ++b)
        if (std::abs(s_.correlation(a, b)) > kHighCorrelation)
          s_.warnings.push_back(
              fmt::format("{} and {} are correlated (r = {:.3f}): the data barely "
                          "separate them",
                          s_.correlation_names[a], s_.correlation_names[b], s_.correlation(a, b)));

    for (std::size_t o = 0; o < spec_.outputs.size(); ++o) {
      DelayEstimate d;
      d.output = spec_.outputs[o];
      d.estimate = delay_[o];
      d.scanned = spec_.output_delay[o].IsScan();
      if (d.scanned) {
        // The profile along this output: other outputs at their estimates.
        for (const auto& point : profile_points_) {
          const std::vector<int>& candidate = point.delay;
          bool others_at_estimate = true;
          for (std::size_t q = 0; q < delay_.size(); ++q)
            if (q != o && candidate[q] != delay_[q]) others_at_estimate = false;
          if (!others_at_estimate) continue;
          DelayProfilePoint pt;
          pt.delay = candidate[o];
          pt.converged = point.converged || candidate == delay_;
          if (std::isfinite(point.loglik))
            pt.loglik = candidate == delay_ ? s_.loglik : point.loglik;
          d.profile.push_back(pt);
        }
      }
      s_.delays.push_back(std::move(d));
    }
    if (!s_.converged)
      s_.warnings.insert(s_.warnings.begin(), "the optimiser did not converge: " + s_.message);
    for (std::size_t o = 0; o < s_.delays.size(); ++o) {
      const model::DelaySpec& range = spec_.output_delay[o];
      if (range.IsScan() && (delay_[o] == range.min || delay_[o] == range.max) && range.min > 0)
        s_.warnings.push_back(
            fmt::format("the delay of {} ({} samples) is at the end of its scanned "
                        "range [{}, {}]: widen the range",
                        spec_.outputs[o], delay_[o], range.min, range.max));
      else if (range.IsScan() && delay_[o] == range.max)
        s_.warnings.push_back(
            fmt::format("the delay of {} ({} samples) is at the top of its scanned "
                        "range: widen the range",
                        spec_.outputs[o], delay_[o]));
    }
    if (options_.profile_intervals) {
      fitter_->Report("profile intervals", best_.z, best_.loglik, delay_);
      auto intervals = ProfileIntervals(lik_, s_, {}, options_.profile_level, options_);
      if (fitter_->Cancelled()) return CancelledSummary();
      if (!intervals) return intervals.error();
      std::size_t w = 0;
      for (auto& e : s_.parameters) {
        if (e.fixed) continue;
        e.profile = std::move((*intervals)[w++]);
        AddProfileWarnings(e, &s_.warnings);
      }
    } else {
      RecommendProfiles(s_.parameters, &s_.warnings);
    }
    Finish();
    return s_;
  }

  // The counts and times of the whole run.
  void Finish() {
    s_.evaluations = fitter_ ? fitter_->evaluations() : 0;
    s_.iterations = fitter_ ? fitter_->iterations() : 0;
    s_.elapsed_s = std::chrono::duration<double>(Clock::now() - start_time_).count();
    const ode::OdeCounts ode = lik_.ode_counts();
    s_.ode.intervals = ode.intervals - ode_at_start_.intervals;
    s_.ode.stiff_intervals = ode.stiff_intervals - ode_at_start_.stiff_intervals;
    s_.ode.steps = ode.steps - ode_at_start_.steps;
    s_.ode.rejected = ode.rejected - ode_at_start_.rejected;
    s_.ode.rhs = ode.rhs - ode_at_start_.rhs;
  }

  EstimateSummary CancelledSummary() {
    s_.cancelled = true;
    s_.converged = false;
    s_.message = "cancelled";
    Finish();
    return s_;
  }

  filter::Likelihood lik_;
  const EstimateOptions& options_;
  const model::ModelSpec& spec_;
  const Clock::time_point start_time_;
  const int threads_;
  std::optional<Fitter> fitter_;  // from Prepare on
  ode::OdeCounts ode_at_start_;
  bool scanning_ = false;  // an output's delay is scanned
  EstimateSummary s_;
  std::vector<int> delay_;           // the delay of the best fit
  std::vector<int> second_delay_;    // the runner-up at the start values (empty: none)
  std::vector<int> delay_of_start_;  // the delay the plain start was last fitted at
  std::vector<double> z_start_;
  int plain_evaluations_ = 0;  // what a fit from a start costs here
  FitResult best_;
  FitResult runner_up_;           // the plain start's fit at the other delay, if any
  std::vector<Reached> reached_;  // the fits from the starts (the plain start's first)
  std::vector<int> runaways_;     // the parameters that ran off at the estimate (ReleaseRunaways)
  bool landed_in_best_ = false;   // FitStarts' last fits all ended at the estimate's optimum
  bool released_into_best_ = false;     // so did every fit of the released runaways' last round
  std::optional<Uncertainty> at_best_;  // AtBest()'s, at at_best_z_ and at_best_delay_
  std::vector<double> at_best_z_;
  std::vector<int> at_best_delay_;
  std::vector<ProfileValue> profile_points_;
};

}  // namespace

Result<EstimateSummary> Estimate(const filter::Likelihood& likelihood,
                                 const EstimateOptions& options) {
  std::string why;
  if (!options.IsValid(&why)) return InputError("invalid estimation options: " + why);
  // A nonlinear model's filter runs on native code where it can be built: the same values bit
  // for bit, some 2-3 times faster (docs/benchmarks.md, issue 37); the interpreter otherwise.
  std::optional<filter::Likelihood> native;
  std::string native_note;
  if (likelihood.nonlinear() && !likelihood.native()) {
    if (!expr::NativeCode::Enabled()) {
      native_note = "native code turned off by GREYBENCH_NATIVE";
    } else if (auto built = likelihood.WithNativeCode()) {
      native = std::move(*built);
    } else {
      native_note = built.error().message;
    }
  }
  EstimateRun run(native ? *native : likelihood, options);
  Result<EstimateSummary> summary = run.Run();
  if (summary) {
    summary->native = native.has_value() || likelihood.native();
    summary->native_note = std::move(native_note);
  }
  return summary;
}

Result<EstimateSummary> StoppedSummary(const filter::Likelihood& likelihood,
                                       EstimateSummary cancelled, const Progress& best) {
  const model::ModelSpec& spec = likelihood.spec();
  if (best.theta.size() != spec.parameters.size())
    return InputError("the fit was stopped before it reached a point of the model's parameters");
  std::vector<int> delay = best.delay;
  if (delay.empty())
    for (const model::DelaySpec& d : spec.output_delay) delay.push_back(d.min);
  auto at = likelihood.Evaluate(best.theta, delay);
  if (!at) return at.error();
  if (!std::isfinite(at->loglik))
    return NumericalError("the log-likelihood cannot be evaluated at the best point so far");
  EstimateSummary& s = cancelled;
  s.cancelled = true;
  s.converged = false;
  s.message = fmt::format("stopped by the user after {} iterations", s.iterations);
  s.theta = best.theta;
  s.loglik = at->loglik;
  s.n_obs = at->n_obs;
  s.n_free = 0;
  for (const model::Parameter& p : spec.parameters) s.n_free += p.fixed ? 0 : 1;
  for (const model::DelaySpec& d : spec.output_delay) s.n_free += d.IsScan() ? 1 : 0;
  s.aic = -2 * s.loglik + 2 * s.n_free;
  s.bic = -2 * s.loglik + s.n_free * std::log(static_cast<double>(std::max<long>(1, s.n_obs)));
  s.parameters.clear();
  for (std::size_t i = 0; i < spec.parameters.size(); ++i)
    s.parameters.push_back(EstimateOf(spec.parameters[i], best.theta[i]));
  s.delays.clear();
  for (std::size_t o = 0; o < spec.outputs.size(); ++o)
    s.delays.push_back(
        {spec.outputs[o], o < delay.size() ? delay[o] : 0, spec.output_delay[o].IsScan(), {}});
  s.optima = {Optimum{s.loglik, 1, false, s.theta}};
  s.starts_at_best = 1;
  s.correlation_names.clear();
  s.correlation.resize(0, 0);
  s.covariance.resize(0, 0);
  s.warnings = {
      fmt::format("the fit was stopped by the user after {} iterations ({}): these are "
                  "the best values it had reached, not an optimum, so no standard errors "
                  "are given; run the estimation again from them to finish it",
                  s.iterations, best.stage.empty() ? "fitting" : best.stage)};
  return s;
}

// ---- 6. likelihood-ratio test ----------------------------------------------------------------

Result<LikelihoodRatioTest> CompareNested(double loglik_restricted, int n_free_restricted,
                                          double loglik_full, int n_free_full) {
  if (n_free_full <= n_free_restricted)
    return InputError(
        fmt::format("the larger model must have more free parameters ({} vs {}): "
                    "give the restricted model first",
                    n_free_full, n_free_restricted));
  LikelihoodRatioTest t;
  t.statistic = 2 * (loglik_full - loglik_restricted);
  t.df = n_free_full - n_free_restricted;
  const boost::math::chi_squared chi2(t.df);
  t.p_value = t.statistic <= 0 ? 1.0 : boost::math::cdf(boost::math::complement(chi2, t.statistic));
  return t;
}

}  // namespace gb::estimate
