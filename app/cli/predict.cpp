#include "core/filter/predict.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <set>

#include <fmt/format.h>

#include "app/cli/cli.h"
#include "core/data/write_csv.h"
#include "core/filter/ekf_predict.h"
#include "core/filter/initial_state.h"
#include "core/project/problem.h"
#include "core/project/project.h"
#include "core/project/result_file.h"
#include "core/util/file.h"

namespace gb::cli {
namespace {

// predict --states: t, then per state x_filtered, x_filtered_sd, x_smoothed, x_smoothed_sd, then
// per output o_smoothed, o_smoothed_sd (the noise-free output at the smoothed state).
Status WriteStates(const std::string& path, const EvaluatedSeries& e,
                   const filter::FilterTrace& trace, const filter::SmoothedStates& smoothed,
                   std::vector<std::string> comments) {
  const model::ModelSpec& m = e.spec();
  const auto N = static_cast<Eigen::Index>(e.series->size());
  std::vector<std::vector<double>> storage;
  std::vector<std::string> names;
  auto add = [&](std::string name, auto value) {
    std::vector<double> column(static_cast<std::size_t>(N));
    for (Eigen::Index k = 0; k < N; ++k) column[static_cast<std::size_t>(k)] = value(k);
    storage.push_back(std::move(column));
    names.push_back(std::move(name));
  };
  for (std::size_t i = 0; i < m.states.size(); ++i) {
    const auto r = static_cast<Eigen::Index>(i);
    const auto sd = [r](const Eigen::MatrixXd& P) { return std::sqrt(std::max(P(r, r), 0.0)); };
    add(m.states[i] + "_filtered", [&](Eigen::Index k) { return trace.x_filt(r, k); });
    add(m.states[i] + "_filtered_sd", [&](Eigen::Index k) { return sd(trace.P_filt[k]); });
    add(m.states[i] + "_smoothed", [&](Eigen::Index k) { return smoothed.x(r, k); });
    add(m.states[i] + "_smoothed_sd", [&](Eigen::Index k) { return sd(smoothed.P[k]); });
  }
  for (std::size_t o = 0; o < m.outputs.size(); ++o) {
    const auto r = static_cast<Eigen::Index>(o);
    add(m.outputs[o] + "_smoothed", [&](Eigen::Index k) { return smoothed.y(r, k); });
    add(m.outputs[o] + "_smoothed_sd", [&](Eigen::Index k) { return smoothed.y_sd(r, k); });
  }
  std::vector<data::CsvColumn> cols = {{"t", e.series->time}};
  for (std::size_t c = 0; c < storage.size(); ++c) cols.push_back({names[c], storage[c]});
  comments.insert(comments.begin() + 1,
                  e.nonlinear ? "states: filtered by the extended Kalman filter, smoothed by "
                                "the extended Rauch-Tung-Striebel smoother"
                              : "states: filtered by the Kalman filter, smoothed by the "
                                "Rauch-Tung-Striebel smoother");
  return data::WriteCsvFile(path, cols, comments);
}

}  // namespace

Result<EvaluatedSeries> LoadEvaluatedSeries(const CommandInputs& in,
                                            const data::DatasetSpec& dataset,
                                            const std::vector<std::string>& sets,
                                            const std::string& result_path) {
  auto loaded = LoadModelWithOverrides(in, sets);
  if (!loaded) return loaded.error();
  // A fitted record of a fit per record starts from its own copies of the initial state's
  // parameters (record 1 from the originals); a result of such a fit says so.
  CommandInputs as_fitted = in;
  if (!result_path.empty()) {
    auto result = ReadJsonFile(result_path);
    if (result && result->is_object() && result->value("initial_states", "") == "per_record")
      as_fitted.per_record_initial_states = true;
  }
  auto fitted_model = FittedModel(as_fitted, std::move(*loaded));
  if (!fitted_model) return fitted_model.error();
  model::ModelSpec* spec = &fitted_model->spec;
  int record = -1;  // the dataset's place among the fitted records
  if (!fitted_model->index.empty() && dataset.role == data::Role::kEstimation) {
    const auto fitted = data::WithRole(in.datasets, data::Role::kEstimation);
    for (std::size_t r = 0; r < fitted.size(); ++r)
      if (fitted[r].file == dataset.file && fitted[r].name == dataset.name)
        record = static_cast<int>(r);
  }
  std::vector<int> result_delay(spec->outputs.size(), -1);
  if (!result_path.empty()) {
    std::set<std::string> set_names;
    for (const auto& s : sets) set_names.insert(s.substr(0, s.find('=')));
    auto d = project::ApplyResultFile(result_path, set_names, &*spec);
    if (!d) return d.error();
    result_delay = *d;
  }
  EvaluatedSeries out;
  out.theta = spec->Values();
  if (record > 0)
    out.theta =
        filter::SeriesTheta(out.theta, fitted_model->index[static_cast<std::size_t>(record)]);
  auto problem = project::LoadProblem(std::move(*spec), std::vector{dataset});
  if (!problem) return problem.error();
  auto lik = project::MakeLikelihood(*problem);
  if (!lik) return lik.error();
  UseNativeCode(&*lik);
  out.model = problem->model;
  out.nonlinear = lik->nonlinear_shared();
  out.series = problem->series.front();
  const model::ModelSpec& m = out.spec();
  if (out.model) {
    auto ss = out.model->Evaluate(out.theta);
    if (!ss) return ss.error();
    out.ss = std::move(*ss);
  }
  out.settings = lik->settings();  // first observation = each output's largest delay

  // Delays: the result's where it names them; the rest at the model's value, or chosen by
  // profile likelihood at θ when the model scans a range (as `loglik` does).
  bool scan = false;
  for (std::size_t o = 0; o < m.outputs.size(); ++o)
    scan = scan || (result_delay[o] < 0 && m.output_delay[o].IsScan());
  out.settings.delay.resize(m.outputs.size());
  for (std::size_t o = 0; o < m.outputs.size(); ++o)
    out.settings.delay[o] = result_delay[o] >= 0 ? result_delay[o] : m.output_delay[o].min;
  bool from_result = false;
  for (int d : result_delay) from_result = from_result || d >= 0;
  out.delay_source = from_result ? "result file" : "model file";
  if (scan) {
    auto profile = lik->Profile(out.theta);
    if (!profile) return profile.error();
    int best = -1;
    for (int c = 0; c < static_cast<int>(profile->candidates.size()); ++c) {
      const auto& cand = profile->candidates[c];
      bool fits = cand.ok;
      for (std::size_t o = 0; o < m.outputs.size(); ++o)
        fits = fits && (result_delay[o] < 0 || cand.delay[o] == result_delay[o]);
      if (fits && (best < 0 || cand.loglik > profile->candidates[best].loglik)) best = c;
    }
    if (best < 0) return NumericalError(profile->candidates.front().message);
    out.settings.delay = profile->candidates[best].delay;
    out.delay_source = "profile likelihood at these parameter values";
  }
  // A validation record starts at its own initial state, from its first samples (as the
  // workbench's Predictions view does).
  if (dataset.role == data::Role::kValidation) {
    const int n = filter::InitialStateSamples(static_cast<int>(out.series->size()));
    Result<filter::InitialStateEstimate> start =
        out.nonlinear ? filter::EkfEstimateInitialState(*out.nonlinear, out.theta, *out.series,
                                                        out.settings, n)
                      : filter::EstimateInitialState(out.ss, *out.series, out.settings, n);
    if (!start) return start.error();
    out.settings.x0 = start->x0;
    out.settings.P0 = start->P0;
    out.initial_samples = start->samples;
  }
  return out;
}

Result<filter::OneStepPredictions> PredictOneStep(const EvaluatedSeries& e,
                                                  filter::FilterTrace* trace) {
  filter::FilterTrace own;
  if (!trace) trace = &own;
  const Result<filter::Loglik> l =
      e.nonlinear ? filter::EkfRunFilter(*e.nonlinear, e.theta, *e.series, e.settings, trace)
                  : filter::RunFilter(e.ss, *e.series, e.settings, trace);
  if (!l) return l.error();
  return filter::OneStepFromTrace(*e.series, e.settings, *trace, *l);
}

Result<filter::SmoothedStates> SmoothStates(const EvaluatedSeries& e,
                                            const filter::FilterTrace& trace) {
  if (e.nonlinear) return filter::EkfSmooth(*e.nonlinear, e.theta, *e.series, e.settings, trace);
  return filter::SmoothFromTrace(e.ss, *e.series, e.settings, trace);
}

std::vector<std::string> DescribeEvaluation(const EvaluatedSeries& e, const std::string& tool) {
  const model::ModelSpec& m = e.spec();
  std::vector<std::string> lines = {
      fmt::format("{} by greybench-cli: model {}, data {}", tool, m.source, e.series->source)};
  std::string values;
  for (std::size_t i = 0; i < m.parameters.size(); ++i)
    values += fmt::format("{}{}={}", i ? " " : "", m.parameters[i].name, e.theta[i]);
  lines.push_back("parameters: " + values);
  std::string delays;
  for (std::size_t o = 0; o < m.outputs.size(); ++o)
    delays += fmt::format("{}{}={}", o ? " " : "", m.outputs[o], e.settings.delay[o]);
  lines.push_back(fmt::format("output delay (samples): {} (from the {})", delays, e.delay_source));
  if (e.initial_samples > 0) {
    lines.push_back(
        fmt::format("initial state: a validation record's own, from its first {} "
                    "rows (smoothed back to its start)",
                    e.initial_samples));
  }
  return lines;
}

int RunPredict(const PredictArgs& args) {
  auto in = ResolveInputs(
      args.model,
      args.data.empty() ? std::vector<std::string>{} : std::vector<std::string>{args.data},
      args.initial_states);
  if (!in) return Fail(in.error());
  std::vector<FileRole> inputs = in->Files();
  inputs.push_back({args.result, "the --result file"});
  if (int s = GuardOutputs(inputs, {{args.out, "--out"}, {args.states, "--states"}})) return s;
  auto dataset = ChooseDataset(*in, args.dataset);
  if (!dataset) return Fail(dataset.error());
  auto e = LoadEvaluatedSeries(*in, *dataset, args.sets, args.result);
  if (!e) return Fail(e.error());
  const std::shared_ptr<const data::Series> original = e->series;  // e->series may be masked
  const data::Series& s = *original;
  const int N = static_cast<int>(s.size());
  if (args.simulate_after < 0 || args.simulate_after >= N)
    return Fail(
        InputError(fmt::format("--simulate-after {}: expected a number of rows from 1 to "
                               "{} ({} has {} rows)",
                               args.simulate_after, N - 1, s.source, N)));
  if (args.simulate_after > 0) {
    // The filter sees no output after the first rows: its predictions are the simulation.
    auto masked = std::make_shared<data::Series>(s);
    masked->Y.rightCols(N - args.simulate_after)
        .setConstant(std::numeric_limits<double>::quiet_NaN());
    e->series = masked;
  }
  filter::FilterTrace trace;
  auto pred = PredictOneStep(*e, &trace);
  if (!pred) return Fail(pred.error());
  pred->residual = s.Y - pred->y_pred;
  const model::ModelSpec& m = e->spec();
  std::vector<std::string> rms_lines;
  if (args.simulate_after > 0) {
    Json rms = Json::object();
    for (std::size_t o = 0; o < m.outputs.size(); ++o) {
      const auto row = static_cast<Eigen::Index>(o);
      double sum = 0.0, sum_y = 0.0;
      long count = 0;
      for (int k = args.simulate_after; k < N; ++k) {
        const double r = pred->residual(row, k);
        if (std::isnan(r)) continue;
        sum += r * r;
        sum_y += s.Y(row, k);
        ++count;
      }
      // fit % = 100 (1 - ||y - ŷ|| / ||y - ȳ||) over the same rows (the benchmark's NRMSE fit).
      double spread = 0.0;
      for (int k = args.simulate_after; k < N && count > 0; ++k) {
        if (std::isnan(pred->residual(row, k))) continue;
        const double d = s.Y(row, k) - sum_y / static_cast<double>(count);
        spread += d * d;
      }
      const double value = count ? std::sqrt(sum / count) : std::nan("");
      const double fit =
          count > 1 && spread > 0 ? 100 * (1 - std::sqrt(sum / spread)) : std::nan("");
      Json figures = {{"rms", value}, {"n", count}};
      if (std::isfinite(fit)) figures["fit_percent"] = fit;
      rms[m.outputs[o]] = figures;
      rms_lines.push_back(
          fmt::format("simulation of {} from row {} on (state from the first {} "
                      "rows): RMS error {:.6g}{} over {} rows",
                      m.outputs[o], args.simulate_after + 1, args.simulate_after, value,
                      std::isfinite(fit) ? fmt::format(", fit {:.1f} %", fit) : "", count));
    }
    std::printf("%s\n",
                Json{{"simulate_after", args.simulate_after}, {"outputs", rms}}.dump().c_str());
  }
  std::vector<std::vector<double>> storage;
  std::vector<std::string> names;
  for (std::size_t o = 0; o < m.outputs.size(); ++o) {
    const auto row = [&](const Eigen::MatrixXd& M) {
      return std::vector<double>(M.row(o).begin(), M.row(o).end());
    };
    storage.push_back(row(s.Y));
    names.push_back(m.outputs[o]);
    storage.push_back(row(pred->y_pred));
    names.push_back(m.outputs[o] + "_pred");
    storage.push_back(row(pred->y_sd));
    names.push_back(m.outputs[o] + "_sd");
    storage.push_back(row(pred->residual));
    names.push_back(m.outputs[o] + "_residual");
  }
  std::vector<data::CsvColumn> cols = {{"t", s.time}};
  for (std::size_t c = 0; c < storage.size(); ++c) cols.push_back({names[c], storage[c]});
  std::vector<std::string> comments =
      DescribeEvaluation(*e, args.simulate_after > 0 ? "simulation" : "one-step predictions");
  comments.insert(comments.end(), rms_lines.begin(), rms_lines.end());
  comments.push_back(fmt::format("log-likelihood {:.10g} over {} observations", pred->loglik.loglik,
                                 pred->loglik.n_obs));
  if (auto st = data::WriteCsvFile(args.out, cols, comments); !st) return Fail(st.error());
  if (!args.states.empty()) {
    auto smoothed = SmoothStates(*e, trace);
    if (!smoothed) return Fail(smoothed.error());
    if (auto st = WriteStates(args.states, *e, trace, *smoothed, comments); !st)
      return Fail(st.error());
  }
  return 0;
}

}  // namespace gb::cli
