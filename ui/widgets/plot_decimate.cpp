#include "ui/widgets/plot_decimate.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <limits>

namespace gb::ui::plot {

IndexWindow VisibleWindow(const double* x, int n, double xmin, double xmax) {
  IndexWindow w;
  if (n <= 0) return w;
  const double* lo = std::lower_bound(x, x + n, xmin);
  const double* hi = std::upper_bound(x, x + n, xmax);
  w.begin = std::max(0, static_cast<int>(lo - x) - 1);
  w.end = std::min(n, static_cast<int>(hi - x) + 1);
  if (w.end < w.begin) w.end = w.begin;
  return w;
}

bool FiniteMinMax(const double* y, int n, double* lo, double* hi) {
  // NaN never compares true, so missing values drop out of this loop without a test; only
  // infinities need the careful pass below.
  double mn = std::numeric_limits<double>::infinity();
  double mx = -mn;
  for (int i = 0; i < n; ++i) {
    const double v = y[i];
    mn = v < mn ? v : mn;
    mx = v > mx ? v : mx;
  }
  if (std::isfinite(mn) && std::isfinite(mx)) {
    *lo = mn;
    *hi = mx;
    return true;
  }
  bool any = false;
  for (int i = 0; i < n; ++i) {
    const double v = y[i];
    if (!std::isfinite(v)) continue;
    *lo = any ? std::min(*lo, v) : v;
    *hi = any ? std::max(*hi, v) : v;
    any = true;
  }
  return any;
}

void DecimateMinMax(const double* x, const double* y, IndexWindow window, double xmin, double xmax,
                    int columns, std::vector<ColumnAggregate>* out) {
  assert(columns > 0 && xmax > xmin);
  out->assign(columns, ColumnAggregate{});
  const double width = (xmax - xmin) / columns;
  bool gap = false;  // a missing value since the last finite one
  int begin = window.begin;
  for (int c = 0; c < columns; ++c) {
    // Samples [begin, end) have x in column c; the neighbours outside the view fall into the
    // first and the last column.
    const int end =
        c + 1 == columns
            ? window.end
            : static_cast<int>(std::lower_bound(x + begin, x + window.end, xmin + (c + 1) * width) -
                               x);
    if (end <= begin) continue;
    int first = begin;
    while (first < end && !std::isfinite(y[first])) ++first;
    if (first == end) {
      gap = true;
      begin = end;
      continue;
    }
    int last = end - 1;
    while (!std::isfinite(y[last])) --last;
    ColumnAggregate& col = (*out)[c];
    col.any = true;
    col.gap_before = gap || first > begin;
    col.first = y[first];
    col.last = y[last];
    FiniteMinMax(y + first, last - first + 1, &col.min, &col.max);
    gap = last < end - 1;
    begin = end;
  }
}

}  // namespace gb::ui::plot
