#include <charconv>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <set>

#include <fmt/format.h>

#include "app/cli/cli.h"
#include "core/expr/native.h"
#include "core/project/problem.h"
#include "core/project/project.h"
#include "core/project/result_file.h"
#include "core/util/file.h"

namespace gb::cli {

int Fail(const Error& e) {
  std::fprintf(stderr, "greybench-cli: error: %s\n", e.ToString().c_str());
  return e.kind == ErrorKind::kNumerical ? 1 : 2;
}

int GuardOutputs(const std::vector<FileRole>& inputs, const std::vector<FileRole>& outputs) {
  if (auto st = CheckOutputs(inputs, outputs); !st) return Fail(st.error());
  return 0;
}

namespace {

Result<model::ModelSpec> ApplySets(model::ModelSpec spec, const std::vector<std::string>& sets) {
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
    if (auto st = model::SetParameter(&spec, name, value); !st) return st.error();
  }
  return spec;
}

}  // namespace

std::vector<FileRole> CommandInputs::Files() const {
  std::vector<FileRole> files = project_files;
  if (!project_path.empty()) files.push_back({project_path, "the project file"});
  if (!model_path.empty()) files.push_back({model_path, "the model file"});
  for (const data::DatasetSpec& d : datasets) files.push_back({d.file, "the data file"});
  return files;
}

bool IsProjectFile(const std::string& path) {
  auto j = ReadJsonFile(path);
  return j && j->is_object() && j->contains("greybench_project");
}

std::string NamedFile(const Json& result, const char* key, const std::string& result_path) {
  if (!result.is_object() || !result.contains(key) || !result[key].is_string()) return "";
  const std::filesystem::path file = result[key].get<std::string>();
  if (file.empty() || file.is_absolute()) return file.string();
  return (std::filesystem::path(result_path).parent_path() / file).lexically_normal().string();
}

namespace {

Result<CommandInputs> ResolveFiles(const std::string& first, const std::vector<std::string>& data) {
  CommandInputs in;
  if (!IsProjectFile(first)) {
    if (data.empty()) {
      return InputError(fmt::format(
          "{} is a model file: give the data files after it (or a project file in its place)",
          first));
    }
    in.model_path = first;
    in.datasets = project::PlainDatasets(data);
    return in;
  }
  auto p = project::LoadProject(first);
  if (!p) return p.error();
  in.project_path = first;
  in.project_files = project::ProjectFiles(*p);
  in.model_path = p->model_path;
  if (p->model_path.empty()) in.inline_model = p->model_json;
  in.datasets = data.empty() ? p->datasets : project::PlainDatasets(data);
  in.per_record_initial_states =
      project::ReadEstimationDefaults(*p).per_record_initial_states.value_or(false);
  if (in.datasets.empty()) {
    Error e = InputError("the project lists no datasets: add some, or give data files after it");
    e.file = first;
    e.path = "datasets";
    return e;
  }
  return in;
}

}  // namespace

Result<CommandInputs> ResolveInputs(const std::string& first, const std::vector<std::string>& data,
                                    const std::string& initial_states) {
  auto resolved = ResolveFiles(first, data);
  if (resolved && !initial_states.empty())
    resolved->per_record_initial_states = initial_states == "per_record";
  return resolved;
}

Result<std::vector<data::DatasetSpec>> FittedDatasets(const CommandInputs& in) {
  std::vector<data::DatasetSpec> fitted = data::WithRole(in.datasets, data::Role::kEstimation);
  if (fitted.empty()) {
    Error e = InputError(
        "every dataset of the project has the role \"validation\": none is left to fit (give "
        "one \"role\": \"estimation\")");
    e.file = in.project_path;
    e.path = "datasets";
    return e;
  }
  return fitted;
}

