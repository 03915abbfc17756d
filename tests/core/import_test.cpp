// Tests of core/data/import.cpp and the CSV formats it reads with (csv.cpp's CsvFormat,
// SniffCsv, TimeUnitScale): each other form of a record reads to the same numbers as the plain
// CSV, the preparation steps against closed forms, and bad keys named by their JSON path.
//
// Contents
//   Helpers
//   Formats      headerless, sample time, separators, decimal commas, time units, range
//   Sniff        what SniffCsv tells from the text
//   Keys         ParseDatasetSpec / DatasetSpecToJson: round trip and errors
//   Map          expressions of columns
//   Detrend      mean and least-squares line
//   Resample     Decimate against sinusoids, gaps and the record's ends
//   Files        ReadDataset end to end, the bundled Bosch records
#include "core/data/import.h"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "core/data/mdf4.h"
#include "core/util/json.h"

namespace gb::data {
namespace {

// ---------------------------------------------------------------------------------------------
// Helpers

std::shared_ptr<const Dataset> Parse(std::string_view text, const CsvFormat& format) {
  Result<std::shared_ptr<const Dataset>> r = ParseCsv(text, "run.csv", format);
  EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.error().ToString());
  return r.ok() ? *r : nullptr;
}

std::string ParseError(std::string_view text, const CsvFormat& format) {
  Result<std::shared_ptr<const Dataset>> r = ParseCsv(text, "run.csv", format);
  EXPECT_FALSE(r.ok()) << "expected an error for:\n" << text;
  return r.ok() ? "" : r.error().ToString();
}

const std::vector<double>& Values(const Dataset& d, std::string_view name) {
  const int i = d.Find(name);
  EXPECT_GE(i, 0) << name;
  return d.columns.at(static_cast<std::size_t>(std::max(i, 0))).values;
}

// Two datasets hold the same numbers under the same names (bit for bit; NaN equal to NaN).
void ExpectSameData(const Dataset& a, const Dataset& b) {
  ASSERT_EQ(a.time, b.time);
  ASSERT_EQ(a.columns.size(), b.columns.size());
  for (const Column& c : a.columns) {
    const std::vector<double>& other = Values(b, c.name);
    ASSERT_EQ(c.values.size(), other.size()) << c.name;
    for (std::size_t k = 0; k < other.size(); ++k) {
      if (std::isnan(c.values[k]))
        EXPECT_TRUE(std::isnan(other[k])) << c.name << " row " << k;
      else
        EXPECT_EQ(c.values[k], other[k]) << c.name << " row " << k;
    }
  }
}

class TempDir {
 public:
  TempDir() {
    path_ =
        std::filesystem::temp_directory_path() /
        ("greybench_import_" + std::to_string(::testing::UnitTest::GetInstance()->random_seed()) +
         "_" + ::testing::UnitTest::GetInstance()->current_test_info()->name());
    std::filesystem::create_directories(path_);
  }
  ~TempDir() { std::filesystem::remove_all(path_); }
  std::string Write(const std::string& name, const std::string& text) const {
    const std::string p = (path_ / name).string();
    std::ofstream(p, std::ios::binary) << text;
    return p;
  }

