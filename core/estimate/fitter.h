// The fitter behind Estimate and ProfileIntervals (internal to core/estimate): the free
// parameters on a scaled copy, the objective (log L, plus the log priors), its exact gradient and
// BHHH information, and the optimisers (estimate.h describes them).
#pragma once

#include <algorithm>
#include <atomic>
#include <cmath>
#include <functional>
#include <limits>
#include <mutex>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "core/estimate/estimate.h"

namespace gb::estimate::internal {

inline constexpr double kFailedObjective = 1e300;  // -log L reported to NLopt where log L fails
                                                   // before any point could be evaluated
inline constexpr double kGradientStep = 1e-5;  // ≈ eps^(1/3): central differences in scaled units
inline constexpr int kMaxBhhhIterations = 500;
// Fits whose log-likelihoods differ by less than this reached the same optimum (log L units; one
// standard error is worth 0.5).
inline constexpr double kSameOptimum = 1e-3;
// Fits that end within this of each other relative to log L reached the same optimum as far as
// an estimate's outcome goes (issue 33: the same optimum from starts no one can tell apart).
inline constexpr double kSameLevel = 1e-6;
// How far below (or above) `loglik` a fit still ended at its level: kSameOptimum, or kSameLevel
// relative where that is more.
inline double SameLevel(double loglik) {
  return std::max(kSameOptimum, kSameLevel * std::abs(loglik));
}
inline constexpr int kMaxSaddleEscapes = 3;
// Where the estimate is on a bound (starts_on_bound): each extra start is fitted this many
// iterations, and those above the estimate by then fitted on, each within twice the evaluations
// of the plain start's fit (at least kMinExtraEvaluations).
inline constexpr int kExploreIterations = 100;
inline constexpr int kMinExtraEvaluations = 200;
// An explored start's fit stops after kExploreEvaluations times its iterations in evaluations.
inline constexpr int kExploreEvaluations = 3;
// Runaway parameters put back to their starts (ReleaseRunaways): at most this many rounds.
inline constexpr int kReleaseRounds = 3;
// Each released start is fitted this many iterations (at most as many as the plain start's fit
// took evaluations); those that end above the estimate are fitted on.
inline constexpr int kReleaseIterations = 200;
// Where a variance of the diffusion ended on a bound, the model is fitted again with σσ' times this
// (EstimateRun::RelaxDiffusion).
inline constexpr double kRelaxFactor = 10;
// A release that raised log L by more than this reached another basin (log L units; one standard
// error is worth 0.5), whose runaways are released in turn.
inline constexpr double kNewBasin = 1.0;
// Where the exact Hessian at the estimate promises more than this (log L units), the fit may have
// stopped on a curved valley and is fitted on (EstimateRun::Polish).
inline constexpr double kPolishDecrement = 1e-6;
// A parameter without bounds this many times its start's size from its start (scaled units) has
// run off towards ±inf.
inline constexpr double kRunaway = 10;
// The trust-region fit: the exact Hessian replaces the quasi-Newton model after this many
// accepted steps (at least k) without it; the radius test's thresholds.
inline constexpr int kExactEvery = 10;
inline constexpr int kCrawlWindow = 5;
// A positive parameter that fell at every step of a crawl's window, by this fraction of itself
// over the window, creeps towards its lower bound (BhhhLoop's rescale_creepers).
inline constexpr double kCreep = 0.01;
inline constexpr double kCrawlGain = 1.0;
inline constexpr double kNegligibleGain = 1e-6;
inline constexpr double kAcceptRatio = 1e-4;
inline constexpr double kShrinkRatio = 0.25;
inline constexpr double kGrowRatio = 0.75;
inline constexpr double kArmijo = 1e-4;  // sufficient increase along the BHHH direction
inline constexpr int kMaxHalvings = 40;
inline constexpr double kMaxLogStep = 1.0;  // the line search's first step on a log scale, at most
inline constexpr double kFirstDamping = 1e-10;  // Levenberg damping of a singular BHHH information,
inline constexpr int kDampingSteps = 8;         // then x100 per step up to 1e4
inline constexpr double kNearBound = 1e-6;      // scaled: a parameter this close is on its bound
// An expected improvement of log L below this (in log-likelihood units, far below the 0.5 that
// one standard error is worth) counts as converged when rounding stops further progress.
inline constexpr double kNegligibleImprovement = 1e-4;
inline constexpr double kHessianStep = 1e-4;          // ≈ eps^(1/4): second differences, relative
inline constexpr double kGradientHessianStep = 1e-5;  // ≈ eps^(1/3): differences of the gradient
// An eigenvalue of the Hessian below -this x its largest magnitude marks a saddle.
inline constexpr double kNegativeCurvature = 1e-6;
inline constexpr double kAtBoundTol = 1e-7;  // relative distance to a bound that counts as on it
inline constexpr double kUndeterminedEig =
    1e-9;  // eigenvalue of the scaled Hessian below: undetermined
inline constexpr double kHighCorrelation = 0.99;

// The step e that maximises g'e - ½ e'Be subject to ‖e‖ ≤ radius, B symmetric and possibly
// indefinite (Moré & Sorensen 1983): with B = Q Λ Q' and γ = Q'g, e(λ) = Q (γ_i / (λ_i + λ)) for
// the smallest λ ≥ max(0, -λ_min) with ‖e(λ)‖ ≤ radius, found by bisection on the monotone ‖e(λ)‖.
// In the hard case (negative curvature whose eigenvector g does not reach) the step is completed to
// the radius along that eigenvector.
Eigen::VectorXd TrustRegionStep(const Eigen::MatrixXd& B, const Eigen::VectorXd& g, double radius);

// The step d in the box lo <= d <= hi (lo <= 0 <= hi) that maximises the model g'd - d'S d/2
// (S positive definite), by a primal active set from d = 0: each pass solves the entries not
// held with the held ones fixed; a solution outside the box moves to the first face on the
// way and holds it; one inside releases the held entry whose multiplier points into the box
// most, or ends. `newton` (S⁻¹ g) when it lies in the box, or where a reduced system is
// singular. The fit's step where the Newton step leaves the box: a parameter the model drives
// onto its bound is held there and the others re-solved with it, where clamping the Newton
// step would leave them where they were for the parameter's old value.
Eigen::VectorXd BoxModelStep(const Eigen::MatrixXd& S, const Eigen::VectorXd& g,
                             const Eigen::VectorXd& lo, const Eigen::VectorXd& hi,
                             const Eigen::VectorXd& newton);

// ---- 2. the fitter ---------------------------------------------------------------------------

struct FitResult {
  std::vector<double> z;
  Eigen::MatrixXd model;  // auto and BHHH: the curvature model of -objective at z (scaled units)
  double loglik = -std::numeric_limits<double>::infinity();
  bool converged = false;
  bool cancelled = false;
  bool crawling = false;      // BHHH's loop stopped for the end game: it was gaining too slowly
  std::vector<int> creeping;  // it stopped because these parameters crept (rescale_creepers)
  // auto: the parameters the fit went on with on a log scale because they crept towards their
  // lower bounds (in index order). One that ends on that bound reached it along a valley on
  // which log L rose at every step, the others following it: it did not run off.
  std::vector<int> crept;
  std::string message;
  // How a fit alongside (Fitter::Alongside) ended up taking a linear model's gradients
  // (Fitter::Scores): a fit that starts from this one begins where it ended.
  filter::LinearGradient linear_gradient = filter::LinearGradient::kSteadyState;
};

// Adds `more` to r's crept parameters (FitResult::crept), keeping them sorted, each once.
void AddCrept(const std::vector<int>& more, FitResult* r);

// The threads of fits that run side by side (lanes): each unfinished lane's share of `total`, so
// that a fit whose partners are done goes on with all of them (a delay profile's walker up a long
// side, an extra start that takes longer than the others). Any number of threads gives the same
// result (the score's chunks are the same sums), so the share changes only the time.
class ThreadShare {
 public:
  ThreadShare(int total, int lanes) : total_(total), unfinished_(lanes) {}
  int Threads() const { return std::max(1, total_ / std::max(1, unfinished_.load())); }
  void Done() { unfinished_.fetch_sub(1); }

