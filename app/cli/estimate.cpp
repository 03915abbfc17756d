#include "core/estimate/estimate.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <optional>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "app/cli/cli.h"
#include "core/project/project.h"
#include "core/project/result_file.h"
#include "core/util/file.h"

namespace gb::cli {

int RunEstimate(const EstimateArgs& args) {
  auto in = ResolveInputs(args.model, args.data, args.initial_states);
  if (!in) return Fail(in.error());
  std::vector<FileRole> inputs = in->Files();
  inputs.push_back({args.start, "the --start result file"});
  if (int s = GuardOutputs(inputs, {{args.out, "--out"}, {args.checkpoint, "--checkpoint"}}))
    return s;
  auto loaded = LoadLikelihood(*in, args.sets, args.start);
  if (!loaded) return Fail(loaded.error());
  // What the data were, byte for byte, as read: `compare` refuses fits to other data.
  Json fingerprints = Json::array();
  for (const data::DatasetSpec& d : data::WithRole(in->datasets, data::Role::kEstimation))
    fingerprints.push_back(FileFingerprint(d.file));
  // A fit may take minutes: a result file that cannot be written is reported before it.
  if (!args.out.empty())
    if (auto st = CheckWritable(args.out); !st) return Fail(st.error());
  const filter::Likelihood* lik = &loaded->likelihood;
  estimate::EstimateOptions options;
  options.threads = args.threads;
  options.multistart = args.multistart;
  options.starts_on_bound = args.starts_on_bound;
  options.score_differences = args.score_differences;
  options.log_scale = args.log_scale;
  options.max_evaluations = args.max_evaluations;
  options.ftol_rel = args.ftol;
  options.profile_intervals = args.profile_intervals;
  options.profile_level = args.profile_level;
  options.steady_start = args.steady_start;
  options.steady_window = args.steady_window;
  if (!args.checkpoint.empty())
    if (auto st = CheckWritable(args.checkpoint); !st) return Fail(st.error());
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
      (void)WriteFileAtomic(args.checkpoint, j.dump(1) + "\n");
    };
  }
  if (args.algorithm == "auto")
    options.algorithm = estimate::Algorithm::kAuto;
  else if (args.algorithm == "bhhh")
    options.algorithm = estimate::Algorithm::kBhhh;
  else if (args.algorithm == "lbfgs")
    options.algorithm = estimate::Algorithm::kLbfgs;
  else if (args.algorithm == "slsqp")
    options.algorithm = estimate::Algorithm::kSlsqp;
  else if (args.algorithm == "bobyqa")
    options.algorithm = estimate::Algorithm::kBobyqa;
  else if (args.algorithm == "trust-region")
    options.algorithm = estimate::Algorithm::kTrustRegion;
  else
    return Fail(InputError("--algorithm: use auto, bhhh, slsqp, lbfgs, bobyqa or trust-region"));
  auto summary = estimate::Estimate(*lik, options);
  if (!summary) return Fail(summary.error());
  std::printf("%s", summary->Report().c_str());
  if (!args.out.empty()) {
    // The model file, relative to the result's folder, so that `linearise` finds it.
    Json j = summary->ToJson();
    namespace fs = std::filesystem;
    std::error_code ec;
    const fs::path dir = fs::absolute(fs::path(args.out), ec).parent_path();
    const auto relative = [&](const std::string& p) {
      const fs::path rel = fs::absolute(fs::path(p), ec).lexically_relative(dir);
      return rel.empty() ? p : rel.generic_string();
    };
    if (!in->model_path.empty()) j["model_file"] = relative(in->model_path);
    if (!in->project_path.empty()) j["project_file"] = relative(in->project_path);
    j["data_fingerprints"] = fingerprints;
    // How the records started: predict and diagnose read a result of a fit per record so.
    if (!lik->series_parameters().empty()) j["initial_states"] = "per_record";
    if (auto st = WriteFileAtomic(args.out, j.dump(1) + "\n"); !st) return Fail(st.error());
  }
  return summary->converged ? 0 : 1;
}

int RunCompare(const CompareArgs& args) {
  auto read = [](const std::string& path) -> Result<project::NestedFit> {
    auto j = ReadJsonFile(path);
    if (!j) return j.error();
    return project::ReadNestedFit(*j, path);
  };
  auto a = read(args.a);
  if (!a) return Fail(a.error());
  auto b = read(args.b);
  if (!b) return Fail(b.error());
  if (a->n_free == b->n_free)
    return Fail(
        InputError(fmt::format("{} and {} have the same number of free parameters ({}): "
                               "a likelihood-ratio test needs nested models",
                               args.a, args.b, a->n_free)));
  const bool a_restricted = a->n_free < b->n_free;
  const project::NestedFit& r = a_restricted ? *a : *b;
  const project::NestedFit& f = a_restricted ? *b : *a;
  bool by_name_only = false;
  if (const std::string why = project::WhyNotNested(r, f, &by_name_only); !why.empty())
    return Fail(InputError("no likelihood-ratio test: " + why));
  auto test = estimate::CompareNested(r.loglik, r.n_free, f.loglik, f.n_free);
  if (!test) return Fail(test.error());
  std::printf("restricted: %s (log L %.6f, %d free)\nfull:       %s (log L %.6f, %d free)\n",
              r.path.c_str(), r.loglik, r.n_free, f.path.c_str(), f.loglik, f.n_free);
  std::printf("%s", test->Report().c_str());
  if (by_name_only)
    std::printf(
        "  note: a result file does not record its data's fingerprint (written by an "
        "older greybench): the data were matched by file name and count only.\n");
  if (r.model != f.model)
    std::printf(
        "  note: the models have different names (%s, %s); they were found nested by "
        "their parameters only.\n",
        r.model.c_str(), f.model.c_str());
  if (f.loglik < r.loglik)
    std::printf(
        "  note: the full model's log-likelihood is below the restricted one's: its fit "
        "did not reach the optimum, or the models are not nested.\n");
  return 0;
}

}  // namespace gb::cli
