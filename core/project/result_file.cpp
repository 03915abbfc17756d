#include "core/project/result_file.h"

#include <algorithm>
#include <cmath>
#include <filesystem>

#include <Eigen/Eigenvalues>
#include <fmt/format.h>
#include <fmt/ranges.h>

#include "core/online/monitor.h"
#include "core/util/file.h"
#include "core/util/json.h"

namespace gb::project {

Error ResultFileError(const std::string& file, const std::string& path,
                      const std::string& message) {
  Error e = InputError(message);
  e.file = file;
  e.path = path;
  return e;
}

Result<std::vector<int>> ApplyResultFile(const std::string& path, const std::set<std::string>& keep,
                                         model::ModelSpec* spec, bool free_only, Json* json) {
  auto j = ReadJsonFile(path);
  if (!j) return j.error();
  if (!j->is_object() || !j->contains("greybench_result"))
    return ResultFileError(path, "", "not a greybench result file (no \"greybench_result\")");
  if (json) *json = *j;
  const Json& params = (*j)["parameters"];
  if (!params.is_object())
    return ResultFileError(path, "parameters", "expected an object of parameter estimates");
  for (const auto& [name, entry] : params.items()) {
    const std::string where = "parameters." + name;
    if (keep.count(name)) continue;
    const int i = spec->ParameterIndex(name);
    if (i < 0)
      return ResultFileError(path, where,
                             fmt::format("the model {} has no parameter '{}': is the result from "
                                         "another model?",
                                         spec->source, name));
    if (!entry.is_object() || !entry.contains("estimate") || !entry["estimate"].is_number())
      return ResultFileError(path, where + ".estimate", "expected a number");
    const double value = entry["estimate"].get<double>();
    model::Parameter& par = spec->parameters[i];
    if (free_only && par.fixed) continue;
    if (!std::isfinite(value) ||
        (!par.fixed && ((par.lower && value < *par.lower) || (par.upper && value > *par.upper))))
      return ResultFileError(path, where + ".estimate",
                             fmt::format("{} is outside the bounds the model {} gives '{}'", value,
                                         spec->source, name));
    par.value = value;
  }
  // A free parameter the result does not name would silently keep the model's start value:
  // the result is from another model (or another version of it).
  std::string missing;
  for (const model::Parameter& par : spec->parameters)
    if (!par.fixed && !keep.count(par.name) && !params.contains(par.name))
      missing += (missing.empty() ? "'" : ", '") + par.name + "'";
  if (!missing.empty())
    return ResultFileError(
        path, "parameters",
        fmt::format("no estimate of the model's free parameter{} {} (the model {}): is the result "
                    "from another model? Give a value with --set NAME=VALUE, or fix the parameter",
                    missing.find(',') == std::string::npos ? "" : "s", missing, spec->source));
  std::vector<int> delay(spec->outputs.size(), -1);
  if (j->contains("output_delay")) {
    const Json& delays = (*j)["output_delay"];
    if (!delays.is_object()) return ResultFileError(path, "output_delay", "expected an object");
    for (const auto& [name, entry] : delays.items()) {
      const std::string where = "output_delay." + name + ".estimate";
      const int o = spec->OutputIndex(name);
      if (o < 0)
        return ResultFileError(path, "output_delay." + name,
                               fmt::format("the model {} has no output '{}'", spec->source, name));
      if (!entry.is_object() || !entry["estimate"].is_number_integer())
        return ResultFileError(path, where, "expected a whole number of samples");
      const int d = entry["estimate"].get<int>();
      const model::DelaySpec& range = spec->output_delay[o];
      if (d < range.min || d > range.max)
        return ResultFileError(path, where,
                               fmt::format("delay {} is outside the model's range {}..{} for '{}'",
                                           d, range.min, range.max, name));
      delay[o] = d;
    }
  }
  return delay;
}

namespace {

// The correlation checks' tolerance: greybench writes full doubles, so the matrices it writes are
// symmetric and have a unit diagonal to the last bit and eigenvalues above -1e-14; one off by
// more than this was edited or written by another program.
constexpr double kCorrelationTolerance = 1e-8;

// The covariance of the free parameters with standard errors (`free`, `se`) from the file's
// "correlation" (see LoadReference).
Result<Eigen::MatrixXd> CovarianceOfFile(const std::string& path, const Json& j,
                                         const model::ModelSpec& spec, const std::vector<int>& free,
                                         const std::vector<double>& se) {
  const auto k = static_cast<Eigen::Index>(free.size());
  Eigen::MatrixXd covariance = Eigen::MatrixXd::Zero(k, k);
  for (Eigen::Index a = 0; a < k; ++a) covariance(a, a) = se[a] * se[a];
  if (!j.contains("correlation")) {
    if (k < 2) return covariance;
    std::string names;
    for (int i : free) names += (names.empty() ? "" : ", ") + spec.parameters[i].name;
    return ResultFileError(
        path, "correlation",
        fmt::format("the result gives standard errors of {} parameters ({}) but no correlation "
                    "matrix, and taken as uncorrelated they would give wrong standard errors and "
                    "alarms: run estimate again with this version of greybench, which writes it",
                    k, names));
  }
  const Json& c = j["correlation"];
  if (!c.is_object() || !c.contains("names") || !c["names"].is_array() || !c.contains("matrix") ||
      !c["matrix"].is_array())
    return ResultFileError(path, "correlation", "expected an object with \"names\" and \"matrix\"");
  const Json& names = c["names"];
  const Json& matrix = c["matrix"];
  const std::size_t m = names.size();
  std::vector<Eigen::Index> at(m, -1);  // position in `free`, or -1
  std::vector<std::string> listed;
  for (std::size_t n = 0; n < m; ++n) {
    if (!names[n].is_string())
      return ResultFileError(path, fmt::format("correlation.names[{}]", n),
                             "expected a parameter name");
    listed.push_back(names[n].get<std::string>());
    if (std::find(listed.begin(), listed.end() - 1, listed.back()) != listed.end() - 1)
      return ResultFileError(path, fmt::format("correlation.names[{}]", n),
                             fmt::format("'{}' is listed twice", listed.back()));
    const int i = spec.ParameterIndex(listed.back());
    for (Eigen::Index a = 0; a < k; ++a)
      if (free[a] == i) at[n] = a;
  }
  for (Eigen::Index a = 0; a < k; ++a) {
    if (std::find(at.begin(), at.end(), a) == at.end())
      return ResultFileError(
          path, "correlation.names",
          fmt::format("'{}' has a standard error but is not in the correlation matrix: run "
                      "estimate again with this version of greybench",
                      spec.parameters[free[a]].name));
  }
  if (matrix.size() != m)
    return ResultFileError(path, "correlation.matrix",
                           fmt::format("expected {} rows, one per name", m));
  Eigen::MatrixXd r(m, m);
  for (std::size_t x = 0; x < m; ++x) {
    if (!matrix[x].is_array() || matrix[x].size() != m)
      return ResultFileError(path, fmt::format("correlation.matrix[{}]", x),
                             fmt::format("expected {} numbers, one per name", m));
    for (std::size_t y = 0; y < m; ++y) {
      const Json& v = matrix[x][y];
      if (!v.is_number() || !(std::abs(v.get<double>()) <= 1.0))
        return ResultFileError(path, fmt::format("correlation.matrix[{}][{}]", x, y),
                               "expected a correlation in [-1, 1]");
      r(static_cast<Eigen::Index>(x), static_cast<Eigen::Index>(y)) = v.get<double>();
    }
  }
  for (Eigen::Index x = 0; x < r.rows(); ++x) {
    if (std::abs(r(x, x) - 1.0) > kCorrelationTolerance)
      return ResultFileError(
          path, fmt::format("correlation.matrix[{}][{}]", x, x),
          fmt::format("the correlation of {} with itself is 1, not {:.10g}", listed[x], r(x, x)));
    for (Eigen::Index y = 0; y < x; ++y)
      if (std::abs(r(x, y) - r(y, x)) > kCorrelationTolerance)
        return ResultFileError(
            path, fmt::format("correlation.matrix[{}][{}]", x, y),
            fmt::format("{:.10g} differs from matrix[{}][{}] = {:.10g}: a correlation matrix is "
                        "symmetric",
                        r(x, y), y, x, r(y, x)));
  }
  // Positive semi-definite: no combination of the parameters with a negative variance. Within
  // the tolerance, negative eigenvalues are rounding and are set to 0.
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(0.5 * (r + r.transpose()));
  if (m > 0 && eigen.eigenvalues()(0) < -kCorrelationTolerance)
    return ResultFileError(
        path, "correlation.matrix",
        fmt::format("is not positive semi-definite (its smallest eigenvalue is {:.3g}, along a "
                    "combination of {}): no estimates have these correlations; run estimate "
                    "again with this version of greybench",
                    eigen.eigenvalues()(0),
                    online::CombinationOf(eigen.eigenvectors().col(0), listed)));
  if (m > 0 && eigen.eigenvalues()(0) < 0.0) {
    r = eigen.eigenvectors() * eigen.eigenvalues().cwiseMax(0.0).asDiagonal() *
        eigen.eigenvectors().transpose();
    const Eigen::VectorXd scale = r.diagonal().cwiseSqrt().cwiseInverse();
    r = scale.asDiagonal() * r * scale.asDiagonal();
  }
  for (std::size_t x = 0; x < m; ++x)
    for (std::size_t y = 0; y < m; ++y)
      if (at[x] >= 0 && at[y] >= 0 && at[x] != at[y])
        covariance(at[x], at[y]) =
            r(static_cast<Eigen::Index>(x), static_cast<Eigen::Index>(y)) * se[at[x]] * se[at[y]];
  return covariance;
}

}  // namespace

Result<online::Reference> LoadReference(const std::string& path, const model::ModelSpec& spec) {
  model::ModelSpec copy = spec;
  Json j;
  auto delays = ApplyResultFile(path, {}, &copy, /*free_only=*/true, &j);
  if (!delays) return delays.error();
  online::Reference r;
  r.source = path;
  r.theta = copy.Values();
  for (std::size_t o = 0; o < delays->size(); ++o)
    r.delay.push_back((*delays)[o] >= 0 ? (*delays)[o] : spec.output_delay[o].min);
  if (j.contains("n_obs") && j["n_obs"].is_number_integer()) r.n_obs = j["n_obs"].get<long>();
  // The covariance from the standard errors and the correlation matrix.
  const Json& params = j["parameters"];
  std::vector<double> se;
  for (int i = 0; i < static_cast<int>(spec.parameters.size()); ++i) {
    if (spec.parameters[i].fixed) continue;
    const std::string& name = spec.parameters[i].name;
    if (!params.contains(name)) continue;
    const Json& e = params[name];
    if (!e.contains("std_error") || !e["std_error"].is_number()) continue;
    const double s = e["std_error"].get<double>();
    if (!(s > 0.0) || !std::isfinite(s))
      return ResultFileError(path, "parameters." + name + ".std_error",
                             fmt::format("{:g} is not a standard error", s));
    r.free.push_back(i);
    se.push_back(s);
  }
  auto covariance = CovarianceOfFile(path, j, spec, r.free, se);
  if (!covariance) return covariance.error();
  r.covariance = std::move(*covariance);
  return r;
}

}  // namespace gb::project

