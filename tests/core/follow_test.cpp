// Tests of core/data/follow: the incremental CSV reader, the file follower and ReadSome.
//
// Contents
//   Helpers
//   Follow      CsvRowReader: pieces against whole files (ParseCsv + Bind), partial lines, rows
//               skipped, fatal headers, Restart
//   FollowFile  FileFollower with a writer thread, truncation, replacement; ReadSome
#include "core/data/follow.h"

#include <atomic>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>
#include <thread>
#include <vector>

#include <fcntl.h>
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include "core/data/dataset.h"

namespace gb::data {
namespace {

// ---------------------------------------------------------------------------------------------
// Helpers

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
const std::vector<std::string> kInputs = {"u"};
const std::vector<std::string> kOutputs = {"y"};

// What a reader gave for a whole source.
struct Read {
  std::vector<Sample> samples;
  std::vector<Error> problems;
  std::optional<Error> fatal;
};

void Collect(CsvRowReader& reader, Read* read) {
  for (Sample& s : reader.TakeSamples()) read->samples.push_back(std::move(s));
  for (Error& e : reader.TakeProblems()) read->problems.push_back(std::move(e));
  read->fatal = reader.fatal();
}

// Feeds `text` cut before each offset in `cuts` (ascending), then finishes.
Read ReadInPieces(std::string_view text, const std::vector<std::size_t>& cuts,
                  const std::vector<std::string>& inputs = kInputs,
                  const std::vector<std::string>& outputs = kOutputs) {
  CsvRowReader reader("run.csv", inputs, outputs);
  Read read;
  std::size_t from = 0;
  for (std::size_t cut : cuts) {
    reader.Feed(text.substr(from, cut - from));
    Collect(reader, &read);
    from = cut;
  }
  reader.Feed(text.substr(from));
  reader.Finish();
  Collect(reader, &read);
  return read;
}

Read ReadWhole(std::string_view text, const std::vector<std::string>& inputs = kInputs,
               const std::vector<std::string>& outputs = kOutputs) {
  return ReadInPieces(text, {}, inputs, outputs);
}

Read ReadByteAtATime(std::string_view text) {
  std::vector<std::size_t> cuts;
  for (std::size_t i = 1; i < text.size(); ++i) cuts.push_back(i);
  return ReadInPieces(text, cuts);
}

// Equal, or both NaN.
bool Same(double a, double b) { return a == b || (std::isnan(a) && std::isnan(b)); }

bool Same(const std::vector<double>& a, const std::vector<double>& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (!Same(a[i], b[i])) return false;
  }
  return true;
}

// `s` holds exactly these values (NaN where an output is missing) from this line.
void ExpectSample(const Sample& s, double t, const std::vector<double>& u,
                  const std::vector<double>& y, int line) {
  EXPECT_EQ(s.line, line);
  EXPECT_EQ(s.t, t) << "line " << s.line;
  EXPECT_EQ(s.u, u) << "line " << s.line;
  EXPECT_TRUE(Same(s.y, y)) << "line " << s.line;
}

testing::AssertionResult SameRead(const Read& a, const Read& b) {
  if (a.samples.size() != b.samples.size() || a.problems.size() != b.problems.size()) {
    return testing::AssertionFailure()
           << a.samples.size() << " and " << b.samples.size() << " samples, " << a.problems.size()
           << " and " << b.problems.size() << " problems";
  }
  for (std::size_t k = 0; k < a.samples.size(); ++k) {
    const Sample& p = a.samples[k];
    const Sample& q = b.samples[k];
    if (!Same(p.t, q.t) || !Same(p.u, q.u) || !Same(p.y, q.y) || p.line != q.line) {
      return testing::AssertionFailure()
             << "sample " << k << " differs (lines " << p.line << " and " << q.line << ")";
    }
  }
  for (std::size_t k = 0; k < a.problems.size(); ++k) {
    if (a.problems[k].ToString() != b.problems[k].ToString()) {
      return testing::AssertionFailure()
             << a.problems[k].ToString() << " against " << b.problems[k].ToString();
    }
  }
  if (a.fatal.has_value() != b.fatal.has_value()) return testing::AssertionFailure() << "fatal";
  return testing::AssertionSuccess();
}

// A comment and a BOM, CRLF line ends, quotes, a separator inside quotes, an unbound text column
// holding UTF-8, missing outputs in every spelling, spaces around fields, and a last line with no
// line end.
const std::string kRigText =
    "\xEF\xBB\xBF# logged by the rig, \xC2\xB5s clock\r\n"
    "\"time\";\"u\";note;\"y\"\r\n"
    "0;1.5;ok;2\r\n"
    "\r\n"
    "0.25; -3 ;\"a;b\";NA\r\n"
    "# a pause \xE2\x80\x94 then more\r\n"
    "0.5;+2e-1;\"say \"\"hi\"\"\";\r\n"
    "1;4;\xC3\xBC\xC3\xB1;nan\r\n"
    "1.5;.5;x; 7 \r\n"
    "2.5;1e-3;;-0.125";

// Three lines ending in CR alone, two in LF alone, and a row skipped in the middle.
const std::string kMixedEndsText = "t,y,u\r0,1,2\r0.5,x,3\n1,4,5\r\n\n2,,6\r";

// ---------------------------------------------------------------------------------------------
// Follow: pieces against whole files

TEST(Follow, ByteAtATimeFeedingGivesWhatParseCsvAndBindGive) {
  const Read read = ReadByteAtATime(kRigText);
  Result<std::shared_ptr<const data::Dataset>> d = data::ParseCsv(kRigText, "run.csv");
  ASSERT_TRUE(d.ok()) << d.error().ToString();
  Result<std::shared_ptr<const data::Series>> series = data::Bind(**d, kInputs, kOutputs);
  ASSERT_TRUE(series.ok()) << series.error().ToString();
  const data::Series& s = **series;

  EXPECT_TRUE(read.problems.empty());
  EXPECT_FALSE(read.fatal);
  ASSERT_EQ(read.samples.size(), s.size());
  for (std::size_t k = 0; k < s.size(); ++k) {
    const auto col = static_cast<Eigen::Index>(k);
    ExpectSample(read.samples[k], s.time[k], {s.U(0, col)}, {s.Y(0, col)}, s.row_line[k]);
  }
  // And the values themselves, as written.
  ASSERT_EQ(read.samples.size(), 6u);
  ExpectSample(read.samples[0], 0, {1.5}, {2}, 3);
  ExpectSample(read.samples[1], 0.25, {-3}, {kNaN}, 5);
  ExpectSample(read.samples[2], 0.5, {0.2}, {kNaN}, 7);
  ExpectSample(read.samples[3], 1, {4}, {kNaN}, 8);
  ExpectSample(read.samples[4], 1.5, {0.5}, {7}, 9);
  ExpectSample(read.samples[5], 2.5, {1e-3}, {-0.125}, 10);
}

TEST(Follow, ATimeColumnWithAUnitIsInSecondsAsParseCsvReadsIt) {
  const std::string text = "time [ms],u,y\n0,1,2\n250,3,4\n500,5,6\n";
  const Read read = ReadByteAtATime(text);
  Result<std::shared_ptr<const data::Dataset>> d = data::ParseCsv(text, "run.csv");
  ASSERT_TRUE(d.ok()) << d.error().ToString();
  EXPECT_EQ((*d)->time, (std::vector<double>{0, 0.25, 0.5}));
  ASSERT_EQ(read.samples.size(), 3u);
  for (std::size_t k = 0; k < 3; ++k) EXPECT_EQ(read.samples[k].t, (*d)->time[k]) << k;
  // A time that does not increase says both the unit's value and the seconds.
  const Read bad = ReadByteAtATime("time [ms],u,y\n0,1,2\n250,3,4\n250,5,6\n");
  ASSERT_EQ(bad.problems.size(), 1u);
  EXPECT_NE(bad.problems[0].ToString().find("time 250 (0.25 s) does not increase"),
            std::string::npos)
      << bad.problems[0].ToString();
}

TEST(Follow, EverySplitPointGivesTheSameSamples) {
  for (const std::string& text : {kRigText, kMixedEndsText}) {
    const Read whole = ReadWhole(text);
    ASSERT_FALSE(whole.samples.empty());
    // Three pieces, cut anywhere: inside a BOM, a CRLF pair, a quote or a UTF-8 character.
    for (std::size_t i = 0; i <= text.size(); ++i) {
      for (std::size_t j = i; j <= text.size(); ++j) {
        ASSERT_TRUE(SameRead(ReadInPieces(text, {i, j}), whole)) << "cut at " << i << ", " << j;
      }
    }
  }
}

TEST(Follow, LinesEndingInCrAloneLfAloneOrCrlfAreCountedAsParseCsvCountsThem) {
  const Read read = ReadWhole(kMixedEndsText);
  ASSERT_EQ(read.samples.size(), 3u);
  ExpectSample(read.samples[0], 0, {2}, {1}, 2);
  ExpectSample(read.samples[1], 1, {5}, {4}, 4);
  ExpectSample(read.samples[2], 2, {6}, {kNaN}, 6);
  ASSERT_EQ(read.problems.size(), 1u);
  EXPECT_EQ(read.problems[0].ToString(),
            "run.csv:3:2: in column 'y' (an output of the model), 'x' is not a number; row "
            "skipped");
}

// ---------------------------------------------------------------------------------------------
// Follow: partial lines

TEST(Follow, APartialLineIsNotParsedUntilItsNewlineArrives) {
  CsvRowReader reader("run.csv", kInputs, kOutputs);
  reader.Feed("t,u,y\n0,1,2\n1,3,4");
  EXPECT_TRUE(reader.header_seen());
  std::vector<Sample> samples = reader.TakeSamples();
  ASSERT_EQ(samples.size(), 1u);
  EXPECT_EQ(samples[0].y, (std::vector<double>{2}));
  // "1,3,4" is a complete row by itself, but the line goes on.
  reader.Feed("5");
  EXPECT_TRUE(reader.TakeSamples().empty());
  reader.Feed(".25");
  EXPECT_TRUE(reader.TakeSamples().empty());
  reader.Feed("\n");
  samples = reader.TakeSamples();
  ASSERT_EQ(samples.size(), 1u);
  ExpectSample(samples[0], 1, {3}, {45.25}, 3);
  EXPECT_TRUE(reader.TakeProblems().empty());
}

TEST(Follow, AHeaderIsNotReadUntilItsNewlineArrives) {
  CsvRowReader reader("run.csv", kInputs, kOutputs);
  reader.Feed("t,u,y");  // could still become "t,u,y2"
  EXPECT_FALSE(reader.header_seen());
  EXPECT_FALSE(reader.fatal());
  reader.Feed("\r");
  EXPECT_TRUE(reader.header_seen());
}

TEST(Follow, FinishParsesALastLineWithoutALineEnd) {
  CsvRowReader reader("run.csv", kInputs, kOutputs);
  reader.Feed("t,u,y\n0,1,2\n1,3,4");
  EXPECT_EQ(reader.TakeSamples().size(), 1u);
  reader.Finish();
  const std::vector<Sample> samples = reader.TakeSamples();
  ASSERT_EQ(samples.size(), 1u);
  EXPECT_EQ(samples[0].y, (std::vector<double>{4}));
  EXPECT_EQ(samples[0].line, 3);
  EXPECT_FALSE(reader.fatal());
}

// Reading that stops while the source may be mid-line (a followed file whose writer paused):
// the line without its end is not a row, whatever it holds ("1,3,4" would parse, "1,3" is a cut
// row), and the problem says so by its line; a trailing comment or blank line is no problem.
TEST(Follow, FinishDroppingTheLastLineUsesNoIncompleteLineAndSaysSo) {
  for (const std::string last : {"1,3,4", "1,3", "1,3,4\r\n1,5,6"}) {
    SCOPED_TRACE(last);
    CsvRowReader reader("run.csv", kInputs, kOutputs);
    reader.Feed("t,u,y\n0,1,2\n" + last);
    const std::size_t whole = reader.TakeSamples().size();
    reader.Finish(CsvRowReader::LastLine::kDrop);
    EXPECT_TRUE(reader.TakeSamples().empty());
    const std::vector<Error> problems = reader.TakeProblems();
    ASSERT_EQ(problems.size(), 1u);
    const int line = last.find('\n') == std::string::npos ? 3 : 4;
    EXPECT_EQ(problems[0].ToString(),
              fmt::format("run.csv:{}: the last line is incomplete (no line end came before "
                          "reading stopped): not used; row skipped",
                          line));
    EXPECT_EQ(whole, line == 3 ? 1u : 2u);
    EXPECT_FALSE(reader.fatal());
  }
  CsvRowReader reader("run.csv", kInputs, kOutputs);
  reader.Feed("t,u,y\n0,1,2\n# a comment");
  reader.Finish(CsvRowReader::LastLine::kDrop);
  EXPECT_TRUE(reader.TakeProblems().empty());
  EXPECT_EQ(reader.TakeSamples().size(), 1u);
  // A header cut short is fatal: nothing can be bound.
  CsvRowReader header("run.csv", kInputs, kOutputs);
  header.Feed("t,u");
  header.Finish(CsvRowReader::LastLine::kDrop);
  ASSERT_TRUE(header.fatal());
  EXPECT_EQ(header.fatal()->ToString(),
            "run.csv:1: the header line is incomplete (no line end came before reading stopped): "
            "nothing was read");
}

TEST(Follow, ACrAtTheEndOfAPieceEndsItsLineAndTheLfAfterItEndsNone) {
  CsvRowReader reader("run.csv", kInputs, kOutputs);
  reader.Feed("t,u,y\r");
  EXPECT_TRUE(reader.header_seen());
  reader.Feed("\n0,1,2\r");
  std::vector<Sample> samples = reader.TakeSamples();
  ASSERT_EQ(samples.size(), 1u);
  EXPECT_EQ(samples[0].line, 2);
  reader.Feed("");
  reader.Feed("\n");
  reader.Feed("1,3,4\n");
  samples = reader.TakeSamples();
  ASSERT_EQ(samples.size(), 1u);
  EXPECT_EQ(samples[0].line, 3);
  EXPECT_TRUE(reader.TakeProblems().empty());
}

// ---------------------------------------------------------------------------------------------
// Follow: rows

TEST(Follow, MalformedRowsAreReportedByLineAndColumnAndSkipped) {
  const Read read = ReadWhole(
      "t,u,y,note\n"
      "0.5,1,10,a\n"
      "0.5,2\n"
      "1,abc,11,b\n"
      "1,3,1;5,c\n"
      "1,,12,d\n"
      ",4,13,e\n"
      "inf,4,13,e\n"
      "0.25,4,13,e\n"
      "1,5,\"14,x\n"
      "1,6,15,f,g\n"
      "1,7,16,\"h\"\n");
  ASSERT_EQ(read.samples.size(), 2u);
  ExpectSample(read.samples[0], 0.5, {1}, {10}, 2);
  ExpectSample(read.samples[1], 1, {7}, {16}, 12);

  const std::vector<std::string> expected = {
      "run.csv:3:3: line 3 has 2 fields, the header has 4; row skipped",
      "run.csv:4:2: in column 'u' (an input of the model), 'abc' is not a number; row skipped",
      "run.csv:5:3: in column 'y' (an output of the model), '1;5' is not a number; row skipped",
      "run.csv:6:2: input 'u' is missing (inputs must be given at every row); row skipped",
      "run.csv:7:1: the time is missing (every row needs a time); row skipped",
      "run.csv:8:1: time 'inf' is not finite; row skipped",
      "run.csv:9:1: time 0.25 does not increase (previous row, line 2, has 0.5); row skipped",
      "run.csv:10:3: field 3 opens a quote that is not closed on this line; row skipped",
      "run.csv:11:5: line 11 has 5 fields, the header has 4; row skipped",
  };
  ASSERT_EQ(read.problems.size(), expected.size());
  for (std::size_t i = 0; i < expected.size(); ++i) {
    EXPECT_EQ(read.problems[i].kind, ErrorKind::kInput);
    EXPECT_EQ(read.problems[i].ToString(), expected[i]);
  }
  EXPECT_FALSE(read.fatal);
}

TEST(Follow, EmptyNaAndNanOutputsAreMissingObservations) {
  const Read read =
      ReadWhole("t,u,y1,y2\n0,1,,NA\n1,2,nan,\"\"\n2,3,Na,4\n", kInputs, {"y1", "y2"});
  ASSERT_EQ(read.samples.size(), 3u);
  ExpectSample(read.samples[0], 0, {1}, {kNaN, kNaN}, 2);
  ExpectSample(read.samples[1], 1, {2}, {kNaN, kNaN}, 3);
  ExpectSample(read.samples[2], 2, {3}, {kNaN, 4}, 4);
  EXPECT_TRUE(read.problems.empty());
}

TEST(Follow, BindsColumnsByNameInTheModelsOrderAndIgnoresTheRest) {
  const Read read = ReadWhole("b\tdate\tTIME\ty\ta\n1\t2024-05-01\t0\t9\t2\n", {"a", "b"}, {"y"});
  ASSERT_EQ(read.samples.size(), 1u);
  ExpectSample(read.samples[0], 0, {2, 1}, {9}, 2);
  EXPECT_TRUE(read.problems.empty());
}

TEST(Follow, AModelWithoutInputsReadsOutputsOnly) {
  const Read read = ReadWhole("t;y\n0;1\n1;2\n", {}, kOutputs);
  ASSERT_EQ(read.samples.size(), 2u);
  EXPECT_TRUE(read.samples[1].u.empty());
  EXPECT_EQ(read.samples[1].y, (std::vector<double>{2}));
}

TEST(Follow, ALineLongerThanTheLimitIsReportedAndNotKept) {
  CsvRowReader reader("run.csv", kInputs, kOutputs);
  reader.Feed("t,u,y\n0,1,2\n");
  const std::string chunk(4096, '7');
  reader.Feed("# ");  // a comment this long is skipped silently
  for (std::size_t n = 0; n <= CsvRowReader::kMaxLineBytes; n += chunk.size()) reader.Feed(chunk);
  reader.Feed("\n1,");
  for (std::size_t n = 0; n <= CsvRowReader::kMaxLineBytes; n += chunk.size()) reader.Feed(chunk);
  reader.Feed(",3\n2,4,5\n");
  const std::vector<Sample> samples = reader.TakeSamples();
  ASSERT_EQ(samples.size(), 2u);
  EXPECT_EQ(samples[1].t, 2.0);
  EXPECT_EQ(samples[1].line, 5);
  const std::vector<Error> problems = reader.TakeProblems();
  ASSERT_EQ(problems.size(), 1u);
  EXPECT_EQ(problems[0].ToString(), "run.csv:4: line 4 is longer than 1048576 bytes; row skipped");
}

// ---------------------------------------------------------------------------------------------
// Follow: fatal headers, Restart

TEST(Follow, AHeaderThatCannotBeBoundIsFatalAndNothingMoreIsRead) {
  struct Case {
    std::string header;
    std::vector<std::string> inputs;
    std::string expected;
  };
  const std::vector<Case> cases = {
      {"t,u,y",
       {"mfi"},
       "run.csv:2: column 'mfi' (an input of the model) is not in the file; its columns are t, u, "
       "y"},
      {"t,u,z",
       {"u"},
       "run.csv:2: column 'y' (an output of the model) is not in the file; its columns are t, u, "
       "z"},
      {"t,u,y,u",
       {"u"},
       "run.csv:2:4: column 'u' (an input of the model) appears more than once in the header, as "
       "fields 2, 4"},
      {"a,u,y",
       {"u"},
       "run.csv:2: no time column: the header needs a column named 't' or 'time' (a unit may "
       "follow, as in 'time [ms]' or 't_s'); it has: a, u, y"},
      {"t,u,\"y",
       {"u"},
       "run.csv:2:3: in the header, field 3 opens a quote that is not closed on this line"},
  };
  for (const Case& c : cases) {
    CsvRowReader reader("run.csv", c.inputs, kOutputs);
    reader.Feed("# rig 4\n" + c.header + "\n0,1,2\n");
    ASSERT_TRUE(reader.fatal()) << c.header;
    EXPECT_FALSE(reader.header_seen());
    EXPECT_EQ(reader.fatal()->ToString(), c.expected);
    EXPECT_EQ(reader.fatal()->line, 2);
    reader.Feed("1,2,3\n");
    reader.Finish();
    EXPECT_TRUE(reader.TakeSamples().empty());
    EXPECT_TRUE(reader.TakeProblems().empty());
    EXPECT_EQ(reader.fatal()->ToString(), c.expected);
  }
}

TEST(Follow, FinishBeforeAHeaderIsFatal) {
  for (const auto& [text, expected] :
       {std::pair<std::string, std::string>{"", "it was empty"},
        {"\xEF\xBB\xBF\r\n  \n", "it was empty"},
        {"# nothing yet\n\n", "it held only comments and blank lines"}}) {
    CsvRowReader reader("<stdin>", kInputs, kOutputs);
    reader.Feed(text);
    EXPECT_FALSE(reader.fatal());
    reader.Finish();
    ASSERT_TRUE(reader.fatal());
    EXPECT_EQ(reader.fatal()->ToString(), "<stdin>: the input ended before a header: " + expected);
  }
}

TEST(Follow, RestartReadsANewHeaderAndTimesFromTheStart) {
  CsvRowReader reader("run.csv", kInputs, kOutputs);
  reader.Feed("t,u,y\n5,1,2\n6,3,");
  EXPECT_EQ(reader.TakeSamples().size(), 1u);
  reader.Restart();
  EXPECT_FALSE(reader.header_seen());
  reader.Feed("\xEF\xBB\xBFy;time;u\n7;0;8\n");  // another layout, and times from 0
  const std::vector<Sample> samples = reader.TakeSamples();
  ASSERT_EQ(samples.size(), 1u);
  ExpectSample(samples[0], 0, {8}, {7}, 2);
  EXPECT_TRUE(reader.TakeProblems().empty());

  // A fatal header is forgotten too.
  reader.Restart();
  reader.Feed("t,u\n");  // no y
  ASSERT_TRUE(reader.fatal());
  reader.Restart();
  EXPECT_FALSE(reader.fatal());
  reader.Feed("t,u,y\n1,2,3\n");
  EXPECT_EQ(reader.TakeSamples().size(), 1u);
}

// ---------------------------------------------------------------------------------------------
// FollowFile

namespace fs = std::filesystem;

// A path under the system's temporary folder, removed at the end of the test.
class ScratchFile {
 public:
  explicit ScratchFile(const std::string& name)
      : path_((fs::temp_directory_path() /
               ("greybench-follow-" + std::to_string(::getpid()) + "-" + name))
                  .string()) {
    fs::remove(path_);
  }
  ~ScratchFile() {
    std::error_code ignored;
    fs::remove(path_, ignored);
  }
  const std::string& path() const { return path_; }

