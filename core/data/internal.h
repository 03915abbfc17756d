// Pieces of the CSV reader (csv.cpp) shared with the live sources of core/online, so that a file
// read whole and a file read as it grows follow one set of rules (dataset.h) and say the same
// things about them; not part of the public API.
#pragma once

#include <algorithm>
#include <deque>
#include <limits>
#include <string>
#include <string_view>
#include <vector>

#include "core/data/dataset.h"
#include "core/util/result.h"

namespace gb::data::internal {

inline constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
inline constexpr std::string_view kByteOrderMark = "\xEF\xBB\xBF";

// An input Error at `file`:`line`:`col` (1-based; 0 = unknown).
Error FileError(const std::string& file, int line, int col, std::string message);

// ASCII letters compared without case ("NaN" and "nan", ".MF4" and ".mf4").
inline bool EqualsIgnoringCase(std::string_view a, std::string_view b) {
  return std::equal(a.begin(), a.end(), b.begin(), b.end(), [](char x, char y) {
    return (x >= 'A' && x <= 'Z' ? x - 'A' + 'a' : x) == (y >= 'A' && y <= 'Z' ? y - 'A' + 'a' : y);
  });
}

enum class Cell { kNumber, kMissing, kNotANumber };

// `s` is a trimmed field. Only a complete finite decimal number is a number (in *value); an empty
// cell, `NA` or `NaN` is missing (*value = NaN); anything else is not a number. With decimal ','
// the number's decimal mark is a comma, and a point makes it not a number.
Cell ParseCell(std::string_view s, double* value, char decimal = '.');

// Blank lines and comment lines ('#' after optional spaces) carry no data.
bool IsSkipped(std::string_view line);

// The candidate occurring most often outside quotes; ',' when none occurs (ties: , ; TAB).
char DetectSeparator(std::string_view header);

// Splits one line into trimmed, unquoted fields. The views point into the line, or into the
// splitter's own buffers for quoted fields holding "" (valid until the next Split).
class FieldSplitter {
 public:
  explicit FieldSplitter(char separator) : sep_(separator) {}

  // On a malformed quote, returns false with the 1-based field in *bad_field and the problem.
  bool Split(std::string_view line, int* bad_field, std::string* problem);
  const std::vector<std::string_view>& fields() const { return fields_; }

 private:
  bool IsTrimmed(char c) const { return c == ' ' || (c == '\t' && sep_ != '\t'); }
  std::size_t SkipSpaces(std::string_view line, std::size_t pos) const {
    while (pos < line.size() && IsTrimmed(line[pos])) ++pos;
    return pos;
  }
  // *pos is at the opening quote; leaves it after the closing one.
  bool SplitQuoted(std::string_view line, std::size_t* pos, std::string_view* value);

  char sep_;
  std::vector<std::string_view> fields_;
  // One buffer per field, reused across lines; a deque so growing it keeps earlier views valid.
  std::deque<std::string> unescaped_;
};

// Reads the header `line` (line `line_no` of `d->source`, split by `splitter`) into d's
// header_line, time_name, time_field, time_scale and columns (names and fields; no values), as
// `format` says (its columns, time and sample_time; format.header must be true).
// An Error when a quote is malformed or there is no time column.
Status ReadHeader(FieldSplitter& splitter, std::string_view line, int line_no, Dataset* d,
                  const CsvFormat& format = {});

// What every reader checks of a data row: splits `line` (line `line_no`) into the splitter's
// fields, checks that there are as many as `header` has, and reads the time into *t, which must
// be finite and greater than `previous_time`, the time of line `previous_line` (0: no previous
// row); without a time column (header.time_field 0) *t is left alone. The time and
// `previous_time` are in seconds (the column's unit converted by header.time_scale), so a file
// read whole and one read as it grows convert it alike. The Error names `header.source`, the
// line and the field.
Status SplitRow(FieldSplitter& splitter, std::string_view line, int line_no, const Dataset& header,
                int previous_line, double previous_time, double* t);

}  // namespace gb::data::internal
