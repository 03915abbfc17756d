// Sections: 1. options  2. the fitter (scaled free parameters, objective, parallel gradient,
//           NLopt)  3. start points  4. Hessian and uncertainties  5. Estimate (with delays)
//           6. likelihood-ratio test
// The report and JSON forms of the summary are in summary_format.cpp.
#include "core/estimate/estimate.h"

#include <algorithm>
#include <chrono>
#include <climits>
#include <cmath>
#include <limits>
#include <map>
#include <mutex>
#include <random>
#include <tuple>

#include <Eigen/Dense>
#include <boost/math/distributions/chi_squared.hpp>
#include <boost/math/distributions/students_t.hpp>
#include <fmt/format.h>
#include <nlopt.hpp>

#include "core/util/parallel.h"

namespace gb::estimate {

// ---- 1. options ------------------------------------------------------------------------------

bool EstimateOptions::IsValid(std::string* why) const {
  auto fail = [&](const char* m) {
    if (why) *why = m;
    return false;
  };
  if (!(ftol_rel >= 0) || !(xtol_rel >= 0)) return fail("tolerances must be >= 0");
  if (ftol_rel == 0 && xtol_rel == 0 && max_evaluations <= 0)
    return fail("no stopping rule: set a tolerance or max_evaluations");
  if (max_evaluations < 0) return fail("max_evaluations must be >= 0");
  if (multistart < 0) return fail("multistart must be >= 0");
  if (threads < 0) return fail("threads must be >= 0 (0 = all cores)");
  return true;
}

namespace {

constexpr double kFailedObjective = 1e300;   // -log L reported to NLopt where log L fails
                                             // before any point could be evaluated
constexpr double kGradientStep = 1e-5;       // ≈ eps^(1/3): central differences in scaled units
constexpr int kMaxBhhhIterations = 500;
constexpr int kProfileIterations = 10;       // BHHH iterations for a fit at a non-best delay
constexpr double kArmijo = 1e-4;             // sufficient increase along the BHHH direction
constexpr int kMaxHalvings = 40;
constexpr double kFirstDamping = 1e-10;      // Levenberg damping of a singular BHHH information,
constexpr int kDampingSteps = 8;             // then x100 per step up to 1e4
// An expected improvement of log L below this (in log-likelihood units, far below the 0.5 that
// one standard error is worth) counts as converged when rounding stops further progress.
constexpr double kNegligibleImprovement = 1e-4;
constexpr double kHessianStep = 1e-4;        // ≈ eps^(1/4): second differences, relative
constexpr double kAtBoundTol = 1e-7;         // relative distance to a bound that counts as on it
constexpr double kUndeterminedEig = 1e-9;    // eigenvalue of the scaled Hessian below: undetermined
constexpr double kHighCorrelation = 0.99;

using Clock = std::chrono::steady_clock;

// ---- 2. the fitter ---------------------------------------------------------------------------

struct FitResult {
  std::vector<double> z;
  double loglik = -std::numeric_limits<double>::infinity();
  bool converged = false;
  bool cancelled = false;
  std::string message;
};

class Fitter {
 public:
  Fitter(const filter::Likelihood& lik, const EstimateOptions& options)
      : lik_(lik), options_(options) {
    const auto& spec = lik.model().spec();
    theta0_ = spec.Values();
    for (std::size_t i = 0; i < spec.parameters.size(); ++i) {
      const auto& p = spec.parameters[i];
      if (p.fixed) continue;
      free_.push_back(static_cast<int>(i));
      const double s = p.value != 0 ? std::abs(p.value)
                       : (p.lower && p.upper) ? (*p.upper - *p.lower) / 10 : 1.0;
      scale_.push_back(s);
      lower_.push_back(p.lower ? *p.lower / s : -HUGE_VAL);
      upper_.push_back(p.upper ? *p.upper / s : HUGE_VAL);
    }
    threads_ = options.threads > 0 ? options.threads : HardwareThreads();
  }

  int k() const { return static_cast<int>(free_.size()); }
  const std::vector<int>& free() const { return free_; }
  const std::vector<double>& scale() const { return scale_; }
  double lower(int i) const { return lower_[i]; }
  double upper(int i) const { return upper_[i]; }
  int evaluations() const { return evaluations_.load(); }
  int iterations() const { return iterations_; }
  bool Cancelled() const { return options_.cancel && options_.cancel->load(); }

  std::vector<double> ZStart() const {
    std::vector<double> z(k());
    for (int i = 0; i < k(); ++i) z[i] = theta0_[free_[i]] / scale_[i];
    return z;
  }

  std::vector<double> Theta(const std::vector<double>& z) const {
    std::vector<double> theta = theta0_;
    for (int i = 0; i < k(); ++i) theta[free_[i]] = z[i] * scale_[i];
    return theta;
  }

