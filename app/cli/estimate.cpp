#include <chrono>
#include <cstdio>
#include <filesystem>

#include <fmt/format.h>

#include "app/cli/cli.h"
#include "core/estimate/estimate.h"
#include "core/project/project.h"

namespace gb::cli {

int RunEstimate(const EstimateArgs& args) {
  auto loaded = LoadLikelihood(args.model, args.data, args.sets, args.start);
  if (!loaded) return Fail(loaded.error());
  // A fit may take minutes: a result file that cannot be written is reported before it.
  if (!args.out.empty())
    if (auto st = project::CheckWritable(args.out); !st) return Fail(st.error());
  const filter::Likelihood* lik = &loaded->likelihood;
  estimate::EstimateOptions options;
  options.threads = args.threads;
  options.multistart = args.multistart;
  options.starts_on_bound = args.starts_on_bound;
  options.score_differences = args.score_differences;
  options.max_evaluations = args.max_evaluations;
  options.ftol_rel = args.ftol;
  options.profile_intervals = args.profile_intervals;
  options.profile_level = args.profile_level;
  options.steady_start = args.steady_start;
  options.steady_window = args.steady_window;
  if (!args.checkpoint.empty())
    if (auto st = project::CheckWritable(args.checkpoint); !st) return Fail(st.error());
  if (args.progress || !args.checkpoint.empty()) {
    const auto start = std::chrono::steady_clock::now();
    const model::ModelSpec& spec = lik->spec();
    options.progress = [start, &args, &spec](const estimate::Progress& p) {
      if (args.progress) {
        const double s =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        std::fprintf(stderr, "[%7.1f s] %s: iteration %d, %d evaluations, log L %.10g\n", s,
                     p.stage.c_str(), p.iteration, p.evaluations, p.loglik);
      }
      if (args.checkpoint.empty() || p.theta.size() != spec.parameters.size()) return;
      // The best point so far as a result file --start reads (estimates only).
      Json j;
      j["greybench_result"] = 1;
      j["model"] = spec.name;
      j["partial"] = true;
      j["stage"] = p.stage;
      j["iteration"] = p.iteration;
      j["loglik"] = p.loglik;
      Json params = Json::object();
      for (std::size_t i = 0; i < spec.parameters.size(); ++i)
        if (!spec.parameters[i].fixed) params[spec.parameters[i].name] = {{"estimate", p.theta[i]}};
      j["parameters"] = params;
      if (!p.delay.empty()) {
        Json delays = Json::object();
        for (std::size_t o = 0; o < p.delay.size() && o < spec.outputs.size(); ++o)
          delays[spec.outputs[o]] = {{"estimate", p.delay[o]}};
        j["output_delay"] = delays;
      }
      // A checkpoint that cannot be written is not worth stopping the fit for.
      (void)project::WriteFileAtomic(args.checkpoint, j.dump(1) + "\n");
    };
  }
  if (args.algorithm == "auto") options.algorithm = estimate::Algorithm::kAuto;
  else if (args.algorithm == "bhhh") options.algorithm = estimate::Algorithm::kBhhh;
  else if (args.algorithm == "lbfgs") options.algorithm = estimate::Algorithm::kLbfgs;
  else if (args.algorithm == "slsqp") options.algorithm = estimate::Algorithm::kSlsqp;
  else if (args.algorithm == "bobyqa") options.algorithm = estimate::Algorithm::kBobyqa;
  else return Fail(InputError("--algorithm: use auto, bhhh, slsqp, lbfgs or bobyqa"));
  auto summary = estimate::Estimate(*lik, options);
  if (!summary) return Fail(summary.error());
  std::printf("%s", summary->Report().c_str());
  if (!args.out.empty()) {
    // The model file, relative to the result's folder, so that `linearise` finds it.
    Json j = summary->ToJson();
    namespace fs = std::filesystem;
    std::error_code ec;
    const fs::path dir = fs::absolute(fs::path(args.out), ec).parent_path();
    const fs::path rel = fs::absolute(fs::path(args.model), ec).lexically_relative(dir);
    j["model_file"] = rel.empty() ? args.model : rel.generic_string();
    if (auto st = project::WriteFileAtomic(args.out, j.dump(1) + "\n"); !st)
      return Fail(st.error());
  }
  return summary->converged ? 0 : 1;
}

int RunCompare(const CompareArgs& args) {
  struct Fit {
    double loglik;
    int n_free;
  };
  auto read = [](const std::string& path) -> Result<Fit> {
    auto j = project::ReadJsonFile(path);
    if (!j) return j.error();
    auto fail = [&](const std::string& what) {
      Error e = InputError(what);
      e.file = path;
      return e;
    };
    if (!j->is_object() || !j->contains("greybench_result"))
      return fail("not a greybench result file (no \"greybench_result\")");
    if (!(*j)["loglik"].is_number()) return fail("loglik: expected a number");
    if (!(*j)["n_free"].is_number_integer()) return fail("n_free: expected a whole number");
    return Fit{(*j)["loglik"].get<double>(), (*j)["n_free"].get<int>()};
  };
  auto a = read(args.a);
  if (!a) return Fail(a.error());
  auto b = read(args.b);
  if (!b) return Fail(b.error());
  if (a->n_free == b->n_free)
    return Fail(InputError(fmt::format("{} and {} have the same number of free parameters ({}): "
                                       "a likelihood-ratio test needs nested models",
                                       args.a, args.b, a->n_free)));
  const bool a_restricted = a->n_free < b->n_free;
  const Fit& r = a_restricted ? *a : *b;
  const Fit& f = a_restricted ? *b : *a;
  auto test = estimate::CompareNested(r.loglik, r.n_free, f.loglik, f.n_free);
  if (!test) return Fail(test.error());
  std::printf("restricted: %s (log L %.6f, %d free)\nfull:       %s (log L %.6f, %d free)\n",
              (a_restricted ? args.a : args.b).c_str(), r.loglik, r.n_free,
              (a_restricted ? args.b : args.a).c_str(), f.loglik, f.n_free);
  std::printf("%s", test->Report().c_str());
  if (f.loglik < r.loglik)
    std::printf("  note: the full model's log-likelihood is below the restricted one's: its fit "
                "did not reach the optimum, or the models are not nested.\n");
  return 0;
}

}  // namespace gb::cli
