// Measured data: CSV files (user guide §3) read once into an immutable Dataset, and the
// binding of a Dataset's columns to a model's inputs and outputs.
//
// File format
//   - Lines starting with '#' (after optional spaces) are comments; blank lines are skipped.
//   - The first other line is the header. The separator is ',', ';' or TAB, detected from the
//     header (the candidate occurring most often outside double quotes; ',' when none occurs).
//   - Fields may be wrapped in double quotes ("t","Ps"); "" inside quotes is a literal quote.
//     A quoted field ends on its own line (a quote still open at the end of a line is an error).
//   - A UTF-8 byte-order mark at the start, CRLF or CR line ends, and spaces around fields are
//     accepted. The decimal point is '.'.
//   - The time column is the first column whose trimmed name is `t` or `time` (case-insensitive).
//     Every row must have a finite time, strictly greater than the previous row's.
//   - Every data row must have as many fields as the header.
//   - A cell that is empty, `NA` or `NaN` (case-insensitive) is missing (stored as quiet NaN).
//     A number is a decimal such as `-1.5`, `+2`, `.5`, `1e-3`; hexadecimal, `inf` and a decimal
//     comma are not numbers. Values too small for a double read as 0.
//     Any other cell that does not parse completely as a finite number is "not a number": this is
//     recorded (first such cell per column), not an error at read time, because extra columns
//     (a date, a comment) are allowed and ignored; it is an error when the column is bound.
//   - Duplicated column names are recorded; binding a duplicated name is an error.
// Errors name the file, the 1-based line and 1-based column (field number) and what is wrong,
// e.g. `run1.csv:14:1: time 0.25 does not increase (previous row, line 13, has 0.25)`.
//
// Other forms (a project's dataset keys, core/data/import.h) are read with a CsvFormat: no header
// (the first line is data; the columns named by `columns`, else c1, c2, ...), a given separator,
// a decimal comma, a named time column, a time column with a unit in its name (`time [ms]`,
// `t_ms`, `Zeit [s]`: converted to seconds), or no time column at all (row k at k * sample_time).
#pragma once

#include <array>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "core/util/result.h"

namespace gb::data {

struct Column {
  std::string name;            // trimmed, quotes removed
  int field = 0;               // 1-based field number in the file
  std::vector<double> values;  // one per row; NaN where missing or not a number
  // The first cell that is neither a number nor a missing marker (0 = none).
  int bad_line = 0;
  std::string bad_text;
  // The first missing cell (0 = none), for messages about a missing input.
  int first_missing_line = 0;
  int n_missing = 0;
};

// Immutable once read.
struct Dataset {
  std::string source;     // the path as the user gave it (used in messages)
  int header_line = 0;    // 1-based line of the header; 0 for a file without one
  std::string time_name;  // as written in the header; "t" when the rows are timed by
                          // a sample time (time_field 0: no column)
  int time_field = 0;
  double time_scale = 1;        // seconds per unit of the time column (`time [ms]`: 0.001)
  char decimal = '.';           // the decimal mark the cells were read with
  std::vector<double> time;     // strictly increasing, in seconds when the column had a unit
  std::vector<int> row_line;    // 1-based file line of each row
  std::vector<Column> columns;  // every column except the time column, in file order

