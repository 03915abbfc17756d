// The estimation report as a file: Markdown or HTML. The same facts as the text
// `greybench-cli estimate` prints (EstimateSummary::Report), as tables: the fit (log L, AIC, BIC,
// free parameters, observations), the estimates (estimate, standard error, t value, p-value, the
// 95 % Wald interval estimate ± 1.96 SE, the profile likelihood interval when computed, bounds),
// the output delays, the correlation of the estimates and the warnings; and, when the model and
// the data were at hand, per output the residual analysis of one dataset (Ljung-Box, cumulated
// periodogram, Jarque-Bera, the verdict of core/diagnose/residuals.h). The HTML report also holds
// the main figures inline as SVG (core/report/figure.h): the one-step predictions with ± 2 SD
// and the measured values, and the ACF of the standardised residuals with its 95 % band.
//
// Input: a result file's JSON (user guide §5; EstimateSummary::ToJson gives the same for a
// fit in memory). Numbers are printed as the text report prints them (estimates and errors to 6
// significant digits, t to 3, p-values to 3 or "<2e-16", log L to 6 decimals); a value the result
// lacks (null) is printed as "–", never as a number.
#pragma once

#include <string>
#include <vector>

#include "core/diagnose/residuals.h"
#include "core/report/figure.h"
#include "core/util/json.h"
#include "core/util/result.h"

namespace gb::report {

enum class ReportFormat { kMarkdown, kHtml };

// The residual analysis of one output of one dataset.
struct ResidualSection {
  std::string output;
  std::string dataset;  // the data file's name
  diagnose::ResidualDiagnostics diagnostics;
  Figure predictions;  // PredictionFigure
  Figure acf;          // AcfFigure
};

struct ReportInput {
  Json result;              // a result file's JSON
  std::string result_file;  // for the report's heading and errors ("" : a fit in memory)
  std::vector<ResidualSection> residuals;  // empty: no residual analysis
  std::string residuals_note;  // why there is none, when empty (e.g. "give --model and --data")
};

// The report. An input error, naming result_file and the JSON path, when the JSON is not a result
// (CheckResultJson).
Result<std::string> WriteReport(const ReportInput& in, ReportFormat format);

// Ok when `result` has what a report needs ("greybench_result", a "parameters" object); else an
// input error naming `file` and the JSON path.
Status CheckResultJson(const Json& result, const std::string& file);

// "md" / "markdown" and "html" / "htm" (any case); nullopt otherwise.
std::optional<ReportFormat> ParseReportFormat(const std::string& name);

// The figures of a residual section. t: the sample times; y the measured output (NaN missing),
// y_pred the one-step predictions and lower, upper the band y_pred ∓ 2 sd (NaN where none).
Figure PredictionFigure(const std::string& output, const std::string& time_unit,
                        const std::vector<double>& t, const std::vector<double>& y,
                        const std::vector<double>& y_pred, const std::vector<double>& lower,
                        const std::vector<double>& upper);
Figure AcfFigure(const std::string& output, const diagnose::Correlogram& acf);

}  // namespace gb::report
