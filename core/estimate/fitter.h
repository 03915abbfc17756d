// The fitter behind Estimate and ProfileIntervals (internal to core/estimate): the free
// parameters on a scaled copy, the objective (log L, plus the log priors), its exact gradient and
// BHHH information, and the optimisers (estimate.h describes them).
#pragma once

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <mutex>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <Eigen/Dense>
#include <fmt/format.h>
#include <nlopt.hpp>

#include "core/estimate/estimate.h"
#include "core/util/parallel.h"

namespace gb::estimate::internal {

inline constexpr double kFailedObjective = 1e300;   // -log L reported to NLopt where log L fails
                                             // before any point could be evaluated
inline constexpr double kGradientStep = 1e-5;       // ≈ eps^(1/3): central differences in scaled units
inline constexpr int kMaxBhhhIterations = 500;
// Fits whose log-likelihoods differ by less than this reached the same optimum (log L units; one
// standard error is worth 0.5).
inline constexpr double kSameOptimum = 1e-3;
inline constexpr int kMaxSaddleEscapes = 3;
// Where the estimate is on a bound (starts_on_bound): each extra start is fitted this many
// iterations, and the best kContinuedStarts of them fitted on, each within twice the evaluations
// of the plain start's fit (at least kMinExtraEvaluations).
inline constexpr int kExploreIterations = 100;
inline constexpr int kMinExtraEvaluations = 200;
inline constexpr int kContinuedStarts = 2;
inline constexpr double kArmijo = 1e-4;             // sufficient increase along the BHHH direction
inline constexpr int kMaxHalvings = 40;
inline constexpr double kFirstDamping = 1e-10;      // Levenberg damping of a singular BHHH information,
inline constexpr int kDampingSteps = 8;             // then x100 per step up to 1e4
inline constexpr double kNearBound = 1e-6;          // scaled: a parameter this close is on its bound
// An expected improvement of log L below this (in log-likelihood units, far below the 0.5 that
// one standard error is worth) counts as converged when rounding stops further progress.
inline constexpr double kNegligibleImprovement = 1e-4;
inline constexpr double kHessianStep = 1e-4;        // ≈ eps^(1/4): second differences, relative
inline constexpr double kGradientHessianStep = 1e-5;  // ≈ eps^(1/3): differences of the gradient
// An eigenvalue of the Hessian below -this x its largest magnitude marks a saddle.
inline constexpr double kNegativeCurvature = 1e-6;
inline constexpr double kAtBoundTol = 1e-7;         // relative distance to a bound that counts as on it
inline constexpr double kUndeterminedEig = 1e-9;    // eigenvalue of the scaled Hessian below: undetermined
inline constexpr double kHighCorrelation = 0.99;

// ---- 2. the fitter ---------------------------------------------------------------------------

struct FitResult {
  std::vector<double> z;
  Eigen::MatrixXd model;  // auto and BHHH: the curvature model of -objective at z (scaled units)
  double loglik = -std::numeric_limits<double>::infinity();
  bool converged = false;
  bool cancelled = false;
  std::string message;
};

class Fitter {
 public:
  // Over the model's free parameters, from its start values; or, with `theta_base`, from those
  // values with the parameters `held` (indices into the model's parameters) held too.
  Fitter(const filter::Likelihood& lik, const EstimateOptions& options,
         std::span<const double> theta_base = {}, std::span<const int> held = {})
      : lik_(lik), options_(options) {
    const auto& spec = lik.spec();
    theta0_ = theta_base.empty() ? spec.Values()
                                 : std::vector<double>(theta_base.begin(), theta_base.end());
    for (std::size_t i = 0; i < spec.parameters.size(); ++i) {
      const auto& p = spec.parameters[i];
      if (p.fixed || std::find(held.begin(), held.end(), static_cast<int>(i)) != held.end())
        continue;
      free_.push_back(static_cast<int>(i));
      const double start = theta0_[i];
      const double s = start != 0 ? std::abs(start)
                       : (p.lower && p.upper) ? (*p.upper - *p.lower) / 10 : 1.0;
      scale_.push_back(s);
      lower_.push_back(p.lower ? *p.lower / s : -HUGE_VAL);
      upper_.push_back(p.upper ? *p.upper / s : HUGE_VAL);
      if (p.prior) priors_.push_back({static_cast<int>(free_.size()) - 1, *p.prior});
    }
    threads_ = options.threads > 0 ? options.threads : HardwareThreads();
  }

