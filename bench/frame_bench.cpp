// Frame time of the workbench (issue 6): the CPU side of one frame (DrawWorkbench and ImGui's
// Render, no GL) on a 200 000-sample fuel-film dataset, on the Data and the Estimate view,
// with and without an estimation running on the background thread. The mouse rests over the
// middle of the view (plots draw their crosshair and nearest-sample readout). Target: < 16 ms.
//
// The dataset is simulated once per run by core's simulator (the model of the speed
// benchmarks, a PRBS input of order 10 at 80 Hz) into a temporary directory.
// Run from the repository root:
//   build/bench/frame_bench --benchmark_repetitions=3 --benchmark_report_aggregates_only=true
#include <chrono>
#include <filesystem>
#include <limits>
#include <string>

#include <benchmark/benchmark.h>
#include <unistd.h>

#include "core/data/write_csv.h"
#include "core/design/prbs.h"
#include "core/model/linear_model.h"
#include "core/project/project.h"
#include "core/sim/simulate.h"
#include "tests/ui/workbench_driver.h"

namespace {

using namespace gb;
namespace fs = std::filesystem;

constexpr int kSamples = 200000;
constexpr double kSampleTime = 0.0125;  // s, as the virtual dyno records

// Writes model, data and project into `dir`; returns the project file, or "" with `why`.
std::string WriteCase(const fs::path& dir, std::string* why) {
  const std::string root = GREYBENCH_SOURCE_DIR;
  auto spec = model::LoadModelFile(root + "/bench/models/fuel_film_f1.json");
  if (!spec) return *why = spec.error().ToString(), "";
  const std::vector<double> theta = spec->Values();
  auto lm = model::LinearModel::Compile(*spec);
  if (!lm) return *why = lm.error().ToString(), "";
  auto ss = lm->Evaluate(theta);
  if (!ss) return *why = ss.error().ToString(), "";

  design::PrbsOptions prbs;
  prbs.order = 10;
  prbs.bit_period = 0.5;
  prbs.sample_time = kSampleTime;
  prbs.duration = kSamples * kSampleTime;
  prbs.low = 1.07;  // the dyno's fuel bias ± 10 %
  prbs.high = 1.31;
  prbs.name = "mfi";
  auto u = design::MakePrbs(prbs);
  if (!u) return *why = u.error().ToString(), "";

  // The simulator takes its times and inputs from a bound series, as `greybench-cli simulate`.
  const std::string inputs_csv = (dir / "inputs.csv").string();
  const std::vector<data::CsvColumn> input_cols = {{"t", u->t}, {"mfi", u->u}};
  if (auto st = data::WriteCsvFile(inputs_csv, input_cols); !st)
    return *why = st.error().ToString(), "";
  auto inputs = data::ReadCsvFile(inputs_csv);
  if (!inputs) return *why = inputs.error().ToString(), "";
  auto bound = data::Bind(**inputs, lm->spec().inputs, {});
  if (!bound) return *why = bound.error().ToString(), "";
  data::Series series = **bound;
  series.Y.setConstant(1, static_cast<Eigen::Index>(series.size()),
                       std::numeric_limits<double>::quiet_NaN());
  auto sim = sim::Simulate(*ss, series, filter::FilterSettings::FromModel(lm->spec()), {});
  if (!sim) return *why = sim.error().ToString(), "";
  const std::vector<double> y(sim->Y.row(0).begin(), sim->Y.row(0).end());
  const std::vector<data::CsvColumn> cols = {{"t", series.time}, {"mfi", u->u}, {"ilambda", y}};
  const std::string csv = (dir / "fuel_200k.csv").string();
  if (auto st = data::WriteCsvFile(csv, cols, {{"frame_bench: simulated fuel film"}}); !st)
    return *why = st.error().ToString(), "";

  project::Project p;
  p.name = "Frame benchmark: 200 000 samples";
  p.model_path = root + "/bench/models/fuel_film_f1.json";
  p.datasets = {gb::data::PlainDataset(csv)};
  const std::string file = (dir / "frame_bench.json").string();
  if (auto st = project::SaveProject(p, file); !st) return *why = st.error().ToString(), "";
  return file;
}

// The case, written once for all the benchmarks of the run and removed at exit.
struct Case {
  fs::path dir;
  std::string project;
  std::string error;
  Case() {
    dir = fs::temp_directory_path() / ("greybench-frame-bench-" + std::to_string(::getpid()));
    fs::create_directories(dir);
    project = WriteCase(dir, &error);
  }
  ~Case() {
    std::error_code ec;
    fs::remove_all(dir, ec);
  }
};

const Case& TheCase() {
  static const Case the_case;  // a benchmark fixture, not UI state
  return the_case;
}

// range(0): the view (0 data, 1 estimate); range(1): 1 with a fit running.
void BM_WorkbenchFrame(benchmark::State& state) {
  const Case& c = TheCase();
  if (c.project.empty()) return state.SkipWithError(c.error.c_str());
  ui::testing::WorkbenchDriver d;
  d.Open(c.project);
  if (!d.state.project || d.state.datasets.empty() || !d.state.datasets[0].data)
    return state.SkipWithError("the benchmark project did not load");
  d.state.view = state.range(0) == 0 ? ui::View::kData : ui::View::kEstimate;
  const bool fit = state.range(1) == 1;
  d.state.estimation.settings.multistart = 50;  // keeps the thread busy for the whole run
  auto start_fit = [&] {
    std::string why;
    if (!ui::StartEstimation(d.state, &why)) state.SkipWithError(why.c_str());
  };
  if (fit) start_fit();
  for (int i = 0; i < 5; ++i) d.Frame();  // layout settles, plots fit their ranges
  if (ImGuiWindow* view = ui::testing::WorkbenchDriver::ViewWindow()) {
    ImGui::GetIO().MousePos = view->Rect().GetCenter();
  }
  int restarts = 0;
  for (auto _ : state) {
    d.Frame();
    if (fit && !ui::EstimationRunning(d.state)) {
      state.PauseTiming();
      d.Frame();  // installs the result
      start_fit();
      ++restarts;
      state.ResumeTiming();
    }
  }
  state.counters["samples"] = static_cast<double>(d.state.datasets[0].summary.rows);
  // What a frame draws (shows the view was drawn in full, and how much of it there is).
  state.counters["vertices"] = ImGui::GetDrawData() ? ImGui::GetDrawData()->TotalVtxCount : 0;
  state.counters["fit_running"] = fit ? 1 : 0;
  state.counters["fit_restarts"] = restarts;
  if (fit) ui::CancelEstimation(d.state);
}
BENCHMARK(BM_WorkbenchFrame)
    ->ArgNames({"view", "fit"})
    ->Args({0, 0})
    ->Args({0, 1})
    ->Args({1, 0})
    ->Args({1, 1})
    ->Unit(benchmark::kMillisecond)
    ->MinTime(2.0);

}  // namespace

BENCHMARK_MAIN();
