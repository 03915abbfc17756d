#include "core/project/project.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "core/util/file.h"

namespace gb::project {
namespace fs = std::filesystem;

std::string ResolvePath(const std::string& base_dir, const std::string& p) {
  fs::path path(p);
  if (path.is_absolute() || base_dir.empty()) return path.lexically_normal().string();
  return (fs::path(base_dir) / path).lexically_normal().string();
}

namespace {

// `p` as written into a project file in `dir`: relative when it can be, "/" separated.
std::string PathForFile(const std::string& p, const fs::path& dir, bool relative) {
  const fs::path absolute = fs::absolute(fs::path(p)).lexically_normal();
  if (!relative) return absolute.generic_string();
  const fs::path rel = absolute.lexically_relative(dir);
  if (rel.empty()) return absolute.generic_string();
  return rel.generic_string();
}

// One entry of "sliders" at `where` ("sliders[1]"): a parameter's name, or an object with its
// range and scale.
Result<SliderSpec> ParseSlider(const Json& e, const std::string& file, const std::string& where) {
  SliderSpec s;
  if (e.is_string()) {
    s.parameter = e.get<std::string>();
    if (s.parameter.empty()) return FileError(file, "expected a parameter's name", where);
    return s;
  }
  if (!e.is_object())
    return FileError(file,
                     "expected a parameter's name or an object such as {\"parameter\": \"X\", "
                     "\"min\": 0, \"max\": 1}",
                     where);
  for (auto it = e.begin(); it != e.end(); ++it) {
    const std::string at = where + "." + it.key();
    if (it.key() == "parameter") {
      if (!it.value().is_string() || it.value().get<std::string>().empty())
        return FileError(file, "expected a parameter's name", at);
      s.parameter = it.value().get<std::string>();
    } else if (it.key() == "min" || it.key() == "max") {
      if (!it.value().is_number() || !std::isfinite(it.value().get<double>()))
        return FileError(file, "expected a finite number", at);
      (it.key() == "min" ? s.min : s.max) = it.value().get<double>();
    } else if (it.key() == "log") {
      if (!it.value().is_boolean()) return FileError(file, "expected true or false", at);
      s.log = it.value().get<bool>();
    } else {
      return FileError(file, "unknown member (expected parameter, min, max or log)", at);
    }
  }
  if (s.parameter.empty())
    return FileError(file, "the slider names no parameter (its \"parameter\")", where);
  if (s.min.has_value() != s.max.has_value())
    return FileError(file, "give both \"min\" and \"max\", or neither",
                     where + (s.min ? ".max" : ".min"));
  if (s.min && !(*s.min < *s.max))
    return FileError(file, fmt::format("min {} is not below max {}", *s.min, *s.max), where);
  if (s.log == true && s.min && !(*s.min > 0))
    return FileError(file, "a log scale needs min > 0", where + ".min");
  return s;
}

Status CheckSliders(const Json& list, const std::string& file) {
  if (!list.is_array())
    return FileError(file, "expected a list of parameter names such as [\"tau_ff\", \"X\"]",
                     kSlidersKey);
  std::vector<std::string> seen;
  for (std::size_t i = 0; i < list.size(); ++i) {
    const std::string where = fmt::format("{}[{}]", kSlidersKey, i);
    Result<SliderSpec> s = ParseSlider(list[i], file, where);
    if (!s) return s.error();
    if (std::find(seen.begin(), seen.end(), s->parameter) != seen.end())
      return FileError(file, "the parameter " + s->parameter + " has a slider already", where);
    seen.push_back(s->parameter);
  }
  return Ok{};
}

}  // namespace

Result<Project> LoadProject(const std::string& path) {
  auto json = ReadJsonFile(path);
  if (!json) return json.error();
  const Json& j = *json;
  if (!j.is_object()) return FileError(path, "a project file holds a JSON object");
  if (!j.contains("greybench_project"))
    return FileError(path, "not a greybench project: the key \"greybench_project\": 1 is missing");
  if (!j["greybench_project"].is_number_integer() ||
      j["greybench_project"].get<std::int64_t>() != 1)
    return FileError(path, "unsupported project version (this greybench reads version 1)",
                     "greybench_project");

  Project p;
  p.path = path;
  p.base_dir = fs::path(path).parent_path().string();
  if (j.contains("name")) {
    if (!j["name"].is_string()) return FileError(path, "expected a string", "name");
    p.name = j["name"].get<std::string>();
  }
  if (!j.contains("model")) return FileError(path, "the project names no model", "model");
  const auto& m = j["model"];
  if (m.is_string()) {
    p.model_path = ResolvePath(p.base_dir, m.get<std::string>());
    auto model = ReadJsonFile(p.model_path);
    if (!model) return model.error();
    p.model_json = *model;
  } else if (m.is_object()) {
    p.model_json = m;
  } else {
    return FileError(path, "expected a model file name or an inline model object", "model");
  }
  if (j.contains("datasets")) {
    const auto& d = j["datasets"];
    if (!d.is_array()) return FileError(path, "expected a list of data file names", "datasets");
    for (std::size_t i = 0; i < d.size(); ++i) {
      Result<data::DatasetSpec> spec =
          data::ParseDatasetSpec(d[i], path, fmt::format("datasets[{}]", i));
      if (!spec) return spec.error();
      spec->file = ResolvePath(p.base_dir, spec->file);
      p.datasets.push_back(std::move(*spec));
    }
  }
  if (j.contains(kEstimationKey)) {
    const Json& e = j[kEstimationKey];
    const std::string root = kEstimationKey;
    if (!e.is_object())
      return FileError(path, "expected an object such as {\"steady_start\": true}", root);
    for (auto it = e.begin(); it != e.end(); ++it) {
      if (it.key() == "steady_start") {
        if (!it.value().is_boolean())
          return FileError(path, "expected true or false", root + ".steady_start");
      } else if (it.key() == "steady_window") {
        if (!it.value().is_number() || !(it.value().get<double>() > 0))
          return FileError(path, "expected a number of time units greater than 0",
                           root + ".steady_window");
      } else if (it.key() == "initial_states") {
        if (!it.value().is_string() || (it.value() != "shared" && it.value() != "per_record"))
          return FileError(path,
                           "expected \"shared\" (every record from the model's initial state) "
                           "or \"per_record\" (each from its own)",
                           root + ".initial_states");
      } else {
        return FileError(path,
                         "unknown member (expected steady_start, steady_window or initial_states)",
                         root + "." + it.key());
      }
    }
  }
  if (j.contains(kSlidersKey)) {
    if (Status checked = CheckSliders(j[kSlidersKey], path); !checked) return checked.error();
  }
  if (p.name.empty()) p.name = fs::path(path).stem().string();
  for (auto it = j.begin(); it != j.end(); ++it) {
    if (it.key() != "greybench_project" && it.key() != "name" && it.key() != "model" &&
        it.key() != "datasets")
      p.extra[it.key()] = it.value();
  }
  return p;
}

std::vector<SliderSpec> ReadSliders(const Project& project) {
  std::vector<SliderSpec> out;
  if (!project.extra.is_object() || !project.extra.contains(kSlidersKey)) return out;
  const Json& list = project.extra[kSlidersKey];
  if (!list.is_array()) return out;
  for (const Json& e : list) {
    Result<SliderSpec> s = ParseSlider(e, "", "");
    if (s) out.push_back(std::move(*s));
  }
  return out;
}

Json SlidersToJson(const std::vector<SliderSpec>& sliders) {
  Json list = Json::array();
  for (const SliderSpec& s : sliders) {
    if (!s.min && !s.log) {
      list.push_back(s.parameter);
      continue;
    }
    Json e = Json::object();
    e["parameter"] = s.parameter;
    if (s.min) e["min"] = *s.min;
    if (s.max) e["max"] = *s.max;
    if (s.log) e["log"] = *s.log;
    list.push_back(std::move(e));
  }
  return list;
}

EstimationDefaults ReadEstimationDefaults(const Project& project) {
  EstimationDefaults d;
  if (!project.extra.is_object() || !project.extra.contains(kEstimationKey)) return d;
  const Json& e = project.extra[kEstimationKey];
  if (!e.is_object()) return d;
  if (auto it = e.find("steady_start"); it != e.end() && it->is_boolean())
    d.steady_start = it->get<bool>();
  if (auto it = e.find("steady_window"); it != e.end() && it->is_number() && it->get<double>() > 0)
    d.steady_window = it->get<double>();
  if (auto it = e.find("initial_states"); it != e.end() && it->is_string())
    d.per_record_initial_states = *it == "per_record";
  return d;
}

Json ProjectToJson(const Project& p, const std::string& path, bool relative_paths) {
  const fs::path dir = fs::absolute(fs::path(path)).lexically_normal().parent_path();
  Json j = Json::object();
  j["greybench_project"] = 1;
  j["name"] = p.name;
  if (!p.model_path.empty()) {
    j["model"] = PathForFile(p.model_path, dir, relative_paths);
  } else {
    j["model"] = p.model_json;
  }
  Json datasets = Json::array();
  for (const data::DatasetSpec& d : p.datasets)
    datasets.push_back(data::DatasetSpecToJson(d, PathForFile(d.file, dir, relative_paths)));
  j["datasets"] = std::move(datasets);
  if (p.extra.is_object()) {
    for (auto it = p.extra.begin(); it != p.extra.end(); ++it) j[it.key()] = it.value();
  }
  return j;
}

std::vector<FileRole> ProjectFiles(const Project& p) {
  std::vector<FileRole> files;
  if (!p.path.empty()) files.push_back({p.path, "the project file"});
  if (!p.model_path.empty()) files.push_back({p.model_path, "the project's model file"});
  for (const data::DatasetSpec& d : p.datasets)
    files.push_back({d.file, "a dataset of the project"});
  if (p.extra.is_object() && p.extra.contains("diagram") && p.extra["diagram"].is_string())
    files.push_back({ResolvePath(p.base_dir, p.extra["diagram"].get<std::string>()),
                     "the project's diagram file"});
  return files;
}

Status SaveProject(const Project& p, const std::string& path, bool relative_paths) {
  return WriteFileAtomic(path, ProjectToJson(p, path, relative_paths).dump(1) + "\n");
}

}  // namespace gb::project