  // log L at scaled point z, or -inf where it cannot be evaluated.
  double LogLik(const std::vector<double>& z, const std::vector<int>& delay, long* n_obs = nullptr,
                std::vector<double>* terms = nullptr) {
    evaluations_.fetch_add(1);
    auto l = lik_.Evaluate(Theta(z), delay, terms);
    if (!l) return -std::numeric_limits<double>::infinity();
    if (n_obs) *n_obs = l->n_obs;
    return l->loglik;
  }

  // The score of every log-likelihood term by central differences (one-sided at a bound): the
  // gradient g (their sums) and the BHHH information Σ_j s_j s_j' (both in scaled units).
  bool Scores(const std::vector<double>& z, const std::vector<int>& delay,
              std::vector<double>* f0_terms, Eigen::VectorXd* g, Eigen::MatrixXd* info) {
    struct Point {
      int i;
      double step;
    };
    std::vector<Point> points;
    for (int i = 0; i < k(); ++i) {
      const double h = kGradientStep * std::max(1.0, std::abs(z[i]));
      if (z[i] + h <= upper_[i]) points.push_back({i, h});
      if (z[i] - h >= lower_[i]) points.push_back({i, -h});
    }
    std::vector<std::vector<double>> terms(points.size());
    std::vector<char> ok(points.size(), 0);
    ParallelFor(static_cast<int>(points.size()), threads_, [&](int p) {
      if (Cancelled()) return;  // leave the rest undone: the caller stops
      std::vector<double> zp = z;
      zp[points[p].i] += points[p].step;
      evaluations_.fetch_add(1);
      ok[p] = lik_.Evaluate(Theta(zp), delay, &terms[p]).ok();
    });
    if (Cancelled()) return false;
    const Eigen::Index n = static_cast<Eigen::Index>(f0_terms->size());
    Eigen::MatrixXd S = Eigen::MatrixXd::Zero(n, k());
    for (int i = 0; i < k(); ++i) {
      int plus = -1, minus = -1;
      for (std::size_t p = 0; p < points.size(); ++p) {
        if (points[p].i != i || !ok[p]) continue;
        (points[p].step > 0 ? plus : minus) = static_cast<int>(p);
      }
      const std::vector<double>* a = plus >= 0 ? &terms[plus] : f0_terms;
      const std::vector<double>* b = minus >= 0 ? &terms[minus] : f0_terms;
      const double width = (plus >= 0 ? points[plus].step : 0.0) - (minus >= 0 ? points[minus].step : 0.0);
      if (width == 0.0) return false;
      for (Eigen::Index j = 0; j < n; ++j) S(j, i) = ((*a)[j] - (*b)[j]) / width;
    }
    *g = S.colwise().sum().transpose();
    *info = S.transpose() * S;
    return g->allFinite() && info->allFinite();
  }

  // Solves I_FF d = g_F, with Levenberg damping only where I_FF is singular (a parameter the data
  // ignore). Returns an empty vector if no damping helps.
  static Eigen::VectorXd NewtonStep(const Eigen::MatrixXd& info, const Eigen::VectorXd& g,
                                    const std::vector<int>& F) {
    const int m = static_cast<int>(F.size());
    Eigen::MatrixXd I(m, m);
    Eigen::VectorXd gF(m);
    for (int a = 0; a < m; ++a) {
      gF(a) = g(F[a]);
      for (int b = 0; b < m; ++b) I(a, b) = info(F[a], F[b]);
    }
    // Damping μ = 0, then 1e-10, 1e-8, ..., 1e4 (an integer counter: no float loop counter).
    for (int attempt = 0; attempt <= kDampingSteps; ++attempt) {
      const double mu = attempt == 0 ? 0.0 : kFirstDamping * std::pow(100.0, attempt - 1);
      Eigen::MatrixXd M = I;
      M.diagonal() += mu * I.diagonal().cwiseMax(1e-300) + Eigen::VectorXd::Constant(m, mu);
      Eigen::LLT<Eigen::MatrixXd> llt(M);
      if (llt.info() != Eigen::Success) continue;
      Eigen::VectorXd d = llt.solve(gF);
      if (d.allFinite()) return d;
    }
    return {};
  }