 private:
  std::string path_;
};

void WriteFile(const std::string& path, std::string_view text,
               std::ios::openmode mode = std::ios::trunc) {
  std::ofstream out(path, std::ios::binary | mode);
  out << text;
}

std::string PollOrFail(FileFollower& follower) {
  Result<std::string> bytes = follower.Poll();
  EXPECT_TRUE(bytes.ok()) << bytes.error().ToString();
  return bytes.ok() ? *bytes : "";
}

TEST(FollowFile, OpeningAFileThatCannotBeFollowedNamesIt) {
  const ScratchFile absent("absent.csv");
  Result<FileFollower> r = FileFollower::Open(absent.path());
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().file, absent.path());
  EXPECT_EQ(r.error().message, "cannot open the file: No such file or directory");

  r = FileFollower::Open(fs::temp_directory_path().string());
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().message, "cannot follow the file: it is a folder");

  const ScratchFile fifo("fifo");
  ASSERT_EQ(::mkfifo(fifo.path().c_str(), 0600), 0);
  r = FileFollower::Open(fifo.path());
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("not a regular file"), std::string::npos);
}

TEST(FollowFile, PollReturnsTheBytesAppendedSinceTheLastCall) {
  const ScratchFile file("appended.csv");
  WriteFile(file.path(), "t,u,y\n0,1");
  Result<FileFollower> follower = FileFollower::Open(file.path());
  ASSERT_TRUE(follower.ok()) << follower.error().ToString();
  EXPECT_EQ(PollOrFail(*follower), "t,u,y\n0,1");
  EXPECT_EQ(PollOrFail(*follower), "");
  WriteFile(file.path(), ",2\n", std::ios::app);
  EXPECT_EQ(PollOrFail(*follower), ",2\n");
  EXPECT_EQ(PollOrFail(*follower), "");
  EXPECT_FALSE(follower->TakeNote());
}

