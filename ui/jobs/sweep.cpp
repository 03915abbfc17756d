#include "ui/jobs/sweep.h"

#include <algorithm>
#include <cmath>
#include <exception>
#include <numeric>
#include <utility>

#include "ui/format.h"

namespace gb::ui {
namespace {

constexpr int kCurvePoints = 96;        // samples of the c / n curve over the speeds' range
constexpr const char* kTimeUnit = "s";  // core's sweep gives delays in seconds
constexpr double kDodge = 0.012;        // Dodged: the fraction of the x range

const estimate::ParameterEstimate* FindParameter(const estimate::EstimateSummary& s,
                                                 const std::string& name) {
  for (const estimate::ParameterEstimate& p : s.parameters)
    if (p.name == name) return &p;
  return nullptr;
}

std::string WithUnit(const std::string& label, const std::string& unit) {
  return unit.empty() ? label : label + " [" + unit + "]";
}

// Sorts the parallel arrays by `x` (the plot widget wants x ascending).
void SortByX(std::vector<double>* x, std::vector<std::vector<double>*> others) {
  std::vector<std::size_t> order(x->size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) { return (*x)[a] < (*x)[b]; });
  auto permute = [&](std::vector<double>* v) {
    std::vector<double> sorted;
    sorted.reserve(v->size());
    for (std::size_t i : order) sorted.push_back((*v)[i]);
    *v = std::move(sorted);
  };
  permute(x);
  for (std::vector<double>* v : others) permute(v);
}

std::string EstimateCell(const estimate::ParameterEstimate& p) {
  std::string cell = FormatSig(p.estimate, 4);
  if (p.std_error) return cell + " (" + FormatSig(*p.std_error, 2) + ")";
  if (p.at_bound) return cell + " (at bound)";
  return cell + " (" + kDash + ")";
}

// The linearised nonlinear fit at the points `run` fitted (in its rows' order).
void Linearise(const SweepInput& input, SweepRun* run) {
  const project::LinearisedSpec& spec = *input.points.linearised;
  std::vector<std::string> datasets;
  for (const project::SweepRow& r : run->result->rows) datasets.push_back(r.dataset);
  Result<project::LinearisedSweep> lin = InputError("no model to linearise");
  if (!spec.model.empty()) {
    lin = project::LineariseAtPoints(spec, "", datasets);
  } else if (input.project_model) {
    lin = project::LineariseAtPoints(spec, *input.project_model, datasets);
  } else {
    lin = InputError("the project's model is not valid (see the Equations view)");
  }
  if (lin) {
    run->linearised = std::move(lin).value();
  } else {
    run->linearised_error = lin.error().ToString();
  }
}

// The linearised `quantity` at every point (rows' order) that has `tag`, sorted by the tag: the
// tag, the value and its SE (0 where it has none).
void LinearisedAgainst(const project::LinearisedSweep& lin,
                       const std::vector<project::SweepRow>& rows, const std::string& tag,
                       const std::string& quantity, std::vector<double>* x,
                       std::vector<double>* value, std::vector<double>* se) {
  for (std::size_t i = 0; i < rows.size(); ++i) {
    auto it = rows[i].point.values.find(tag);
    const auto [v, s] = lin.At(i, quantity);
    if (it == rows[i].point.values.end() || !std::isfinite(v)) continue;
    x->push_back(it->second);
    value->push_back(v);
    se->push_back(std::isfinite(s) ? s : 0.0);
  }
  SortByX(x, {value, se});
}

// (b − a) / √(SE_a² + SE_b²), NaN when a standard error is missing or both are zero.
double CombinedZ(double a, double se_a, double b, double se_b) {
  const double s = std::sqrt(se_a * se_a + se_b * se_b);
  return std::isfinite(s) && s > 0 ? (b - a) / s : std::nan("");
}

}  // namespace