  // BHHH (Berndt-Hall-Hall-Hausman): Newton steps with the information estimated by the outer
  // product of the per-observation scores, projected onto the bounds (a parameter on a bound
  // whose gradient points outward is held there), with a backtracking line search.
  FitResult FitBhhh(std::vector<double> z, const std::vector<int>& delay, const std::string& stage,
                    int max_iterations) {
    FitResult r;
    for (int i = 0; i < k(); ++i) z[i] = std::clamp(z[i], lower_[i], upper_[i]);
    std::vector<double> terms;
    evaluations_.fetch_add(1);
    auto first = lik_.Evaluate(Theta(z), delay, &terms);
    if (!first) {
      r.message = "the log-likelihood cannot be evaluated at the start: " + first.error().ToString();
      return r;
    }
    double f = first->loglik;
    r.z = z;
    r.loglik = f;
    if (k() == 0) {
      r.converged = true;
      r.message = "no free parameters";
      return r;
    }
    double last_expected = HUGE_VAL;
    for (int it = 0; it < max_iterations; ++it) {
      if (Cancelled()) {
        r.cancelled = true;
        r.message = "cancelled";
        return r;
      }
      if (options_.max_evaluations > 0 && evaluations() > options_.max_evaluations) {
        r.message = fmt::format("stopped after {} evaluations without converging (raise the "
                                "evaluation limit)", evaluations());
        return r;
      }
      Eigen::VectorXd g;
      Eigen::MatrixXd info;
      if (!Scores(z, delay, &terms, &g, &info)) {
        r.cancelled = Cancelled();
        r.message = r.cancelled ? "cancelled"
                                : "the scores could not be computed (the log-likelihood fails "
                                  "near the point)";
        return r;
      }
      ++iterations_;
      Report(stage, z, f, delay);
      std::vector<int> F;
      for (int i = 0; i < k(); ++i) {
        const bool at_lower = z[i] <= lower_[i] && g(i) <= 0;
        const bool at_upper = z[i] >= upper_[i] && g(i) >= 0;
        if (!at_lower && !at_upper) F.push_back(i);
      }
      if (F.empty()) {
        r.converged = true;
        r.message = "every free parameter is held at a bound";
        return r;
      }
      // Solve for the step on the free set; a parameter on a bound whose step points out of the
      // box is held too, and the step re-solved (projected Newton).
      Eigen::VectorXd d, gF;
      for (;;) {
        d = NewtonStep(info, g, F);
        if (d.size() == 0) {
          r.message = "the information matrix is singular: the data do not determine the parameters";
          return r;
        }
        std::vector<int> keep;
        for (std::size_t a = 0; a < F.size(); ++a) {
          const int i = F[a];
          const bool out = (z[i] <= lower_[i] && d(a) < 0) || (z[i] >= upper_[i] && d(a) > 0);
          if (!out) keep.push_back(i);
        }
        if (keep.size() == F.size()) break;
        F = std::move(keep);
        if (F.empty()) {
          r.converged = true;
          r.message = "every free parameter is held at a bound";
          return r;
        }
      }
      const int m = static_cast<int>(F.size());
      gF.resize(m);
      for (int a = 0; a < m; ++a) gF(a) = g(F[a]);
      const double expected = 0.5 * gF.dot(d);  // the Newton decrement / 2
      last_expected = expected;
      const double tol = std::max(options_.ftol_rel * std::abs(f), 1e-12);
      if (expected < tol) {
        r.converged = true;
        r.message = "the expected improvement of log L is below the tolerance";
        return r;
      }
      // Backtracking along the projected direction.
      bool accepted = false;
      std::vector<double> z_new(z);
      double f_new = f;
      for (int half = 0, alpha_exp = 0; half < kMaxHalvings; ++half, --alpha_exp) {
        const double alpha = std::ldexp(1.0, alpha_exp);
        z_new = z;
        double predicted = 0;
        for (int a = 0; a < m; ++a) {
          const int i = F[a];
          z_new[i] = std::clamp(z[i] + alpha * d(a), lower_[i], upper_[i]);
          predicted += g(i) * (z_new[i] - z[i]);
        }
        f_new = LogLik(z_new, delay);
        if (std::isfinite(f_new) && f_new >= f + kArmijo * predicted && f_new > f) {
          accepted = true;
          break;
        }
        if (Cancelled()) break;
      }
      if (!accepted) {
        if (Cancelled()) {
          r.cancelled = true;
          r.message = "cancelled";
          return r;
        }
        r.converged = expected < kNegligibleImprovement;
        r.message = r.converged ? "at the precision of the log-likelihood (no further increase is possible)"
                                : "the line search found no increase of the log-likelihood";
        return r;
      }
      const double gain = f_new - f;
      z = z_new;
      f = f_new;
      r.z = z;
      r.loglik = f;
      evaluations_.fetch_add(1);
      if (!lik_.Evaluate(Theta(z), delay, &terms).ok()) {
        r.message = "the log-likelihood failed at an accepted point";
        return r;
      }
      if (gain < tol && expected < kNegligibleImprovement) {
        r.converged = true;
        r.message = "the log-likelihood stopped increasing";
        return r;
      }
    }
    r.converged = last_expected < kNegligibleImprovement;
    r.message = r.converged ? "the expected improvement left is negligible"
                            : fmt::format("stopped after {} iterations without converging",
                                          max_iterations);
    return r;
  }

