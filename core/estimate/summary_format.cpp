// EstimateSummary::Report (readable, in the spirit of CTSM's summary) and ToJson (the user guide
// §5). No NaN is ever printed as a number: missing values are blank / null.
#include <algorithm>
#include <cmath>

#include <boost/math/distributions/normal.hpp>
#include <fmt/format.h>

#include "core/estimate/estimate.h"
#include "core/util/json.h"

namespace gb::estimate {
namespace {

constexpr std::size_t kListedOptima = 5;  // the report lists at most this many distinct optima

std::string Num(double v) { return fmt::format("{:.6g}", v); }

std::string Opt(const std::optional<double>& v, const char* blank = "") {
  return v ? Num(*v) : std::string(blank);
}

std::string PValue(double p) {
  if (p < 2.2e-16) return "<2e-16";
  return fmt::format("{:.3g}", p);
}

Json OptJson(const std::optional<double>& v) { return v ? Json(*v) : Json(nullptr); }

}  // namespace

std::vector<std::size_t> EstimateSummary::DifferMost(std::size_t o, std::size_t n) const {
  if (o >= optima.size() || optima[o].theta.size() != parameters.size()) return {};
  std::vector<std::pair<double, std::size_t>> differ;
  for (std::size_t i = 0; i < parameters.size(); ++i) {
    const ParameterEstimate& p = parameters[i];
    if (p.fixed) continue;
    const double unit = p.std_error ? *p.std_error : std::max(std::abs(p.estimate), 1e-300);
    const double d = std::abs(optima[o].theta[i] - p.estimate) / unit;
    if (d > 0 && std::isfinite(d)) differ.emplace_back(d, i);
  }
  std::stable_sort(differ.begin(), differ.end(),
                   [](const auto& a, const auto& b) { return a.first > b.first; });
  std::vector<std::size_t> most;
  for (std::size_t t = 0; t < differ.size() && t < n; ++t) most.push_back(differ[t].second);
  return most;
}

std::string EstimateSummary::Report() const {
  std::string r;
  auto line = [&r](const std::string& s) { r += s + "\n"; };
  line(fmt::format("Model: {}", model_name.empty() ? "(unnamed)" : model_name));
  std::string data;
  for (std::size_t i = 0; i < datasets.size(); ++i) data += (i ? ", " : "") + datasets[i];
  line(fmt::format("Data: {} ({} observations)", data, n_obs));
  if (steady_start) line(steady_start->Report());
  line(fmt::format("{}: {}", converged ? "Converged" : (cancelled ? "Cancelled" : "NOT converged"),
                   message));
  line(fmt::format("{} iterations, {} log-likelihood evaluations, {:.2f} s", iterations,
                   evaluations, elapsed_s));
  if (extended) {
    line(
        fmt::format("Filter: extended Kalman filter{} (nonlinear model); ODE {}, rtol {:g}, "
                    "atol {:g}: {} steps over {} intervals, {} stiff (BDF)",
                    ekf.iterations > 1 ? fmt::format(", iterated ({} passes)", ekf.iterations) : "",
                    model::OdeMethodName(ekf.method), ekf.rtol, ekf.atol, ode.steps, ode.intervals,
                    ode.stiff_intervals));
    line(native ? "Model code: native (compiled C, the interpreter's values bit for bit)"
                : "Model code: interpreter" +
                      (native_note.empty() ? std::string() : " (" + native_note + ")"));
  } else {
    line("Filter: Kalman filter, exact discretisation (the model is linear)");
  }
  // The EKF's gradient by the rule the fit used (core/filter/likelihood.h); the per-observation
  // scores are always forward sensitivities.
  const bool adjoint =
      extended && filter::Likelihood::AutoUsesAdjoint(static_cast<std::size_t>(n_free), ekf.method);
  line(exact_scores ? (adjoint    ? "Scores: exact (the gradient by the filter's adjoint, "
                                    "per-observation scores by forward sensitivities)"
                       : extended ? "Scores: exact (forward sensitivities of the filter)"
                                  : "Scores: exact (derivatives of the filter)")
                    : "Scores: central differences of log L; standard errors from second "
                      "differences");
  line("");
  line(fmt::format("Log-likelihood: {:.6f}   AIC: {:.3f}   BIC: {:.3f}   free parameters: {}",
                   loglik, aic, bic, n_free));
  if (log_posterior)
    line(fmt::format("MAP estimate (priors on some parameters): log posterior {:.6f}",
                     *log_posterior));
  if (starts > 1)
    line(fmt::format("{}: {} of {} starts reached the best optimum",
                     starts_for_bound ? "Extra starts (parameters ran off or ended on a bound)"
                     : released_starts > 0 && relaxed_starts > 0
                         ? "Starts with the diffusion relaxed and with the parameters that ran "
                           "off put back"
                     : released_starts > 0 ? "Starts with the parameters that ran off put back"
                     : relaxed_starts > 0  ? "Starts with the diffusion relaxed"
                                           : "Multistart",
                     starts_at_best, starts));
  if (relaxed_starts > 0)
    line(relaxed_better ? "A variance of the diffusion ended on a bound: fitted again with the "
                          "diffusion relaxed first, which reached a better optimum"
                        : "A variance of the diffusion ended on a bound: fitted again with the "
                          "diffusion relaxed first, which reached no better optimum");
  if (!log_scale.empty()) {
    // Which of them ended on the lower bound they crept towards (not released: they did not run
    // off).
    std::string names;
    for (const std::string& name : log_scale) {
      const auto p = std::find_if(parameters.begin(), parameters.end(),
                                  [&](const ParameterEstimate& e) { return e.name == name; });
      names += fmt::format("{}{}{}", names.empty() ? "" : ", ", name,
                           p != parameters.end() && p->at_bound ? " (ended on it)" : "");
    }
    line("Crept towards their lower bounds along a valley, so fitted on a log scale from there: " +
         names);
  }
  if (releases > 0)
    line(
        fmt::format("Parameters that ran off, put back to their start values: a better optimum "
                    "{} time{}",
                    releases, releases == 1 ? "" : "s"));
  if (optima.size() > 1) {
    // Each other optimum with the free parameters that differ most from the estimate.
    line(fmt::format("Distinct optima reached ({} of the starts, the estimate's first):",
                     log_posterior ? "log posterior" : "log L"));
    const std::size_t listed = std::min<std::size_t>(optima.size(), kListedOptima);
    for (std::size_t o = 0; o < listed; ++o) {
      const Optimum& opt = optima[o];
      std::string text =
          fmt::format("  {:.6f}  {} start{}{}", opt.loglik, opt.starts, opt.starts == 1 ? "" : "s",
                      opt.converged ? "" : " (stopped early)");
      std::string most;
      for (const std::size_t i : o > 0 ? DifferMost(o, 3) : std::vector<std::size_t>{})
        most += fmt::format("{}{} {:.4g} (estimate {:.4g})", most.empty() ? "" : ", ",
                            parameters[i].name, opt.theta[i], parameters[i].estimate);
      if (!most.empty()) text += "; differs most in " + most;
      line(text);
    }
    if (optima.size() > listed) line(fmt::format("  ... and {} more", optima.size() - listed));
  }
  for (const auto& d : delays) {
    if (!d.scanned && d.estimate == 0) continue;
    line(fmt::format("Output delay of {}: {} samples{}", d.output, d.estimate,
                     d.scanned ? " (estimated by profile likelihood)" : " (fixed)"));
  }
  line("");
  // Coefficient table.
  std::size_t w = 9;
  for (const auto& p : parameters) w = std::max(w, p.name.size() + 1);
  line(fmt::format("{:<{}} {:>13} {:>12} {:>10} {:>10}   {}", "", w, "Estimate", "Std. Error",
                   "t value", "Pr(>|t|)", "bounds"));
  for (const auto& p : parameters) {
    std::string bounds = p.fixed ? "fixed"
                                 : fmt::format("[{}, {}]", p.lower ? Num(*p.lower) : "-inf",
                                               p.upper ? Num(*p.upper) : "inf");
    if (p.at_bound) bounds += "  AT BOUND";
    std::string se = p.fixed ? "" : Opt(p.std_error, "-");
    line(fmt::format("{:<{}} {:>13} {:>12} {:>10} {:>10}   {}", p.name, w, Num(p.estimate), se,
                     p.t_value ? fmt::format("{:.3g}", *p.t_value) : "",
                     p.p_value ? PValue(*p.p_value) : "", bounds));
  }
  line("p-values: two-sided, Student's t with n_obs - n_free degrees of freedom.");
  // Profile likelihood intervals beside the Wald ones.
  bool any_profile = false;
  for (const auto& p : parameters) any_profile = any_profile || p.profile.has_value();
  if (any_profile) {
    double level = 0.95;
    for (const auto& p : parameters)
      if (p.profile) level = p.profile->level;
    const double zq = boost::math::quantile(boost::math::normal(), 0.5 + level / 2);
    line("");
    line(
        fmt::format("{:.0f} % intervals: profile likelihood (likelihood ratio) and Wald (estimate "
                    "+- {:.3f} SE):",
                    100 * level, zq));
    line(fmt::format("{:<{}} {:>13} {:>13}   {:>13} {:>13}", "", w, "profile lower",
                     "profile upper", "Wald lower", "Wald upper"));
    auto end = [](const std::optional<double>& v, bool at_bound) {
      return v ? Num(*v) : std::string(at_bound ? "(bound)" : "(none)");
    };
    for (const auto& p : parameters) {
      if (!p.profile) continue;
      const auto& pi = *p.profile;
      std::string wald_lo, wald_hi;
      if (p.std_error) {
        wald_lo = Num(p.estimate - zq * *p.std_error);
        wald_hi = Num(p.estimate + zq * *p.std_error);
      }
      line(fmt::format("{:<{}} {:>13} {:>13}   {:>13} {:>13}", p.name, w,
                       end(pi.lower, pi.lower_at_bound), end(pi.upper, pi.upper_at_bound), wald_lo,
                       wald_hi));
    }
    line("(bound): the profile stays within the threshold up to the parameter's bound.");
  }
  // Delay profile.
  for (const auto& d : delays) {
    if (!d.scanned) continue;
    line("");
    line(
        fmt::format("Profile log-likelihood of the {} delay (\">\": fit stopped early, a lower "
                    "bound):",
                    d.output));
    double best = -INFINITY;
    for (const auto& pt : d.profile)
      if (pt.loglik) best = std::max(best, *pt.loglik);
    for (const auto& pt : d.profile) {
      if (!pt.loglik) {
        line(fmt::format("  {:>4}  (failed)", pt.delay));
        continue;
      }
      line(fmt::format("  {:>4}  {}{:>15.4f}  {:>12.4f}{}", pt.delay, pt.converged ? " " : ">",
                       *pt.loglik, *pt.loglik - best,
                       pt.delay == d.estimate ? "  <- estimate" : ""));
    }
  }
  if (!correlation_names.empty() && correlation_names.size() <= 12) {
    line("");
    line("Correlation of the estimates:");
    std::string head = fmt::format("{:<{}}", "", w);
    for (const auto& n : correlation_names) head += fmt::format(" {:>7.7}", n);
    line(head);
    for (std::size_t a = 0; a < correlation_names.size(); ++a) {
      std::string row = fmt::format("{:<{}}", correlation_names[a], w);
      for (std::size_t b = 0; b <= a; ++b)
        row += fmt::format(" {:>7.3f}",
                           correlation(static_cast<Eigen::Index>(a), static_cast<Eigen::Index>(b)));
      line(row);
    }
  }
  if (!warnings.empty()) {
    line("");
    line("Warnings:");
    for (const auto& w_text : warnings) line("  - " + w_text);
  }
  return r;
}

Json EstimateSummary::ToJson() const {
  Json j;
  j["greybench_result"] = 1;
  j["model"] = model_name;
  j["datasets"] = datasets;
  j["converged"] = converged;
  if (cancelled) j["cancelled"] = true;  // stopped by the user: the best point so far
  j["message"] = message;
  j["loglik"] = loglik;
  j["n_obs"] = n_obs;
  j["n_free"] = n_free;
  j["aic"] = aic;
  j["bic"] = bic;
  j["iterations"] = iterations;
  j["evaluations"] = evaluations;
  j["elapsed_s"] = elapsed_s;
  if (extended) {
    j["filter"] = {{"kind", "ekf"},
                   {"ode", model::OdeMethodName(ekf.method)},
                   {"rtol", ekf.rtol},
                   {"atol", ekf.atol},
                   {"iterations", ekf.iterations},
                   {"ode_steps", ode.steps},
                   {"ode_intervals", ode.intervals},
                   {"stiff_intervals", ode.stiff_intervals},
                   {"code", native ? "native" : "interpreter"}};
  } else {
    j["filter"] = {{"kind", "kalman"}};
  }
  j["filter"]["scores"] = exact_scores ? "exact" : "differences";
  if (log_posterior) j["log_posterior"] = *log_posterior;
  j["starts"] = {{"total", starts},
                 {"at_best", starts_at_best},
                 {"on_bound", starts_for_bound},
                 {"releases", releases},
                 {"released", released_starts},
                 {"relaxed", relaxed_starts},
                 {"relaxed_better", relaxed_better}};
  j["log_scale"] = log_scale;
  Json optima_json = Json::array();
  for (const Optimum& opt : optima) {
    Json values = Json::object();
    for (std::size_t i = 0; i < parameters.size() && i < opt.theta.size(); ++i)
      values[parameters[i].name] = opt.theta[i];
    optima_json.push_back({{"loglik", opt.loglik},
                           {"starts", opt.starts},
                           {"converged", opt.converged},
                           {"parameters", values}});
  }
  j["optima"] = std::move(optima_json);
  if (steady_start) j["steady_start"] = steady_start->ToJson();
  Json params = Json::object();
  for (const auto& p : parameters) {
    Json e;
    e["estimate"] = p.estimate;
    e["std_error"] = OptJson(p.std_error);
    e["t_value"] = OptJson(p.t_value);
    e["p_value"] = OptJson(p.p_value);
    e["lower"] = OptJson(p.lower);
    e["upper"] = OptJson(p.upper);
    e["fixed"] = p.fixed;
    e["at_bound"] = p.at_bound;
    if (!p.unit.empty()) e["unit"] = p.unit;
    if (p.profile) {
      const auto& pi = *p.profile;
      e["profile_interval"] = {
          {"lower", OptJson(pi.lower)}, {"upper", OptJson(pi.upper)}, {"level", pi.level}};
      Json points = Json::array();
      for (const auto& pt : pi.curve) points.push_back({pt.value, pt.loglik, pt.converged});
      e["profile"] = {{"lower_at_bound", pi.lower_at_bound},
                      {"upper_at_bound", pi.upper_at_bound},
                      {"points", points}};
    }
    params[p.name] = e;
  }
  j["parameters"] = params;
  Json matrix = Json::array();
  for (Eigen::Index a = 0; a < correlation.rows(); ++a) {
    Json row = Json::array();
    for (Eigen::Index b = 0; b < correlation.cols(); ++b) row.push_back(correlation(a, b));
    matrix.push_back(row);
  }
  j["correlation"] = {{"names", correlation_names}, {"matrix", matrix}};
  Json delays_json = Json::object();
  for (const auto& d : delays) {
    Json e;
    e["estimate"] = d.estimate;
    e["scanned"] = d.scanned;
    Json prof = Json::array();
    for (const auto& pt : d.profile)
      prof.push_back(
          {{"delay", pt.delay}, {"loglik", OptJson(pt.loglik)}, {"converged", pt.converged}});
    e["profile"] = prof;
    delays_json[d.output] = e;
  }
  j["output_delay"] = delays_json;
  j["warnings"] = warnings;
  return j;
}

std::string LikelihoodRatioTest::Report() const {
  return fmt::format(
      "Likelihood-ratio test of the restricted model against the full one:\n"
      "  statistic 2 (log L_full - log L_restricted) = {:.4f}\n"
      "  degrees of freedom = {}\n"
      "  p-value P(chi2_{} > statistic) = {}\n"
      "  {}\n",
      statistic, df, df, PValue(p_value),
      p_value < 0.05 ? "The full model fits significantly better (5 % level): keep the extra "
                       "parameters."
                     : "The full model is not significantly better (5 % level): the restricted "
                       "model suffices.");
}

}  // namespace gb::estimate