 private:
  std::filesystem::path path_;
};

DatasetSpec SpecOf(const std::string& json) {
  Result<DatasetSpec> s = ParseDatasetSpec(Json::parse(json), "case.json", "datasets[0]");
  EXPECT_TRUE(s.ok()) << (s.ok() ? "" : s.error().ToString());
  return s.ok() ? *s : DatasetSpec{};
}

std::string SpecError(const std::string& json) {
  Result<DatasetSpec> s = ParseDatasetSpec(Json::parse(json), "case.json", "datasets[0]");
  EXPECT_FALSE(s.ok()) << json;
  return s.ok() ? "" : s.error().ToString();
}

constexpr std::string_view kPlain =
    "t,n,load,Tex\n"
    "0,1500.5,0.25,300\n"
    "0.1,1510,0.5,NA\n"
    "0.2,1520.25,0.75,310.5\n";

// ---------------------------------------------------------------------------------------------
// Formats

TEST(Formats, AHeaderlessFileWithASampleTimeReadsAsThePlainCsvWithItsColumnsNamed) {
  CsvFormat f;
  f.header = false;
  f.sample_time = 0.1;
  f.columns = {"n", "load", "Tex"};
  const auto headerless = Parse("1500.5,0.25,300\n1510,0.5,NA\n1520.25,0.75,310.5\n", f);
  // Row k is at k * 0.1, the product (0.2 is 2 * 0.1, not the decimal 0.2's double).
  CsvFormat plain;
  auto reference = Parse("t,n,load,Tex\n0,1500.5,0.25,300\n0.1,1510,0.5,NA\n" +
                             fmt::format("{:.17g},1520.25,0.75,310.5\n", 2 * 0.1),
                         plain);
  ASSERT_TRUE(headerless && reference);
  ExpectSameData(*headerless, *reference);
  EXPECT_EQ(headerless->header_line, 0);
  EXPECT_EQ(headerless->time_field, 0);
  EXPECT_EQ(headerless->row_line, (std::vector<int>{1, 2, 3}));
}

TEST(Formats, AHeaderlessFileWithoutNamesHasColumnsC1ToCn) {
  CsvFormat f;
  f.header = false;
  f.sample_time = 0.5;
  const auto d = Parse("# logger export\n1,2,3\n4,5,6\n", f);
  ASSERT_TRUE(d);
  ASSERT_EQ(d->columns.size(), 3u);
  EXPECT_EQ(d->columns[0].name, "c1");
  EXPECT_EQ(d->columns[2].name, "c3");
  EXPECT_EQ(d->time, (std::vector<double>{0, 0.5}));
  EXPECT_EQ(d->row_line, (std::vector<int>{2, 3}));
}

TEST(Formats, AHeaderlessFileCanNameItsTimeColumn) {
  CsvFormat f;
  f.header = false;
  f.columns = {"stamp_ms", "u"};
  f.time = "stamp_ms";
  const auto d = Parse("0,1\n250,2\n500,3\n", f);
  ASSERT_TRUE(d);
  EXPECT_EQ(d->time, (std::vector<double>{0, 0.25, 0.5}));
  EXPECT_EQ(d->time_scale, 1e-3);
  EXPECT_EQ(Values(*d, "u"), (std::vector<double>{1, 2, 3}));
}

TEST(Formats, AGermanBenchExportReadsAsThePlainCsv) {
  CsvFormat f;
  f.separator = ';';
  f.decimal = ',';
  const auto german = Parse(
      "Zeit [ms];n;load;Tex\n0;1500,5;0,25;300\n100;1510;0,5;NA\n200;1520,25;0,75;310,5\n", f);
  const auto plain = Parse(kPlain, CsvFormat{});
  ASSERT_TRUE(german && plain);
  ExpectSameData(*german, *plain);  // 100 ms / 1000 is the double of 0.1
  EXPECT_EQ(german->time_name, "Zeit [ms]");
}

TEST(Formats, TimeUnitsInTheHeaderAreConvertedToSeconds) {
  EXPECT_EQ(TimeUnitScale("t"), 1.0);
  EXPECT_EQ(TimeUnitScale("Time"), 1.0);
  EXPECT_EQ(TimeUnitScale("time [s]"), 1.0);
  EXPECT_EQ(TimeUnitScale("t_ms"), 1e-3);
  EXPECT_EQ(TimeUnitScale("Zeit (min)"), 60.0);
  EXPECT_EQ(TimeUnitScale("TIME[us]"), 1e-6);
  EXPECT_EQ(TimeUnitScale("t_h"), 3600.0);
  EXPECT_FALSE(TimeUnitScale("temperature"));
  EXPECT_FALSE(TimeUnitScale("tex_ms"));
  std::string unknown;
  EXPECT_FALSE(TimeUnitScale("time [deg]", &unknown));
  EXPECT_EQ(unknown, "deg");

  const auto minutes = Parse("x,time (min)\n1,0\n2,0.5\n", CsvFormat{});
  ASSERT_TRUE(minutes);
  EXPECT_EQ(minutes->time, (std::vector<double>{0, 30}));
  EXPECT_NE(ParseError("x,time [deg]\n1,0\n2,1\n", CsvFormat{})
                .find("run.csv:1:2: the time column 'time [deg]' has the unit 'deg', which is not "
                      "a unit of time"),
            std::string::npos);
}

TEST(Formats, TheContractsTimeNamesComeBeforeNamesWithAUnit) {
  // A file that read before reads the same: 't' is the time, 't_ms' a column.
  const auto d = Parse("t_ms,t,u\n5,0,1\n6,1,2\n", CsvFormat{});
  ASSERT_TRUE(d);
  EXPECT_EQ(d->time_name, "t");
  EXPECT_EQ(Values(*d, "t_ms"), (std::vector<double>{5, 6}));
}

TEST(Formats, ADecimalCommaRefusesAPointAndACommaSeparator) {
  CsvFormat f;
  f.separator = ';';
  f.decimal = ',';
  const auto d = Parse("t;u\n0;1,5\n1;2.5\n", f);
  ASSERT_TRUE(d);
  EXPECT_EQ(d->columns[0].bad_line, 3);
  EXPECT_EQ(NotANumberReason(d->columns[0].bad_text, ','),
            "'2.5' is not a number (the decimal mark must be ',')");
  f.separator = ',';
  EXPECT_NE(ParseError("t,u\n0,1\n", f).find("a decimal comma needs another separator than ','"),
            std::string::npos);
}

TEST(Formats, NamesThatDoNotMatchTheFieldsAreAnErrorAtTheLine) {
  CsvFormat f;
  f.header = false;
  f.sample_time = 1;
  f.columns = {"a", "b"};
  EXPECT_EQ(ParseError("# x\n1,2,3\n", f),
            "run.csv:2: 2 column names are given, but line 2 has 3 fields");
  f.columns = {"a", "b", "c"};
  EXPECT_EQ(ParseError("1,2,3\n4,5\n", f), "run.csv:2:3: line 2 has 2 fields, the first row has 3");
  CsvFormat named;
  named.time = "clock";
  EXPECT_NE(ParseError("t,u\n0,1\n", named).find("no column named 'clock'"), std::string::npos);
}

TEST(Formats, ARangeKeepsItsRowsAndStillChecksTheOthers) {
  CsvFormat f;
  f.range = std::array<double, 2>{0.1, 0.2};
  const auto d = Parse(kPlain, f);
  ASSERT_TRUE(d);
  EXPECT_EQ(d->time, (std::vector<double>{0.1, 0.2}));
  EXPECT_EQ(d->row_line, (std::vector<int>{3, 4}));
  EXPECT_EQ(Values(*d, "load"), (std::vector<double>{0.5, 0.75}));
  // Missing cells are counted over the rows kept.
  EXPECT_EQ(d->columns[2].n_missing, 1);
  EXPECT_EQ(d->columns[2].first_missing_line, 3);
  // A row outside the range is still checked: the time must increase.
  EXPECT_NE(ParseError("t,u\n0,1\n5,2\n4,3\n", f).find("run.csv:4:1: time 4 does not increase"),
            std::string::npos);
  // The reader keeps what the range holds; a dataset entry needs 2 rows, said at its key.
  f.range = std::array<double, 2>{0.15, 0.2};
  const auto one = Parse(kPlain, f);
  ASSERT_TRUE(one);
  EXPECT_EQ(one->rows(), 1u);
  TempDir dir;
  DatasetSpec spec = SpecOf(R"({"file": "run.csv", "range": [0.15, 0.2]})");
  spec.file = dir.Write("run.csv", std::string(kPlain));
  Result<std::shared_ptr<const Dataset>> read = ReadDataset(spec);
  ASSERT_FALSE(read.ok());
  EXPECT_NE(read.error().ToString().find(
                "case.json: datasets[0].range: [0.15, 0.2] holds 1 row of the record"),
            std::string::npos)
      << read.error().ToString();
}

// ---------------------------------------------------------------------------------------------
// Sniff

TEST(Sniff, TellsTheSeparatorTheDecimalMarkAndTheHeaderFromTheText) {
  CsvFormat german = SniffCsv("Zeit [ms];n\n0;1500,5\n100;1510,25\n");
  EXPECT_EQ(german.separator, ';');
  EXPECT_EQ(german.decimal, ',');
  EXPECT_TRUE(german.header);

  CsvFormat plain = SniffCsv(kPlain);
  EXPECT_EQ(plain.separator, ',');
  EXPECT_EQ(plain.decimal, '.');
  EXPECT_TRUE(plain.header);

  CsvFormat headerless = SniffCsv("1.56e+00,1.3e-01,-1.1e-01\n1.59e+00,1.4e-01,-1.7e-01\n");
  EXPECT_EQ(headerless.separator, ',');
  EXPECT_FALSE(headerless.header);

  // Integers on both sides of a comma are no evidence of a decimal comma with ',' separators.
  CsvFormat integers = SniffCsv("1,2\n3,4\n");
  EXPECT_EQ(integers.separator, ',');
  EXPECT_EQ(integers.decimal, '.');
  EXPECT_FALSE(integers.header);

  CsvFormat tabs = SniffCsv("t\tu\n0\t1.5\n");
  EXPECT_EQ(tabs.separator, '\t');
  EXPECT_EQ(tabs.decimal, '.');

  // A headerless German file: ';' splits every line the same way, so the commas are decimal.
  CsvFormat german_data = SniffCsv("0;1,5\n1;2,5\n");
  EXPECT_EQ(german_data.separator, ';');
  EXPECT_EQ(german_data.decimal, ',');
  EXPECT_FALSE(german_data.header);
}

// ---------------------------------------------------------------------------------------------
// Keys

TEST(Keys, EveryKeyRoundTripsThroughJson) {
  const std::string json = R"({"file": "run1.csv", "name": "run 1", "header": false,
      "separator": ";", "decimal": ",", "columns": ["n", "load", "Tex"], "sample_time": 0.1,
      "map": {"y": "Tex - 300", "u": "load"}, "range": [10, 600],
      "detrend": {"n": "mean", "u": "linear"}, "resample": 0.5, "role": "validation"})";
  const DatasetSpec s = SpecOf(json);
  EXPECT_FALSE(s.plain);
  EXPECT_EQ(s.header, false);
  EXPECT_EQ(s.separator, ';');
  EXPECT_EQ(s.decimal, ',');
  EXPECT_EQ(s.map.size(), 2u);
  EXPECT_EQ(s.map[0].first, "y");
  EXPECT_EQ(s.role, Role::kValidation);
  EXPECT_EQ(s.DisplayName(), "run 1");
  const Json back = DatasetSpecToJson(s, "run1.csv");
  EXPECT_EQ(back, Json::parse(json));
  // A plain file name stays one; the one-word detrend stays one word.
  EXPECT_EQ(DatasetSpecToJson(SpecOf(R"("data/f1.csv")"), "data/f1.csv"), Json("data/f1.csv"));
  EXPECT_EQ(DatasetSpecToJson(SpecOf(R"({"file": "a.csv", "detrend": "mean"})"), "a.csv"),
            Json::parse(R"({"file": "a.csv", "detrend": "mean"})"));
  EXPECT_EQ(SpecOf(R"("data/f1.csv")").DisplayName(), "f1.csv");
}