  FitResult Fit(std::vector<double> z, const std::vector<int>& delay, const std::string& stage,
                int max_iterations = kMaxBhhhIterations) {
    if (options_.algorithm == Algorithm::kBhhh) return FitBhhh(std::move(z), delay, stage, max_iterations);
    if (options_.algorithm == Algorithm::kAuto) {
      FitResult rough = FitNlopt(std::move(z), delay, stage, nlopt::LD_LBFGS,
                                 std::max(options_.ftol_rel, options_.handover_ftol_rel));
      if (rough.cancelled || !std::isfinite(rough.loglik)) return rough;
      FitResult polished = FitBhhh(rough.z, delay, stage, max_iterations);
      if (polished.converged || polished.cancelled) return polished;
      // BHHH could not finish (flat or bound-limited directions, where the outer product of the
      // scores is a poor Hessian): L-BFGS to the full tolerance from the best point so far.
      FitResult& better = polished.loglik >= rough.loglik ? polished : rough;
      FitResult finished = FitNlopt(better.z, delay, stage, nlopt::LD_LBFGS, options_.ftol_rel);
      return finished.loglik >= better.loglik ? finished : better;
    }
    const nlopt::algorithm algo = options_.algorithm == Algorithm::kLbfgs   ? nlopt::LD_LBFGS
                                  : options_.algorithm == Algorithm::kSlsqp ? nlopt::LD_SLSQP
                                                                            : nlopt::LN_BOBYQA;
    return FitNlopt(std::move(z), delay, stage, algo, options_.ftol_rel);
  }

  // A fit from a nearby optimum: BHHH under kAuto, else the chosen algorithm.
  FitResult FitWarm(std::vector<double> z, const std::vector<int>& delay, const std::string& stage,
                    int max_iterations) {
    if (options_.algorithm == Algorithm::kAuto) return FitBhhh(std::move(z), delay, stage, max_iterations);
    return Fit(std::move(z), delay, stage, max_iterations);
  }

  // What NLopt sees at a point z where log L cannot be evaluated: worse than every point seen,
  // by the spread of the values seen so far (at least 1), and a gradient that points back to the
  // best point. A finite, moderate value keeps BOBYQA's quadratic models and the quasi-Newton
  // line searches usable: 1e300 would swamp them, and a zero gradient reads as a stationary
  // point. The optimiser then shortens its step or turns away, as it would from a steep wall.
  static double FailedObjective(const std::vector<double>& z, std::vector<double>& grad,
                                const FitResult& best, double worst_loglik) {
    if (!std::isfinite(best.loglik)) {
      std::fill(grad.begin(), grad.end(), 0.0);
      return kFailedObjective;
    }
    const double gap = std::max(1.0, best.loglik - worst_loglik);
    if (!grad.empty()) {
      double dist2 = 0;
      for (std::size_t i = 0; i < z.size(); ++i) dist2 += (z[i] - best.z[i]) * (z[i] - best.z[i]);
      for (std::size_t i = 0; i < z.size(); ++i)
        grad[i] = dist2 > 0 ? gap * (z[i] - best.z[i]) / dist2 : 0.0;
    }
    return -worst_loglik + gap;
  }

