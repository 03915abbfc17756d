// Reading rows of live CSV sources (format and behaviour in follow.h).
#include "core/data/follow.h"

#include <cerrno>
#include <climits>
#include <span>
#include <system_error>
#include <utility>

#include <fcntl.h>
#include <fmt/format.h>
#include <poll.h>
#include <sys/stat.h>
#include <unistd.h>

#include "core/data/internal.h"

namespace gb::data {

using data::internal::Cell;
using data::internal::FieldSplitter;
using data::internal::FileError;
using data::internal::kByteOrderMark;

namespace {

std::string SystemMessage(int error) { return std::generic_category().message(error); }

}  // namespace

// ---------------------------------------------------------------------------------------------
// CsvRowReader

CsvRowReader::CsvRowReader(std::string source, std::vector<std::string> inputs,
                           std::vector<std::string> outputs)
    : source_(std::move(source)), inputs_(std::move(inputs)), outputs_(std::move(outputs)) {}

CsvRowReader::~CsvRowReader() = default;
CsvRowReader::CsvRowReader(CsvRowReader&&) noexcept = default;
CsvRowReader& CsvRowReader::operator=(CsvRowReader&&) noexcept = default;

void CsvRowReader::Feed(std::string_view bytes) {
  while (!bytes.empty() && !fatal_) {
    if (after_cr_) {
      after_cr_ = false;
      if (bytes.front() == '\n') {
        bytes.remove_prefix(1);
        continue;
      }
    }
    const std::size_t end = bytes.find_first_of("\r\n");
    if (end == std::string_view::npos) {
      Keep(bytes);
      return;
    }
    after_cr_ = bytes[end] == '\r';
    if (partial_.empty() && !overlong_) {  // the common case: a whole line in this piece
      EndLine(bytes.substr(0, end));
    } else {
      Keep(bytes.substr(0, end));
      EndLine(partial_);
      partial_.clear();
    }
    bytes.remove_prefix(end + 1);
  }
}

void CsvRowReader::Finish(LastLine last) {
  if (fatal_) return;
  if ((!partial_.empty() || overlong_) && last == LastLine::kDrop) {
    std::string_view start = partial_;
    if (lines_ == 0 && start.starts_with(kByteOrderMark))
      start.remove_prefix(kByteOrderMark.size());
    const bool skipped = overlong_ ? overlong_skipped_ : data::internal::IsSkipped(start);
    const int line_no = lines_ < INT_MAX ? lines_ + 1 : INT_MAX;
    const char* const why = "no line end came before reading stopped";
    if (!skipped && header_seen_) {
      Skip(FileError(source_, line_no, 0,
                     fmt::format("the last line is incomplete ({}): not used", why)));
    } else if (!skipped) {
      fatal_ = FileError(source_, line_no, 0,
                         fmt::format("the header line is incomplete ({}): nothing was read", why));
    }
    partial_.clear();
    overlong_ = false;
  }
  if (!partial_.empty() || overlong_) {
    EndLine(partial_);
    partial_.clear();
  }
  after_cr_ = false;
  if (!header_seen_ && !fatal_) {
    const char* what = saw_comment_ ? "it held only comments and blank lines" : "it was empty";
    fatal_ = FileError(source_, 0, 0, fmt::format("the input ended before a header: {}", what));
  }
}

void CsvRowReader::Restart() {
  partial_.clear();
  after_cr_ = false;
  overlong_ = false;
  lines_ = 0;
  saw_comment_ = false;
  header_seen_ = false;
  header_ = data::Dataset{};
  splitter_.reset();
  input_fields_.clear();
  output_fields_.clear();
  last_time_ = 0;
  last_line_ = 0;
  fatal_.reset();
}

std::vector<Sample> CsvRowReader::TakeSamples() { return std::exchange(samples_, {}); }
std::vector<Error> CsvRowReader::TakeProblems() { return std::exchange(problems_, {}); }

// A line longer than kMaxLineBytes is not kept: only whether it began as a comment (or blank).
void CsvRowReader::Keep(std::string_view piece) {
  if (overlong_) return;
  partial_.append(piece);
  if (partial_.size() <= kMaxLineBytes) return;
  std::string_view start = partial_;
  if (lines_ == 0 && start.starts_with(kByteOrderMark)) start.remove_prefix(kByteOrderMark.size());
  overlong_ = true;
  overlong_skipped_ = data::internal::IsSkipped(start);
  partial_.clear();
  partial_.shrink_to_fit();
}

void CsvRowReader::EndLine(std::string_view line) {
  if (lines_ < INT_MAX) ++lines_;
  const int line_no = lines_;
  if (overlong_) {
    overlong_ = false;
    if (overlong_skipped_) return;
    const std::string problem =
        fmt::format("line {} is longer than {} bytes", line_no, kMaxLineBytes);
    if (header_seen_) {
      Skip(FileError(source_, line_no, 0, problem));
    } else {
      fatal_ = FileError(source_, line_no, 0, problem + ", too long for a header");
    }
    return;
  }
  if (line_no == 1 && line.starts_with(kByteOrderMark)) line.remove_prefix(kByteOrderMark.size());
  if (data::internal::IsSkipped(line)) {
    saw_comment_ = saw_comment_ || line.find_first_not_of(" \t") != std::string_view::npos;
    return;
  }
  if (header_seen_) {
    ReadRow(line, line_no);
  } else {
    ReadHeaderLine(line, line_no);
  }
}

void CsvRowReader::ReadHeaderLine(std::string_view line, int line_no) {
  splitter_ = std::make_unique<FieldSplitter>(data::internal::DetectSeparator(line));
  header_ = data::Dataset{};
  header_.source = source_;
  if (Status s = data::internal::ReadHeader(*splitter_, line, line_no, &header_); !s) {
    fatal_ = s.error();
    return;
  }
  // Bound as a whole file's columns are, with Bind's messages: a trial binding of two rows of
  // zeros can fail only for the header's sake.
  data::Dataset trial = header_;
  trial.time = {0, 1};
  for (data::Column& c : trial.columns) c.values = {0, 0};
  if (auto bound = data::Bind(trial, inputs_, outputs_); !bound) {
    fatal_ = bound.error();
    return;
  }
  const auto field_of = [this](const std::string& name) {
    const int index = header_.Find(name);  // found: Bind succeeded
    return static_cast<std::size_t>(header_.columns[static_cast<std::size_t>(index)].field - 1);
  };
  for (const std::string& name : inputs_) input_fields_.push_back(field_of(name));
  for (const std::string& name : outputs_) output_fields_.push_back(field_of(name));
  header_seen_ = true;
}

void CsvRowReader::ReadRow(std::string_view line, int line_no) {
  Sample sample;
  if (Status s = data::internal::SplitRow(*splitter_, line, line_no, header_, last_line_,
                                          last_time_, &sample.t);
      !s) {
    return Skip(s.error());
  }
  const std::vector<std::string_view>& fields = splitter_->fields();
  // Reads the bound cells of one role into *values; false when the row is skipped.
  const auto read = [&](std::span<const std::string> names, std::span<const std::size_t> index,
                        const char* role, bool missing_allowed, std::vector<double>* values) {
    values->resize(names.size());
    for (std::size_t i = 0; i < names.size(); ++i) {
      const std::string_view cell = fields[index[i]];
      const int col = static_cast<int>(index[i]) + 1;
      switch (data::internal::ParseCell(cell, &(*values)[i])) {
        case Cell::kNumber:
          break;
        case Cell::kMissing:
          if (missing_allowed) break;
          Skip(FileError(source_, line_no, col,
                         fmt::format("{} '{}' is missing (inputs must be given at every row)", role,
                                     names[i])));
          return false;
        case Cell::kNotANumber:
          Skip(FileError(source_, line_no, col,
                         fmt::format("in column '{}' (an {} of the model), {}", names[i], role,
                                     data::NotANumberReason(cell))));
          return false;
      }
    }
    return true;
  };
  if (!read(inputs_, input_fields_, "input", false, &sample.u)) return;
  if (!read(outputs_, output_fields_, "output", true, &sample.y)) return;
  sample.line = line_no;
  last_time_ = sample.t;
  last_line_ = line_no;
  samples_.push_back(std::move(sample));
}

void CsvRowReader::Skip(Error problem) {
  problem.message += "; row skipped";
  problems_.push_back(std::move(problem));
}

// ---------------------------------------------------------------------------------------------
// FileFollower

FileFollower::FileFollower(std::string path, int fd, dev_t device, ino_t inode)
    : path_(std::move(path)), fd_(fd), device_(device), inode_(inode) {}

FileFollower::~FileFollower() {
  if (fd_ >= 0) ::close(fd_);
}

FileFollower::FileFollower(FileFollower&& other) noexcept
    : path_(std::move(other.path_)),
      fd_(std::exchange(other.fd_, -1)),
      device_(other.device_),
      inode_(other.inode_),
      offset_(other.offset_),
      note_(std::move(other.note_)) {}

FileFollower& FileFollower::operator=(FileFollower&& other) noexcept {
  if (this == &other) return *this;
  if (fd_ >= 0) ::close(fd_);
  path_ = std::move(other.path_);
  fd_ = std::exchange(other.fd_, -1);
  device_ = other.device_;
  inode_ = other.inode_;
  offset_ = other.offset_;
  note_ = std::move(other.note_);
  return *this;
}

Result<FileFollower> FileFollower::Open(const std::string& path) {
  // Non-blocking, so that opening a FIFO does not wait for a writer before it is refused.
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NONBLOCK);
  if (fd < 0) return FileError(path, 0, 0, "cannot open the file: " + SystemMessage(errno));
  struct stat st {};
  if (::fstat(fd, &st) != 0) {
    const int error = errno;
    ::close(fd);
    return FileError(path, 0, 0, "cannot read the file: " + SystemMessage(error));
  }
  if (!S_ISREG(st.st_mode)) {
    ::close(fd);
    return FileError(path, 0, 0,
                     S_ISDIR(st.st_mode)
                         ? "cannot follow the file: it is a folder"
                         : "cannot follow the file: it is a device or a pipe, not a regular file "
                           "(give '-' and send it to standard input instead)");
  }
  return FileFollower(path, fd, st.st_dev, st.st_ino);
}