TEST(Keys, BadKeysAreNamedByTheProjectFileAndTheirJsonPath) {
  const std::vector<std::pair<std::string, std::string>> cases = {
      {R"(3)", "case.json: datasets[0]: expected a file name (a string) or an object"},
      {R"("")", "case.json: datasets[0]: expected a file name, not \"\""},
      {R"({"role": "validation"})", "case.json: datasets[0]: the dataset names no file"},
      {R"({"file": 1})", "case.json: datasets[0].file: expected a file name"},
      {R"({"file": "a", "header": "no"})", "case.json: datasets[0].header: expected true or false"},
      {R"({"file": "a", "separator": "|"})", "case.json: datasets[0].separator: expected"},
      {R"({"file": "a", "decimal": ";"})",
       "case.json: datasets[0].decimal: expected \".\" or \",\""},
      {R"({"file": "a", "decimal": ",", "separator": ","})",
       "case.json: datasets[0].decimal: a decimal comma needs another separator"},
      {R"({"file": "a", "columns": []})", "case.json: datasets[0].columns: expected a list"},
      {R"({"file": "a", "columns": ["x", "x"]})",
       "case.json: datasets[0].columns[1]: 'x' is named twice"},
      {R"({"file": "a", "columns": ["x", 2]})",
       "case.json: datasets[0].columns[1]: expected a column name"},
      {R"({"file": "a", "time": ""})", "case.json: datasets[0].time: expected the name"},
      {R"({"file": "a", "sample_time": 0})",
       "case.json: datasets[0].sample_time: expected a number of seconds greater than 0"},
      {R"({"file": "a", "sample_time": 0.1, "time": "t"})",
       "case.json: datasets[0].sample_time: give either \"time\""},
      {R"({"file": "a", "header": false, "time": "t"})",
       "case.json: datasets[0].time: a file without a header names its columns"},
      {R"({"file": "a", "map": []})", "case.json: datasets[0].map: expected an object"},
      {R"({"file": "a", "map": {"y": 2}})", "case.json: datasets[0].map.y: expected an expression"},
      {R"({"file": "a", "range": [5, 1]})", "case.json: datasets[0].range: expected t0 < t1"},
      {R"({"file": "a", "range": [0]})", "case.json: datasets[0].range: expected [t0, t1]"},
      {R"({"file": "a", "detrend": "quadratic"})",
       "case.json: datasets[0].detrend: expected \"mean\""},
      {R"({"file": "a", "detrend": {"u": 1}})",
       "case.json: datasets[0].detrend.u: expected \"mean\""},
      {R"({"file": "a", "resample": -1})", "case.json: datasets[0].resample: expected a number"},
      {R"({"file": "a", "role": "test"})", "case.json: datasets[0].role: expected \"estimation\""},
      {R"({"file": "a", "colour": "red"})", "case.json: datasets[0].colour: unknown key"},
  };
  for (const auto& [json, message] : cases) {
    const std::string e = SpecError(json);
    EXPECT_EQ(e.substr(0, message.size()), message) << json << "\n" << e;
  }
}

