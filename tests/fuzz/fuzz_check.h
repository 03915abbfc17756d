// A check inside a fuzz target: a property that must hold for every input. A failure prints the
// property and aborts, which libFuzzer reports as a crash and saves the input.
#pragma once

#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "core/data/dataset.h"

#define FUZZ_CHECK(condition)                                                                 \
  do {                                                                                        \
    if (!(condition)) {                                                                       \
      std::fprintf(stderr, "%s:%d: fuzz check failed: %s\n", __FILE__, __LINE__, #condition); \
      std::abort();                                                                           \
    }                                                                                         \
  } while (0)

// A Dataset keeps its documented invariants: finite, strictly increasing times; one value per row
// in every column; one file line per row.
inline void CheckDataset(const gb::data::Dataset& d) {
  FUZZ_CHECK(d.row_line.size() == d.rows());
  for (std::size_t r = 0; r < d.rows(); ++r) {
    FUZZ_CHECK(std::isfinite(d.time[r]));
    if (r > 0) FUZZ_CHECK(d.time[r] > d.time[r - 1]);
  }
  for (const gb::data::Column& c : d.columns) FUZZ_CHECK(c.values.size() == d.rows());
}
