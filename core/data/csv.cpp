// Reading CSV text into a Dataset (format in dataset.h).
//
// The pieces in namespace internal are shared with core/online (declared in internal.h).
//
// Contents
//   Cells                  ParseCell: number, missing marker or not a number
//   Lines and fields       LineReader (LF, CRLF, CR), DetectSeparator, FieldSplitter
//   Header                 ReadHeader: column names and the time column
//   Rows                   NotANumberReason, SplitRow, ParseCsv
//   Files                  ReadCsvFile, Dataset::Find
#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <system_error>

#include <fmt/format.h>

#include "core/data/dataset.h"
#include "core/data/internal.h"
#include "core/util/file.h"

namespace gb::data {

using internal::Cell;
using internal::DetectSeparator;
using internal::FieldSplitter;
using internal::FileError;
using internal::IsSkipped;
using internal::kByteOrderMark;
using internal::kNaN;
using internal::ParseCell;
using internal::ReadHeader;
using internal::SplitRow;

Error internal::FileError(const std::string& file, int line, int col, std::string message) {
  Error e = InputError(std::move(message));
  e.file = file;
  e.line = line;
  e.col = col;
  return e;
}

namespace {

using internal::EqualsIgnoringCase;

// ---------------------------------------------------------------------------------------------
// Cells

bool IsMissingMarker(std::string_view s) {
  return s.empty() || EqualsIgnoringCase(s, "na") || EqualsIgnoringCase(s, "nan");
}

// from_chars reports overflow and underflow alike; a negative exponent means the value is
// merely too small for a double, which reads as zero.
bool IsUnderflow(std::string_view s) {
  const std::size_t e = s.find_first_of("eE");
  return e != std::string_view::npos && e + 1 < s.size() && s[e + 1] == '-';
}

}  // namespace

Cell internal::ParseCell(std::string_view s, double* value, char decimal) {
  if (IsMissingMarker(s)) {
    *value = kNaN;
    return Cell::kMissing;
  }
  // A decimal comma: the cell with its comma read as a point (a point in it is no number).
  char buffer[64];
  if (decimal == ',' && s.find_first_of(",.") != std::string_view::npos) {
    if (s.find('.') != std::string_view::npos || s.size() > sizeof buffer) return Cell::kNotANumber;
    std::copy(s.begin(), s.end(), buffer);
    std::replace(buffer, buffer + s.size(), ',', '.');
    s = std::string_view(buffer, s.size());
  }
  std::string_view digits = s;
  // from_chars takes '-' but not '+'; "+-1" must stay invalid.
  if (!digits.empty() && digits.front() == '+') {
    digits.remove_prefix(1);
    if (digits.empty() || digits.front() == '-') return Cell::kNotANumber;
  }
  const char* end = digits.data() + digits.size();
  const auto [ptr, ec] = std::from_chars(digits.data(), end, *value, std::chars_format::general);
  if (ptr != end) return Cell::kNotANumber;
  if (ec == std::errc::result_out_of_range && IsUnderflow(digits)) {
    *value = digits.front() == '-' ? -0.0 : 0.0;
    return Cell::kNumber;
  }
  if (ec != std::errc() || !std::isfinite(*value)) return Cell::kNotANumber;
  return Cell::kNumber;
}

// ---------------------------------------------------------------------------------------------
// Lines and fields

namespace {

// Splits text into lines ending in LF, CRLF or CR, counting from 1.
class LineReader {
 public:
  explicit LineReader(std::string_view text) : text_(text) {}

  bool Next(std::string_view* line) {
    if (pos_ >= text_.size()) return false;
    std::size_t end = pos_;
    while (end < text_.size() && text_[end] != '\n' && text_[end] != '\r') ++end;
    *line = text_.substr(pos_, end - pos_);
    const bool crlf = end + 1 < text_.size() && text_[end] == '\r' && text_[end + 1] == '\n';
    pos_ = end + (crlf ? 2 : 1);
    ++number_;
    return true;
  }
  int number() const { return number_; }