// ---------------------------------------------------------------------------------------------
// Map

TEST(Map, AddsColumnsOfExpressionsAndReplacesOneOfTheSameName) {
  const auto plain = Parse("t,Lambda,Tex\n0,0.8,300\n1,NA,301\n2,1.25,302\n", CsvFormat{});
  ASSERT_TRUE(plain);
  DatasetSpec spec =
      SpecOf(R"({"file": "run.csv", "map": {"ilambda": "1/Lambda", "Tex": "Tex - 273.15"}})");
  Result<std::shared_ptr<const Dataset>> d = Prepare(plain, spec);
  ASSERT_TRUE(d.ok()) << d.error().ToString();
  const std::vector<double>& il = Values(**d, "ilambda");
  EXPECT_EQ(il[0], 1 / 0.8);
  EXPECT_TRUE(std::isnan(il[1]));  // a missing cell stays missing
  EXPECT_EQ(il[2], 1 / 1.25);
  EXPECT_EQ((*d)->columns[static_cast<std::size_t>((*d)->Find("ilambda"))].n_missing, 1);
  EXPECT_EQ(Values(**d, "Tex"), (std::vector<double>{300 - 273.15, 301 - 273.15, 302 - 273.15}));
  EXPECT_EQ((*d)->Find("Tex") >= 0, true);  // replaced, not duplicated
}

