#include "core/project/problem.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <set>

#include <fmt/format.h>

#include "core/filter/initial_state.h"

namespace gb::project {

Result<RecordInitialStates> PerRecordInitialStates(model::ModelSpec spec, int records) {
  RecordInitialStates out;
  if (records < 2) {
    out.spec = std::move(spec);
    return out;
  }
  std::set<std::string> elsewhere, initial;
  for (const auto* formulas :
       {&spec.drift, &spec.diffusion, &spec.observation, &spec.measurement_variance})
    for (const model::Formula& f : *formulas) expr::CollectNames(f.expr, &elsewhere);
  for (const auto* formulas : {&spec.initial_state, &spec.initial_variance})
    for (const model::Formula& f : *formulas) expr::CollectNames(f.expr, &initial);
  std::vector<int> own;
  for (std::size_t i = 0; i < spec.parameters.size(); ++i) {
    const model::Parameter& p = spec.parameters[i];
    if (!p.fixed && initial.count(p.name) && !elsewhere.count(p.name))
      own.push_back(static_cast<int>(i));
  }
  if (own.empty()) {
    Error e = InputError(
        "each record from its own initial state needs a free parameter that only the initial "
        "state uses, and this model has none (its initial state is fixed or shares its "
        "parameters with the dynamics): write the initial state with parameters of its own, "
        "e.g. \"initial_state\": {\"x\": \"x0\"}");
    e.file = spec.source;
    e.path = "initial_state";
    return e;
  }
  // Copies come after the model's parameters; one already in the model is taken as it is.
  std::vector<std::vector<int>> copy(static_cast<std::size_t>(records));  // [record][own]
  for (int r = 2; r <= records; ++r) {
    for (int i : own) {
      const std::string name = fmt::format("{}_r{}", spec.parameters[i].name, r);
      int at = spec.ParameterIndex(name);
      if (at < 0) {
        model::Parameter p = spec.parameters[i];
        p.name = name;
        p.description = fmt::format("{} of record {}", spec.parameters[i].name, r);
        spec.parameters.push_back(std::move(p));
        at = static_cast<int>(spec.parameters.size()) - 1;
      } else if (elsewhere.count(name) || initial.count(name)) {
        Error e = InputError(fmt::format(
            "the parameter '{}' is a model formula's, so it cannot also be record {}'s copy of "
            "'{}': rename it",
            name, r, spec.parameters[i].name));
        e.file = spec.source;
        e.path = "parameters." + name;
        return e;
      }
      copy[static_cast<std::size_t>(r - 1)].push_back(at);
    }
  }
  std::vector<bool> is_copy(spec.parameters.size(), false);
  for (const auto& row : copy)
    for (int c : row) is_copy[static_cast<std::size_t>(c)] = true;
  for (int r = 1; r <= records; ++r) {
    std::vector<int> row(spec.parameters.size());
    for (std::size_t i = 0; i < row.size(); ++i) row[i] = is_copy[i] ? -1 : static_cast<int>(i);
    if (r > 1)
      for (std::size_t k = 0; k < own.size(); ++k)
        row[static_cast<std::size_t>(own[k])] = copy[static_cast<std::size_t>(r - 1)][k];
    out.index.push_back(std::move(row));
  }
  for (int i : own) out.own.push_back(spec.parameters[i].name);
  out.spec = std::move(spec);
  return out;
}

namespace {

// The starts of records 2, 3, ...'s copies where a state's initial value is one parameter
// (x(t0) = x0): the state at the record's first row from its first samples
// (filter::EstimateInitialState at the starts), within the parameter's bounds. A copy the model
// itself declares keeps its start. Returns whether a start moved.
bool StartsFromFirstSamples(const Problem& p, const std::vector<bool>& declared,
                            model::ModelSpec* spec) {
  filter::FilterSettings settings = filter::FilterSettings::FromModel(*spec);
  for (const auto& d : spec->output_delay) settings.first_obs.push_back(d.max);
  const std::vector<double> theta = spec->Values();
  bool moved = false;
  for (std::size_t r = 1; r < p.series.size(); ++r) {
    const std::vector<double> own = filter::SeriesTheta(theta, p.series_parameters[r]);
    const data::Series& series = *p.series[r];
    const int n = filter::InitialStateSamples(static_cast<int>(series.size()));
    std::optional<filter::InitialStateEstimate> start;
    if (p.model) {
      auto ss = p.model->Evaluate(own);
      if (!ss) continue;
      if (auto e = filter::EstimateInitialState(*ss, series, settings, n)) start = *e;
    } else if (auto e = filter::EkfEstimateInitialState(*p.nonlinear, own, series, settings, n)) {
      start = *e;
    }
    if (!start) continue;  // the copies keep the original's start
    for (std::size_t x = 0; x < spec->states.size(); ++x) {
      const int original = spec->ParameterIndex(expr::ToString(spec->initial_state[x].expr));
      if (original < 0) continue;
      const int c = p.series_parameters[r][static_cast<std::size_t>(original)];
      if (c == original || c < 0 || declared[static_cast<std::size_t>(c)]) continue;
      model::Parameter& copy = spec->parameters[static_cast<std::size_t>(c)];
      double v = start->x0(static_cast<Eigen::Index>(x));
      if (!std::isfinite(v)) continue;
      if (copy.lower) v = std::max(v, *copy.lower);
      if (copy.upper) v = std::min(v, *copy.upper);
      moved = moved || v != copy.value;
      copy.value = v;
    }
  }
  return moved;
}

Result<Problem> Compile(const model::ModelSpec& spec) {
  Problem p;
  if (auto lm = model::LinearModel::Compile(spec)) {
    p.model = std::make_shared<const model::LinearModel>(std::move(*lm));
  } else {
    auto nm = model::NonlinearModel::Compile(spec);
    if (!nm) return nm.error();
    p.nonlinear = std::make_shared<const model::NonlinearModel>(std::move(*nm));
  }
  return p;
}

}  // namespace

Result<Problem> MakeProblem(model::ModelSpec spec,
                            std::vector<std::shared_ptr<const data::Dataset>> datasets,
                            InitialStates initial) {
  std::vector<std::vector<int>> series_parameters;
  std::vector<bool> declared;  // parameters the model itself declares
  if (initial == InitialStates::kPerRecord) {
    const std::size_t n_model = spec.parameters.size();
    auto records = PerRecordInitialStates(std::move(spec), static_cast<int>(datasets.size()));
    if (!records) return records.error();
    spec = std::move(records->spec);
    series_parameters = std::move(records->index);
    declared.assign(spec.parameters.size(), false);
    std::fill(declared.begin(), declared.begin() + static_cast<std::ptrdiff_t>(n_model), true);
  }
  auto compiled = Compile(spec);
  if (!compiled) return compiled.error();
  Problem p = std::move(compiled).value();
  p.series_parameters = std::move(series_parameters);
  for (const auto& d : datasets) {
    auto s = data::Bind(*d, p.spec().inputs, p.spec().outputs);
    if (!s) return s.error();
    p.series.push_back(*s);
  }
  p.datasets = std::move(datasets);
  if (!p.series_parameters.empty() && StartsFromFirstSamples(p, declared, &spec)) {
    auto restarted = Compile(spec);
    if (!restarted) return restarted.error();
    p.model = restarted->model;
    p.nonlinear = restarted->nonlinear;
  }
  return p;
}

Result<Problem> LoadProblem(model::ModelSpec spec, const std::vector<data::DatasetSpec>& data,
                            InitialStates initial) {
  std::vector<std::shared_ptr<const data::Dataset>> datasets;
  for (const data::DatasetSpec& d : data) {
    auto read = data::ReadDataset(d);
    if (!read) return read.error();
    datasets.push_back(*read);
  }
  return MakeProblem(std::move(spec), std::move(datasets), initial);
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
  auto lik = problem.model ? filter::Likelihood::Create(problem.model, problem.series)
                           : filter::Likelihood::Create(problem.nonlinear, problem.series);
  if (lik && !problem.series_parameters.empty())
    lik->set_series_parameters(problem.series_parameters);
  return lik;
}

}  // namespace gb::project