// Rows k = 0..kRows-1 of t = k/8, u = k/2 - 3, y = k/4 (NA every 7th row), all exact in binary;
// the row at kBadRow has the time "x".
constexpr int kRows = 120;
constexpr int kBadRow = 60;

std::string WriterText() {
  std::string text = "# written while it is read\nt,u,y\n";
  for (int k = 0; k < kRows; ++k) {
    if (k == kBadRow) {
      text += "x,1,2\n";
    } else if (k % 7 == 3) {
      text += fmt::format("{},{},NA\n", k / 8.0, k / 2.0 - 3);
    } else {
      text += fmt::format("{},{},{}\n", k / 8.0, k / 2.0 - 3, k / 4.0);
    }
  }
  return text;
}

TEST(FollowFile, AWriterAppendingInPiecesThatEndMidLineLosesNoRowAndDuplicatesNone) {
  const ScratchFile file("written.csv");
  WriteFile(file.path(), "");
  Result<FileFollower> follower = FileFollower::Open(file.path());
  ASSERT_TRUE(follower.ok()) << follower.error().ToString();

  const std::string text = WriterText();
  const std::size_t pause_at = text.find("\n6.5,") + 3;  // mid-line, half way
  std::atomic<bool> written{false};
  std::thread writer([&] {
    const int fd = ::open(file.path().c_str(), O_WRONLY | O_APPEND);
    const std::size_t sizes[] = {5, 17, 3, 29, 11};
    std::size_t from = 0;
    for (int i = 0; from < text.size(); ++i) {
      std::size_t to = std::min(text.size(), from + sizes[i % 5]);
      if (from < pause_at && to > pause_at) to = pause_at;
      const ssize_t n = ::write(fd, text.data() + from, to - from);
      from += n > 0 ? static_cast<std::size_t>(n) : 0;
      std::this_thread::sleep_for(std::chrono::milliseconds(from == pause_at ? 200 : 2));
    }
    ::close(fd);
    written = true;
  });

  CsvRowReader reader(file.path(), kInputs, kOutputs);
  std::vector<Sample> samples;
  std::vector<Error> problems;
  int polls_ending_mid_line = 0;
  for (bool last = false; !last;) {
    last = written;  // one more poll after the writer is done
    const std::string bytes = PollOrFail(*follower);
    polls_ending_mid_line += !bytes.empty() && bytes.back() != '\n';
    reader.Feed(bytes);
    for (Sample& s : reader.TakeSamples()) samples.push_back(std::move(s));
    for (Error& e : reader.TakeProblems()) problems.push_back(std::move(e));
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  writer.join();

  EXPECT_GT(polls_ending_mid_line, 0);
  EXPECT_FALSE(follower->TakeNote());
  EXPECT_FALSE(reader.fatal());
  ASSERT_EQ(samples.size(), static_cast<std::size_t>(kRows - 1));
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const int k = static_cast<int>(i) + (static_cast<int>(i) >= kBadRow ? 1 : 0);
    ExpectSample(samples[i], k / 8.0, {k / 2.0 - 3}, {k % 7 == 3 ? kNaN : k / 4.0}, k + 3);
  }
  ASSERT_EQ(problems.size(), 1u);
  EXPECT_EQ(problems[0].ToString(), fmt::format("{}:{}:1: time 'x' is not a number; row skipped",
                                                file.path(), kBadRow + 3));
}