TEST(Map, AColumnNameThatIsNoIdentifierIsMappedWhole) {
  const auto plain = Parse("t,T exh [degC]\n0,300\n1,301\n", CsvFormat{});
  ASSERT_TRUE(plain);
  Result<std::shared_ptr<const Dataset>> d =
      Prepare(plain, SpecOf(R"({"file": "run.csv", "map": {"Tex": "T exh [degC]"}})"));
  ASSERT_TRUE(d.ok()) << d.error().ToString();
  EXPECT_EQ(Values(**d, "Tex"), (std::vector<double>{300, 301}));
}

TEST(Map, ErrorsNameTheKeyAndTheColumnInTheExpression) {
  const auto plain = Parse("t,Lambda\n0,0.8\n1,0\n", CsvFormat{});
  ASSERT_TRUE(plain);
  const auto error = [&](const std::string& json) {
    Result<std::shared_ptr<const Dataset>> d = Prepare(plain, SpecOf(json));
    EXPECT_FALSE(d.ok()) << json;
    return d.ok() ? "" : d.error().ToString();
  };
  EXPECT_EQ(error(R"({"file": "run.csv", "map": {"ilambda": "1/Lamda"}})"),
            "case.json: datasets[0].map.ilambda, column 3: column 'Lamda' is not in the file; its "
            "columns are Lambda");
  EXPECT_EQ(error(R"({"file": "run.csv", "map": {"ilambda": "1/(Lambda"}})"),
            "case.json: datasets[0].map.ilambda, column 10: expected ')' to close '(' at column 3");
  // 1/0 is not a number at its line: Bind says so when the column is bound.
  Result<std::shared_ptr<const Dataset>> d =
      Prepare(plain, SpecOf(R"({"file": "run.csv", "map": {"ilambda": "1/Lambda"}})"));
  ASSERT_TRUE(d.ok());
  const std::vector<std::string> inputs, outputs = {"ilambda"};
  Result<std::shared_ptr<const Series>> s = Bind(**d, inputs, outputs);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().ToString(),
            "run.csv:3: in column 'ilambda' (an output of the model), '1/Lambda = inf' is not a "
            "number");
}

// ---------------------------------------------------------------------------------------------
// Detrend

