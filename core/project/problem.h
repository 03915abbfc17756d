// A model together with the data it is fitted to: what every command and view works on.
// Loading binds each dataset to the model's inputs and outputs once; everything is immutable
// afterwards and shared (the GUI's background jobs hold the same pointers as the UI).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "core/data/dataset.h"
#include "core/data/import.h"
#include "core/filter/likelihood.h"
#include "core/model/linear_model.h"
#include "core/model/nonlinear_model.h"

namespace gb::project {

struct Problem {
  // Exactly one is set: the linear model (exact Kalman filter), or, for a model that is not
  // linear, the one the extended Kalman filter runs.
  std::shared_ptr<const model::LinearModel> model;
  std::shared_ptr<const model::NonlinearModel> nonlinear;
  std::vector<std::shared_ptr<const data::Dataset>> datasets;
  std::vector<std::shared_ptr<const data::Series>> series;  // bound, one per dataset

  const model::ModelSpec& spec() const { return model ? model->spec() : nonlinear->spec(); }
};

// Compiles the model (linear when it is, else for the EKF), reads, prepares and binds every
// dataset (whatever its role: the caller picks the ones to fit).
Result<Problem> LoadProblem(model::ModelSpec spec, const std::vector<data::DatasetSpec>& data);
// The same for CSV files read in the default form.
Result<Problem> LoadProblem(model::ModelSpec spec, const std::vector<std::string>& data_paths);

// Files as datasets read in the default form (plain entries).
std::vector<data::DatasetSpec> PlainDatasets(const std::vector<std::string>& paths);

// Binds already-read datasets.
Result<Problem> MakeProblem(model::ModelSpec spec,
                            std::vector<std::shared_ptr<const data::Dataset>> datasets);

// The likelihood over all the problem's series (checks that delays fit the data).
Result<filter::Likelihood> MakeLikelihood(const Problem& problem);

}  // namespace gb::project
