// Maximum-likelihood estimation of a linear SDE model's parameters (and output delays).
//
//   θ̂ = argmax_θ log L(θ)   over the free parameters, within their bounds (fixed ones held)
//
// The objective is log L, or with priors on some parameters (model::Parameter::prior) the log
// posterior log L + Σ log N(θ_i | m_i, s_i²) (a MAP estimate).
//
// Optimiser, on a scaled copy of the free parameters (z_i = θ_i / s_i, s_i = |start_i|, or 1 when
// the start is 0) so that a variance of 1e-4 and a gain of 1 move alike. Gradients are exact: the
// analytic score of the filter (core/filter/score.h), its parameters shared out over the threads.
//   - auto (default): BHHH with BFGS corrections. The first curvature model is BHHH's
//     information I = Σ_j s_j s_j', the outer product of the per-observation scores s_j = ∂ℓ_j/∂z
//     (ℓ_j: the log-likelihood term of state index j), which estimates the Fisher information:
//     near the optimum of a well-specified model the steps are close to Newton's. Each accepted
//     step then corrects it by a BFGS update from the change of the exact gradient, which learns
//     the difference where the model is misspecified (a wrong delay) and far from the optimum.
//     A line search that fails on the corrected model restarts it from BHHH's information.
//     Where this cannot finish (flat or bound-limited directions), L-BFGS (NLopt) finishes.
//     Typically 15-60 gradient evaluations per fit.
//   - BHHH: the same without the BFGS corrections. Bounds, in both: a parameter on a bound whose
//     gradient points out is held; steps are clipped to the box; backtracking line search (Armijo).
//   - NLopt's LD_SLSQP, LD_LBFGS (bounds native) or LN_BOBYQA (derivative-free), selectable.
//   - trust-region: auto's start, and where its steps crawl (gains that shrink too slowly to wait
//     for) or its line search fails, a trust-region Newton method whose curvature model is the
//     exact Hessian from forward differences of the exact gradient, refreshed every k steps
//     (Fitter::FitTrustRegion). Selectable for measurement (docs/benchmarks.md, issue 33).
//   - auto and trust-region, at the end: where the exact Hessian at the estimate still promises
//     an increase above 1e-6, or is singular in a direction off the bounds, the fit may have
//     stopped crawling along a curved valley, where the quadratic model understates what is left;
//     it goes on from the estimate with the parameters that have a positive lower bound on a log
//     scale, where a valley of capacities and resistances is straighter, and is kept where it is
//     higher (Fitter::FitOnLogScale; building 3: from 0.0077 below the optimum to it).
//
// Output delays with a range [min, max] (user guide §1) are estimated by profile likelihood:
// the delay to start at is the best of the grid at the start values; the fit alternates between
// θ at a fixed delay and the best delay at that θ until the delay stops changing; then θ is re-
// optimised to convergence at every other delay of the range (warm-started from the nearest
// fitted delay), which gives the profile log L(d) = max_θ log L(θ, d), and the best of those is
// the estimate. When that is not the delay the plain start was fitted at, the plain start is
// fitted there too (a first delay far from the right one can lead its fit to a poor optimum that
// the warm-started fits inherit), and the better fit is kept.
//
// Multistart: extra starts (Latin hypercube over the bounds) are fitted at the delay found from
// the plain start; the best of all is the estimate, and the summary says how many reached it.
//
// Uncertainty: H = Hessian of -log L (or -log posterior) at θ̂ on the natural scale, from central
// differences of the exact gradient, over the free parameters that are not at a bound.
// Cov = H⁻¹, standard errors sqrt(diag Cov), t = θ̂ / SE, p = two-sided P(|T| > |t|) for
// Student's t with n_obs - n_free degrees of freedom (as CTSM reports). When H is not positive
// definite the directions it fails in are named and those parameters get no standard error
// (never a misleadingly small one). Where the gradient cannot be computed on one side of an
// estimate, that parameter's differences are one-sided (second order); where it fails on both
// sides, the parameter gets no standard error and the others' hold it at its estimate. Both are
// warned about. Where H has a clearly negative eigenvalue the fit stopped at a saddle point: it
// steps along that direction and fits again (up to 3 times); a saddle it cannot leave is reported
// as not converged, with what to try.
//
// Profile likelihood intervals (ProfileIntervals below): for a parameter θ_i, the set where
// max over the others of log L stays within χ²₁(level)/2 of log L(θ̂).
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "core/estimate/steady_start.h"
#include "core/filter/likelihood.h"
#include "core/util/json_fwd.h"
#include "core/util/result.h"