TEST(Detrend, SubtractsTheMeanOrTheLeastSquaresLineOverThePresentCells) {
  const auto plain = Parse("t,a,b,c\n0,1,2,5\n1,2,5,NA\n2,4,8,7\n3,5,11,6\n", CsvFormat{});
  ASSERT_TRUE(plain);
  Result<std::shared_ptr<const Dataset>> d = Prepare(
      plain,
      SpecOf(R"({"file": "run.csv", "detrend": {"a": "mean", "b": "linear", "c": "mean"}})"));
  ASSERT_TRUE(d.ok()) << d.error().ToString();
  EXPECT_EQ(Values(**d, "a"), (std::vector<double>{-2, -1, 1, 2}));
  for (double v : Values(**d, "b")) EXPECT_NEAR(v, 0, 1e-14);  // b = 2 + 3 t exactly
  const std::vector<double>& c = Values(**d, "c");
  EXPECT_EQ(c[0], -1);
  EXPECT_TRUE(std::isnan(c[1]));
  EXPECT_EQ(c[2], 1);
  EXPECT_EQ(c[3], 0);
  EXPECT_EQ(
      Prepare(plain, SpecOf(R"({"file": "run.csv", "detrend": {"x": "mean"}})")).error().ToString(),
      "case.json: datasets[0].detrend.x: column 'x' is not in the file; its columns are "
      "a, b, c");
}

// ---------------------------------------------------------------------------------------------
// Resample

std::vector<double> Grid(double dt, int n) {
  std::vector<double> t(static_cast<std::size_t>(n));
  for (int k = 0; k < n; ++k) t[static_cast<std::size_t>(k)] = k * dt;
  return t;
}

// The decimated sinusoid of frequency f (Hz), without 20 samples at either end.
std::pair<std::vector<double>, std::vector<double>> DecimatedSine(double f, double old_dt,
                                                                  double new_dt) {
  const std::vector<double> t = Grid(old_dt, 20000);
  std::vector<double> x(t.size());
  for (std::size_t k = 0; k < t.size(); ++k) x[k] = std::sin(2 * std::numbers::pi * f * t[k]);
  const std::vector<double> y = Decimate(t, x, new_dt);
  std::vector<double> time, values;
  for (std::size_t k = 20; k + 20 < y.size(); ++k) {
    time.push_back(static_cast<double>(k) * new_dt);
    values.push_back(y[k]);
  }
  return {time, values};
}

// Its amplitude at f, by least squares on sin and cos (the samples need not hit the peaks).
double PassedAmplitude(double f, double old_dt, double new_dt) {
  const auto [t, y] = DecimatedSine(f, old_dt, new_dt);
  double ss = 0, sc = 0, cc = 0, ys = 0, yc = 0;
  for (std::size_t k = 0; k < t.size(); ++k) {
    const double s = std::sin(2 * std::numbers::pi * f * t[k]);
    const double c = std::cos(2 * std::numbers::pi * f * t[k]);
    ss += s * s;
    sc += s * c;
    cc += c * c;
    ys += y[k] * s;
    yc += y[k] * c;
  }
  const double det = ss * cc - sc * sc;
  const double a = (ys * cc - yc * sc) / det, b = (yc * ss - ys * sc) / det;
  return std::hypot(a, b);
}

// The largest value left: whatever frequency an aliased sinusoid appears at, it is no larger.
double LargestValue(double f, double old_dt, double new_dt) {
  double largest = 0;
  for (double v : DecimatedSine(f, old_dt, new_dt).second) largest = std::max(largest, std::abs(v));
  return largest;
}

TEST(Resample, KeepsWhatTheNewRateCanCarryAndRemovesWhatWouldAlias) {
  // 100 Hz to 10 Hz: the new Nyquist frequency is 5 Hz.
  EXPECT_NEAR(PassedAmplitude(0.5, 0.01, 0.1), 1, 0.002);
  EXPECT_NEAR(PassedAmplitude(2.0, 0.01, 0.1), 1, 0.01);
  EXPECT_LT(LargestValue(7.0, 0.01, 0.1), 0.005);  // would alias to 3 Hz
  EXPECT_LT(LargestValue(13.0, 0.01, 0.1), 0.005);
  // A ratio that is not a whole number: 100 Hz to 30 Hz (new Nyquist 15 Hz).
  EXPECT_NEAR(PassedAmplitude(3.0, 0.01, 1.0 / 30), 1, 0.01);
  EXPECT_LT(LargestValue(20.0, 0.01, 1.0 / 30), 0.005);
}

TEST(Resample, AConstantStaysExactToTheEndsAndAGapBecomesMissing) {
  const std::vector<double> t = Grid(0.01, 1001);
  std::vector<double> x(t.size(), 3.25);
  std::vector<double> y = Decimate(t, x, 0.1);
  ASSERT_EQ(y.size(), 101u);
  for (double v : y) EXPECT_NEAR(v, 3.25, 1e-14);
  // A gap of 1 s (10 new samples) in the middle: the new samples inside it are missing; one
  // missing old cell leaves every new sample.
  for (std::size_t k = 400; k < 500; ++k) x[k] = std::nan("");
  x[100] = std::nan("");
  y = Decimate(t, x, 0.1);
  int missing = 0;
  for (std::size_t k = 0; k < y.size(); ++k) {
    if (std::isnan(y[k])) {
      ++missing;
      EXPECT_GE(k, 40u);
      EXPECT_LE(k, 50u);
    } else {
      EXPECT_NEAR(y[k], 3.25, 1e-14);
    }
  }
  EXPECT_GE(missing, 8);
}

