// On-line identification per row (docs/benchmarks.md "On-line"): the recursive estimator
// (core/online/recursive.h) and the whole monitor (core/online/monitor.h) over the bundled dyno
// records, from the batch fit of each record as the reference. Rows per second of CPU; the
// dyno's real time is 80 rows/s (fuel) and 16 rows/s (crankshaft).
//   build/bench/online_bench --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include <string>
#include <vector>

#include "core/estimate/estimate.h"
#include "core/online/monitor.h"
#include "core/project/problem.h"

namespace {

using namespace gb;

struct Case {
  project::Problem problem;
  online::Reference reference;
  std::vector<online::Sample> rows;
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
  const data::Series& s = *problem->series[0];
  for (std::size_t j = 0; j < s.size(); ++j) {
    online::Sample r;
    r.t = s.time[j];
    r.u.assign(s.U.col(j).data(), s.U.col(j).data() + s.U.rows());
    r.y.assign(s.Y.col(j).data(), s.Y.col(j).data() + s.Y.rows());
    c.rows.push_back(std::move(r));
  }
  cache.emplace_back(model, std::move(c));
  return cache.back().second;
}

void Recursive(benchmark::State& state, const char* model, const char* data) {
  const Case& c = Load(model, data);
  online::RecursiveOptions o;
  o.forgetting = 0.999;
  for (auto _ : state) {
    auto rml = online::RecursiveMl::Create(*c.problem.model, c.reference, o);
    for (const online::Sample& r : c.rows) benchmark::DoNotOptimize(rml->Push(r));
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

}  // namespace
BENCHMARK_MAIN();
