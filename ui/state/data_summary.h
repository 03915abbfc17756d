// What the data view says about a dataset before any model is fitted: its size, its sample
// time, and per column how much is missing and the range of the values. Computed once when the
// dataset is loaded (in the loading job), never per frame.
#pragma once

#include <string>
#include <vector>

#include "core/data/dataset.h"

namespace gb::ui {

struct ColumnSummary {
  int n_missing = 0;          // empty, NA or NaN cells
  int n_values = 0;           // finite values
  bool has_bad_cell = false;  // a cell that is not a number (first one: bad_line, bad_text)
  double min = 0.0, max = 0.0, mean = 0.0;  // over the finite values (0 when there are none)
};

struct DatasetSummary {
  std::size_t rows = 0;
  double t_first = 0.0, t_last = 0.0;
  // Sample intervals t[k+1] - t[k], in the data's time unit (NaN with fewer than 2 rows).
  double median_interval = 0.0;
  double min_interval = 0.0, max_interval = 0.0;
  bool uniform = true;                 // all intervals equal to the median within a relative 1e-6
  std::vector<ColumnSummary> columns;  // parallel to Dataset::columns
};

DatasetSummary Summarize(const data::Dataset& data);

}  // namespace gb::ui
