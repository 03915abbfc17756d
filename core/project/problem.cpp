#include "core/project/problem.h"

namespace gb::project {

Result<Problem> MakeProblem(model::ModelSpec spec,
                            std::vector<std::shared_ptr<const data::Dataset>> datasets) {
  auto lm = model::LinearModel::Compile(std::move(spec));
  if (!lm) return lm.error();
  Problem p;
  p.model = std::make_shared<const model::LinearModel>(std::move(*lm));
  for (const auto& d : datasets) {
    auto s = data::Bind(*d, p.model->spec().inputs, p.model->spec().outputs);
    if (!s) return s.error();
    p.series.push_back(*s);
  }
  p.datasets = std::move(datasets);
  return p;
}

Result<Problem> LoadProblem(model::ModelSpec spec, const std::vector<std::string>& data_paths) {
  std::vector<std::shared_ptr<const data::Dataset>> datasets;
  for (const auto& path : data_paths) {
    auto d = data::ReadCsvFile(path);
    if (!d) return d.error();
    datasets.push_back(*d);
  }
  return MakeProblem(std::move(spec), std::move(datasets));
}

Result<filter::Likelihood> MakeLikelihood(const Problem& problem) {
  return filter::Likelihood::Create(problem.model, problem.series);
}

}  // namespace gb::project