Result<data::DatasetSpec> ChooseDataset(const CommandInputs& in, const std::string& choice) {
  const auto list = [&] {
    std::string out;
    for (std::size_t i = 0; i < in.datasets.size(); ++i)
      out += fmt::format("{}{} {} ({})", i ? ", " : "", i + 1, in.datasets[i].DisplayName(),
                         data::RoleName(in.datasets[i].role));
    return out;
  };
  if (choice.empty()) {
    if (in.datasets.size() == 1) return in.datasets.front();
    return InputError(
        fmt::format("the project has {} datasets: choose one with --dataset (its "
                    "number, name or file name): {}",
                    in.datasets.size(), list()));
  }
  int number = 0;
  const auto [ptr, ec] = std::from_chars(choice.data(), choice.data() + choice.size(), number);
  if (ec == std::errc() && ptr == choice.data() + choice.size()) {
    if (number >= 1 && number <= static_cast<int>(in.datasets.size()))
      return in.datasets[static_cast<std::size_t>(number - 1)];
  }
  for (const data::DatasetSpec& d : in.datasets) {
    if (d.DisplayName() == choice || d.name == choice ||
        std::filesystem::path(d.file).filename().string() == choice || d.file == choice)
      return d;
  }
  return InputError(
      fmt::format("--dataset {}: no such dataset; the datasets are: {}", choice, list()));
}

Result<project::RecordInitialStates> FittedModel(const CommandInputs& in, model::ModelSpec spec) {
  const std::size_t fitted = data::WithRole(in.datasets, data::Role::kEstimation).size();
  if (!in.per_record_initial_states || fitted < 2) {
    project::RecordInitialStates same;
    same.spec = std::move(spec);
    return same;
  }
  return project::PerRecordInitialStates(std::move(spec), static_cast<int>(fitted));
}

Result<model::ModelSpec> LoadModelWithOverrides(const CommandInputs& in,
                                                const std::vector<std::string>& sets) {
  if (!in.model_path.empty()) return LoadModelWithOverrides(in.model_path, sets);
  auto spec = model::ParseModel(in.inline_model, in.project_path);
  if (!spec) {
    Error e = spec.error();
    e.path = e.path.empty() ? "model" : "model." + e.path;
    return e;
  }
  return ApplySets(std::move(*spec), sets);
}

Result<model::ModelSpec> LoadModelWithOverrides(const std::string& path,
                                                const std::vector<std::string>& sets) {
  auto spec = model::LoadModelFile(path);
  if (!spec) return spec.error();
  return ApplySets(std::move(*spec), sets);
}

Result<LoadedLikelihood> LoadLikelihood(const CommandInputs& in,
                                        const std::vector<std::string>& sets,
                                        const std::string& start_result) {
  auto fitted = FittedDatasets(in);
  if (!fitted) return fitted.error();
  auto spec = LoadModelWithOverrides(in, sets);
  if (!spec) return spec.error();
  const auto initial = in.per_record_initial_states ? project::InitialStates::kPerRecord
                                                    : project::InitialStates::kShared;
  if (!start_result.empty()) {
    // A result of a fit per record holds every record's copies: the model takes them first.
    auto model = FittedModel(in, std::move(*spec));
    if (!model) return model.error();
    spec = std::move(model->spec);
    std::set<std::string> set_names;
    for (const auto& s : sets) set_names.insert(s.substr(0, s.find('=')));
    if (auto d = project::ApplyResultFile(start_result, set_names, &*spec, /*free_only=*/true); !d)
      return d.error();
  }
  auto problem = project::LoadProblem(std::move(*spec), *fitted, initial);
  if (!problem) return problem.error();
  auto lik = project::MakeLikelihood(*problem);
  if (!lik) return lik.error();
  std::vector<double> theta = problem->spec().Values();  // with the copies' starts
  return LoadedLikelihood{std::move(*lik), std::move(theta)};
}

std::vector<diagnose::InputSeries> DiagnoseInputs(const EvaluatedSeries& e,
                                                  std::vector<std::vector<double>>* values) {
  const model::ModelSpec& m = e.spec();
  const data::Series& s = *e.series;
  values->clear();
  for (std::size_t i = 0; i < m.inputs.size(); ++i)
    values->emplace_back(s.U.row(static_cast<Eigen::Index>(i)).begin(),
                         s.U.row(static_cast<Eigen::Index>(i)).end());
  std::vector<diagnose::InputSeries> inputs;
  for (std::size_t i = 0; i < m.inputs.size(); ++i) inputs.push_back({m.inputs[i], (*values)[i]});
  return inputs;
}

bool UseNativeCode(filter::Likelihood* likelihood) {
  if (!likelihood->nonlinear() || !expr::NativeCode::Enabled()) return false;
  auto native = likelihood->WithNativeCode();
  if (!native) return false;
  *likelihood = std::move(*native);
  return true;
}

}  // namespace gb::cli