  // One NLopt run.
  FitResult FitNlopt(std::vector<double> z, const std::vector<int>& delay, const std::string& stage,
                     nlopt::algorithm algo, double ftol_rel) {
    FitResult result;
    for (int i = 0; i < k(); ++i) z[i] = std::clamp(z[i], lower_[i], upper_[i]);
    if (k() == 0) {
      result.z = z;
      result.loglik = LogLik(z, delay);
      result.converged = std::isfinite(result.loglik);
      result.message = "no free parameters";
      return result;
    }
    struct Data {
      Fitter* self;
      const std::vector<int>* delay;
      FitResult* best;
      const std::string* stage;
      double worst_loglik;  // the lowest finite log L seen
    } data{this, &delay, &result, &stage, HUGE_VAL};
    auto objective = [](const std::vector<double>& zz, std::vector<double>& grad, void* raw) {
      auto* d = static_cast<Data*>(raw);
      Fitter* self = d->self;
      if (self->Cancelled()) throw nlopt::forced_stop();
      std::vector<double> terms;
      const double f = self->LogLik(zz, *d->delay, nullptr, grad.empty() ? nullptr : &terms);
      if (!std::isfinite(f)) return FailedObjective(zz, grad, *d->best, d->worst_loglik);
      d->worst_loglik = std::min(d->worst_loglik, f);
      if (f > d->best->loglik) {
        d->best->loglik = f;
        d->best->z = zz;
      }
      if (!grad.empty()) {
        ++self->iterations_;
        Eigen::VectorXd g;
        Eigen::MatrixXd info;
        if (!self->Scores(zz, *d->delay, &terms, &g, &info)) {
          if (self->Cancelled()) throw nlopt::forced_stop();
          g.setZero(self->k());
        }
        for (int i = 0; i < self->k(); ++i) grad[i] = -g(i);
        self->Report(*d->stage, d->best->z, d->best->loglik, *d->delay);
      }
      return -f;
    };
    nlopt::opt opt(algo, static_cast<unsigned>(k()));
    opt.set_lower_bounds(lower_);
    opt.set_upper_bounds(upper_);
    opt.set_min_objective(objective, &data);
    opt.set_ftol_rel(ftol_rel);
    opt.set_xtol_rel(options_.xtol_rel);
    if (options_.max_evaluations > 0) opt.set_maxeval(options_.max_evaluations);
    double minf = 0;
    result.z = z;
    try {
      const nlopt::result r = opt.optimize(z, minf);
      result.converged = r == nlopt::FTOL_REACHED || r == nlopt::XTOL_REACHED ||
                         r == nlopt::SUCCESS || r == nlopt::STOPVAL_REACHED;
      switch (r) {
        case nlopt::FTOL_REACHED: result.message = "relative tolerance on the objective reached"; break;
        case nlopt::XTOL_REACHED: result.message = "relative tolerance on the parameters reached"; break;
        case nlopt::MAXEVAL_REACHED:
          result.message = fmt::format("stopped after {} evaluations without converging "
                                       "(raise the evaluation limit)", options_.max_evaluations);
          break;
        default: result.message = "the optimiser reported success"; break;
      }
    } catch (const nlopt::forced_stop&) {
      result.cancelled = true;
      result.message = "cancelled";
    } catch (const nlopt::roundoff_limited&) {
      // The objective's rounding noise stops further progress: at the optimum to the precision
      // the likelihood can be computed. Accept when the gradient is small there.
      result.converged = true;
      result.message = "at the precision of the log-likelihood (roundoff-limited)";
    } catch (const std::exception& e) {
      result.message = fmt::format("the optimiser failed: {}", e.what());
    }
    if (!std::isfinite(result.loglik)) {
      result.converged = false;
      if (!result.cancelled) result.message = "the log-likelihood could not be evaluated";
    }
    return result;
  }

  void Report(const std::string& stage, const std::vector<double>& z, double loglik,
              const std::vector<int>& delay) {
    if (!options_.progress) return;
    Progress p;
    p.iteration = iterations_;
    p.evaluations = evaluations();
    p.loglik = loglik;
    p.theta = Theta(z);
    p.delay = delay;
    p.stage = stage;
    options_.progress(p);
  }

 private:
  const filter::Likelihood& lik_;
  const EstimateOptions& options_;
  std::vector<double> theta0_;
  std::vector<int> free_;
  std::vector<double> scale_, lower_, upper_;
  int threads_ = 1;
  std::atomic<int> evaluations_{0};
  int iterations_ = 0;
};

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
        z[i] = lo + u * (hi - lo);
      } else {
        const double base = z0[i] != 0 ? z0[i] : 1.0;
        z[i] = std::clamp(base * std::pow(10.0, 2 * u - 1), lo, hi);
      }
    }
    starts.push_back(std::move(z));
  }
  return starts;
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
      : f_(f), z_(z), f0_(f0), delay_(delay), active_(active), h_(std::move(h)),
        threads_(threads), dir_(active.size(), 0), dropped_(active.size(), false) {}

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
      v[c] = -f_.LogLik(zp, delay_);
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

struct Uncertainty {
  std::vector<std::optional<double>> std_error;  // per free parameter
  std::vector<bool> at_bound;
  std::vector<int> with_se;                      // free-parameter indices that have an SE
  Eigen::MatrixXd covariance;                    // over with_se
  std::vector<std::string> warnings;
};

