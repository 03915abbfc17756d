#include "ui/jobs/sweep.h"

#include <algorithm>
#include <cmath>
#include <exception>
#include <numeric>
#include <utility>

#include "core/util/sanitizers.h"
#include "ui/format.h"

namespace gb::ui {
namespace {

constexpr int kCurvePoints = 96;        // samples of the c / n curve over the speeds' range
constexpr const char* kTimeUnit = "s";  // core's sweep gives delays in seconds

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

}  // namespace

estimate::SweepOptions MakeSweepOptions(const SweepInput& input) {
  estimate::SweepOptions options;
  options.estimate.threads = 1;
  // Under the sanitizers (CI's instrumented build, some 40x slower) the delay profile of each
  // point is evaluated at its estimate instead of re-optimised at every delay: the estimates,
  // the delays and the table are the same, in a fraction of the fits (as tests/core/sweep_test).
  options.estimate.full_delay_profile = !kSanitized;
  // ... and a point whose estimate ends on a bound (f7's measurement variance) gets no extra
  // starts: their code path has its own test (tests/core/profile_test.cpp).
  if (kSanitized) options.estimate.starts_on_bound = 0;
  options.parallel = input.parallel;
  options.mean_of = input.points.mean_of;
  options.speed_tag = input.points.speed_tag;
  options.trend_parameter = input.points.trend_parameter;
  options.trend_tag = input.points.trend_tag;
  options.delay_parameter = input.points.delay_parameter;
  return options;
}

void SweepStatus::Record(const estimate::SweepProgress& p) {
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
    estimate::SweepOptions options = MakeSweepOptions(input);
    options.estimate.cancel = &control.cancel;
    const float n = static_cast<float>(std::max<std::size_t>(1, input.points.datasets.size()));
    options.progress = [&status, &control, n](const estimate::SweepProgress& p) {
      status.Record(p);
      control.progress = static_cast<float>(status.done()) / n;
    };
    Result<estimate::SweepResult> result =
        estimate::Sweep(input.spec, input.points.datasets, options);
    if (!result) {
      run.error = result.error().ToString();
      return run;
    }
    run.result = std::move(result).value();
  } catch (const std::exception& e) {  // e.g. out of memory; never into the UI loop
    run.result.reset();
    run.error = std::string("the sweep stopped: ") + e.what();
  }
  control.progress = 1.0f;
  return run;
}

SweepFigures MakeSweepFigures(estimate::SweepResult result, project::OperatingPointsSpec points,
                              int model_revision) {
  SweepFigures f;
  f.model_revision = model_revision;
  const std::vector<estimate::SweepRow>& rows = result.rows;
  for (const estimate::SweepRow& r : rows) f.columns.push_back(r.point.name);
  // Rows are referred to by index: adding one may move the others.
  auto add_row = [&](std::string label) {
    f.table.push_back({std::move(label), std::vector<std::string>(rows.size(), kDash), ""});
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

  // Fig. 3.
  for (const estimate::SweepRow& r : rows) {
    auto it = r.point.values.find(points.speed_tag);
    if (it == r.point.values.end() || r.summary.delays.empty() || !r.summary.delays[0].scanned)
      continue;
    f.speed.push_back(it->second);
    f.delay.push_back(r.summary.delays[0].estimate * r.sample_interval);
    f.delay_half_sample.push_back(0.5 * r.sample_interval);
  }
  SortByX(&f.speed, {&f.delay, &f.delay_half_sample});
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

TrendPlot MakeTrendPlot(const estimate::SweepResult& result, const std::string& parameter,
                        const std::string& tag) {
  TrendPlot t;
  t.parameter = parameter;
  t.tag = tag;
  for (const estimate::SweepRow& r : result.rows) {
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
    estimate::LinearFit fit = estimate::FitLine(t.x, t.y, true);
    fit.y = parameter;
    fit.x = tag;
    t.line_x = {t.x.front(), t.x.back()};
    t.line_y = {fit.a + fit.b * t.x.front(), fit.a + fit.b * t.x.back()};
    t.fit = fit;
  }
  return t;
}

}  // namespace gb::ui