 private:
  int total_;
  std::atomic<int> unfinished_;
};

class Fitter {
 public:
  // Over the model's free parameters, from its start values; or, with `theta_base`, from those
  // values with the parameters `held` (indices into the model's parameters) held too.
  Fitter(const filter::Likelihood& lik, const EstimateOptions& options,
         std::span<const double> theta_base = {}, std::span<const int> held = {});

  // A fitter over the same free parameters and scaling as `base`, with other options (threads,
  // progress): for fits that run beside each other.
  Fitter(const Fitter& base, const EstimateOptions& options);

  // Fit(z, delay, stage) on a fitter of its own with `threads` threads, or with `share`'s share of
  // them (and, if > 0, its own evaluation limit), safe to call from several threads at once: its
  // progress reports are passed on one at a time, and its iterations and evaluations are added to
  // this fitter's when it returns.
  // `gradient`: how the fitter takes its first gradients (a neighbour's FitResult's).
  FitResult FitAlongside(std::vector<double> z, const std::vector<int>& delay,
                         const std::string& stage, int threads, int max_evaluations = 0,
                         const Eigen::MatrixXd* first_model = nullptr,
                         const ThreadShare* share = nullptr,
                         filter::LinearGradient gradient = filter::LinearGradient::kSteadyState);

  // `iterations` iterations of auto's BHHH with BFGS corrections from z (`first_model`: as Fit's),
  // where it stalls before they are up L-BFGS, within kExploreEvaluations x `iterations`
  // evaluations; no progress reports; as FitAlongside: a cheap look at where a start leads.
  // With a finite `level` (the estimate's log L), a fit that crawls (FitBhhh's hand_over test)
  // at that level (within kSameOptimum, or kSameLevel relative) stops there, crawling: it came
  // back to the estimate's optimum or its valley.
  FitResult ExploreAlongside(std::vector<double> z, const std::vector<int>& delay, int iterations,
                             int threads, const Eigen::MatrixXd* first_model = nullptr,
                             double level = HUGE_VAL, const ThreadShare* share = nullptr);

