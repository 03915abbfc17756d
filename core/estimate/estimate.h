// Maximum-likelihood estimation of a linear SDE model's parameters (and output delays).
//
//   θ̂ = argmax_θ log L(θ)   over the free parameters, within their bounds (fixed ones held)
//
// Optimiser, on a scaled copy of the free parameters (z_i = θ_i / s_i, s_i = |start_i|, or 1 when
// the start is 0) so that a variance of 1e-4 and a gain of 1 move alike:
//   - auto (default): L-BFGS (NLopt) from each start to a loose tolerance, then BHHH. L-BFGS is
//     robust far from the optimum, BHHH converges in few iterations near it.
//   - BHHH: Newton steps d = I⁻¹ g where g is the gradient of log L and I = Σ_j s_j s_j'
//     the outer product of the per-observation scores s_j = ∂ℓ_j/∂z (ℓ_j: the log-likelihood term
//     of state index j). I estimates the Fisher information, so near the optimum the steps are
//     close to Newton's and a fit takes 10-20 iterations where generic quasi-Newton methods need
//     60+ on these badly conditioned surfaces. Bounds: a parameter on a bound whose gradient
//     points out is held; steps are clipped to the box; backtracking line search (Armijo).
//   - NLopt's LD_SLSQP, LD_LBFGS (bounds native) or LN_BOBYQA (derivative-free), selectable.
// Gradients and scores by central differences, the 2k evaluations spread over threads; a
// difference that would leave the bounds is taken one-sided.
//
// Output delays with a range [min, max] (CONTRACT section 1) are estimated by profile likelihood:
// the fit alternates between θ at a fixed delay and the best delay at that θ until the delay
// stops changing; then θ is re-optimised at every other delay of the range (warm-started), which
// gives the profile log L(d) = max_θ log L(θ, d), and the best of those is the estimate.
//
// Uncertainty: H = Hessian of -log L at θ̂ on the natural scale (central differences), over the
// free parameters that are not at a bound. Cov = H⁻¹, standard errors sqrt(diag Cov),
// t = θ̂ / SE, p = two-sided P(|T| > |t|) for Student's t with n_obs - n_free degrees of freedom
// (as CTSM reports). When H is not positive definite the directions it fails in are named and
// those parameters get no standard error (never a misleadingly small one). Where log L cannot
// be evaluated on one side of an estimate, that parameter's differences are one-sided (second
// order); where it fails on both sides, the parameter gets no standard error and the others'
// hold it at its estimate. Both are warned about.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "core/filter/likelihood.h"
#include "core/util/json.h"
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
  kAuto,    // from each start: NLopt L-BFGS to a loose tolerance (robust far from the optimum),
            // then BHHH to the final tolerance; warm-started delay-profile fits: BHHH only
  kBhhh,    // Newton steps with the BHHH information (outer product of per-observation scores),
            // projected onto the bounds, with a line search: few iterations on ML problems
  kLbfgs,   // NLopt LD_LBFGS: limited-memory quasi-Newton with bounds, gradients by differences
  kSlsqp,   // NLopt LD_SLSQP: sequential quadratic programming with a dense BFGS Hessian
  kBobyqa,  // NLopt LN_BOBYQA: derivative-free quadratic models within the bounds
};

struct EstimateOptions {
  Algorithm algorithm = Algorithm::kAuto;
  // With kAuto: the relative tolerance at which the L-BFGS phase hands over to BHHH.
  double handover_ftol_rel = 1e-7;
  // Stop when an iteration changes -log L by less than ftol_rel times its value.
  double ftol_rel = 1e-12;
  // ... or changes every scaled parameter by less than xtol_rel (relative).
  double xtol_rel = 1e-10;
  // ... or after this many log-likelihood evaluations in one fit (reported as not converged).
  int max_evaluations = 20000;
  // Extra starts spread over the bounds (Latin hypercube; parameters without both bounds are
  // spread log-uniformly within a factor 10 of their start). 0: only the model's start values.
  int multistart = 0;
  std::uint64_t seed = 1;
  // Threads for gradients and the Hessian; 0 = all cores.
  int threads = 0;
  // Re-optimise θ at every delay of a scanned range (the full profile). Off: the profile is
  // evaluated at θ̂ only (cheaper, and enough to locate the delay).
  bool full_delay_profile = true;
  // Called from the estimating thread after every iteration (keep it short).
  std::function<void(const Progress&)> progress;
  // Set to true from any thread to stop; Estimate returns within about one evaluation.
  const std::atomic<bool>* cancel = nullptr;

  bool IsValid(std::string* why) const;
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

struct EstimateSummary {
  bool converged = false;
  std::string message = "Estimate() was not called";
  bool cancelled = false;
  std::string model_name;
  std::vector<std::string> datasets;
  double loglik = 0.0;
  long n_obs = 0;
  int n_free = 0;           // free parameters + scanned delays
  double aic = 0.0;         // -2 log L + 2 n_free
  double bic = 0.0;         // -2 log L + n_free log(n_obs)
  int iterations = 0;
  int evaluations = 0;
  double elapsed_s = 0.0;
  std::vector<ParameterEstimate> parameters;   // all parameters, in model order
  std::vector<double> theta;                   // all parameters at the estimate
  std::vector<std::string> correlation_names;  // parameters with a standard error
  Eigen::MatrixXd correlation;
  Eigen::MatrixXd covariance;                  // of the parameters in correlation_names
  std::vector<DelayEstimate> delays;           // one per output
  std::vector<std::string> warnings;

  std::string Report() const;  // readable, in the spirit of CTSM's summary
  Json ToJson() const;         // CONTRACT section 5
};

// Fits the model of `likelihood` to its data. Fails only for invalid options or when the log-
// likelihood cannot be evaluated at the start values; a fit that does not converge returns a
// summary with converged = false and a message saying why.
Result<EstimateSummary> Estimate(const filter::Likelihood& likelihood, const EstimateOptions& options);

// The likelihood-ratio test of a restricted model (fewer free parameters) against a full one.
struct LikelihoodRatioTest {
  double statistic = 0.0;   // 2 (log L_full - log L_restricted)
  int df = 0;               // n_free(full) - n_free(restricted)
  double p_value = 1.0;     // P(χ²_df > statistic)
  std::string Report() const;
};
Result<LikelihoodRatioTest> CompareNested(double loglik_restricted, int n_free_restricted,
                                          double loglik_full, int n_free_full);

}  // namespace gb::estimate
