#include "core/project/sweep.h"

#include <atomic>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>

#include <Eigen/Dense>
#include <fmt/format.h>

#include "core/project/problem.h"
#include "core/util/file.h"
#include "core/util/json.h"
#include "core/util/parallel.h"

namespace gb::project {
namespace {

constexpr const char* kTagPrefix = "# greybench:";

const estimate::ParameterEstimate* FindParameter(const estimate::EstimateSummary& s,
                                                 const std::string& name) {
  for (const auto& p : s.parameters)
    if (p.name == name) return &p;
  return nullptr;
}

}  // namespace

LinearFit FitLine(const std::vector<double>& x, const std::vector<double>& y, bool with_intercept) {
  LinearFit f;
  f.n = static_cast<int>(x.size());
  const int p = with_intercept ? 2 : 1;
  if (f.n <= p) return f;
  Eigen::MatrixXd X(f.n, p);
  Eigen::VectorXd Y(f.n);
  for (int i = 0; i < f.n; ++i) {
    if (with_intercept) X(i, 0) = 1.0;
    X(i, p - 1) = x[i];
    Y(i) = y[i];
  }
  const Eigen::MatrixXd XtX = X.transpose() * X;
  const Eigen::VectorXd beta = XtX.ldlt().solve(X.transpose() * Y);
  const Eigen::VectorXd res = Y - X * beta;
  const double s2 = res.squaredNorm() / (f.n - p);
  const Eigen::MatrixXd cov = s2 * XtX.inverse();
  if (with_intercept) {
    f.a = beta(0);
    f.se_a = std::sqrt(cov(0, 0));
  }
  f.b = beta(p - 1);
  f.se_b = std::sqrt(cov(p - 1, p - 1));
  const double mean = Y.mean();
  const double tss = with_intercept ? (Y.array() - mean).square().sum() : Y.squaredNorm();
  f.r2 = tss > 0 ? 1 - res.squaredNorm() / tss : 0;
  return f;
}

Result<OperatingPoint> ReadOperatingPoint(const std::string& path) {
  // The tags are in the leading lines, but a line of a device never ends.
  std::string why = WhyNotReadable(path, std::numeric_limits<std::uintmax_t>::max());
  std::ifstream in;
  if (why.empty()) {
    in.open(path);
    if (!in) why = "cannot open the file";
  }
  if (!why.empty()) {
    Error e = InputError(why);
    e.file = path;
    return e;
  }
  OperatingPoint point;
  point.name = std::filesystem::path(path).stem().string();
  int line_no = 0;
  for (std::string line; std::getline(in, line);) {
    ++line_no;
    if (line.empty() || line[0] != '#') break;  // tags live in the leading comments
    if (line.rfind(kTagPrefix, 0) != 0) continue;
    const Json j = Json::parse(line.substr(std::string(kTagPrefix).size()), nullptr, false);
    if (j.is_discarded() || !j.is_object()) {
      Error e = InputError("the greybench tag is not a JSON object");
      e.file = path;
      e.line = line_no;
      return e;
    }
    if (!j.contains("operating_point") || !j["operating_point"].is_object()) continue;
    for (const auto& [key, value] : j["operating_point"].items()) {
      if (key == "name" && value.is_string())
        point.name = value.get<std::string>();
      else if (value.is_number())
        point.values[key] = value.get<double>();
    }
  }
  return point;
}

Result<SweepResult> Sweep(const model::ModelSpec& spec,
                          const std::vector<data::DatasetSpec>& datasets,
                          const SweepOptions& options) {
  SweepResult result;
  result.rows.resize(datasets.size());
  std::vector<std::optional<Error>> errors(datasets.size());
  std::vector<char> fitted(datasets.size(), 0);  // not vector<bool>: set from several threads
  const std::atomic<bool>* cancel = options.estimate.cancel;
  auto cancelled = [cancel] { return cancel && cancel->load(); };
  const int parallel = options.parallel > 0 ? options.parallel : HardwareThreads();
  auto fit_one = [&](int i) {
    auto point = ReadOperatingPoint(datasets[i].file);
    if (!point) {
      errors[i] = point.error();
      return;
    }
    auto problem = LoadProblem(spec, {datasets[i]});
    if (!problem) {
      errors[i] = problem.error();
      return;
    }
    auto lik = MakeLikelihood(*problem);
    if (!lik) {
      errors[i] = lik.error();
      return;
    }
    estimate::EstimateOptions o = options.estimate;
    if (parallel > 1) o.threads = 1;
    auto summary = estimate::Estimate(*lik, o);
    if (!summary) {
      errors[i] = summary.error();
      return;
    }
    if (summary->cancelled) return;
    const auto& t = problem->series[0]->time;
    const double interval = (t.back() - t.front()) / static_cast<double>(t.size() - 1);
    result.rows[i] = {datasets[i].file, std::move(*point), interval, std::move(*summary)};
    fitted[i] = 1;
  };
  ParallelFor(static_cast<int>(datasets.size()), parallel, [&](int i) {
    if (cancelled()) return;  // the remaining datasets are not started
    if (options.progress) options.progress({i, false});
    fit_one(i);
    if (options.progress) options.progress({i, true});
  });
  // A cancelled sweep reports what it finished; errors of fits stopped half-way do not count.
  if (cancelled()) {
    SweepResult partial;
    partial.cancelled = true;
    for (std::size_t i = 0; i < datasets.size(); ++i)
      if (fitted[i]) partial.rows.push_back(std::move(result.rows[i]));
    return partial;
  }
  for (const auto& e : errors)
    if (e) return *e;

  for (const auto& name : options.mean_of) {
    std::vector<double> v;
    for (const auto& r : result.rows)
      if (const auto* p = FindParameter(r.summary, name)) v.push_back(p->estimate);
    if (v.empty()) continue;
    double mean = 0;
    for (double x : v) mean += x;
    mean /= static_cast<double>(v.size());
    double ss = 0;
    for (double x : v) ss += (x - mean) * (x - mean);
    result.means[name] = {mean,
                          v.size() > 1 ? std::sqrt(ss / static_cast<double>(v.size() - 1)) : 0.0};
  }
  // Δt = c / n, the delay in seconds (estimated samples times the data's sample interval, or
  // the delay parameter's estimate).
  {
    std::vector<double> inv_n, delay_s;
    for (const auto& r : result.rows) {
      auto it = r.point.values.find(options.speed_tag);
      if (it == r.point.values.end()) continue;
      if (!options.delay_parameter.empty()) {
        const auto* p = FindParameter(r.summary, options.delay_parameter);
        if (!p) continue;
        inv_n.push_back(1.0 / it->second);
        delay_s.push_back(p->estimate);
        continue;
      }
      if (r.summary.delays.empty() || !r.summary.delays[0].scanned) continue;
      inv_n.push_back(1.0 / it->second);
      delay_s.push_back(r.summary.delays[0].estimate * r.sample_interval);
    }
    if (inv_n.size() >= 2) {
      LinearFit f = FitLine(inv_n, delay_s, false);
      f.y = "delay_s";
      f.x = "1/" + options.speed_tag;
      result.delay_vs_speed = f;
    }
  }
  {
    std::vector<double> x, y;
    for (const auto& r : result.rows) {
      auto it = r.point.values.find(options.trend_tag);
      const auto* p = FindParameter(r.summary, options.trend_parameter);
      if (it == r.point.values.end() || !p) continue;
      x.push_back(it->second);
      y.push_back(p->estimate);
    }
    if (x.size() >= 3) {
      LinearFit f = FitLine(x, y, true);
      f.y = options.trend_parameter;
      f.x = options.trend_tag;
      result.trend = f;
    }
  }
  return result;
}

std::string SweepResult::Markdown() const {
  if (rows.empty()) return "(no datasets)\n";
  std::vector<std::string> tags;
  for (const auto& [k, v] : rows[0].point.values) tags.push_back(k);
  std::string out = "| point |";
  std::string rule = "|---|";
  for (const auto& t : tags) out += " " + t + " |", rule += "---|";
  out += " delay (samples) |";
  rule += "---|";
  std::vector<std::string> params;
  for (const auto& p : rows[0].summary.parameters)
    if (!p.fixed) params.push_back(p.name);
  for (const auto& p : params) out += " " + p + " |", rule += "---|";
  out += " log L |\n" + rule + "---|\n";
  for (const auto& r : rows) {
    std::string line = "| " + r.point.name + " |";
    for (const auto& t : tags) {
      auto it = r.point.values.find(t);
      line += it == r.point.values.end() ? " |" : fmt::format(" {:g} |", it->second);
    }
    line += r.summary.delays.empty() ? " |" : fmt::format(" {} |", r.summary.delays[0].estimate);
    for (const auto& name : params) {
      const auto* p = FindParameter(r.summary, name);
      if (!p) {
        line += " |";
        continue;
      }
      line += p->std_error
                  ? fmt::format(" {:.4g} ({:.2g}) |", p->estimate, *p->std_error)
                  : fmt::format(" {:.4g}{} |", p->estimate, p->at_bound ? " (at bound)" : "");
    }
    line += fmt::format(" {:.2f} |\n", r.summary.loglik);
    out += line;
  }
  out += "\nEstimates with standard errors in brackets.\n";
  for (const auto& [name, ms] : means)
    out +=
        fmt::format("\nMean of {} over the points: {:.4g} (SD {:.2g}).", name, ms.first, ms.second);
  if (delay_vs_speed)
    out += fmt::format(
        "\nDelay against speed: delay = c / n with c = {:.4g} ± {:.2g} (R² {:.3f}, {} points).",
        delay_vs_speed->b, delay_vs_speed->se_b, delay_vs_speed->r2, delay_vs_speed->n);
  if (trend)
    out += fmt::format(
        "\nTrend: {} = {:.4g} (± {:.2g}) + {:.4g} (± {:.2g}) · {} (R² {:.3f}, {} points).",
        trend->y, trend->a, trend->se_a, trend->b, trend->se_b, trend->x, trend->r2, trend->n);
  return out + "\n";
}

std::string SweepResult::Csv() const {
  if (rows.empty()) return "";
  std::vector<std::string> tags;
  for (const auto& [k, v] : rows[0].point.values) tags.push_back(k);
  std::vector<std::string> params;
  for (const auto& p : rows[0].summary.parameters) params.push_back(p.name);
  std::string out = "point,dataset";
  for (const auto& t : tags) out += "," + t;
  out += ",delay_samples,loglik,converged";
  for (const auto& p : params) out += "," + p + "," + p + "_se";
  out += "\n";
  for (const auto& r : rows) {
    out += r.point.name + "," + r.dataset;
    for (const auto& t : tags) {
      auto it = r.point.values.find(t);
      out += it == r.point.values.end() ? "," : fmt::format(",{}", it->second);
    }
    out += fmt::format(",{},{},{}", r.summary.delays.empty() ? 0 : r.summary.delays[0].estimate,
                       r.summary.loglik, r.summary.converged ? "true" : "false");
    for (const auto& name : params) {
      const auto* p = FindParameter(r.summary, name);
      out += fmt::format(",{},{}", p ? fmt::format("{}", p->estimate) : "NA",
                         p && p->std_error ? fmt::format("{}", *p->std_error) : "NA");
    }
    out += "\n";
  }
  return out;
}

}  // namespace gb::project