Result<std::string> FileFollower::Poll() {
  struct stat named {};
  const bool replaced =
      ::stat(path_.c_str(), &named) == 0 && (named.st_dev != device_ || named.st_ino != inode_);
  Result<std::string> bytes = ReadAppended();
  // What was written to a replaced file before it was replaced comes first.
  if (!bytes || !bytes->empty() || !replaced) return bytes;
  if (Status s = SwitchToReplacement(); !s) return s.error();
  return ReadAppended();
}

Result<std::string> FileFollower::ReadAppended() {
  struct stat now {};
  if (::fstat(fd_, &now) != 0) {
    return FileError(path_, 0, 0, "cannot read the file: " + SystemMessage(errno));
  }
  if (now.st_size < offset_) {
    note_ = fmt::format("{} was truncated (from {} to {} bytes); reading it again from the start",
                        path_, offset_, now.st_size);
    offset_ = 0;
  }
  const auto available = static_cast<std::size_t>(now.st_size - offset_);
  std::string bytes(std::min(available, kMaxPollBytes), '\0');
  std::size_t got = 0;
  while (got < bytes.size()) {
    const ssize_t n = ::pread(fd_, bytes.data() + got, bytes.size() - got, offset_);
    if (n == 0) break;  // truncated since fstat: seen by the next Poll
    if (n < 0) {
      if (errno == EINTR) continue;
      return FileError(path_, 0, 0, "cannot read the file: " + SystemMessage(errno));
    }
    got += static_cast<std::size_t>(n);
    offset_ += static_cast<off_t>(n);
  }
  bytes.resize(got);
  return bytes;
}