  // A fitter over the same free parameters and scaling as `base`, with other options (threads,
  // progress): for fits that run beside each other.
  Fitter(const Fitter& base, const EstimateOptions& options)
      : lik_(base.lik_), options_(options), theta0_(base.theta0_), free_(base.free_),
        scale_(base.scale_), lower_(base.lower_), upper_(base.upper_), priors_(base.priors_) {
    threads_ = options.threads > 0 ? options.threads : HardwareThreads();
  }

  // Fit(z, delay, stage) on a fitter of its own with `threads` threads (and, if > 0, its own
  // evaluation limit), safe to call from several threads at once: its progress reports are passed
  // on one at a time, and its iterations and evaluations are added to this fitter's when it
  // returns.
  FitResult FitAlongside(std::vector<double> z, const std::vector<int>& delay,
                         const std::string& stage, int threads, int max_evaluations = 0,
                         const Eigen::MatrixXd* first_model = nullptr) {
    return Alongside(threads, max_evaluations, /*report=*/true, [&](Fitter& f) {
      return f.Fit(std::move(z), delay, stage, kMaxBhhhIterations, first_model);
    });
  }

  // `iterations` iterations of auto's BHHH with BFGS corrections from z (no L-BFGS finish, no
  // progress reports), as FitAlongside: a cheap look at where a start leads.
  FitResult ExploreAlongside(std::vector<double> z, const std::vector<int>& delay, int iterations,
                             int threads) {
    return Alongside(threads, 0, /*report=*/false, [&](Fitter& f) {
      return f.FitBhhh(std::move(z), delay, "fitting", iterations, /*bfgs_updates=*/true);
    });
  }

  int k() const { return static_cast<int>(free_.size()); }
  const std::vector<int>& free() const { return free_; }
  const std::vector<double>& scale() const { return scale_; }
  double lower(int i) const { return lower_[i]; }
  double upper(int i) const { return upper_[i]; }
  int evaluations() const { return evaluations_.load(); }
  int iterations() const { return iterations_.load(); }
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

  // The objective at scaled point z: log L, plus Σ log N(θ_i | m_i, s_i²) over the parameters
  // with a prior (a log posterior); -inf where log L cannot be evaluated.
  double Objective(const std::vector<double>& z, const std::vector<int>& delay) {
    return LogLik(z, delay) + LogPrior(z);
  }

  // log L alone (no prior) at z.
  double LogLik(const std::vector<double>& z, const std::vector<int>& delay, long* n_obs = nullptr) {
    evaluations_.fetch_add(1);
    auto l = lik_.Evaluate(Theta(z), delay);
    if (!l) return -std::numeric_limits<double>::infinity();
    if (n_obs) *n_obs = l->n_obs;
    return l->loglik;
  }

  bool HasPriors() const { return !priors_.empty(); }

  // Σ log N(θ_i | m_i, s_i²) over the free parameters with a prior (natural scale, normalised).
  double LogPrior(const std::vector<double>& z) const {
    double sum = 0;
    for (const auto& [i, prior] : priors_) sum += prior.LogDensity(z[i] * scale_[i]);
    return sum;
  }