TEST(Resample, ThroughTheKeysKeepsTheTimeGridAndRefusesWhatItCannotDo) {
  std::string text = "t,u\n";
  for (int k = 0; k <= 100; ++k) text += fmt::format("{:.17g},{}\n", k * 0.01, k % 7);
  const auto plain = Parse(text, CsvFormat{});
  ASSERT_TRUE(plain);
  Result<std::shared_ptr<const Dataset>> d =
      Prepare(plain, SpecOf(R"({"file": "run.csv", "resample": 0.1})"));
  ASSERT_TRUE(d.ok()) << d.error().ToString();
  ASSERT_EQ((*d)->rows(), 11u);
  for (std::size_t k = 0; k < 11; ++k) EXPECT_EQ((*d)->time[k], static_cast<double>(k) * 0.1);
  EXPECT_EQ((*d)->row_line[3], 32);  // the line of the nearest old row (t = 0.3), for messages
  EXPECT_NE(Prepare(plain, SpecOf(R"({"file": "run.csv", "resample": 0.001})"))
                .error()
                .ToString()
                .find("datasets[0].resample: 0.001 s is shorter than the record's sample time"),
            std::string::npos);
  const auto irregular = Parse("t,u\n0,1\n0.1,2\n0.3,3\n0.4,4\n", CsvFormat{});
  EXPECT_NE(Prepare(irregular, SpecOf(R"({"file": "run.csv", "resample": 0.2})"))
                .error()
                .ToString()
                .find("the record is not regularly sampled (its intervals run from 0.1 to 0.2 s)"),
            std::string::npos);
}

// ---------------------------------------------------------------------------------------------
// Files

TEST(Files, APlainSpecReadsAsReadCsvFileAndAnObjectDetectsItsFormat) {
  TempDir dir;
  const std::string plain = dir.Write("plain.csv", std::string(kPlain));
  const std::string german = dir.Write(
      "german.csv",
      "Zeit [ms];n;load;Tex\n0;1500,5;0,25;300\n100;1510;0,5;NA\n200;1520,25;0,75;310,5\n");
  DatasetSpec p;
  p.file = plain;
  Result<std::shared_ptr<const Dataset>> a = ReadDataset(p);
  ASSERT_TRUE(a.ok()) << a.error().ToString();
  DatasetSpec g = SpecOf(R"({"file": "german.csv"})");
  g.file = german;
  Result<std::shared_ptr<const Dataset>> b = ReadDataset(g);
  ASSERT_TRUE(b.ok()) << b.error().ToString();
  ExpectSameData(**a, **b);
  // Read as a plain file name, the same export keeps its decimal commas as cells that are not
  // numbers (refused when bound, with their line).
  p.file = german;
  Result<std::shared_ptr<const Dataset>> c = ReadDataset(p);
  ASSERT_TRUE(c.ok()) << c.error().ToString();
  EXPECT_EQ((*c)->columns[0].bad_line, 2);
  EXPECT_EQ((*c)->columns[0].bad_text, "1500,5");
}

// The bundled Bosch records (docs/examples/bosch-exhaust/data): 13 standardised columns, no
// header, no time, 10 Hz.
TEST(Files, TheBoschRecordsReadByTheirKeysAlone) {
  const std::string file = std::string(GREYBENCH_SOURCE_DIR) +
                           "/docs/examples/bosch-exhaust/data/raw_000012_measurement_000000.csv";
  DatasetSpec s = SpecOf(R"({"file": "x", "sample_time": 0.1,
      "columns": ["n", "load", "lambda", "ign", "cutoff", "PN", "CO", "CO2", "HC", "NOx", "O2",
                  "Tex", "Tcat"]})");
  s.file = file;
  Result<std::shared_ptr<const Dataset>> d = ReadDataset(s);
  ASSERT_TRUE(d.ok()) << d.error().ToString();
  EXPECT_EQ((*d)->rows(), 14052u);
  EXPECT_EQ((*d)->columns.size(), 13u);
  EXPECT_EQ((*d)->time[10], 10 * 0.1);
  EXPECT_EQ(Values(**d, "n")[0], 1.56428813);
  EXPECT_EQ(Values(**d, "Tcat")[0], 1.43876136);
}