project::SweepOptions MakeSweepOptions(const SweepInput& input) {
  project::SweepOptions options;
  options.estimate.threads = 1;
  if (input.quick) {  // SweepState::quick
    options.estimate.full_delay_profile = false;
    options.estimate.starts_on_bound = 0;
  }
  options.parallel = input.parallel;
  options.mean_of = input.points.mean_of;
  options.speed_tag = input.points.speed_tag;
  options.trend_parameter = input.points.trend_parameter;
  options.trend_tag = input.points.trend_tag;
  options.delay_parameter = input.points.delay_parameter;
  return options;
}

void SweepStatus::Record(const project::SweepProgress& p) {
  const std::lock_guard<std::mutex> lock(mutex_);
  const auto i = static_cast<std::size_t>(p.dataset);
  if (i < states_.size()) states_[i] = p.finished ? PointState::kDone : PointState::kFitting;
}

int SweepStatus::done() const {
  const std::lock_guard<std::mutex> lock(mutex_);
  return static_cast<int>(std::count(states_.begin(), states_.end(), PointState::kDone));
}

std::vector<SweepStatus::PointState> SweepStatus::states() const {
  const std::lock_guard<std::mutex> lock(mutex_);
  return states_;
}

SweepRun RunSweep(const SweepInput& input, SweepStatus& status, JobControl& control) {
  SweepRun run;
  try {
    project::SweepOptions options = MakeSweepOptions(input);
    options.estimate.cancel = &control.cancel;
    const float n = static_cast<float>(std::max<std::size_t>(1, input.points.datasets.size()));
    options.progress = [&status, &control, n](const project::SweepProgress& p) {
      status.Record(p);
      control.progress = static_cast<float>(status.done()) / n;
    };
    Result<project::SweepResult> result =
        project::Sweep(input.spec, input.points.datasets, options);
    if (!result) {
      run.error = result.error().ToString();
      return run;
    }
    run.result = std::move(result).value();
    if (input.points.linearised && !run.result->cancelled) Linearise(input, &run);
  } catch (const std::exception& e) {  // e.g. out of memory; never into the UI loop
    run.result.reset();
    run.linearised.reset();
    run.error = std::string("the sweep stopped: ") + e.what();
  }
  control.progress = 1.0f;
  return run;
}

