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

// How the records of a joint fit start: all from the model's one initial state, or each from
// its own (PerRecordInitialStates). A project's "estimation": {"initial_states": "per_record"}.
enum class InitialStates { kShared, kPerRecord };

struct Problem {
  // Exactly one is set: the linear model (exact Kalman filter), or, for a model that is not
  // linear, the one the extended Kalman filter runs.
  std::shared_ptr<const model::LinearModel> model;
  std::shared_ptr<const model::NonlinearModel> nonlinear;
  std::vector<std::shared_ptr<const data::Dataset>> datasets;
  std::vector<std::shared_ptr<const data::Series>> series;  // bound, one per dataset
  // With InitialStates::kPerRecord and two or more records: each series' own parameters
  // (filter::Likelihood::set_series_parameters); empty otherwise.
  std::vector<std::vector<int>> series_parameters;

  const model::ModelSpec& spec() const { return model ? model->spec() : nonlinear->spec(); }
};

// Compiles the model (linear when it is, else for the EKF), reads, prepares and binds every
// dataset (whatever its role: the caller picks the ones to fit).
Result<Problem> LoadProblem(model::ModelSpec spec, const std::vector<data::DatasetSpec>& data,
                            InitialStates initial = InitialStates::kShared);
// The same for CSV files read in the default form.
Result<Problem> LoadProblem(model::ModelSpec spec, const std::vector<std::string>& data_paths);

// Files as datasets read in the default form (plain entries).
std::vector<data::DatasetSpec> PlainDatasets(const std::vector<std::string>& paths);

// Binds already-read datasets.
Result<Problem> MakeProblem(model::ModelSpec spec,
                            std::vector<std::shared_ptr<const data::Dataset>> datasets,
                            InitialStates initial = InitialStates::kShared);

// Each of `records` records from its own initial state, as CTSM-R fits several series: the free
// parameters that only the initial state uses (they appear in initial_state or
// initial_variance and in no drift, diffusion, observation or measurement variance) get a copy
// for every record after the first, named `<name>_r<k>` (k = 2, 3, ...: the record's place
// among the fitted ones), with the original's start, bounds, unit and prior. A parameter of that
// name already in the model is used as it is (its own start and bounds). Record 1 keeps the
// originals. `index` is one row per record for filter::Likelihood::set_series_parameters; a
// model and one record come back unchanged (no rows). Fails when the model's initial state has
// no free parameter of its own (a fixed or constant initial state: nothing to estimate per
// record), naming the model file.
struct RecordInitialStates {
  model::ModelSpec spec;                // with the copies appended to its parameters
  std::vector<std::vector<int>> index;  // per record; empty with fewer than two records
  std::vector<std::string> own;         // the parameters copied (the originals' names)
};
Result<RecordInitialStates> PerRecordInitialStates(model::ModelSpec spec, int records);

// The likelihood over all the problem's series (checks that delays fit the data).
Result<filter::Likelihood> MakeLikelihood(const Problem& problem);

}  // namespace gb::project