  // Adds the priors' gradient to *g and their information (the negative Hessian of the log
  // prior) to *info, both in scaled units.
  void AddPriorDerivatives(const std::vector<double>& z, Eigen::VectorXd* g,
                           Eigen::MatrixXd* info) const {
    for (const auto& [i, prior] : priors_) {
      const double sd_z = prior.sd / scale_[i];
      (*g)(i) -= (z[i] - prior.mean / scale_[i]) / (sd_z * sd_z);
      if (info) (*info)(i, i) += 1 / (sd_z * sd_z);
    }
  }

  // The objective's value *f, its gradient *g and, with `info`, BHHH's information Σ_j s_j s_j'
  // (plus the priors' information), all in scaled units, from the exact score
  // (filter::Likelihood::EvaluateWithScore). With `split`, the parameters are shared out over the
  // threads (each evaluates the filter once more, with its share of the sensitivities). False
  // where log L or its score cannot be evaluated.
  bool Scores(const std::vector<double>& z, const std::vector<int>& delay, double* f,
              Eigen::VectorXd* g, Eigen::MatrixXd* info, bool split = true,
              bool* exact = nullptr) {
    if (exact) *exact = true;
    if (Cancelled()) return false;
    // The iterated extended Kalman filter has no exact score: differences of its terms, as where
    // an exact score fails (and, not being exact, they are not differenced again for the Hessian).
    if (!lik_.exact_scores() || options_.score_differences) {
      if (exact) *exact = false;
      return ScoresByDifferences(z, delay, f, g, info);
    }
    const std::vector<double> theta = Theta(z);
    // One chunk at least, also with no free parameter (only a delay is estimated).
    const int chunks = split && k() > 1 ? std::clamp(std::min(threads_, k() / 2), 1, k()) : 1;
    std::vector<std::vector<int>> which(chunks);
    for (int i = 0; i < k(); ++i) which[i * chunks / k()].push_back(free_[i]);
    std::vector<Eigen::VectorXd> g_part(chunks);
    std::vector<Eigen::MatrixXd> J_part(chunks);
    std::vector<double> value(chunks, 0.0);
    std::vector<char> ok(chunks, 0);
    evaluations_.fetch_add(1);
    ParallelFor(chunks, chunks, [&](int c) {
      auto l = lik_.EvaluateWithScore(theta, delay, which[c], &g_part[c],
                                      info ? &J_part[c] : nullptr);
      ok[c] = l.ok();
      if (l) value[c] = l->loglik;
    });
    if (Cancelled()) return false;
    if (std::find(ok.begin(), ok.end(), 0) != ok.end()) {  // e.g. d sqrt(s)/ds at s = 0
      if (exact) *exact = false;
      return ScoresByDifferences(z, delay, f, g, info);
    }
    *f = value[0] + LogPrior(z);
    g->resize(k());
    Eigen::MatrixXd J;
    if (info) J.resize(J_part[0].rows(), k());
    for (int c = 0, at = 0; c < chunks; ++c) {
      const int n = static_cast<int>(which[c].size());
      for (int a = 0; a < n; ++a) {
        (*g)(at + a) = g_part[c](a) * scale_[at + a];
        if (info) J.col(at + a) = J_part[c].col(a) * scale_[at + a];
      }
      at += n;
    }
    if (info) *info = J.transpose() * J;
    AddPriorDerivatives(z, g, info);
    return std::isfinite(*f) && g->allFinite() && (!info || info->allFinite());
  }

