// Log-likelihood evaluation speed (issue 2; the extended Kalman filter: issue 15). Run:
//   build/bench/loglik_bench --benchmark_counters_tabular=true
// Reported: time per evaluation and ns per sample. Data are simulated from each model with
// greybench's own simulators (exact for linear models, Milstein for the tank models; PRBS
// inputs), so every benchmark is self-contained.
//
// BM_Ekf*: the EKF on chains of n tanks with orifice outflow (n = 2, 10), on 2 tanks with a
// fast sensor state (stiff: the sensor's mode is 500 times faster than the sample interval),
// and on the linear fuel film, each with the ODE method as its argument (0 auto, 1 explicit,
// 2 BDF) so that the methods are measured side by side; BM_FuelFilmExactVsEkf compares the
// exact filter with the EKF on the same linear model and data.
#include <cstdlib>
#include <filesystem>
#include <utility>

#include <benchmark/benchmark.h>
#include <fmt/format.h>
#include <unistd.h>

#include "core/data/dataset.h"
#include "core/design/prbs.h"
#include "core/expr/native.h"
#include "core/filter/likelihood.h"
#include "core/model/linear_model.h"
#include "core/model/model.h"
#include "core/model/nonlinear_model.h"
#include "core/model/nonlinear_sensitivity.h"
#include "core/sim/sde.h"
#include "core/sim/simulate.h"
#include "core/util/json.h"

namespace {

using namespace gb;

// The fuel-film model of user guide §2 at the paper's point f1, fixed delay of 5 samples.
const char* kFuelFilm = R"json({
  "greybench_model": 1, "states": ["mfv", "mff"], "inputs": ["mfi"], "outputs": ["ilambda"],
  "parameters": {"tau_fv": 0.075, "tau_ff": 0.375, "X": 0.175, "Kb": 0.8421,
                 "s11": 0.1098e-2, "s12": 0.3910e-3, "s2": 1.2570e-4},
  "drift": {"mfv": "(-mfv + (1 - X)*mfi)/tau_fv", "mff": "(-mff + X*mfi)/tau_ff"},
  "diffusion": {"mfv": "sqrt(s11)", "mff": "sqrt(s12)"},
  "observation": {"ilambda": "Kb*(mfv + mff)"},
  "measurement_variance": {"ilambda": "s2"},
  "output_delay": {"ilambda": 5}, "robust_huber": 3
})json";

// The same model at the generic fit's optimum on f7 (docs/benchmarks.md), where the measurement
// variance is on its lower bound: the filter's covariance and its sensitivities end in a cycle
// of steps, not on one (linear_step.h, SteadyReplay).
const char* kFuelFilmF7 = R"json({
  "greybench_model": 1, "states": ["mfv", "mff"], "inputs": ["mfi"], "outputs": ["ilambda"],
  "parameters": {"tau_fv": 0.0879525, "tau_ff": 0.35309, "X": 0.158823, "Kb": 0.650211,
                 "s11": 0.0159101, "s12": 0.000160355, "s2": 1e-9},
  "drift": {"mfv": "(-mfv + (1 - X)*mfi)/tau_fv", "mff": "(-mff + X*mfi)/tau_ff"},
  "diffusion": {"mfv": "sqrt(s11)", "mff": "sqrt(s12)"},
  "observation": {"ilambda": "Kb*(mfv + mff)"},
  "measurement_variance": {"ilambda": "s2"},
  "output_delay": {"ilambda": 3}
})json";