namespace gb::project {
namespace {

const Json& Member(const Json& j, const char* key) {
  static const Json kNull;
  const auto it = j.find(key);
  return it == j.end() ? kNull : *it;
}

}  // namespace

Result<NestedFit> ReadNestedFit(const Json& result, const std::string& path) {
  const Json& j = result;
  auto fail = [&](const std::string& where, const std::string& what) {
    return ResultFileError(path, where, what);
  };
  if (!j.is_object() || !j.contains("greybench_result"))
    return fail("", "not a greybench result file (no \"greybench_result\")");
  if (j.value("partial", false))
    return fail("partial",
                "a partial result (a checkpoint of a fit that did not finish): its log L "
                "is not an optimum, so a likelihood-ratio test on it means nothing");
  if (j.value("cancelled", false))
    return fail("cancelled",
                "a fit stopped by the user before it finished: its log L is not an "
                "optimum, so a likelihood-ratio test on it means nothing");
  NestedFit fit;
  fit.path = path;
  const Json& loglik = Member(j, "loglik");
  if (!loglik.is_number() || !std::isfinite(loglik.get<double>()))
    return fail("loglik", "expected a finite number");
  if (!Member(j, "n_free").is_number_integer()) return fail("n_free", "expected a whole number");
  if (!Member(j, "n_obs").is_number_integer() || Member(j, "n_obs").get<long>() < 1)
    return fail("n_obs", "expected a whole number of observations (1 or more)");
  fit.loglik = loglik.get<double>();
  fit.n_free = Member(j, "n_free").get<int>();
  fit.n_obs = Member(j, "n_obs").get<long>();
  if (Member(j, "model").is_string()) fit.model = Member(j, "model").get<std::string>();
  namespace fs = std::filesystem;
  if (Member(j, "datasets").is_array())
    for (const Json& d : Member(j, "datasets"))
      if (d.is_string()) fit.datasets.push_back(fs::path(d.get<std::string>()).filename().string());
  if (Member(j, "data_fingerprints").is_array())
    for (const Json& d : Member(j, "data_fingerprints"))
      if (d.is_string()) fit.fingerprints.push_back(d.get<std::string>());
  std::sort(fit.datasets.begin(), fit.datasets.end());
  std::sort(fit.fingerprints.begin(), fit.fingerprints.end());
  const Json& params = Member(j, "parameters");
  if (!params.is_object()) return fail("parameters", "expected an object of parameter estimates");
  for (const auto& [name, entry] : params.items()) {
    if (!entry.is_object() || !Member(entry, "estimate").is_number())
      return fail("parameters." + name + ".estimate", "expected a number");
    const bool fixed = entry.value("fixed", false);
    fit.parameters[name] =
        fixed ? std::optional<double>(entry["estimate"].get<double>()) : std::nullopt;
  }
  return fit;
}

std::string WhyNotNested(const NestedFit& r, const NestedFit& f, bool* by_name_only) {
  if (r.n_obs != f.n_obs)
    return fmt::format("they were fitted to different data: {} has {} observations, {} has {}",
                       r.path, r.n_obs, f.path, f.n_obs);
  *by_name_only = r.fingerprints.empty() || f.fingerprints.empty();
  if (!*by_name_only && r.fingerprints != f.fingerprints)
    return fmt::format(
        "they were fitted to different data: the data files of {} and of {} "
        "differ in content",
        r.path, f.path);
  if (*by_name_only && r.datasets != f.datasets)
    return fmt::format("they were fitted to different data files ({} and {})",
                       fmt::join(r.datasets, ", "), fmt::join(f.datasets, ", "));
  for (const auto& [name, fixed_r] : r.parameters) {
    const auto it = f.parameters.find(name);
    if (it == f.parameters.end())
      return fmt::format("the models are not nested: '{}' of {} is not a parameter of {}", name,
                         r.path, f.path);
    const std::optional<double>& fixed_f = it->second;
    if (!fixed_r && fixed_f)
      return fmt::format(
          "the models are not nested: '{}' is free in {} (the fit with fewer free "
          "parameters) but fixed in {}",
          name, r.path, f.path);
    if (fixed_r && fixed_f &&
        std::abs(*fixed_r - *fixed_f) > 1e-12 * std::max(std::abs(*fixed_r), std::abs(*fixed_f)))
      return fmt::format("the models are not nested: '{}' is fixed at {} in {} and at {} in {}",
                         name, *fixed_r, r.path, *fixed_f, f.path);
  }
  return "";
}

}  // namespace gb::project