SweepFigures MakeSweepFigures(project::SweepResult result, project::OperatingPointsSpec points,
                              int model_revision,
                              std::optional<project::LinearisedSweep> linearised,
                              std::string linearised_error) {
  SweepFigures f;
  f.model_revision = model_revision;
  f.linearised = std::move(linearised);
  f.linearised_error = std::move(linearised_error);
  const project::LinearisedSweep* lin = f.linearised ? &*f.linearised : nullptr;
  auto has_quantity = [&](const std::string& name) {
    return lin &&
           std::find(lin->quantities.begin(), lin->quantities.end(), name) != lin->quantities.end();
  };
  const std::vector<project::SweepRow>& rows = result.rows;
  for (const project::SweepRow& r : rows) f.columns.push_back(r.point.name);
  // Rows are referred to by index: adding one may move the others.
  auto add_row = [&](std::string label) {
    SweepTableRow row;
    row.label = std::move(label);
    row.cells.assign(rows.size(), kDash);
    f.table.push_back(std::move(row));
    return f.table.size() - 1;
  };

  // The tags every point has, the speed first (the paper's order: n, then α).
  if (!rows.empty()) {
    for (const auto& tag_value : rows[0].point.values) {
      const std::string& tag = tag_value.first;
      const bool everywhere = std::all_of(
          rows.begin(), rows.end(), [&](const auto& r) { return r.point.values.count(tag) > 0; });
      if (everywhere) f.tags.push_back(tag);
    }
    std::stable_partition(f.tags.begin(), f.tags.end(),
                          [&](const std::string& t) { return t == points.speed_tag; });
  }
  for (const std::string& tag : f.tags) {
    const project::TagLabel label = points.Label(tag);
    const std::size_t row = add_row(WithUnit(label.label, label.unit));
    for (std::size_t i = 0; i < rows.size(); ++i)
      f.table[row].cells[i] = FormatSig(rows[i].point.values.at(tag), 4);
  }

  // The delays: whole samples, and in time (samples × the data's sample interval).
  if (!rows.empty()) {
    const std::size_t n_outputs = rows[0].summary.delays.size();
    for (std::size_t o = 0; o < n_outputs; ++o) {
      if (!rows[0].summary.delays[o].scanned) continue;
      const std::string of = n_outputs > 1 ? " of " + rows[0].summary.delays[o].output : "";
      const std::size_t samples = add_row("delay" + of + " [samples]");
      const std::size_t time = add_row(WithUnit("\xCE\x94t" + of, kTimeUnit));  // Δt
      for (std::size_t i = 0; i < rows.size(); ++i) {
        if (o >= rows[i].summary.delays.size()) continue;
        const int d = rows[i].summary.delays[o].estimate;
        f.table[samples].cells[i] = std::to_string(d);
        f.table[time].cells[i] = FormatSig(d * rows[i].sample_interval, 4);
      }
    }
  }

  // The free parameters: estimate (standard error), and the mean over the points.
  if (!rows.empty()) {
    for (const estimate::ParameterEstimate& p : rows[0].summary.parameters) {
      if (p.fixed) continue;
      f.parameters.push_back(p.name);
      const std::size_t row = add_row(WithUnit(p.name, p.unit));
      for (std::size_t i = 0; i < rows.size(); ++i) {
        if (const estimate::ParameterEstimate* q = FindParameter(rows[i].summary, p.name))
          f.table[row].cells[i] = EstimateCell(*q);
      }
      auto mean = result.means.find(p.name);
      if (mean != result.means.end())
        f.table[row].mean =
            FormatSig(mean->second.first, 4) + " (" + FormatSig(mean->second.second, 2) + ")";
      if (!has_quantity(p.name)) continue;
      // Beneath it, the nonlinear fit linearised at the same points.
      const std::size_t lrow = add_row("  linearised");
      SweepTableRow& l = f.table[lrow];
      l.linearised = true;
      l.z.assign(rows.size(), std::nan(""));
      for (std::size_t i = 0; i < rows.size(); ++i) {
        const auto [value, se] = lin->At(i, p.name);
        if (!std::isfinite(value)) continue;
        l.cells[i] =
            FormatSig(value, 4) + " (" + (std::isfinite(se) ? FormatSig(se, 2) : kDash) + ")";
        if (const estimate::ParameterEstimate* q = FindParameter(rows[i].summary, p.name);
            q && q->std_error)
          l.z[i] = CombinedZ(q->estimate, *q->std_error, value, se);
      }
    }
    // Quantities without a parameter of their name: rows of their own.
    if (lin) {
      for (const std::string& name : lin->quantities) {
        if (std::find(f.parameters.begin(), f.parameters.end(), name) != f.parameters.end())
          continue;
        const std::size_t lrow = add_row(name + ", linearised");
        f.table[lrow].linearised = true;
        f.table[lrow].z.assign(rows.size(), std::nan(""));
        for (std::size_t i = 0; i < rows.size(); ++i) {
          const auto [value, se] = lin->At(i, name);
          if (std::isfinite(value))
            f.table[lrow].cells[i] =
                FormatSig(value, 4) + " (" + (std::isfinite(se) ? FormatSig(se, 2) : kDash) + ")";
        }
      }
    }
    const std::size_t loglik = add_row("log L");
    for (std::size_t i = 0; i < rows.size(); ++i)
      f.table[loglik].cells[i] = FormatFixed(rows[i].summary.loglik, 1);
    const bool all_converged =
        std::all_of(rows.begin(), rows.end(), [](const auto& r) { return r.summary.converged; });
    if (!all_converged) {
      const std::size_t converged = add_row("converged");
      for (std::size_t i = 0; i < rows.size(); ++i)
        f.table[converged].cells[i] = rows[i].summary.converged ? "yes" : "NO";
    }
  }

  // Fig. 3: the delay in whole samples, or the delay parameter with its standard error.
  f.delay_bar_is_se = !points.delay_parameter.empty();
  for (const project::SweepRow& r : rows) {
    auto it = r.point.values.find(points.speed_tag);
    if (it == r.point.values.end()) continue;
    if (f.delay_bar_is_se) {
      const estimate::ParameterEstimate* p = FindParameter(r.summary, points.delay_parameter);
      if (!p) continue;
      f.speed.push_back(it->second);
      f.delay.push_back(p->estimate);
      f.delay_bar.push_back(p->std_error.value_or(0.0));
      continue;
    }
    if (r.summary.delays.empty() || !r.summary.delays[0].scanned) continue;
    f.speed.push_back(it->second);
    f.delay.push_back(r.summary.delays[0].estimate * r.sample_interval);
    f.delay_bar.push_back(0.5 * r.sample_interval);
  }
  SortByX(&f.speed, {&f.delay, &f.delay_bar});
  const std::string delay_quantity =
      points.delay_parameter.empty() ? std::string("delay") : points.delay_parameter;
  if (has_quantity(delay_quantity)) {
    LinearisedAgainst(*lin, rows, points.speed_tag, delay_quantity, &f.lin_speed, &f.lin_delay,
                      &f.lin_delay_se);
    f.lin_speed_drawn = Dodged(f.lin_speed, f.speed);
  }
  if (result.delay_vs_speed && !f.speed.empty() && f.speed.front() > 0) {
    const double lo = f.speed.front(), hi = f.speed.back();
    for (int k = 0; k < kCurvePoints; ++k) {
      const double n = lo + (hi - lo) * k / (kCurvePoints - 1);
      f.curve_speed.push_back(n);
      f.curve_delay.push_back(result.delay_vs_speed->b / n);
    }
  }
  f.result = std::move(result);
  f.points = std::move(points);
  return f;
}