// A chain of n thermal masses: T1 heated by u, each coupled to its neighbours, the last to the
// ambient 0; the first is measured.
std::string ChainModel(int n) {
  Json j;
  j["greybench_model"] = 1;
  std::vector<std::string> states;
  for (int i = 1; i <= n; ++i) states.push_back(fmt::format("T{}", i));
  j["states"] = states;
  j["inputs"] = {"u"};
  j["outputs"] = {"y"};
  j["parameters"] = {{"R", 0.5}, {"C", 2.0}, {"s", 0.1}, {"r", 0.01}};
  for (int i = 1; i <= n; ++i) {
    std::string left = i == 1 ? "u" : fmt::format("(T{} - T{})/R", i - 1, i);
    std::string right = i == n ? fmt::format("T{}/R", i) : fmt::format("(T{} - T{})/R", i, i + 1);
    j["drift"][states[i - 1]] = fmt::format("({} - {})/C", left, right);
    j["diffusion"][states[i - 1]] = "s";
  }
  j["observation"]["y"] = "T1";
  j["measurement_variance"]["y"] = "r";
  return j.dump();
}

struct Fixture {
  std::shared_ptr<const model::LinearModel> model;
  std::shared_ptr<const data::Series> series;
  std::vector<double> theta;
};

Fixture Make(const std::string& model_json, int n_samples, double ts, double bit_period, double low,
             double high) {
  auto spec = model::ParseModel(Json::parse(model_json), "bench.json");
  auto lm = std::make_shared<const model::LinearModel>(*model::LinearModel::Compile(*spec));
  design::PrbsOptions o;
  o.order = 6;
  o.bit_period = bit_period;
  o.sample_time = ts;
  o.duration = n_samples * ts;
  o.low = low;
  o.high = high;
  auto u = *design::MakePrbs(o);
  data::Series s;
  s.source = "bench";
  s.time = u.t;
  s.U = Eigen::Map<const Eigen::MatrixXd>(u.u.data(), 1, static_cast<Eigen::Index>(u.u.size()));
  s.Y.setZero(lm->n_outputs(), static_cast<Eigen::Index>(u.t.size()));
  s.intervals = data::GroupIntervals(s.time);
  const std::vector<double> theta = lm->spec().Values();
  auto ss = *lm->Evaluate(theta);
  auto sim = *sim::Simulate(ss, s, filter::FilterSettings::FromModel(lm->spec()), {});
  s.Y = sim.Y;
  return {lm, std::make_shared<const data::Series>(std::move(s)), theta};
}