Uncertainty ComputeUncertainty(Fitter& f, const std::vector<double>& z, double f0,
                               const std::vector<int>& delay, const model::ModelSpec& spec,
                               int threads) {
  Uncertainty u;
  const int k = f.k();
  u.std_error.assign(k, std::nullopt);
  u.at_bound.assign(k, false);
  std::vector<int> active;       // free parameters not at a bound
  std::vector<double> h;         // their steps (scaled units)
  for (int i = 0; i < k; ++i) {
    const double range = std::isfinite(f.upper(i) - f.lower(i)) ? f.upper(i) - f.lower(i)
                                                                : std::max(1.0, std::abs(z[i]));
    const double to_bound = std::min(z[i] - f.lower(i), f.upper(i) - z[i]);
    if (to_bound <= kAtBoundTol * std::max(range, std::abs(z[i]))) {
      u.at_bound[i] = true;
      continue;
    }
    double step = kHessianStep * std::max(std::abs(z[i]), 1e-2);
    step = std::min(step, to_bound / 2.5);  // stay inside the bounds with ±2 steps
    active.push_back(i);
    h.push_back(step);
  }
  const int m = static_cast<int>(active.size());
  auto name = [&](int a) { return spec.parameters[f.free()[active[a]]].name; };
  HessianByDifferences hd(f, z, f0, delay, active, std::move(h), threads);
  Eigen::MatrixXd H = hd.Run();
  if (f.Cancelled()) return u;
  for (int a = 0; a < m; ++a) {
    if (hd.dropped(a))
      u.warnings.push_back(fmt::format(
          "the log-likelihood cannot be evaluated on either side of {} near the estimate: no "
          "standard error for {}; the others' are computed with it held at its estimate",
          name(a), name(a)));
    else if (hd.direction(a) != 0)
      u.warnings.push_back(fmt::format(
          "the log-likelihood cannot be evaluated just {} the estimate of {} (the model fails "
          "there): its standard error uses one-sided differences",
          hd.direction(a) > 0 ? "below" : "above", name(a)));
  }
  if (!H.allFinite()) {  // every point finite, yet the differences overflow
    u.warnings.push_back("the Hessian could not be computed (the differences of the "
                         "log-likelihood near the estimate overflow): no standard errors");
    return u;
  }
  // Hessian of -log L in scaled units, then to the natural scale: θ_i = s_i z_i.
  for (int a = 0; a < m; ++a)
    for (int b = 0; b < m; ++b) H(a, b) /= f.scale()[active[a]] * f.scale()[active[b]];

  // Parameters whose own curvature is not positive are not determined by the data at all.
  std::vector<int> keep;
  for (int a = 0; a < m; ++a) {
    if (hd.dropped(a)) continue;
    if (H(a, a) > 0) keep.push_back(a);
    else
      u.warnings.push_back(fmt::format("the log-likelihood is flat or curves upward in {}: the "
                                       "data do not determine it (no standard error)", name(a)));
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
        "them.", names, involved.size() > 1 ? "them" : "it"));
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
    u.warnings.push_back("the Hessian is not positive definite at the estimate (not a maximum?): "
                         "no standard errors");
    return u;
  }
  u.covariance = llt.solve(Eigen::MatrixXd::Identity(n, n));
  for (int i = 0; i < n; ++i) {
    const int fi = active[keep[i]];
    u.with_se.push_back(fi);
    u.std_error[fi] = std::sqrt(u.covariance(i, i));
  }
  return u;
}


}  // namespace

// ---- 5. Estimate -----------------------------------------------------------------------------

