// greybench-cli's command line (docs/user-guide.md, section 4): the subcommands and their options,
// parsed and dispatched to the Run* functions of app/cli/. In a library of its own so that a fuzz
// target can drive the whole command line in one process (tests/fuzz/cli_fuzz.cpp).
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <limits>
#include <string>

#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include "app/cli/cli.h"
#include "core/design/prbs.h"
#include "core/estimate/estimate.h"
#include "core/project/design_fits.h"
#include "core/util/json.h"

namespace gb::cli {
namespace {

// Every floating-point option refuses a value that is not a finite number (`--duration nan`,
// `--ftol inf`): CLI11 parses them as doubles, and a range check lets NaN through.
void RequireFiniteNumbers(CLI::App& app) {
  const CLI::Validator finite(
      [](std::string& value) -> std::string {
        const double v = std::strtod(value.c_str(), nullptr);
        return std::isfinite(v) ? "" : value + " is not a finite number";
      },
      "", "finite");
  for (CLI::App* sub : app.get_subcommands([](CLI::App*) { return true; }))
    for (CLI::Option* opt : sub->get_options())
      if (opt->get_type_name().rfind("FLOAT", 0) == 0) opt->check(finite);
}

// An empty value, which CLI11 takes as "not given": the option would silently keep its default
// (`--out ""` would write nothing, `--duration ""` run the default length). "" when none is.
std::string WhyEmptyValue(const CLI::App& app) {
  for (const CLI::App* sub : app.get_subcommands())
    for (const CLI::Option* opt : sub->get_options())
      for (const std::string& value : opt->results())
        if (value.empty())
          return fmt::format(
              "{} {}: the value is empty; give a value, or leave the option out "
              "for its default",
              sub->get_name(), opt->get_name());
  return "";
}

// "-" as an output: standard output where the help says so (`monitor --out`, `dyno --live
// --out`); anywhere else it would become a file named "-" in the current folder.
std::string WhyDashOutput(const CLI::App& app, bool live) {
  for (const CLI::App* sub : app.get_subcommands()) {
    const std::string& name = sub->get_name();
    if (name == "monitor" || (name == "dyno" && live)) continue;
    for (const CLI::Option* opt : sub->get_options()) {
      const std::string& o = opt->get_name();
      if (o.rfind("--out", 0) != 0 && o != "--states" && o != "--checkpoint") continue;
      for (const std::string& value : opt->results())
        if (value == "-")
          return fmt::format(
              "{} {} -: {} writes files, not standard output; give a file name "
              "(./- for a file of that name)",
              name, o, name);
    }
  }
  return "";
}

constexpr double kInf = std::numeric_limits<double>::infinity();

// The values a numeric option takes: a finite number (CLI11 reads "nan" and "inf" as doubles and
// "" as 0, so the text is checked before it is converted) in [lo, hi], lo left out with lo_open,
// a whole one with `whole`; `unit` for the message and the help ("seconds").
struct Allowed {
  double lo = -kInf;
  double hi = kInf;
  bool lo_open = false;
  bool whole = false;
  const char* unit = "";
};

// "a number of seconds > 0", "a whole number in [1, 1000]".
std::string Describe(const Allowed& a) {
  std::string what = a.whole ? "a whole number" : "a number";
  if (*a.unit) what += fmt::format(" of {}", a.unit);
  if (a.lo == -kInf && a.hi == kInf) return "a finite number";
  if (a.hi == kInf) return fmt::format("{} {} {}", what, a.lo_open ? ">" : ">=", a.lo);
  return fmt::format("{} in {}{}, {}]", what, a.lo_open ? '(' : '[', a.lo, a.hi);
}

// The check of an option's text against `a`; CLI11 prefixes the option's name to the message:
// "--duration: 'nan' is not a number of seconds > 0".
CLI::Validator Number(Allowed a) {
  const std::string what = Describe(a);
  return CLI::Validator(
      [a, what](std::string& text) -> std::string {
        const bool plus = text.size() > 1 && text[0] == '+' && text[1] != '-' && text[1] != '+';
        const char* first = text.data() + (plus ? 1 : 0);
        const char* end = text.data() + text.size();
        double v = 0;
        bool parsed = false;
        if (a.whole) {  // digits only, as CLI11 reads them after this check
          long long i = 0;
          const auto [ptr, ec] = std::from_chars(first, end, i);
          parsed = ec == std::errc() && ptr == end;
          v = static_cast<double>(i);
        } else {
          const auto [ptr, ec] = std::from_chars(first, end, v);
          parsed = ec == std::errc() && ptr == end;
        }
        const bool ok = !text.empty() && parsed && std::isfinite(v) &&
                        (a.lo_open ? v > a.lo : v >= a.lo) && v <= a.hi;
        return ok ? "" : fmt::format("'{}' is not {}", text, what);
      },
      what);
}

// A seed: a whole number in [0, max] (CLI11 would read "" as 0 and "-1" as the largest value).
CLI::Validator Seed(std::uint64_t max) {
  const std::string what = fmt::format("a whole number in [0, {}]", max);
  return CLI::Validator(
      [max, what](std::string& text) -> std::string {
        const char* end = text.data() + text.size();
        std::uint64_t v = 0;
        const auto [ptr, ec] = std::from_chars(text.data(), end, v);
        if (text.empty() || ec != std::errc() || ptr != end || v > max)
          return fmt::format("'{}' is not {}", text, what);
        return "";
      },
      what);
}

const Allowed kSeconds{.lo = 0, .lo_open = true, .unit = "seconds"};
const Allowed kPositive{.lo = 0, .lo_open = true};
const Allowed kCount{.lo = 1, .whole = true};  // a number of rows or lags, 1 or more
const Allowed kPrbsOrder{.lo = design::kMinPrbsOrder, .hi = design::kMaxPrbsOrder, .whole = true};

}  // namespace

// --initial-states on the commands that fit or evaluate records of a project.
void AddInitialStates(CLI::App* command, std::string* value) {
  command
      ->add_option("--initial-states", *value,
                   "shared: every fitted record from the model's initial state; per_record: "
                   "each from its own (copies of the initial state's parameters, named "
                   "NAME_r2, NAME_r3, ...); default: the project's estimation.initial_states, "
                   "else shared")
      ->check(CLI::IsMember({"shared", "per_record"}));
}

int Main(int argc, char** argv) {
  CLI::App app{"greybench-cli: identify continuous-time stochastic grey-box models"};
  app.require_subcommand(1);
  std::function<int()> run;

  LoglikArgs loglik;
  auto* c_loglik = app.add_subcommand("loglik", "log-likelihood at the model's parameter values");
  c_loglik->add_option("model", loglik.model, "model file (JSON), or a project file")->required();
  c_loglik->add_option("data", loglik.data,
                       "data files (CSV); their log-likelihoods add up (with a project: its "
                       "estimation datasets unless given)");
  c_loglik->add_option("--set", loglik.sets, "NAME=VALUE: override a parameter's value");
  c_loglik->add_flag("--gradient", loglik.gradient,
                     "also print the exact gradient over the free parameters (natural scale)");
  AddInitialStates(c_loglik, &loglik.initial_states);
  c_loglik->callback([&] { run = [&] { return RunLoglik(loglik); }; });

  BenchArgs bench;
  auto* c_bench = app.add_subcommand("bench", "time one log-likelihood evaluation (median)");
  c_bench->add_option("model", bench.model, "model file (JSON), or a project file")->required();
  c_bench->add_option("data", bench.data,
                      "data files (CSV; with a project: its estimation datasets unless given)");
  c_bench->add_option("--set", bench.sets, "NAME=VALUE: override a parameter's value");
  c_bench->add_option("--repeat", bench.repeat, "timed evaluations (default 21; 1..10000)")
      ->check(Number({.lo = 1, .hi = 10000, .whole = true}));
  c_bench->callback([&] { run = [&] { return RunBench(bench); }; });

  SimulateArgs simulate;
  auto* c_sim = app.add_subcommand(
      "simulate", "a sample path of the SDE at the input times, or its deterministic response");
  c_sim->add_option("model", simulate.model, "model file (JSON)")->required();
  c_sim->add_option("--inputs", simulate.inputs, "CSV with t and the model's inputs")->required();
  c_sim->add_option("--set", simulate.sets, "NAME=VALUE: override a parameter's value");
  c_sim->add_option("--result", simulate.result,
                    "result file (JSON): the parameter values and output delays of a fit");
  auto* sim_seed = c_sim->add_option("--seed", simulate.seed, "random seed (default 1)")
                       ->check(Seed(std::numeric_limits<std::uint64_t>::max()));
  c_sim->add_flag("--deterministic", simulate.deterministic,
                  "the noise-free response from the initial state: no process or measurement "
                  "noise (exact for a linear model, error-controlled for any other)");
  c_sim->add_option("--out", simulate.out, "output CSV")->required();
  c_sim->callback([&, sim_seed] {
    simulate.seed_given = sim_seed->count() > 0;
    run = [&] { return RunSimulate(simulate); };
  });

  PrbsArgs prbs;
  auto* c_prbs = app.add_subcommand("prbs", "a maximal-length PRBS input signal");
  c_prbs->add_option("--order", prbs.order, "register length n (period 2^n - 1 bits)")
      ->required()
      ->check(Number(kPrbsOrder));
  c_prbs->add_option("--period", prbs.period, "bit period T_prbs, at least --ts")
      ->required()
      ->check(Number({.lo = 0, .lo_open = true}));
  c_prbs->add_option("--ts", prbs.ts, "sample time")
      ->required()
      ->check(Number({.lo = 0, .lo_open = true}));
  c_prbs
      ->add_option("--duration", prbs.duration, "length of the signal (at most 50 million samples)")
      ->required()
      ->check(Number({.lo = 0, .lo_open = true}));
  c_prbs->add_option("--low", prbs.low, "level of a 0 bit")->required()->check(Number({}));
  c_prbs->add_option("--high", prbs.high, "level of a 1 bit (not --low)")
      ->required()
      ->check(Number({}));
  c_prbs->add_option("--name", prbs.name, "column name (default u)");
  c_prbs->add_option("--seed", prbs.seed, "initial register state (default 1)")
      ->check(Seed(std::numeric_limits<std::uint32_t>::max()));
  c_prbs->add_option("--out", prbs.out, "output CSV")->required();
  c_prbs->callback([&] { run = [&] { return RunPrbs(prbs); }; });

  EstimateArgs est;
  auto* c_est = app.add_subcommand("estimate", "maximum-likelihood estimates with standard errors");
  c_est->add_option("model", est.model, "model file (JSON), or a project file")->required();
  c_est->add_option("data", est.data,
                    "data files (CSV), fitted jointly (with a project: its estimation datasets "
                    "unless given)");
  c_est->add_option("--set", est.sets, "NAME=VALUE: override a start (or fixed) value");
  c_est->add_option("--out", est.out, "result file (JSON, user guide §5)");
  AddInitialStates(c_est, &est.initial_states);
  c_est->add_option("--start", est.start,
                    "start the free parameters at a result file's estimates (--set overrides)");
  auto* steady = c_est->add_flag(
      "--steady-start", est.steady_start,
      "first move the parameters the model's steady states depend on so that they match the "
      "records' levels (means over windows; for nonlinear models far from their optimum)");
  c_est
      ->add_option("--steady-window", est.steady_window,
                   "the windows' length for --steady-start, > 0 in the records' time unit "
                   "(default 5)")
      ->check(Number(kPositive))
      ->needs(steady);
  c_est
      ->add_option("--threads", est.threads,
                   "threads for the score and the Hessian, 1..1024 (default: all cores)")
      ->check(Number({.lo = 1, .hi = estimate::kMaxThreads, .whole = true}));
  c_est
      ->add_option("--multistart", est.multistart,
                   "extra starts spread over the bounds, 0..10000 (default 0)")
      ->check(Number({.lo = 0, .hi = estimate::kMaxStarts, .whole = true}));
  c_est
      ->add_option("--starts-on-bound", est.starts_on_bound,
                   "without --multistart: where the fit ends with parameters that ran off (onto "
                   "a bound, towards +-inf, or where the data do not determine them), fits with "
                   "them put back to their starts, then if needed this many extra starts, "
                   "0..10000 (default 8; 0: neither)")
      ->check(Number({.lo = 0, .hi = estimate::kMaxStarts, .whole = true}));
  c_est->add_flag("--progress", est.progress,
                  "print the stage, iteration, evaluations and best log L to stderr after every "
                  "iteration (for long fits)");
  c_est->add_option("--checkpoint", est.checkpoint,
                    "after every iteration, write the best estimates so far to this file (a "
                    "partial result that --start resumes from)");
  c_est->add_flag("--score-differences", est.score_differences,
                  "scores from central differences of log L instead of the exact ones (for "
                  "comparison; standard errors then from second differences)");
  c_est->add_flag("--log-scale", est.log_scale,
                  "fit the parameters with a positive lower bound on a log scale (for comparison: "
                  "docs/benchmarks.md, issue 33)");
  c_est
      ->add_option("--max-evaluations", est.max_evaluations,
                   "log-likelihood evaluations per fit, 1..100000000 (default 20000)")
      ->check(Number({.lo = 1, .hi = 1e8, .whole = true}));
  c_est->add_option(
      "--algorithm", est.algorithm,
      "auto (default: BHHH with BFGS corrections), bhhh, slsqp, lbfgs, bobyqa or trust-region "
      "(auto, then a trust-region Newton end game on the exact Hessian)");
  c_est
      ->add_option("--ftol", est.ftol,
                   "relative tolerance on -log L, 0..0.1 (default 1e-12; 0: only the step "
                   "tolerance stops)")
      ->check(Number({.lo = 0, .hi = 0.1}));
  auto* profile = c_est->add_flag("--profile-intervals", est.profile_intervals,
                                  "likelihood-ratio (profile) intervals for every free parameter");
  c_est->add_option("--profile-level", est.profile_level, "their level, 0.5..0.9999 (default 0.95)")
      ->check(Number({.lo = 0.5, .hi = 0.9999}))
      ->needs(profile);
  c_est->callback([&] { run = [&] { return RunEstimate(est); }; });

  CompareArgs cmp;
  auto* c_cmp = app.add_subcommand("compare", "likelihood-ratio test of two nested fits");
  c_cmp->add_option("result_a", cmp.a, "result file (JSON)")->required();
  c_cmp->add_option("result_b", cmp.b, "result file (JSON)")->required();
  c_cmp->callback([&] { run = [&] { return RunCompare(cmp); }; });

  PredictArgs predict;
  auto* c_pred = app.add_subcommand("predict", "one-step predictions with standard deviations");
  c_pred->add_option("model", predict.model, "model file (JSON), or a project file")->required();
  c_pred->add_option("data", predict.data, "data file (CSV; with a project: one of its datasets)");
  c_pred->add_option("--dataset", predict.dataset,
                     "with a project: the dataset (its number from 1, name or file name)");
  AddInitialStates(c_pred, &predict.initial_states);
  c_pred->add_option("--set", predict.sets, "NAME=VALUE: override a parameter's value");
  c_pred->add_option("--result", predict.result,
                     "take the estimates (and delays) from a result file");
  c_pred->add_option("--out", predict.out, "output CSV: t, then o, o_pred, o_sd, o_residual")
      ->required();
  c_pred
      ->add_option("--simulate-after", predict.simulate_after,
                   "N >= 1: use the outputs of the first N rows only and simulate the rest from "
                   "the state estimated on them; prints the simulation's RMS error")
      ->check(Number(kCount));
  c_pred->add_option("--states", predict.states,
                     "CSV of the states: t, then x_filtered, x_filtered_sd, x_smoothed, "
                     "x_smoothed_sd for every state x, and o_smoothed, o_smoothed_sd for every "
                     "output o (the smoother conditions on every observation)");
  c_pred->callback([&] { run = [&] { return RunPredict(predict); }; });

  DiagnoseArgs diag;
  auto* c_diag =
      app.add_subcommand("diagnose", "residual diagnostics: ACF, PACF, CCF, periodogram, tests");
  c_diag->add_option("model", diag.model, "model file (JSON), or a project file")->required();
  c_diag->add_option("data", diag.data, "data file (CSV; with a project: one of its datasets)");
  c_diag->add_option("--dataset", diag.dataset,
                     "with a project: the dataset (its number from 1, name or file name)");
  AddInitialStates(c_diag, &diag.initial_states);
  c_diag->add_option("--set", diag.sets, "NAME=VALUE: override a parameter's value");
  c_diag->add_option("--result", diag.result, "take the estimates (and delays) from a result file");
  c_diag
      ->add_option("--max-lag", diag.max_lag,
                   "lags of ACF, PACF and CCF, >= 1 (default min(40, n/4))")
      ->check(Number(kCount));
  c_diag
      ->add_option("--lb-lags", diag.ljung_box_lags,
                   "Ljung-Box lags, >= 1 (default min(20, max lag))")
      ->check(Number(kCount));
  c_diag->add_option("--out", diag.out, "output JSON with every series and test")->required();
  c_diag->callback([&] { run = [&] { return RunDiagnose(diag); }; });

  ExportModelArgs export_model;
  auto* c_export =
      app.add_subcommand("export-model", "write the model a project's diagram compiles to");
  c_export->add_option("project", export_model.project, "project file (JSON) with a \"diagram\"")
      ->required();
  c_export->add_option("--out", export_model.out, "model file to write (JSON)")->required();
  c_export->callback([&] { run = [&] { return RunExportModel(export_model); }; });

  ExportFmuArgs export_fmu;
  auto* c_fmu = app.add_subcommand(
      "export-fmu", "write a fit's model as an FMI 2.0 FMU (Model Exchange, Co-Simulation)");
  c_fmu->add_option("result", export_fmu.result, "result file (JSON) of the fit")->required();
  c_fmu->add_option("--model", export_fmu.model,
                    "model or project file (default: the one the result names)");
  auto* fmu_interface =
      c_fmu->add_option("--interface", export_fmu.interface, "me, cs or both (default)")
          ->check(CLI::IsMember({"me", "cs", "both"}));
  c_fmu->add_flag("--virtual-sensor", export_fmu.virtual_sensor,
                  "the fitted filter instead (Co-Simulation): inputs u, the measurements and "
                  "their validity; outputs the filtered states, predictions and innovations");
  c_fmu
      ->add_option("--out", export_fmu.out,
                   "the FMU to write (NAME.fmu; NAME is its model "
                   "identifier)")
      ->required();
  c_fmu->callback([&, fmu_interface] {
    export_fmu.interface_given = fmu_interface->count() > 0;
    run = [&] { return RunExportFmu(export_fmu); };
  });

  ReportArgs report;
  auto* c_report =
      app.add_subcommand("report", "the estimation report of a result file as Markdown or HTML");
  c_report->add_option("result", report.result, "result file of the fit (JSON)")->required();
  c_report->add_option("--model", report.model,
                       "model file, or a project file (default: the one the result names)");
  c_report->add_option("--data", report.data, "data files (CSV) for the residual analysis");
  c_report->add_option(
      "--dataset", report.dataset,
      "with a project: the dataset of the residual analysis (number, name or file)");
  c_report->add_option("--format", report.format, "md or html (default: --out's extension)");
  c_report->add_option("--out", report.out, "report file to write (.md or .html)")->required();
  c_report->callback([&] { run = [&] { return RunReport(report); }; });

  MonitorArgs monitor;
  auto* c_monitor = app.add_subcommand(
      "monitor", "watch a model on-line: recursive estimates and alarms from a reference");
  c_monitor->add_option("model", monitor.model, "model file (JSON)")->required();
  c_monitor->add_option("source", monitor.source, "- to read rows from standard input");
  c_monitor->add_option("--reference", monitor.reference, "batch result file (JSON) to start from")
      ->required();
  c_monitor->add_option("--follow", monitor.follow,
                        "CSV file to follow as it grows (as tail -f does)");
  // One value per occurrence, so that a source `-` after them is not taken for a value.
  c_monitor->add_option("--set", monitor.sets, "NAME=VALUE: override a parameter of the model")
      ->allow_extra_args(false);
  c_monitor->add_option("--forgetting", monitor.forgetting,
                        "forgetting factor in (0, 1] (memory 1/(1-λ) rows; default 0.999)");
  c_monitor
      ->add_option("--track", monitor.track,
                   "parameters to track (default: all free ones in the dynamics and observations)")
      ->delimiter(',')
      ->allow_extra_args(false);
  c_monitor->add_option("--false-alarms", monitor.false_alarms,
                        "false alarms per hour, all tests together, > 0 (default 0.125)");
  c_monitor->add_option("--change", monitor.change,
                        "relative change of a parameter worth an alarm, > 0 (default 0.25)");
  c_monitor->add_option_function<double>(
      "--idle", [&monitor](const double& seconds) { monitor.idle = seconds; },
      "--follow: stop after this many seconds (> 0) with nothing new in the file (not given: "
      "never stop)");
  c_monitor->add_option("--every", monitor.every,
                        "write every N-th update, N >= 1 (alarms always; default 1)");
  c_monitor->add_option("--out", monitor.out, "log file (JSON Lines; default or - is stdout)");
  c_monitor->callback([&] { run = [&] { return RunMonitor(monitor); }; });

  DynoArgs dyno;
  auto* c_dyno = app.add_subcommand(
      "dyno",
      "run an experiment on the virtual dyno (simulated data); an option the experiment does not "
      "take is refused");
  c_dyno->add_option("experiment", dyno.experiment, "fuel, crankshaft, square-wave or engine")
      ->required()
      ->check(CLI::IsMember({"fuel", "crankshaft", "square-wave", "engine"}));
  c_dyno->add_option("--point", dyno.point,
                     "fuel, engine: operating point of Table 2 (f1 f2 f3 f4 f7 f8; default f1); "
                     "engine also n=RPM,alpha=DEG; not with --path");
  c_dyno->add_option("--path", dyno.path,
                     "engine: a slow sweep through two or more points (f3,f1,f7 or "
                     "'n=2600,alpha=25;n=3600,alpha=35'); not with --point");
  c_dyno
      ->add_option("--hold", dyno.hold, "engine sweep (--path): seconds at each point (default 20)")
      ->check(Number({.lo = 0, .unit = "seconds"}));
  c_dyno
      ->add_option("--ramp", dyno.ramp,
                   "engine sweep (--path): seconds between points (default 40)")
      ->check(Number(kSeconds));
  c_dyno
      ->add_option("--sample-time", dyno.sample_time,
                   "engine: seconds between samples (default 0.0125; the anti-alias filters cut "
                   "off at a quarter of the rate; the simulated world's step, sample time / "
                   "oversample, at most 0.0025 s)")
      ->check(Number({.lo = 0.001, .hi = 1, .unit = "seconds"}));
  c_dyno->add_flag("--hold-speed", dyno.hold_speed,
                   "engine: the dyno holds the speed (a PI controller on the load), as for the "
                   "paper's fuel experiments; default: it holds the load");
  c_dyno
      ->add_option("--throttle-amplitude", dyno.throttle_amplitude,
                   "engine: +/- degrees of the throttle's PRBS (default 1; 0: the fuel's only, "
                   "the paper's experiment)")
      ->check(Number({.lo = 0, .hi = 10, .unit = "degrees"}));
  c_dyno
      ->add_option("--duration", dyno.duration,
                   "default: fuel 125, crankshaft 600, square-wave 16, engine 125 or the sweep's "
                   "length; with --live, without end; at most 10 million samples and 100 million "
                   "steps of the simulated world")
      ->check(Number(kSeconds));
  c_dyno->add_option("--seed", dyno.seed, "random seed (default 1)")
      ->check(Seed(std::numeric_limits<std::uint64_t>::max()));
  c_dyno
      ->add_option("--order", dyno.order,
                   "fuel, crankshaft, engine: PRBS order (default: fuel 6, crankshaft 7, engine's "
                   "fuel 6)")
      ->check(Number(kPrbsOrder));
  c_dyno
      ->add_option("--bit-period", dyno.bit_period,
                   "fuel, crankshaft, engine: PRBS bit period in s, at least the sample time "
                   "(default 0.5, crankshaft 1)")
      ->check(Number(kSeconds));
  c_dyno->add_flag("--no-filter", dyno.no_filter, "record without the anti-alias filters");
  c_dyno
      ->add_option("--oversample", dyno.oversample,
                   "steps of the simulated world per sample (default 10; its step at least 1e-5 s)")
      ->check(Number({.lo = 1, .hi = 1000, .whole = true}));
  c_dyno
      ->add_option("--lambda-sensor", dyno.lambda_sensor,
                   "engine: the lambda sensor's transport delay, exact (a delay line, default) or "
                   "pade (the [3/3] approximant the bundled models use)")
      ->check(CLI::IsMember({"exact", "pade"}));
  c_dyno->add_flag("--constant-load", dyno.constant_load, "crankshaft: hold the load torque");
  c_dyno->add_option("--out", dyno.out, "output CSV (with --live: default or - is stdout)");
  auto* live = c_dyno->add_flag("--live", dyno.live,
                                "fuel: stream the live dyno's CSV row by row (each row flushed) "
                                "until --duration, or without end");
  c_dyno
      ->add_option("--speed", dyno.speed,
                   "with --live: times real time (default 1; 0: as fast as possible)")
      ->needs(live)
      ->check(Number({.lo = 0}));
  c_dyno
      ->add_option("--fault", dyno.faults,
                   "with --live: TIME:PARAMETER*FACTOR[/RAMP] (PARAMETER tau_ff, X, delay or "
                   "gain; a step, or linear over RAMP s; tau_ff and gain within 1/100..100 times "
                   "their nominal values) or TIME:clear[/RAMP], e.g. 60:tau_ff*1.5/30")
      ->needs(live);
  c_dyno
      ->add_flag("--truth", dyno.truth,
                 "with --live: also columns true_tau_ff, true_X, true_delay, true_Kb")
      ->needs(live);
  c_dyno->callback([&] { run = [&] { return RunDyno(dyno); }; });

  DesignArgs design;
  auto* c_design = app.add_subcommand(
      "design", "the standard errors an experiment would give: one input design, or two compared");
  c_design->add_option("model", design.model, "model file (JSON; a linear model)")->required();
  c_design
      ->add_option("--design", design.designs,
                   "SHAPE:KEY=VALUE,...: prbs:order=6,bit=0.5,level=1.19,amplitude=0.12,ts=0.0125,"
                   "duration=125; square:period=..; step:at=.. (once, or twice to compare)")
      ->required();
  c_design->add_option("--drive", design.drive,
                       "the input the design drives (default: the model's only input)");
  c_design->add_option("--hold", design.holds, "INPUT=VALUE: the level of another input");
  c_design->add_option("--set", design.sets, "NAME=VALUE: override a parameter's value");
  c_design->add_option("--result", design.result,
                       "the parameter values of a result file (--set overrides)");
  c_design
      ->add_option("--fit", design.fit,
                   "also simulate this many records with each design and fit them, 1..1000")
      ->check(Number({.lo = 1, .hi = project::kMaxDesignRecords, .whole = true}));
  c_design->add_option("--seed", design.seed, "the first record's seed (default 1)")
      ->check(Seed(std::numeric_limits<std::uint64_t>::max()));
  c_design->add_option("--out", design.out, "write the designs' standard errors as JSON");
  c_design->callback([&] { run = [&] { return RunDesign(design); }; });

  LineariseArgs linearise;
  auto* c_lin = app.add_subcommand(
      "linearise", "the linearised model (A, B, C, D) of a fitted model at an operating point");
  c_lin->add_option("result", linearise.result, "result file of the fit (JSON)")->required();
  c_lin
      ->add_option("--point", linearise.point,
                   "NAME=VALUE,...: states, inputs or outputs that fix the steady state")
      ->required();
  c_lin->add_option("--model", linearise.model,
                    "model file (default: the result file's model_file)");
  c_lin
      ->add_option("--quantity", linearise.quantities,
                   "NAME=EXPRESSION of A_x_x, B_x_u, C_y_x, D_y_u, states, inputs, outputs and "
                   "parameters (repeatable)")
      ->allow_extra_args(false);
  c_lin->add_option("--out", linearise.out, "write the linearisation as JSON");
  c_lin->callback([&] { run = [&] { return RunLinearise(linearise); }; });

  SweepArgs sweep;
  auto* c_sweep = app.add_subcommand("sweep", "estimate one model on many operating points");
  c_sweep->add_option("model", sweep.model, "model file (JSON), or a project file")->required();
  c_sweep->add_option("data", sweep.data,
                      "data files, each tagged with its operating point (with a project: its "
                      "estimation datasets unless given)");
  c_sweep->add_option("--set", sweep.sets, "NAME=VALUE: override a start (or fixed) value");
  c_sweep->add_option("--out-csv", sweep.out_csv, "table of estimates (CSV)");
  c_sweep->add_option("--out-md", sweep.out_md, "table of estimates (Markdown)");
  c_sweep->add_option("--trend", sweep.trend,
                      "PARAMETER:TAG fitted linearly (default X:alpha_deg)");
  c_sweep->add_option("--delay-parameter", sweep.delay_parameter,
                      "a parameter that is the delay in seconds (a continuous delay): the delay "
                      "relation fits its estimates");
  c_sweep
      ->add_option("--parallel", sweep.parallel,
                   "datasets fitted at once, 1..1024 (default: all cores)")
      ->check(Number({.lo = 1, .hi = estimate::kMaxThreads, .whole = true}));
  c_sweep->callback([&] { run = [&] { return RunSweep(sweep); }; });

  RequireFiniteNumbers(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp&) {
    std::printf("%s", app.help().c_str());
    return 0;
  } catch (const CLI::CallForAllHelp&) {
    std::printf("%s", app.help("", CLI::AppFormatMode::All).c_str());
    return 0;
  } catch (const CLI::ParseError& e) {
    std::fprintf(stderr, "greybench-cli: error: %s\nRun 'greybench-cli --help' for usage.\n",
                 e.what());
    return 2;
  }
  std::string why = WhyEmptyValue(app);
  if (why.empty()) why = WhyDashOutput(app, dyno.live);
  if (!why.empty()) {
    std::fprintf(stderr, "greybench-cli: error: %s\n", why.c_str());
    return 2;
  }
  return run();
}

}  // namespace gb::cli
