#include "core/project/result_file.h"

#include <fmt/format.h>

#include <cmath>

#include "core/project/project.h"

namespace gb::project {

Error ResultFileError(const std::string& file, const std::string& path,
                      const std::string& message) {
  Error e = InputError(message);
  e.file = file;
  e.path = path;
  return e;
}

Result<std::vector<int>> ApplyResultFile(const std::string& path, const std::set<std::string>& keep,
                                         model::ModelSpec* spec, bool free_only, Json* json) {
  auto j = ReadJsonFile(path);
  if (!j) return j.error();
  if (!j->is_object() || !j->contains("greybench_result"))
    return ResultFileError(path, "", "not a greybench result file (no \"greybench_result\")");
  if (json) *json = *j;
  const Json& params = (*j)["parameters"];
  if (!params.is_object())
    return ResultFileError(path, "parameters", "expected an object of parameter estimates");
  for (const auto& [name, entry] : params.items()) {
    const std::string where = "parameters." + name;
    if (keep.count(name)) continue;
    const int i = spec->ParameterIndex(name);
    if (i < 0)
      return ResultFileError(path, where,
                             fmt::format("the model {} has no parameter '{}': is the result from "
                                         "another model?",
                                         spec->source, name));
    if (!entry.is_object() || !entry.contains("estimate") || !entry["estimate"].is_number())
      return ResultFileError(path, where + ".estimate", "expected a number");
    const double value = entry["estimate"].get<double>();
    model::Parameter& par = spec->parameters[i];
    if (free_only && par.fixed) continue;
    if (!std::isfinite(value) ||
        (!par.fixed && ((par.lower && value < *par.lower) || (par.upper && value > *par.upper))))
      return ResultFileError(path, where + ".estimate",
                             fmt::format("{} is outside the bounds the model {} gives '{}'", value,
                                         spec->source, name));
    par.value = value;
  }
  // A free parameter the result does not name would silently keep the model's start value:
  // the result is from another model (or another version of it).
  std::string missing;
  for (const model::Parameter& par : spec->parameters)
    if (!par.fixed && !keep.count(par.name) && !params.contains(par.name))
      missing += (missing.empty() ? "'" : ", '") + par.name + "'";
  if (!missing.empty())
    return ResultFileError(
        path, "parameters",
        fmt::format("no estimate of the model's free parameter{} {} (the model {}): is the result "
                    "from another model? Give a value with --set NAME=VALUE, or fix the parameter",
                    missing.find(',') == std::string::npos ? "" : "s", missing, spec->source));
  std::vector<int> delay(spec->outputs.size(), -1);
  if (j->contains("output_delay")) {
    const Json& delays = (*j)["output_delay"];
    if (!delays.is_object()) return ResultFileError(path, "output_delay", "expected an object");
    for (const auto& [name, entry] : delays.items()) {
      const std::string where = "output_delay." + name + ".estimate";
      const int o = spec->OutputIndex(name);
      if (o < 0)
        return ResultFileError(path, "output_delay." + name,
                               fmt::format("the model {} has no output '{}'", spec->source, name));
      if (!entry.is_object() || !entry["estimate"].is_number_integer())
        return ResultFileError(path, where, "expected a whole number of samples");
      const int d = entry["estimate"].get<int>();
      const model::DelaySpec& range = spec->output_delay[o];
      if (d < range.min || d > range.max)
        return ResultFileError(path, where,
                               fmt::format("delay {} is outside the model's range {}..{} for '{}'",
                                           d, range.min, range.max, name));
      delay[o] = d;
    }
  }
  return delay;
}

}  // namespace gb::project
