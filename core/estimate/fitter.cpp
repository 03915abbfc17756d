// The fitter's implementation (fitter.h declares it; estimate.h describes the optimisers).
#include "core/estimate/fitter.h"

#include <algorithm>
#include <cmath>
#include <optional>

#include <Eigen/Dense>
#include <fmt/format.h>
#include <nlopt.hpp>

#include "core/util/parallel.h"

namespace gb::estimate::internal {

namespace {

// What NLopt sees at a point z where log L cannot be evaluated: worse than every point seen, by
// the spread of the values seen so far (at least 1), and a gradient that points back to the best
// point. A finite, moderate value keeps BOBYQA's quadratic models and the quasi-Newton line
// searches usable: 1e300 would swamp them, and a zero gradient reads as a stationary point. The
// optimiser then shortens its step or turns away, as it would from a steep wall.
double FailedObjective(const std::vector<double>& z, std::vector<double>& grad,
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

}  // namespace

Eigen::VectorXd BoxModelStep(const Eigen::MatrixXd& S, const Eigen::VectorXd& gF,
                             const Eigen::VectorXd& lo, const Eigen::VectorXd& hi,
                             const Eigen::VectorXd& newton) {
  const int m = static_cast<int>(gF.size());
  auto inside = [&](const Eigen::VectorXd& d) {
    for (int a = 0; a < m; ++a)
      if (d(a) < lo(a) || d(a) > hi(a)) return false;
    return true;
  };
  if (inside(newton)) return newton;
  Eigen::VectorXd d = Eigen::VectorXd::Zero(m);
  std::vector<char> held(static_cast<std::size_t>(m), 0);
  for (int pass = 0; pass < 4 * m + 4; ++pass) {
    std::vector<int> rest;
    for (int a = 0; a < m; ++a)
      if (!held[static_cast<std::size_t>(a)]) rest.push_back(a);
    Eigen::VectorXd target = d;
    if (!rest.empty()) {
      // S_rr d_r = g_r - S_rW d_W
      Eigen::VectorXd d_held = Eigen::VectorXd::Zero(m);
      for (int a = 0; a < m; ++a)
        if (held[static_cast<std::size_t>(a)]) d_held(a) = d(a);
      const Eigen::VectorXd rhs = gF - S * d_held;
      const Eigen::VectorXd dr = Fitter::NewtonStep(S, rhs, rest);
      if (dr.size() == 0) return newton;  // singular: the clamped step as before
      for (std::size_t r = 0; r < rest.size(); ++r)
        target(rest[r]) = dr(static_cast<Eigen::Index>(r));
    }
    if (!inside(target)) {
      double alpha = 1.0;
      int blocking = -1;
      for (const int a : rest) {
        const double delta = target(a) - d(a);
        const double room = delta > 0 ? hi(a) - d(a) : delta < 0 ? lo(a) - d(a) : 0.0;
        if (delta != 0.0 && room / delta < alpha) {
          alpha = std::max(0.0, room / delta);
          blocking = a;
        }
      }
      d += alpha * (target - d);
      if (blocking >= 0) {  // exactly on its face
        d(blocking) = target(blocking) > d(blocking) ? hi(blocking) : lo(blocking);
        held[static_cast<std::size_t>(blocking)] = 1;
      }
      continue;
    }
    d = target;
    // The model's gradient at d; a held entry on its lower face whose gradient points up (into
    // the box), or on its upper face pointing down, is released.
    const Eigen::VectorXd r = gF - S * d;
    int release = -1;
    double most = 0.0;
    for (int a = 0; a < m; ++a) {
      if (!held[static_cast<std::size_t>(a)]) continue;
      const double into = d(a) <= lo(a) ? r(a) : -r(a);
      if (into > most) {
        most = into;
        release = a;
      }
    }
    if (release < 0) return d;
    held[static_cast<std::size_t>(release)] = 0;
  }
  return d;
}

Eigen::VectorXd TrustRegionStep(const Eigen::MatrixXd& B, const Eigen::VectorXd& g, double radius) {
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(B);
  const Eigen::VectorXd& lam = es.eigenvalues();  // ascending
  const Eigen::MatrixXd& Q = es.eigenvectors();
  const Eigen::VectorXd gamma = Q.transpose() * g;
  const Eigen::Index m = lam.size();
  const double tiny = 1e-12 * std::max(1.0, lam.cwiseAbs().maxCoeff());
  auto coefficients = [&](double l) {
    Eigen::VectorXd c(m);
    for (Eigen::Index i = 0; i < m; ++i) {
      const double denominator = lam(i) + l;
      c(i) = denominator > tiny ? gamma(i) / denominator : 0.0;
    }
    return c;
  };
  const double lmin = lam(0);
  if (lmin > tiny) {
    const Eigen::VectorXd c = coefficients(0.0);
    if (c.norm() <= radius) return Q * c;
  }
  const double lo0 = std::max(0.0, -lmin);
  Eigen::VectorXd c = coefficients(lo0);
  if (c.norm() <= radius) {
    // ‖e‖ stays within the radius down to the smallest λ allowed: with negative curvature, the
    // rest of the radius goes along its eigenvector (the sign that does not lower g'e).
    if (lmin < -tiny) {
      const double tau = std::sqrt(std::max(0.0, radius * radius - c.squaredNorm()));
      c(0) += gamma(0) >= 0 ? tau : -tau;
    }
    return Q * c;
  }
  double lo = lo0, hi = lo0 + g.norm() / radius + tiny;
  for (int it = 0; it < 200 && hi - lo > 1e-14 * std::max(1.0, hi); ++it) {
    const double mid = 0.5 * (lo + hi);
    (coefficients(mid).norm() > radius ? lo : hi) = mid;
  }
  return Q * coefficients(hi);
}

void AddCrept(const std::vector<int>& more, FitResult* r) {
  r->crept.insert(r->crept.end(), more.begin(), more.end());
  std::sort(r->crept.begin(), r->crept.end());
  r->crept.erase(std::unique(r->crept.begin(), r->crept.end()), r->crept.end());
}

Fitter::Fitter(const filter::Likelihood& lik, const EstimateOptions& options,
               std::span<const double> theta_base, std::span<const int> held)
    : lik_(lik), options_(options) {
  const auto& spec = lik.spec();
  theta0_ = theta_base.empty() ? spec.Values()
                               : std::vector<double>(theta_base.begin(), theta_base.end());
  for (std::size_t i = 0; i < spec.parameters.size(); ++i) {
    const auto& p = spec.parameters[i];
    if (p.fixed || std::find(held.begin(), held.end(), static_cast<int>(i)) != held.end()) continue;
    free_.push_back(static_cast<int>(i));
    const double start = theta0_[i];
    const bool log = options.log_scale && p.lower && *p.lower > 0 && start > 0;
    const double s = log                    ? 1.0
                     : start != 0           ? std::abs(start)
                     : (p.lower && p.upper) ? (*p.upper - *p.lower) / 10
                                            : 1.0;
    log_.push_back(log ? 1 : 0);
    scale_.push_back(s);
    if (log) {
      lower_.push_back(std::log(*p.lower));
      upper_.push_back(p.upper ? std::log(*p.upper) : HUGE_VAL);
    } else {
      lower_.push_back(p.lower ? *p.lower / s : -HUGE_VAL);
      upper_.push_back(p.upper ? *p.upper / s : HUGE_VAL);
    }
    if (p.prior) priors_.push_back({static_cast<int>(free_.size()) - 1, *p.prior});
  }
  threads_ = options.threads > 0 ? options.threads : HardwareThreads();
}

FitResult Fitter::FitAlongside(std::vector<double> z, const std::vector<int>& delay,
                               const std::string& stage, int threads, int max_evaluations,
                               const Eigen::MatrixXd* first_model, const ThreadShare* share,
                               filter::LinearGradient gradient) {
  return Alongside(
      threads, max_evaluations, /*report=*/true,
      [&](Fitter& f) { return f.Fit(std::move(z), delay, stage, kMaxBhhhIterations, first_model); },
      share, gradient);
}

FitResult Fitter::ExploreAlongside(std::vector<double> z, const std::vector<int>& delay,
                                   int iterations, int threads, const Eigen::MatrixXd* first_model,
                                   double level, const ThreadShare* share) {
  return Alongside(
      threads, kExploreEvaluations * iterations, /*report=*/false,
      [&](Fitter& f) {
        const bool watch = std::isfinite(level);
        FitResult r = f.FitBhhh(std::move(z), delay, "fitting", iterations, /*bfgs_updates=*/true,
                                first_model, /*hand_over=*/watch);
        if (r.crawling) {
          // Crawling at the level: back at the estimate's optimum, or on its valley. (Below it, a
          // fit may still be on its way to a better basin: building 3's p22 released from 5929.72
          // crawls below that before it climbs to 5930.12.)
          if (std::abs(r.loglik - level) <= SameLevel(level)) return r;
          const Eigen::MatrixXd model = r.model;
          FitResult on = f.FitBhhh(r.z, delay, "fitting", iterations - f.iterations(),
                                   /*bfgs_updates=*/true, &model);
          if (on.cancelled || on.loglik >= r.loglik) r = std::move(on);
          r.crawling = false;
        }
        // Stalled before its iterations were up (flat or bound-limited directions, where auto goes
        // on with L-BFGS): L-BFGS, within the same evaluation limit again.
        if (r.converged || r.cancelled || !std::isfinite(r.loglik) || f.iterations() >= iterations)
          return r;
        FitResult on = f.FitNlopt(r.z, delay, "fitting", Algorithm::kLbfgs, options_.ftol_rel);
        if (on.cancelled || on.loglik >= r.loglik) {
          on.model = std::move(r.model);  // BHHH's, for the next round
          return on;
        }
        return r;
      },
      share);
}

Fitter::Fitter(const Fitter& base, const EstimateOptions& options)
    : lik_(base.lik_),
      options_(options),
      theta0_(base.theta0_),
      free_(base.free_),
      scale_(base.scale_),
      lower_(base.lower_),
      upper_(base.upper_),
      log_(base.log_),
      priors_(base.priors_),
      share_(base.share_) {
  threads_ = options.threads > 0 ? options.threads : HardwareThreads();
}

double Fitter::LogLik(const std::vector<double>& z, const std::vector<int>& delay, long* n_obs,
                      int threads) {
  evaluations_.fetch_add(1);
  auto l = lik_.Evaluate(Theta(z), delay, nullptr, threads > 0 ? threads : Threads());
  if (!l) return -std::numeric_limits<double>::infinity();
  if (n_obs) *n_obs = l->n_obs;
  return l->loglik;
}

void Fitter::AddPriorDerivatives(const std::vector<double>& z, Eigen::VectorXd* g,
                                 Eigen::MatrixXd* info) const {
  for (const auto& [i, prior] : priors_) {
    // d/dz log N(θ | m, s²) = -(θ - m) / s² dθ/dz; the information (θ' / s)² (Fisher's: the
    // second derivative of the log scale's transform does not enter it).
    const double slope = Slope(i, z[i]);
    (*g)(i) -= (ThetaOf(i, z[i]) - prior.mean) / (prior.sd * prior.sd) * slope;
    if (info) (*info)(i, i) += slope * slope / (prior.sd * prior.sd);
  }
}

bool Fitter::Scores(const std::vector<double>& z, const std::vector<int>& delay, double* f,
                    Eigen::VectorXd* g, Eigen::MatrixXd* info, bool split, bool* exact) {
  if (exact) *exact = true;
  if (Cancelled()) return false;
  // The iterated extended Kalman filter has no exact score: differences of its terms, as where
  // an exact score fails (and, not being exact, they are not differenced again for the Hessian).
  if (!lik_.exact_scores() || options_.score_differences) {
    if (exact) *exact = false;
    return ScoresByDifferences(z, delay, f, g, info);
  }
  const std::vector<double> theta = Theta(z);
  // The free parameters in chunks on the threads, each chunk's derivatives by forward
  // sensitivities or by differentiating the filter's own algebra, whose cost grows with the
  // chunk; one chunk at least, also with no free parameter (only a delay is estimated). The
  // EKF's adjoint costs the same for any chunk: one chunk, with the records (the series of a
  // joint fit) on the threads instead.
  const bool adjoint = !info && lik_.UsesAdjoint(static_cast<std::size_t>(k()));
  // A linear model's gradient alone comes from an adjoint, in one piece (in chunks its last
  // bits would turn on them): the steady state's (forward sensitivities up to it), until a
  // gradient where it covered fewer than nine rows in ten; from then on (a fit whose
  // covariances settle late: the fuel film's profile at delays far from the estimate) the
  // whole recursion's (the threshold measured on the fuel film's job against half and always,
  // docs/benchmarks.md). Which one a gradient is turns on the fit's own evaluations, never on
  // the threads.
  const bool one_piece = !info && split && lik_.GradientInOnePiece();
  const int threads = Threads();
  const int chunks = split && !adjoint && k() > 1 && !one_piece
                         ? std::clamp(std::min(threads, k() / 2), 1, k())
                         : 1;
  const filter::LinearGradient linear_gradient =
      !split || one_piece ? linear_gradient_ : filter::LinearGradient::kForward;
  std::vector<std::vector<int>> which(chunks);
  for (int i = 0; i < k(); ++i) which[i * chunks / k()].push_back(free_[i]);
  std::vector<Eigen::VectorXd> g_part(chunks);
  std::vector<Eigen::MatrixXd> J_part(chunks);
  std::vector<double> value(chunks, 0.0);
  std::vector<char> ok(chunks, 0);
  evaluations_.fetch_add(1);
  ParallelFor(chunks, chunks, [&](int c) {
    auto l = lik_.EvaluateWithScore(theta, delay, which[c], &g_part[c], info ? &J_part[c] : nullptr,
                                    split ? std::max(1, threads / chunks) : 1, linear_gradient);
    ok[c] = l.ok();
    if (l) value[c] = l->loglik;
    if (l && one_piece && linear_gradient_ == filter::LinearGradient::kSteadyState &&
        10 * l->adjoint * static_cast<long>(lik_.spec().outputs.size()) < 9 * l->n_obs)
      linear_gradient_ = filter::LinearGradient::kAdjoint;
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
      const double slope = Slope(at + a, z[at + a]);
      (*g)(at + a) = g_part[c](a) * slope;
      if (info) J.col(at + a) = J_part[c].col(a) * slope;
    }
    at += n;
  }
  if (info) *info = J.transpose() * J;
  AddPriorDerivatives(z, g, info);
  return std::isfinite(*f) && g->allFinite() && (!info || info->allFinite());
}

bool Fitter::ScoresByDifferences(const std::vector<double>& z, const std::vector<int>& delay,
                                 double* f, Eigen::VectorXd* g, Eigen::MatrixXd* info) {
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
  ParallelFor(static_cast<int>(points.size()), Threads(), [&](int p) {
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
    const double width =
        (plus >= 0 ? points[plus].step : 0.0) - (minus >= 0 ? points[minus].step : 0.0);
    if (width == 0.0) return false;
    for (Eigen::Index j = 0; j < n; ++j) S(j, i) = ((*a)[j] - (*b)[j]) / width;
  }
  *f = l0->loglik + LogPrior(z);
  *g = S.colwise().sum().transpose();
  if (info) *info = S.transpose() * S;
  AddPriorDerivatives(z, g, info);
  return std::isfinite(*f) && g->allFinite() && (!info || info->allFinite());
}

Eigen::VectorXd Fitter::NewtonStep(const Eigen::MatrixXd& info, const Eigen::VectorXd& g,
                                   const std::vector<int>& F) {
  const int m = static_cast<int>(F.size());
  const Eigen::MatrixXd I = SubMatrix(info, F);
  Eigen::VectorXd gF(m);
  for (int a = 0; a < m; ++a) gF(a) = g(F[a]);
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

Eigen::MatrixXd Fitter::SubMatrix(const Eigen::MatrixXd& B, const std::vector<int>& F) {
  const int m = static_cast<int>(F.size());
  Eigen::MatrixXd S(m, m);
  for (int a = 0; a < m; ++a)
    for (int b = 0; b < m; ++b) S(a, b) = B(F[a], F[b]);
  return S;
}

FitResult Fitter::FitBhhh(std::vector<double> z, const std::vector<int>& delay,
                          const std::string& stage, int max_iterations, bool bfgs_updates,
                          const Eigen::MatrixXd* first_model, bool hand_over,
                          bool rescale_creepers) {
  Eigen::MatrixXd B;  // the curvature model of -objective (scaled units)
  FitResult r = BhhhLoop(std::move(z), delay, stage, max_iterations, bfgs_updates, first_model,
                         hand_over, rescale_creepers, B);
  r.model = std::move(B);
  return r;
}

FitResult Fitter::BhhhLoop(std::vector<double> z, const std::vector<int>& delay,
                           const std::string& stage, int max_iterations, bool bfgs_updates,
                           const Eigen::MatrixXd* first_model, bool hand_over,
                           bool rescale_creepers, Eigen::MatrixXd& B) {
  FitResult r;
  const int evaluations_before = evaluations();
  Eigen::VectorXd g_last;  // the gradient at the last accepted point
  std::vector<double> z_last;
  bool reset = true;  // take BHHH's information afresh
  if (StartInBox(&z, delay, &r)) return r;
  double last_expected = HUGE_VAL;
  std::vector<double> recent_gains;                // of the accepted steps
  std::vector<std::vector<double>> recent_points;  // the last kCrawlWindow + 1 accepted points
  if (rescale_creepers) recent_points.push_back(z);
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
    if (OverEvaluationLimit(evaluations_before, &r.message)) return r;
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
      if (first) Overlay(first_model, &B);
    } else if (!z_last.empty()) {
      Eigen::VectorXd step(k());
      for (int i = 0; i < k(); ++i) step(i) = z[i] - z_last[i];
      BfgsUpdate(step, g_last - g, &B);
    }
    g_last = g;
    z_last = z;
    std::vector<int> F;
    std::vector<std::pair<int, double>> onto_bound;  // held parameters and their bound
    SplitAtBounds(z, g, &F, &onto_bound);
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
    // Where the Newton step leaves the box, the model's best step inside it is not the step
    // clamped: solve the model's box-constrained problem (a parameter that the model drives
    // onto its bound held there, the others re-solved with it).
    const int m = static_cast<int>(F.size());
    gF.resize(m);
    Eigen::VectorXd lo(m), hi(m);
    for (int a = 0; a < m; ++a) {
      gF(a) = g(F[a]);
      lo(a) = lower_[F[a]] - z[F[a]];
      hi(a) = upper_[F[a]] - z[F[a]];
    }
    const Eigen::MatrixXd BF = SubMatrix(B, F);
    const Eigen::VectorXd in_box = BoxModelStep(BF, gF, lo, hi, d);
    const bool boxed = in_box != d;
    d = in_box;
    // The model's gain: the Newton decrement / 2, or g'd - d'Bd/2 for a step the box bent.
    const double expected = boxed ? gF.dot(d) - 0.5 * d.dot(BF * d) : 0.5 * gF.dot(d);
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
    // On a log scale a unit step multiplies a parameter by e: the line search starts within
    // kMaxLogStep there (a flow coefficient multiplied by e^5 turns a model's ODE stiff, and one
    // evaluation there costs tens of ordinary ones).
    int first_exp = 0;
    for (int a = 0; a < m; ++a)
      if (log_[F[a]])
        while (std::ldexp(std::abs(d(a)), first_exp) > kMaxLogStep && first_exp > -kMaxHalvings)
          --first_exp;
    for (int half = 0, alpha_exp = first_exp; half < kMaxHalvings; ++half, --alpha_exp) {
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
      r.message = r.converged
                      ? "at the precision of the log-likelihood (no further increase is possible)"
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
    recent_gains.push_back(gain);
    if (rescale_creepers) {
      recent_points.push_back(z);
      if (static_cast<int>(recent_points.size()) > kCrawlWindow + 1)
        recent_points.erase(recent_points.begin());
    }
    if ((hand_over || rescale_creepers) && static_cast<int>(recent_gains.size()) >= kCrawlWindow) {
      // Crawling: small gains that shrink too slowly to be worth waiting for. At the rate ρ they
      // shrank by over the window (linear convergence), the gain falls below kNegligibleGain after
      // log(kNegligibleGain / gain) / log ρ more steps; where that is more than the k gradients
      // the exact Hessian costs, the end game takes over.
      const std::size_t first = recent_gains.size() - kCrawlWindow;
      double sum = 0;
      for (std::size_t j = first; j < recent_gains.size(); ++j) sum += recent_gains[j];
      const double last = recent_gains.back();
      const double rate = std::pow(last / recent_gains[first], 1.0 / (kCrawlWindow - 1));
      const double steps_left = last <= kNegligibleGain ? 0.0
                                : rate >= 1 || !(rate > 0)
                                    ? HUGE_VAL
                                    : std::log(kNegligibleGain / last) / std::log(rate);
      if (sum < kCrawlGain && steps_left > std::max(k(), kCrawlWindow)) {
        if (rescale_creepers) r.creeping = Creeping(recent_points);
        if (hand_over || !r.creeping.empty()) {
          r.crawling = true;
          r.message = r.creeping.empty() ? "gaining too slowly"
                                         : "gaining too slowly, positive parameters creeping "
                                           "towards their lower bounds";
          return r;
        }
      }
    }
  }
  r.converged = last_expected < kNegligibleImprovement;
  r.message = r.converged
                  ? "the expected improvement left is negligible"
                  : fmt::format("stopped after {} iterations without converging", max_iterations);
  return r;
}

bool Fitter::ExactHessian(const std::vector<double>& z, const std::vector<int>& delay,
                          const Eigen::VectorXd& g, const std::vector<int>& which,
                          Eigen::MatrixXd* H) {
  const int m = static_cast<int>(which.size());
  std::vector<Eigen::VectorXd> column(m);
  std::vector<double> step(m, 0.0);
  ParallelFor(m, Threads(), [&](int a) {
    const int i = which[a];
    const double h = kGradientHessianStep * std::max(std::abs(z[i]), 1.0);
    for (const double signed_h : {h, -h}) {
      std::vector<double> zp = z;
      zp[i] += signed_h;
      if (zp[i] > upper_[i] || zp[i] < lower_[i]) continue;
      double value = 0;
      Eigen::VectorXd gp;
      if (!Scores(zp, delay, &value, &gp, nullptr, /*split=*/false)) continue;
      column[a] = -(gp - g) / signed_h;
      step[a] = signed_h;
      return;
    }
  });
  if (Cancelled()) return false;
  for (int a = 0; a < m; ++a)
    if (step[a] == 0.0) return false;
  Eigen::MatrixXd block(m, m);
  for (int a = 0; a < m; ++a)
    for (int b = 0; b < m; ++b) block(b, a) = column[a](which[b]);
  block = (block + block.transpose()) / 2;
  for (int a = 0; a < m; ++a)
    for (int b = 0; b < m; ++b) (*H)(which[a], which[b]) = block(a, b);
  return true;
}

bool Fitter::StartInBox(std::vector<double>* z, const std::vector<int>& delay, FitResult* r) {
  for (int i = 0; i < k(); ++i) (*z)[i] = std::clamp((*z)[i], lower_[i], upper_[i]);
  r->z = *z;
  if (k() > 0) return false;
  r->loglik = Objective(*z, delay);
  r->converged = std::isfinite(r->loglik);
  r->message = r->converged ? "no free parameters" : "the log-likelihood cannot be evaluated";
  return true;
}

void Fitter::SplitAtBounds(const std::vector<double>& z, const Eigen::VectorXd& g,
                           std::vector<int>* free_set,
                           std::vector<std::pair<int, double>>* held) const {
  for (int i = 0; i < k(); ++i) {
    // On a bound, or within kNearBound of it (scaled units), with the gradient pointing out:
    // held, and put on the bound by the step. Without the band a parameter a hair above its
    // bound stays free, and every step clamps it after a dozen halvings.
    const bool at_lower = z[i] <= lower_[i] + kNearBound && g(i) <= 0;
    const bool at_upper = z[i] >= upper_[i] - kNearBound && g(i) >= 0;
    if (!at_lower && !at_upper)
      free_set->push_back(i);
    else
      held->emplace_back(i, at_lower ? lower_[i] : upper_[i]);
  }
}

std::vector<int> Fitter::Creeping(const std::vector<std::vector<double>>& points) const {
  std::vector<int> creeping;
  if (static_cast<int>(points.size()) != kCrawlWindow + 1) return creeping;
  for (int i = 0; i < k(); ++i) {
    if (!OnLogScaleThere(i)) continue;
    bool fell = true;
    for (std::size_t j = 1; j < points.size() && fell; ++j) fell = points[j][i] < points[j - 1][i];
    if (fell && points.front()[i] >= (1 + kCreep) * points.back()[i]) creeping.push_back(i);
  }
  return creeping;
}

void Fitter::Overlay(const Eigen::MatrixXd* model, Eigen::MatrixXd* B) {
  if (!model) return;
  for (Eigen::Index i = 0; i < B->rows(); ++i)
    for (Eigen::Index j = 0; j < B->cols(); ++j)
      if (std::isfinite((*model)(i, j))) (*B)(i, j) = (*model)(i, j);
}

void Fitter::BfgsUpdate(const Eigen::VectorXd& s, const Eigen::VectorXd& y, Eigen::MatrixXd* B) {
  const double sy = s.dot(y);
  const Eigen::VectorXd Bs = *B * s;
  const double sBs = s.dot(Bs);
  if (sy > 1e-10 * s.norm() * y.norm() && sBs > 0)
    *B += y * y.transpose() / sy - Bs * Bs.transpose() / sBs;
}

bool Fitter::OverEvaluationLimit(int evaluations_before, std::string* message) const {
  const int used = evaluations() - evaluations_before;
  if (options_.max_evaluations <= 0 || used <= options_.max_evaluations) return false;
  *message = fmt::format(
      "stopped after {} evaluations without converging (raise the evaluation "
      "limit)",
      used);
  return true;
}

FitResult Fitter::FitTrustRegion(std::vector<double> z, const std::vector<int>& delay,
                                 const std::string& stage, int max_iterations,
                                 const Eigen::MatrixXd* first_model, bool exact_first) {
  FitResult r;
  if (StartInBox(&z, delay, &r)) return r;
  const int evaluations_before = evaluations();
  double f = 0;
  Eigen::VectorXd g;
  Eigen::MatrixXd B;  // the curvature model of -objective at z
  if (!Scores(z, delay, &f, &g, &B)) {
    r.cancelled = Cancelled();
    r.message = r.cancelled ? "cancelled"
                            : "the log-likelihood or its score cannot be evaluated at the start";
    return r;
  }
  Overlay(first_model, &B);
  r.loglik = f;
  Eigen::VectorXd D = Eigen::VectorXd::Zero(k());  // the trust region's scaling, √diag B at most
  double radius = -1;                              // set by the first step
  bool exact_here = false;                         // B is the exact Hessian at z
  bool been_exact = false;  // B was the exact Hessian once (then SR1 updates: it may be indefinite)
  int since_exact = 0;      // accepted steps since B last was the exact Hessian
  int tiny_gains = 0;       // accepted steps in a row that gained and promised next to nothing
  auto finish = [&](bool converged, std::string message) {
    r.converged = converged;
    r.message = std::move(message);
    r.model = B;
    return r;
  };
  // B becomes the exact Hessian at z over the parameters F (false where it cannot be computed).
  auto make_exact = [&](const std::vector<int>& F) {
    if (!ExactHessian(z, delay, g, F, &B)) return false;
    exact_here = been_exact = true;
    since_exact = 0;
    return true;
  };
  for (int it = 0; it < max_iterations; ++it) {
    if (Cancelled()) {
      r.cancelled = true;
      return finish(false, "cancelled");
    }
    if (std::string over; OverEvaluationLimit(evaluations_before, &over))
      return finish(false, std::move(over));
    ++iterations_;
    Report(stage, z, f, delay);
    std::vector<int> F;
    std::vector<std::pair<int, double>> onto_bound;  // held parameters and their bound
    SplitAtBounds(z, g, &F, &onto_bound);
    if (F.empty()) return finish(true, "every free parameter is held at a bound");
    if (!exact_here && (exact_first || since_exact >= std::max(kExactEvery, k()))) {
      exact_first = false;
      if (!make_exact(F) && Cancelled()) continue;
    }
    const int m = static_cast<int>(F.size());
    Eigen::MatrixXd BF(m, m);
    Eigen::VectorXd gF(m);
    for (int a = 0; a < m; ++a) {
      gF(a) = g(F[a]);
      D(F[a]) = std::max(D(F[a]), std::sqrt(std::abs(B(F[a], F[a]))));
    }
    Eigen::VectorXd DF(m);
    const double d_floor = 1e-8 * std::max(1e-300, D.maxCoeff());
    for (int a = 0; a < m; ++a) {
      DF(a) = std::max(D(F[a]), d_floor);
      for (int b = 0; b < m; ++b) BF(a, b) = B(F[a], F[b]) / (DF(a) * DF(b));
    }
    const Eigen::VectorXd gs = gF.cwiseQuotient(DF);
    // The increase the model promises for its unconstrained maximum (infinite where B is not
    // positive definite on F): below the tolerance the fit has converged, if B can be trusted.
    const Eigen::LLT<Eigen::MatrixXd> llt(BF);
    const bool definite = llt.info() == Eigen::Success;
    const Eigen::VectorXd newton = definite ? Eigen::VectorXd(llt.solve(gs)) : Eigen::VectorXd();
    const double decrement = definite && newton.allFinite() ? 0.5 * gs.dot(newton) : HUGE_VAL;
    const double tol = std::max(options_.ftol_rel * std::abs(f), 1e-12);
    // A quasi-Newton model's promise is checked with the exact Hessian first.
    if (decrement < tol) {
      if (exact_here || been_exact || !make_exact(F)) {
        if (Cancelled()) continue;
        return finish(true, "the expected improvement of log L is below the tolerance");
      }
      continue;  // check again with the exact Hessian
    }
    if (radius < 0) radius = definite && newton.allFinite() ? newton.norm() : DF.norm();
    const Eigen::VectorXd e = TrustRegionStep(BF, gs, radius);
    std::vector<double> z_new = z;
    for (const auto& [i, bound] : onto_bound) z_new[i] = bound;
    for (int a = 0; a < m; ++a)
      z_new[F[a]] = std::clamp(z[F[a]] + e(a) / DF(a), lower_[F[a]], upper_[F[a]]);
    Eigen::VectorXd s(k());
    for (int i = 0; i < k(); ++i) s(i) = z_new[i] - z[i];
    const double predicted = g.dot(s) - 0.5 * s.dot(B * s);
    double step_norm = 0;
    for (int a = 0; a < m; ++a) step_norm += std::pow(DF(a) * s(F[a]), 2);
    step_norm = std::sqrt(step_norm);
    double f_new = -HUGE_VAL;
    Eigen::VectorXd g_new;
    if (predicted > 0 && step_norm > 0 && !Scores(z_new, delay, &f_new, &g_new, nullptr))
      f_new = -HUGE_VAL;
    if (Cancelled()) continue;
    const double ratio = predicted > 0 ? (f_new - f) / predicted : -1.0;
    if (!(ratio >= kShrinkRatio))
      radius = kShrinkRatio * std::min(radius, step_norm);
    else if (ratio > kGrowRatio && step_norm > 0.99 * radius)
      radius *= 2;
    if (!(ratio > kAcceptRatio && f_new > f)) {
      // No increase: the radius shrank. Below the rounding of the parameters nothing is left to
      // try but the exact Hessian, once.
      double size = 0;
      for (int a = 0; a < m; ++a) size += std::pow(DF(a) * std::max(std::abs(z[F[a]]), 1.0), 2);
      if (radius > 1e-12 * std::sqrt(size)) continue;
      if (!exact_here && make_exact(F)) {
        radius = -1;
        continue;
      }
      if (Cancelled()) continue;
      const bool converged = decrement < kNegligibleImprovement;
      return finish(converged, converged
                                   ? "at the precision of the log-likelihood (no further increase "
                                     "is possible)"
                                   : "the trust region shrank to nothing without an increase of "
                                     "the log-likelihood");
    }
    // Accepted: the model learns from the gradient's change along the step.
    const Eigen::VectorXd y = g - g_new;  // change of the gradient of -objective
    if (been_exact) {                     // SR1: keeps the curvature's sign, which a saddle needs
      const Eigen::VectorXd v = y - B * s;
      const double vs = v.dot(s);
      if (std::abs(vs) > 1e-8 * v.norm() * s.norm()) B += v * v.transpose() / vs;
    } else {
      BfgsUpdate(s, y, &B);
    }
    const double gain = f_new - f;
    z = std::move(z_new);
    f = f_new;
    g = std::move(g_new);
    exact_here = false;
    ++since_exact;
    r.z = z;
    r.loglik = f;
    // Steps that gain nothing measurable where the model (from the exact Hessian) promises
    // little more: converged. (A flat or nearly singular direction keeps the Newton decrement
    // large while the steps along it gain nothing.)
    tiny_gains =
        gain < kNegligibleImprovement && predicted < kNegligibleImprovement ? tiny_gains + 1 : 0;
    if (been_exact && tiny_gains >= 3) return finish(true, "the log-likelihood stopped increasing");
  }
  return finish(false,
                fmt::format("stopped after {} iterations without converging", max_iterations));
}

FitResult Fitter::Fit(std::vector<double> z, const std::vector<int>& delay,
                      const std::string& stage, int max_iterations,
                      const Eigen::MatrixXd* first_model) {
  if (options_.algorithm == Algorithm::kBhhh)
    return FitBhhh(std::move(z), delay, stage, max_iterations);
  if (options_.algorithm == Algorithm::kAuto) {
    // BHHH with BFGS corrections from the start; where it cannot finish (flat or bound-limited
    // directions), L-BFGS to the full tolerance from its best point.
    FitResult r = FitBhhh(std::move(z), delay, stage, max_iterations, /*bfgs_updates=*/true,
                          first_model, /*hand_over=*/false, /*rescale_creepers=*/true);
    if (!r.creeping.empty() && !r.cancelled) {
      // A crawl down a valley along which positive parameters fall towards their lower bounds
      // (the Cascaded Tanks SDE's upper outflow coefficient, traded against its exponent and the
      // overflow level over two decades): on their log scale the valley is straight.
      FitResult on = FitOnLogScale(r.z, delay, stage, 0, &r.creeping);
      if (on.cancelled || on.loglik >= r.loglik) {
        AddCrept(r.creeping, &on);
        return on;
      }
      r.crawling = false;
      r.creeping.clear();
    }
    if (r.converged || r.cancelled || !std::isfinite(r.loglik)) return r;
    FitResult finished = FitNlopt(r.z, delay, stage, Algorithm::kLbfgs, options_.ftol_rel);
    return finished.loglik >= r.loglik ? finished : r;
  }
  if (options_.algorithm == Algorithm::kTrustRegion) {
    // The same while it gains well; where it crawls or its line search fails, the trust-region
    // end game from the exact Hessian.
    FitResult r = FitBhhh(std::move(z), delay, stage, max_iterations, /*bfgs_updates=*/true,
                          first_model, /*hand_over=*/true);
    if (r.converged || r.cancelled || !std::isfinite(r.loglik)) return r;
    FitResult finished = FitTrustRegion(r.z, delay, stage, max_iterations, &r.model,
                                        /*exact_first=*/true);
    return finished.loglik >= r.loglik || finished.cancelled ? finished : r;
  }
  return FitNlopt(std::move(z), delay, stage, options_.algorithm, options_.ftol_rel);
}

FitResult Fitter::FitNlopt(std::vector<double> z, const std::vector<int>& delay,
                           const std::string& stage, Algorithm algorithm, double ftol_rel) {
  const nlopt::algorithm algo = algorithm == Algorithm::kLbfgs   ? nlopt::LD_LBFGS
                                : algorithm == Algorithm::kSlsqp ? nlopt::LD_SLSQP
                                                                 : nlopt::LN_BOBYQA;
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
      case nlopt::FTOL_REACHED:
        result.message = "relative tolerance on the objective reached";
        break;
      case nlopt::XTOL_REACHED:
        result.message = "relative tolerance on the parameters reached";
        break;
      case nlopt::MAXEVAL_REACHED:
        result.message = fmt::format(
            "stopped after {} evaluations without converging "
            "(raise the evaluation limit)",
            options_.max_evaluations);
        break;
      default:
        result.message = "the optimiser reported success";
        break;
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

void Fitter::Report(const std::string& stage, const std::vector<double>& z, double loglik,
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

EstimateOptions Fitter::SubOptions(int threads, int max_evaluations) {
  EstimateOptions sub = options_;
  sub.threads = threads;
  if (max_evaluations > 0) sub.max_evaluations = max_evaluations;
  sub.progress = nullptr;
  if (options_.progress)
    sub.progress = [this](const Progress& p) {
      const std::lock_guard<std::mutex> lock(progress_mutex_);
      Progress q = p;
      q.iteration += iterations_.load();
      q.evaluations += evaluations_.load();
      options_.progress(q);
    };
  return sub;
}

FitResult Fitter::Alongside(int threads, int max_evaluations, bool report,
                            const std::function<FitResult(Fitter&)>& fit, const ThreadShare* share,
                            filter::LinearGradient gradient) {
  EstimateOptions sub = SubOptions(threads, max_evaluations);
  if (!report) sub.progress = nullptr;
  Fitter f(*this, sub);
  if (share) f.share_ = share;
  f.linear_gradient_ = gradient;
  FitResult r = fit(f);
  r.linear_gradient = f.linear_gradient_;
  AddWork(f);
  return r;
}

bool Fitter::AnyOnLogScale() const {
  for (int i = 0; i < k(); ++i)
    if (OnLogScaleThere(i)) return true;
  return false;
}

FitResult Fitter::FitOnLogScale(const std::vector<double>& z, const std::vector<int>& delay,
                                const std::string& stage, int max_evaluations,
                                const std::vector<int>* which) {
  const std::vector<double> theta = Theta(z);
  // (Its gradients are taken as this fitter's were.)
  FitResult r = Alongside(
      Threads(), max_evaluations, true,
      [&](Fitter& f) {
        for (int i = 0; i < k(); ++i) {
          if (!OnLogScaleThere(i) ||
              (which && std::find(which->begin(), which->end(), i) == which->end()))
            continue;
          f.log_[i] = 1;
          f.lower_[i] = std::log(lower_[i] * scale_[i]);
          f.upper_[i] = std::isfinite(upper_[i]) ? std::log(upper_[i] * scale_[i]) : HUGE_VAL;
        }
        std::vector<double> zl(k());
        for (int i = 0; i < k(); ++i) zl[i] = f.ZOf(i, theta[free_[i]]);
        FitResult fl = f.Fit(zl, delay, stage);
        const std::vector<double> theta_end = f.Theta(fl.z);
        for (int i = 0; i < k(); ++i)
          fl.z[i] = std::clamp(ZOf(i, theta_end[free_[i]]), lower_[i], upper_[i]);
        fl.model.resize(0, 0);
        return fl;
      },
      /*share=*/nullptr, linear_gradient_);
  return r;
}

}  // namespace gb::estimate::internal
