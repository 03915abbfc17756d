#include "ui/state/data_summary.h"

#include <cmath>

#include <gtest/gtest.h>

namespace gb::ui {
namespace {

data::Dataset MakeDataset(std::vector<double> time, std::vector<double> values, int n_missing) {
  data::Dataset d;
  d.time = std::move(time);
  data::Column c;
  c.name = "y";
  c.values = std::move(values);
  c.n_missing = n_missing;
  d.columns.push_back(c);
  return d;
}

TEST(Summarize, MedianIntervalOfAnIrregularSeries) {
  // Intervals 1, 1, 3, 1, 2: sorted 1 1 1 2 3, median 1.
  const DatasetSummary s = Summarize(MakeDataset({0, 1, 2, 5, 6, 8}, {1, 2, NAN, 4, 5, 6}, 1));
  EXPECT_EQ(s.rows, 6u);
  EXPECT_DOUBLE_EQ(s.median_interval, 1.0);
  EXPECT_DOUBLE_EQ(s.min_interval, 1.0);
  EXPECT_DOUBLE_EQ(s.max_interval, 3.0);
  EXPECT_FALSE(s.uniform);
  EXPECT_DOUBLE_EQ(s.t_first, 0.0);
  EXPECT_DOUBLE_EQ(s.t_last, 8.0);
  ASSERT_EQ(s.columns.size(), 1u);
  EXPECT_EQ(s.columns[0].n_missing, 1);
  EXPECT_EQ(s.columns[0].n_values, 5);
  EXPECT_DOUBLE_EQ(s.columns[0].min, 1.0);
  EXPECT_DOUBLE_EQ(s.columns[0].max, 6.0);
  EXPECT_DOUBLE_EQ(s.columns[0].mean, 18.0 / 5.0);
}

TEST(Summarize, UniformSamplingWithRoundedTimes) {
  std::vector<double> t;
  for (int k = 0; k < 100; ++k) t.push_back(k * 0.02);  // 0.02 is not exact in binary
  const DatasetSummary s = Summarize(MakeDataset(t, std::vector<double>(100, 0.0), 0));
  EXPECT_TRUE(s.uniform);
  EXPECT_NEAR(s.median_interval, 0.02, 1e-15);
}

TEST(Summarize, ASingleRowHasNoSampleTime) {
  const DatasetSummary s = Summarize(MakeDataset({3.0}, {1.0}, 0));
  EXPECT_TRUE(std::isnan(s.median_interval));
}

}  // namespace
}  // namespace gb::ui