namespace gb::estimate {

struct Progress {
  int iteration = 0;          // gradient evaluations so far (the optimiser's iterations)
  int evaluations = 0;        // log-likelihood evaluations so far
  double loglik = 0.0;        // best log L so far
  std::vector<double> theta;  // all parameters at the best point so far
  std::vector<int> delay;     // the delay per output being fitted
  std::string stage;          // "fitting", "delay profile", "standard errors"
};

enum class Algorithm {
  kAuto,    // BHHH's information corrected by BFGS updates, L-BFGS to finish where it cannot
  kBhhh,    // Newton steps with the BHHH information (outer product of per-observation scores),
            // projected onto the bounds, with a line search: few iterations on ML problems
  kLbfgs,   // NLopt LD_LBFGS: limited-memory quasi-Newton with bounds
  kSlsqp,   // NLopt LD_SLSQP: sequential quadratic programming with a dense BFGS Hessian
  kBobyqa,  // NLopt LN_BOBYQA: derivative-free quadratic models within the bounds
  kTrustRegion,  // auto's BHHH with BFGS corrections while it gains well, then a trust-region
                 // Newton end game on the exact Hessian (from differences of the exact gradient)
};

// Limits of EstimateOptions: starts beyond these would only exhaust the machine (each start is a
// whole fit, and their points are drawn together).
inline constexpr int kMaxStarts = 10000;
inline constexpr int kMaxThreads = 1024;

struct EstimateOptions {
  Algorithm algorithm = Algorithm::kAuto;
  // Stop when an iteration changes -log L by less than ftol_rel times its value.
  double ftol_rel = 1e-12;
  // ... or changes every scaled parameter by less than xtol_rel (relative).
  double xtol_rel = 1e-10;
  // ... or after this many log-likelihood evaluations in one fit (reported as not converged).
  int max_evaluations = 20000;
  // Extra starts spread over the bounds (Latin hypercube; parameters without both bounds are
  // spread log-uniformly within a factor 10 of their start). 0: only the model's start values.
  int multistart = 0;
  // Without multistart: where the fit ends with free parameters that ran off (onto a bound they
  // did not start on, towards ±inf on a scale without bounds, or where the data do not determine
  // them: often the sign of a local optimum, a variance pinned at zero, a time constant at the
  // end of its range), fits from the estimate with them put back to their start values; then,
  // where the estimate is on a bound or a runaway without bounds stays, this many extra starts
  // like multistart's (see ReleaseRunaways and StartsOnBound in estimate.cpp). 0: neither.
  int starts_on_bound = 8;
  std::uint64_t seed = 1;
  // Threads for the score (its parameters shared out) and the Hessian; 0 = all cores.
  int threads = 0;
  // Re-optimise θ at every delay of a scanned range (the full profile). Off: the profile is
  // evaluated at θ̂ only (cheaper, and enough to locate the delay).
  bool full_delay_profile = true;
  // Likelihood-ratio (profile) intervals for every free parameter, at profile_level.
  bool profile_intervals = false;
  // Scores from central differences of log L even where exact ones exist (for comparison and
  // for models whose derivatives misbehave; the standard errors then come from second
  // differences of log L).
  bool score_differences = false;
  double profile_level = 0.95;
  // Before fitting, move the free parameters that the model's steady states depend on until
  // those steady states match the records' levels, and fit from there (SteadyStart, core/
  // estimate/steady_start.h): for nonlinear models whose start values are far off, where the
  // filter would explain a wrong level with noise. The windows' length is steady_window (the
  // records' time unit).
  bool steady_start = false;
  double steady_window = 5.0;
  // Fit the parameters with a positive lower bound on a log scale (Fitter::log_scale), for
  // comparison: on the bundled cases it is not yet better (docs/benchmarks.md, issue 33).
  bool log_scale = false;
  // Called from the estimating thread after every iteration (keep it short).
  std::function<void(const Progress&)> progress;
  // Set to true from any thread to stop; Estimate returns within about one evaluation.
  const std::atomic<bool>* cancel = nullptr;

