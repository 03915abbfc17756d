// The operating-point sweep a project names: which datasets (one per operating point) one model
// is fitted to, and which relations are drawn across the points. A project key beside those of
// user guide §3a (kept in Project::extra):
//
//   "operating_points": {
//     "datasets":  ["../data/fuel_f1.csv", "../data/fuel_f2.csv", ...],
//     "speed_tag": "n_rpm",
//     "trend":     {"parameter": "X", "tag": "alpha_deg"},
//     "mean_of":   ["tau_fv", "tau_ff"],
//     "tags":      {"n_rpm": {"label": "n", "unit": "rpm"}, "alpha_deg": {"label": "α", "unit":
//     "°"}}
//   }
//
// Every member is optional:
//   datasets   paths relative to the project file; absent: the project's own `datasets`.
//   model      the model fitted at each point (a file, relative to the project file); absent: the
//              project's model. A project whose model is nonlinear names its per-point linear
//              model here.
//   delay_parameter  a parameter that is the delay in seconds (a model whose delay is continuous,
//              e.g. through a Padé approximant), for the delay relation; absent: the output delay
//              in whole samples.
//              Each file carries its operating point in a `# greybench: {"operating_point": ...}`
//              comment (core/project/sweep.h).
//   speed_tag  the tag n of the delay relation Δt = c / n (default "n_rpm").
//   trend      the parameter fitted against a tag, θ = a + b · tag (default X against alpha_deg).
//   mean_of    parameters averaged over the points (default tau_fv, tau_ff).
//   tags       how the views name a tag and its unit (default: the tag itself, no unit).
//   linearised the linearisation of a fitted nonlinear model at every point, beside the per-point
//              fits (core/model/linearise.h):
//                "linearised": {
//                  "result": "../results/engine_mvem.json",   the fit (its estimates and
//                  covariance) "model":  "../models/engine_mvem.json",    absent: the project's
//                  model "point":  {"N": "n_rpm", "alpha": "alpha_deg", "ilambda": 1},
//                  "quantities": {"tau_ff": "-1/A_mff_mff", "X": "-B_mff_mfi/A_mff_mff"}
//                }
//              `point` gives each state, input or output that fixes the steady state a tag of
//              the point's data file or a number; `quantities` are named like the per-point
//              model's parameters they are compared with.
// `{}` sweeps the project's datasets with every default.
#pragma once

#include <map>
#include <optional>
#include <string>
#include <vector>

#include "core/project/project.h"
#include "core/util/result.h"

namespace gb::project {

struct TagLabel {
  std::string label;  // "n"
  std::string unit;   // "rpm"; "" when the tag has none
};

// "linearised" of the key (see above), paths resolved.
struct LinearisedSpec {
  std::string result;
  std::string model;  // "": the project's model
  struct Value {
    std::string tag;    // a tag of the point's data file, or
    double number = 0;  // this number when `tag` is empty
  };
  std::vector<std::pair<std::string, Value>> point;             // state, input or output -> value
  std::vector<std::pair<std::string, std::string>> quantities;  // name -> expression
};

struct OperatingPointsSpec {
  std::vector<data::DatasetSpec> datasets;  // files resolved
  bool datasets_from_project = false;       // `datasets` was absent: these are the project's
  std::string model;                        // resolved path; "": the project's model
  std::string delay_parameter;              // "": the output delay in samples
  std::optional<LinearisedSpec> linearised;
  std::string speed_tag = "n_rpm";
  std::string trend_parameter = "X";
  std::string trend_tag = "alpha_deg";
  std::vector<std::string> mean_of = {"tau_fv", "tau_ff"};
  std::map<std::string, TagLabel> tags;

  // The label of `tag` (the tag itself when the project gives none) and its unit.
  TagLabel Label(const std::string& tag) const;
};

inline constexpr const char* kOperatingPointsKey = "operating_points";

// Reads the "operating_points" key of `project` (absent: nullopt). Errors name the project file
// and the JSON path, e.g. `case.json: operating_points.trend.tag: expected a tag name (a string)`.
Result<std::optional<OperatingPointsSpec>> ReadOperatingPoints(const Project& project);

}  // namespace gb::project