std::vector<double> Dodged(const std::vector<double>& x, const std::vector<double>& others) {
  double lo = INFINITY, hi = -INFINITY;
  for (const std::vector<double>* v : {&x, &others}) {
    for (double e : *v) {
      lo = std::min(lo, e);
      hi = std::max(hi, e);
    }
  }
  const double shift = hi > lo ? kDodge * (hi - lo) : 0.0;
  std::vector<double> out(x);
  for (double& e : out) e += shift;
  return out;
}

TrendPlot MakeTrendPlot(const SweepFigures& figures, const std::string& parameter,
                        const std::string& tag) {
  const project::SweepResult& result = figures.result;
  TrendPlot t;
  t.parameter = parameter;
  t.tag = tag;
  for (const project::SweepRow& r : result.rows) {
    auto it = r.point.values.find(tag);
    const estimate::ParameterEstimate* p = FindParameter(r.summary, parameter);
    if (it == r.point.values.end() || !p) continue;
    t.x.push_back(it->second);
    t.y.push_back(p->estimate);
    t.se.push_back(p->std_error.value_or(0.0));
    if (!p->std_error) ++t.without_se;
  }
  SortByX(&t.x, {&t.y, &t.se});
  if (t.x.size() >= 3) {
    project::LinearFit fit = project::FitLine(t.x, t.y, true);
    fit.y = parameter;
    fit.x = tag;
    t.line_x = {t.x.front(), t.x.back()};
    t.line_y = {fit.a + fit.b * t.x.front(), fit.a + fit.b * t.x.back()};
    t.fit = fit;
  }
  if (figures.linearised) {
    LinearisedAgainst(*figures.linearised, result.rows, tag, parameter, &t.lin_x, &t.lin_y,
                      &t.lin_se);
    t.lin_x_drawn = Dodged(t.lin_x, t.x);
  }
  return t;
}

}  // namespace gb::ui
