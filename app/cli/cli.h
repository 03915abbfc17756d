// greybench-cli commands (user guide §4). Each Run* returns the process exit status:
// 0 success, 1 numerical failure or non-convergence, 2 bad input.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "core/data/dataset.h"
#include "core/data/import.h"
#include "core/diagnose/residuals.h"
#include "core/filter/kalman.h"
#include "core/filter/likelihood.h"
#include "core/filter/predict.h"
#include "core/model/linear_model.h"
#include "core/model/model.h"
#include "core/model/nonlinear_model.h"
#include "core/project/problem.h"
#include "core/util/json.h"
#include "core/util/output_guard.h"
#include "core/util/result.h"

namespace gb::cli {

// The whole command line: parses argv, runs the subcommand, returns the exit status (usage errors
// print a message and return 2). Never calls exit().
int Main(int argc, char** argv);

// Prints `greybench-cli: error: <where>: <what>` to stderr; returns 2 (input) or 1 (numerical).
int Fail(const Error& e);

// The output guard (core/util/output_guard.h) over one command's files, before it opens anything
// for writing: 0 when no output would destroy an input or another output, otherwise the refusal
// printed and its exit status (2).
int GuardOutputs(const std::vector<FileRole>& inputs, const std::vector<FileRole>& outputs);

// What a command's positional MODEL DATA... name: a model file and data files (CSV read in the
// default form), or a project file in the model's place: its model (a file or inline) and its
// datasets with their keys and roles (core/data/import.h). Data files given after a project
// replace its datasets.
struct CommandInputs {
  std::string model_path;                   // "" when the project holds the model inline
  Json inline_model;                        // the project's inline model
  std::string project_path;                 // "" without a project
  std::vector<data::DatasetSpec> datasets;  // every dataset, in order
  // Every file the project is made of (project::ProjectFiles: its diagram file too); empty
  // without a project.
  std::vector<FileRole> project_files;
  // Several fitted records each from its own initial state (the project's
  // "estimation": {"initial_states": "per_record"}, or --initial-states).
  bool per_record_initial_states = false;