Result<EstimateSummary> Estimate(const filter::Likelihood& shared_likelihood,
                                 const EstimateOptions& options) {
  std::string why;
  if (!options.IsValid(&why)) return InputError("invalid estimation options: " + why);
  // A copy (it shares the model and data) whose evaluations also watch the cancel flag.
  filter::Likelihood lik = shared_likelihood;
  lik.set_cancel(options.cancel);
  const auto start_time = Clock::now();
  const model::ModelSpec& spec = lik.model().spec();
  Fitter fitter(lik, options);
  const int threads = options.threads > 0 ? options.threads : HardwareThreads();

  EstimateSummary s;
  s.model_name = spec.name;
  for (const auto& series : lik.series()) s.datasets.push_back(series->source);

  // Cancellation can arrive in any stage; each stage ends by looking at the flag.
  auto cancelled_summary = [&] {
    s.cancelled = true;
    s.converged = false;
    s.message = "cancelled";
    s.evaluations = fitter.evaluations();
    s.iterations = fitter.iterations();
    s.elapsed_s = std::chrono::duration<double>(Clock::now() - start_time).count();
    return s;
  };

  // The delay to start from: the best of the grid at the start values.
  const bool scanning = spec.HasDelayScan();
  std::vector<int> delay;
  {
    auto profile = lik.Profile(spec.Values());
    if (fitter.Cancelled()) return cancelled_summary();
    if (!profile) {
      Error e = profile.error();  // the model cannot be evaluated at θ0: say that it is the start
      e.message = "the log-likelihood cannot be evaluated at the start values: " + e.message;
      return e;
    }
    if (profile->best < 0) {
      Error e = NumericalError("the log-likelihood cannot be evaluated at the start values: " +
                               profile->candidates.front().message);
      return e;
    }
    delay = profile->candidates[profile->best].delay;
  }

  // Fit from every start at that delay; keep the best.
  FitResult best;
  for (const auto& z0 : StartPoints(fitter, options.multistart, options.seed)) {
    FitResult r = fitter.Fit(z0, delay, "fitting");
    if (r.cancelled) {
      best = r;
      break;
    }
    if (r.loglik > best.loglik) best = r;
  }
  // Alternate θ and delay until the delay settles.
  for (int round = 0; scanning && !best.cancelled && !fitter.Cancelled() && round < 10; ++round) {
    auto profile = lik.Profile(fitter.Theta(best.z));
    if (!profile || profile->best < 0) break;
    const auto& next = profile->candidates[profile->best].delay;
    if (next == delay) break;
    delay = next;
    best = fitter.FitWarm(best.z, delay, "fitting", kMaxBhhhIterations);
  }
  // The profile: θ re-optimised at every other delay candidate, walking outward from the
  // estimate so that each fit starts from the optimum of its nearest fitted neighbour. Fits at
  // wrong delays are misspecified, where BHHH converges slowly; their effort is bounded
  // (kProfileIterations): a profile value is then a lower bound, which cannot mislead the choice
  // of the delay (the best delay's own fit is complete).
  struct ProfileValue {
    std::vector<int> delay;
    double loglik;
    bool converged;
    bool operator<(const ProfileValue& o) const { return delay < o.delay; }
  };
  std::vector<ProfileValue> profile_points;
  if (scanning && !best.cancelled) {
    const std::vector<int> delay_best = delay;
    auto distance = [](const std::vector<int>& a, const std::vector<int>& b) {
      int d = 0;
      for (std::size_t i = 0; i < a.size(); ++i) d += std::abs(a[i] - b[i]);
      return d;
    };
    std::vector<std::vector<int>> grid = lik.DelayGrid();
    std::stable_sort(grid.begin(), grid.end(), [&](const auto& a, const auto& b) {
      return distance(a, delay_best) < distance(b, delay_best);
    });
    std::vector<std::pair<std::vector<int>, std::vector<double>>> fitted = {{delay_best, best.z}};
    for (const auto& candidate : grid) {
      double ll;
      bool complete = true;
      if (candidate == delay_best) {
        ll = best.loglik;
      } else if (options.full_delay_profile) {
        const std::vector<double>* start = &best.z;
        int nearest = INT_MAX;
        for (const auto& [d, z] : fitted)
          if (distance(d, candidate) < nearest) nearest = distance(d, candidate), start = &z;
        FitResult r = fitter.FitWarm(*start, candidate, "delay profile", kProfileIterations);
        if (r.cancelled) {
          best.cancelled = true;
          best.message = r.message;
          break;
        }
        ll = r.loglik;
        complete = r.converged;
        if (std::isfinite(r.loglik)) fitted.emplace_back(candidate, r.z);
        if (r.loglik > best.loglik) {
          // A better delay found while profiling: complete its fit and make it the estimate.
          FitResult full = fitter.Fit(r.z, candidate, "fitting");
          if (full.loglik >= r.loglik) r = full;
          best = r;
          delay = candidate;
          ll = r.loglik;
          complete = r.converged;
        }
      } else {
        ll = fitter.LogLik(best.z, candidate);
      }
      profile_points.push_back({candidate, ll, complete});
    }
    std::sort(profile_points.begin(), profile_points.end());
  }
  if (best.cancelled || fitter.Cancelled()) return cancelled_summary();
  if (!std::isfinite(best.loglik))
    return NumericalError("the log-likelihood could not be evaluated anywhere the optimiser went");

  // Summary at the estimate.
  s.converged = best.converged;
  s.message = best.message;
  s.theta = fitter.Theta(best.z);
  long n_obs = 0;
  s.loglik = fitter.LogLik(best.z, delay, &n_obs);
  s.n_obs = n_obs;
  int scanned = 0;
  for (const auto& d : spec.output_delay) scanned += d.IsScan() ? 1 : 0;
  s.n_free = fitter.k() + scanned;
  s.aic = -2 * s.loglik + 2 * s.n_free;
  s.bic = -2 * s.loglik + s.n_free * std::log(static_cast<double>(s.n_obs));

  if (fitter.Cancelled() || !std::isfinite(s.loglik)) {
    if (fitter.Cancelled()) return cancelled_summary();
    return NumericalError("the log-likelihood cannot be evaluated at the estimate");
  }
  fitter.Report("standard errors", best.z, s.loglik, delay);
  Uncertainty u = ComputeUncertainty(fitter, best.z, s.loglik, delay, spec, threads);
  if (fitter.Cancelled()) return cancelled_summary();
  s.warnings = u.warnings;
  const double dof = static_cast<double>(std::max<long>(1, s.n_obs - s.n_free));
  const boost::math::students_t t_dist(dof);
  std::vector<int> free_pos(spec.parameters.size(), -1);
  for (int i = 0; i < fitter.k(); ++i) free_pos[fitter.free()[i]] = i;
  for (std::size_t i = 0; i < spec.parameters.size(); ++i) {
    const auto& p = spec.parameters[i];
    ParameterEstimate e;
    e.name = p.name;
    e.estimate = s.theta[i];
    e.lower = p.lower;
    e.upper = p.upper;
    e.fixed = p.fixed;
    e.unit = p.unit;
    const int fi = free_pos[i];
    if (fi >= 0) {
      e.at_bound = u.at_bound[fi];
      if (e.at_bound)
        s.warnings.push_back(fmt::format("{} is at its {} bound ({}): its standard error is not "
                                         "reported", p.name,
                                         std::abs(e.estimate - p.lower.value_or(NAN)) <
                                                 std::abs(e.estimate - p.upper.value_or(NAN))
                                             ? "lower" : "upper",
                                         e.estimate));
      if (u.std_error[fi]) {
        e.std_error = *u.std_error[fi];
        e.t_value = e.estimate / *e.std_error;
        e.p_value = 2 * boost::math::cdf(boost::math::complement(t_dist, std::abs(*e.t_value)));
      }
    }
    s.parameters.push_back(std::move(e));
  }
  const int n_se = static_cast<int>(u.with_se.size());
  s.covariance = u.covariance;
  s.correlation = Eigen::MatrixXd::Identity(n_se, n_se);
  for (int a = 0; a < n_se; ++a) {
    s.correlation_names.push_back(spec.parameters[fitter.free()[u.with_se[a]]].name);
    for (int b = 0; b < n_se; ++b)
      if (a != b)
        s.correlation(a, b) =
            u.covariance(a, b) / std::sqrt(u.covariance(a, a) * u.covariance(b, b));
  }
  for (int a = 0; a < n_se; ++a)
    for (int b = a + 1; b < n_se; ++b)
      if (std::abs(s.correlation(a, b)) > kHighCorrelation)
        s.warnings.push_back(fmt::format("{} and {} are correlated (r = {:.3f}): the data barely "
                                         "separate them", s.correlation_names[a],
                                         s.correlation_names[b], s.correlation(a, b)));

  for (std::size_t o = 0; o < spec.outputs.size(); ++o) {
    DelayEstimate d;
    d.output = spec.outputs[o];
    d.estimate = delay[o];
    d.scanned = spec.output_delay[o].IsScan();
    if (d.scanned) {
      // The profile along this output: other outputs at their estimates.
      for (const auto& point : profile_points) {
        const std::vector<int>& candidate = point.delay;
        bool others_at_estimate = true;
        for (std::size_t q = 0; q < delay.size(); ++q)
          if (q != o && candidate[q] != delay[q]) others_at_estimate = false;
        if (!others_at_estimate) continue;
        DelayProfilePoint pt;
        pt.delay = candidate[o];
        pt.converged = point.converged || candidate == delay;
        if (std::isfinite(point.loglik)) pt.loglik = candidate == delay ? s.loglik : point.loglik;
        d.profile.push_back(pt);
      }
    }
    s.delays.push_back(std::move(d));
  }
  if (!s.converged)
    s.warnings.insert(s.warnings.begin(), "the optimiser did not converge: " + s.message);
  for (std::size_t o = 0; o < s.delays.size(); ++o) {
    const model::DelaySpec& range = spec.output_delay[o];
    if (range.IsScan() && (delay[o] == range.min || delay[o] == range.max) && range.min > 0)
      s.warnings.push_back(fmt::format("the delay of {} ({} samples) is at the end of its scanned "
                                       "range [{}, {}]: widen the range", spec.outputs[o],
                                       delay[o], range.min, range.max));
    else if (range.IsScan() && delay[o] == range.max)
      s.warnings.push_back(fmt::format("the delay of {} ({} samples) is at the top of its scanned "
                                       "range: widen the range", spec.outputs[o], delay[o]));
  }
  s.iterations = fitter.iterations();
  s.evaluations = fitter.evaluations();
  s.elapsed_s = std::chrono::duration<double>(Clock::now() - start_time).count();
  return s;
}

// ---- 6. likelihood-ratio test ----------------------------------------------------------------

Result<LikelihoodRatioTest> CompareNested(double loglik_restricted, int n_free_restricted,
                                          double loglik_full, int n_free_full) {
  if (n_free_full <= n_free_restricted)
    return InputError(fmt::format("the larger model must have more free parameters ({} vs {}): "
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
