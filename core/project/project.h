// Project files (user guide §3a): a name, a model (a path or an inline model object) and
// datasets, with paths relative to the project file.
//
//   {"greybench_project": 1, "name": "Fuel film f1",
//    "model": "models/fuel_film.json" | { inline model },
//    "datasets": ["data/f1.csv", {"file": "data/f2.csv", "role": "validation"}, ...],
//    ... other keys are kept untouched in `extra` (views, layout, diagram) }
// A dataset entry is a file name or an object with how to read and prepare it
// (core/data/import.h).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "core/data/import.h"
#include "core/util/json.h"
#include "core/util/output_guard.h"
#include "core/util/result.h"

namespace gb::project {

// clang-tidy's bugprone-exception-escape reports the implicit move constructor: it moves two
// nlohmann::ordered_json members, whose ordered_map storage is not declared noexcept-movable;
// such a move can only throw std::bad_alloc, which no caller could handle better.
// NOLINTNEXTLINE(bugprone-exception-escape)
struct Project {
  std::string path;      // the project file as given ("" for an unsaved project)
  std::string base_dir;  // directory that relative paths are resolved against
  std::string name;
  std::string model_path;                   // resolved path of the model file; "" when inline
  Json model_json;                          // the model object (read from model_path, or inline)
  std::vector<data::DatasetSpec> datasets;  // with their files' paths resolved
  Json extra;                               // every other top-level key, preserved on save
};

// The project's "estimation" object: options of the Estimate view kept with the project
// (docs/user-guide.md, section 7). An absent member leaves the view's default.
//   "estimation": {"steady_start": true, "steady_window": 5, "initial_states": "per_record"}
struct EstimationDefaults {
  std::optional<bool> steady_start;     // EstimateOptions::steady_start
  std::optional<double> steady_window;  // EstimateOptions::steady_window (> 0)
  // "initial_states": "per_record" (true) or "shared": several records fitted each from its own
  // initial state (problem.h's PerRecordInitialStates) or all from the model's.
  std::optional<bool> per_record_initial_states;
};
inline constexpr const char* kEstimationKey = "estimation";
// LoadProject checks the object (errors name the file and JSON path, e.g. `engine.json:
// estimation.steady_start: expected true or false`); this reads what it holds.
EstimationDefaults ReadEstimationDefaults(const Project& project);

// The project's "sliders" list: the parameters the workbench shows as sliders beside the Data,
// Predictions and Residuals views (user guide §6a), in order. An entry is a parameter's name, or
// an object that also sets the slider's range and scale (absent: from the parameter's bounds or
// its value):
//   "sliders": ["tau_ff", {"parameter": "X", "min": 0, "max": 0.5, "log": false}]
struct SliderSpec {
  std::string parameter;
  std::optional<double> min, max;  // both or neither; min < max, finite
  std::optional<bool> log;         // a log scale (min > 0 then)
  bool operator==(const SliderSpec&) const = default;
};
inline constexpr const char* kSlidersKey = "sliders";
// LoadProject checks the list (errors name the file and JSON path, e.g. `case.json: sliders[1].min:
// expected a number`; whether the parameters exist is the model's business); this reads it.
std::vector<SliderSpec> ReadSliders(const Project& project);
// The list as the project file holds it: a name alone where neither range nor scale is set.
Json SlidersToJson(const std::vector<SliderSpec>& sliders);

// Reads a project file and the model file it names (the model is only read as JSON here;
// core/model validates it), and checks its dataset entries' keys (the recordings are read by
// data::ReadDataset). Errors name the file and JSON path, e.g.
// `case.json: datasets[1].decimal: expected "." or ","`.
Result<Project> LoadProject(const std::string& path);

// Every file the project is made of, as inputs for the output guard (core/util/output_guard.h):
// the project file, its model file, its datasets and its diagram file, each with its role.
std::vector<FileRole> ProjectFiles(const Project& p);

// `path` as given in a project file: relative paths are taken from `base_dir`.
std::string ResolvePath(const std::string& base_dir, const std::string& path);

// The project file for `p` saved at `path` (user guide §3a), the inverse of LoadProject:
//   "name"     p.name;
//   "model"    when p.model_path is set, that file's path (the caller has checked that it holds
//              the model to save); otherwise p.model_json inline;
//   "datasets" p.datasets (data::DatasetSpecToJson);
//   every key of p.extra, untouched (diagrams, layout).
// With `relative_paths`, model and dataset paths are written relative to the directory of
// `path` (as LoadProject resolves them); otherwise absolute (e.g. for a recovery file kept
// elsewhere). A path on another root than `path` stays absolute.
Json ProjectToJson(const Project& p, const std::string& path, bool relative_paths = true);

// Writes ProjectToJson(p, path) to `path` atomically. Errors name the file.
Status SaveProject(const Project& p, const std::string& path, bool relative_paths = true);

}  // namespace gb::project