  int k() const { return static_cast<int>(free_.size()); }
  const std::vector<int>& free() const { return free_; }
  double lower(int i) const { return lower_[i]; }
  double upper(int i) const { return upper_[i]; }
  int evaluations() const { return evaluations_.load(); }
  // The options of a fit beside this one's (Alongside; another fitter's, as for the relaxed
  // diffusion): `threads` threads, its own evaluation limit if > 0, progress passed on as this
  // fitter's under a lock (iterations and evaluations counted on from this one's).
  EstimateOptions SubOptions(int threads, int max_evaluations);
  // Adds another fitter's iterations and evaluations to this one's.
  void AddWork(const Fitter& other) {
    iterations_.fetch_add(other.iterations());
    evaluations_.fetch_add(other.evaluations());
  }
  int iterations() const { return iterations_.load(); }
  bool Cancelled() const { return options_.cancel && options_.cancel->load(); }

  // The working scale of free parameter i: z = θ / s (s = |start|, or a tenth of the range, or
  // 1), or, for a parameter with a positive lower bound, z = log θ (a decade is one unit there, and
  // a variance or time constant heading for its bound walks a straight line).
  bool log_scale(int i) const { return log_[i] != 0; }
  double ThetaOf(int i, double z) const { return log_[i] ? std::exp(z) : z * scale_[i]; }
  double ZOf(int i, double theta) const { return log_[i] ? std::log(theta) : theta / scale_[i]; }
  double Slope(int i, double z) const { return log_[i] ? std::exp(z) : scale_[i]; }  // dθ/dz