  // The model file, or the project file for an inline model (for messages).
  const std::string& ModelSource() const { return model_path.empty() ? project_path : model_path; }
  // The files read, as inputs for GuardOutputs.
  std::vector<FileRole> Files() const;
};
// `first` is a project when it is a JSON object with "greybench_project". Without a project,
// `data` must not be empty ("give DATA files"); a project without datasets needs `data`.
// `initial_states` is --initial-states: "shared" or "per_record" overrides the project's
// "estimation": {"initial_states": ...}; "" keeps it (shared without a project).
Result<CommandInputs> ResolveInputs(const std::string& first, const std::vector<std::string>& data,
                                    const std::string& initial_states = "");
// Whether `path` holds a project: a JSON object with "greybench_project" (what is not JSON, or
// not readable, is left to the model's reader to report).
bool IsProjectFile(const std::string& path);
// The file a result names under `key` ("project_file", "model_file"), relative to the result
// file; "" when it names none.
std::string NamedFile(const Json& result, const char* key, const std::string& result_path);
// The datasets a fit uses (role estimation); an input error when there are none.
Result<std::vector<data::DatasetSpec>> FittedDatasets(const CommandInputs& in);
// The one dataset `predict` and `diagnose` work on: `choice` is its 1-based number in the
// project, its name or its file's name; "" picks the only one (several: an input error that lists
// them).
Result<data::DatasetSpec> ChooseDataset(const CommandInputs& in, const std::string& choice);

// The model as a fit of `in` sees it: with each fitted record's copies of the initial state's
// parameters (project::PerRecordInitialStates) when the records start from their own initial
// states and two or more are fitted; else `spec` itself (no index rows).
Result<project::RecordInitialStates> FittedModel(const CommandInputs& in, model::ModelSpec spec);

// Reads the model file and applies every `NAME=VALUE` of --set.
Result<model::ModelSpec> LoadModelWithOverrides(const std::string& path,
                                                const std::vector<std::string>& sets);
// The same for a command's model (a file, or a project's inline model).
Result<model::ModelSpec> LoadModelWithOverrides(const CommandInputs& in,
                                                const std::vector<std::string>& sets);

// The model (with --set applied) and its data as a likelihood, and θ at the model's values:
// the common start of loglik, bench and estimate.
struct LoadedLikelihood {
  filter::Likelihood likelihood;
  std::vector<double> theta;
};
// With `start_result`: the free parameters' values from that result file's estimates (those not
// set by `sets`; the model's fixed parameters keep theirs).
// The datasets used are FittedDatasets(in).
Result<LoadedLikelihood> LoadLikelihood(const CommandInputs& in,
                                        const std::vector<std::string>& sets,
                                        const std::string& start_result = "");

// A nonlinear model's filter (and smoother) on native code where it can be built, as a fit's
// (the same values bit for bit, from the library a fit of the model left in the cache), else on
// the interpreter. True if native code now runs.
bool UseNativeCode(filter::Likelihood* likelihood);

struct LoglikArgs {
  std::string initial_states;  // --initial-states ("" = the project's)
  std::string model;
  std::vector<std::string> data;
  std::vector<std::string> sets;
  bool gradient = false;  // also print ∂ log L/∂θ over the free parameters (natural scale)
};
int RunLoglik(const LoglikArgs& args);

struct BenchArgs {
  std::string model;
  std::vector<std::string> data;
  std::vector<std::string> sets;
  int repeat = 21;
};
int RunBench(const BenchArgs& args);

struct SimulateArgs {
  std::string model;
  std::string inputs;
  std::vector<std::string> sets;
  std::string result;  // the parameter values and delays of a result file
  std::uint64_t seed = 1;
  bool seed_given = false;
  bool deterministic = false;  // the noise-free response from x0
  std::string out;
};
int RunSimulate(const SimulateArgs& args);

struct PrbsArgs {
  int order = 6;
  double period = 0.5;
  double ts = 0.0125;
  double duration = 0;
  double low = -1;
  double high = 1;
  std::uint32_t seed = 1;
  std::string name = "u";
  std::string out;
};
int RunPrbs(const PrbsArgs& args);

struct EstimateArgs {
  std::string initial_states;  // --initial-states ("" = the project's)
  bool steady_start = false;   // EstimateOptions::steady_start
  double steady_window = 5.0;
  std::string model;
  std::vector<std::string> data;
  std::vector<std::string> sets;
  std::string out;
  int threads = 0;
  int multistart = 0;
  int starts_on_bound = 8;
  bool score_differences = false;
  bool log_scale = false;
  std::string start;  // a result file whose estimates are the start values
  int max_evaluations = 20000;
  std::string algorithm = "auto";
  double ftol = 1e-12;
  bool profile_intervals = false;
  double profile_level = 0.95;
  bool progress = false;  // one line per iteration on stderr
  // After every iteration, the best estimates so far as a result file that `--start` reads
  // ("partial": true), so that a long fit that is stopped can be resumed.
  std::string checkpoint;
};
int RunEstimate(const EstimateArgs& args);

struct CompareArgs {
  std::string a;
  std::string b;
};
int RunCompare(const CompareArgs& args);

// dyno EXPERIMENT: the virtual dyno's experiments (core/sim/dyno.h, engine.h, live_dyno.h). An
// option not given is empty (std::nullopt; the flags false) and takes the experiment's default;
// an option the experiment does not take is refused (RunDyno), never ignored. The ranges are
// checked when the command line is parsed (main.cpp), the limits of the record's size and the
// simulated world's step by RunDyno.
struct DynoArgs {
  std::string experiment;            // fuel, crankshaft, square-wave, engine
  std::optional<std::string> point;  // fuel, engine (default f1); engine also n=RPM,alpha=DEG
  // engine: a sweep along these points (comma-separated names, or n=..,alpha=.. joined by ';'),
  // `hold` s at each (>= 0, default 20) and `ramp` s between (> 0, default 40).
  std::optional<std::string> path;
  std::optional<double> hold, ramp;
  // engine: s between samples, 0.001..1 (default 0.0125, 80 Hz); the anti-alias filters cut off
  // at a quarter of the rate.
  std::optional<double> sample_time;
  bool hold_speed = false;                   // engine: the dyno holds the speed (else the load)
  std::optional<double> throttle_amplitude;  // engine: ± deg of the throttle's PRBS, 0..10 (1)
  std::optional<double> duration;  // s > 0 (the experiment's default; with --live, without end)
  std::uint64_t seed = 1;
  std::optional<int> order;          // PRBS order 2..24 (fuel and engine 6, crankshaft 7)
  std::optional<double> bit_period;  // PRBS bit period, s >= the sample time (0.5, crankshaft 1)
  bool no_filter = false;
  std::optional<int> oversample;  // fine-grid steps per sample of the simulated world, 1..1000 (10)
  std::optional<std::string> lambda_sensor;  // engine: exact (a delay line, default) or pade
  bool constant_load = false;                // crankshaft: hold the load torque
  std::string out;  // required without --live; with it, empty or "-" is stdout
  // --live (fuel): the live dyno (core/sim/live_dyno.h) writes its CSV a row at a time, each row
  // flushed, paced at `speed` times real time (>= 0, default 1; 0: as fast as it can), until
  // `duration` (without it, until the reader goes away: exit 0). `faults`:
  // TIME:PARAMETER*FACTOR[/RAMP] or TIME:clear[/RAMP].
  bool live = false;
  std::optional<double> speed;
  std::vector<std::string> faults;
  bool truth = false;  // also the true values of the faulted parameters, as columns
};
int RunDyno(const DynoArgs& args);

// linearise RESULT.json --point NAME=VALUE,...: the linearised model (A, B, C, D) of a fitted
// model at a steady state, with standard errors by the delta method (core/model/linearise.h).
// design MODEL --design SPEC [--design SPEC]: the standard errors an experiment would give
// (core/design/experiment.h), one design or two side by side; --fit N also simulates N records
// with each and fits them (core/project/design_fits.h).
struct DesignArgs {
  std::string model;
  std::vector<std::string> designs;  // the text form of design::InputDesign, 1 or 2
  std::string drive;                 // the input the designs drive (default: the only one)
  std::vector<std::string> holds;    // INPUT=VALUE: the other inputs' levels
  std::vector<std::string> sets;
  std::string result;  // the parameter values of a result file
  int fit = 0;         // records simulated and fitted per design
  std::uint64_t seed = 1;
  std::string out;  // JSON; empty: none
};
int RunDesign(const DesignArgs& args);

struct LineariseArgs {
  std::string result;
  std::string model;  // empty: the result file's "model_file"
  std::string point;
  std::vector<std::string> quantities;  // NAME=EXPRESSION
  std::string out;                      // JSON; empty: none
};
int RunLinearise(const LineariseArgs& args);

// monitor MODEL --reference RESULT.json (--follow FILE | -): the condition monitor of
// core/online/monitor.h over rows that arrive; one JSON line per update to --out or stdout, and
// every problem (a skipped row, an alarm) to stderr.
struct MonitorArgs {
  std::string model;
  std::vector<std::string> sets;
  std::string reference;
  std::string follow;  // a file to follow; "-" (as `source`): standard input
  std::string source;  // the positional "-"
  double forgetting = 0.999;
  std::vector<std::string> track;  // parameter names (empty: all that can be)
  double false_alarms = 0.125;     // per hour, all tests together
  double change = 0.25;            // relative parameter change worth an alarm
  std::optional<double> idle;      // --follow: stop after this many seconds without a new row
                                   // (> 0; none: never)
  int every = 1;                   // write every this-many-th update (alarms always)
  std::string out;                 // JSON Lines; empty or "-": stdout
};
int RunMonitor(const MonitorArgs& args);

struct SweepArgs {
  std::string model;
  std::vector<std::string> data;
  std::vector<std::string> sets;
  std::string out_csv;
  std::string out_md;
  std::optional<std::string> trend;  // PARAMETER:TAG; not given: X:alpha_deg where both exist
  std::string delay_parameter;       // a parameter that is the delay in seconds
  std::optional<int> parallel;       // not given: all cores
};
int RunSweep(const SweepArgs& args);

// The model, one data series and the parameter values and delays `predict` and `diagnose` work
// at: the model file's values, replaced by the estimates of a result file (--result, may be
// empty), then by --set. Delays: the result's "output_delay" estimates where it names them;
// otherwise the model's delay, chosen by profile likelihood at θ when the model scans a range.
// The filter settings score observations as `loglik` does (first used row = largest delay).
struct EvaluatedSeries {
  std::shared_ptr<const model::LinearModel> model;         // a linear model, with ss
  std::shared_ptr<const model::NonlinearModel> nonlinear;  // or one the EKF runs
  const model::ModelSpec& spec() const { return model ? model->spec() : nonlinear->spec(); }
  std::shared_ptr<const data::Series> series;
  std::vector<double> theta;
  model::StateSpace ss;
  filter::FilterSettings settings;  // with the chosen delay per output
  std::string delay_source;         // "model file", "result file" or "profile likelihood ..."
  int initial_samples = 0;          // a validation record: the rows its own initial state is from
};
Result<EvaluatedSeries> LoadEvaluatedSeries(const CommandInputs& in,
                                            const data::DatasetSpec& dataset,
                                            const std::vector<std::string>& sets,
                                            const std::string& result_path);
// Comment lines for output files: the tool, the files, the parameter values and the delays.
std::vector<std::string> DescribeEvaluation(const EvaluatedSeries& e, const std::string& tool);
// One-step predictions of the series at θ, by the Kalman filter or the EKF; with `trace`, what
// the filter computed as well (for SmoothStates).
Result<filter::OneStepPredictions> PredictOneStep(const EvaluatedSeries& e,
                                                  filter::FilterTrace* trace = nullptr);
// The smoothed states from that trace: Rauch-Tung-Striebel, or its extended form for the EKF.
Result<filter::SmoothedStates> SmoothStates(const EvaluatedSeries& e,
                                            const filter::FilterTrace& trace);
// The series' inputs as the residual diagnostics take them (diagnose, report): their values are
// copied into `values`, which the result points into.
std::vector<diagnose::InputSeries> DiagnoseInputs(const EvaluatedSeries& e,
                                                  std::vector<std::vector<double>>* values);

struct PredictArgs {
  std::string initial_states;  // --initial-states ("" = the project's)
  std::string model;           // or a project
  std::string data;            // "" with a project: its dataset chosen by `dataset`
  std::string dataset;
  std::vector<std::string> sets;
  std::string result;
  std::string out;
  // With N >= 1: the filter uses the outputs of the first N rows only; every later row is
  // predicted open loop from the state estimated on them (a simulation with its initial state
  // from N samples). stdout then gets the simulation's RMS error per output over rows >= N.
  int simulate_after = 0;
  // With a path: the filtered and smoothed states (and the smoothed outputs) written there.
  std::string states;
};
int RunPredict(const PredictArgs& args);

struct DiagnoseArgs {
  std::string initial_states;  // --initial-states ("" = the project's)
  std::string model;           // or a project
  std::string data;            // "" with a project: its dataset chosen by `dataset`
  std::string dataset;
  std::vector<std::string> sets;
  std::string result;
  std::string out;
  int max_lag = 0;         // 0: automatic (core/diagnose/residuals.h)
  int ljung_box_lags = 0;  // 0: automatic
};
int RunDiagnose(const DiagnoseArgs& args);

// export-model PROJECT --out MODEL: writes the model the project's block diagram (its "diagram"
// key: inline or a file name) compiles to. A project without a diagram is an input error.
struct ExportModelArgs {
  std::string project;
  std::string out;
};
int RunExportModel(const ExportModelArgs& args);

// export-fmu RESULT.json [--model MODEL] [--interface me|cs|both] --out NAME.fmu: the fitted
// model's deterministic part at the result's estimates as an FMI 2.0 FMU (core/fmu/fmu.h); the
// model is --model (a model or a project file), else the project or model file the result
// names. NAME (sanitised to a C identifier) is the FMU's model identifier.
struct ExportFmuArgs {
  std::string result;
  std::string model;
  std::string interface = "both";
  bool interface_given = false;
  bool virtual_sensor = false;  // the filter as a Co-Simulation FMU (core/fmu/sensor.c)
  std::string out;
};
int RunExportFmu(const ExportFmuArgs& args);

// report RESULT.json --out FILE: the estimation report as Markdown or HTML
// (core/report/report.h); with the model and the data (--model, --data, else the project or
// model file the result names) also the residual analysis of one dataset and, in HTML, its
// figures.
struct ReportArgs {
  std::string result;
  std::string model;  // a model or a project file ("": the result's project_file or model_file)
  std::vector<std::string> data;
  std::string dataset;  // which dataset (as predict's --dataset); "": the only one
  std::string format;   // md or html; "": the extension of `out`
  std::string out;
};
int RunReport(const ReportArgs& args);

}  // namespace gb::cli
