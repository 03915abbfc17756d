#include <charconv>
#include <cmath>
#include <cstdio>
#include <set>

#include <fmt/format.h>

#include "app/cli/cli.h"
#include "core/project/problem.h"
#include "core/project/project.h"
#include "core/project/result_file.h"

namespace gb::cli {

int Fail(const Error& e) {
  std::fprintf(stderr, "greybench-cli: error: %s\n", e.ToString().c_str());
  return e.kind == ErrorKind::kNumerical ? 1 : 2;
}

int GuardOutputs(const std::vector<FileRole>& inputs, const std::vector<FileRole>& outputs) {
  if (auto st = CheckOutputs(inputs, outputs); !st) return Fail(st.error());
  return 0;
}

std::vector<FileRole> DataFiles(const std::vector<std::string>& paths) {
  std::vector<FileRole> files;
  for (const std::string& p : paths) files.push_back({p, "the data file"});
  return files;
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
    if (auto d = project::ApplyResultFile(start_result, set_names, &*spec, /*free_only=*/true); !d)
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
