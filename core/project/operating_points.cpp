#include "core/project/operating_points.h"

#include <fmt/format.h>

#include "core/util/json.h"

namespace gb::project {
namespace {

// The reader walks the JSON with the path of the member it is at, so every error can name it.
class Reader {
 public:
  explicit Reader(const Project& project) : project_(project) {}

  Error Fail(const std::string& path, std::string message) const {
    Error e = InputError(std::move(message));
    e.file = project_.path;
    e.path = path;
    return e;
  }

  std::optional<Error> String(const Json& j, const std::string& path, const char* what,
                              std::string* out) const {
    if (!j.is_string()) return Fail(path, fmt::format("expected {} (a string)", what));
    *out = j.get<std::string>();
    if (out->empty()) return Fail(path, fmt::format("expected {}, not an empty string", what));
    return std::nullopt;
  }

  std::optional<Error> Strings(const Json& j, const std::string& path, const char* what,
                               std::vector<std::string>* out) const {
    if (!j.is_array()) return Fail(path, fmt::format("expected a list of {}s", what));
    out->clear();
    for (std::size_t i = 0; i < j.size(); ++i) {
      std::string s;
      if (auto e = String(j[i], fmt::format("{}[{}]", path, i), what, &s)) return e;
      out->push_back(std::move(s));
    }
    return std::nullopt;
  }

