#include "ui/widgets/plot_decimate.h"

#include <algorithm>
#include <cmath>
#include <random>

#include <gtest/gtest.h>

namespace gb::ui::plot {
namespace {

// Column of each sample, computed directly from its x (the definition, not the algorithm).
int ColumnOf(double x, double xmin, double xmax, int columns) {
  const int c = static_cast<int>(std::floor((x - xmin) / (xmax - xmin) * columns));
  return std::clamp(c, 0, columns - 1);
}

TEST(VisibleWindow, IsTheSamplesInViewPlusOneNeighbourEachSide) {
  const std::vector<double> x = {0, 1, 2, 3, 4, 5, 6, 7, 8, 9};
  const IndexWindow w = VisibleWindow(x.data(), 10, 2.5, 5.5);
  EXPECT_EQ(w.begin, 2);  // x = 2, the neighbour left of 3
  EXPECT_EQ(w.end, 7);    // up to x = 6, the neighbour right of 5
  const IndexWindow all = VisibleWindow(x.data(), 10, -100, 100);
  EXPECT_EQ(all.begin, 0);
  EXPECT_EQ(all.end, 10);
  EXPECT_EQ(VisibleWindow(x.data(), 0, 0, 1).size(), 0);
}

TEST(FiniteMinMax, SkipsMissingAndInfiniteValues) {
  const std::vector<double> y = {NAN, 3.0, -INFINITY, -2.0, NAN, 7.5, INFINITY};
  double lo = 0, hi = 0;
  ASSERT_TRUE(FiniteMinMax(y.data(), static_cast<int>(y.size()), &lo, &hi));
  EXPECT_EQ(lo, -2.0);
  EXPECT_EQ(hi, 7.5);
  const std::vector<double> none = {NAN, INFINITY};
  EXPECT_FALSE(FiniteMinMax(none.data(), 2, &lo, &hi));
}

// Against a brute-force pass that assigns every sample to its column by its x.
TEST(DecimateMinMax, MatchesBruteForceOnIrregularSamplesWithGaps) {
  std::mt19937 rng(42);
  std::uniform_real_distribution<double> u(0.0, 100.0);
  const int n = 20000;
  std::vector<double> x(n), y(n);
  for (double& v : x) v = u(rng);
  std::sort(x.begin(), x.end());
  for (int i = 0; i < n; ++i) y[i] = (i % 97 < 3) ? NAN : std::sin(x[i]) + 0.01 * u(rng);

  const double xmin = 20.0, xmax = 70.0;
  const int columns = 333;
  const IndexWindow w = VisibleWindow(x.data(), n, xmin, xmax);
  std::vector<ColumnAggregate> got;
  DecimateMinMax(x.data(), y.data(), w, xmin, xmax, columns, &got);
  ASSERT_EQ(static_cast<int>(got.size()), columns);

  std::vector<ColumnAggregate> want(columns);
  bool gap = false;
  for (int i = w.begin; i < w.end; ++i) {
    if (std::isnan(y[i])) {
      gap = true;
      continue;
    }
    ColumnAggregate& c = want[ColumnOf(x[i], xmin, xmax, columns)];
    if (!c.any) {
      c.any = true;
      c.gap_before = gap;
      c.first = c.min = c.max = y[i];
    }
    c.min = std::min(c.min, y[i]);
    c.max = std::max(c.max, y[i]);
    c.last = y[i];
    gap = false;
  }
  for (int c = 0; c < columns; ++c) {
    SCOPED_TRACE(c);
    EXPECT_EQ(got[c].any, want[c].any);
    if (!want[c].any) continue;
    EXPECT_EQ(got[c].first, want[c].first);
    EXPECT_EQ(got[c].last, want[c].last);
    EXPECT_EQ(got[c].min, want[c].min);
    EXPECT_EQ(got[c].max, want[c].max);
  }
}

TEST(DecimateMinMax, KeepsASingleSampleSpike) {
  const int n = 1000000;
  std::vector<double> x(n), y(n, 0.0);
  for (int i = 0; i < n; ++i) x[i] = i * 1e-3;
  y[523456] = 3.0;
  std::vector<ColumnAggregate> cols;
  DecimateMinMax(x.data(), y.data(), VisibleWindow(x.data(), n, 0.0, x.back()), 0.0, x.back(), 1000,
                 &cols);
  double top = 0.0;
  for (const ColumnAggregate& c : cols) top = std::max(top, c.max);
  EXPECT_EQ(top, 3.0);
}

TEST(DecimateMinMax, MarksAGapAfterMissingValuesAtAColumnBoundary) {
  // Ten samples per column; samples 18..21 are missing, straddling columns 1 and 2.
  std::vector<double> x(40), y(40, 1.0);
  for (int i = 0; i < 40; ++i) x[i] = i + 0.5;
  for (int i = 18; i < 22; ++i) y[i] = NAN;
  std::vector<ColumnAggregate> cols;
  DecimateMinMax(x.data(), y.data(), {0, 40}, 0.0, 40.0, 4, &cols);
  EXPECT_FALSE(cols[1].gap_before);
  EXPECT_TRUE(cols[2].gap_before);
  EXPECT_FALSE(cols[3].gap_before);
}

}  // namespace
}  // namespace gb::ui::plot