  std::vector<double> ZStart() const {
    std::vector<double> z(k());
    for (int i = 0; i < k(); ++i) z[i] = ZOf(i, theta0_[free_[i]]);
    return z;
  }

  std::vector<double> Theta(const std::vector<double>& z) const {
    std::vector<double> theta = theta0_;
    for (int i = 0; i < k(); ++i) theta[free_[i]] = ThetaOf(i, z[i]);
    return theta;
  }

  // The objective at scaled point z: log L, plus Σ log N(θ_i | m_i, s_i²) over the parameters
  // with a prior (a log posterior); -inf where log L cannot be evaluated. `threads`: for the
  // records (Likelihood::Evaluate); 0 the fitter's own, 1 where the caller runs points side by
  // side already.
  double Objective(const std::vector<double>& z, const std::vector<int>& delay, int threads = 0) {
    return LogLik(z, delay, nullptr, threads) + LogPrior(z);
  }

  // log L alone (no prior) at z; `threads` as Objective's.
  double LogLik(const std::vector<double>& z, const std::vector<int>& delay, long* n_obs = nullptr,
                int threads = 0);

  bool HasPriors() const { return !priors_.empty(); }

  // Σ log N(θ_i | m_i, s_i²) over the free parameters with a prior (natural scale, normalised).
  double LogPrior(const std::vector<double>& z) const {
    double sum = 0;
    for (const auto& [i, prior] : priors_) sum += prior.LogDensity(ThetaOf(i, z[i]));
    return sum;
  }

  // Adds the priors' gradient to *g and their information (the negative Hessian of the log
  // prior) to *info, both in scaled units.
  void AddPriorDerivatives(const std::vector<double>& z, Eigen::VectorXd* g,
                           Eigen::MatrixXd* info) const;

  // The objective's value *f, its gradient *g and, with `info`, BHHH's information Σ_j s_j s_j'
  // (plus the priors' information), all in scaled units, from the exact score
  // (filter::Likelihood::EvaluateWithScore). With `split`, the threads are used: the parameters
  // are shared out over them (each evaluates the filter once more, with its share of the
  // sensitivities), or for the EKF's adjoint, whose cost does not depend on the share, the
  // records of a joint fit are; without, one thread (the caller runs points side by side).
  // False where log L or its score cannot be evaluated.
  bool Scores(const std::vector<double>& z, const std::vector<int>& delay, double* f,
              Eigen::VectorXd* g, Eigen::MatrixXd* info, bool split = true, bool* exact = nullptr);

  // Scores where the exact score cannot be computed but log L can (a derivative of the model's
  // entries that is infinite at z, such as d sqrt(s)/ds at s = 0 on a bound): every per-term
  // score by central differences, one-sided where a step would leave the bounds.
  bool ScoresByDifferences(const std::vector<double>& z, const std::vector<int>& delay, double* f,
                           Eigen::VectorXd* g, Eigen::MatrixXd* info);

  // Solves I_FF d = g_F, with Levenberg damping only where I_FF is singular (a parameter the data
  // ignore). Returns an empty vector if no damping helps.
  static Eigen::VectorXd NewtonStep(const Eigen::MatrixXd& info, const Eigen::VectorXd& g,
                                    const std::vector<int>& F);
  // B's rows and columns F.
  static Eigen::MatrixXd SubMatrix(const Eigen::MatrixXd& B, const std::vector<int>& F);