 private:
  std::string_view text_;
  std::size_t pos_ = 0;
  int number_ = 0;
};

// LF, or CR when the text has no LF.
std::size_t CountLineEnds(std::string_view text) {
  const auto count = [text](char end) {
    std::size_t n = 0;
    for (const char *p = text.data(), *last = text.data() + text.size();
         (p = static_cast<const char*>(std::memchr(p, end, static_cast<std::size_t>(last - p))));
         ++p) {
      ++n;
    }
    return n;
  };
  const std::size_t lf = count('\n');
  return lf > 0 ? lf : count('\r');
}

}  // namespace

bool internal::IsSkipped(std::string_view line) {
  const std::size_t first = line.find_first_not_of(" \t");
  return first == std::string_view::npos || line[first] == '#';
}

char internal::DetectSeparator(std::string_view header) {
  int comma = 0, semicolon = 0, tab = 0;
  bool quoted = false;
  for (char c : header) {
    if (c == '"') quoted = !quoted;
    if (quoted) continue;
    comma += c == ',';
    semicolon += c == ';';
    tab += c == '\t';
  }
  if (semicolon > comma && semicolon >= tab) return ';';
  if (tab > comma && tab > semicolon) return '\t';
  return ',';
}

namespace internal {

bool FieldSplitter::Split(std::string_view line, int* bad_field, std::string* problem) {
  fields_.clear();
  std::size_t pos = 0;
  while (true) {
    pos = SkipSpaces(line, pos);
    const int field = static_cast<int>(fields_.size()) + 1;
    if (pos < line.size() && line[pos] == '"') {
      std::string_view value;
      if (!SplitQuoted(line, &pos, &value)) {
        *bad_field = field;
        *problem = fmt::format("field {} opens a quote that is not closed on this line", field);
        return false;
      }
      pos = SkipSpaces(line, pos);
      if (pos < line.size() && line[pos] != sep_) {
        *bad_field = field;
        *problem = fmt::format("field {} has text after its closing quote", field);
        return false;
      }
      fields_.push_back(value);
    } else {
      std::size_t end = line.find(sep_, pos);
      if (end == std::string_view::npos) end = line.size();
      std::size_t last = end;
      while (last > pos && IsTrimmed(line[last - 1])) --last;
      fields_.push_back(line.substr(pos, last - pos));
      pos = end;
    }
    if (pos >= line.size()) return true;
    ++pos;  // the separator
  }
}

bool FieldSplitter::SplitQuoted(std::string_view line, std::size_t* pos, std::string_view* value) {
  const std::size_t begin = *pos + 1;
  std::size_t close = line.find('"', begin);
  if (close == std::string_view::npos) return false;
  if (close + 1 >= line.size() || line[close + 1] != '"') {  // the common case: no ""
    *value = line.substr(begin, close - begin);
    *pos = close + 1;
    return true;
  }
  if (unescaped_.size() <= fields_.size()) unescaped_.resize(fields_.size() + 1);
  std::string& buffer = unescaped_[fields_.size()];
  buffer.clear();
  std::size_t from = begin;
  while (close + 1 < line.size() && line[close + 1] == '"') {
    buffer.append(line.substr(from, close + 1 - from));  // keeps one quote
    from = close + 2;
    close = line.find('"', from);
    if (close == std::string_view::npos) return false;
  }
  buffer.append(line.substr(from, close - from));
  *value = buffer;
  *pos = close + 1;
  return true;
}

}  // namespace internal

// ---------------------------------------------------------------------------------------------
// Header

namespace {

std::string JoinNames(const std::vector<std::string_view>& names) {
  std::string out;
  for (std::string_view n : names) {
    if (!out.empty()) out += ", ";
    out += n.empty() ? std::string_view("\"\"") : n;
  }
  return out;
}

// `name` split into a base and a unit: `time [ms]`, `time(ms)`, `t_ms`; false when it has none.
bool SplitUnit(std::string_view name, std::string_view* base, std::string_view* unit) {
  const auto trim = [](std::string_view v) {
    while (!v.empty() && v.front() == ' ') v.remove_prefix(1);
    while (!v.empty() && v.back() == ' ') v.remove_suffix(1);
    return v;
  };
  name = trim(name);
  if (!name.empty() && (name.back() == ']' || name.back() == ')')) {
    const char open = name.back() == ']' ? '[' : '(';
    const std::size_t at = name.rfind(open);
    if (at == std::string_view::npos || at == 0) return false;
    *base = trim(name.substr(0, at));
    *unit = trim(name.substr(at + 1, name.size() - at - 2));
    return !base->empty() && !unit->empty();
  }
  const std::size_t at = name.rfind('_');
  if (at == std::string_view::npos || at == 0 || at + 1 == name.size()) return false;
  *base = name.substr(0, at);
  *unit = name.substr(at + 1);
  return true;
}

std::optional<double> UnitScale(std::string_view u) {
  const auto is = [u](std::string_view name) { return EqualsIgnoringCase(u, name); };
  if (is("s") || is("sec")) return 1.0;
  if (is("ms")) return 1e-3;
  if (is("us") || u == "\xC2\xB5s" || u == "\xCE\xBCs") return 1e-6;  // us, micro sign, mu
  if (is("ns")) return 1e-9;
  if (is("min")) return 60.0;
  if (is("h")) return 3600.0;
  return std::nullopt;
}

bool IsTimeWord(std::string_view name) {
  return EqualsIgnoringCase(name, "t") || EqualsIgnoringCase(name, "time") ||
         EqualsIgnoringCase(name, "zeit");
}

// Names the columns of `d` (every field but the time column) from `names` (the header's, or
// those a headerless file is given), and finds the time column as `format` says.
Status NameColumns(const std::vector<std::string_view>& names, int line_no, const CsvFormat& format,
                   Dataset* d) {
  int time_index = -1;
  if (format.sample_time > 0) {
    // No time column: every field is a column; the time is called t.
    d->time_name = "t";
  } else if (!format.time.empty()) {
    for (std::size_t i = 0; i < names.size() && time_index < 0; ++i)
      if (names[i] == format.time) time_index = static_cast<int>(i);
    if (time_index < 0) {
      return FileError(d->source, line_no, 0,
                       fmt::format("no column named '{}' (the time column asked for); the columns "
                                   "are: {}",
                                   format.time, JoinNames(names)));
    }
  } else {
    // The contract's names first, so a file that read before reads the same.
    for (std::size_t i = 0; i < names.size() && time_index < 0; ++i)
      if (EqualsIgnoringCase(names[i], "t") || EqualsIgnoringCase(names[i], "time"))
        time_index = static_cast<int>(i);
    // A time name with a unit that is not one of time is taken, to be refused with its unit.
    for (std::size_t i = 0; i < names.size() && time_index < 0; ++i) {
      std::string unknown;
      if (TimeUnitScale(names[i], &unknown) || !unknown.empty()) time_index = static_cast<int>(i);
    }
    if (time_index < 0) {
      return FileError(
          d->source, line_no, 0,
          "no time column: the header needs a column named 't' or 'time' (a unit may follow, as "
          "in 'time [ms]' or 't_s'); it has: " +
              JoinNames(names));
    }
  }
  if (time_index >= 0) {
    const std::string_view name = names[static_cast<std::size_t>(time_index)];
    std::string unknown;
    std::string_view base, unit;
    if (const std::optional<double> scale = TimeUnitScale(name, &unknown)) {
      d->time_scale = *scale;
    } else if (!unknown.empty()) {
      return FileError(d->source, line_no, time_index + 1,
                       fmt::format("the time column '{}' has the unit '{}', which is not a unit "
                                   "of time (s, ms, us, ns, min, h)",
                                   name, unknown));
    } else if (SplitUnit(name, &base, &unit) && UnitScale(unit)) {
      d->time_scale = *UnitScale(unit);  // a column named by `time`, such as `stamp_ms`
    }
    d->time_name = std::string(name);
    d->time_field = time_index + 1;
  }
  for (std::size_t i = 0; i < names.size(); ++i) {
    if (static_cast<int>(i) == time_index) continue;
    Column& c = d->columns.emplace_back();
    c.name = std::string(names[i]);
    c.field = static_cast<int>(i) + 1;
  }
  return Ok{};
}

// The names of a line of `n_fields` fields: format.columns (which must have that many), or
// the header's (`header`, may be empty for a headerless file: c1, c2, ...).
Result<std::vector<std::string>> FieldNames(const std::vector<std::string_view>& header,
                                            std::size_t n_fields, const CsvFormat& format,
                                            const std::string& source, int line_no) {
  std::vector<std::string> names;
  if (!format.columns.empty()) {
    if (format.columns.size() != n_fields) {
      return FileError(
          source, line_no, 0,
          fmt::format("{} column names are given, but line {} has {} field{}",
                      format.columns.size(), line_no, n_fields, n_fields == 1 ? "" : "s"));
    }
    names = format.columns;
  } else if (!header.empty()) {
    names.assign(header.begin(), header.end());
  } else {
    for (std::size_t i = 0; i < n_fields; ++i) names.push_back(fmt::format("c{}", i + 1));
  }
  return names;
}

}  // namespace

std::optional<double> TimeUnitScale(std::string_view name, std::string* unknown_unit) {
  if (IsTimeWord(name)) return 1.0;
  std::string_view base, unit;
  if (!SplitUnit(name, &base, &unit) || !IsTimeWord(base)) return std::nullopt;
  const std::optional<double> scale = UnitScale(unit);
  if (!scale && unknown_unit != nullptr) *unknown_unit = std::string(unit);
  return scale;
}

Status internal::ReadHeader(FieldSplitter& splitter, std::string_view line, int line_no, Dataset* d,
                            const CsvFormat& format) {
  int bad_field = 0;
  std::string problem;
  if (!splitter.Split(line, &bad_field, &problem)) {
    return FileError(d->source, line_no, bad_field, "in the header, " + problem);
  }
  const std::vector<std::string_view>& fields = splitter.fields();
  d->header_line = line_no;
  Result<std::vector<std::string>> names =
      FieldNames(fields, fields.size(), format, d->source, line_no);
  if (!names) return names.error();
  const std::vector<std::string_view> views(names->begin(), names->end());
  return NameColumns(views, line_no, format, d);
}

// ---------------------------------------------------------------------------------------------
// Rows

std::string NotANumberReason(std::string_view text, char decimal) {
  if (decimal == ',' && text.find('.') != std::string_view::npos)
    return fmt::format("'{}' is not a number (the decimal mark must be ',')", text);
  std::string_view digits = text;
  if (!digits.empty() && (digits.front() == '+' || digits.front() == '-')) digits.remove_prefix(1);
  double v = 0;
  const char* end = digits.data() + digits.size();
  const auto [ptr, ec] = std::from_chars(digits.data(), end, v, std::chars_format::general);
  const bool reads_as_number = !digits.empty() && digits.front() != '-' && ptr == end;
  if (reads_as_number) return fmt::format("'{}' is not finite", text);
  if (decimal == ',') return fmt::format("'{}' is not a number", text);
  return fmt::format(
      "'{}' is not a number{}", text,
      text.find(',') != std::string_view::npos ? " (the decimal point must be '.')" : "");
}

namespace {

// A time of the time column in seconds. A unit below a second divides by a whole number (100 ms
// is 0.1 s to the last bit, which 100 * 0.001 is not).
double Seconds(const Dataset& d, double t) {
  if (d.time_scale == 1) return t;
  const double per_second = std::round(1 / d.time_scale);
  const bool divide = d.time_scale < 1 && std::abs(per_second * d.time_scale - 1) < 1e-12;
  return divide ? t / per_second : t * d.time_scale;
}

}  // namespace

Status internal::SplitRow(FieldSplitter& splitter, std::string_view line, int line_no,
                          const Dataset& header, int previous_line, double previous_time,
                          double* t) {
  int bad_field = 0;
  std::string problem;
  if (!splitter.Split(line, &bad_field, &problem)) {
    return FileError(header.source, line_no, bad_field, problem);
  }
  const std::vector<std::string_view>& fields = splitter.fields();
  const std::size_t n_fields = header.columns.size() + (header.time_field > 0 ? 1 : 0);
  if (fields.size() != n_fields) {
    return FileError(header.source, line_no,
                     static_cast<int>(std::min(fields.size(), n_fields)) + 1,
                     fmt::format("line {} has {} field{}, the {} has {}", line_no, fields.size(),
                                 fields.size() == 1 ? "" : "s",
                                 header.header_line > 0 ? "header" : "first row", n_fields));
  }
  if (header.time_field == 0) return Ok{};
  const std::string_view time = fields[static_cast<std::size_t>(header.time_field - 1)];
  switch (ParseCell(time, t, header.decimal)) {
    case Cell::kNumber:
      break;
    case Cell::kMissing:
      return FileError(header.source, line_no, header.time_field,
                       "the time is missing (every row needs a time)");
    case Cell::kNotANumber:
      return FileError(header.source, line_no, header.time_field,
                       "time " + NotANumberReason(time, header.decimal));
  }
  const double raw = *t;
  *t = Seconds(header, raw);
  if (previous_line > 0 && !(*t > previous_time)) {
    if (header.time_scale == 1) {
      return FileError(header.source, line_no, header.time_field,
                       fmt::format("time {} does not increase (previous row, line {}, has {})", *t,
                                   previous_line, previous_time));
    }
    return FileError(header.source, line_no, header.time_field,
                     fmt::format("time {} ({} s) does not increase (previous row, line {}, is at "
                                 "{} s)",
                                 raw, *t, previous_line, previous_time));
  }
  return Ok{};
}

Result<std::shared_ptr<const Dataset>> ParseCsv(std::string_view text, std::string source,
                                                const CsvFormat& format) {
  auto d = std::make_shared<Dataset>();
  d->source = std::move(source);
  d->decimal = format.decimal;
  if (text.starts_with(kByteOrderMark)) text.remove_prefix(kByteOrderMark.size());
  if (format.decimal == ',' && format.separator == ',') {
    return FileError(d->source, 0, 0, "a decimal comma needs another separator than ','");
  }

  LineReader lines(text);
  std::string_view line;
  bool found_first = false;
  while (!found_first && lines.Next(&line)) found_first = !IsSkipped(line);
  if (!found_first) {
    return FileError(
        d->source, 0, 0,
        text.find_first_not_of(" \t\r\n") == std::string_view::npos ? "the file is empty"
        : format.header ? "the file has no header: it holds only comments and blank lines"
                        : "the file has no rows: it holds only comments and blank lines");
  }
  char separator = format.separator != 0 ? format.separator : DetectSeparator(line);
  if (format.decimal == ',' && separator == ',') separator = ';';
  FieldSplitter splitter(separator);
  // A headerless file: the first line is data, and it names nothing but its count of fields.
  bool first_is_data = false;
  if (format.header) {
    if (Status s = ReadHeader(splitter, line, lines.number(), d.get(), format); !s)
      return s.error();
  } else {
    int bad_field = 0;
    std::string problem;
    if (!splitter.Split(line, &bad_field, &problem))
      return FileError(d->source, lines.number(), bad_field, problem);
    Result<std::vector<std::string>> names =
        FieldNames({}, splitter.fields().size(), format, d->source, lines.number());
    if (!names) return names.error();
    const std::vector<std::string_view> views(names->begin(), names->end());
    if (Status s = NameColumns(views, lines.number(), format, d.get()); !s) return s.error();
    first_is_data = true;
  }

  // Reserving for every remaining line avoids regrowing the columns (most lines are rows). A row
  // of n fields takes at least n bytes (separators and line end), which bounds the reservation
  // by the size of the text: blank or comment lines under a wide header reserve nothing.
  const std::size_t n_fields = d->columns.size() + 1;
  const std::size_t max_rows = std::min(CountLineEnds(text) + 1, text.size() / n_fields + 1);
  d->time.reserve(max_rows);
  d->row_line.reserve(max_rows);
  for (Column& c : d->columns) c.values.reserve(max_rows);

  // The last row read (kept or not): times must increase over every row of the file.
  int previous_line = 0;
  double previous_time = 0;
  std::size_t row_count = 0;
  const auto read_row = [&](std::string_view row, int line_no) -> Status {
    double t = 0;
    if (Status s = SplitRow(splitter, row, line_no, *d, previous_line, previous_time, &t); !s) {
      return s.error();
    }
    if (d->time_field == 0) t = static_cast<double>(row_count) * format.sample_time;
    ++row_count;
    previous_line = line_no;
    previous_time = t;
    if (format.range && (t < (*format.range)[0] || t > (*format.range)[1])) return Ok{};
    const std::vector<std::string_view>& fields = splitter.fields();
    d->time.push_back(t);
    d->row_line.push_back(line_no);

    for (Column& c : d->columns) {
      const std::string_view cell = fields[static_cast<std::size_t>(c.field - 1)];
      double v = 0;
      switch (ParseCell(cell, &v, d->decimal)) {
        case Cell::kNumber:
          break;
        case Cell::kMissing:
          if (c.n_missing++ == 0) c.first_missing_line = line_no;
          break;
        case Cell::kNotANumber:
          v = kNaN;
          if (c.bad_line == 0) {
            c.bad_line = line_no;
            c.bad_text = std::string(cell);
          }
          break;
      }
      c.values.push_back(v);
    }
    return Ok{};
  };
  if (first_is_data)
    if (Status s = read_row(line, lines.number()); !s) return s.error();
  while (lines.Next(&line)) {
    if (IsSkipped(line)) continue;
    if (Status s = read_row(line, lines.number()); !s) return s.error();
  }
  if (row_count == 0) {
    return FileError(d->source, d->header_line, 0, "the file has a header but no data rows");
  }
  return std::shared_ptr<const Dataset>(std::move(d));
}

CsvFormat SniffCsv(std::string_view text) {
  CsvFormat format;
  if (text.starts_with(kByteOrderMark)) text.remove_prefix(kByteOrderMark.size());
  constexpr int kLines = 50;
  std::vector<std::string_view> sample;
  LineReader lines(text);
  std::string_view line;
  while (static_cast<int>(sample.size()) < kLines && lines.Next(&line))
    if (!IsSkipped(line)) sample.push_back(line);
  if (sample.empty()) return format;

  const auto count_outside_quotes = [](std::string_view l, char c) {
    int n = 0;
    bool quoted = false;
    for (char x : l) {
      if (x == '"') quoted = !quoted;
      n += !quoted && x == c;
    }
    return n;
  };
  for (char candidate : {';', '\t', ','}) {
    const int n = count_outside_quotes(sample.front(), candidate);
    bool consistent = n > 0;
    for (std::string_view l : sample)
      consistent = consistent && count_outside_quotes(l, candidate) == n;
    if (consistent) {
      format.separator = candidate;
      break;
    }
  }
  if (format.separator == 0) format.separator = DetectSeparator(sample.front());

  FieldSplitter splitter(format.separator);
  int bad_field = 0;
  std::string problem;
  if (format.separator != ',') {
    int with_point = 0, with_comma = 0;
    for (std::string_view l : sample) {
      if (!splitter.Split(l, &bad_field, &problem)) continue;
      for (std::string_view f : splitter.fields()) {
        double v = 0;
        if (f.find('.') != std::string_view::npos && ParseCell(f, &v, '.') == Cell::kNumber)
          ++with_point;
        if (f.find(',') != std::string_view::npos && ParseCell(f, &v, ',') == Cell::kNumber)
          ++with_comma;
      }
    }
    if (with_comma > 0 && with_point == 0) format.decimal = ',';
  }
  if (splitter.Split(sample.front(), &bad_field, &problem)) {
    bool all_numbers = !splitter.fields().empty();
    for (std::string_view f : splitter.fields()) {
      double v = 0;
      all_numbers = all_numbers && ParseCell(f, &v, format.decimal) == Cell::kNumber;
    }
    format.header = !all_numbers;
  }
  return format;
}

// ---------------------------------------------------------------------------------------------
// Files

namespace {

// Data files are read whole; 4 GiB is some 100 million rows of a few columns.
constexpr std::uintmax_t kMaxCsvBytes = std::uintmax_t{4} << 30;

// Reads the first `max_bytes` of `path` (all of it when shorter) into *text (not zero-filled
// first: fread writes it once); *got the bytes read, *size the file's.
Status ReadWhole(const std::string& path, std::unique_ptr<char[]>* text, std::size_t* got,
                 std::uintmax_t max_bytes = kMaxCsvBytes, std::uintmax_t* file_size = nullptr) {
  std::uintmax_t size = 0;
  if (const std::string why = WhyNotReadable(path, kMaxCsvBytes, &size); !why.empty())
    return FileError(path, 0, 0, why);
  if (file_size != nullptr) *file_size = size;
  size = std::min(size, max_bytes);
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (f == nullptr) {
    return FileError(path, 0, 0, "cannot open the file: " + std::generic_category().message(errno));
  }
  *text = std::make_unique_for_overwrite<char[]>(static_cast<std::size_t>(size));
  *got = std::fread(text->get(), 1, static_cast<std::size_t>(size), f);
  const bool failed = std::ferror(f) != 0;
  const int error = errno;
  std::fclose(f);
  if (failed) {
    return FileError(path, 0, 0, "cannot read the file: " + std::generic_category().message(error));
  }
  return Ok{};
}

}  // namespace

Result<std::shared_ptr<const Dataset>> ReadCsvFile(const std::string& path,
                                                   const CsvFormat& format) {
  return ReadCsvFile(path, [&format](std::string_view) { return format; });
}

Result<std::shared_ptr<const Dataset>> ReadCsvFile(
    const std::string& path, const std::function<CsvFormat(std::string_view text)>& format_of) {
  std::unique_ptr<char[]> text;
  std::size_t size = 0;
  if (Status s = ReadWhole(path, &text, &size); !s) return s.error();
  const std::string_view view(text.get(), size);
  return ParseCsv(view, path, format_of(view));
}

Result<std::string> ReadFileHead(const std::string& path, std::size_t max_bytes, bool* truncated) {
  std::unique_ptr<char[]> text;
  std::size_t size = 0;
  std::uintmax_t file_size = 0;
  if (Status s = ReadWhole(path, &text, &size, max_bytes, &file_size); !s) return s.error();
  *truncated = file_size > size;
  return std::string(text.get(), size);
}

int Dataset::Find(std::string_view name) const {
  int found = -1;
  for (std::size_t i = 0; i < columns.size(); ++i) {
    if (columns[i].name != name) continue;
    if (found >= 0) return -2;
    found = static_cast<int>(i);
  }
  return found;
}

}  // namespace gb::data
