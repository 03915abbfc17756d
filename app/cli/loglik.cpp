#include <algorithm>
#include <chrono>
#include <cstdio>

#include "app/cli/cli.h"
#include "core/util/json.h"

namespace gb::cli {

int RunLoglik(const LoglikArgs& args) {
  auto in = ResolveInputs(args.model, args.data, args.initial_states);
  if (!in) return Fail(in.error());
  auto loaded = LoadLikelihood(*in, args.sets);
  if (!loaded) return Fail(loaded.error());
  UseNativeCode(&loaded->likelihood);
  const filter::Likelihood* lik = &loaded->likelihood;
  const std::vector<double>& theta = loaded->theta;

  Json out;
  const auto& model = lik->spec();
  std::vector<int> delay;  // the delay the gradient is taken at (empty: each output's min)
  if (!model.HasDelayScan()) {
    auto l = lik->Evaluate(theta);
    if (!l) return Fail(l.error());
    out["loglik"] = l->loglik;
    out["n_obs"] = l->n_obs;
  } else {
    // At fixed θ the delay is chosen by profile likelihood over the model's ranges, every
    // candidate scored on the same observations.
    auto profile = lik->Profile(theta);
    if (!profile) return Fail(profile.error());
    if (profile->best < 0) return Fail(NumericalError(profile->candidates.front().message));
    const auto& best = profile->candidates[profile->best];
    out["loglik"] = best.loglik;
    out["n_obs"] = best.n_obs;
    Json delays = Json::object();
    for (std::size_t o = 0; o < model.outputs.size(); ++o) {
      Json prof = Json::array();
      for (const auto& c : profile->candidates) {
        Json entry = {{"delay", c.delay[o]}};
        entry["loglik"] = c.ok ? Json(c.loglik) : Json(nullptr);
        prof.push_back(entry);
      }
      delays[model.outputs[o]] = {{"estimate", best.delay[o]}, {"profile", prof}};
    }
    out["output_delay"] = delays;
    delay = best.delay;
  }
  if (args.gradient) {
    std::vector<int> free;
    for (std::size_t i = 0; i < model.parameters.size(); ++i)
      if (!model.parameters[i].fixed) free.push_back(static_cast<int>(i));
    Eigen::VectorXd gradient;
    auto l = lik->EvaluateWithScore(theta, delay, free, &gradient);
    if (!l) return Fail(l.error());
    Json g = Json::object();
    for (std::size_t f = 0; f < free.size(); ++f)
      g[model.parameters[free[f]].name] = gradient(static_cast<Eigen::Index>(f));
    out["gradient"] = g;
  }
  // A linear model's output is as user guide §4 gives it.
  if (lik->nonlinear()) out["filter"] = "ekf";
  std::printf("%s\n", out.dump().c_str());
  return 0;
}

int RunBench(const BenchArgs& args) {
  auto in = ResolveInputs(args.model, args.data);
  if (!in) return Fail(in.error());
  auto loaded = LoadLikelihood(*in, args.sets);
  if (!loaded) return Fail(loaded.error());
  // The filter a fit would time.
  const bool native = UseNativeCode(&loaded->likelihood);
  const filter::Likelihood* lik = &loaded->likelihood;
  const std::vector<double>& theta = loaded->theta;
  if (args.repeat < 1) return Fail(InputError("--repeat must be at least 1"));

  std::vector<double> seconds;
  long n_obs = 0;
  ode::OdeCounts per_evaluation;  // the ODE solver's work in one evaluation (a nonlinear model)
  for (int r = 0; r < args.repeat + 1; ++r) {  // the first run warms caches and is not counted
    const ode::OdeCounts before = lik->ode_counts();
    const auto start = std::chrono::steady_clock::now();
    auto l = lik->Evaluate(theta);
    const auto stop = std::chrono::steady_clock::now();
    if (!l) return Fail(l.error());
    n_obs = l->n_obs;
    if (r > 0) seconds.push_back(std::chrono::duration<double>(stop - start).count());
    const ode::OdeCounts after = lik->ode_counts();
    per_evaluation = {after.intervals - before.intervals,
                      after.stiff_intervals - before.stiff_intervals, after.steps - before.steps,
                      after.rejected - before.rejected, after.rhs - before.rhs};
  }
  std::nth_element(seconds.begin(), seconds.begin() + seconds.size() / 2, seconds.end());
  Json out;
  out["loglik_eval_s"] = seconds[seconds.size() / 2];
  out["n_obs"] = n_obs;
  if (lik->nonlinear()) {
    out["code"] = native ? "native" : "interpreter";
    out["ode"] = {{"intervals", per_evaluation.intervals},
                  {"stiff_intervals", per_evaluation.stiff_intervals},
                  {"steps", per_evaluation.steps},
                  {"rejected", per_evaluation.rejected},
                  {"rhs", per_evaluation.rhs}};
  }
  std::printf("%s\n", out.dump().c_str());
  return 0;
}

}  // namespace gb::cli