  // BHHH (Berndt-Hall-Hall-Hausman): Newton steps with the information estimated by the outer
  // product of the per-observation scores, projected onto the bounds (a parameter on a bound
  // whose gradient points outward is held there), with a backtracking line search.
  // With `hand_over`, it stops (crawling, not converged) where its last kCrawlWindow steps
  // gained less than kCrawlGain together and shrink so slowly that reaching kNegligibleGain would
  // take more steps than an exact Hessian costs gradients: a trust-region end game on the exact
  // Hessian finishes in a few steps what its curvature model would take hundreds for.
  // With `rescale_creepers`, it stops (crawling, with `creeping` set) where, on such a crawl,
  // parameters with a positive lower bound on a linear scale fell at every step of the window,
  // by kCreep of themselves or more: a crawl down a valley that a log scale straightens.
  FitResult FitBhhh(std::vector<double> z, const std::vector<int>& delay, const std::string& stage,
                    int max_iterations, bool bfgs_updates = false,
                    const Eigen::MatrixXd* first_model = nullptr, bool hand_over = false,
                    bool rescale_creepers = false);

  // FitBhhh's iterations; B ends as the curvature model at the returned point.
  FitResult BhhhLoop(std::vector<double> z, const std::vector<int>& delay, const std::string& stage,
                     int max_iterations, bool bfgs_updates, const Eigen::MatrixXd* first_model,
                     bool hand_over, bool rescale_creepers, Eigen::MatrixXd& B);

  // The trust-region algorithm's end game: a trust-region Newton method on a curvature model B
  // of -objective (scaled units). B starts as BHHH's information (its finite entries replaced by
  // `first_model`'s) and learns from the gradient's changes along accepted steps (BFGS updates, SR1
  // once B has been the exact Hessian, which may be indefinite). Every step solves
  //   max_d  g'd - ½ d'Bd   subject to  ‖D d‖ ≤ Δ
  // exactly (Moré & Sorensen, by B's eigendecomposition) over the parameters not held at a bound,
  // D = √diag B as the largest seen (the scaling of MINPACK's Levenberg-Marquardt), and the radius
  // Δ follows the ratio of the achieved to the predicted increase. Where the updates learn too
  // slowly (kExactEvery accepted steps since B last was the exact Hessian, at least k), B becomes
  // the exact Hessian from forward differences of the exact gradient (ExactHessian): a crawl of
  // a thousand quasi-Newton steps becomes a few Newton steps, a flat direction is run along at a
  // radius that doubles, and negative curvature is followed out of a saddle.
  FitResult FitTrustRegion(std::vector<double> z, const std::vector<int>& delay,
                           const std::string& stage, int max_iterations,
                           const Eigen::MatrixXd* first_model = nullptr, bool exact_first = false);

  // The Hessian of -objective in scaled units at z (gradient g there) over the free parameters
  // `which` (its rows and columns; the others are left as they are in *H), column a from the
  // forward difference -(g(z + h e_a) - g) / h, h = kGradientHessianStep max(|z_a|, 1), backward
  // where the forward point leaves the bounds or fails; symmetrised. The gradients run on the
  // fitter's threads. False where a column cannot be computed on either side.
  bool ExactHessian(const std::vector<double>& z, const std::vector<int>& delay,
                    const Eigen::VectorXd& g, const std::vector<int>& which, Eigen::MatrixXd* H);

  // auto: BHHH with BFGS corrections, L-BFGS to finish where it cannot; where BHHH crawls with
  // positive parameters creeping towards their lower bounds, the fit goes on with those on a log
  // scale (FitOnLogScale); trust-region: the same
  // while it gains well, then (where it crawls or its line search fails) the trust-region end
  // game from the exact Hessian. `first_model` (auto and trust-region): a curvature model of
  // -objective in scaled units to start from (NaN entries: BHHH's).
  FitResult Fit(std::vector<double> z, const std::vector<int>& delay, const std::string& stage,
                int max_iterations = kMaxBhhhIterations,
                const Eigen::MatrixXd* first_model = nullptr);

  // Fit(z, delay, stage) on the log working scale for the free parameters with a positive lower
  // bound (z = log θ there, the other parameters as here): where a curved valley runs along
  // products and ratios of positive parameters it is straighter there. Its iterations and
  // evaluations are added to this fitter's; the result is in this fitter's scale (no model).
  // `max_evaluations` > 0: its limit. With `which`, only those free parameters go on a log scale
  // (each one that OnLogScaleThere).
  FitResult FitOnLogScale(const std::vector<double>& z, const std::vector<int>& delay,
                          const std::string& stage, int max_evaluations,
                          const std::vector<int>* which = nullptr);

