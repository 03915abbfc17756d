// Live CSV sources for on-line identification: the rows of a file another process is still
// writing (read as `tail -f` reads it), or of standard input, parsed as their bytes arrive and
// bound to a model's inputs and outputs, one Sample per row, for a recursive estimator.
//
// Format: user guide §3, with the rules of core/data/dataset.h (they share its code):
// comments and blank lines skipped; the first other line is the header, whose separator (',' ';'
// or TAB) is detected from it; quoted fields, a UTF-8 byte-order mark, LF, CRLF or CR line ends
// and spaces around fields accepted; the time column is the first named `t` or `time` (any case);
// the other columns are bound by name to the model's inputs and outputs, extra columns ignored
// (never parsed). What differs from reading a whole file is what a problem does to the rest:
//   - A header that cannot be bound (no time column, an input or output column absent or
//     duplicated, a malformed quote) is fatal(): nothing more is read until Restart(). The
//     messages are ParseCsv's and Bind's: "run.csv:1: column 'mfi' (an input of the model) is not
//     in the file; its columns are t, u, y".
//   - A malformed data row is reported (a problem) and skipped, and reading goes on: a quote not
//     closed, a wrong number of fields, a time that is missing, not a finite number or not
//     greater than the last accepted row's, a bound cell that is not a number, a missing input.
//     "run.csv:14:1: time 0.25 does not increase (previous row, line 13, has 0.25); row skipped".
//   - An output cell that is empty, `NA` or `NaN` is a missing observation: NaN in Sample::y.
//   - A line is parsed only once its line end has arrived (or at Finish()): bytes may arrive split
//     anywhere, inside a CRLF pair or a multi-byte character, and the rows come out the same.
//     A CR ends its line at once; an LF right after it (in the same piece or the next) ends none.
//
// Memory: O(1) in the length of the stream. A reader keeps only the line being received, at most
// kMaxLineBytes of it (a longer line is dropped as it arrives, and reported when it ends), plus
// the samples and problems not yet taken.
//
// Use, following a file (a monitor polls every few milliseconds; a pipe: ReadSome in a loop):
//   CsvRowReader reader(path, inputs, outputs);
//   Result<FileFollower> follower = FileFollower::Open(path);    // an Error names the file
//   while (running) {
//     Result<std::string> bytes = follower->Poll();              // never blocks
//     if (std::optional<std::string> note = follower->TakeNote()) {
//       print(*note);                                            // the file was truncated or
//       reader.Restart();                                        // replaced: a new header comes
//     }
//     reader.Feed(*bytes);
//     for (const Sample& s : reader.TakeSamples()) estimator.Update(s);
//     for (const Error& e : reader.TakeProblems()) print(e.ToString());
//     if (reader.fatal()) break;
//     if (bytes->empty()) sleep(10 ms);
//   }
// None of these types is thread-safe; each belongs to the thread that reads the source.
#pragma once

#include <cstddef>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <sys/types.h>

#include "core/data/dataset.h"
#include "core/util/result.h"

namespace gb::data::internal {
class FieldSplitter;
}  // namespace gb::data::internal

namespace gb::data {

// One row of a live source, bound to a model's inputs and outputs.
struct Sample {
  double t = 0;           // the time column, in the model's time unit; finite, increasing
  std::vector<double> u;  // one per input, in the model's order; finite
  std::vector<double> y;  // one per output, in the model's order; NaN = missing observation
  int line = 0;  // 1-based line in the source (0: generated, e.g. by the virtual dyno); a stream
                 // longer than INT_MAX lines says INT_MAX from there on
};

// The rows of a whole series as samples (a record replayed through an on-line estimator; the
// line from the series' row_line where it has one, else 0).
std::vector<Sample> SamplesOf(const data::Series& series);

// Incremental CSV parser for data that arrives in pieces (rules above).
class CsvRowReader {
 public:
  // Longest line kept while it is received: 1 MiB, some ten thousand numeric fields.
  static constexpr std::size_t kMaxLineBytes = std::size_t{1} << 20;

  // `source` names the file (or "<stdin>") in messages; rows are bound by name to the columns
  // `inputs` and `outputs` (the model's names, in its order).
  CsvRowReader(std::string source, std::vector<std::string> inputs,
               std::vector<std::string> outputs);
  ~CsvRowReader();
  CsvRowReader(CsvRowReader&&) noexcept;
  CsvRowReader& operator=(CsvRowReader&&) noexcept;