// Opens the file now under the name (if it is gone again, keeps the old one until the next Poll).
Status FileFollower::SwitchToReplacement() {
  const int fd = ::open(path_.c_str(), O_RDONLY | O_CLOEXEC | O_NONBLOCK);
  if (fd < 0 && errno == ENOENT) return Ok{};
  if (fd < 0) return FileError(path_, 0, 0, "cannot open the file: " + SystemMessage(errno));
  struct stat st {};
  if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
    ::close(fd);
    return FileError(path_, 0, 0, "cannot follow the file: its name now holds no regular file");
  }
  ::close(fd_);
  fd_ = fd;
  device_ = st.st_dev;
  inode_ = st.st_ino;
  offset_ = 0;
  note_ = fmt::format("{} was replaced by a new file; reading it from the start", path_);
  return Ok{};
}

std::optional<std::string> FileFollower::TakeNote() { return std::exchange(note_, std::nullopt); }

// ---------------------------------------------------------------------------------------------
// ReadSome

Result<std::string> ReadSome(int fd, const std::string& source) {
  std::string bytes(kReadSomeBytes, '\0');
  while (true) {
    const ssize_t n = ::read(fd, bytes.data(), bytes.size());
    if (n >= 0) {
      bytes.resize(static_cast<std::size_t>(n));
      return bytes;
    }
    if (errno == EINTR) continue;
    if (errno == EAGAIN || errno == EWOULDBLOCK) {  // a non-blocking descriptor: wait for it
      pollfd wait{fd, POLLIN, 0};
      if (::poll(&wait, 1, -1) >= 0 || errno == EINTR) continue;
    }
    return FileError(source, 0, 0, "cannot read the input: " + SystemMessage(errno));
  }
}

std::vector<Sample> SamplesOf(const data::Series& series) {
  std::vector<Sample> rows;
  rows.reserve(series.size());
  for (std::size_t j = 0; j < series.size(); ++j) {
    const auto c = static_cast<Eigen::Index>(j);
    Sample r;
    r.t = series.time[j];
    r.u.assign(series.U.col(c).data(), series.U.col(c).data() + series.U.rows());
    r.y.assign(series.Y.col(c).data(), series.Y.col(c).data() + series.Y.rows());
    r.line = j < series.row_line.size() ? series.row_line[j] : 0;
    rows.push_back(std::move(r));
  }
  return rows;
}

}  // namespace gb::data