 private:
  const Project& project_;
};

constexpr const char* kMembers[] = {"datasets", "model", "delay_parameter", "speed_tag", "trend",
                                    "mean_of",  "tags",  "linearised"};

}  // namespace

TagLabel OperatingPointsSpec::Label(const std::string& tag) const {
  auto it = tags.find(tag);
  if (it == tags.end()) return {tag, ""};
  return {it->second.label.empty() ? tag : it->second.label, it->second.unit};
}

Result<std::optional<OperatingPointsSpec>> ReadOperatingPoints(const Project& project) {
  if (!project.extra.is_object() || !project.extra.contains(kOperatingPointsKey))
    return std::optional<OperatingPointsSpec>{};
  const Reader r(project);
  const std::string root = kOperatingPointsKey;
  const Json& j = project.extra[kOperatingPointsKey];
  if (!j.is_object())
    return r.Fail(root, "expected an object such as {\"datasets\": [\"f1.csv\", \"f2.csv\"]}");
  for (auto it = j.begin(); it != j.end(); ++it) {
    bool known = false;
    for (const char* m : kMembers) known = known || it.key() == m;
    if (!known)
      return r.Fail(root + "." + it.key(),
                    "unknown member (expected datasets, model, delay_parameter, speed_tag, trend, "
                    "mean_of, tags or linearised)");
  }

  OperatingPointsSpec spec;
  if (j.contains("datasets")) {
    std::vector<std::string> files;
    if (auto e = r.Strings(j["datasets"], root + ".datasets", "data file name", &files)) return *e;
    for (const std::string& f : files)
      spec.datasets.push_back(data::PlainDataset(ResolvePath(project.base_dir, f)));
  } else {
    spec.datasets = project.datasets;
    spec.datasets_from_project = true;
  }
  if (j.contains("model")) {
    std::string file;
    if (auto e = r.String(j["model"], root + ".model", "a model file name", &file)) return *e;
    spec.model = ResolvePath(project.base_dir, file);
  }
  if (j.contains("delay_parameter")) {
    if (auto e = r.String(j["delay_parameter"], root + ".delay_parameter", "a parameter name",
                          &spec.delay_parameter))
      return *e;
  }
  if (j.contains("linearised")) {
    const Json& l = j["linearised"];
    const std::string path = root + ".linearised";
    if (!l.is_object())
      return r.Fail(path, "expected {\"result\": FILE, \"point\": {...}, \"quantities\": {...}}");
    LinearisedSpec lin;
    for (auto it = l.begin(); it != l.end(); ++it) {
      const std::string at = path + "." + it.key();
      if (it.key() == "result" || it.key() == "model") {
        std::string file;
        if (auto e = r.String(it.value(), at, "a file name", &file)) return *e;
        (it.key() == "result" ? lin.result : lin.model) = ResolvePath(project.base_dir, file);
      } else if (it.key() == "point") {
        if (!it.value().is_object() || it.value().empty())
          return r.Fail(at, "expected an object such as {\"N\": \"n_rpm\", \"ilambda\": 1}");
        for (auto v = it.value().begin(); v != it.value().end(); ++v) {
          LinearisedSpec::Value value;
          if (v.value().is_string() && !v.value().get<std::string>().empty())
            value.tag = v.value().get<std::string>();
          else if (v.value().is_number())
            value.number = v.value().get<double>();
          else
            return r.Fail(at + "." + v.key(), "expected a tag name (a string) or a number");
          lin.point.emplace_back(v.key(), std::move(value));
        }
      } else if (it.key() == "quantities") {
        if (!it.value().is_object() || it.value().empty())
          return r.Fail(at, "expected an object such as {\"tau_ff\": \"-1/A_mff_mff\"}");
        for (auto q = it.value().begin(); q != it.value().end(); ++q) {
          std::string text;
          if (auto e = r.String(q.value(), at + "." + q.key(), "an expression", &text)) return *e;
          lin.quantities.emplace_back(q.key(), std::move(text));
        }
      } else {
        return r.Fail(at, "unknown member (expected result, model, point or quantities)");
      }
    }
    if (lin.result.empty())
      return r.Fail(path, "name the nonlinear fit's result file in \"result\"");
    if (lin.point.empty()) return r.Fail(path, "give the operating point in \"point\"");
    spec.linearised = std::move(lin);
  }
  if (j.contains("speed_tag")) {
    if (auto e = r.String(j["speed_tag"], root + ".speed_tag", "a tag name", &spec.speed_tag))
      return *e;
  }
  if (j.contains("trend")) {
    const Json& t = j["trend"];
    const std::string path = root + ".trend";
    if (!t.is_object() || !t.contains("parameter") || !t.contains("tag"))
      return r.Fail(path, "expected {\"parameter\": NAME, \"tag\": TAG}");
    if (auto e = r.String(t["parameter"], path + ".parameter", "a parameter name",
                          &spec.trend_parameter))
      return *e;
    if (auto e = r.String(t["tag"], path + ".tag", "a tag name", &spec.trend_tag)) return *e;
  }
  if (j.contains("mean_of")) {
    if (auto e = r.Strings(j["mean_of"], root + ".mean_of", "parameter name", &spec.mean_of))
      return *e;
  }
  if (j.contains("tags")) {
    const Json& t = j["tags"];
    const std::string path = root + ".tags";
    if (!t.is_object())
      return r.Fail(path,
                    "expected an object such as {\"n_rpm\": {\"label\": \"n\", "
                    "\"unit\": \"rpm\"}}");
    for (auto it = t.begin(); it != t.end(); ++it) {
      const std::string at = path + "." + it.key();
      const Json& v = it.value();
      if (!v.is_object()) return r.Fail(at, "expected {\"label\": TEXT, \"unit\": TEXT}");
      TagLabel label;
      for (auto m = v.begin(); m != v.end(); ++m) {
        if (m.key() != "label" && m.key() != "unit")
          return r.Fail(at + "." + m.key(), "unknown member (expected label or unit)");
        if (!m.value().is_string()) return r.Fail(at + "." + m.key(), "expected a string");
        (m.key() == "label" ? label.label : label.unit) = m.value().get<std::string>();
      }
      spec.tags[it.key()] = std::move(label);
    }
  }
  if (spec.datasets.empty()) {
    return r.Fail(root + (spec.datasets_from_project ? "" : ".datasets"),
                  spec.datasets_from_project
                      ? "the project lists no datasets: name the sweep's in \"datasets\""
                      : "expected at least one data file");
  }
  return std::optional<OperatingPointsSpec>(std::move(spec));
}

}  // namespace gb::project
