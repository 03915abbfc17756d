// The live dyno's speed (core/sim/live_dyno.h): samples per second, which must be far above the
// experiments' real-time rates (fuel 80 Hz, crankshaft 16 Hz). Run:
//   build/bench/dyno_bench
// BM_LiveFuelDyno: 0 no fault; 1 step faults on all four parameters (the film discretised once
// more); 2 τ_ff ramping the whole time (over 10⁶ s) (the film discretised anew every fine step).
// BM_LiveCrankshaftDyno: 0 no fault; 1 J_e ramping the whole time.
#include <benchmark/benchmark.h>

#include "core/sim/live_dyno.h"

namespace {

using namespace gb;

void BM_LiveFuelDyno(benchmark::State& state) {
  sim::FuelExperiment e;
  e.point = *sim::FindFuelPoint("f1");
  auto dyno = sim::LiveFuelDyno::Create(e);
  if (!dyno) {
    state.SkipWithError(dyno.error().message.c_str());
    return;
  }
  using Kind = sim::FuelFault::Kind;
  if (state.range(0) == 1) {
    for (Kind kind : {Kind::kTauFF, Kind::kX, Kind::kSensorDelay, Kind::kSensorGain})
      (void)dyno->Inject({kind, 1.2});
  } else if (state.range(0) == 2) {
    (void)dyno->Inject({Kind::kTauFF, 2, 1e6});
  }
  double sum = 0;
  for (auto _ : state) sum += dyno->Next().ilambda;
  benchmark::DoNotOptimize(sum);
  state.counters["samples_per_s"] =
      benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
  state.SetLabel(state.range(0) == 0 ? "no fault" : state.range(0) == 1 ? "steps" : "ramp");
}
BENCHMARK(BM_LiveFuelDyno)->Arg(0)->Arg(1)->Arg(2);

void BM_LiveCrankshaftDyno(benchmark::State& state) {
  auto dyno = sim::LiveCrankshaftDyno::Create(sim::CrankshaftExperiment{});
  if (!dyno) {
    state.SkipWithError(dyno.error().message.c_str());
    return;
  }
  if (state.range(0) == 1) (void)dyno->Inject({sim::CrankshaftFault::Kind::kJe, 2, 1e6});
  double sum = 0;
  for (auto _ : state) sum += dyno->Next().N;
  benchmark::DoNotOptimize(sum);
  state.counters["samples_per_s"] =
      benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
  state.SetLabel(state.range(0) == 0 ? "no fault" : "ramp");
}
BENCHMARK(BM_LiveCrankshaftDyno)->Arg(0)->Arg(1);

}  // namespace

BENCHMARK_MAIN();