TEST(FollowFile, ATruncatedFileIsReadAgainFromTheStart) {
  const ScratchFile file("truncated.csv");
  WriteFile(file.path(), "t,u,y\n0,1,2\n1,3,4\n");
  Result<FileFollower> follower = FileFollower::Open(file.path());
  ASSERT_TRUE(follower.ok()) << follower.error().ToString();
  CsvRowReader reader(file.path(), kInputs, kOutputs);
  reader.Feed(PollOrFail(*follower));
  EXPECT_EQ(reader.TakeSamples().size(), 2u);

  WriteFile(file.path(), "t,y,u\n0,5,6\n");  // the same file, shorter
  const std::string bytes = PollOrFail(*follower);
  const std::optional<std::string> note = follower->TakeNote();
  ASSERT_TRUE(note);
  EXPECT_EQ(*note,
            file.path() + " was truncated (from 18 to 12 bytes); reading it again from the start");
  EXPECT_FALSE(follower->TakeNote());
  EXPECT_EQ(bytes, "t,y,u\n0,5,6\n");
  reader.Restart();
  reader.Feed(bytes);
  const std::vector<Sample> samples = reader.TakeSamples();
  ASSERT_EQ(samples.size(), 1u);
  ExpectSample(samples[0], 0, {6}, {5}, 2);
  EXPECT_TRUE(reader.TakeProblems().empty());
}

