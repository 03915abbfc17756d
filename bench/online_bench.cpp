// On-line identification per row (docs/benchmarks.md "On-line"): the recursive estimator
// (core/online/recursive.h) and the whole monitor (core/online/monitor.h) over the bundled dyno
// records, from the batch fit of each record as the reference; and for nonlinear models the
// augmented EKF (core/online/augmented.h) and the monitor over the Cascaded Tanks estimation
// record (from its recorded estimates, tests/data/tanks) and CTSM's fed-batch bioreactor (from
// its fit). Rows per second of CPU; the dyno's real time is 80 rows/s (fuel) and 16 rows/s
// (crankshaft), the tanks' 0.25 rows/s.
//   build/bench/online_bench --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
#include <string>
#include <vector>

#include <benchmark/benchmark.h>

#include "core/data/dataset.h"
#include "core/estimate/estimate.h"
#include "core/filter/likelihood.h"
#include "core/online/augmented.h"
#include "core/online/monitor.h"
#include "core/project/problem.h"
#include "core/project/result_file.h"
#include "core/util/json.h"

namespace {

using namespace gb;

struct Case {
  project::Problem problem;
  online::Reference reference;
  std::vector<data::Sample> rows;
};

const Case& Load(const std::string& model, const std::string& data) {
  static std::vector<std::pair<std::string, Case>> cache;
  for (const auto& [key, c] : cache)
    if (key == model) return c;
  const std::string assets = std::string(GREYBENCH_SOURCE_DIR) + "/assets/";
  auto spec = model::LoadModelFile(assets + model);
  auto problem = project::LoadProblem(std::move(*spec), {assets + data});
  auto lik = project::MakeLikelihood(*problem);
  auto fit = estimate::Estimate(*lik, estimate::EstimateOptions{});
  Case c{*problem, online::ReferenceFromSummary(*fit, problem->spec()), {}};
  c.rows = data::SamplesOf(*problem->series[0]);
  cache.emplace_back(model, std::move(c));
  return cache.back().second;
}

void Recursive(benchmark::State& state, const char* model, const char* data) {
  const Case& c = Load(model, data);
  online::RecursiveOptions o;
  o.forgetting = 0.999;
  for (auto _ : state) {
    auto rml = online::RecursiveMl::Create(*c.problem.model, c.reference, o);
    for (const data::Sample& r : c.rows) benchmark::DoNotOptimize(rml->Push(r));
  }
  state.SetItemsProcessed(state.iterations() * static_cast<long>(c.rows.size()));
}

void Monitor(benchmark::State& state, const char* model, const char* data) {
  const Case& c = Load(model, data);
  online::MonitorOptions o;
  for (auto _ : state) {
    // Created, and its tests designed (at the second row), outside the timing: once per run.
    state.PauseTiming();
    auto m = online::Monitor::Create(*c.problem.model, c.reference, o);
    benchmark::DoNotOptimize(m->Push(c.rows[0]));
    benchmark::DoNotOptimize(m->Push(c.rows[1]));
    state.ResumeTiming();
    for (std::size_t j = 2; j < c.rows.size(); ++j) benchmark::DoNotOptimize(m->Push(c.rows[j]));
  }
  state.SetItemsProcessed(state.iterations() * static_cast<long>(c.rows.size()));
}

BENCHMARK_CAPTURE(Recursive, fuel_film, "models/fuel_film.json", "data/fuel_f1.csv")
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(Recursive, crankshaft, "models/crankshaft.json", "data/crankshaft.csv")
    ->Unit(benchmark::kMillisecond);
// The monitor's start: the CUSUM thresholds for the false-alarm rate (cusum.h), once per run.
void MonitorDesign(benchmark::State& state) {
  const Case& c = Load("models/fuel_film.json", "data/fuel_f1.csv");
  online::MonitorOptions o;
  for (auto _ : state) {
    auto m = online::Monitor::Create(*c.problem.model, c.reference, o);
    benchmark::DoNotOptimize(m->Push(c.rows[0]));
    benchmark::DoNotOptimize(m->Push(c.rows[1]));
  }
}
BENCHMARK(MonitorDesign)->Unit(benchmark::kMillisecond);

BENCHMARK_CAPTURE(Monitor, fuel_film, "models/fuel_film.json", "data/fuel_f1.csv")
    ->Unit(benchmark::kMillisecond);

// ---- nonlinear models ----

struct NonlinearCase {
  std::shared_ptr<const model::NonlinearModel> model;
  online::Reference reference;
  std::vector<data::Sample> rows;
};

// "tanks": the bundled model at its recorded estimates; "bioreactor": fitted here.
const NonlinearCase& LoadNonlinear(const std::string& which) {
  static std::vector<std::pair<std::string, NonlinearCase>> cache;
  for (const auto& [key, c] : cache)
    if (key == which) return c;
  const std::string root = std::string(GREYBENCH_SOURCE_DIR);
  const bool tanks = which == "tanks";
  auto spec = model::LoadModelFile(tanks ? root + "/assets/models/cascaded_tanks.json"
                                         : root + "/tests/data/bioreactor/fedbatch.json");
  auto model =
      std::make_shared<const model::NonlinearModel>(*model::NonlinearModel::Compile(*spec));
  auto dataset = data::ReadCsvFile(tanks ? root + "/assets/data/tanks_estimation.csv"
                                         : root + "/tests/data/bioreactor/fedbatch.csv");
  auto series = *data::Bind(**dataset, spec->inputs, spec->outputs);
  NonlinearCase c{model, {}, data::SamplesOf(*series)};
  if (tanks) {
    c.reference = *project::LoadReference(root + "/tests/data/tanks/estimates.json", *spec);
  } else {
    auto lik = filter::Likelihood::Create(model, {series});
    c.reference =
        online::ReferenceFromSummary(*estimate::Estimate(*lik, estimate::EstimateOptions{}), *spec);
  }
  cache.emplace_back(which, std::move(c));
  return cache.back().second;
}

void Augmented(benchmark::State& state, const char* which) {
  const NonlinearCase& c = LoadNonlinear(which);
  online::RecursiveOptions o;
  o.forgetting = 0.999;
  std::size_t tracked = 0;
  for (auto _ : state) {
    auto ekf = online::AugmentedEkf::Create(c.model, c.reference, o);
    tracked = ekf->tracked().size();
    for (const data::Sample& r : c.rows) benchmark::DoNotOptimize(ekf->Push(r));
  }
  state.counters["tracked"] = static_cast<double>(tracked);
  state.SetItemsProcessed(state.iterations() * static_cast<long>(c.rows.size()));
}

void NonlinearMonitor(benchmark::State& state, const char* which) {
  const NonlinearCase& c = LoadNonlinear(which);
  online::MonitorOptions o;
  for (auto _ : state) {
    state.PauseTiming();
    auto m = online::Monitor::Create(c.model, c.reference, o);
    benchmark::DoNotOptimize(m->Push(c.rows[0]));
    benchmark::DoNotOptimize(m->Push(c.rows[1]));
    state.ResumeTiming();
    for (std::size_t j = 2; j < c.rows.size(); ++j) benchmark::DoNotOptimize(m->Push(c.rows[j]));
  }
  state.SetItemsProcessed(state.iterations() * static_cast<long>(c.rows.size()));
}

BENCHMARK_CAPTURE(Augmented, bioreactor, "bioreactor")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(Augmented, tanks, "tanks")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(NonlinearMonitor, tanks, "tanks")->Unit(benchmark::kMillisecond);

}  // namespace
BENCHMARK_MAIN();
