#include <cstdio>

#include <fmt/format.h>

#include "app/cli/cli.h"
#include "core/diagnose/residuals.h"
#include "core/filter/predict.h"
#include "core/util/file.h"
#include "core/util/json.h"

namespace gb::cli {
namespace {

Json CorrelogramJson(const diagnose::Correlogram& c) {
  return {{"lag", c.lag}, {"value", c.value}, {"band", c.band}};
}

Json DiagnosticsJson(const diagnose::ResidualDiagnostics& d) {
  Json j;
  j["rows"] = {{"first", d.first_row}, {"count", d.rows}};
  j["n"] = d.n;
  j["white"] = d.white;
  j["normal"] = d.normal;
  j["verdict"] = d.verdict;
  j["ljung_box"] = {{"statistic", d.ljung_box.statistic},
                    {"lags", d.ljung_box.lags},
                    {"df", d.ljung_box.df},
                    {"p_value", d.ljung_box.p_value}};
  j["acf"] = CorrelogramJson(d.acf);
  j["pacf"] = CorrelogramJson(d.pacf);
  Json ccf = Json::object();
  for (const auto& c : d.ccf) {
    Json e = CorrelogramJson(c.ccf);
    e["prewhitened"] = CorrelogramJson(c.ccf_prewhitened);
    e["prewhitened"]["ar"] = c.prewhitening_ar;
    e["constant"] = c.constant;
    e["peak_lag"] = c.peak_lag;
    e["peak"] = c.peak;
    e["peak_bound"] = c.peak_bound;
    e["significant"] = c.significant;
    ccf[c.input] = e;
  }
  j["ccf"] = ccf;
  const auto& cp = d.periodogram;
  j["cumulated_periodogram"] = {{"frequency", cp.frequency},
                                {"value", cp.value},
                                {"white", cp.white},
                                {"band", cp.band},
                                {"q", cp.q},
                                {"max_deviation", cp.max_deviation},
                                {"peak_frequency", cp.peak_frequency},
                                {"inside", cp.inside}};
  const auto& nm = d.normality;
  j["normality"] = {
      {"mean", nm.mean},
      {"sd", nm.sd},
      {"skewness", nm.skewness},
      {"excess_kurtosis", nm.excess_kurtosis},
      {"jarque_bera", nm.jarque_bera},
      {"p_value", nm.p_value},
      {"qq", {{"theoretical", nm.qq_theoretical}, {"sample", nm.qq_sample}}},
      {"histogram", {{"edges", nm.histogram_edges}, {"counts", nm.histogram_counts}}}};
  return j;
}

}  // namespace

int RunDiagnose(const DiagnoseArgs& args) {
  auto in = ResolveInputs(
      args.model,
      args.data.empty() ? std::vector<std::string>{} : std::vector<std::string>{args.data},
      args.initial_states);
  if (!in) return Fail(in.error());
  std::vector<FileRole> files = in->Files();
  files.push_back({args.result, "the --result file"});
  if (int s = GuardOutputs(files, {{args.out, "--out"}})) return s;
  auto dataset = ChooseDataset(*in, args.dataset);
  if (!dataset) return Fail(dataset.error());
  diagnose::DiagnoseOptions options;
  options.max_lag = args.max_lag;
  options.ljung_box_lags = args.ljung_box_lags;
  if (std::string why; !options.IsValid(&why)) return Fail(InputError(why));
  auto e = LoadEvaluatedSeries(*in, *dataset, args.sets, args.result);
  if (!e) return Fail(e.error());
  auto pred = PredictOneStep(*e);
  if (!pred) return Fail(pred.error());

  const model::ModelSpec& m = e->spec();
  const data::Series& s = *e->series;
  std::vector<std::vector<double>> input_values;
  const std::vector<diagnose::InputSeries> inputs = DiagnoseInputs(*e, &input_values);

  Json out;
  out["greybench_diagnostics"] = 1;
  out["model"] = m.name;
  out["model_file"] = m.source;
  out["dataset"] = s.source;
  Json params = Json::object();
  for (std::size_t i = 0; i < m.parameters.size(); ++i) params[m.parameters[i].name] = e->theta[i];
  out["parameters"] = params;
  Json delays = Json::object();
  for (std::size_t o = 0; o < m.outputs.size(); ++o) delays[m.outputs[o]] = e->settings.delay[o];
  out["output_delay"] = delays;
  out["delay_source"] = e->delay_source;
  out["loglik"] = pred->loglik.loglik;
  out["n_obs"] = pred->loglik.n_obs;
  // Lags are in samples and frequencies in cycles per sample; with one sample interval this
  // converts them to the data's time unit.
  out["sample_interval"] =
      s.intervals.distinct.size() == 1 ? Json(s.intervals.distinct[0]) : Json(nullptr);
  out["lag_convention"] =
      "ccf(k) = corr(residual[t+k], input[t]): a residual that responds to "
      "the input k samples later peaks at +k";

  Json outputs = Json::object();
  std::string verdict;
  int diagnosed = 0;
  Error first_error;
  for (std::size_t o = 0; o < m.outputs.size(); ++o) {
    const std::vector<double> z(pred->standardized.row(o).begin(), pred->standardized.row(o).end());
    auto d = diagnose::Diagnose(z, inputs, options);
    std::string line;
    if (d) {
      outputs[m.outputs[o]] = DiagnosticsJson(*d);
      line = d->verdict;
      ++diagnosed;
    } else {
      if (diagnosed == 0 && first_error.message.empty()) first_error = d.error();
      outputs[m.outputs[o]] = {{"error", d.error().message}};
      line = "not diagnosed: " + d.error().message;
    }
    verdict += fmt::format("{}{}: {}", verdict.empty() ? "" : "\n", m.outputs[o], line);
  }
  if (diagnosed == 0) {
    first_error.file = s.source;
    return Fail(first_error);
  }
  out["outputs"] = outputs;
  out["verdict"] = verdict;
  if (auto st = WriteFileAtomic(args.out, out.dump(1) + "\n"); !st) return Fail(st.error());
  std::printf("%s\n", verdict.c_str());
  return 0;
}

}  // namespace gb::cli