TEST(FollowFile, AReplacedFileIsReadToItsEndAndThenTheNewOneFromTheStart) {
  const ScratchFile file("replaced.csv");
  const ScratchFile next("replaced.csv.new");
  WriteFile(file.path(), "t,u,y\n0,1,2\n");
  Result<FileFollower> follower = FileFollower::Open(file.path());
  ASSERT_TRUE(follower.ok()) << follower.error().ToString();
  EXPECT_EQ(PollOrFail(*follower), "t,u,y\n0,1,2\n");

  WriteFile(file.path(), "1,3,4\n", std::ios::app);  // the old file's last row
  WriteFile(next.path(), "t,u,y\n0,5,6\n1,7,8\n2,9,10\n");
  fs::rename(next.path(), file.path());
  EXPECT_EQ(PollOrFail(*follower), "1,3,4\n");
  EXPECT_FALSE(follower->TakeNote());
  EXPECT_EQ(PollOrFail(*follower), "t,u,y\n0,5,6\n1,7,8\n2,9,10\n");
  const std::optional<std::string> note = follower->TakeNote();
  ASSERT_TRUE(note);
  EXPECT_EQ(*note, file.path() + " was replaced by a new file; reading it from the start");
  EXPECT_EQ(PollOrFail(*follower), "");
}