  bool IsValid(std::string* why) const;
};

// The profile log-likelihood of one parameter θ_i: at each value v, the maximum of log L (or of
// the log posterior, with priors) over the other free parameters with θ_i held at v (the delays
// held at their estimates). The likelihood-ratio interval at `level` is where the profile stays
// within χ²₁(level)/2 of its maximum.
struct ProfilePoint {
  double value = 0.0;
  double loglik = 0.0;
  bool converged = true;  // false: that fit stopped early (its value is a lower bound)
};

struct ProfileInterval {
  double level = 0.95;
  // An end is absent when the profile stays above the threshold all the way to the parameter's
  // bound (at_bound: the data do not bound the parameter on that side) or to where the search
  // gave up (not at_bound; the warning says why).
  std::optional<double> lower, upper;
  bool lower_at_bound = false, upper_at_bound = false;
  std::vector<ProfilePoint> curve;  // every value fitted, sorted, the estimate included
  std::vector<std::string> warnings;
};

struct ParameterEstimate {
  std::string name;
  double estimate = 0.0;
  std::optional<double> std_error;  // absent: fixed, at a bound, or not determined by the data
  std::optional<double> t_value;
  std::optional<double> p_value;
  std::optional<double> lower, upper;
  bool fixed = false;
  bool at_bound = false;
  std::string unit;
  std::optional<ProfileInterval> profile;  // with EstimateOptions::profile_intervals
};

struct DelayProfilePoint {
  int delay = 0;
  std::optional<double> loglik;  // absent when the fit at this delay failed
  bool converged = true;         // false: the fit was stopped early, loglik is a lower bound
};

struct DelayEstimate {
  std::string output;
  int estimate = 0;
  bool scanned = false;
  std::vector<DelayProfilePoint> profile;
};

// An optimum the fit's starts reached (EstimateSummary::optima).
struct Optimum {
  double loglik = 0.0;        // the objective there: log L, or the log posterior with priors
  int starts = 1;             // the starts that reached it (within 1e-3 in the objective)
  bool converged = true;      // false: the best fit that reached it stopped early
  std::vector<double> theta;  // all parameters there
};

struct EstimateSummary {
  bool converged = false;
  std::string message = "Estimate() was not called";
  bool cancelled = false;
  std::string model_name;
  std::vector<std::string> datasets;
  double loglik = 0.0;                  // log L at the estimate (without the priors)
  std::optional<double> log_posterior;  // with priors: log L + Σ log prior (a MAP estimate)
  long n_obs = 0;
  int n_free = 0;    // free parameters + scanned delays
  double aic = 0.0;  // -2 log L + 2 n_free
  double bic = 0.0;  // -2 log L + n_free log(n_obs)
  int iterations = 0;
  int evaluations = 0;
  double elapsed_s = 0.0;
  // The filter that ran: the exact Kalman filter of a linear model, or the extended Kalman filter
  // (core/filter/ekf.h) with its options and the ODE solver's work over the whole fit.
  bool extended = false;
  model::EkfOptions ekf;
  ode::OdeCounts ode;
  // The extended filter's formulas ran as native code (core/expr/native.h), not the interpreter;
  // where native code was wanted but could not be built, `native_note` says why.
  bool native = false;
  std::string native_note;
  // The scores were exact (the Kalman filter's, or the EKF's forward sensitivities); false:
  // central differences of log L (the iterated EKF, or EstimateOptions::score_differences).
  bool exact_scores = true;
  int starts = 1;                 // start points fitted (the model's and the multistart ones)
  bool starts_for_bound = false;  // the extra starts were starts_on_bound's (not multistart's)
  int starts_at_best = 1;  // of them, those that reached the best optimum (within 1e-3 in log L)
  // Times a better optimum was found by putting parameters that ran off (onto a bound, or where
  // the data do not determine them) back to their start values.
  int releases = 0;
  int released_starts = 0;  // starts made by putting runaways back (counted in `starts`)
  // Starts from a fit with the diffusion relaxed (a variance of it had ended on a bound; counted
  // in `starts`), and whether one reached a better optimum.
  int relaxed_starts = 0;
  bool relaxed_better = false;
  // The free parameters the fit that reached the estimate went on with on a log scale, because
  // it crawled while they crept towards their lower bounds (Fitter::Fit), in model order.
  std::vector<std::string> log_scale;
  // The distinct optima the starts reached, best first (the estimate's is the first): more than
  // one is a second basin the user should know of.
  std::vector<Optimum> optima;
  std::vector<ParameterEstimate> parameters;   // all parameters, in model order
  std::vector<double> theta;                   // all parameters at the estimate
  std::vector<std::string> correlation_names;  // parameters with a standard error
  Eigen::MatrixXd correlation;
  Eigen::MatrixXd covariance;         // of the parameters in correlation_names
  std::vector<DelayEstimate> delays;  // one per output
  std::vector<std::string> warnings;
  // With EstimateOptions::steady_start: how the start values were moved (printed after the data).
  std::optional<SteadyStartResult> steady_start;

