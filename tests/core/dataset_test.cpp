// Tests of core/data: reading CSV (csv.cpp), grouping intervals and binding (bind.cpp).
//
// Contents
//   Helpers
//   Csv        layouts that are accepted, cells, errors with their line and column
//   Dataset    Find
//   Intervals  GroupIntervals
//   Bind       layout of U and Y, errors
//   Building3  the CTSM-R conformance data
#include "core/data/dataset.h"

#include <algorithm>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include <gtest/gtest.h>

namespace gb::data {
namespace {

// ---------------------------------------------------------------------------------------------
// Helpers

std::shared_ptr<const Dataset> Parse(std::string_view text) {
  Result<std::shared_ptr<const Dataset>> r = ParseCsv(text, "run.csv");
  EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.error().ToString());
  return r.ok() ? *r : nullptr;
}

Error ParseError(std::string_view text) {
  Result<std::shared_ptr<const Dataset>> r = ParseCsv(text, "run.csv");
  EXPECT_FALSE(r.ok()) << "expected an error for:\n" << text;
  return r.ok() ? Error{} : r.error();
}

const Column& ColumnNamed(const Dataset& d, std::string_view name) {
  const int i = d.Find(name);
  EXPECT_GE(i, 0) << name;
  return d.columns.at(static_cast<std::size_t>(std::max(i, 0)));
}

std::string TestData(const std::string& relative) {
  return std::string(GREYBENCH_TEST_DATA_DIR) + "/" + relative;
}

Error BindError(const Dataset& d, std::vector<std::string> inputs,
                std::vector<std::string> outputs) {
  Result<std::shared_ptr<const Series>> r = Bind(d, inputs, outputs);
  EXPECT_FALSE(r.ok());
  return r.ok() ? Error{} : r.error();
}

// ---------------------------------------------------------------------------------------------
// Csv: accepted layouts

TEST(Csv, ReadsQuotedHeaderLikeCtsmrFiles) {
  auto d = Parse("\"t\",\"Ps\",\"Ta\",\"Thm\",\"yTi\"\n0,0,7.6,0,17.9\n0.25,1,7.5,0,17.8\n");
  ASSERT_TRUE(d);
  EXPECT_EQ(d->header_line, 1);
  EXPECT_EQ(d->time_name, "t");
  EXPECT_EQ(d->time_field, 1);
  ASSERT_EQ(d->columns.size(), 4u);
  EXPECT_EQ(d->columns[0].name, "Ps");
  EXPECT_EQ(d->columns[3].name, "yTi");
  EXPECT_EQ(d->columns[3].field, 5);
  EXPECT_EQ(d->time, (std::vector<double>{0, 0.25}));
  EXPECT_EQ(d->columns[1].values, (std::vector<double>{7.6, 7.5}));
}

TEST(Csv, AcceptsSemicolonSeparatorAndCrlf) {
  auto d = Parse("t;u;y\r\n0;1;2\r\n1;3;4\r\n");
  ASSERT_TRUE(d);
  EXPECT_EQ(d->rows(), 2u);
  EXPECT_EQ(d->row_line, (std::vector<int>{2, 3}));
  EXPECT_EQ(ColumnNamed(*d, "y").values, (std::vector<double>{2, 4}));
}

TEST(Csv, AcceptsTabSeparator) {
  auto d = Parse("t\tu\ty\n0\t1\t2\n1\t 3 \t4\n");
  ASSERT_TRUE(d);
  EXPECT_EQ(ColumnNamed(*d, "u").values, (std::vector<double>{1, 3}));
  EXPECT_EQ(ColumnNamed(*d, "y").values, (std::vector<double>{2, 4}));
}

TEST(Csv, AcceptsCrOnlyLineEnds) {
  auto d = Parse("t,y\r0,1\r\r1,2\r");
  ASSERT_TRUE(d);
  EXPECT_EQ(d->time, (std::vector<double>{0, 1}));
  EXPECT_EQ(d->row_line, (std::vector<int>{2, 4}));
}

TEST(Csv, SkipsUtf8ByteOrderMark) {
  auto d = Parse("\xEF\xBB\xBFt,y\n0,1\n1,2\n");
  ASSERT_TRUE(d);
  EXPECT_EQ(d->time_name, "t");
  EXPECT_EQ(d->time_field, 1);
}

TEST(Csv, SkipsCommentsAndBlankLines) {
  auto d = Parse("# a comment\n\n   \n  # indented comment\nt,y\n0,1\n\n# between rows\n1,2\n");
  ASSERT_TRUE(d);
  EXPECT_EQ(d->header_line, 5);
  EXPECT_EQ(d->row_line, (std::vector<int>{6, 9}));
}

TEST(Csv, FindsTimeColumnNamedTimeAnywhereIgnoringCase) {
  auto d = Parse("y,Time,t\n1,0,5\n2,1,4\n");
  ASSERT_TRUE(d);
  EXPECT_EQ(d->time_name, "Time");
  EXPECT_EQ(d->time_field, 2);
  // Only the first time-like column is the time; a later 't' is an ordinary column.
  EXPECT_EQ(ColumnNamed(*d, "t").values, (std::vector<double>{5, 4}));
  EXPECT_EQ(ColumnNamed(*d, "t").field, 3);
}

TEST(Csv, TrimsSpacesAroundFieldsAndNames) {
  auto d = Parse("  t ,  \"y\"  \n 0 ,  1.5\n1,2  \n");
  ASSERT_TRUE(d);
  EXPECT_EQ(d->time_name, "t");
  EXPECT_EQ(ColumnNamed(*d, "y").values, (std::vector<double>{1.5, 2}));
}

TEST(Csv, ReadsDecimalNumbersInEveryForm) {
  auto d = Parse("t,a,b,c,d,e,f\n0,+2,-1.5,.5,5.,1e-3,-2.5E+2\n1,\"3\",0,1e-400,0,0,0\n");
  ASSERT_TRUE(d);
  EXPECT_EQ(ColumnNamed(*d, "a").values, (std::vector<double>{2, 3}));
  EXPECT_EQ(ColumnNamed(*d, "b").values[0], -1.5);
  EXPECT_EQ(ColumnNamed(*d, "c").values, (std::vector<double>{0.5, 0}));  // 1e-400 underflows
  EXPECT_EQ(ColumnNamed(*d, "d").values[0], 5.0);
  EXPECT_EQ(ColumnNamed(*d, "e").values[0], 0.001);
  EXPECT_EQ(ColumnNamed(*d, "f").values[0], -250.0);
  for (const Column& c : d->columns) EXPECT_EQ(c.bad_line, 0) << c.name;
}

TEST(Csv, ReadsMissingMarkersAsNaN) {
  auto d = Parse("t,y\n0,1\n1,\n2,NA\n3,na\n4,NaN\n5,nan\n6,\"NA\"\n7,2\n");
  ASSERT_TRUE(d);
  const Column& y = ColumnNamed(*d, "y");
  EXPECT_EQ(y.n_missing, 6);
  EXPECT_EQ(y.first_missing_line, 3);
  EXPECT_EQ(y.bad_line, 0);
  for (std::size_t k = 1; k <= 6; ++k) EXPECT_TRUE(std::isnan(y.values[k])) << k;
  EXPECT_EQ(y.values[0], 1.0);
  EXPECT_EQ(y.values[7], 2.0);
}

TEST(Csv, RecordsFirstNonNumberCellWithoutFailing) {
  auto d = Parse(
      "t;dots;comma;hex;inf;word;plusminus;space;huge\n"
      "0;1;2;3;4;5;6;7;8\n"
      "1;1.2.3;1,5;0x10;inf;abc;+-1;1 2;1e999\n"
      "2;x;x;x;x;x;x;x;x\n");
  ASSERT_TRUE(d);
  const std::vector<std::string> expected = {"1.2.3", "1,5", "0x10", "inf",
                                             "abc",   "+-1", "1 2",  "1e999"};
  ASSERT_EQ(d->columns.size(), expected.size());
  for (std::size_t i = 0; i < expected.size(); ++i) {
    const Column& c = d->columns[i];
    EXPECT_EQ(c.bad_line, 3) << c.name;
    EXPECT_EQ(c.bad_text, expected[i]) << c.name;
    EXPECT_EQ(c.values[0], static_cast<double>(i + 1)) << c.name;
    EXPECT_TRUE(std::isnan(c.values[1])) << c.name;
    EXPECT_EQ(c.n_missing, 0) << c.name;
  }
}

TEST(Csv, ExplainsWhyACellIsNotANumber) {
  EXPECT_EQ(NotANumberReason("abc"), "'abc' is not a number");
  EXPECT_EQ(NotANumberReason("+-1"), "'+-1' is not a number");
  EXPECT_EQ(NotANumberReason("1,5"), "'1,5' is not a number (the decimal point must be '.')");
  EXPECT_EQ(NotANumberReason("inf"), "'inf' is not finite");
  EXPECT_EQ(NotANumberReason("-1e999"), "'-1e999' is not finite");
}

TEST(Csv, UnescapesDoubledQuotesAndKeepsSeparatorsInsideQuotes) {
  auto d = Parse("t,\"say \"\"hi\"\"\",\"a,b\"\n0,1,2\n1,\"x\"\"y\",\"3\"\n");
  ASSERT_TRUE(d);
  ASSERT_EQ(d->columns.size(), 2u);
  EXPECT_EQ(d->columns[0].name, "say \"hi\"");
  EXPECT_EQ(d->columns[0].bad_text, "x\"y");
  EXPECT_EQ(d->columns[1].name, "a,b");
  EXPECT_EQ(d->columns[1].values, (std::vector<double>{2, 3}));
}

TEST(Csv, KeepsUnnamedAndDuplicatedColumns) {
  // R's write.csv writes an unnamed row-number column first.
  auto d = Parse("\"\",\"t\",\"y\",\"y\"\n\"1\",0,1,2\n\"2\",1,3,4\n");
  ASSERT_TRUE(d);
  ASSERT_EQ(d->columns.size(), 3u);
  EXPECT_EQ(d->columns[0].name, "");
  EXPECT_EQ(d->columns[0].values, (std::vector<double>{1, 2}));
  EXPECT_EQ(d->time_field, 2);
}

TEST(Csv, ReadsFileWithByteOrderMarkCommentsAndQuotes) {
  auto r = ReadCsvFile(TestData("csv/quoted_bom_comments.csv"));
  ASSERT_TRUE(r.ok()) << r.error().ToString();
  const Dataset& d = **r;
  EXPECT_EQ(d.source, TestData("csv/quoted_bom_comments.csv"));
  EXPECT_EQ(d.header_line, 4);
  EXPECT_EQ(d.time_name, "time");
  EXPECT_EQ(d.time, (std::vector<double>{0, 0.5, 1}));
  EXPECT_EQ(d.row_line, (std::vector<int>{5, 6, 9}));
  const Column& ti = ColumnNamed(d, "Ti");
  EXPECT_EQ(ti.n_missing, 1);
  EXPECT_EQ(ti.first_missing_line, 6);
  const Column& note = ColumnNamed(d, "note");
  EXPECT_EQ(note.bad_line, 5);
  EXPECT_EQ(note.bad_text, "start");
}

TEST(Csv, ReadsSemicolonCrlfFile) {
  auto r = ReadCsvFile(TestData("csv/semicolon_crlf.csv"));
  ASSERT_TRUE(r.ok()) << r.error().ToString();
  EXPECT_EQ((*r)->time, (std::vector<double>{0, 1, 2}));
  EXPECT_EQ((*r)->row_line, (std::vector<int>{2, 3, 4}));
  EXPECT_EQ(ColumnNamed(**r, "u").bad_text, "1,5");  // a decimal comma is not a number
}

// ---------------------------------------------------------------------------------------------
// Csv: errors

TEST(Csv, RejectsRowWithTooFewFields) {
  const Error e = ParseError("t,a,b,c\n0,1,2,3\n1,2,3,4\n# x\n2,3,4,5\n\n3,4,5\n");
  EXPECT_EQ(e.kind, ErrorKind::kInput);
  EXPECT_EQ(e.file, "run.csv");
  EXPECT_EQ(e.line, 7);
  EXPECT_EQ(e.col, 4);
  EXPECT_EQ(e.message, "line 7 has 3 fields, the header has 4");
  EXPECT_EQ(e.ToString(), "run.csv:7:4: line 7 has 3 fields, the header has 4");
}

TEST(Csv, RejectsRowWithTooManyFields) {
  const Error e = ParseError("t,a\n0,1\n1,2,\n");
  EXPECT_EQ(e.line, 3);
  EXPECT_EQ(e.col, 3);
  EXPECT_EQ(e.message, "line 3 has 3 fields, the header has 2");
}

TEST(Csv, RejectsHeaderWithoutTimeColumn) {
  const Error e = ParseError("# c\na,b\n0,1\n");
  EXPECT_EQ(e.line, 2);
  EXPECT_EQ(e.col, 0);
  EXPECT_EQ(e.message,
            "no time column: the header needs a column named 't' or 'time' (a unit may follow, as "
            "in 'time [ms]' or 't_s'); it has: a, b");
}

TEST(Csv, RejectsMissingTime) {
  const Error e = ParseError("y,t\n1,0\n2,NA\n");
  EXPECT_EQ(e.line, 3);
  EXPECT_EQ(e.col, 2);
  EXPECT_NE(e.message.find("time is missing"), std::string::npos) << e.message;
}

TEST(Csv, RejectsTimeThatIsNotANumber) {
  const Error e = ParseError("t,y\n0,1\n2024-01-01,2\n");
  EXPECT_EQ(e.line, 3);
  EXPECT_EQ(e.col, 1);
  EXPECT_EQ(e.message, "time '2024-01-01' is not a number");
}

TEST(Csv, RejectsTimeThatIsNotFinite) {
  const Error e = ParseError("t,y\n0,1\n\n-inf,2\n");
  EXPECT_EQ(e.line, 4);
  EXPECT_EQ(e.col, 1);
  EXPECT_EQ(e.message, "time '-inf' is not finite");
}

TEST(Csv, RejectsTimeThatRepeats) {
  const Error e = ParseError("t,y\n0,1\n0.25,2\n# c\n0.25,3\n");
  EXPECT_EQ(e.line, 5);
  EXPECT_EQ(e.col, 1);
  EXPECT_EQ(e.message, "time 0.25 does not increase (previous row, line 3, has 0.25)");
}

TEST(Csv, RejectsTimeThatDecreases) {
  const Error e = ParseError("y;time\n1;0\n2;1.5\n3;1\n");
  EXPECT_EQ(e.line, 4);
  EXPECT_EQ(e.col, 2);
  EXPECT_EQ(e.message, "time 1 does not increase (previous row, line 3, has 1.5)");
}

TEST(Csv, RejectsEmptyFile) {
  for (std::string_view text : {"", "\xEF\xBB\xBF", "\n\r\n  \n"}) {
    const Error e = ParseError(text);
    EXPECT_EQ(e.file, "run.csv");
    EXPECT_EQ(e.line, 0);
    EXPECT_EQ(e.message, "the file is empty");
  }
}

TEST(Csv, RejectsFileWithOnlyComments) {
  const Error e = ParseError("# nothing\n\n# here\n");
  EXPECT_EQ(e.line, 0);
  EXPECT_EQ(e.message, "the file has no header: it holds only comments and blank lines");
}

TEST(Csv, RejectsHeaderWithoutRows) {
  const Error e = ParseError("# c\nt,y\n\n# no rows\n");
  EXPECT_EQ(e.line, 2);
  EXPECT_EQ(e.message, "the file has a header but no data rows");
}

TEST(Csv, RejectsUnterminatedQuote) {
  const Error e = ParseError("t,y,note\n0,1,\"ok\"\n1,2,\"not closed\n");
  EXPECT_EQ(e.line, 3);
  EXPECT_EQ(e.col, 3);
  EXPECT_EQ(e.message, "field 3 opens a quote that is not closed on this line");
}

TEST(Csv, RejectsUnterminatedQuoteInHeader) {
  const Error e = ParseError("t,\"y\n0,1\n");
  EXPECT_EQ(e.line, 1);
  EXPECT_EQ(e.col, 2);
  EXPECT_EQ(e.message, "in the header, field 2 opens a quote that is not closed on this line");
}

TEST(Csv, RejectsTextAfterClosingQuote) {
  const Error e = ParseError("t,y\n0,\"1\"2\n");
  EXPECT_EQ(e.line, 2);
  EXPECT_EQ(e.col, 2);
  EXPECT_EQ(e.message, "field 2 has text after its closing quote");
}

// Found by review for tests/fuzz/csv_fuzz: columns reserved one slot per line of the file, so a
// 1.2 MB file with a wide header over blank lines asked for 100k x 1M doubles (800 GB) and died.
TEST(Csv, WideHeaderOverManyBlankLinesReadsWithoutHugeReservation) {
  std::string text = "t" + std::string(100'000, ',') + "\n" + std::string(1'000'000, '\n');
  text += "0" + std::string(100'000, ',') + "\n";
  const auto d = Parse(text);
  ASSERT_TRUE(d);
  EXPECT_EQ(d->rows(), 1u);
  EXPECT_EQ(d->columns.size(), 100'000u);
  EXPECT_TRUE(std::isnan(d->columns.back().values[0]));
}

TEST(Csv, ReportsFileThatCannotBeRead) {
  const std::string path = TestData("csv/does_not_exist.csv");
  auto r = ReadCsvFile(path);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().kind, ErrorKind::kInput);
  EXPECT_EQ(r.error().file, path);
  EXPECT_EQ(r.error().line, 0);
  EXPECT_NE(r.error().message.find("cannot read the file"), std::string::npos);
  EXPECT_NE(r.error().message.find("No such file"), std::string::npos) << r.error().message;
}

TEST(Csv, ReportsDirectoryAsUnreadable) {
  auto r = ReadCsvFile(TestData("csv"));
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().file, TestData("csv"));
  EXPECT_NE(r.error().message.find("cannot read the file"), std::string::npos);
}

// ---------------------------------------------------------------------------------------------
// Dataset

TEST(Dataset, FindReturnsIndexOrMinusOneOrMinusTwoForDuplicates) {
  auto d = Parse("a,t,b,a\n1,0,2,3\n");
  ASSERT_TRUE(d);
  EXPECT_EQ(d->Find("b"), 1);
  EXPECT_EQ(d->Find("a"), -2);
  EXPECT_EQ(d->Find("c"), -1);
  EXPECT_EQ(d->Find("t"), -1);  // the time column is not among `columns`
  EXPECT_EQ(d->Find("B"), -1);  // names are case-sensitive
}

// ---------------------------------------------------------------------------------------------
// Intervals

TEST(Intervals, UniformSamplingGivesOneGroup) {
  std::vector<double> t(1000);
  for (std::size_t k = 0; k < t.size(); ++k) t[k] = 0.25 * static_cast<double>(k);
  const Intervals iv = GroupIntervals(t);
  EXPECT_EQ(iv.distinct, (std::vector<double>{0.25}));
  EXPECT_EQ(iv.group, std::vector<int>(999, 0));
}

TEST(Intervals, AccumulatedRoundingStaysInOneGroup) {
  // 0.1 is not exact in binary: successive differences of a running sum vary in the last bits.
  std::vector<double> t = {0};
  for (int k = 0; k < 10000; ++k) t.push_back(t.back() + 0.1);
  const Intervals iv = GroupIntervals(t);
  ASSERT_EQ(iv.distinct.size(), 1u);
  EXPECT_EQ(iv.distinct[0], t[1] - t[0]);
}

TEST(Intervals, IrregularSamplingGroupsEqualIntervalsInOrderOfFirstUse) {
  const std::vector<double> t = {0, 1, 2, 4, 5, 5.5, 7.5, 8.5, 9};
  const Intervals iv = GroupIntervals(t);
  EXPECT_EQ(iv.distinct, (std::vector<double>{1, 2, 0.5}));
  EXPECT_EQ(iv.group, (std::vector<int>{0, 0, 1, 0, 2, 1, 0, 2}));
}

TEST(Intervals, NearlyEqualIntervalsShareTheFirstMembersValue) {
  const double h = 0.3;
  const double close = h * (1 + 1e-13);
  const double apart = h * (1 + 1e-9);
  const std::vector<double> t = {10, 10 + h, 10 + h + close, 10 + h + close + apart};
  const Intervals iv = GroupIntervals(t);
  ASSERT_EQ(iv.distinct.size(), 2u);
  EXPECT_EQ(iv.distinct[0], t[1] - t[0]);
  EXPECT_EQ(iv.distinct[1], t[3] - t[2]);
  EXPECT_EQ(iv.group, (std::vector<int>{0, 0, 1}));
}

TEST(Intervals, ManyDistinctIntervalsMatchABruteForceGrouping) {
  // Intervals cycle through 300 values that are each repeated, with tiny perturbations.
  std::vector<double> t = {0};
  for (int k = 0; k < 3000; ++k) {
    const double base = 1.0 + 0.01 * ((k * 37) % 300);
    const double wobble = (k % 3 == 0 ? 1e-14 : (k % 3 == 1 ? -1e-14 : 0.0)) * base;
    t.push_back(t.back() + base + wobble);
  }
  const Intervals iv = GroupIntervals(t);
  // Brute force: scan the groups in creation order, open a new one when none matches.
  std::vector<double> distinct;
  std::vector<int> group;
  for (std::size_t k = 0; k + 1 < t.size(); ++k) {
    const double dt = t[k + 1] - t[k];
    int g = -1;
    for (std::size_t j = 0; j < distinct.size() && g < 0; ++j) {
      if (std::abs(dt - distinct[j]) < Intervals::kIntervalRelTol * distinct[j]) {
        g = static_cast<int>(j);
      }
    }
    if (g < 0) {
      g = static_cast<int>(distinct.size());
      distinct.push_back(dt);
    }
    group.push_back(g);
  }
  EXPECT_EQ(distinct.size(), 300u);
  EXPECT_EQ(iv.distinct, distinct);
  EXPECT_EQ(iv.group, group);
}

TEST(Intervals, FewerThanTwoTimesGiveNoIntervals) {
  EXPECT_TRUE(GroupIntervals(std::vector<double>{}).group.empty());
  EXPECT_TRUE(GroupIntervals(std::vector<double>{3.0}).distinct.empty());
}

// ---------------------------------------------------------------------------------------------
// Bind

TEST(Bind, LaysOutInputsAndOutputsOneSamplePerColumn) {
  auto d = Parse("t,y2,u1,y1,u2\n0,10,1,100,-1\n0.5,20,2,200,-2\n1.5,30,3,300,-3\n");
  ASSERT_TRUE(d);
  const std::vector<std::string> inputs = {"u1", "u2"};
  const std::vector<std::string> outputs = {"y1", "y2"};
  auto r = Bind(*d, inputs, outputs);
  ASSERT_TRUE(r.ok()) << r.error().ToString();
  const Series& s = **r;
  EXPECT_EQ(s.source, "run.csv");
  EXPECT_EQ(s.size(), 3u);
  EXPECT_EQ(s.time, (std::vector<double>{0, 0.5, 1.5}));
  ASSERT_EQ(s.U.rows(), 2);
  ASSERT_EQ(s.U.cols(), 3);
  ASSERT_EQ(s.Y.rows(), 2);
  ASSERT_EQ(s.Y.cols(), 3);
  for (int k = 0; k < 3; ++k) {
    EXPECT_EQ(s.U(0, k), k + 1.0);
    EXPECT_EQ(s.U(1, k), -(k + 1.0));
    EXPECT_EQ(s.Y(0, k), 100.0 * (k + 1));
    EXPECT_EQ(s.Y(1, k), 10.0 * (k + 1));
    // One sample's inputs are contiguous in memory.
    EXPECT_EQ(s.U.col(k).data() + 1, &s.U(1, k));
  }
  EXPECT_EQ(s.intervals.distinct, (std::vector<double>{0.5, 1}));
  EXPECT_EQ(s.intervals.group, (std::vector<int>{0, 1}));
}

TEST(Bind, IgnoresExtraColumnsAndUnboundTextColumns) {
  auto d = Parse("date,t,u,comment,y,spare\n2024-01-01,0,1,hello,2,x\n2024-01-02,1,3,,4,\n");
  ASSERT_TRUE(d);
  auto r = Bind(*d, std::vector<std::string>{"u"}, std::vector<std::string>{"y"});
  ASSERT_TRUE(r.ok()) << r.error().ToString();
  EXPECT_EQ((*r)->U(0, 1), 3.0);
  EXPECT_EQ((*r)->Y(0, 1), 4.0);
}

TEST(Bind, AllowsNoInputs) {
  auto d = Parse("t,y\n0,1\n1,2\n");
  ASSERT_TRUE(d);
  auto r = Bind(*d, {}, std::vector<std::string>{"y"});
  ASSERT_TRUE(r.ok()) << r.error().ToString();
  EXPECT_EQ((*r)->U.rows(), 0);
  EXPECT_EQ((*r)->U.cols(), 2);
}

TEST(Bind, MissingOutputsBecomeNaN) {
  auto d = Parse("t,u,y\n0,1,NA\n1,2,5\n2,3,\n");
  ASSERT_TRUE(d);
  auto r = Bind(*d, std::vector<std::string>{"u"}, std::vector<std::string>{"y"});
  ASSERT_TRUE(r.ok()) << r.error().ToString();
  EXPECT_TRUE(std::isnan((*r)->Y(0, 0)));
  EXPECT_EQ((*r)->Y(0, 1), 5.0);
  EXPECT_TRUE(std::isnan((*r)->Y(0, 2)));
  EXPECT_TRUE((*r)->U.allFinite());
}

TEST(Bind, RejectsMissingInputAtItsLineAndColumn) {
  auto d = Parse("t,u1,y,u2\n0,1,1,1\n1,2,2,NA\n2,,3,\n3,4,4,4\n");
  ASSERT_TRUE(d);
  const Error e = BindError(*d, {"u1", "u2"}, {"y"});
  EXPECT_EQ(e.file, "run.csv");
  EXPECT_EQ(e.line, 3);
  EXPECT_EQ(e.col, 4);
  EXPECT_EQ(e.message,
            "input 'u2' is missing at line 3; inputs must be given at every row (3 input cells are "
            "missing in all)");
}

TEST(Bind, RejectsAbsentColumnListingTheFilesColumns) {
  auto d = Parse("# c\nt,u,y\n0,1,2\n1,2,3\n");
  ASSERT_TRUE(d);
  const Error e = BindError(*d, {"mfi"}, {"y"});
  EXPECT_EQ(e.line, 2);
  EXPECT_EQ(e.col, 0);
  EXPECT_EQ(e.message,
            "column 'mfi' (an input of the model) is not in the file; its columns are t, u, y");
  auto late_time = Parse("u,y,time\n1,2,0\n2,3,1\n");
  ASSERT_TRUE(late_time);
  const Error out = BindError(*late_time, {"u"}, {"Y"});
  EXPECT_EQ(out.message,
            "column 'Y' (an output of the model) is not in the file; its columns are u, y, time");
}

TEST(Bind, RejectsTheTimeColumnAsAnInput) {
  auto d = Parse("t,y\n0,1\n1,2\n");
  ASSERT_TRUE(d);
  const Error e = BindError(*d, {"t"}, {"y"});
  EXPECT_EQ(e.line, 1);
  EXPECT_EQ(e.col, 1);
  EXPECT_NE(e.message.find("is the time column"), std::string::npos) << e.message;
}

TEST(Bind, RejectsDuplicatedColumn) {
  auto d = Parse("t,y,u,y\n0,1,2,3\n1,2,3,4\n");
  ASSERT_TRUE(d);
  const Error e = BindError(*d, {"u"}, {"y"});
  EXPECT_EQ(e.line, 1);
  EXPECT_EQ(e.col, 4);
  EXPECT_EQ(e.message,
            "column 'y' (an output of the model) appears more than once in the header, as fields "
            "2, 4");
}

TEST(Bind, RejectsNonNumberInBoundOutputAtItsLineAndColumn) {
  auto d = Parse("t,u,y\n0,1,2\n\n1,2,3.4.5\n2,3,oops\n");
  ASSERT_TRUE(d);
  const Error e = BindError(*d, {"u"}, {"y"});
  EXPECT_EQ(e.line, 4);
  EXPECT_EQ(e.col, 3);
  EXPECT_EQ(e.message, "in column 'y' (an output of the model), '3.4.5' is not a number");
}

TEST(Bind, RejectsNonNumberInBoundInputBeforeMissingInputs) {
  auto r = ReadCsvFile(TestData("csv/semicolon_crlf.csv"));
  ASSERT_TRUE(r.ok()) << r.error().ToString();
  const Error e = BindError(**r, {"u"}, {"y"});
  EXPECT_EQ(e.file, TestData("csv/semicolon_crlf.csv"));
  EXPECT_EQ(e.line, 2);
  EXPECT_EQ(e.col, 2);
  EXPECT_EQ(e.message,
            "in column 'u' (an input of the model), '1,5' is not a number (the decimal point must "
            "be '.')");
}

TEST(Bind, RejectsFewerThanTwoRows) {
  auto d = Parse("t,u,y\n0,1,2\n");
  ASSERT_TRUE(d);
  const Error e = BindError(*d, {"u"}, {"y"});
  EXPECT_EQ(e.line, 1);
  EXPECT_EQ(e.message, "the file has 1 data row; at least 2 are needed");
}

// ---------------------------------------------------------------------------------------------
// Building3: the data of the CTSM-R conformance case, as published (see tests/data/building3).

TEST(Building3, ReadsAndBindsTheCtsmrData) {
  auto r = ReadCsvFile(TestData("building3/data.csv"));
  ASSERT_TRUE(r.ok()) << r.error().ToString();
  const Dataset& d = **r;
  ASSERT_EQ(d.rows(), 6905u);
  EXPECT_EQ(d.time_name, "t");
  EXPECT_EQ(d.time.front(), 0.0);
  EXPECT_EQ(d.time.back(), 1726.0);
  EXPECT_EQ(d.row_line.back(), 6906);
  for (const Column& c : d.columns) {
    EXPECT_EQ(c.bad_line, 0) << c.name;
    EXPECT_EQ(c.n_missing, 0) << c.name;
  }

  const std::vector<std::string> inputs = {"Ta", "Ps", "Thm"};
  const std::vector<std::string> outputs = {"yTi"};
  auto s = Bind(d, inputs, outputs);
  ASSERT_TRUE(s.ok()) << s.error().ToString();
  ASSERT_EQ(s->get()->U.rows(), 3);
  ASSERT_EQ(s->get()->U.cols(), 6905);
  ASSERT_EQ(s->get()->Y.rows(), 1);
  // First and last rows of the file: 0,0,7.6,0,17.9054545454545 and 1726,0,3.2,0,14.7818181818182.
  EXPECT_EQ(s->get()->U(0, 0), 7.6);
  EXPECT_EQ(s->get()->U(1, 0), 0.0);
  EXPECT_EQ(s->get()->Y(0, 0), 17.9054545454545);
  EXPECT_EQ(s->get()->U(0, 6904), 3.2);
  EXPECT_EQ(s->get()->Y(0, 6904), 14.7818181818182);
  // Quarter-hourly throughout.
  EXPECT_EQ(s->get()->intervals.distinct, (std::vector<double>{0.25}));
}

}  // namespace
}  // namespace gb::data