void RunLoglik(benchmark::State& state, const Fixture& f) {
  auto lik = *filter::Likelihood::Create(f.model, {f.series});
  for (auto _ : state) {
    auto l = lik.Evaluate(f.theta);
    benchmark::DoNotOptimize(l);
  }
  const double n = static_cast<double>(f.series->size());
  // Rate of samples per second, inverted: seconds per sample; scaled to nanoseconds.
  state.counters["ns_per_sample"] = benchmark::Counter(
      n * 1e-9, benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
  state.counters["samples"] = n;
}

// The exact score over every parameter. Arg 0: the gradient alone (the steady state's adjoint,
// LinearGradient::kSteadyState); 1: with every row's score; 2: the gradient alone by forward
// sensitivities; 3: by the adjoint of the whole recursion.
constexpr filter::LinearGradient kGradients[] = {
    filter::LinearGradient::kSteadyState, filter::LinearGradient::kSteadyState,
    filter::LinearGradient::kForward, filter::LinearGradient::kAdjoint};
void RunScore(benchmark::State& state, const Fixture& f) {
  auto lik = *filter::Likelihood::Create(f.model, {f.series});
  std::vector<int> all(f.theta.size());
  for (std::size_t i = 0; i < all.size(); ++i) all[i] = static_cast<int>(i);
  Eigen::VectorXd g;
  Eigen::MatrixXd J;
  const std::vector<int> delay;
  for (auto _ : state) {
    auto l = lik.EvaluateWithScore(f.theta, delay, all, &g, state.range(0) == 1 ? &J : nullptr, 1,
                                   kGradients[state.range(0)]);
    benchmark::DoNotOptimize(l);
  }
  const double n = static_cast<double>(f.series->size());
  state.counters["ns_per_sample"] = benchmark::Counter(
      n * 1e-9, benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
  state.counters["parameters"] = static_cast<double>(all.size());
}

void BM_FuelFilm2State(benchmark::State& state) {
  static const Fixture f = Make(kFuelFilm, 200000, 0.0125, 0.5, 0.9, 1.1);
  RunLoglik(state, f);
}
BENCHMARK(BM_FuelFilm2State)->Unit(benchmark::kMillisecond);

void BM_Chain4State(benchmark::State& state) {
  static const Fixture f = Make(ChainModel(4), 200000, 0.1, 2.0, -1, 1);
  RunLoglik(state, f);
}
BENCHMARK(BM_Chain4State)->Unit(benchmark::kMillisecond);

void BM_Chain10State(benchmark::State& state) {
  static const Fixture f = Make(ChainModel(10), 200000, 0.1, 2.0, -1, 1);
  RunLoglik(state, f);
}
BENCHMARK(BM_Chain10State)->Unit(benchmark::kMillisecond);

void BM_FuelFilm2StateScore(benchmark::State& state) {
  static const Fixture f = Make(kFuelFilm, 10000, 0.0125, 0.5, 0.9, 1.1);
  RunScore(state, f);
}
BENCHMARK(BM_FuelFilm2StateScore)->DenseRange(0, 3)->Unit(benchmark::kMillisecond);

void BM_FuelFilmF7Score(benchmark::State& state) {
  static const Fixture f = Make(kFuelFilmF7, 10000, 0.0125, 0.5, 0.9, 1.1);
  RunScore(state, f);
}
BENCHMARK(BM_FuelFilmF7Score)->DenseRange(0, 3)->Unit(benchmark::kMillisecond);

void BM_Chain4StateScore(benchmark::State& state) {
  static const Fixture f = Make(ChainModel(4), 10000, 0.1, 2.0, -1, 1);
  RunScore(state, f);
}
BENCHMARK(BM_Chain4StateScore)->DenseRange(0, 3)->Unit(benchmark::kMillisecond);

void BM_Chain10StateScore(benchmark::State& state) {
  static const Fixture f = Make(ChainModel(10), 10000, 0.1, 2.0, -1, 1);
  RunScore(state, f);
}
BENCHMARK(BM_Chain10StateScore)->DenseRange(0, 3)->Unit(benchmark::kMillisecond);

// ---- the extended Kalman filter --------------------------------------------------------------

// n tanks in a chain, each draining through an orifice into the next; the pump fills the first
// and the last is measured. With `fast_sensor`, the measured level passes a first-order sensor
// with time constant 0.002 (one more state).
std::string TankChain(int n, bool fast_sensor) {
  Json j;
  j["greybench_model"] = 1;
  std::vector<std::string> states;
  for (int i = 1; i <= n; ++i) states.push_back(fmt::format("h{}", i));
  if (fast_sensor) states.push_back("m");
  j["states"] = states;
  j["inputs"] = {"u"};
  j["outputs"] = {"y"};
  j["parameters"] = {{"k", 0.5}, {"kin", 0.6}, {"s", 0.02}, {"r", 0.001}, {"tau", 0.002}};
  for (int i = 1; i <= n; ++i) {
    const std::string in = i == 1 ? "kin*u" : fmt::format("k*sqrt(h{})", i - 1);
    j["drift"][states[i - 1]] = fmt::format("{} - k*sqrt(h{})", in, i);
    j["diffusion"][states[i - 1]] = "s";
    j["initial_state"][states[i - 1]] = "1.4";
  }
  if (fast_sensor) {
    j["drift"]["m"] = fmt::format("(h{} - m)/tau", n);
    j["initial_state"]["m"] = "1.4";
    j["observation"]["y"] = "m";
  } else {
    j["observation"]["y"] = fmt::format("h{}", n);
  }
  j["measurement_variance"]["y"] = "r";
  return j.dump();
}

struct EkfFixture {
  std::shared_ptr<const model::NonlinearModel> model;
  std::shared_ptr<const data::Series> series;
  std::vector<double> theta;
};

// PRBS between 0.8 and 1.2 (levels near 1.4), sampled every 0.5 time units.
EkfFixture MakeEkf(const std::string& model_json, int n_samples, model::OdeMethod method) {
  auto spec = *model::ParseModel(Json::parse(model_json), "bench.json");
  spec.ekf.method = method;
  auto nm = std::make_shared<const model::NonlinearModel>(*model::NonlinearModel::Compile(spec));
  design::PrbsOptions o;
  o.order = 6;
  o.bit_period = 5.0;
  o.sample_time = 0.5;
  o.duration = n_samples * o.sample_time;
  o.low = 0.8;
  o.high = 1.2;
  auto u = *design::MakePrbs(o);
  data::Series s;
  s.source = "bench";
  s.time = u.t;
  s.U = Eigen::Map<const Eigen::MatrixXd>(u.u.data(), 1, static_cast<Eigen::Index>(u.u.size()));
  s.Y.setZero(1, static_cast<Eigen::Index>(u.t.size()));
  s.intervals = data::GroupIntervals(s.time);
  const std::vector<double> theta = spec.Values();
  s.Y = sim::SamplePath(*nm, theta, s, filter::FilterSettings::FromModel(spec), 1)->Y;
  return {nm, std::make_shared<const data::Series>(std::move(s)), theta};
}

model::OdeMethod MethodOf(const benchmark::State& state) {
  return state.range(0) == 1   ? model::OdeMethod::kExplicit
         : state.range(0) == 2 ? model::OdeMethod::kBdf
                               : model::OdeMethod::kAuto;
}

// The second argument, where given: 0 the interpreter (expr::Tape), 1 native code
// (core/expr/native.h; compiled before the timing, or loaded from the cache).
void RunEkf(benchmark::State& state, const EkfFixture& f) {
  auto lik = *filter::Likelihood::Create(f.model, {f.series});
  if (state.range(1) == 1) {
    auto native = lik.WithNativeCode();
    if (!native) {
      state.SkipWithError(native.error().ToString().c_str());
      return;
    }
    lik = std::move(*native);
  }
  for (auto _ : state) {
    auto l = lik.Evaluate(f.theta);
    if (!l) state.SkipWithError(l.error().ToString().c_str());
    benchmark::DoNotOptimize(l);
  }
  const double n = static_cast<double>(f.series->size());
  state.counters["ns_per_sample"] = benchmark::Counter(
      n * 1e-9, benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
  const ode::OdeCounts c = lik.ode_counts();
  state.counters["steps_per_interval"] =
      c.intervals ? static_cast<double>(c.steps) / static_cast<double>(c.intervals) : 0.0;
  state.counters["rhs_per_interval"] =
      c.intervals ? static_cast<double>(c.rhs) / static_cast<double>(c.intervals) : 0.0;
}

void BM_EkfTanks2State(benchmark::State& state) {
  const EkfFixture f = MakeEkf(TankChain(2, false), 2000, MethodOf(state));
  RunEkf(state, f);
}
BENCHMARK(BM_EkfTanks2State)
    ->Args({1, 0})
    ->Args({1, 1})
    ->Args({2, 0})
    ->Unit(benchmark::kMillisecond);

void BM_EkfStiffTanks3State(benchmark::State& state) {
  const EkfFixture f = MakeEkf(TankChain(2, true), 2000, MethodOf(state));
  RunEkf(state, f);
}
BENCHMARK(BM_EkfStiffTanks3State)
    ->Args({0, 0})
    ->Args({0, 1})
    ->Args({1, 0})
    ->Args({2, 0})
    ->Unit(benchmark::kMillisecond);

void BM_EkfTanks10State(benchmark::State& state) {
  const EkfFixture f = MakeEkf(TankChain(10, false), 2000, MethodOf(state));
  RunEkf(state, f);
}
BENCHMARK(BM_EkfTanks10State)
    ->Args({1, 0})
    ->Args({1, 1})
    ->Args({2, 0})
    ->Unit(benchmark::kMillisecond);

// The linear fuel film, 10 000 samples: argument 0 the exact Kalman filter, 1 the EKF (explicit
// ODE method, default tolerances) on the same model and data.
void BM_FuelFilmExactVsEkf(benchmark::State& state) {
  static const Fixture f = Make(kFuelFilm, 10000, 0.0125, 0.5, 0.9, 1.1);
  if (state.range(0) == 0) {
    RunLoglik(state, f);
    return;
  }
  EkfFixture e{std::make_shared<const model::NonlinearModel>(
                   *model::NonlinearModel::Compile(f.model->spec())),
               f.series, f.theta};
  RunEkf(state, e);
}
BENCHMARK(BM_FuelFilmExactVsEkf)
    ->Args({0, 0})
    ->Args({1, 0})
    ->Args({1, 1})
    ->Unit(benchmark::kMillisecond);

// A bundled nonlinear case: the Cascaded Tanks SDE model on its estimation record, or the engine
// model (7 states) on the first 600 rows of engine_sweep.csv.
std::pair<model::ModelSpec, data::Series> BundledCase(bool engine) {
  const std::string root = GREYBENCH_SOURCE_DIR;
  auto spec = *model::LoadModelFile(root + (engine ? "/assets/models/engine_mvem.json"
                                                   : "/assets/models/cascaded_tanks_sde.json"));
  auto data = *data::ReadCsvFile(
      root + (engine ? "/assets/data/engine_sweep.csv" : "/assets/data/tanks_estimation.csv"));
  auto bound = *data::Bind(*data, spec.inputs, spec.outputs);
  data::Series s = *bound;
  if (engine) {
    const int rows = 600;
    s.time.resize(rows);
    s.U = bound->U.leftCols(rows);
    s.Y = bound->Y.leftCols(rows);
    if (!s.row_line.empty()) s.row_line.resize(rows);
    s.intervals = data::GroupIntervals(s.time);
  }
  return {std::move(spec), std::move(s)};
}

// The free parameters of a model file, in its order.
std::vector<int> FreeOf(const model::ModelSpec& spec) {
  std::vector<int> free;
  for (std::size_t i = 0; i < spec.parameters.size(); ++i)
    if (!spec.parameters[i].fixed) free.push_back(static_cast<int>(i));
  return free;
}

// One evaluation of `lik` per iteration at the model file's values: log L, or with `score` also
// its gradient in `free`; ns per row (of `rows`) and the number of free parameters as counters.
void TimeBundled(benchmark::State& state, const filter::Likelihood& lik,
                 const model::ModelSpec& spec, std::size_t rows, const std::vector<int>& free,
                 bool score) {
  const std::vector<double> theta = spec.Values();
  Eigen::VectorXd gradient;
  for (auto _ : state) {
    auto l = score ? lik.EvaluateWithScore(theta, {}, free, &gradient) : lik.Evaluate(theta);
    if (!l) state.SkipWithError(l.error().ToString().c_str());
    benchmark::DoNotOptimize(l);
  }
  state.counters["ns_per_row"] = benchmark::Counter(
      static_cast<double>(rows) * 1e-9,
      benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
  state.counters["free"] = static_cast<double>(free.size());
  const ode::OdeCounts counts = lik.ode_counts();
  if (counts.intervals > 0) {
    state.counters["steps_per_interval"] =
        static_cast<double>(counts.steps) / static_cast<double>(counts.intervals);
    state.counters["rhs_per_interval"] =
        static_cast<double>(counts.rhs) / static_cast<double>(counts.intervals);
  }
}

// The bundled nonlinear cases through the EKF, interpreter (second argument 0) against native
// code (1), one evaluation per iteration: the first argument is 0 the Cascaded Tanks SDE model
// on its estimation record (log L), 1 the same with the exact score of its 14 free parameters,
// 2 the engine model (7 states) on the first 600 rows of engine_sweep.csv (log L), 3 the same
// with the exact score of its free parameters.
void BM_BundledEkf(benchmark::State& state) {
  const bool engine = state.range(0) >= 2;
  const bool score = state.range(0) % 2 == 1;
  auto [spec, s] = BundledCase(engine);
  auto nm = std::make_shared<const model::NonlinearModel>(*model::NonlinearModel::Compile(spec));
  auto lik = *filter::Likelihood::Create(nm, {std::make_shared<const data::Series>(s)});
  if (state.range(1) == 1) lik = *lik.WithNativeCode();
  TimeBundled(state, lik, spec, s.size(), FreeOf(spec), score);
}
BENCHMARK(BM_BundledEkf)
    ->ArgsProduct({{0, 1, 2, 3}, {0, 1}})
    ->Unit(benchmark::kMillisecond)
    ->MeasureProcessCPUTime();

// The gradient of the bundled nonlinear cases on native code, forward sensitivities against the
// adjoint (core/filter/ekf_adjoint.h), beside log L alone: the first argument is the model (0 the
// Cascaded Tanks SDE model on its estimation record, 1 the engine model on the first 600 rows of
// engine_sweep.csv), the second the number of free parameters (the first ones of the model
// file's free parameters; 0: all, 14 and 19), the third what is computed (0 log L, 1 the gradient
// by forward sensitivities, 2 by the adjoint).
void BM_EkfGradient(benchmark::State& state) {
  const bool engine = state.range(0) == 1;
  auto [spec, s] = BundledCase(engine);
  auto nm = std::make_shared<const model::NonlinearModel>(*model::NonlinearModel::Compile(spec));
  auto lik = *(*filter::Likelihood::Create(nm, {std::make_shared<const data::Series>(s)}))
                  .WithNativeCode();
  const int mode = static_cast<int>(state.range(2));
  lik.set_gradient_method(mode == 2 ? filter::Likelihood::GradientMethod::kAdjoint
                                    : filter::Likelihood::GradientMethod::kForward);
  std::vector<int> free = FreeOf(spec);
  if (state.range(1) > 0) free.resize(static_cast<std::size_t>(state.range(1)));
  TimeBundled(state, lik, spec, s.size(), free, mode != 0);
}
BENCHMARK(BM_EkfGradient)
    ->ArgsProduct({{0, 1}, {1, 2, 3, 5, 0}, {0, 1, 2}})
    ->Unit(benchmark::kMillisecond)
    ->MeasureProcessCPUTime();

// Compiling a bundled model's native code (its formulas, Jacobians and the derivative programs:
// core/expr/native.h) into an empty cache folder each time: the latency a fit pays once per model.
// The argument: 0 the fuel film, 1 the Cascaded Tanks SDE model, 2 the engine model.
void BM_NativeCompile(benchmark::State& state) {
  const char* files[] = {"fuel_film.json", "cascaded_tanks_sde.json", "engine_mvem.json"};
  const std::string root = GREYBENCH_SOURCE_DIR;
  auto spec = *model::LoadModelFile(root + "/assets/models/" + files[state.range(0)]);
  auto nm = *model::NonlinearModel::Compile(spec);
  auto sens = *model::NonlinearSensitivity::Compile(nm);
  std::vector<expr::NativeCode::Program> programs = nm.NativePrograms();
  for (auto& p : sens.NativePrograms()) programs.push_back(std::move(p));
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / fmt::format("greybench-bench-native-{}", getpid());
  setenv("GREYBENCH_NATIVE_CACHE", dir.c_str(), 1);
  std::size_t bytes = 0;
  for (auto _ : state) {
    std::filesystem::remove_all(dir);
    auto code =
        expr::NativeCode::Compile(programs, [&nm](const std::string& n) { return nm.SlotOf(n); });
    if (!code) state.SkipWithError(code.error().ToString().c_str());
  }
  bytes = expr::NativeCode::Source(programs, [&nm](const std::string& n) {
            return nm.SlotOf(n);
          })->size();
  std::filesystem::remove_all(dir);
  unsetenv("GREYBENCH_NATIVE_CACHE");
  state.counters["source_kB"] = static_cast<double>(bytes) / 1000.0;
}
BENCHMARK(BM_NativeCompile)->DenseRange(0, 2)->Unit(benchmark::kMillisecond)->Iterations(3);

}  // namespace

BENCHMARK_MAIN();