// An ASAM MDF 4 recording (tests/data/mdf4/two_rates.mf4: group "fast", 50 records at 100 Hz
// with speed and temp; group "slow", 5 at 10 Hz with pressure) read through a project's keys:
// `columns` picks the channels, `time` the time base, `interpolation` the way onto it; the same
// numbers as mdf4.h reads directly, and the preparation keys apply as to a CSV.
const std::string kTwoRates = std::string(GREYBENCH_SOURCE_DIR) + "/tests/data/mdf4/two_rates.mf4";

TEST(Files, AnMdfRecordingReadsByItsKeysAsTheMdfReaderReadsIt) {
  EXPECT_TRUE(IsMdfFile(kTwoRates));
  EXPECT_FALSE(IsMdfFile(std::string(GREYBENCH_SOURCE_DIR) + "/assets/data/fuel_f1.csv"));
  DatasetSpec s = SpecOf(R"({"file": "x", "columns": ["speed", "pressure"], "time": "slow"})");
  s.file = kTwoRates;
  Result<std::shared_ptr<const Dataset>> d = ReadDataset(s);
  ASSERT_TRUE(d.ok()) << d.error().ToString();
  Result<Mdf4File> file = ReadMdf4File(kTwoRates);
  ASSERT_TRUE(file.ok());
  Mdf4Format format;
  format.channels = {"speed", "pressure"};
  format.time_base = "slow";
  Result<std::shared_ptr<const Dataset>> direct = Mdf4ToDataset(*file, kTwoRates, format);
  ASSERT_TRUE(direct.ok());
  ExpectSameData(**d, **direct);
  EXPECT_EQ((*d)->rows(), 5u);
  // speed on the 10 Hz rows, held: its sample at t = k/10 (record 10 k), -10 + 0.5 (1237 · 10 k).
  EXPECT_EQ(Values(**d, "speed")[2], -10 + 0.5 * (1237 * 20));
  // Linear on the 100 Hz rows: pressure between its 10 Hz samples (1000 + 1.5 k at t = k/10).
  s = SpecOf(R"({"file": "x", "columns": ["speed", "pressure"], "time": "fast",
                 "interpolation": "linear", "range": [0.1, 0.3], "map": {"p_bar": "pressure/1000"}})");
  s.file = kTwoRates;
  d = ReadDataset(s);
  ASSERT_TRUE(d.ok()) << d.error().ToString();
  ASSERT_EQ((*d)->rows(), 21u);
  EXPECT_NEAR((*d)->time[5], 0.15, 1e-12);
  EXPECT_NEAR(Values(**d, "pressure")[5], 1000 + 1.5 * 1.5, 1e-9);
  EXPECT_NEAR(Values(**d, "p_bar")[5], 1.00225, 1e-12);
  // The keys round-trip.
  auto back = ParseDatasetSpec(DatasetSpecToJson(s, "run.mf4"), "p.json", "datasets[0]");
  ASSERT_TRUE(back.ok()) << back.error().ToString();
  EXPECT_EQ(back->interpolation, "linear");
}

TEST(Files, KeysOfTheOtherFormatAreRefusedNamingTheKey) {
  DatasetSpec s = SpecOf(R"({"file": "x", "decimal": ","})");
  s.file = kTwoRates;
  Result<std::shared_ptr<const Dataset>> d = ReadDataset(s);
  ASSERT_FALSE(d.ok());
  EXPECT_EQ(d.error().path, "datasets[0].decimal");
  EXPECT_NE(d.error().message.find("is an ASAM MDF file"), std::string::npos) << d.error().message;
  s = SpecOf(R"({"file": "x", "interpolation": "linear"})");
  s.file = std::string(GREYBENCH_SOURCE_DIR) + "/assets/data/fuel_f1.csv";
  d = ReadDataset(s);
  ASSERT_FALSE(d.ok());
  EXPECT_EQ(d.error().path, "datasets[0].interpolation");
  // A channel the file lacks: the file and its channels.
  s = SpecOf(R"({"file": "x", "columns": ["speeed"]})");
  s.file = kTwoRates;
  d = ReadDataset(s);
  ASSERT_FALSE(d.ok());
  EXPECT_NE(d.error().ToString().find("two_rates.mf4"), std::string::npos) << d.error().ToString();
  EXPECT_NE(d.error().message.find("speed"), std::string::npos) << d.error().message;
  EXPECT_EQ(SpecError(R"({"file": "x", "interpolation": "cubic"})"),
            "case.json: datasets[0].interpolation: expected \"hold\" or \"linear\"");
}

}  // namespace
}  // namespace gb::data
