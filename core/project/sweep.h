// Operating-point sweep: one model estimated separately on many datasets, each tagged with the
// operating point it was recorded at, and the parameters related to the operating point
// (the paper's Table 2 and Fig. 3-4).
//
// Tags: a data file carries its operating point in a comment line
//   # greybench: {"operating_point": {"name": "f1", "n_rpm": 2931, "alpha_deg": 29.5}}
// (the virtual dyno writes it). Any numeric fields are kept; `name` labels the row.
//
// Relations fitted across the points (ordinary least squares, with standard errors):
//   delay:  Δt = c / n            (Fig. 3: the exhaust transport delay falls with speed; Δt the
//                                  scanned delay in samples times the sample interval, or a
//                                  delay parameter in seconds: SweepOptions::delay_parameter)
//   trend:  θ = a + b · tag        for a chosen parameter and tag (Fig. 4: X against α)
#pragma once

#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "core/data/import.h"
#include "core/estimate/estimate.h"
#include "core/model/model.h"

namespace gb::project {

struct OperatingPoint {
  std::string name;                      // from the tag, else the file's stem
  std::map<std::string, double> values;  // numeric tags (n_rpm, alpha_deg, ...)
};

// Reads the `# greybench: {...}` tag of a data file (an empty point if there is none).
Result<OperatingPoint> ReadOperatingPoint(const std::string& path);

struct SweepRow {
  std::string dataset;
  OperatingPoint point;
  double sample_interval = 0;  // mean interval of the data (delays in seconds = samples × it)
  estimate::EstimateSummary summary;
};

struct LinearFit {
  std::string y, x;     // what was fitted against what
  double a = 0, b = 0;  // y = a + b x   (for the delay relation: a = 0, b = c, x = 1/n)
  double se_a = 0, se_b = 0;
  double r2 = 0;
  int n = 0;
};

struct SweepResult {
  // Set when EstimateOptions::cancel stopped the sweep: `rows` then holds only the points whose
  // fit had finished, and neither the means nor the relations are computed.
  bool cancelled = false;
  std::vector<SweepRow> rows;
  std::map<std::string, std::pair<double, double>> means;  // parameter -> (mean, SD across points)
  std::optional<LinearFit> delay_vs_speed;                 // Δt (s) = c / n
  std::optional<LinearFit> trend;                          // parameter vs tag
  std::string Markdown() const;                            // the Table 2 layout: est (SE) per point
  std::string Csv() const;  // one row per point: tags, estimates, SEs
};

// What Sweep reports while it runs (several datasets may be under way at once).
struct SweepProgress {
  int dataset = 0;        // index into Sweep's `datasets`
  bool finished = false;  // false: its fit starts; true: it ended (fitted, failed or cancelled)
};

struct SweepOptions {
  // Options of every fit. Its `cancel` also stops the sweep: no further dataset is started, the
  // fits under way return within about one evaluation, and Sweep returns a result with
  // `cancelled` set. Its `progress` is called from every fitting thread.
  estimate::EstimateOptions estimate;
  std::vector<std::string> mean_of = {"tau_fv", "tau_ff"};  // parameters to average
  std::string speed_tag = "n_rpm";
  // A parameter that is the delay in seconds (a continuous delay, e.g. a Padé approximant's):
  // the delay relation then fits its estimates. Empty: the first output's scanned delay.
  std::string delay_parameter;
  std::string trend_parameter = "X";
  std::string trend_tag = "alpha_deg";
  int parallel = 0;  // datasets fitted at once (0 = all cores; each fit then uses one thread)
  // Called from the fitting threads when a dataset's fit starts and when it ends (keep it short).
  std::function<void(const SweepProgress&)> progress;
};

// Fits `spec` to every dataset. A dataset that cannot be read or fitted fails the sweep with
// its name in the message (unless the sweep was cancelled: then the result says so).
Result<SweepResult> Sweep(const model::ModelSpec& spec,
                          const std::vector<data::DatasetSpec>& datasets,
                          const SweepOptions& options);

// y = a + b x by ordinary least squares (with_intercept), or y = b x through the origin; the
// standard errors from s² (X'X)⁻¹ with s² = RSS / (n - p). Fewer than p + 1 points: n is set and
// everything else stays 0. `y` and `x` (the names) are left empty.
LinearFit FitLine(const std::vector<double>& x, const std::vector<double>& y, bool with_intercept);

}  // namespace gb::project
