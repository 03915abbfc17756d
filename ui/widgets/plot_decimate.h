// Reducing a long series to what a plot can show: the visible index window of an ascending x,
// and min/max per pixel column. Pure functions over the caller's arrays (nothing is copied);
// the output vectors are scratch buffers the caller reuses from frame to frame.
//
// Min/max decimation keeps every extreme: a spike one sample wide still reaches its full height
// after 1e6 samples are folded into 1500 columns, which plain subsampling would miss.
#pragma once

#include <vector>

namespace gb::ui::plot {

// Samples [begin, end) of an ascending x that a view [xmin, xmax] needs: those inside, plus one
// neighbour on each side so a line reaches the plot's edges.
struct IndexWindow {
  int begin = 0;
  int end = 0;
  int size() const { return end - begin; }
};
IndexWindow VisibleWindow(const double* x, int n, double xmin, double xmax);

// Minimum and maximum of the finite values among y[0, n): false when there are none.
bool FiniteMinMax(const double* y, int n, double* lo, double* hi);

// The finite y values of the samples that fall in one pixel column.
struct ColumnAggregate {
  bool any = false;         // at least one finite value
  bool gap_before = false;  // a missing value (NaN) since the previous finite value
  double first = 0.0, last = 0.0, min = 0.0, max = 0.0;
};

// Folds samples `window` of (x, y) into `columns` equal columns spanning [xmin, xmax] (the
// neighbours outside the view land in the first and last column). `out` is resized to
// `columns`. Preconditions: x ascending, columns > 0, xmax > xmin.
void DecimateMinMax(const double* x, const double* y, IndexWindow window, double xmin, double xmax,
                    int columns, std::vector<ColumnAggregate>* out);

}  // namespace gb::ui::plot
