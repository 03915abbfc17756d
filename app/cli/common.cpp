#include <charconv>
#include <cmath>
#include <cstdio>
#include <set>

#include <fmt/format.h>

#include "app/cli/cli.h"
#include "core/project/problem.h"
#include "core/project/project.h"

namespace gb::cli {

namespace {

Error ResultError(const std::string& file, const std::string& path, const std::string& message) {
  Error e = InputError(message);
  e.file = file;
  e.path = path;
  return e;
}

}  // namespace

Result<std::vector<int>> ApplyResult(const std::string& path, const std::set<std::string>& keep,
                                     model::ModelSpec* spec, bool free_only) {
  auto j = project::ReadJsonFile(path);
  if (!j) return j.error();
  if (!j->is_object() || !j->contains("greybench_result"))
    return ResultError(path, "", "not a greybench result file (no \"greybench_result\")");
  const Json& params = (*j)["parameters"];
  if (!params.is_object())
    return ResultError(path, "parameters", "expected an object of parameter estimates");
  for (const auto& [name, entry] : params.items()) {
    const std::string where = "parameters." + name;
    if (keep.count(name)) continue;
    const int i = spec->ParameterIndex(name);
    if (i < 0)
      return ResultError(path, where,
                         fmt::format("the model {} has no parameter '{}': is the result from "
                                     "another model?",
                                     spec->source, name));
    if (!entry.is_object() || !entry.contains("estimate") || !entry["estimate"].is_number())
      return ResultError(path, where + ".estimate", "expected a number");
    const double value = entry["estimate"].get<double>();
    model::Parameter& par = spec->parameters[i];
    if (free_only && par.fixed) continue;
    if (!std::isfinite(value) ||
        (!par.fixed && ((par.lower && value < *par.lower) || (par.upper && value > *par.upper))))
      return ResultError(path, where + ".estimate",
                         fmt::format("{} is outside the bounds the model {} gives '{}'", value,
                                     spec->source, name));
    par.value = value;
  }
  std::vector<int> delay(spec->outputs.size(), -1);
  if (j->contains("output_delay")) {
    const Json& delays = (*j)["output_delay"];
    if (!delays.is_object()) return ResultError(path, "output_delay", "expected an object");
    for (const auto& [name, entry] : delays.items()) {
      const std::string where = "output_delay." + name + ".estimate";
      const int o = spec->OutputIndex(name);
      if (o < 0)
        return ResultError(path, "output_delay." + name,
                           fmt::format("the model {} has no output '{}'", spec->source, name));
      if (!entry.is_object() || !entry["estimate"].is_number_integer())
        return ResultError(path, where, "expected a whole number of samples");
      const int d = entry["estimate"].get<int>();
      const model::DelaySpec& range = spec->output_delay[o];
      if (d < range.min || d > range.max)
        return ResultError(path, where,
                           fmt::format("delay {} is outside the model's range {}..{} for '{}'", d,
                                       range.min, range.max, name));
      delay[o] = d;
    }
  }
  return delay;
}

int Fail(const Error& e) {
  std::fprintf(stderr, "greybench-cli: error: %s\n", e.ToString().c_str());
  return e.kind == ErrorKind::kNumerical ? 1 : 2;
}

Result<model::ModelSpec> LoadModelWithOverrides(const std::string& path,
                                                const std::vector<std::string>& sets) {
  auto spec = model::LoadModelFile(path);
  if (!spec) return spec.error();
  for (const auto& s : sets) {
    const auto eq = s.find('=');
    if (eq == std::string::npos || eq == 0)
      return InputError(fmt::format("--set '{}': expected NAME=VALUE", s));
    const std::string name = s.substr(0, eq);
    const std::string text = s.substr(eq + 1);
    double value = 0;
    const char* end = text.data() + text.size();
    auto [ptr, ec] = std::from_chars(text.data(), end, value);
    if (ec == std::errc::result_out_of_range && ptr == end)
      return InputError(fmt::format("--set {}: '{}' is out of the range of a double", name, text));
    if (ec != std::errc() || ptr != end || text.empty())
      return InputError(fmt::format("--set {}: '{}' is not a number", name, text));
    if (auto st = model::SetParameter(&*spec, name, value); !st) return st.error();
  }
  return spec;
}

Result<LoadedLikelihood> LoadLikelihood(const std::string& model_path,
                                        const std::vector<std::string>& data_paths,
                                        const std::vector<std::string>& sets,
                                        const std::string& start_result) {
  auto spec = LoadModelWithOverrides(model_path, sets);
  if (!spec) return spec.error();
  if (!start_result.empty()) {
    std::set<std::string> set_names;
    for (const auto& s : sets) set_names.insert(s.substr(0, s.find('=')));
    if (auto d = ApplyResult(start_result, set_names, &*spec, /*free_only=*/true); !d)
      return d.error();
  }
  std::vector<double> theta = spec->Values();
  auto problem = project::LoadProblem(std::move(*spec), data_paths);
  if (!problem) return problem.error();
  auto lik = project::MakeLikelihood(*problem);
  if (!lik) return lik.error();
  return LoadedLikelihood{std::move(*lik), std::move(theta)};
}

}  // namespace gb::cli
