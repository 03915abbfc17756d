// The workbench's analysis job (ui/jobs/analysis.h) on the bundled case study — 10 000 samples, one
// output, one input: one-step and 10-step predictions, the simulation, the preview and the
// residual diagnostics. "profile": at the model's start values, the λ delay chosen by profile
// likelihood over 0..10 (as before a fit); "fit delay": the delay given (as after a fit);
// "fit delay, no h-step": the same without the 10-step predictions (what the workbench computes
// while the Predictions view does not show them, e.g. for a slider's drag).
// Run from the repository root:
//   build/bench/analysis_bench --benchmark_min_time=2
#include <benchmark/benchmark.h>

#include "core/data/dataset.h"
#include "core/model/model.h"
#include "core/util/json.h"
#include "ui/jobs/analysis.h"

namespace {

using namespace gb;

void BM_AnalysisCaseStudy(benchmark::State& state) {
  const std::string root = GREYBENCH_SOURCE_DIR;
  auto spec = model::LoadModelFile(root + "/assets/models/fuel_film.json");
  auto data = data::ReadCsvFile(root + "/assets/data/fuel_f1.csv");
  if (!spec || !data) {
    state.SkipWithError("cannot read the case study");
    return;
  }
  ui::AnalysisInput input;
  input.spec = *spec;
  input.datasets = {*data};
  input.names = {"fuel_f1.csv"};
  input.read_errors = {""};
  input.request.theta = spec->Values();
  input.request.preview_theta = spec->Values();
  input.request.horizon = state.range(0) == 2 ? 0 : 10;
  if (state.range(0) >= 1) input.request.delay = {5};
  int n = 0;
  for (auto _ : state) {
    ui::JobControl control;
    ui::AnalysisRun run = ui::RunAnalysis(input, control);
    if (!run.analysis) {
      state.SkipWithError(run.error.c_str());
      return;
    }
    n = run.analysis->datasets[0].outputs[0].n_observed;
  }
  state.counters["n_observed"] = n;
  state.SetLabel(state.range(0) == 0   ? "profile"
                 : state.range(0) == 1 ? "fit delay"
                                       : "fit delay, no h-step");
}
BENCHMARK(BM_AnalysisCaseStudy)
    ->Arg(0)
    ->Arg(1)
    ->Arg(2)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
