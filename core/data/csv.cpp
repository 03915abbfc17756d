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
#include <fmt/format.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <system_error>

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

// ---------------------------------------------------------------------------------------------
// Cells

bool EqualsIgnoringCase(std::string_view a, std::string_view b) {
  return std::equal(a.begin(), a.end(), b.begin(), b.end(), [](char x, char y) {
    return (x >= 'A' && x <= 'Z' ? x - 'A' + 'a' : x) == (y >= 'A' && y <= 'Z' ? y - 'A' + 'a' : y);
  });
}

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

Cell internal::ParseCell(std::string_view s, double* value) {
  if (IsMissingMarker(s)) {
    *value = kNaN;
    return Cell::kMissing;
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

}  // namespace

Status internal::ReadHeader(FieldSplitter& splitter, std::string_view line, int line_no,
                            Dataset* d) {
  int bad_field = 0;
  std::string problem;
  if (!splitter.Split(line, &bad_field, &problem)) {
    return FileError(d->source, line_no, bad_field, "in the header, " + problem);
  }
  const std::vector<std::string_view>& names = splitter.fields();
  d->header_line = line_no;
  for (std::size_t i = 0; i < names.size(); ++i) {
    const int field = static_cast<int>(i) + 1;
    if (d->time_field == 0 &&
        (EqualsIgnoringCase(names[i], "t") || EqualsIgnoringCase(names[i], "time"))) {
      d->time_name = std::string(names[i]);
      d->time_field = field;
    } else {
      Column& c = d->columns.emplace_back();
      c.name = std::string(names[i]);
      c.field = field;
    }
  }
  if (d->time_field == 0) {
    return FileError(d->source, line_no, 0,
                     "no time column: the header needs a column named 't' or 'time'; it has: " +
                         JoinNames(names));
  }
  return Ok{};
}

// ---------------------------------------------------------------------------------------------
// Rows

std::string NotANumberReason(std::string_view text) {
  std::string_view digits = text;
  if (!digits.empty() && (digits.front() == '+' || digits.front() == '-')) digits.remove_prefix(1);
  double v = 0;
  const char* end = digits.data() + digits.size();
  const auto [ptr, ec] = std::from_chars(digits.data(), end, v, std::chars_format::general);
  const bool reads_as_number = !digits.empty() && digits.front() != '-' && ptr == end;
  if (reads_as_number) return fmt::format("'{}' is not finite", text);
  return fmt::format(
      "'{}' is not a number{}", text,
      text.find(',') != std::string_view::npos ? " (the decimal point must be '.')" : "");
}

Status internal::SplitRow(FieldSplitter& splitter, std::string_view line, int line_no,
                          const Dataset& header, int previous_line, double previous_time,
                          double* t) {
  int bad_field = 0;
  std::string problem;
  if (!splitter.Split(line, &bad_field, &problem)) {
    return FileError(header.source, line_no, bad_field, problem);
  }
  const std::vector<std::string_view>& fields = splitter.fields();
  const std::size_t n_fields = header.columns.size() + 1;
  if (fields.size() != n_fields) {
    return FileError(header.source, line_no,
                     static_cast<int>(std::min(fields.size(), n_fields)) + 1,
                     fmt::format("line {} has {} field{}, the header has {}", line_no,
                                 fields.size(), fields.size() == 1 ? "" : "s", n_fields));
  }
  const std::string_view time = fields[static_cast<std::size_t>(header.time_field - 1)];
  switch (ParseCell(time, t)) {
    case Cell::kNumber:
      break;
    case Cell::kMissing:
      return FileError(header.source, line_no, header.time_field,
                       "the time is missing (every row needs a time)");
    case Cell::kNotANumber:
      return FileError(header.source, line_no, header.time_field, "time " + NotANumberReason(time));
  }
  if (previous_line > 0 && !(*t > previous_time)) {
    return FileError(header.source, line_no, header.time_field,
                     fmt::format("time {} does not increase (previous row, line {}, has {})", *t,
                                 previous_line, previous_time));
  }
  return Ok{};
}

Result<std::shared_ptr<const Dataset>> ParseCsv(std::string_view text, std::string source) {
  auto d = std::make_shared<Dataset>();
  d->source = std::move(source);
  if (text.starts_with(kByteOrderMark)) text.remove_prefix(kByteOrderMark.size());

  LineReader lines(text);
  std::string_view line;
  bool found_header = false;
  while (!found_header && lines.Next(&line)) found_header = !IsSkipped(line);
  if (!found_header) {
    return FileError(d->source, 0, 0,
                     text.find_first_not_of(" \t\r\n") == std::string_view::npos
                         ? "the file is empty"
                         : "the file has no header: it holds only comments and blank lines");
  }
  FieldSplitter splitter(DetectSeparator(line));
  if (Status s = ReadHeader(splitter, line, lines.number(), d.get()); !s) return s.error();

  // Reserving for every remaining line avoids regrowing the columns (most lines are rows). A row
  // of n fields takes at least n bytes (separators and line end), which bounds the reservation
  // by the size of the text: blank or comment lines under a wide header reserve nothing.
  const std::size_t n_fields = d->columns.size() + 1;
  const std::size_t max_rows = std::min(CountLineEnds(text) + 1, text.size() / n_fields + 1);
  d->time.reserve(max_rows);
  d->row_line.reserve(max_rows);
  for (Column& c : d->columns) c.values.reserve(max_rows);

  while (lines.Next(&line)) {
    if (IsSkipped(line)) continue;
    const int line_no = lines.number();
    double t = 0;
    const int previous_line = d->time.empty() ? 0 : d->row_line.back();
    const double previous_time = d->time.empty() ? 0.0 : d->time.back();
    if (Status s = SplitRow(splitter, line, line_no, *d, previous_line, previous_time, &t); !s) {
      return s.error();
    }
    const std::vector<std::string_view>& fields = splitter.fields();
    d->time.push_back(t);
    d->row_line.push_back(line_no);

    for (Column& c : d->columns) {
      const std::string_view cell = fields[static_cast<std::size_t>(c.field - 1)];
      double v = 0;
      switch (ParseCell(cell, &v)) {
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
  }
  if (d->time.empty()) {
    return FileError(d->source, d->header_line, 0, "the file has a header but no data rows");
  }
  return std::shared_ptr<const Dataset>(std::move(d));
}

// ---------------------------------------------------------------------------------------------
// Files

Result<std::shared_ptr<const Dataset>> ReadCsvFile(const std::string& path) {
  // Data files are read whole; 4 GiB is some 100 million rows of a few columns.
  constexpr std::uintmax_t kMaxCsvBytes = std::uintmax_t{4} << 30;
  std::uintmax_t size = 0;
  if (const std::string why = WhyNotReadable(path, kMaxCsvBytes, &size); !why.empty())
    return FileError(path, 0, 0, why);
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (f == nullptr) {
    return FileError(path, 0, 0, "cannot open the file: " + std::generic_category().message(errno));
  }
  // Not zero-filled: the buffer is written once, by fread.
  const auto text = std::make_unique_for_overwrite<char[]>(static_cast<std::size_t>(size));
  const std::size_t got = std::fread(text.get(), 1, static_cast<std::size_t>(size), f);
  const bool failed = std::ferror(f) != 0;
  const int error = errno;
  std::fclose(f);
  if (failed) {
    return FileError(path, 0, 0, "cannot read the file: " + std::generic_category().message(error));
  }
  return ParseCsv(std::string_view(text.get(), got), path);
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