TEST(FollowFile, AFileLargerThanOnePollIsReadInPieces) {
  const ScratchFile file("large.csv");
  WriteFile(file.path(), std::string(FileFollower::kMaxPollBytes + 10, '#'));
  Result<FileFollower> follower = FileFollower::Open(file.path());
  ASSERT_TRUE(follower.ok()) << follower.error().ToString();
  EXPECT_EQ(PollOrFail(*follower).size(), FileFollower::kMaxPollBytes);
  EXPECT_EQ(PollOrFail(*follower).size(), 10u);
  EXPECT_EQ(PollOrFail(*follower).size(), 0u);
}

TEST(FollowFile, ReadSomeReadsAPipeUntilItsEnd) {
  int fds[2];
  ASSERT_EQ(::pipe(fds), 0);
  ASSERT_EQ(::write(fds[1], "t,y\n0,", 6), 6);
  Result<std::string> bytes = ReadSome(fds[0]);
  ASSERT_TRUE(bytes.ok()) << bytes.error().ToString();
  EXPECT_EQ(*bytes, "t,y\n0,");
  ::close(fds[1]);
  bytes = ReadSome(fds[0]);
  ASSERT_TRUE(bytes.ok()) << bytes.error().ToString();
  EXPECT_EQ(*bytes, "");
  ::close(fds[0]);

  bytes = ReadSome(fds[0], "<stdin>");  // closed
  ASSERT_FALSE(bytes.ok());
  EXPECT_EQ(bytes.error().ToString(), "<stdin>: cannot read the input: Bad file descriptor");
}

}  // namespace
}  // namespace gb::data
