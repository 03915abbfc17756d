#include "core/project/linearised.h"

#include <cmath>
#include <limits>

#include <fmt/format.h>

#include "core/project/result_file.h"

namespace gb::project {

std::pair<double, double> LinearisedSweep::At(std::size_t i, const std::string& name) const {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  if (i >= points.size() || !points[i].error.empty()) return {nan, nan};
  for (std::size_t k = 0; k < quantities.size(); ++k)
    if (k < points[i].lin.quantities.size() && quantities[k] == name)
      return {points[i].lin.quantities[k], points[i].lin.se_quantities[k]};
  return {nan, nan};
}

Result<LinearisedSweep> LineariseAtPoints(const model::NonlinearModel& model,
                                          const NonlinearFit& fit, const LinearisedSpec& spec,
                                          const std::vector<OperatingPoint>& points) {
  // A model that changes with time fails at every point: say so once.
  if (auto st = model::CheckTimeInvariant(model.spec()); !st) return st.error();
  LinearisedSweep out;
  out.model_name = model.spec().name;
  out.result = spec.result;
  model::LinearisationOptions options;
  for (const auto& [name, text] : spec.quantities) {
    auto q = model::ParseQuantity(name + "=" + text);
    if (!q) return q.error();
    options.quantities.push_back(*q);
    out.quantities.push_back(name);
  }
  options.free = fit.free;
  options.covariance = fit.covariance;
  for (const auto& p : points) {
    LinearisedAtPoint at;
    at.point = p;
    std::vector<std::pair<std::string, double>> values;
    for (const auto& [name, v] : spec.point) {
      if (v.tag.empty()) {
        values.emplace_back(name, v.number);
        continue;
      }
      auto it = p.values.find(v.tag);
      if (it == p.values.end()) {
        at.error = fmt::format("the point has no tag '{}' (for {})", v.tag, name);
        break;
      }
      values.emplace_back(name, it->second);
    }
    if (at.error.empty()) {
      auto lin = model::Linearise(model, fit.theta, values, options);
      if (lin) {
        at.lin = std::move(*lin);
      } else {
        // A quantity naming what the model lacks fails at every point: say so once.
        if (lin.error().message.rfind("quantity ", 0) == 0) return lin.error();
        at.error = lin.error().message;
      }
    }
    out.points.push_back(std::move(at));
  }
  return out;
}

Result<LinearisedSweep> LineariseAtPoints(const LinearisedSpec& spec,
                                          const std::string& project_model,
                                          const std::vector<std::string>& datasets) {
  const std::string model_path = spec.model.empty() ? project_model : spec.model;
  auto model_spec = model::LoadModelFile(model_path);
  if (!model_spec) return model_spec.error();
  return LineariseAtPoints(spec, *model_spec, datasets);
}

Result<LinearisedSweep> LineariseAtPoints(const LinearisedSpec& spec,
                                          const model::ModelSpec& model_spec,
                                          const std::vector<std::string>& datasets) {
  auto reference = LoadReference(spec.result, model_spec);
  if (!reference) return reference.error();
  auto compiled = model::NonlinearModel::Compile(model_spec);
  if (!compiled) return compiled.error();
  std::vector<OperatingPoint> points;
  for (const auto& d : datasets) {
    auto p = ReadOperatingPoint(d);
    if (!p) return p.error();
    points.push_back(std::move(*p));
  }
  const NonlinearFit fit{reference->theta, reference->free, reference->covariance};
  return LineariseAtPoints(*compiled, fit, spec, points);
}

}  // namespace gb::project
