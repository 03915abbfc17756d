// Writing data files in the format ReadCsvFile reads (user guide §3): comma-separated,
// a header line, numbers with 17 significant digits (exact round trip), `NA` for missing values.
#pragma once

#include <span>
#include <string>
#include <vector>

#include "core/util/result.h"

namespace gb::data {

struct CsvColumn {
  std::string name;
  std::span<const double> values;  // all columns have the same length; NaN is written as NA
};

// `comments` are written first, each as a line starting with "# ". Written atomically.
Status WriteCsvFile(const std::string& path, std::span<const CsvColumn> columns,
                    std::span<const std::string> comments = {});

// The same text, for callers that print it.
std::string FormatCsv(std::span<const CsvColumn> columns,
                      std::span<const std::string> comments = {});

}  // namespace gb::data
