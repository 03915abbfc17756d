// Operating-point sweep: one model estimated separately on many datasets, each tagged with the
// operating point it was recorded at, and the parameters related to the operating point
// (the paper's Table 2 and Fig. 3-4).
//
// Tags: a data file carries its operating point in a comment line
//   # greybench: {"operating_point": {"name": "f1", "n_rpm": 2931, "alpha_deg": 29.5}}
// (the virtual dyno writes it). Any numeric fields are kept; `name` labels the row.
//
// Relations fitted across the points (ordinary least squares, with standard errors):
//   delay:  Δt = c / n            (Fig. 3: the exhaust transport delay falls with speed)
//   trend:  θ = a + b · tag        for a chosen parameter and tag (Fig. 4: X against α)
#pragma once

#include <map>
#include <optional>
#include <string>
#include <vector>

#include "core/estimate/estimate.h"
#include "core/model/model.h"

namespace gb::estimate {

struct OperatingPoint {
  std::string name;                  // from the tag, else the file's stem
  std::map<std::string, double> values;  // numeric tags (n_rpm, alpha_deg, ...)
};

// Reads the `# greybench: {...}` tag of a data file (an empty point if there is none).
Result<OperatingPoint> ReadOperatingPoint(const std::string& path);

struct SweepRow {
  std::string dataset;
  OperatingPoint point;
  double sample_interval = 0;       // mean interval of the data (delays in seconds = samples × it)
  EstimateSummary summary;
};

struct LinearFit {
  std::string y, x;                 // what was fitted against what
  double a = 0, b = 0;              // y = a + b x   (for the delay relation: a = 0, b = c, x = 1/n)
  double se_a = 0, se_b = 0;
  double r2 = 0;
  int n = 0;
};

struct SweepResult {
  std::vector<SweepRow> rows;
  std::map<std::string, std::pair<double, double>> means;  // parameter -> (mean, SD across points)
  std::optional<LinearFit> delay_vs_speed;  // Δt (s) = c / n
  std::optional<LinearFit> trend;           // parameter vs tag
  std::string Markdown() const;             // the Table 2 layout: est (SE) per point
  std::string Csv() const;                  // one row per point: tags, estimates, SEs
};

struct SweepOptions {
  EstimateOptions estimate;
  std::vector<std::string> mean_of = {"tau_fv", "tau_ff"};  // parameters to average
  std::string speed_tag = "n_rpm";
  std::string trend_parameter = "X";
  std::string trend_tag = "alpha_deg";
  int parallel = 0;  // datasets fitted at once (0 = all cores; each fit then uses one thread)
};

// Fits `spec` to every dataset. A dataset that cannot be read or fitted fails the sweep with
// its name in the message.
Result<SweepResult> Sweep(const model::ModelSpec& spec, const std::vector<std::string>& datasets,
                          const SweepOptions& options);

}  // namespace gb::estimate