  // Whether FitOnLogScale would fit any parameter on another scale than this fitter does.
  bool AnyOnLogScale() const;
  // Whether free parameter i is on a linear scale here and goes on a log one in FitOnLogScale.
  bool OnLogScaleThere(int i) const {
    return !log_[i] && lower_[i] > 0 && std::isfinite(lower_[i]);
  }

  // One NLopt run: `algo` is kLbfgs, kSlsqp or kBobyqa.
  FitResult FitNlopt(std::vector<double> z, const std::vector<int>& delay, const std::string& stage,
                     Algorithm algo, double ftol_rel);

  void Report(const std::string& stage, const std::vector<double>& z, double loglik,
              const std::vector<int>& delay);

 private:
  // A fit's start: z clamped into the bounds, and r->z set to it. True when there is nothing to
  // fit (no free parameter): *r is then the result.
  bool StartInBox(std::vector<double>* z, const std::vector<int>& delay, FitResult* r);

  // The free parameters that may move at z (gradient g) into *free_set; those on a bound (or
  // within kNearBound of it) whose gradient points out into *held, with that bound.
  void SplitAtBounds(const std::vector<double>& z, const Eigen::VectorXd& g,
                     std::vector<int>* free_set, std::vector<std::pair<int, double>>* held) const;

  // Of the accepted points of a crawl's window (kCrawlWindow + 1, oldest first), the free
  // parameters that OnLogScaleThere and fell at every step, by kCreep of themselves or more.
  std::vector<int> Creeping(const std::vector<std::vector<double>>& points) const;

  // The finite entries of `model` (if any) replace B's: a better first curvature model.
  static void Overlay(const Eigen::MatrixXd* model, Eigen::MatrixXd* B);

  // BFGS's update of the curvature model B of -objective from a step s and the change y of the
  // gradient of -objective along it, where the step shows positive curvature (else B is kept).
  static void BfgsUpdate(const Eigen::VectorXd& s, const Eigen::VectorXd& y, Eigen::MatrixXd* B);

  // Whether a fit that began at `evaluations_before` has used more than the evaluation limit;
  // then *message says so.
  bool OverEvaluationLimit(int evaluations_before, std::string* message) const;

  // Runs fit(sub) on a fitter over the same parameters with its own options (threads, evaluation
  // limit, progress passed on under a lock or none) and `share` (if given; else this one's), and
  // adds its counts to this one's.
  FitResult Alongside(int threads, int max_evaluations, bool report,
                      const std::function<FitResult(Fitter&)>& fit,
                      const ThreadShare* share = nullptr,
                      filter::LinearGradient gradient = filter::LinearGradient::kSteadyState);
  // The threads an evaluation may use now: the share's, or threads_.
  int Threads() const { return share_ ? share_->Threads() : threads_; }

  const filter::Likelihood& lik_;
  const EstimateOptions& options_;
  std::vector<double> theta0_;
  std::vector<int> free_;
  std::vector<double> scale_, lower_, upper_;
  std::vector<char> log_;
  struct FreePrior {
    int i;                          // index into the free parameters
    model::Parameter::Prior prior;  // natural scale
  };
  std::vector<FreePrior> priors_;
  int threads_ = 1;
  const ThreadShare* share_ = nullptr;
  // Scores: how a linear model's gradient alone is differentiated (the steady state's adjoint
  // until it covered fewer than nine rows in ten, then the whole recursion's).
  filter::LinearGradient linear_gradient_ = filter::LinearGradient::kSteadyState;
  std::atomic<int> evaluations_{0};
  std::atomic<int> iterations_{0};
  std::mutex progress_mutex_;
};

}  // namespace gb::estimate::internal