  std::size_t rows() const { return time.size(); }
  // Index into `columns` of the column named `name`, or -1. If the name occurs twice: -2.
  int Find(std::string_view name) const;
};

// How a CSV file is laid out, where it is not the default form above. The default CsvFormat
// reads exactly as described there.
struct CsvFormat {
  bool header = true;  // false: the first line that is not a comment is data
  char separator = 0;  // ',', ';' or '\t'; 0: detected from the first line
  char decimal = '.';  // '.' or ',' (then the separator cannot be ',')
  // The fields' names in file order: required to match the fields' count. Without a header they
  // name the columns (default c1, c2, ...); with one they replace the header's names.
  std::vector<std::string> columns;
  // The time column's name; "": the first named t or time, else the first such name with a unit
  // (time_unit.h's names: `time [ms]`, `t_s`, `Zeit (min)`).
  std::string time;
  double sample_time = 0;  // > 0: there is no time column; row k is at k * sample_time
  // Only the rows with range[0] <= t <= range[1] (seconds) are kept (maybe none); every row is
  // still checked.
  std::optional<std::array<double, 2>> range;
};

// The format of `text` as far as it can be told from its first lines: the separator that splits
// every line into the same number of fields (';', then TAB, then ','), a decimal comma when no
// field is a number with a point and some is one with a comma (and the separator is not ','),
// and no header when every field of the first line is a number. Used where a format is not
// given (a dataset object without those keys, the import dialog's first guess).
CsvFormat SniffCsv(std::string_view text);

// Reads a CSV file in one go; `path` names it in messages and becomes `Dataset::source`.
// A file that cannot be read is an Error with `file` set and no line.
Result<std::shared_ptr<const Dataset>> ReadCsvFile(const std::string& path,
                                                   const CsvFormat& format = {});
// The same, with the format told from the file's text (a dataset entry's keys and SniffCsv).
Result<std::shared_ptr<const Dataset>> ReadCsvFile(
    const std::string& path, const std::function<CsvFormat(std::string_view text)>& format_of);
// Parses CSV text already in memory; `source` is used in messages.
Result<std::shared_ptr<const Dataset>> ParseCsv(std::string_view text, std::string source,
                                                const CsvFormat& format = {});
// The first `max_bytes` of a file (all of it when shorter; *truncated says which), with
// ReadCsvFile's checks and messages (not a regular file, too large, unreadable): a preview.
Result<std::string> ReadFileHead(const std::string& path, std::size_t max_bytes, bool* truncated);

// Seconds per unit of a time column named `name`: `t`, `time`, `zeit` (any case) alone, or with
// a unit in brackets or parentheses or after '_' (`time [ms]`, `Zeit (s)`, `t_us`); units s,
// sec, ms, us, µs, ns, min, h. nullopt for another name; an unknown unit on a time name
// (`time [deg]`) is nullopt too, with *unknown_unit set to it when given.
std::optional<double> TimeUnitScale(std::string_view name, std::string* unknown_unit = nullptr);

// Why a cell that is neither a number nor a missing marker (Column::bad_text) was refused, in
// words: "'abc' is not a number", "'inf' is not finite",
// "'1,5' is not a number (the decimal point must be '.')".
std::string NotANumberReason(std::string_view text, char decimal = '.');

// Sample intervals grouped so each distinct interval is discretised once.
// Intervals whose relative difference is below kIntervalRelTol belong to one group; the group's
// value is the interval of its first member. For N rows there are N-1 intervals.
// Precondition: `time` strictly increasing. Cost O(N) when consecutive intervals mostly repeat,
// O(N log G) for G groups otherwise.
struct Intervals {
  static constexpr double kIntervalRelTol = 1e-10;
  std::vector<double> distinct;  // the groups' intervals
  std::vector<int> group;        // group of interval k (between rows k and k+1), size N-1
};
Intervals GroupIntervals(std::span<const double> time);

// A dataset's columns bound to a model's inputs and outputs, laid out for the filter.
// Immutable once built.
struct Series {
  std::string source;
  std::vector<double> time;  // size N
  Eigen::MatrixXd U;         // n_inputs x N, every entry finite
  Eigen::MatrixXd Y;         // n_outputs x N, NaN = missing observation
  Intervals intervals;
  // For messages only (both may be empty, e.g. for a series built in memory):
  std::vector<std::string> outputs;  // the names of Y's rows
  std::vector<int> row_line;         // 1-based file line of each row
  std::size_t size() const { return time.size(); }
};

// `e` located at row j of `series`: an error without a file (or in the series' own file) gets
// the series' file and the row's line; an error in another file (a model's formula, evaluated at
// this row) keeps its file and JSON path and says in its message where in the data it happened:
// "... (at data.csv line 14, t = 0.1625)".
Error AtRow(Error e, const Series& series, int j);

// Binds columns by name. Errors (file:line:col): an input or output column that is absent
// ("column 'mfi' (an input of the model) is not in the file; its columns are t, u, y") or
// duplicated, a bound column holding a cell that is not a number, a missing input cell
// ("input 'mfi' is missing at line 14"). Fewer than 2 rows is an error.
// The column of an Error is the offending column's field number (0 for an absent column, whose
// Error points at the header line).
Result<std::shared_ptr<const Series>> Bind(const Dataset& data, std::span<const std::string> inputs,
                                           std::span<const std::string> outputs);

}  // namespace gb::data
