// greybench-cli report: the estimation report of a result file as Markdown or HTML
// (core/report/report.h), with the residual analysis of one dataset when the model and the data
// are at hand.
#include "core/report/report.h"

#include <cstdio>
#include <filesystem>

#include <fmt/format.h>

#include "app/cli/cli.h"
#include "core/diagnose/residuals.h"
#include "core/util/file.h"

namespace gb::cli {
namespace {

namespace fs = std::filesystem;

// The residual sections of the report: one-step predictions at the result's estimates and their
// diagnostics, per output, as `diagnose` computes them.
Result<std::vector<report::ResidualSection>> ResidualSections(const CommandInputs& in,
                                                              const ReportArgs& args) {
  auto dataset = ChooseDataset(in, args.dataset);
  if (!dataset) return dataset.error();
  auto e = LoadEvaluatedSeries(in, *dataset, {}, args.result);
  if (!e) return e.error();
  auto pred = PredictOneStep(*e);
  if (!pred) return pred.error();
  const model::ModelSpec& m = e->spec();
  const data::Series& s = *e->series;
  std::vector<std::vector<double>> input_values;
  const std::vector<diagnose::InputSeries> inputs = DiagnoseInputs(*e, &input_values);
  const auto row = [](const Eigen::MatrixXd& x, std::size_t o) {
    return std::vector<double>(x.row(static_cast<Eigen::Index>(o)).begin(),
                               x.row(static_cast<Eigen::Index>(o)).end());
  };
  std::vector<report::ResidualSection> sections;
  for (std::size_t o = 0; o < m.outputs.size(); ++o) {
    auto d = diagnose::Diagnose(row(pred->standardized, o), inputs, {});
    if (!d) {
      Error err = d.error();
      err.file = s.source;
      err.message = "output " + m.outputs[o] + ": " + err.message;
      return err;
    }
    report::ResidualSection section;
    section.output = m.outputs[o];
    section.dataset = fs::path(s.source).filename().string();
    section.diagnostics = std::move(d).value();
    const std::vector<double> y_pred = row(pred->y_pred, o), y_sd = row(pred->y_sd, o);
    std::vector<double> lower(y_pred.size()), upper(y_pred.size());
    for (std::size_t k = 0; k < y_pred.size(); ++k) {
      lower[k] = y_pred[k] - 2.0 * y_sd[k];
      upper[k] = y_pred[k] + 2.0 * y_sd[k];
    }
    section.predictions =
        report::PredictionFigure(m.outputs[o], "", s.time, row(s.Y, o), y_pred, lower, upper);
    section.acf = report::AcfFigure(m.outputs[o], section.diagnostics.acf);
    sections.push_back(std::move(section));
  }
  return sections;
}

// The data files a result names ("datasets"), relative to the result file, when every one of
// them is there; empty otherwise.
std::vector<std::string> NamedData(const Json& result, const std::string& result_path) {
  std::vector<std::string> files;
  if (!result.contains("datasets") || !result["datasets"].is_array()) return {};
  for (const Json& d : result["datasets"]) {
    if (!d.is_string()) return {};
    fs::path file = d.get<std::string>();
    if (!file.is_absolute()) file = fs::path(result_path).parent_path() / file;
    std::error_code ec;
    if (!fs::is_regular_file(file, ec)) return {};
    files.push_back(file.lexically_normal().string());
  }
  return files;
}

}  // namespace

int RunReport(const ReportArgs& args) {
  // The format: --format, else the extension of --out.
  std::string format_name = args.format;
  if (format_name.empty()) {
    format_name = fs::path(args.out).extension().string();
    if (!format_name.empty()) format_name.erase(0, 1);
    if (!report::ParseReportFormat(format_name)) {
      return Fail(InputError("--out " + args.out +
                             ": give --format md or --format html (the name's extension does not "
                             "say which)"));
    }
  }
  const std::optional<report::ReportFormat> format = report::ParseReportFormat(format_name);
  if (!format) return Fail(InputError("--format '" + format_name + "': expected md or html"));

  auto result = ReadJsonFile(args.result);
  if (!result) return Fail(result.error());
  if (Status st = report::CheckResultJson(*result, args.result); !st) return Fail(st.error());

  // The model and the data the residual analysis needs: --model (a model or a project file) and
  // --data, else the project or model file the result names (with the project's datasets).
  const bool explicit_model = !args.model.empty();
  std::string model = args.model;
  if (model.empty()) model = NamedFile(*result, "project_file", args.result);
  if (model.empty()) model = NamedFile(*result, "model_file", args.result);
  // A model file without --data: the data files the result names (a project has its own).
  std::vector<std::string> data = args.data;
  if (data.empty() && !model.empty() && !IsProjectFile(model))
    data = NamedData(*result, args.result);
  std::vector<FileRole> files = {{args.result, "the result file"}};
  std::optional<CommandInputs> in;
  std::string note;
  if (model.empty()) {
    note = "Not computed: the result file names no model file; give --model and --data.";
  } else if (auto resolved = ResolveInputs(model, data); resolved) {
    in = std::move(resolved).value();
  } else if (explicit_model || !args.data.empty()) {
    return Fail(resolved.error());
  } else {
    note = "Not computed: " + resolved.error().ToString() +
           ". Give the model and the data with --model and --data.";
  }
  if (in) {
    const std::vector<FileRole> read = in->Files();
    files.insert(files.end(), read.begin(), read.end());
  } else if (!model.empty()) {
    files.push_back({model, "the model file"});
  }
  for (const std::string& d : data) files.push_back({d, "a data file"});
  if (int s = GuardOutputs(files, {{args.out, "--out"}})) return s;

  report::ReportInput input;
  input.result = std::move(result).value();
  input.result_file = args.result;
  input.residuals_note = note;
  if (in) {
    auto sections = ResidualSections(*in, args);
    if (!sections) return Fail(sections.error());
    input.residuals = std::move(sections).value();
  } else {
    std::fprintf(stderr, "greybench-cli: warning: the report has no residual analysis: %s\n",
                 note.c_str());
  }
  auto text = report::WriteReport(input, *format);
  if (!text) return Fail(text.error());
  if (auto st = WriteFileAtomic(args.out, *text); !st) return Fail(st.error());
  return 0;
}

}  // namespace gb::cli
