// Estimation speed (issue 3): the bundled fuel-film case — 10 000 samples at 80 Hz, 7 free
// parameters, the λ delay scanned over 0..10 samples with the full profile, standard errors.
// Run from the repository root:
//   build/bench/estimate_bench --benchmark_min_time=5
#include <benchmark/benchmark.h>

#include "core/estimate/estimate.h"
#include "core/project/problem.h"
#include "core/util/json.h"

namespace {

using namespace gb;

void BM_EstimateFuelFilmCaseStudy(benchmark::State& state) {
  const std::string root = GREYBENCH_SOURCE_DIR;
  auto spec = model::LoadModelFile(root + "/assets/models/fuel_film.json");
  auto problem = project::LoadProblem(std::move(*spec), {root + "/assets/data/fuel_f1.csv"});
  if (!problem) {
    state.SkipWithError(problem.error().ToString().c_str());
    return;
  }
  auto lik = project::MakeLikelihood(*problem);
  estimate::EstimateOptions options;
  options.threads = static_cast<int>(state.range(0));
  double loglik = 0;
  int evaluations = 0;
  for (auto _ : state) {
    auto s = estimate::Estimate(*lik, options);
    loglik = s->loglik;
    evaluations = s->evaluations;
  }
  state.counters["loglik"] = loglik;
  state.counters["evaluations"] = evaluations;
}
BENCHMARK(BM_EstimateFuelFilmCaseStudy)
    ->Arg(1)
    ->Arg(2)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
