#include "core/project/problem.h"

namespace gb::project {

Result<Problem> MakeProblem(model::ModelSpec spec,
                            std::vector<std::shared_ptr<const data::Dataset>> datasets) {
  Problem p;
  if (auto lm = model::LinearModel::Compile(spec)) {
    p.model = std::make_shared<const model::LinearModel>(std::move(*lm));
  } else {
    auto nm = model::NonlinearModel::Compile(std::move(spec));
    if (!nm) return nm.error();
    p.nonlinear = std::make_shared<const model::NonlinearModel>(std::move(*nm));
  }
  for (const auto& d : datasets) {
    auto s = data::Bind(*d, p.spec().inputs, p.spec().outputs);
    if (!s) return s.error();
    p.series.push_back(*s);
  }
  p.datasets = std::move(datasets);
  return p;
}

Result<Problem> LoadProblem(model::ModelSpec spec, const std::vector<data::DatasetSpec>& data) {
  std::vector<std::shared_ptr<const data::Dataset>> datasets;
  for (const data::DatasetSpec& d : data) {
    auto read = data::ReadDataset(d);
    if (!read) return read.error();
    datasets.push_back(*read);
  }
  return MakeProblem(std::move(spec), std::move(datasets));
}

Result<Problem> LoadProblem(model::ModelSpec spec, const std::vector<std::string>& data_paths) {
  return LoadProblem(std::move(spec), PlainDatasets(data_paths));
}

std::vector<data::DatasetSpec> PlainDatasets(const std::vector<std::string>& paths) {
  std::vector<data::DatasetSpec> out;
  out.reserve(paths.size());
  for (const std::string& p : paths) out.push_back(data::PlainDataset(p));
  return out;
}

Result<filter::Likelihood> MakeLikelihood(const Problem& problem) {
  if (problem.model) return filter::Likelihood::Create(problem.model, problem.series);
  return filter::Likelihood::Create(problem.nonlinear, problem.series);
}

}  // namespace gb::project
