// The operating-point sweep a project names: which datasets (one per operating point) one model
// is fitted to, and which relations are drawn across the points. A project key beside those of
// CONTRACT section 7 (kept in Project::extra):
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
//              Each file carries its operating point in a `# greybench: {"operating_point": ...}`
//              comment (core/estimate/sweep.h).
//   speed_tag  the tag n of the delay relation Δt = c / n (default "n_rpm").
//   trend      the parameter fitted against a tag, θ = a + b · tag (default X against alpha_deg).
//   mean_of    parameters averaged over the points (default tau_fv, tau_ff).
//   tags       how the views name a tag and its unit (default: the tag itself, no unit).
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

struct OperatingPointsSpec {
  std::vector<std::string> datasets;   // resolved paths
  bool datasets_from_project = false;  // `datasets` was absent: these are the project's
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