  // The free parameters (indices into `parameters`) whose values at optima[o] differ most from
  // the estimate, most first, at most n: in the estimate's standard errors where it has one,
  // else relative to its size.
  std::vector<std::size_t> DifferMost(std::size_t o, std::size_t n) const;

  std::string Report() const;  // readable, in the spirit of CTSM's summary
  Json ToJson() const;         // user guide §5
  // A result file read back (the inverse of ToJson; the ODE solver's rejected steps and the
  // steady-state start's θ, which it does not write, stay empty). Errors name `file` and the
  // JSON path; a partial result (a checkpoint) is refused: it holds estimates only.
  static Result<EstimateSummary> FromJson(const Json& j, const std::string& file);
};

// Fits the model of `likelihood` to its data. Fails only for invalid options or when the log-
// likelihood cannot be evaluated at the start values; a fit that does not converge returns a
// summary with converged = false and a message saying why.
Result<EstimateSummary> Estimate(const filter::Likelihood& likelihood,
                                 const EstimateOptions& options);

// The summary of a fit the user stopped (Estimate's summary with `cancelled` set) at the best
// point it had reported (Progress::theta and ::delay): log L evaluated there once more, the
// run's counts and times, the parameters' values without standard errors (not an optimum), and
// a warning that says so. `likelihood` must not be the cancelled one (Estimate copies it).
Result<EstimateSummary> StoppedSummary(const filter::Likelihood& likelihood,
                                       EstimateSummary cancelled, const Progress& best);

// The profile log-likelihood and likelihood-ratio interval at `level` of each free parameter named
// in `names` (empty: every free parameter), at the estimate `at` of `likelihood`'s model (its
// delays held). Each side of each parameter walks outward from the estimate, with steps from its
// standard error (or 10 % of its value) that grow where the profile is flat, fitting the others
// warm-started from the last point, until the profile drops below the threshold; the end is then
// found by the Illinois (regula falsi) method to 1e-3 in log L. The (parameter, side) searches
// run in parallel (fit_options.threads). Fails for an unknown or fixed name, or a summary of
// another model. If a profile rises above log L(θ̂), the estimate was not the maximum: a warning
// says so.
Result<std::vector<ProfileInterval>> ProfileIntervals(const filter::Likelihood& likelihood,
                                                      const EstimateSummary& at,
                                                      const std::vector<std::string>& names,
                                                      double level,
                                                      const EstimateOptions& fit_options);

// The likelihood-ratio test of a restricted model (fewer free parameters) against a full one.
struct LikelihoodRatioTest {
  double statistic = 0.0;  // 2 (log L_full - log L_restricted)
  int df = 0;              // n_free(full) - n_free(restricted)
  double p_value = 1.0;    // P(χ²_df > statistic)
  std::string Report() const;
};
Result<LikelihoodRatioTest> CompareNested(double loglik_restricted, int n_free_restricted,
                                          double loglik_full, int n_free_full);

}  // namespace gb::estimate