  // Parses the complete lines of what has arrived so far; a partial last line waits for the rest.
  // Does nothing once fatal().
  void Feed(std::string_view bytes);
  // End of input. A last line without a line end is parsed (kParse: the input ended, so the line
  // is whole, as for a file read to its end or standard input closed), or dropped (kDrop: reading
  // stopped while the source may be mid-line, e.g. a followed file whose writer paused; it is a
  // problem, "run.csv:802: the last line is incomplete (...): not used; row skipped"). When no
  // header has come, that is fatal ("the input ended before a header: it was empty"). Call once,
  // at the end.
  enum class LastLine { kParse, kDrop };
  void Finish(LastLine last = LastLine::kParse);
  // The source starts again from its first byte (a file truncated or replaced): forgets the
  // unfinished line, the header and its binding, fatal(), the line count and the last time.
  // Samples and problems not yet taken are kept.
  void Restart();

  // Rows accepted since the last call, in order.
  std::vector<Sample> TakeSamples();
  // Rows skipped since the last call, in order: an input Error with file, 1-based line and
  // column (field; 0 for a line too long to keep), and a message ending in "; row skipped".
  std::vector<Error> TakeProblems();
  // Why nothing more is read: a header that cannot be bound (file, header line, column), or
  // Finish() before any header. Empty while reading goes on.
  const std::optional<Error>& fatal() const { return fatal_; }
  // The header has been read and bound: the lines that follow are rows.
  bool header_seen() const { return header_seen_; }
  const std::string& source() const { return source_; }

 private:
  void Keep(std::string_view piece);
  void EndLine(std::string_view line);
  void ReadHeaderLine(std::string_view line, int line_no);
  void ReadRow(std::string_view line, int line_no);
  void Skip(Error problem);

  std::string source_;
  std::vector<std::string> inputs_;
  std::vector<std::string> outputs_;

  // The line being received.
  std::string partial_;
  bool after_cr_ = false;          // the last line ended in CR: an LF next ends no line
  bool overlong_ = false;          // the line passed kMaxLineBytes: its rest is dropped as it comes
  bool overlong_skipped_ = false;  // ... and it began as a comment or blank line
  int lines_ = 0;                  // lines ended so far (at most INT_MAX)
  bool saw_comment_ = false;       // a comment came before any header

  // The header and the fields bound to the model (0-based).
  bool header_seen_ = false;
  data::Dataset header_;  // names and fields only, no rows
  std::unique_ptr<data::internal::FieldSplitter> splitter_;
  std::vector<std::size_t> input_fields_;
  std::vector<std::size_t> output_fields_;
  double last_time_ = 0;  // of the last accepted row,
  int last_line_ = 0;     // at this line (0: none yet)

  std::optional<Error> fatal_;
  std::vector<Sample> samples_;
  std::vector<Error> problems_;
};

// Follows a regular file that another process appends to. Poll() never blocks: it returns the
// bytes appended since the last call ("" when there are none), at most kMaxPollBytes at a time
// (poll again at once while it returns bytes; an existing file is read from its start).
// When the file shrinks below what was read (truncated), or its name comes to hold another file
// (replaced, as by a rename over it or a log rotation: another inode), the follower reads it again
// from its first byte and leaves a note to say so: the caller must Restart() its reader before
// feeding the bytes of that Poll. A replaced file's last bytes are read before the new one.
// A file truncated and written past the old size between two polls is not seen (as with tail -f).
// A name that disappears leaves the open file followed until a file of that name appears.
class FileFollower {
 public:
  static constexpr std::size_t kMaxPollBytes = std::size_t{1} << 20;

  // Opens `path`: an Error naming it when it is absent, unreadable, a folder, or not a regular
  // file (a pipe or device: read it through standard input and ReadSome).
  static Result<FileFollower> Open(const std::string& path);
  ~FileFollower();
  FileFollower(FileFollower&& other) noexcept;
  FileFollower& operator=(FileFollower&& other) noexcept;
  FileFollower(const FileFollower&) = delete;
  FileFollower& operator=(const FileFollower&) = delete;

  // The bytes appended since the last call; an Error naming the file when it cannot be read.
  Result<std::string> Poll();
  // Set by a Poll that started the file again (once; empty otherwise), e.g.
  // "run.csv was truncated (from 5120 to 0 bytes); reading it again from the start".
  std::optional<std::string> TakeNote();
  const std::string& path() const { return path_; }

 private:
  FileFollower(std::string path, int fd, dev_t device, ino_t inode);
  Result<std::string> ReadAppended();
  Status SwitchToReplacement();

  std::string path_;
  int fd_ = -1;
  dev_t device_ = 0;
  ino_t inode_ = 0;
  off_t offset_ = 0;  // bytes of the open file read so far
  std::optional<std::string> note_;
};

// Reads what is available from `fd` (standard input, a pipe), waiting until at least one byte is:
// up to kReadSomeBytes, or "" at the end of input. `source` names it in an Error.
inline constexpr std::size_t kReadSomeBytes = std::size_t{64} << 10;
Result<std::string> ReadSome(int fd, const std::string& source = "<stdin>");

}  // namespace gb::data
