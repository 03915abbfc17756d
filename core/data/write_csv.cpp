#include "core/data/write_csv.h"

#include <cassert>
#include <cmath>

#include <fmt/format.h>

#include "core/util/file.h"

namespace gb::data {

std::string FormatCsv(std::span<const CsvColumn> columns, std::span<const std::string> comments) {
  std::string out;
  for (const auto& c : comments) out += "# " + c + "\n";
  for (std::size_t i = 0; i < columns.size(); ++i) out += (i ? "," : "") + columns[i].name;
  out += "\n";
  const std::size_t rows = columns.empty() ? 0 : columns[0].values.size();
  out.reserve(out.size() + rows * columns.size() * 12);
  for (std::size_t r = 0; r < rows; ++r) {
    for (std::size_t i = 0; i < columns.size(); ++i) {
      assert(columns[i].values.size() == rows && "CSV columns have equal lengths");
      if (i) out += ',';
      const double v = columns[i].values[r];
      if (std::isnan(v))
        out += "NA";
      else
        fmt::format_to(std::back_inserter(out), "{}", v);  // shortest exact representation
    }
    out += '\n';
  }
  return out;
}

Status WriteCsvFile(const std::string& path, std::span<const CsvColumn> columns,
                    std::span<const std::string> comments) {
  return WriteFileAtomic(path, FormatCsv(columns, comments));
}

}  // namespace gb::data
