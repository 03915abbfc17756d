#include "ui/state/data_summary.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace gb::ui {
namespace {

// Intervals within this relative distance of the median count as the same sample time (CSV
// times written with few digits jitter in the last one).
constexpr double kUniformRelTol = 1e-6;

}  // namespace

DatasetSummary Summarize(const data::Dataset& data) {
  DatasetSummary s;
  const std::vector<double>& t = data.time;
  s.rows = t.size();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  s.median_interval = s.min_interval = s.max_interval = nan;
  if (!t.empty()) {
    s.t_first = t.front();
    s.t_last = t.back();
  }
  if (t.size() >= 2) {
    std::vector<double> dt(t.size() - 1);
    for (std::size_t k = 0; k + 1 < t.size(); ++k) dt[k] = t[k + 1] - t[k];
    const auto [lo, hi] = std::minmax_element(dt.begin(), dt.end());
    s.min_interval = *lo;
    s.max_interval = *hi;
    const auto mid = dt.begin() + static_cast<std::ptrdiff_t>(dt.size() / 2);
    std::nth_element(dt.begin(), mid, dt.end());
    s.median_interval = *mid;
    const double tol = kUniformRelTol * std::abs(s.median_interval);
    s.uniform =
        s.max_interval - s.median_interval <= tol && s.median_interval - s.min_interval <= tol;
  }

  s.columns.reserve(data.columns.size());
  for (const data::Column& column : data.columns) {
    ColumnSummary c;
    c.n_missing = column.n_missing;
    c.has_bad_cell = column.bad_line != 0;
    double sum = 0.0;
    for (double v : column.values) {
      if (!std::isfinite(v)) continue;
      if (c.n_values == 0) {
        c.min = c.max = v;
      } else {
        c.min = std::min(c.min, v);
        c.max = std::max(c.max, v);
      }
      sum += v;
      ++c.n_values;
    }
    if (c.n_values > 0) c.mean = sum / c.n_values;
    s.columns.push_back(c);
  }
  return s;
}

}  // namespace gb::ui