  // Scores where the exact score cannot be computed but log L can (a derivative of the model's
  // entries that is infinite at z, such as d sqrt(s)/ds at s = 0 on a bound): every per-term
  // score by central differences, one-sided where a step would leave the bounds.
  bool ScoresByDifferences(const std::vector<double>& z, const std::vector<int>& delay, double* f,
                           Eigen::VectorXd* g, Eigen::MatrixXd* info) {
    std::vector<double> f0_terms;
    evaluations_.fetch_add(1);
    auto l0 = lik_.Evaluate(Theta(z), delay, &f0_terms);
    if (!l0) return false;
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
      if (Cancelled()) return;
      std::vector<double> zp = z;
      zp[points[p].i] += points[p].step;
      evaluations_.fetch_add(1);
      ok[p] = lik_.Evaluate(Theta(zp), delay, &terms[p]).ok();
    });
    if (Cancelled()) return false;
    const Eigen::Index n = static_cast<Eigen::Index>(f0_terms.size());
    Eigen::MatrixXd S = Eigen::MatrixXd::Zero(n, k());
    for (int i = 0; i < k(); ++i) {
      int plus = -1, minus = -1;
      for (std::size_t p = 0; p < points.size(); ++p) {
        if (points[p].i != i || !ok[p]) continue;
        (points[p].step > 0 ? plus : minus) = static_cast<int>(p);
      }
      const std::vector<double>* a = plus >= 0 ? &terms[plus] : &f0_terms;
      const std::vector<double>* b = minus >= 0 ? &terms[minus] : &f0_terms;
      const double width = (plus >= 0 ? points[plus].step : 0.0) - (minus >= 0 ? points[minus].step : 0.0);
      if (width == 0.0) return false;
      for (Eigen::Index j = 0; j < n; ++j) S(j, i) = ((*a)[j] - (*b)[j]) / width;
    }
    *f = l0->loglik + LogPrior(z);
    *g = S.colwise().sum().transpose();
    if (info) *info = S.transpose() * S;
    AddPriorDerivatives(z, g, info);
    return std::isfinite(*f) && g->allFinite() && (!info || info->allFinite());
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
                    int max_iterations, bool bfgs_updates = false,
                    const Eigen::MatrixXd* first_model = nullptr) {
    Eigen::MatrixXd B;  // the curvature model of -objective (scaled units)
    FitResult r = BhhhLoop(std::move(z), delay, stage, max_iterations, bfgs_updates, first_model, B);
    r.model = std::move(B);
    return r;
  }

  // FitBhhh's iterations; B ends as the curvature model at the returned point.
  FitResult BhhhLoop(std::vector<double> z, const std::vector<int>& delay, const std::string& stage,
                     int max_iterations, bool bfgs_updates, const Eigen::MatrixXd* first_model,
                     Eigen::MatrixXd& B) {
    FitResult r;
    const int evaluations_before = evaluations();
    Eigen::VectorXd g_last;            // the gradient at the last accepted point
    std::vector<double> z_last;
    bool reset = true;                 // take BHHH's information afresh
    for (int i = 0; i < k(); ++i) z[i] = std::clamp(z[i], lower_[i], upper_[i]);
    r.z = z;
    if (k() == 0) {
      r.loglik = Objective(z, delay);
      r.converged = std::isfinite(r.loglik);
      r.message = r.converged ? "no free parameters" : "the log-likelihood cannot be evaluated";
      return r;
    }
    double last_expected = HUGE_VAL;
    bool scored_ahead = false;  // f_ahead, g_ahead (and info_ahead) are the scores at z
    double f_ahead = 0;
    Eigen::VectorXd g_ahead;
    Eigen::MatrixXd info_ahead;
    for (int it = 0; it < max_iterations; ++it) {
      if (Cancelled()) {
        r.cancelled = true;
        r.message = "cancelled";
        return r;
      }
      if (options_.max_evaluations > 0 &&
          evaluations() - evaluations_before > options_.max_evaluations) {
        r.message = fmt::format("stopped after {} evaluations without converging (raise the "
                                "evaluation limit)", evaluations() - evaluations_before);
        return r;
      }
      // BHHH's information is needed where the curvature model starts afresh; the scores at z
      // may be known already from the line search's full step.
      const bool need_info = !bfgs_updates || reset || B.size() == 0;
      double f = 0;
      Eigen::VectorXd g;
      Eigen::MatrixXd info;
      if (scored_ahead && (!need_info || info_ahead.size() > 0)) {
        f = f_ahead;
        g = g_ahead;
        info = info_ahead;
      } else if (!Scores(z, delay, &f, &g, need_info ? &info : nullptr)) {
        r.cancelled = Cancelled();
        r.message = r.cancelled ? "cancelled"
                    : it == 0   ? "the log-likelihood or its score cannot be evaluated at the start"
                                : "the score could not be computed at an accepted point";
        return r;
      }
      r.z = z;
      r.loglik = f;
      ++iterations_;
      Report(stage, z, f, delay);
      // BHHH's information, or (bfgs_updates) that of the first iteration corrected by BFGS
      // updates from the gradient differences along the steps taken: where the model is
      // misspecified (a wrong delay, say) the outer product of the scores is a poor Hessian, and
      // the updates learn the difference.
      scored_ahead = false;
      info_ahead.resize(0, 0);
      bool fresh = false;  // B is BHHH's information at z
      if (need_info) {
        const bool first = B.size() == 0;
        B = info;
        reset = false;
        fresh = true;
        // A better first model where one is known (the Hessian from the standard errors): its
        // finite entries replace BHHH's.
        if (first && first_model)
          for (int i = 0; i < k(); ++i)
            for (int j = 0; j < k(); ++j)
              if (std::isfinite((*first_model)(i, j))) B(i, j) = (*first_model)(i, j);
      } else if (!z_last.empty()) {
        Eigen::VectorXd step(k());
        for (int i = 0; i < k(); ++i) step(i) = z[i] - z_last[i];
        const Eigen::VectorXd y = g_last - g;  // change of the gradient of -objective
        const double sy = step.dot(y);
        const Eigen::VectorXd Bs = B * step;
        const double sBs = step.dot(Bs);
        if (sy > 1e-10 * step.norm() * y.norm() && sBs > 0)
          B += y * y.transpose() / sy - Bs * Bs.transpose() / sBs;
      }
      g_last = g;
      z_last = z;
      std::vector<int> F;
      std::vector<std::pair<int, double>> onto_bound;  // held parameters and their bound
      for (int i = 0; i < k(); ++i) {
        // On a bound, or within kNearBound of it (scaled units), with the gradient pointing out:
        // held, and put on the bound by the step. Without the band a parameter a hair above its
        // bound stays free, and every step clamps it after a dozen halvings.
        const bool at_lower = z[i] <= lower_[i] + kNearBound && g(i) <= 0;
        const bool at_upper = z[i] >= upper_[i] - kNearBound && g(i) >= 0;
        if (!at_lower && !at_upper) F.push_back(i);
        else onto_bound.emplace_back(i, at_lower ? lower_[i] : upper_[i]);
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
        d = NewtonStep(B, g, F);
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
        for (const auto& [i, bound] : onto_bound) {
          z_new[i] = bound;
          predicted += g(i) * (bound - z[i]);
        }
        for (int a = 0; a < m; ++a) {
          const int i = F[a];
          z_new[i] = std::clamp(z[i] + alpha * d(a), lower_[i], upper_[i]);
          predicted += g(i) * (z_new[i] - z[i]);
        }
        // The full step with its scores (they serve the next iteration when it is accepted, as
        // it mostly is); a shorter one with log L alone.
        if (half == 0) {
          if (!Scores(z_new, delay, &f_ahead, &g_ahead, bfgs_updates ? nullptr : &info_ahead))
            f_ahead = -HUGE_VAL;
          f_new = f_ahead;
        } else {
          f_new = Objective(z_new, delay);
        }
        if (std::isfinite(f_new) && f_new >= f + kArmijo * predicted && f_new > f) {
          accepted = true;
          scored_ahead = half == 0;
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
        if (bfgs_updates && !fresh) {  // the updated model misled: start it afresh
          reset = true;
          z_last.clear();
          continue;
        }
        r.converged = expected < kNegligibleImprovement;
        r.message = r.converged ? "at the precision of the log-likelihood (no further increase is possible)"
                                : "the line search found no increase of the log-likelihood";
        return r;
      }
      const double gain = f_new - f;
      z = z_new;
      r.z = z;
      r.loglik = f_new;
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

  // `first_model` (auto only): a curvature model of -objective in scaled units to start from
  // (NaN entries: BHHH's).
  FitResult Fit(std::vector<double> z, const std::vector<int>& delay, const std::string& stage,
                int max_iterations = kMaxBhhhIterations,
                const Eigen::MatrixXd* first_model = nullptr) {
    if (options_.algorithm == Algorithm::kBhhh) return FitBhhh(std::move(z), delay, stage, max_iterations);
    if (options_.algorithm == Algorithm::kAuto) {
      // BHHH with BFGS corrections from the start; where it cannot finish (flat or bound-limited
      // directions), L-BFGS to the full tolerance from its best point.
      FitResult r = FitBhhh(std::move(z), delay, stage, max_iterations, /*bfgs_updates=*/true,
                            first_model);
      if (r.converged || r.cancelled || !std::isfinite(r.loglik)) return r;
      FitResult finished = FitNlopt(r.z, delay, stage, nlopt::LD_LBFGS, options_.ftol_rel);
      return finished.loglik >= r.loglik ? finished : r;
    }
    const nlopt::algorithm algo = options_.algorithm == Algorithm::kLbfgs   ? nlopt::LD_LBFGS
                                  : options_.algorithm == Algorithm::kSlsqp ? nlopt::LD_SLSQP
                                                                            : nlopt::LN_BOBYQA;
    return FitNlopt(std::move(z), delay, stage, algo, options_.ftol_rel);
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
      result.loglik = Objective(z, delay);
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
      double f = -HUGE_VAL;
      Eigen::VectorXd g;
      if (grad.empty()) {
        f = self->Objective(zz, *d->delay);
      } else if (!self->Scores(zz, *d->delay, &f, &g, nullptr)) {
        if (self->Cancelled()) throw nlopt::forced_stop();
        f = -HUGE_VAL;
      }
      if (!std::isfinite(f)) return FailedObjective(zz, grad, *d->best, d->worst_loglik);
      d->worst_loglik = std::min(d->worst_loglik, f);
      if (f > d->best->loglik) {
        d->best->loglik = f;
        d->best->z = zz;
      }
      if (!grad.empty()) {
        ++self->iterations_;
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
  // Runs fit(sub) on a fitter over the same parameters with its own options (threads, evaluation
  // limit, progress passed on under a lock or none), and adds its counts to this one's.
  template <class Fit>
  FitResult Alongside(int threads, int max_evaluations, bool report, Fit&& fit) {
    EstimateOptions sub = options_;
    sub.threads = threads;
    if (max_evaluations > 0) sub.max_evaluations = max_evaluations;
    sub.progress = nullptr;
    if (report && options_.progress)
      sub.progress = [this](const Progress& p) {
        const std::lock_guard<std::mutex> lock(progress_mutex_);
        Progress q = p;
        q.iteration += iterations_.load();
        q.evaluations += evaluations_.load();
        options_.progress(q);
      };
    Fitter f(*this, sub);
    FitResult r = fit(f);
    iterations_.fetch_add(f.iterations());
    evaluations_.fetch_add(f.evaluations());
    return r;
  }

  const filter::Likelihood& lik_;
  const EstimateOptions& options_;
  std::vector<double> theta0_;
  std::vector<int> free_;
  std::vector<double> scale_, lower_, upper_;
  struct FreePrior {
    int i;                          // index into the free parameters
    model::Parameter::Prior prior;  // natural scale
  };
  std::vector<FreePrior> priors_;
  int threads_ = 1;
  std::atomic<int> evaluations_{0};
  std::atomic<int> iterations_{0};
  std::mutex progress_mutex_;
};

}  // namespace gb::estimate::internal
